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
        dist: exactly(flat_floats(dist, "dist", &[])?, "dist")?,
        r: matrix3(R, "R")?,
        t: exactly(flat_floats(t, "t", &[])?, "t")?,
    };
    let threads = arrays::threads(threads)?;
    let mut shape = None;
    let mut arrays_f32 = Vec::with_capacity(images.len());
    let np = py.import("numpy")?;
    for (i, image) in images.iter().enumerate() {
        let name = format!("images[{i}]");
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
    let m: [f64; 9] = exactly(flat_floats(obj, name, &[3])?, name)?;
    Ok([[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]])
}

/// `values` as exactly `N` numbers, or an error naming the argument.
fn exactly<const N: usize>(values: Vec<f64>, name: &str) -> PyResult<[f64; N]> {
    values.try_into().map_err(|v: Vec<f64>| {
        ArrayError::new_err(format!("{name} must hold {N} numbers, got {}", v.len()))
    })
}
