//! `hullcap.NormalKDTree`: the normal-aware 6-D kd-tree.

use crate::arrays::{self, rows3};
use crate::call::detached;
use hullcap_kdtree::{BuildOptions, DEFAULT_LEAF_SIZE, Gate, Neighbor, NormalKdTree};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

type Answer<'py> = (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<f64>>);
type AnswerK<'py> = (Bound<'py, PyArray2<i64>>, Bound<'py, PyArray2<f64>>);

/// Exact nearest neighbours among target points with normals, in the 6-D space
/// (x, y, z, λ·n), gated by distance in space and by the angle between normals.
#[pyclass(module = "hullcap._engine", name = "NormalKDTree", frozen)]
pub(crate) struct NormalKDTree {
    tree: NormalKdTree,
}

fn gate(max_distance: f64, max_angle: f64) -> Gate {
    Gate {
        max_distance,
        max_angle,
    }
}

fn split(answers: Vec<Neighbor>) -> (Vec<i64>, Vec<f64>) {
    answers.into_iter().map(|n| (n.index, n.distance)).unzip()
}

#[pymethods]
impl NormalKDTree {
    #[new]
    #[pyo3(signature = (points, normals, normal_weight=None, leaf_size=DEFAULT_LEAF_SIZE as i64))]
    fn new(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        normals: &Bound<'_, PyAny>,
        normal_weight: Option<f64>,
        leaf_size: i64,
    ) -> PyResult<Self> {
        let points = rows3(points, "points")?;
        let normals = rows3(normals, "normals")?;
        let options = BuildOptions {
            normal_weight,
            leaf_size: arrays::count(leaf_size, "leaf_size", 1)?,
            ..BuildOptions::default()
        };
        let (p, n) = (points.rows(), normals.rows());
        let tree = detached(py, || NormalKdTree::build(p, n, &options))?;
        Ok(NormalKDTree { tree })
    }

    #[pyo3(signature = (points, normals, max_distance=f64::INFINITY, max_angle=std::f64::consts::PI, threads=None))]
    fn query<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
        max_distance: f64,
        max_angle: f64,
        threads: Option<i64>,
    ) -> PyResult<Answer<'py>> {
        let points = rows3(points, "points")?;
        let normals = rows3(normals, "normals")?;
        let threads = arrays::threads(threads)?;
        let (p, n) = (points.rows(), normals.rows());
        let g = gate(max_distance, max_angle);
        let answers = detached(py, || self.tree.query(p, n, &g, threads))?;
        let (index, distance) = split(answers);
        Ok((arrays::vec1(py, index), arrays::vec1(py, distance)))
    }

    #[pyo3(signature = (points, normals, k, max_distance=f64::INFINITY, max_angle=std::f64::consts::PI, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn query_k<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
        k: i64,
        max_distance: f64,
        max_angle: f64,
        threads: Option<i64>,
    ) -> PyResult<AnswerK<'py>> {
        let points = rows3(points, "points")?;
        let normals = rows3(normals, "normals")?;
        let k = arrays::count(k, "k", 1)?;
        let threads = arrays::threads(threads)?;
        let (p, n) = (points.rows(), normals.rows());
        let g = gate(max_distance, max_angle);
        let answers = detached(py, || self.tree.query_k(p, n, k, &g, threads))?;
        let rows = p.len();
        let (index, distance) = split(answers);
        Ok((
            arrays::vec1(py, index).reshape([rows, k])?,
            arrays::vec1(py, distance).reshape([rows, k])?,
        ))
    }

    /// λ, metres per unit of normal difference.
    #[getter]
    fn normal_weight(&self) -> f64 {
        self.tree.normal_weight()
    }

    /// Most points in a leaf bucket.
    #[getter]
    fn leaf_size(&self) -> usize {
        self.tree.leaf_size()
    }

    fn __len__(&self) -> usize {
        self.tree.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "NormalKDTree(n={}, normal_weight={}, leaf_size={})",
            self.tree.len(),
            self.tree.normal_weight(),
            self.tree.leaf_size()
        )
    }
}
