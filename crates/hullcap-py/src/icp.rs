//! Robust articulated ICP: the target surface and the fit; see `hullcap._engine.pyi`.

use crate::arrays::{self, rows3};
use crate::body::{Rig, root_pose};
use crate::call::detached;
use hullcap_icp::{FitOptions, Params, Residual, Solver, Target as EngineTarget};
use hullcap_kdtree::Gate;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
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

/// Fits a rig to a target; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (rig, target, model_points, theta, root_rotation, root_translation, groups,
                    residual="point_to_point", solver="lm", max_distance=0.15, max_angle=1.0471975511965976,
                    sigma_min=0.004, iterations=10, tolerance=1e-3, rounds=4, hierarchical=true,
                    polish=true, inlier_distance=0.02, threads=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(crate) fn fit<'py>(
    py: Python<'py>,
    rig: PyRef<'py, Rig>,
    target: PyRef<'py, Target>,
    model_points: Vec<i64>,
    theta: Vec<f64>,
    root_rotation: &Bound<'py, PyAny>,
    root_translation: &Bound<'py, PyAny>,
    groups: Vec<Vec<i64>>,
    residual: &str,
    solver: &str,
    max_distance: f64,
    max_angle: f64,
    sigma_min: f64,
    iterations: i64,
    tolerance: f64,
    rounds: i64,
    hierarchical: bool,
    polish: bool,
    inlier_distance: f64,
    threads: Option<i64>,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, numpy::PyArrayDyn<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyDict>,
)> {
    let residual = match residual {
        "point_to_point" => Residual::PointToPoint,
        "point_to_plane" => Residual::PointToPlane,
        other => {
            return Err(PyValueError::new_err(format!(
                "residual must be 'point_to_point' or 'point_to_plane', got {other:?}"
            )));
        }
    };
    let solver = match solver {
        "lm" => Solver::LevenbergMarquardt,
        "cg" => Solver::ConjugateGradient,
        other => {
            return Err(PyValueError::new_err(format!(
                "solver must be 'lm' or 'cg', got {other:?}"
            )));
        }
    };
    let index = |x: i64, what: &str| {
        usize::try_from(x)
            .map_err(|_| PyValueError::new_err(format!("{what} holds a negative index {x}")))
    };
    let points: Vec<u32> = model_points
        .iter()
        .map(|&i| {
            index(i, "model_points").and_then(|u| {
                u32::try_from(u).map_err(|_| PyValueError::new_err("model point index too large"))
            })
        })
        .collect::<PyResult<_>>()?;
    let groups: Vec<Vec<usize>> = groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|&d| index(d, "groups"))
                .collect::<PyResult<_>>()
        })
        .collect::<PyResult<_>>()?;
    let options = FitOptions {
        residual,
        solver,
        gate: Gate {
            max_distance,
            max_angle,
        },
        sigma_min,
        iterations: arrays::count(iterations, "iterations", 1)?,
        tolerance,
        rounds: arrays::count(rounds, "rounds", 1)?,
        hierarchical,
        polish,
        inlier_distance,
        threads: arrays::threads(threads)?,
    };
    let root = root_pose(Some(root_rotation), Some(root_translation))?;
    let initial = Params { root, theta };
    let (rig, target) = (&rig.rig, &target.target);
    let (got, stats) = detached(py, || {
        hullcap_icp::fit(rig, target, &points, &initial, &groups, &options)
    })?;
    let stats_dict = PyDict::new(py);
    stats_dict.set_item("iterations", stats.iterations)?;
    stats_dict.set_item("rounds", stats.rounds)?;
    stats_dict.set_item("energy", stats.energy)?;
    stats_dict.set_item("inlier_fraction", stats.inlier_fraction)?;
    stats_dict.set_item("mean_residual", stats.mean_residual)?;
    stats_dict.set_item("sigma", stats.sigma)?;
    let r: Vec<f64> = (0..9).map(|i| got.root.rotation[(i / 3, i % 3)]).collect();
    Ok((
        PyArray1::from_vec(py, got.theta),
        PyArray1::from_vec(py, r).reshape(vec![3, 3])?,
        PyArray1::from_vec(py, got.root.translation.iter().copied().collect()),
        stats_dict,
    ))
}
