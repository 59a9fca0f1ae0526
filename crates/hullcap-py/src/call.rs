//! The one way every heavy engine call is made from Python: GIL released, panics caught,
//! errors mapped to Python exceptions.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// An engine error and the Python exception class it becomes.
pub(crate) trait IntoPyErr {
    fn into_py_err(self) -> PyErr;
}

impl IntoPyErr for hullcap_kdtree::KdTreeError {
    fn into_py_err(self) -> PyErr {
        match self {
            hullcap_kdtree::KdTreeError::Worker(e) => PyRuntimeError::new_err(e.to_string()),
            other => PyValueError::new_err(other.to_string()),
        }
    }
}

impl IntoPyErr for hullcap_body::BodyError {
    fn into_py_err(self) -> PyErr {
        match self {
            hullcap_body::BodyError::Worker(e) => PyRuntimeError::new_err(e.to_string()),
            other => PyValueError::new_err(other.to_string()),
        }
    }
}

/// Runs `f` without the GIL; its error becomes the matching Python exception, and a panic
/// (an engine bug) becomes `RuntimeError` instead of crossing into Python.
pub(crate) fn detached<T, E, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    F: FnOnce() -> Result<T, E> + Send,
    T: Send,
    E: IntoPyErr + Send,
{
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(e)) => Err(e.into_py_err()),
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".to_owned());
            Err(PyRuntimeError::new_err(format!(
                "internal error in the hullcap engine: {what}"
            )))
        }
    }
}
