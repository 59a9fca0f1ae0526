//! Skinning (the paper's eq. 2) under a root motion, and its analytic derivatives.

use crate::BodyError;
use crate::skeleton::{Skeleton, SkeletonPose};
use nalgebra::{Matrix3, Vector3};

/// K-sparse skin weights: vertex i's weights are `weight[i*k..(i+1)*k]` on the links
/// `index[i*k..(i+1)*k]`, largest first, summing to 1.
#[derive(Debug, Clone, PartialEq)]
pub struct SkinWeights {
    /// Weights per vertex.
    pub k: usize,
    /// Link of each weight.
    pub index: Vec<u32>,
    /// The weights.
    pub weight: Vec<f64>,
}

/// The root motion: world = R · body + t (t is the pelvis joint's world position when the
/// pelvis is the body frame's origin).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootPose {
    /// Rotation R (orthonormal, det +1).
    pub rotation: Matrix3<f64>,
    /// Translation t, metres.
    pub translation: Vector3<f64>,
}

impl Default for RootPose {
    fn default() -> Self {
        RootPose {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }
}

impl RootPose {
    /// Checks that the rotation is one (to 1e-6) and everything is finite.
    pub fn validate(&self) -> Result<(), BodyError> {
        if !self.translation.iter().all(|x| x.is_finite()) {
            return Err(BodyError::NotFinite {
                array: "root_translation",
                row: 0,
            });
        }
        if !self.rotation.iter().all(|x| x.is_finite()) {
            return Err(BodyError::NotFinite {
                array: "root_rotation",
                row: 0,
            });
        }
        let deviation = (self.rotation.transpose() * self.rotation - Matrix3::identity())
            .abs()
            .max();
        let det = self.rotation.determinant();
        if deviation > 1e-6 || det < 0.0 {
            return Err(BodyError::NotARotation { deviation, det });
        }
        Ok(())
    }
}

/// A rigged mesh: skeleton, rest mesh (body frame) and skin weights.
#[derive(Debug, Clone)]
pub struct Rig {
    skeleton: Skeleton,
    rest_vertices: Vec<Vector3<f64>>,
    rest_normals: Vec<Vector3<f64>>,
    weights: SkinWeights,
}

/// A posed rig in the world frame.
#[derive(Debug, Clone)]
pub struct Posed {
    /// Deformed vertices m′_i, world.
    pub vertices: Vec<[f64; 3]>,
    /// Their unit normals (the blended rotation applied to the rest normal, renormalised).
    pub normals: Vec<[f64; 3]>,
    /// The skeleton's pose, body frame.
    pub skeleton: SkeletonPose,
}

/// Vertices per chunk below which a pose is not worth another thread.
const MIN_VERTICES_PER_THREAD: usize = 1024;

/// Most skin weights a vertex may have (K): the paper's blends need a few, and a fixed
/// bound keeps the per-vertex work on the stack.
pub const MAX_WEIGHTS: usize = 16;

impl Rig {
    /// A rig from a skeleton, rest vertices and normals (body frame) and weights.
    pub fn new(
        skeleton: Skeleton,
        rest_vertices: &[[f64; 3]],
        rest_normals: &[[f64; 3]],
        weights: SkinWeights,
    ) -> Result<Self, BodyError> {
        let nv = rest_vertices.len();
        crate::error::check_finite(rest_vertices, "vertices")?;
        crate::error::check_finite(rest_normals, "normals")?;
        if rest_normals.len() != nv {
            return Err(BodyError::WrongLength {
                array: "normals",
                got: rest_normals.len(),
                expected: nv,
            });
        }
        if weights.k > MAX_WEIGHTS {
            return Err(BodyError::BadParameter {
                name: "skin weights per vertex (k)",
                requirement: "at most 16",
                value: weights.k as f64,
            });
        }
        if weights.k == 0
            || weights.index.len() != nv * weights.k
            || weights.weight.len() != nv * weights.k
        {
            return Err(BodyError::WrongLength {
                array: "skin weights",
                got: weights.index.len(),
                expected: nv * weights.k.max(1),
            });
        }
        if let Some(row) = weights
            .index
            .iter()
            .position(|&j| j as usize >= skeleton.n_links())
        {
            return Err(BodyError::IndexOutOfRange {
                array: "skin weight links",
                row: row / weights.k,
                index: i64::from(weights.index[row]),
                bound: skeleton.n_links(),
            });
        }
        if let Some(row) = weights.weight.iter().position(|w| !w.is_finite()) {
            return Err(BodyError::NotFinite {
                array: "skin weights",
                row: row / weights.k,
            });
        }
        Ok(Rig {
            skeleton,
            rest_vertices: rest_vertices.iter().map(|v| Vector3::from(*v)).collect(),
            rest_normals: rest_normals.iter().map(|v| Vector3::from(*v)).collect(),
            weights,
        })
    }

    /// The skeleton.
    pub fn skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    /// The rest vertices, body frame.
    pub fn rest_vertices(&self) -> &[Vector3<f64>] {
        &self.rest_vertices
    }

    /// The rest normals (unit), body frame.
    pub fn rest_normals(&self) -> &[Vector3<f64>] {
        &self.rest_normals
    }

    /// The skin weights.
    pub fn weights(&self) -> &SkinWeights {
        &self.weights
    }

    /// Vertex `i`'s weights as (link, weight) pairs.
    #[inline]
    pub fn vertex_weights(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let k = self.weights.k;
        (0..k).map(move |c| {
            (
                self.weights.index[i * k + c] as usize,
                self.weights.weight[i * k + c],
            )
        })
    }

    /// The link vertex `i` is bound to most.
    #[inline]
    pub fn dominant_link(&self, i: usize) -> usize {
        let k = self.weights.k;
        (0..k)
            .max_by(|&a, &b| {
                self.weights.weight[i * k + a].total_cmp(&self.weights.weight[i * k + b])
            })
            .map_or(0, |c| self.weights.index[i * k + c] as usize)
    }

    /// The same weights on another skeleton and rest mesh (the same vertex count; used
    /// for a body with other proportions, whose validation the weights already passed).
    pub(crate) fn reshaped(
        &self,
        skeleton: Skeleton,
        rest_vertices: Vec<Vector3<f64>>,
        rest_normals: Vec<Vector3<f64>>,
    ) -> Rig {
        debug_assert_eq!(rest_vertices.len(), self.rest_vertices.len());
        Rig {
            skeleton,
            rest_vertices,
            rest_normals,
            weights: self.weights.clone(),
        }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.rest_vertices.len()
    }

    /// Number of parameters of [`Rig::jacobian`]: 3 translation + 3 rotation + joint DOF.
    pub fn n_params(&self) -> usize {
        6 + self.skeleton.n_dofs()
    }

    /// Vertex i skinned in the body frame: Σ_k w_k T_jk(θ) T_jk(0)⁻¹ m_i, computed as
    /// m_i + Σ_k w_k · (offset by link j_k) so that it is m_i exactly at rest (the weights
    /// sum to 1 only up to rounding).
    #[inline]
    pub fn skin_vertex(&self, pose: &SkeletonPose, i: usize) -> Vector3<f64> {
        let k = self.weights.k;
        let m = &self.rest_vertices[i];
        m + (0..k).fold(Vector3::zeros(), |acc, c| {
            let j = self.weights.index[i * k + c] as usize;
            acc + self.weights.weight[i * k + c] * pose.skin_offset(&self.skeleton, j, m)
        })
    }

    /// Vertex i and its unit normal posed in the world: the skinned vertex under the root
    /// motion, and the rest normal turned by the weight-blended link rotation.
    #[inline]
    pub fn posed_vertex(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        i: usize,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let k = self.weights.k;
        let mut blended = Matrix3::zeros();
        for c in 0..k {
            let j = self.weights.index[i * k + c] as usize;
            blended += self.weights.weight[i * k + c] * pose.rotation[j];
        }
        let v = root.rotation * self.skin_vertex(pose, i) + root.translation;
        let n = root.rotation * (blended * self.rest_normals[i]);
        (v, n / n.norm().max(f64::MIN_POSITIVE))
    }

    /// Poses every vertex and normal for joint angles `theta` and the root motion.
    pub fn pose(
        &self,
        theta: &[f64],
        root: &RootPose,
        threads: Option<usize>,
    ) -> Result<Posed, BodyError> {
        root.validate()?;
        let skeleton = self.skeleton.forward(theta)?;
        let nv = self.n_vertices();
        let mut out = vec![([0.0; 3], [0.0; 3]); nv];
        let threads = hullcap_core::resolve_threads(threads);
        hullcap_core::for_each_chunk_mut(
            &mut out,
            threads,
            MIN_VERTICES_PER_THREAD,
            |offset, chunk| {
                for (r, slot) in chunk.iter_mut().enumerate() {
                    let (v, n) = self.posed_vertex(&skeleton, root, offset + r);
                    *slot = (v.into(), n.into());
                }
            },
        )?;
        let (vertices, normals) = out.into_iter().unzip();
        Ok(Posed {
            vertices,
            normals,
            skeleton,
        })
    }

    /// ∂(world vertex)/∂(parameter) for every vertex, row-major V × P × 3 with the
    /// P = [`Rig::n_params`] parameters ordered (tx, ty, tz, ωx, ωy, ωz, θ_1 … θ_n).
    ///
    /// Root rotation derivatives are for R ← exp([ω]×)·R, i.e. ∂x/∂ω_a = e_a × (R m′);
    /// a joint DOF with body-frame axis a through joint centre o moves vertex i by
    /// R · Σ_{links j below the DOF} w_ij · a × (T_j(θ)T_j(0)⁻¹ m_i − o).
    pub fn jacobian(
        &self,
        theta: &[f64],
        root: &RootPose,
        threads: Option<usize>,
    ) -> Result<Vec<[f64; 3]>, BodyError> {
        root.validate()?;
        let skeleton = self.skeleton.forward(theta)?;
        let p = self.n_params();
        let mut out = vec![[0.0; 3]; self.n_vertices() * p];
        let mut rows: Vec<&mut [[f64; 3]]> = out.chunks_mut(p).collect();
        let threads = hullcap_core::resolve_threads(threads);
        hullcap_core::for_each_chunk_mut(
            &mut rows,
            threads,
            MIN_VERTICES_PER_THREAD / 4,
            |offset, chunk| {
                for (r, row) in chunk.iter_mut().enumerate() {
                    self.vertex_jacobian(&skeleton, root, offset + r, row);
                }
            },
        )?;
        Ok(out)
    }

    /// One vertex's row of [`Rig::jacobian`], written into `row` (P entries).
    pub fn vertex_jacobian(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        i: usize,
        row: &mut [[f64; 3]],
    ) {
        let all: Vec<usize> = (0..self.n_params()).collect();
        self.vertex_jacobian_columns(pose, root, i, &all, row);
    }

    /// The columns `params` (indices into (tx, ty, tz, ωx, ωy, ωz, θ…)) of vertex `i`'s
    /// Jacobian row, one per entry of `params`, into `out`. A fit stage that moves a few
    /// parameters asks only for those.
    pub fn vertex_jacobian_columns(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        i: usize,
        params: &[usize],
        out: &mut [[f64; 3]],
    ) {
        let k = self.weights.k;
        let links = &self.weights.index[i * k..(i + 1) * k];
        let weights = &self.weights.weight[i * k..(i + 1) * k];
        let m = self.rest_vertices[i];
        // Where each of the vertex's links puts it, and the blend of those.
        let mut placed = [Vector3::zeros(); MAX_WEIGHTS];
        let mut skinned = m;
        for ((slot, &j), &w) in placed.iter_mut().zip(links).zip(weights) {
            let offset = pose.skin_offset(&self.skeleton, j as usize, &m);
            *slot = m + offset;
            skinned += w * offset;
        }
        let world = root.rotation * skinned;
        let dofs = self.skeleton.dofs();
        // The DOFs of one link come one after another and share the blend of the
        // placements that turn with that link: it is summed once per link.
        let mut last: Option<(usize, Vector3<f64>, f64)> = None;
        for (slot, &p) in out.iter_mut().zip(params) {
            *slot = match p {
                0..=2 => Vector3::ith(p, 1.0),
                3..=5 => Vector3::ith(p - 3, 1.0).cross(&world),
                _ => {
                    let d = p - 6;
                    let link = dofs[d].link;
                    let (moved, weight) = match last {
                        Some((l, moved, weight)) if l == link => (moved, weight),
                        _ => {
                            let mut moved = Vector3::zeros();
                            let mut weight = 0.0;
                            for ((at, &j), &w) in placed.iter().zip(links).zip(weights) {
                                if self.skeleton.moves_with(j as usize, link) {
                                    moved += w * at;
                                    weight += w;
                                }
                            }
                            last = Some((link, moved, weight));
                            (moved, weight)
                        }
                    };
                    if weight == 0.0 {
                        // Most of a vertex's columns: a DOF none of its weighted links turns with.
                        Vector3::zeros()
                    } else {
                        root.rotation
                            * pose.dof_axis[d].cross(&(moved - weight * pose.position[link]))
                    }
                }
            }
            .into();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::blended_rig;
    use nalgebra::{Rotation3, Unit};

    fn rig() -> Rig {
        blended_rig(30, 0.1, 0.3)
    }

    fn root() -> RootPose {
        RootPose {
            rotation: Rotation3::from_euler_angles(0.3, -0.2, 1.1).into_inner(),
            translation: Vector3::new(0.5, -1.0, 2.0),
        }
    }

    #[test]
    fn zero_pose_gives_the_rest_mesh_exactly() {
        let r = rig();
        let posed = r.pose(&[0.0; 3], &RootPose::default(), None).unwrap();
        for (p, m) in posed.vertices.iter().zip(&r.rest_vertices) {
            assert_eq!(Vector3::from(*p), *m);
        }
        for (n, m) in posed.normals.iter().zip(&r.rest_normals) {
            assert!((Vector3::from(*n) - m.normalize()).norm() < 1e-15);
        }
    }

    #[test]
    fn a_root_motion_moves_the_mesh_rigidly() {
        let r = rig();
        let theta = [0.4, -0.3, 0.7];
        let body = r.pose(&theta, &RootPose::default(), None).unwrap();
        let world = r.pose(&theta, &root(), Some(3)).unwrap();
        let root = root();
        for (b, w) in body.vertices.iter().zip(&world.vertices) {
            let want = root.rotation * Vector3::from(*b) + root.translation;
            assert!((want - Vector3::from(*w)).norm() < 1e-12);
        }
    }

    #[test]
    fn analytic_derivatives_match_finite_differences() {
        let r = rig();
        let theta = [0.4, -0.3, 0.7];
        let root = root();
        let jac = r.jacobian(&theta, &root, Some(2)).unwrap();
        let p = r.n_params();
        let h = 1e-6;
        let at = |theta: &[f64], root: &RootPose| r.pose(theta, root, None).unwrap().vertices;
        for param in 0..p {
            let (mut plus, mut minus) = ((theta, root), (theta, root));
            match param {
                0..3 => {
                    plus.1.translation[param] += h;
                    minus.1.translation[param] -= h;
                }
                3..6 => {
                    let axis = Unit::new_normalize(Vector3::ith(param - 3, 1.0));
                    plus.1.rotation =
                        Rotation3::from_axis_angle(&axis, h).into_inner() * root.rotation;
                    minus.1.rotation =
                        Rotation3::from_axis_angle(&axis, -h).into_inner() * root.rotation;
                }
                d => {
                    plus.0[d - 6] += h;
                    minus.0[d - 6] -= h;
                }
            }
            let (vp, vm) = (at(&plus.0, &plus.1), at(&minus.0, &minus.1));
            for i in 0..r.n_vertices() {
                let fd = (Vector3::from(vp[i]) - Vector3::from(vm[i])) / (2.0 * h);
                let an = Vector3::from(jac[i * p + param]);
                assert!(
                    (fd - an).norm() < 1e-7,
                    "param {param}, vertex {i}: {fd:?} vs {an:?}"
                );
            }
        }
    }

    #[test]
    fn bad_poses_are_refused() {
        let r = rig();
        let skew = RootPose {
            rotation: Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
            ..RootPose::default()
        };
        assert!(matches!(
            r.pose(&[0.0; 3], &skew, None),
            Err(BodyError::NotARotation { .. })
        ));
        let mirror = RootPose {
            rotation: -Matrix3::identity(),
            ..RootPose::default()
        };
        assert!(matches!(
            r.pose(&[0.0; 3], &mirror, None),
            Err(BodyError::NotARotation { .. })
        ));
        assert!(matches!(
            r.pose(&[0.0; 2], &RootPose::default(), None),
            Err(BodyError::WrongLength { array: "theta", .. })
        ));
        assert!(matches!(
            r.pose(&[0.0, f64::NAN, 0.0], &RootPose::default(), None),
            Err(BodyError::NotFinite {
                array: "theta",
                row: 1
            })
        ));
    }
}
