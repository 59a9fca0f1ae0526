//! The one way every heavy engine call is made from Python: GIL released, panics caught,
//! errors mapped to the exceptions of `hullcap.errors`.

use hullcap_body::BodyError;
use hullcap_icp::IcpError;
use hullcap_kdtree::KdTreeError;
use hullcap_raster::RasterError as EngineRasterError;
use pyo3::prelude::*;
use std::panic::{AssertUnwindSafe, catch_unwind};

// The exception family lives in Python (`hullcap.errors`); these are its Rust handles.
pyo3::import_exception!(hullcap.errors, ModelError);
pyo3::import_exception!(hullcap.errors, FitError);
pyo3::import_exception!(hullcap.errors, EngineError);
pyo3::import_exception!(hullcap.errors, OptionsError);
pyo3::import_exception!(hullcap.errors, ArrayError);
pyo3::import_exception!(hullcap.errors, RasterError);

/// An engine error and the Python exception class it becomes.
pub(crate) trait IntoPyErr {
    fn into_py_err(self) -> PyErr;
}

/// `IntoPyErr` for an engine error type: the variants matching `$engine` (a worker thread
/// panicked: the engine's fault) become `hullcap.errors.EngineError`, every other one (bad
/// input) the error class `$input` of that crate's kind; the message is the error's own.
macro_rules! input_or_engine_errors {
    ($($ty:ty => $input:ty, $engine:pat),+ $(,)?) => {$(
        impl IntoPyErr for $ty {
            fn into_py_err(self) -> PyErr {
                if matches!(self, $engine) {
                    EngineError::new_err(self.to_string())
                } else {
                    <$input>::new_err(self.to_string())
                }
            }
        }
    )+};
}

input_or_engine_errors! {
    KdTreeError => FitError, KdTreeError::Worker(_),
    BodyError => ModelError, BodyError::Worker(_),
    EngineRasterError => RasterError, EngineRasterError::Panicked(_),
    IcpError => FitError,
        IcpError::Worker(_) | IcpError::Body(BodyError::Worker(_)) | IcpError::Target(KdTreeError::Worker(_)),
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
            Err(EngineError::new_err(format!(
                "internal error in the hullcap engine: {what}"
            )))
        }
    }
}
