//! Z-buffered rasterisation for the renderer of synthetic sequences and the pictures, and
//! plain coverage for the predicted silhouettes of tracking.

use crate::arrays::{self, Rows3, flat_floats, index_rows, rows3};
use crate::call::{ArrayError, detached};
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
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
    let mesh = Projected::new(vertices, faces, width, height, threads)?;
    let (v, f, w, h, t) = mesh.parts();
    let out = detached(py, || hullcap_raster::rasterize(v, f, w, h, near, t))?;
    Ok((mesh.image(py, out.depth)?, mesh.image(py, out.face)?))
}

/// 1 where a triangle given in pixel space covers a pixel, 0 elsewhere; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, width, height, near=1e-3, threads=None, closed=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn coverage<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    width: i64,
    height: i64,
    near: f64,
    threads: Option<i64>,
    closed: bool,
) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    let mesh = Projected::new(vertices, faces, width, height, threads)?;
    let (v, f, w, h, t) = mesh.parts();
    let seen = detached(py, || hullcap_raster::coverage(v, f, w, h, near, t, closed))?;
    mesh.image(py, seen)
}

/// The checked arguments of the two rasterisers: a mesh in pixel space and its image.
struct Projected<'py> {
    vertices: Rows3<'py>,
    faces: Vec<[u32; 3]>,
    width: usize,
    height: usize,
    threads: Option<usize>,
}

impl<'py> Projected<'py> {
    fn new(
        vertices: &Bound<'py, PyAny>,
        faces: &Bound<'py, PyAny>,
        width: i64,
        height: i64,
        threads: Option<i64>,
    ) -> PyResult<Self> {
        let vertices = rows3(vertices, "vertices")?;
        let faces = index_rows::<3>(faces, "faces", vertices.rows().len())?;
        Ok(Projected {
            faces,
            vertices,
            width: arrays::count(width, "width", 1)?,
            height: arrays::count(height, "height", 1)?,
            threads: arrays::threads(threads)?,
        })
    }

    /// What the engine's rasterisers take: vertices, faces, width, height and threads.
    #[allow(clippy::type_complexity)]
    fn parts(&self) -> (&[[f64; 3]], &[[u32; 3]], usize, usize, Option<usize>) {
        (
            self.vertices.rows(),
            &self.faces,
            self.width,
            self.height,
            self.threads,
        )
    }

    /// Row-major `values` as a (height, width) array.
    fn image<T: numpy::Element>(
        &self,
        py: Python<'py>,
        values: Vec<T>,
    ) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
        image(py, values, self.height, self.width)
    }
}

/// Row-major `values` as a new (`height`, `width`) NumPy array.
fn image<'py, T: numpy::Element>(
    py: Python<'py>,
    values: Vec<T>,
    height: usize,
    width: usize,
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    PyArray1::from_vec(py, values).reshape(vec![height, width])
}

/// The carving's verdict per cell (0 out, 1 in, 2 split); see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (centres, radius, views, tolerance, min_views, threads=None))]
pub(crate) fn classify_cells<'py>(
    py: Python<'py>,
    centres: &Bound<'py, PyAny>,
    radius: f64,
    views: Vec<Bound<'py, PyAny>>,
    tolerance: i64,
    min_views: i64,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<u8>>> {
    let centres = rows3(centres, "centres")?;
    if !(radius >= 0.0 && radius.is_finite()) {
        return Err(ArrayError::new_err(format!(
            "radius must be finite and >= 0, got {radius}"
        )));
    }
    let tolerance = arrays::count(tolerance, "tolerance", 0)?;
    let min_views = arrays::count(min_views, "min_views", 0)?;
    let threads = arrays::threads(threads)?;
    let parsed = parse_views(&views)?;
    let carve_views = carve_views(&parsed);
    let c = centres.rows();
    let verdicts = detached(py, || {
        hullcap_raster::classify_cells(c, radius, &carve_views, tolerance, min_views, threads)
    })?;
    Ok(arrays::vec1(
        py,
        verdicts.into_iter().map(|v| v as u8).collect(),
    ))
}

/// Whether the views that leave each point out of their silhouettes were all unsure of
/// it, and enough of them; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (points, views, min_views, threads=None))]
pub(crate) fn doubtful_points<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    views: Vec<Bound<'py, PyAny>>,
    min_views: i64,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let points = rows3(points, "points")?;
    let min_views = arrays::count(min_views, "min_views", 0)?;
    let threads = arrays::threads(threads)?;
    let mut parsed = Vec::with_capacity(views.len());
    for (i, view) in views.iter().enumerate() {
        let name = format!("views[{i}]");
        let (k, dist, r, t, mask, unsure): CutTuple<'py> = view.extract().map_err(|_| {
            ArrayError::new_err(format!(
                "{name} must be (K, dist, R, t, mask, unsure or None)"
            ))
        })?;
        let camera = camera(&k, &dist, &r, &t, &name)?;
        let (mask, [h, w]) =
            contiguous::<u8, 2>(&mask, "uint8", &format!("{name}.mask"), "(height, width)")?;
        let unsure = unsure
            .map(|u| {
                contiguous::<bool, 2>(&u, "bool", &format!("{name}.unsure"), "(height, width)")
            })
            .transpose()?;
        if let Some((_, [uh, uw])) = unsure.as_ref().filter(|(_, shape)| *shape != [h, w]) {
            return Err(ArrayError::new_err(format!(
                "{name}.unsure is {uw}×{uh}, its mask {w}×{h}"
            )));
        }
        parsed.push((camera, w, h, mask, unsure.map(|(u, _)| u)));
    }
    let cut_views: Vec<_> = parsed
        .iter()
        .map(|(camera, w, h, mask, unsure)| hullcap_raster::CutView {
            camera: *camera,
            width: *w,
            height: *h,
            mask: mask.as_slice().unwrap_or(&[]),
            unsure: unsure.as_ref().map(|u| u.as_slice().unwrap_or(&[])),
        })
        .collect();
    let p = points.rows();
    let doubtful = detached(py, || {
        hullcap_raster::doubtful_points(p, &cut_views, min_views, threads)
    })?;
    Ok(arrays::vec1(py, doubtful))
}

/// One view as `doubtful_points` takes it from Python.
type CutTuple<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Option<Bound<'py, PyAny>>,
);

/// Coarse-to-fine carving into a box of kept finest voxels; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (lo, voxel_size, fine, levels, views, tolerance, min_views, threads=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn carve<'py>(
    py: Python<'py>,
    lo: &Bound<'py, PyAny>,
    voxel_size: f64,
    fine: [i64; 3],
    levels: i64,
    views: Vec<Bound<'py, PyAny>>,
    tolerance: i64,
    min_views: i64,
    threads: Option<i64>,
) -> PyResult<([i64; 3], Bound<'py, PyArrayDyn<bool>>, usize)> {
    let lo: [f64; 3] = numbers(lo, "lo", &[])?;
    if !(voxel_size > 0.0 && voxel_size.is_finite()) || lo.iter().any(|v| !v.is_finite()) {
        return Err(ArrayError::new_err(format!(
            "lo must be finite and voxel_size finite and > 0, got {lo:?} and {voxel_size}"
        )));
    }
    let fine = [
        arrays::count(fine[0], "fine[0]", 1)?,
        arrays::count(fine[1], "fine[1]", 1)?,
        arrays::count(fine[2], "fine[2]", 1)?,
    ];
    let levels = arrays::count(levels, "levels", 0)?;
    // The coarsest level's cells are all allocated and tested at once.
    let coarsest: f64 = fine
        .iter()
        .map(|&n| (n as f64 / 2f64.powi(levels.min(60) as i32)).ceil())
        .product();
    if levels > 20 || coarsest > (1u64 << 26) as f64 {
        return Err(ArrayError::new_err(format!(
            "a grid of {fine:?} voxels in {levels} levels is too large to carve \
             ({coarsest} cells at the coarsest level, at most 2^26 and 20 levels)"
        )));
    }
    let tolerance = arrays::count(tolerance, "tolerance", 0)?;
    let min_views = arrays::count(min_views, "min_views", 0)?;
    let threads = arrays::threads(threads)?;
    let parsed = parse_views(&views)?;
    let carve_views = carve_views(&parsed);
    let carved = detached(py, || {
        hullcap_raster::carve(
            lo,
            voxel_size,
            fine,
            levels as u32,
            &carve_views,
            tolerance,
            min_views,
            threads,
        )
    })?;
    Ok((
        carved.first,
        PyArray1::from_vec(py, carved.occupancy).reshape(carved.shape.to_vec())?,
        carved.tested,
    ))
}

/// A view's camera, image size, focal length and distance images, borrowed from Python.
type ParsedView<'py> = (
    hullcap_raster::Camera,
    usize,
    usize,
    f64,
    Distances<'py>,
    Option<Distances<'py>>,
);

/// A signed distance image borrowed from Python: the values of its box, where the box
/// lies, and the size of the image it stands for.
struct Distances<'py> {
    values: PyReadonlyArrayDyn<'py, f32>,
    x0: usize,
    y0: usize,
    box_size: [usize; 2],
    image_size: [usize; 2],
}

impl Distances<'_> {
    /// The engine's view of it.
    fn boxed(&self) -> hullcap_raster::BoxedDistance<'_> {
        hullcap_raster::BoxedDistance {
            x0: self.x0,
            y0: self.y0,
            width: self.box_size[0],
            height: self.box_size[1],
            values: self.values.as_slice().unwrap_or(&[]),
        }
    }
}

/// `obj` as a distance image: a whole (height, width) float32 image, or
/// `(values, x0, y0, width, height)`: an (h, w) box of values at column `x0`, row `y0`
/// of a `width × height` image. `name` names it in errors.
fn distances<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Distances<'py>> {
    let layout = "(height, width) or (values, x0, y0, width, height)";
    if let Ok((values, x0, y0, width, height)) =
        obj.extract::<(Bound<'py, PyAny>, i64, i64, i64, i64)>()
    {
        let (values, [h, w]) =
            contiguous::<f32, 2>(&values, "float32", &format!("{name}[0]"), "(h, w)")?;
        let at = |v: i64, what: &str| arrays::count(v, &format!("{name}.{what}"), 0);
        let (x0, y0, width, height) = (
            at(x0, "x0")?,
            at(y0, "y0")?,
            at(width, "width")?,
            at(height, "height")?,
        );
        if x0 + w > width || y0 + h > height {
            return Err(ArrayError::new_err(format!(
                "{name}: a box of {w}×{h} at ({x0}, {y0}) does not fit in its image of {width}×{height}"
            )));
        }
        return Ok(Distances {
            values,
            x0,
            y0,
            box_size: [w, h],
            image_size: [width, height],
        });
    }
    let (values, [h, w]) = contiguous::<f32, 2>(obj, "float32", name, layout)?;
    Ok(Distances {
        values,
        x0: 0,
        y0: 0,
        box_size: [w, h],
        image_size: [w, h],
    })
}

/// The views of `classify_cells` and `carve`, checked, with errors naming the view.
fn parse_views<'py>(views: &[Bound<'py, PyAny>]) -> PyResult<Vec<ParsedView<'py>>> {
    let mut parsed = Vec::with_capacity(views.len());
    for (i, view) in views.iter().enumerate() {
        let name = format!("views[{i}]");
        let (k, dist, r, t, focal, signed, prior): ViewTuple<'py> =
            view.extract().map_err(|_| {
                ArrayError::new_err(format!(
                    "{name} must be (K, dist, R, t, focal, signed, prior or None)"
                ))
            })?;
        let camera = camera(&k, &dist, &r, &t, &name)?;
        let signed = distances(&signed, &format!("{name}.signed"))?;
        let [w, h] = signed.image_size;
        let prior = prior
            .map(|p| distances(&p, &format!("{name}.prior")))
            .transpose()?;
        if let Some([pw, ph]) = prior
            .as_ref()
            .map(|p| p.image_size)
            .filter(|size| *size != [w, h])
        {
            return Err(ArrayError::new_err(format!(
                "{name}.prior is {pw}×{ph}, its signed image {w}×{h}"
            )));
        }
        parsed.push((camera, w, h, focal, signed, prior));
    }
    Ok(parsed)
}

/// The engine's views over parsed ones.
fn carve_views<'a>(parsed: &'a [ParsedView<'_>]) -> Vec<hullcap_raster::CarveView<'a>> {
    parsed
        .iter()
        .map(
            |(camera, w, h, focal, signed, prior)| hullcap_raster::CarveView {
                camera: *camera,
                width: *w,
                height: *h,
                signed: signed.boxed(),
                prior: prior.as_ref().map(Distances::boxed),
                focal: *focal,
            },
        )
        .collect()
}

/// Horprasert's evidence that each pixel is foreground; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (image, planes, rule, threads=None))]
pub(crate) fn background_evidence<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    planes: &Bound<'py, PyAny>,
    rule: (f64, f64, f64, f64),
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let test = BackgroundTest::new(image, planes, threads)?;
    let (chromaticity, darkest_shadow, brightest_highlight, foreground) = rule;
    let rule = hullcap_raster::EvidenceRule {
        chromaticity: chromaticity as f32,
        darkest_shadow: darkest_shadow as f32,
        brightest_highlight: brightest_highlight as f32,
        foreground: foreground as f32,
    };
    let (pixels, planes, threads) = test.parts();
    let evidence = detached(py, || {
        hullcap_raster::background_evidence(pixels, &planes, &rule, threads)
    })?;
    test.image(py, evidence)
}

/// Horprasert's brightness and chromaticity distortions of each pixel; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (image, planes, threads=None))]
#[allow(clippy::type_complexity)]
pub(crate) fn background_distortions<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    planes: &Bound<'py, PyAny>,
    threads: Option<i64>,
) -> PyResult<(Bound<'py, PyArrayDyn<f32>>, Bound<'py, PyArrayDyn<f32>>)> {
    let test = BackgroundTest::new(image, planes, threads)?;
    let (pixels, planes, threads) = test.parts();
    let (alpha, cd) = detached(py, || {
        hullcap_raster::background_distortions(pixels, &planes, threads)
    })?;
    Ok((test.image(py, alpha)?, test.image(py, cd)?))
}

/// The checked arguments of the background test: an (H, W, 3) uint8 image and the
/// model's (8, H, W) float32 planes.
struct BackgroundTest<'py> {
    image: PyReadonlyArrayDyn<'py, u8>,
    planes: PyReadonlyArrayDyn<'py, f32>,
    height: usize,
    width: usize,
    threads: Option<usize>,
}

impl<'py> BackgroundTest<'py> {
    fn new(
        image: &Bound<'py, PyAny>,
        planes: &Bound<'py, PyAny>,
        threads: Option<i64>,
    ) -> PyResult<Self> {
        let (planes, [count, height, width]) =
            contiguous::<f32, 3>(planes, "float32", "planes", "(8, height, width)")?;
        if count != 8 {
            return Err(ArrayError::new_err(format!(
                "planes must be (8, height, width): 1/s and E/s of each channel, ‖E/s‖², 1/spread of CD; got {count} planes"
            )));
        }
        let (image, [h, w, channels]) =
            contiguous::<u8, 3>(image, "uint8", "image", "(height, width, 3)")?;
        if [h, w, channels] != [height, width, 3] {
            return Err(ArrayError::new_err(format!(
                "image is {w}×{h} with {channels} channels, the background model {width}×{height} with 3"
            )));
        }
        Ok(BackgroundTest {
            image,
            planes,
            height,
            width,
            threads: arrays::threads(threads)?,
        })
    }

    /// The image's values, the engine's view of the planes, and the threads.
    fn parts(&self) -> (&[u8], hullcap_raster::BackgroundPlanes<'_>, Option<usize>) {
        let planes = self.planes.as_slice().unwrap_or(&[]);
        let n = self.height * self.width;
        let plane = |k: usize| &planes[k * n..(k + 1) * n];
        let planes = hullcap_raster::BackgroundPlanes {
            inv_spread: [plane(0), plane(1), plane(2)],
            scaled_mean: [plane(3), plane(4), plane(5)],
            scaled_norm2: plane(6),
            inv_cd_spread: plane(7),
        };
        (self.image.as_slice().unwrap_or(&[]), planes, self.threads)
    }

    /// Row-major `values` as a (height, width) array.
    fn image(&self, py: Python<'py>, values: Vec<f32>) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
        image(py, values, self.height, self.width)
    }
}

/// The log-odds of the model-guided silhouettes over a window of one view; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (evidence, image, origin, ramp, weights, colours=None))]
pub(crate) fn guided_logit<'py>(
    py: Python<'py>,
    evidence: &Bound<'py, PyAny>,
    image: &Bound<'py, PyAny>,
    origin: (i64, i64),
    ramp: &Bound<'py, PyAny>,
    weights: (f64, f64, f64, f64, f64, f64),
    colours: Option<(Bound<'py, PyAny>, i64)>,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let origin = (
        arrays::count(origin.0, "origin[0]", 0)?,
        arrays::count(origin.1, "origin[1]", 0)?,
    );
    let (evidence, [height, width]) =
        contiguous::<f32, 2>(evidence, "float32", "evidence", "(height, width)")?;
    let (image, shape) = contiguous::<u8, 3>(image, "uint8", "image", "(height, width, 3)")?;
    if shape != [height, width, 3] {
        return Err(ArrayError::new_err(format!(
            "image has the shape {shape:?}, the evidence ({height}, {width}): it must be ({height}, {width}, 3)"
        )));
    }
    let (ramp, [rows, columns]) = contiguous::<f32, 2>(ramp, "float32", "ramp", "(rows, columns)")?;
    let table = match &colours {
        Some((table, bins)) => Some((
            contiguous::<f32, 1>(table, "float32", "colours' table", "(bins³,)")?.0,
            arrays::count(*bins, "colours' bins", 0)?,
        )),
        None => None,
    };
    let (evidence_min, evidence_max, background, prior, colour, colour_limit) = weights;
    let weights = hullcap_raster::LogitWeights {
        evidence_min: evidence_min as f32,
        evidence_max: evidence_max as f32,
        background: background as f32,
        prior: prior as f32,
        colour: colour as f32,
        colour_limit: colour_limit as f32,
    };
    let window = hullcap_raster::Window {
        top: origin.0,
        left: origin.1,
        height: rows,
        width: columns,
    };
    let colours = table.as_ref().map(|(t, bins)| hullcap_raster::ColourTable {
        log_ratio: t.as_slice().unwrap_or(&[]),
        bins: *bins,
    });
    let (evidence, image, ramp) = (
        evidence.as_slice().unwrap_or(&[]),
        image.as_slice().unwrap_or(&[]),
        ramp.as_slice().unwrap_or(&[]),
    );
    let logit = detached(py, || {
        hullcap_raster::guided_logit(evidence, image, width, window, ramp, colours, &weights)
    })?;
    self::image(py, logit, rows, columns)
}

/// A 3-D Gaussian blur of a grid of small whole numbers (an occupancy); see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (values, sigma, threads=None))]
pub(crate) fn gaussian_blur<'py>(
    py: Python<'py>,
    values: &Bound<'py, PyAny>,
    sigma: f64,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let threads = arrays::threads(threads)?;
    let (values, shape) = contiguous::<u8, 3>(values, "uint8", "values", "(nx, ny, nz)")?;
    let flat = values.as_slice().unwrap_or(&[]);
    let blurred = detached(py, || {
        hullcap_raster::gaussian_blur(flat, shape, sigma, threads)
    })?;
    PyArray1::from_vec(py, blurred).reshape(shape.to_vec())
}

/// The surface where a 3-D field crosses a level, in grid units; see
/// `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (field, level, threads=None))]
#[allow(clippy::type_complexity)]
pub(crate) fn isosurface<'py>(
    py: Python<'py>,
    field: &Bound<'py, PyAny>,
    level: f64,
    threads: Option<i64>,
) -> PyResult<(
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<i64>>,
    Bound<'py, PyArrayDyn<f64>>,
)> {
    if !level.is_finite() {
        return Err(ArrayError::new_err(format!(
            "level must be finite, got {level}"
        )));
    }
    let (field, shape) = contiguous::<f32, 3>(field, "float32", "field", "(nx, ny, nz)")?;
    let values = field.as_slice().unwrap_or(&[]);
    let threads = arrays::threads(threads)?;
    let surface = detached(py, || {
        hullcap_raster::isosurface(values, shape, level, threads)
    })?;
    let rows = |r: Vec<[f64; 3]>| {
        let n = r.len();
        PyArray1::from_vec(py, r.into_flattened()).reshape(vec![n, 3])
    };
    let faces: Vec<i64> = surface
        .faces
        .as_flattened()
        .iter()
        .map(|&i| i64::from(i))
        .collect();
    Ok((
        rows(surface.vertices)?,
        PyArray1::from_vec(py, faces).reshape(vec![surface.faces.len(), 3])?,
        rows(surface.normals)?,
    ))
}

/// `obj` as a C-contiguous NumPy array of `dtype` with `D` axes (`layout` names them),
/// and its shape; an `ArrayError` naming the argument `name` otherwise.
fn contiguous<'py, T: numpy::Element, const D: usize>(
    obj: &Bound<'py, PyAny>,
    dtype: &str,
    name: &str,
    layout: &str,
) -> PyResult<(PyReadonlyArrayDyn<'py, T>, [usize; D])> {
    let array: PyReadonlyArrayDyn<'py, T> = obj
        .py()
        .import("numpy")?
        .call_method1("ascontiguousarray", (obj, dtype))
        .map_err(|e| ArrayError::new_err(format!("{name} is not an array of {dtype}: {e}")))?
        .extract()?;
    let shape = array.shape().try_into().map_err(|_| {
        ArrayError::new_err(format!(
            "{name} must be {D}-D {layout}, got shape {:?}",
            array.shape()
        ))
    })?;
    Ok((array, shape))
}

/// One view as `classify_cells` takes it from Python.
type ViewTuple<'py> = (
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    Bound<'py, PyAny>,
    f64,
    Bound<'py, PyAny>,
    Option<Bound<'py, PyAny>>,
);

/// A view's calibration from its `K`, `dist`, `R` and `t`; errors name the view `name`.
fn camera(
    k: &Bound<'_, PyAny>,
    dist: &Bound<'_, PyAny>,
    r: &Bound<'_, PyAny>,
    t: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<hullcap_raster::Camera> {
    Ok(hullcap_raster::Camera {
        k: matrix3(k, &format!("{name}.K"))?,
        dist: numbers(dist, &format!("{name}.dist"), &[])?,
        r: matrix3(r, &format!("{name}.R"))?,
        t: numbers(t, &format!("{name}.t"), &[])?,
    })
}

/// `obj` as a 3 × 3 float64 matrix, row-major.
fn matrix3(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[[f64; 3]; 3]> {
    let m: [f64; 9] = numbers(obj, name, &[3])?;
    Ok([[m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]])
}

/// `obj` (shaped (M, *tail)) as exactly `N` numbers, or an error naming the argument.
fn numbers<const N: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
    tail: &[usize],
) -> PyResult<[f64; N]> {
    flat_floats(obj, name, tail)?
        .try_into()
        .map_err(|v: Vec<f64>| {
            ArrayError::new_err(format!("{name} must hold {N} numbers, got {}", v.len()))
        })
}
