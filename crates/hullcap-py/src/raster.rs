//! Z-buffered rasterisation for the renderer of synthetic sequences and the pictures.

use crate::arrays::{self, flat_floats, index_rows, rows3};
use crate::call::{ArrayError, detached};
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
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

/// Images sampled at the projections of world points, and the points' depths; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (points, K, dist, R, t, images, threads=None))]
#[allow(non_snake_case, clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn sample_at_projections<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    K: &Bound<'py, PyAny>,
    dist: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    t: &Bound<'py, PyAny>,
    images: Vec<Bound<'py, PyAny>>,
    threads: Option<i64>,
) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Bound<'py, PyArray1<f64>>)> {
    let points = rows3(points, "points")?;
    let camera = hullcap_raster::Camera {
        k: matrix3(K, "K")?,
        dist: flat_floats(dist, "dist", &[])?
            .try_into()
            .map_err(|v: Vec<f64>| {
                ArrayError::new_err(format!("dist must hold 5 numbers, got {}", v.len()))
            })?,
        r: matrix3(R, "R")?,
        t: flat_floats(t, "t", &[])?
            .try_into()
            .map_err(|v: Vec<f64>| {
                ArrayError::new_err(format!("t must hold 3 numbers, got {}", v.len()))
            })?,
    };
    let threads = arrays::threads(threads)?;
    let mut shape = None;
    let mut arrays_f32 = Vec::with_capacity(images.len());
    for (i, image) in images.iter().enumerate() {
        let name = format!("images[{i}]");
        let np = py.import("numpy")?;
        let arr = np
            .call_method1("ascontiguousarray", (image, "float32"))
            .map_err(|e| ArrayError::new_err(format!("{name} is not an array of numbers: {e}")))?;
        let arr: PyReadonlyArray2<'py, f32> = arr
            .extract()
            .map_err(|_| ArrayError::new_err(format!("{name} must be 2-D (height, width)")))?;
        let (h, w) = (arr.shape()[0], arr.shape()[1]);
        let (h0, w0) = *shape.get_or_insert((h, w));
        if (h0, w0) != (h, w) {
            return Err(ArrayError::new_err(format!(
                "{name} is {w}×{h}, images[0] {w0}×{h0}"
            )));
        }
        arrays_f32.push(arr);
    }
    let (h, w) = shape.ok_or_else(|| ArrayError::new_err("images is empty: give at least one"))?;
    let slices: Vec<&[f32]> = arrays_f32
        .iter()
        .map(|a| a.as_slice().unwrap_or(&[]))
        .collect();
    let p = points.rows();
    let (values, depth) = detached(py, || {
        hullcap_raster::sample_at_projections(p, &camera, &slices, w, h, threads)
    })?;
    let n = p.len();
    let flat: Vec<f32> = values.into_iter().flatten().collect();
    Ok((
        PyArray1::from_vec(py, flat).reshape(vec![slices.len(), n])?,
        PyArray1::from_vec(py, depth),
    ))
}

/// `obj` as a 3 × 3 float64 matrix, row-major.
fn matrix3(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[[f64; 3]; 3]> {
    let flat = flat_floats(obj, name, &[3])?;
    if flat.len() != 9 {
        return Err(ArrayError::new_err(format!(
            "{name} must have shape (3, 3), got {} rows",
            flat.len() / 3
        )));
    }
    Ok([
        [flat[0], flat[1], flat[2]],
        [flat[3], flat[4], flat[5]],
        [flat[6], flat[7], flat[8]],
    ])
}
