//! The body model's engine: geodesic skin weights and the rig (skinning, derivatives).

use crate::arrays::{self, float_rows, index_rows, one_array, rows3};
use crate::call::ArrayError;
use crate::call::detached;
use hullcap_body::{
    BodyError, Dof, Rig as EngineRig, RootPose, Shape as EngineShape, ShapeParameter, Skeleton,
    SkeletonPose, SkinWeightOptions, SkinWeights,
};
use nalgebra::{Matrix3, Vector3};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;

type F64Array<'py> = Bound<'py, numpy::PyArrayDyn<f64>>;

/// Rows of fixed width as a NumPy array of shape (N, *tail).
fn to_numpy<'py, const W: usize>(
    py: Python<'py>,
    rows: &[[f64; W]],
    tail: &[usize],
) -> PyResult<F64Array<'py>> {
    let flat: Vec<f64> = rows.as_flattened().to_vec();
    let shape: Vec<usize> = std::iter::once(rows.len())
        .chain(tail.iter().copied())
        .collect();
    PyArray1::from_vec(py, flat).reshape(shape)
}

fn flat_to_numpy<'py>(py: Python<'py>, flat: Vec<f64>, shape: &[usize]) -> PyResult<F64Array<'py>> {
    PyArray1::from_vec(py, flat).reshape(shape.to_vec())
}

/// Non-penetrating geodesic skin weights; see `hullcap.skin_weights`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, links, b=40.0, k=4, groups=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn skin_weights<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    links: &Bound<'py, PyAny>,
    b: f64,
    k: i64,
    groups: Option<Vec<i64>>,
    threads: Option<i64>,
) -> PyResult<(Bound<'py, numpy::PyArrayDyn<i64>>, F64Array<'py>)> {
    let vertices = rows3(vertices, "vertices")?;
    let faces = index_rows::<3>(faces, "faces", vertices.rows().len())?;
    let links = float_rows::<6>(links, "links", &[2, 3])?;
    let n_links = links.rows().len();
    let groups: Vec<u32> = match groups {
        None => (0..n_links as u32).collect(),
        Some(g) => g
            .iter()
            .map(|&x| {
                u32::try_from(x).map_err(|_| {
                    ArrayError::new_err(format!("groups holds {x}, a negative or huge index"))
                })
            })
            .collect::<PyResult<_>>()?,
    };
    let n_groups = groups.iter().map(|&g| g as usize + 1).max().unwrap_or(0);
    let options = SkinWeightOptions {
        b,
        k: arrays::count(k, "k", 1)?,
        threads: arrays::threads(threads)?,
    };
    let segments: Vec<[[f64; 3]; 2]> = links
        .rows()
        .iter()
        .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]]])
        .collect();
    let v = vertices.rows();
    let (weights, _) = detached(py, || {
        hullcap_body::skin_weights(v, &faces, &segments, &groups, n_groups, &options)
    })?;
    let shape = [v.len(), weights.k];
    let index: Vec<i64> = weights.index.iter().map(|&i| i64::from(i)).collect();
    Ok((
        PyArray1::from_vec(py, index).reshape(shape.to_vec())?,
        flat_to_numpy(py, weights.weight, &shape)?,
    ))
}

/// x_ij and the direct arcs, with the time of each stage; see `hullcap._engine.pyi`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, links, threads=None))]
pub(crate) fn link_distances<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    links: &Bound<'py, PyAny>,
    threads: Option<i64>,
) -> PyResult<(F64Array<'py>, F64Array<'py>, f64, f64, f64)> {
    let vertices = rows3(vertices, "vertices")?;
    let faces = index_rows::<3>(faces, "faces", vertices.rows().len())?;
    let links = float_rows::<6>(links, "links", &[2, 3])?;
    let segments: Vec<[[f64; 3]; 2]> = links
        .rows()
        .iter()
        .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]]])
        .collect();
    let threads = arrays::threads(threads)?;
    let v = vertices.rows();
    let found = detached(py, || {
        hullcap_body::link_distances(v, &faces, &segments, threads)
    })?;
    let (nv, nl) = (v.len(), segments.len());
    Ok((
        flat_to_numpy(py, found.distances, &[nl, nv])?,
        flat_to_numpy(py, found.direct, &[nv, nl])?,
        found.visibility_seconds,
        found.graph_seconds,
        found.dijkstra_seconds,
    ))
}

/// A rigged mesh: skeleton + rest mesh + K-sparse skin weights (the engine under
/// `hullcap.BodyModel`).
#[pyclass(module = "hullcap._engine", name = "Rig", frozen)]
pub(crate) struct Rig {
    pub(crate) rig: EngineRig,
}

/// A skeleton's joint centres (L, 3) and link rotations (L, 3, 3), moved by `root` into
/// the world.
fn world_frames<'py>(
    py: Python<'py>,
    skeleton: &SkeletonPose,
    root: &RootPose,
) -> PyResult<(F64Array<'py>, F64Array<'py>)> {
    let centres: Vec<[f64; 3]> = skeleton
        .position
        .iter()
        .map(|p| (root.rotation * p + root.translation).into())
        .collect();
    let rotations: Vec<[f64; 9]> = skeleton
        .rotation
        .iter()
        .map(|r| {
            let w = root.rotation * r;
            std::array::from_fn(|i| w[(i / 3, i % 3)])
        })
        .collect();
    Ok((
        to_numpy(py, &centres, &[3])?,
        to_numpy(py, &rotations, &[3, 3])?,
    ))
}

pub(crate) fn root_pose(
    rotation: Option<&Bound<'_, PyAny>>,
    translation: Option<&Bound<'_, PyAny>>,
) -> PyResult<RootPose> {
    let mut root = RootPose::default();
    if let Some(r) = rotation {
        root.rotation =
            Matrix3::from_row_slice(&one_array::<9>(r, "root_rotation", "a 3×3 matrix")?);
    }
    if let Some(t) = translation {
        root.translation = Vector3::from(one_array::<3>(t, "root_translation", "3 values")?);
    }
    Ok(root)
}

/// The engine's skeleton from the link tree's arrays: the outer error is an argument it
/// cannot take, the inner one the engine's verdict on the tree.
fn skeleton(
    parents: Vec<i64>,
    origins: &Bound<'_, PyAny>,
    dof_links: Vec<i64>,
    dof_axes: &Bound<'_, PyAny>,
    dof_limits: &Bound<'_, PyAny>,
) -> PyResult<Result<Skeleton, BodyError>> {
    let origins = rows3(origins, "origins")?;
    let axes = rows3(dof_axes, "dof_axes")?;
    let limits = float_rows::<2>(dof_limits, "dof_limits", &[2])?;
    if dof_links.len() != axes.rows().len() || dof_links.len() != limits.rows().len() {
        return Ok(Err(BodyError::WrongLength {
            array: "dof_axes/dof_limits",
            got: axes.rows().len(),
            expected: dof_links.len(),
        }));
    }
    let dofs = dof_links
        .iter()
        .zip(axes.rows().iter().zip(limits.rows()))
        .map(|(&link, (axis, lim))| Dof {
            link: usize::try_from(link).unwrap_or(usize::MAX),
            axis: Vector3::from(*axis),
            lower: lim[0],
            upper: lim[1],
        })
        .collect();
    Ok(Skeleton::new(&parents, origins.rows(), dofs))
}

/// What the engine finds wrong with a link tree, as (link at fault or None, problem), or
/// None when it is sound; see `_engine.pyi`.
#[pyfunction]
pub(crate) fn link_tree_problem(
    parents: Vec<i64>,
    origins: &Bound<'_, PyAny>,
    dof_links: Vec<i64>,
    dof_axes: &Bound<'_, PyAny>,
    dof_limits: &Bound<'_, PyAny>,
) -> PyResult<Option<(Option<usize>, String)>> {
    Ok(
        match skeleton(parents, origins, dof_links, dof_axes, dof_limits)? {
            Ok(_) => None,
            Err(BodyError::BadLink { link, problem }) => Some((Some(link), problem)),
            Err(other) => Some((None, other.to_string())),
        },
    )
}

#[pymethods]
impl Rig {
    #[new]
    #[allow(clippy::too_many_arguments)]
    fn new(
        parents: Vec<i64>,
        origins: &Bound<'_, PyAny>,
        dof_links: Vec<i64>,
        dof_axes: &Bound<'_, PyAny>,
        dof_limits: &Bound<'_, PyAny>,
        vertices: &Bound<'_, PyAny>,
        normals: &Bound<'_, PyAny>,
        weight_links: &Bound<'_, PyAny>,
        weights: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        use crate::call::IntoPyErr;
        let skeleton = skeleton(parents, origins, dof_links, dof_axes, dof_limits)?
            .map_err(IntoPyErr::into_py_err)?;
        let np = weights.py().import("numpy")?;
        let shape: Vec<usize> = np.call_method1("shape", (weights,))?.extract()?;
        let k = match shape.as_slice() {
            [_, k] if *k >= 1 => *k,
            _ => {
                return Err(ArrayError::new_err(format!(
                    "weights must have shape (V, K) with K >= 1, got {shape:?}"
                )));
            }
        };
        let index = arrays::flat_indices(weight_links, "weight_links", k, skeleton.n_links())?;
        let weight = arrays::flat_floats(weights, "weights", &[k])?;
        let sw = SkinWeights { k, index, weight };
        let vertices = rows3(vertices, "vertices")?;
        let normals = rows3(normals, "normals")?;
        let rig = EngineRig::new(skeleton, vertices.rows(), normals.rows(), sw)
            .map_err(IntoPyErr::into_py_err)?;
        Ok(Rig { rig })
    }

    /// Number of joint DOF.
    #[getter]
    fn n_dofs(&self) -> usize {
        self.rig.skeleton().n_dofs()
    }

    /// Poses the mesh: (vertices (V, 3), normals (V, 3), joint centres (L, 3), link
    /// rotations (L, 3, 3)), all in the world frame.
    #[pyo3(signature = (theta, root_rotation=None, root_translation=None, threads=None))]
    fn pose<'py>(
        &self,
        py: Python<'py>,
        theta: Vec<f64>,
        root_rotation: Option<&Bound<'py, PyAny>>,
        root_translation: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
    ) -> PyResult<(F64Array<'py>, F64Array<'py>, F64Array<'py>, F64Array<'py>)> {
        let root = root_pose(root_rotation, root_translation)?;
        let threads = arrays::threads(threads)?;
        let posed = detached(py, || self.rig.pose(&theta, &root, threads))?;
        let (centres, rotations) = world_frames(py, &posed.skeleton, &root)?;
        Ok((
            to_numpy(py, &posed.vertices, &[3])?,
            to_numpy(py, &posed.normals, &[3])?,
            centres,
            rotations,
        ))
    }

    /// The links alone, as :meth:`pose` gives them without the mesh: (joint centres
    /// (L, 3), link rotations (L, 3, 3)) in the world frame.
    #[pyo3(signature = (theta, root_rotation=None, root_translation=None))]
    fn frames<'py>(
        &self,
        py: Python<'py>,
        theta: Vec<f64>,
        root_rotation: Option<&Bound<'py, PyAny>>,
        root_translation: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(F64Array<'py>, F64Array<'py>)> {
        let root = root_pose(root_rotation, root_translation)?;
        let skeleton = detached(py, || {
            root.validate()?;
            self.rig.skeleton().forward(&theta)
        })?;
        world_frames(py, &skeleton, &root)
    }

    /// ∂(world vertex)/∂(parameter), shape (V, 6 + n_dofs, 3); parameters ordered
    /// (tx, ty, tz, ωx, ωy, ωz, θ…), rotations as R ← exp([ω]×)·R.
    #[pyo3(signature = (theta, root_rotation=None, root_translation=None, threads=None))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Vec<f64>,
        root_rotation: Option<&Bound<'py, PyAny>>,
        root_translation: Option<&Bound<'py, PyAny>>,
        threads: Option<i64>,
    ) -> PyResult<F64Array<'py>> {
        let root = root_pose(root_rotation, root_translation)?;
        let threads = arrays::threads(threads)?;
        let jac = detached(py, || self.rig.jacobian(&theta, &root, threads))?;
        let shape = [self.rig.n_vertices(), self.rig.n_params(), 3];
        flat_to_numpy(py, jac.as_flattened().to_vec(), &shape)
    }
}

/// A rig whose proportions are parameters (`hullcap_body::Shape`); see `_engine.pyi`.
#[pyclass(module = "hullcap._engine", name = "Shape", frozen)]
pub(crate) struct Shape {
    pub(crate) shape: EngineShape,
}

#[pymethods]
impl Shape {
    #[new]
    fn new(
        rig: PyRef<'_, Rig>,
        stretches: Vec<Vec<(i64, Bound<'_, PyAny>)>>,
        shifts: Vec<Vec<(i64, Bound<'_, PyAny>)>>,
        centres: Vec<Vec<(i64, Bound<'_, PyAny>)>>,
    ) -> PyResult<Self> {
        use crate::call::IntoPyErr;
        if stretches.len() != shifts.len() || shifts.len() != centres.len() {
            return Err(ArrayError::new_err(format!(
                "stretches, shifts and centres must list the same parameters: {}, {} and {}",
                stretches.len(),
                shifts.len(),
                centres.len()
            )));
        }
        let link = |j: i64| {
            usize::try_from(j)
                .map_err(|_| ArrayError::new_err(format!("shape: link index {j} is negative")))
        };
        let mut params = Vec::with_capacity(stretches.len());
        let vector = |c: &Bound<'_, PyAny>, what| -> PyResult<Vector3<f64>> {
            Ok(Vector3::from(one_array::<3>(c, what, "3 values")?))
        };
        for ((st, sh), ce) in stretches.iter().zip(&shifts).zip(&centres) {
            let mut p = ShapeParameter::default();
            for (j, m) in st {
                let stretch = one_array::<9>(m, "shape stretch", "a 3×3 matrix")?;
                p.stretches
                    .push((link(*j)?, Matrix3::from_row_slice(&stretch)));
            }
            for (j, c) in sh {
                p.shifts.push((link(*j)?, vector(c, "shape shift")?));
            }
            for (j, e) in ce {
                p.centres.push((link(*j)?, vector(e, "shape centre")?));
            }
            params.push(p);
        }
        let shape = EngineShape::new(rig.rig.clone(), &params).map_err(IntoPyErr::into_py_err)?;
        Ok(Shape { shape })
    }

    /// Number of shape parameters.
    #[getter]
    fn n_params(&self) -> usize {
        self.shape.n_params()
    }

    /// The rest body at `shape`: (joint centres (L, 3), vertices (V, 3)), body frame.
    fn rest<'py>(
        &self,
        py: Python<'py>,
        shape: Vec<f64>,
    ) -> PyResult<(F64Array<'py>, F64Array<'py>)> {
        let rig = detached(py, || self.shape.rig(&shape))?;
        let origins: Vec<[f64; 3]> = (0..rig.skeleton().n_links())
            .map(|j| rig.skeleton().origin(j).into())
            .collect();
        let vertices: Vec<[f64; 3]> = rig.rest_vertices().iter().map(|v| (*v).into()).collect();
        Ok((
            to_numpy(py, &origins, &[3])?,
            to_numpy(py, &vertices, &[3])?,
        ))
    }

    /// Rest points bound to `links` (one each) mapped to the body at `shape`: (N, 3).
    fn map_points<'py>(
        &self,
        py: Python<'py>,
        shape: Vec<f64>,
        links: Vec<usize>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<F64Array<'py>> {
        let points = rows3(points, "points")?;
        let p = points.rows();
        let mapped = detached(py, || self.shape.map_points(&shape, &links, p))?;
        to_numpy(py, &mapped, &[3])
    }
}
