//! Array conversion and validation at the boundary: anything array-like in, a contiguous
//! float64 view out (copied once only when the input is not already one), with errors that
//! name the argument.

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A validated (N, 3) float64 array, borrowed from Python for as long as it lives.
pub(crate) struct Rows3<'py>(PyReadonlyArray2<'py, f64>);

impl Rows3<'_> {
    /// The rows as `[x, y, z]` triples.
    pub(crate) fn rows(&self) -> &[[f64; 3]] {
        // `rows3` made the array C-contiguous with 3 columns, so both steps hold.
        let flat = self.0.as_slice().unwrap_or(&[]);
        flat.as_chunks::<3>().0
    }
}

/// `obj` as an (N, 3) float64 C-contiguous array: any real numeric dtype is converted,
/// anything else is a `ValueError` naming `name`.
pub(crate) fn rows3<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Rows3<'py>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("asarray", (obj,))
        .map_err(|e| PyValueError::new_err(format!("{name} is not an array: {e}")))?;
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(PyValueError::new_err(format!(
            "{name} must hold real numbers, got dtype {}",
            dtype.str()?
        )));
    }
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (N, 3), got {shape:?}"
        )));
    }
    let contiguous = np.call_method1("ascontiguousarray", (arr, "float64"))?;
    let readonly: PyReadonlyArray2<'py, f64> = contiguous.extract()?;
    debug_assert!(readonly.is_c_contiguous());
    Ok(Rows3(readonly))
}

/// A count argument from Python (`k`, `leaf_size`, `threads`) checked to be ≥ `min`.
pub(crate) fn count(value: i64, name: &str, min: i64) -> PyResult<usize> {
    if value < min {
        return Err(PyValueError::new_err(format!(
            "{name} must be at least {min}, got {value}"
        )));
    }
    usize::try_from(value)
        .map_err(|_| PyValueError::new_err(format!("{name} is too large: {value}")))
}

/// `threads=None` → all cores; otherwise at least 1.
pub(crate) fn threads(value: Option<i64>) -> PyResult<Option<usize>> {
    value.map(|t| count(t, "threads", 1)).transpose()
}

/// A new 1-D NumPy array owning `values`.
pub(crate) fn vec1<'py, T: numpy::Element>(
    py: Python<'py>,
    values: Vec<T>,
) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, values)
}
