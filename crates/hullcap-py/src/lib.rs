//! `hullcap._engine`: the Python face of the Rust engine.
//!
//! This crate only converts and validates arrays, releases the GIL around engine calls,
//! and maps engine errors to Python exceptions (see [`call`]). The algorithms live in the
//! pure crates beside it.

mod arrays;
mod body;
mod call;
mod icp;
mod kdtree;
mod options;
mod raster;

use pyo3::prelude::*;

/// The threads the engine runs on: `$HULLCAP_THREADS` when it is a positive number, else
/// every core.
#[pyfunction]
fn threads() -> usize {
    hullcap_core::resolve_threads(None)
}

/// The extension module; its name must match `module-name` in pyproject.toml.
#[pymodule]
fn _engine(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<kdtree::NormalKDTree>()?;
    m.add_class::<body::Rig>()?;
    m.add_function(wrap_pyfunction!(body::skin_weights, m)?)?;
    m.add_function(wrap_pyfunction!(body::link_distances, m)?)?;
    m.add_function(wrap_pyfunction!(body::link_tree_problem, m)?)?;
    m.add_function(wrap_pyfunction!(raster::rasterize, m)?)?;
    m.add_function(wrap_pyfunction!(raster::coverage, m)?)?;
    m.add_function(wrap_pyfunction!(raster::classify_cells, m)?)?;
    m.add_function(wrap_pyfunction!(raster::carve, m)?)?;
    m.add_function(wrap_pyfunction!(raster::doubtful_points, m)?)?;
    m.add_function(wrap_pyfunction!(raster::background_evidence, m)?)?;
    m.add_function(wrap_pyfunction!(raster::background_distortions, m)?)?;
    m.add_function(wrap_pyfunction!(raster::guided_logit, m)?)?;
    m.add_function(wrap_pyfunction!(raster::gaussian_blur, m)?)?;
    m.add_function(wrap_pyfunction!(raster::isosurface, m)?)?;
    m.add_class::<icp::Target>()?;
    m.add_function(wrap_pyfunction!(icp::fit, m)?)?;
    m.add_function(wrap_pyfunction!(icp::fit_shape, m)?)?;
    m.add_function(wrap_pyfunction!(icp::evaluate, m)?)?;
    m.add_class::<options::FitOptions>()?;
    m.add_class::<body::Shape>()?;
    m.add_function(wrap_pyfunction!(threads, m)?)?;
    Ok(())
}
