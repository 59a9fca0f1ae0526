//! `hullcap.FitOptions`: the engine's fit options as a Python class whose defaults are
//! the engine's own (`hullcap_icp::FitOptions::default()`), so no number is repeated on
//! the Python side. Distances in metres, angles in radians.

use crate::call::OptionsError;
use hullcap_icp::{FitOptions as EngineOptions, Residual, Solver};
use hullcap_kdtree::Gate;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Options of `hullcap.fit`, `hullcap.fit_shape` and the tracker; see `_engine.pyi`.
#[pyclass(module = "hullcap._engine", name = "FitOptions", get_all, set_all, eq)]
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FitOptions {
    residual: String,
    solver: String,
    max_distance: f64,
    max_angle: f64,
    sigma_min: f64,
    reverse_weight: f64,
    reverse_points: usize,
    reverse_vertices: usize,
    model_points: usize,
    iterations: usize,
    tolerance: f64,
    rounds: usize,
    hierarchical: bool,
    polish: bool,
    coarse: usize,
    over_relaxation: f64,
    inlier_distance: f64,
    threads: Option<usize>,
}

/// Model vertices that seek partners when the caller names none: about this many, spread
/// evenly over the mesh. 1 500 of a 9 000-vertex body keep every limb well sampled (a
/// forearm gets ~100) at a sixth of the cost of all of them.
const DEFAULT_MODEL_POINTS: usize = 1500;

impl Default for FitOptions {
    fn default() -> Self {
        let e = EngineOptions::default();
        FitOptions {
            residual: residual_name(e.residual).to_owned(),
            solver: solver_name(e.solver).to_owned(),
            max_distance: e.gate.max_distance,
            max_angle: e.gate.max_angle,
            sigma_min: e.sigma_min,
            reverse_weight: e.reverse_weight,
            reverse_points: e.reverse_points,
            reverse_vertices: e.reverse_vertices,
            model_points: DEFAULT_MODEL_POINTS,
            iterations: e.iterations,
            tolerance: e.tolerance,
            rounds: e.rounds,
            hierarchical: e.hierarchical,
            polish: e.polish,
            coarse: e.coarse,
            over_relaxation: e.over_relaxation,
            inlier_distance: e.inlier_distance,
            threads: e.threads,
        }
    }
}

fn residual_name(r: Residual) -> &'static str {
    match r {
        Residual::PointToPoint => "point_to_point",
        Residual::PointToPlane => "point_to_plane",
    }
}

fn solver_name(s: Solver) -> &'static str {
    match s {
        Solver::LevenbergMarquardt => "lm",
        Solver::ConjugateGradient => "cg",
    }
}

impl FitOptions {
    /// The engine's options, every value checked (`hullcap.errors.OptionsError` naming the field).
    pub(crate) fn engine(&self) -> PyResult<EngineOptions> {
        let residual = match self.residual.as_str() {
            "point_to_point" => Residual::PointToPoint,
            "point_to_plane" => Residual::PointToPlane,
            other => {
                return Err(OptionsError::new_err(format!(
                    "FitOptions.residual must be 'point_to_point' or 'point_to_plane', got {other:?}"
                )));
            }
        };
        let solver = match self.solver.as_str() {
            "lm" => Solver::LevenbergMarquardt,
            "cg" => Solver::ConjugateGradient,
            other => {
                return Err(OptionsError::new_err(format!(
                    "FitOptions.solver must be 'lm' or 'cg', got {other:?}"
                )));
            }
        };
        if self.model_points == 0 {
            return Err(OptionsError::new_err(
                "FitOptions.model_points must be at least 1",
            ));
        }
        let options = EngineOptions {
            residual,
            solver,
            gate: Gate {
                max_distance: self.max_distance,
                max_angle: self.max_angle,
            },
            sigma_min: self.sigma_min,
            reverse_weight: self.reverse_weight,
            reverse_points: self.reverse_points,
            reverse_vertices: self.reverse_vertices,
            iterations: self.iterations,
            tolerance: self.tolerance,
            rounds: self.rounds,
            hierarchical: self.hierarchical,
            polish: self.polish,
            coarse: self.coarse,
            over_relaxation: self.over_relaxation,
            inlier_distance: self.inlier_distance,
            threads: self.threads,
        };
        options
            .validate()
            .map_err(|e| OptionsError::new_err(format!("FitOptions.{e}")))?;
        Ok(options)
    }

    /// About `model_points` vertex indices of a mesh of `n` vertices, every n-th.
    pub(crate) fn default_model_points(&self, n: usize) -> Vec<u32> {
        hullcap_icp::spread(n, self.model_points)
    }

    fn fields<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("residual", &self.residual)?;
        d.set_item("solver", &self.solver)?;
        d.set_item("max_distance", self.max_distance)?;
        d.set_item("max_angle", self.max_angle)?;
        d.set_item("sigma_min", self.sigma_min)?;
        d.set_item("reverse_weight", self.reverse_weight)?;
        d.set_item("reverse_points", self.reverse_points)?;
        d.set_item("reverse_vertices", self.reverse_vertices)?;
        d.set_item("model_points", self.model_points)?;
        d.set_item("iterations", self.iterations)?;
        d.set_item("tolerance", self.tolerance)?;
        d.set_item("rounds", self.rounds)?;
        d.set_item("hierarchical", self.hierarchical)?;
        d.set_item("polish", self.polish)?;
        d.set_item("coarse", self.coarse)?;
        d.set_item("over_relaxation", self.over_relaxation)?;
        d.set_item("inlier_distance", self.inlier_distance)?;
        d.set_item("threads", self.threads)?;
        Ok(d)
    }
}

#[pymethods]
impl FitOptions {
    #[new]
    #[pyo3(signature = (**changes))]
    fn new(py: Python<'_>, changes: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Self>> {
        FitOptions::default().replace(py, changes)
    }

    /// A copy with the named fields changed (checked).
    #[pyo3(signature = (**changes))]
    fn replace(&self, py: Python<'_>, changes: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Self>> {
        let obj = Bound::new(py, self.clone())?;
        if let Some(changes) = changes {
            for (name, value) in changes.iter() {
                let key: String = name.extract()?;
                if !self.fields(py)?.contains(&key)? {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "FitOptions has no field '{key}'"
                    )));
                }
                obj.setattr(key.as_str(), &value).map_err(|e| {
                    // A whole number out of range (a negative count) or of the wrong type.
                    let message = format!("FitOptions.{key} cannot be {value}: {}", e.value(py));
                    if e.is_instance_of::<pyo3::exceptions::PyTypeError>(py) {
                        pyo3::exceptions::PyTypeError::new_err(message)
                    } else {
                        OptionsError::new_err(message)
                    }
                })?;
            }
        }
        obj.borrow().engine()?;
        Ok(obj.unbind())
    }

    /// These options at the resolution of the coarse stages: a `coarse`-th of the model
    /// points, hull samples and reverse vertices, and `coarse` 1 (see `_engine.pyi`).
    fn coarsened(&self) -> PyResult<Self> {
        let engine = self.engine()?.coarsened();
        Ok(FitOptions {
            model_points: (self.model_points / self.coarse).max(1),
            reverse_points: engine.reverse_points,
            reverse_vertices: engine.reverse_vertices,
            coarse: 1,
            ..self.clone()
        })
    }

    /// The fields as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.fields(py)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let parts: Vec<String> = self
            .fields(py)?
            .iter()
            .map(|(k, v)| Ok(format!("{}={}", k.extract::<String>()?, v.repr()?)))
            .collect::<PyResult<_>>()?;
        Ok(format!("FitOptions({})", parts.join(", ")))
    }

    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (), Bound<'py, PyDict>)> {
        Ok((
            slf.get_type().into_any(),
            (),
            slf.borrow().fields(slf.py())?,
        ))
    }

    fn __setstate__(slf: &Bound<'_, Self>, state: &Bound<'_, PyDict>) -> PyResult<()> {
        for (name, value) in state.iter() {
            slf.setattr(name.extract::<String>()?.as_str(), value)?;
        }
        Ok(())
    }
}
