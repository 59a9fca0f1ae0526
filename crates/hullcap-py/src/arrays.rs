//! Array conversion and validation at the boundary: anything array-like in, a contiguous
//! float64 view out (copied once only when the input is not already one), with errors that
//! name the argument.

use crate::call::ArrayError;
use numpy::{PyArray1, PyReadonlyArrayDyn};
use pyo3::prelude::*;

/// A validated float64 array whose rows have `W` values, borrowed from Python for as long
/// as it lives.
pub(crate) struct Rows<'py, const W: usize>(PyReadonlyArrayDyn<'py, f64>);

/// An (N, 3) float64 array.
pub(crate) type Rows3<'py> = Rows<'py, 3>;

impl<const W: usize> Rows<'_, W> {
    /// The rows, `W` values each.
    pub(crate) fn rows(&self) -> &[[f64; W]] {
        // `float_rows` made the array C-contiguous with rows of W values, so both hold.
        let flat = self.0.as_slice().unwrap_or(&[]);
        flat.as_chunks::<W>().0
    }
}

/// `obj` as a C-contiguous array of dtype `dtype` ("float64" or "int64") and shape
/// (N, *tail): real numbers only (integers only for "int64"); anything else is a
/// `ValueError` naming `name`.
fn contiguous<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    tail: &[usize],
    dtype: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    let arr = np
        .call_method1("asarray", (obj,))
        .map_err(|e| ArrayError::new_err(format!("{name} is not an array: {e}")))?;
    let kind_of = arr.getattr("dtype")?;
    let kind: String = kind_of.getattr("kind")?.extract()?;
    let allowed: &[&str] = if dtype == "int64" {
        &["i", "u"]
    } else {
        &["f", "i", "u"]
    };
    if !allowed.contains(&kind.as_str()) {
        let what = if dtype == "int64" {
            "integers"
        } else {
            "real numbers"
        };
        return Err(ArrayError::new_err(format!(
            "{name} must hold {what}, got dtype {}",
            kind_of.str()?
        )));
    }
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if shape.len() != tail.len() + 1 || shape[1..] != *tail {
        let want: Vec<String> = std::iter::once("N".to_owned())
            .chain(tail.iter().map(|t| t.to_string()))
            .collect();
        return Err(ArrayError::new_err(format!(
            "{name} must have shape ({}), got {shape:?}",
            want.join(", ")
        )));
    }
    np.call_method1("ascontiguousarray", (arr, dtype))
}

/// `obj` as float64 rows of `W` values, shaped (N, *tail) with the product of `tail` = W.
pub(crate) fn float_rows<'py, const W: usize>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    tail: &[usize],
) -> PyResult<Rows<'py, W>> {
    debug_assert_eq!(tail.iter().product::<usize>(), W);
    Ok(Rows(contiguous(obj, name, tail, "float64")?.extract()?))
}

/// `obj` as the one small array an argument is (a 3-vector, a 3×3 matrix: `what` says
/// which), its `W` values row-major; anything NumPy cannot read as `W` real numbers is a
/// `ValueError` naming `name`.
pub(crate) fn one_array<const W: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    what: &str,
) -> PyResult<[f64; W]> {
    let np = obj.py().import("numpy")?;
    let wrong = || ArrayError::new_err(format!("{name} must be {what}"));
    let arr = np.call_method1("asarray", (obj,)).map_err(|_| wrong())?;
    if arr.getattr("size")?.extract::<usize>()? != W {
        return Err(wrong());
    }
    let one = arr.call_method1("reshape", ((1usize, W),))?;
    Ok(float_rows::<W>(&one, name, &[W])?.rows()[0])
}

/// `obj` as an (N, 3) float64 C-contiguous array.
pub(crate) fn rows3<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Rows3<'py>> {
    float_rows(obj, name, &[3])
}

/// `obj` as (N, `width`) indices, each in `0..bound`, flattened row-major as u32.
pub(crate) fn flat_indices(
    obj: &Bound<'_, PyAny>,
    name: &str,
    width: usize,
    bound: usize,
) -> PyResult<Vec<u32>> {
    let arr: PyReadonlyArrayDyn<'_, i64> = contiguous(obj, name, &[width], "int64")?.extract()?;
    let flat = arr.as_slice().unwrap_or(&[]);
    if let Some(at) = flat.iter().position(|&i| i < 0 || i as usize >= bound) {
        return Err(ArrayError::new_err(format!(
            "{name}[{}] holds {}, outside 0..{bound}",
            at / width.max(1),
            flat[at]
        )));
    }
    Ok(flat.iter().map(|&i| i as u32).collect())
}

/// `obj` as (N, W) indices, each in `0..bound`, as u32 rows.
pub(crate) fn index_rows<const W: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    bound: usize,
) -> PyResult<Vec<[u32; W]>> {
    Ok(flat_indices(obj, name, W, bound)?
        .as_chunks::<W>()
        .0
        .to_vec())
}

/// `obj` as float64 values of shape (N, *tail), flattened row-major (a copy).
pub(crate) fn flat_floats(
    obj: &Bound<'_, PyAny>,
    name: &str,
    tail: &[usize],
) -> PyResult<Vec<f64>> {
    let arr: PyReadonlyArrayDyn<'_, f64> = contiguous(obj, name, tail, "float64")?.extract()?;
    Ok(arr.as_slice().unwrap_or(&[]).to_vec())
}

/// A count argument from Python (`k`, `leaf_size`, `threads`) checked to be ≥ `min`.
pub(crate) fn count(value: i64, name: &str, min: i64) -> PyResult<usize> {
    if value < min {
        return Err(ArrayError::new_err(format!(
            "{name} must be at least {min}, got {value}"
        )));
    }
    usize::try_from(value).map_err(|_| ArrayError::new_err(format!("{name} is too large: {value}")))
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
