//! `hullcap._engine`: the Python face of the Rust engine.
//!
//! This crate only converts and validates arrays, releases the GIL around engine calls,
//! and maps engine errors to Python exceptions (see [`call`]). The algorithms live in the
//! pure crates beside it.

mod arrays;
mod call;
mod kdtree;

use pyo3::prelude::*;

/// The extension module; its name must match `module-name` in pyproject.toml.
#[pymodule]
fn _engine(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<kdtree::NormalKDTree>()?;
    Ok(())
}
