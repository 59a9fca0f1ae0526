//! Robust articulated ICP: the target surface and the fit; see `hullcap._engine.pyi`.

use crate::arrays::rows3;
use crate::body::{Rig, Shape, root_pose};
use crate::call::ArrayError;
use crate::call::detached;
use crate::options::FitOptions;
use hullcap_icp::{FitStats, Params, PosePrior, ShapePrior, Target as EngineTarget};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A target surface (points with normals) indexed for correspondences.
#[pyclass(module = "hullcap._engine", name = "Target", frozen)]
pub(crate) struct Target {
    target: EngineTarget,
}

#[pymethods]
impl Target {
    #[new]
    #[pyo3(signature = (points, normals, normal_weight=None))]
    fn new(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        normals: &Bound<'_, PyAny>,
        normal_weight: Option<f64>,
    ) -> PyResult<Self> {
        let p = rows3(points, "points")?;
        let n = rows3(normals, "normals")?;
        let (p, n) = (p.rows(), n.rows());
        let target = detached(py, || EngineTarget::new(p, n, normal_weight))?;
        Ok(Target { target })
    }

    fn __len__(&self) -> usize {
        self.target.len()
    }

    /// λ of the 6-D keys.
    #[getter]
    fn normal_weight(&self) -> f64 {
        self.target.normal_weight()
    }
}

/// A fit's statistics as a dict (the keyword arguments of `hullcap.FitResult`).
fn stats_dict<'py>(py: Python<'py>, stats: &FitStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("iterations", stats.iterations)?;
    d.set_item("rounds", stats.rounds)?;
    d.set_item("energy", stats.energy)?;
    d.set_item("inlier_fraction", stats.inlier_fraction)?;
    d.set_item("mean_residual", stats.mean_residual)?;
    d.set_item("coverage", stats.coverage)?;
    d.set_item("mean_reverse_residual", stats.mean_reverse_residual)?;
    d.set_item("sigma", stats.sigma)?;
    let counts: Vec<i64> = stats
        .links
        .iter()
        .flat_map(|c| [c.points, c.inliers, c.samples, c.covered].map(i64::from))
        .collect();
    d.set_item(
        "link_counts",
        PyArray1::from_vec(py, counts).reshape(vec![stats.links.len(), 4])?,
    )?;
    Ok(d)
}

/// A pose as NumPy arrays: (theta (D,), root rotation (3, 3), root translation (3,)).
type PoseArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, numpy::PyArrayDyn<f64>>,
    Bound<'py, PyArray1<f64>>,
);

fn pose_arrays<'py>(py: Python<'py>, params: &Params) -> PyResult<PoseArrays<'py>> {
    let r: Vec<f64> = (0..9)
        .map(|i| params.root.rotation[(i / 3, i % 3)])
        .collect();
    Ok((
        PyArray1::from_vec(py, params.theta.clone()),
        PyArray1::from_vec(py, r).reshape(vec![3, 3])?,
        PyArray1::from_vec(py, params.root.translation.iter().copied().collect()),
    ))
}

/// Model point indices from Python, or the options' evenly spread default.
fn model_points(
    given: Option<Vec<i64>>,
    n_vertices: usize,
    options: &FitOptions,
) -> PyResult<Vec<u32>> {
    match given {
        None => Ok(options.default_model_points(n_vertices)),
        Some(points) => points
            .iter()
            .map(|&i| {
                u32::try_from(i).map_err(|_| {
                    ArrayError::new_err(format!("model_points holds {i}, not a vertex index"))
                })
            })
            .collect(),
    }
}

fn dof_groups(groups: Vec<Vec<i64>>) -> PyResult<Vec<Vec<usize>>> {
    groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|&d| {
                    usize::try_from(d).map_err(|_| {
                        ArrayError::new_err(format!("groups holds a negative index {d}"))
                    })
                })
                .collect()
        })
        .collect()
}

/// Fits a rig to a target; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (rig, target, theta, root_rotation, root_translation, groups, options, model_points=None,
                    prior=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fit<'py>(
    py: Python<'py>,
    rig: PyRef<'py, Rig>,
    target: PyRef<'py, Target>,
    theta: Vec<f64>,
    root_rotation: &Bound<'py, PyAny>,
    root_translation: &Bound<'py, PyAny>,
    groups: Vec<Vec<i64>>,
    options: PyRef<'py, FitOptions>,
    model_points: Option<Vec<i64>>,
    prior: Option<(Vec<f64>, Vec<f64>, f64)>,
) -> PyResult<(PoseArrays<'py>, Bound<'py, PyDict>)> {
    let engine_options = options.engine()?;
    let points = self::model_points(model_points, rig.rig.n_vertices(), &options)?;
    let groups = dof_groups(groups)?;
    let root = root_pose(Some(root_rotation), Some(root_translation))?;
    let initial = Params { root, theta };
    let prior = prior.map(|(mean, sigma, prior_distance)| PosePrior {
        mean,
        sigma,
        prior_distance,
    });
    let (rig, target) = (&rig.rig, &target.target);
    let (got, stats) = detached(py, || {
        hullcap_icp::fit_with_prior(
            rig,
            target,
            &points,
            &initial,
            &groups,
            &engine_options,
            prior.as_ref(),
        )
    })?;
    Ok((pose_arrays(py, &got)?, stats_dict(py, &stats)?))
}

/// Fits a shape and the poses of several frames together; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (shape, initial_shape, targets, thetas, root_rotations, root_translations,
                    prior_sigma, prior_distance, options, model_points=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn fit_shape<'py>(
    py: Python<'py>,
    shape: PyRef<'py, Shape>,
    initial_shape: Vec<f64>,
    targets: Vec<PyRef<'py, Target>>,
    thetas: Vec<Vec<f64>>,
    root_rotations: Vec<Bound<'py, PyAny>>,
    root_translations: Vec<Bound<'py, PyAny>>,
    prior_sigma: Vec<f64>,
    prior_distance: f64,
    options: PyRef<'py, FitOptions>,
    model_points: Option<Vec<i64>>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Vec<PoseArrays<'py>>,
    Vec<Bound<'py, PyDict>>,
    usize,
)> {
    let engine_options = options.engine()?;
    let n = targets.len();
    if thetas.len() != n || root_rotations.len() != n || root_translations.len() != n {
        return Err(ArrayError::new_err(format!(
            "fit_shape: {n} targets but {} thetas, {} root rotations, {} root translations",
            thetas.len(),
            root_rotations.len(),
            root_translations.len()
        )));
    }
    let shape = &shape.shape;
    let points = self::model_points(model_points, shape.base().n_vertices(), &options)?;
    let mut frames = Vec::with_capacity(n);
    for (f, theta) in thetas.into_iter().enumerate() {
        let root = root_pose(Some(&root_rotations[f]), Some(&root_translations[f]))?;
        frames.push((&targets[f].target, Params { root, theta }));
    }
    let prior = ShapePrior {
        sigma: prior_sigma,
        prior_distance,
    };
    let found = detached(py, || {
        hullcap_icp::fit_shape(
            shape,
            &initial_shape,
            &frames,
            &points,
            &prior,
            &engine_options,
        )
    })?;
    Ok((
        PyArray1::from_vec(py, found.shape),
        found
            .poses
            .iter()
            .map(|p| pose_arrays(py, p))
            .collect::<PyResult<_>>()?,
        found
            .stats
            .iter()
            .map(|s| stats_dict(py, s))
            .collect::<PyResult<_>>()?,
        found.iterations,
    ))
}

/// The statistics of many poses without fitting; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (rig, target, thetas, root_rotations, root_translations, options, model_points=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate<'py>(
    py: Python<'py>,
    rig: PyRef<'py, Rig>,
    target: PyRef<'py, Target>,
    thetas: Vec<Vec<f64>>,
    root_rotations: Vec<Bound<'py, PyAny>>,
    root_translations: Vec<Bound<'py, PyAny>>,
    options: PyRef<'py, FitOptions>,
    model_points: Option<Vec<i64>>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let engine_options = options.engine()?;
    if root_rotations.len() != thetas.len() || root_translations.len() != thetas.len() {
        return Err(ArrayError::new_err(format!(
            "evaluate: {} thetas but {} root rotations and {} root translations",
            thetas.len(),
            root_rotations.len(),
            root_translations.len()
        )));
    }
    let points = self::model_points(model_points, rig.rig.n_vertices(), &options)?;
    let poses = thetas
        .into_iter()
        .enumerate()
        .map(|(f, theta)| {
            let root = root_pose(Some(&root_rotations[f]), Some(&root_translations[f]))?;
            Ok(Params { root, theta })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let (rig, target) = (&rig.rig, &target.target);
    let stats = detached(py, || {
        hullcap_icp::evaluate_poses(rig, target, &points, &poses, &engine_options)
    })?;
    stats.iter().map(|s| stats_dict(py, s)).collect()
}
