//! Z-buffered rasterisation for the renderer of synthetic sequences and the pictures.

use crate::arrays::{self, index_rows, rows3};
use crate::call::detached;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;

/// Depth and triangle index per pixel of triangles given in pixel space; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, width, height, near=1e-3, threads=None))]
#[allow(clippy::type_complexity)]
pub(crate) fn rasterize<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    width: i64,
    height: i64,
    near: f64,
    threads: Option<i64>,
) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Bound<'py, PyArrayDyn<i32>>)> {
    let vertices = rows3(vertices, "vertices")?;
    let faces = index_rows::<3>(faces, "faces", vertices.rows().len())?;
    let (w, h) = (
        arrays::count(width, "width", 1)?,
        arrays::count(height, "height", 1)?,
    );
    let threads = arrays::threads(threads)?;
    let v = vertices.rows();
    let out = detached(py, || {
        hullcap_raster::rasterize(v, &faces, w, h, near, threads)
    })?;
    Ok((
        PyArray1::from_vec(py, out.depth).reshape(vec![h, w])?,
        PyArray1::from_vec(py, out.face).reshape(vec![h, w])?,
    ))
}
