//! Body proportions as parameters: the rest body as a linear function of a shape vector.
//!
//! A shape vector s (one entry per [`ShapeParameter`], 0 = the base body) gives every
//! link j a linear *stretch* S_j(s) = I + Σ_p s_p·P_pj about its joint centre, and places
//! each link's frame with its parent's stretch plus a *shift* Σ_p s_p·c_pj:
//!
//! f_j(s) = f_q(s) + S_q(s)·(o_j⁰ − o_q⁰) + Σ_p s_p·c_pj        (q = parent of j)
//!
//! A rest point x bound to link j maps to f_j(s) + S_j(s)·(x − o_j⁰), and a skinned rest
//! vertex to the weighted sum over its links, m_i(s) = Σ_k w_ik (f_jk(s) + S_jk(s)(m_i⁰ − o_jk⁰)).
//! The link turns about its joint centre o_j(s) = f_j(s) + Σ_p s_p·e_pj: a *centre move* e
//! moves where the joint rotates without moving the surface or the joints below it (where
//! the knee sits inside a leg of a given shape). Everything is linear in s, so ∂f/∂s, ∂o/∂s
//! and ∂m_i/∂s are constants. A length scale of link j is P = u uᵀ (u its segment's
//! direction), a girth scale P = I − u uᵀ, a width or depth scale the projector on one
//! axis across the segment; a shift moves a joint and everything below it by c metres per
//! unit of s.
//!
//! Posed under θ and the root (R, t), a vertex is v_i = R·Σ_k w_ik (R_jk (m_i − o_jk) + p_jk)
//! + t with the joint centres p_j = p_q + R_q (o_j − o_q) of forward kinematics, whence
//!
//! ∂v_i/∂s_p = R·Σ_k w_ik (R_jk (∂m_i/∂s_p − ∂o_jk/∂s_p) + ∂p_jk/∂s_p),
//! ∂p_j/∂s_p = ∂p_q/∂s_p + R_q (∂o_j/∂s_p − ∂o_q/∂s_p).

use crate::skeleton::SkeletonPose;
use crate::{BodyError, Rig, RootPose};
use nalgebra::{Matrix3, Vector3};

/// One shape parameter: how a unit of it stretches links and shifts joints.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ShapeParameter {
    /// `(link, P)`: a unit of the parameter adds P to the link's stretch S_j.
    pub stretches: Vec<(usize, Matrix3<f64>)>,
    /// `(link, c)`: a unit of the parameter moves the link's joint centre by c (metres,
    /// body frame) beyond where its parent puts it; its subtree follows.
    pub shifts: Vec<(usize, Vector3<f64>)>,
    /// `(link, e)`: a unit of the parameter moves the link's joint centre by e (metres,
    /// body frame) and nothing else: the surface and the joints below stay.
    pub centres: Vec<(usize, Vector3<f64>)>,
}

/// A rig whose proportions are parameters (see the module documentation).
#[derive(Debug, Clone)]
pub struct Shape {
    base: Rig,
    n_params: usize,
    /// P_pj, row-major link × parameter.
    stretch: Vec<Matrix3<f64>>,
    /// ∂f_j/∂s_p (constant): where the link's frame carries its surface, link × parameter.
    d_frame: Vec<Vector3<f64>>,
    /// ∂o_j/∂s_p (constant): the joint centre it turns about, link × parameter.
    d_origin: Vec<Vector3<f64>>,
}

impl Shape {
    /// The base rig (s = 0) with its shape parameters.
    pub fn new(base: Rig, params: &[ShapeParameter]) -> Result<Self, BodyError> {
        let nl = base.skeleton().n_links();
        let np = params.len();
        let mut stretch = vec![Matrix3::zeros(); nl * np];
        let mut shift = vec![Vector3::zeros(); nl * np];
        let mut centre = vec![Vector3::zeros(); nl * np];
        for (p, param) in params.iter().enumerate() {
            for (row, &(j, m)) in param.stretches.iter().enumerate() {
                check_link(j, nl, "shape stretch links", row)?;
                if !m.iter().all(|x| x.is_finite()) {
                    return Err(BodyError::NotFinite {
                        array: "shape stretches",
                        row,
                    });
                }
                stretch[j * np + p] += m;
            }
            for (row, &(j, c)) in param.shifts.iter().enumerate() {
                check_link(j, nl, "shape shift links", row)?;
                if !c.iter().all(|x| x.is_finite()) {
                    return Err(BodyError::NotFinite {
                        array: "shape shifts",
                        row,
                    });
                }
                shift[j * np + p] += c;
            }
            for (row, &(j, e)) in param.centres.iter().enumerate() {
                check_link(j, nl, "shape centre links", row)?;
                if !e.iter().all(|x| x.is_finite()) {
                    return Err(BodyError::NotFinite {
                        array: "shape centres",
                        row,
                    });
                }
                centre[j * np + p] += e;
            }
        }
        let skeleton = base.skeleton();
        let mut d_frame = vec![Vector3::zeros(); nl * np];
        for j in 0..nl {
            for p in 0..np {
                d_frame[j * np + p] = shift[j * np + p]
                    + match skeleton.parent(j) {
                        None => Vector3::zeros(),
                        Some(q) => {
                            d_frame[q * np + p]
                                + stretch[q * np + p] * (skeleton.origin(j) - skeleton.origin(q))
                        }
                    };
            }
        }
        let d_origin = d_frame.iter().zip(&centre).map(|(f, e)| f + e).collect();
        Ok(Shape {
            base,
            n_params: np,
            stretch,
            d_frame,
            d_origin,
        })
    }

    /// Number of shape parameters.
    pub fn n_params(&self) -> usize {
        self.n_params
    }

    /// The rig at s = 0.
    pub fn base(&self) -> &Rig {
        &self.base
    }

    fn check(&self, s: &[f64]) -> Result<(), BodyError> {
        if s.len() != self.n_params {
            return Err(BodyError::WrongLength {
                array: "shape",
                got: s.len(),
                expected: self.n_params,
            });
        }
        match s.iter().position(|x| !x.is_finite()) {
            Some(row) => Err(BodyError::NotFinite {
                array: "shape",
                row,
            }),
            None => Ok(()),
        }
    }

    /// S_j(s) − I.
    fn stretch_delta(&self, s: &[f64], j: usize) -> Matrix3<f64> {
        let np = self.n_params;
        (0..np).fold(Matrix3::zeros(), |acc, p| {
            acc + s[p] * self.stretch[j * np + p]
        })
    }

    /// Σ_p s_p·d[j][p] for a link × parameter table `d`.
    fn delta(&self, d: &[Vector3<f64>], s: &[f64], j: usize) -> Vector3<f64> {
        let np = self.n_params;
        (0..np).fold(Vector3::zeros(), |acc, p| acc + s[p] * d[j * np + p])
    }

    /// Every link's joint centre at `s`, body frame.
    pub fn origins(&self, s: &[f64]) -> Result<Vec<Vector3<f64>>, BodyError> {
        self.check(s)?;
        let skeleton = self.base.skeleton();
        Ok((0..skeleton.n_links())
            .map(|j| skeleton.origin(j) + self.delta(&self.d_origin, s, j))
            .collect())
    }

    /// Rest points `x⁰` bound to `links` (one each), mapped to the body at `s`.
    pub fn map_points(
        &self,
        s: &[f64],
        links: &[usize],
        points: &[[f64; 3]],
    ) -> Result<Vec<[f64; 3]>, BodyError> {
        self.check(s)?;
        let skeleton = self.base.skeleton();
        let nl = skeleton.n_links();
        if links.len() != points.len() {
            return Err(BodyError::WrongLength {
                array: "point links",
                got: links.len(),
                expected: points.len(),
            });
        }
        crate::error::check_finite(points, "points")?;
        links
            .iter()
            .zip(points)
            .enumerate()
            .map(|(row, (&j, x))| {
                check_link(j, nl, "point links", row)?;
                let x = Vector3::from(*x);
                let arm = x - skeleton.origin(j);
                Ok((x + self.delta(&self.d_frame, s, j) + self.stretch_delta(s, j) * arm).into())
            })
            .collect()
    }

    /// The rig at `s`: its skeleton's joint centres, rest vertices m_i(s) and normals moved
    /// by the blended inverse-transpose stretch; the skin weights are kept.
    pub fn rig(&self, s: &[f64]) -> Result<Rig, BodyError> {
        let origins = self.origins(s)?;
        let skeleton = self.base.skeleton().with_origins(&origins)?;
        let nl = skeleton.n_links();
        let offsets: Vec<Vector3<f64>> = (0..nl).map(|j| self.delta(&self.d_frame, s, j)).collect();
        let stretches: Vec<Matrix3<f64>> = (0..nl).map(|j| self.stretch_delta(s, j)).collect();
        let normal_maps: Vec<Matrix3<f64>> = stretches
            .iter()
            .map(|d| {
                let full = Matrix3::identity() + d;
                full.try_inverse()
                    .map_or(Matrix3::identity(), |inv| inv.transpose())
            })
            .collect();
        let base = &self.base;
        let mut vertices = Vec::with_capacity(base.n_vertices());
        let mut normals = Vec::with_capacity(base.n_vertices());
        for (i, (m, n)) in base
            .rest_vertices()
            .iter()
            .zip(base.rest_normals())
            .enumerate()
        {
            let mut moved = *m;
            let mut normal = Vector3::zeros();
            for (j, w) in base.vertex_weights(i) {
                moved += w * (offsets[j] + stretches[j] * (m - base.skeleton().origin(j)));
                normal += w * (normal_maps[j] * n);
            }
            vertices.push(moved);
            normals.push(normal / normal.norm().max(f64::MIN_POSITIVE));
        }
        Ok(base.reshaped(skeleton, vertices, normals))
    }

    /// ∂m_i/∂s_p for every parameter, into `out` (one entry per parameter).
    fn rest_derivative(&self, i: usize, out: &mut [Vector3<f64>]) {
        let np = self.n_params;
        let base = &self.base;
        let m = base.rest_vertices()[i];
        out.iter_mut().for_each(|o| *o = Vector3::zeros());
        for (j, w) in base.vertex_weights(i) {
            let arm = m - base.skeleton().origin(j);
            for (p, o) in out.iter_mut().enumerate() {
                *o += w * (self.d_frame[j * np + p] + self.stretch[j * np + p] * arm);
            }
        }
    }

    /// ∂p_j/∂s_p of every link's posed joint centre (body frame), link × parameter.
    pub fn pose_derivatives(&self, pose: &SkeletonPose) -> Vec<Vector3<f64>> {
        let np = self.n_params;
        let skeleton = self.base.skeleton();
        let mut d = vec![Vector3::zeros(); skeleton.n_links() * np];
        for j in 0..skeleton.n_links() {
            for p in 0..np {
                d[j * np + p] = match skeleton.parent(j) {
                    None => self.d_origin[j * np + p],
                    Some(q) => {
                        d[q * np + p]
                            + pose.rotation[q]
                                * (self.d_origin[j * np + p] - self.d_origin[q * np + p])
                    }
                };
            }
        }
        d
    }

    /// ∂v_i/∂s of posed world vertex `i`, one entry per parameter, into `out`. `pose` is
    /// the forward kinematics of the rig at the current shape, `d_pose` its
    /// [`Shape::pose_derivatives`]; `scratch` holds `n_params` vectors.
    pub fn vertex_jacobian(
        &self,
        pose: &SkeletonPose,
        d_pose: &[Vector3<f64>],
        root: &RootPose,
        i: usize,
        scratch: &mut [Vector3<f64>],
        out: &mut [[f64; 3]],
    ) {
        let np = self.n_params;
        self.rest_derivative(i, scratch);
        let total: f64 = self.base.vertex_weights(i).map(|(_, w)| w).sum();
        for (p, o) in out.iter_mut().enumerate() {
            // skin_vertex = m + Σ w [(R_j − I)(m − o_j) + δ_j], δ_j = p_j − o_j.
            let dm = scratch[p];
            let mut d = dm * (1.0 - total);
            for (j, w) in self.base.vertex_weights(i) {
                d += w * (pose.rotation[j] * (dm - self.d_origin[j * np + p]) + d_pose[j * np + p]);
            }
            *o = (root.rotation * d).into();
        }
    }
}

fn check_link(j: usize, n: usize, array: &'static str, row: usize) -> Result<(), BodyError> {
    if j >= n {
        return Err(BodyError::IndexOutOfRange {
            array,
            row,
            index: j as i64,
            bound: n,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rig;
    use crate::testing::{blended_rig, chain_shape_parameters};
    use nalgebra::Rotation3;

    fn rig() -> Rig {
        blended_rig(40, 0.075, 0.55)
    }

    /// Length of link 1 (along x), girth of link 2, a shift of link 2's joint, and a move
    /// of link 1's centre.
    fn params() -> Vec<ShapeParameter> {
        chain_shape_parameters([0.0, 0.1, -0.05], (1, [0.05, 0.02, 0.0]))
    }

    #[test]
    fn zero_shape_is_the_base_and_a_length_moves_the_child_joint() {
        let shape = Shape::new(rig(), &params()).unwrap();
        let at_zero = shape.rig(&[0.0; 4]).unwrap();
        for (a, b) in at_zero
            .rest_vertices()
            .iter()
            .zip(shape.base().rest_vertices())
        {
            assert_eq!(a, b);
        }
        let origins = shape.origins(&[0.5, 0.0, 1.0, 1.0]).unwrap();
        // Link 1 (x = 1 → 2) is 1.5 long; link 2 shifted by (0, 0.1, −0.05); link 1's
        // centre moved by (0.05, 0.02, 0), which moves neither link 2 nor the surface.
        assert!((origins[2] - Vector3::new(2.5, 0.1, -0.05)).norm() < 1e-12);
        assert!((origins[1] - Vector3::new(1.05, 0.02, 0.0)).norm() < 1e-12);
        let s = [0.5, 0.0, 0.0, 1.0];
        let mapped = shape.map_points(&s, &[1], &[[1.5, 0.3, 0.0]]).unwrap();
        assert!((Vector3::from(mapped[0]) - Vector3::new(1.75, 0.3, 0.0)).norm() < 1e-12);
        let moved_centre = shape.rig(&[0.0, 0.0, 0.0, 1.0]).unwrap();
        for (a, b) in moved_centre
            .rest_vertices()
            .iter()
            .zip(shape.base().rest_vertices())
        {
            assert_eq!(a, b);
        }
    }

    /// ∂v/∂s of the posed vertices against central differences of `Shape::rig` then
    /// `Rig::pose`, away from the base shape and under a root motion.
    #[test]
    fn shape_derivatives_match_finite_differences() {
        let shape = Shape::new(rig(), &params()).unwrap();
        let s = [0.2, -0.15, 0.3, 0.7];
        let theta = [0.4, -0.3, 0.7];
        let root = RootPose {
            rotation: Rotation3::from_euler_angles(0.3, -0.2, 1.1).into_inner(),
            translation: Vector3::new(0.5, -1.0, 2.0),
        };
        let at = |s: &[f64]| {
            shape
                .rig(s)
                .unwrap()
                .pose(&theta, &root, Some(1))
                .unwrap()
                .vertices
        };
        let rig_s = shape.rig(&s).unwrap();
        let pose = rig_s.skeleton().forward(&theta).unwrap();
        let d_pose = shape.pose_derivatives(&pose);
        let mut scratch = vec![Vector3::zeros(); 4];
        let mut row = vec![[0.0; 3]; 4];
        let h = 1e-6;
        for p in 0..4 {
            let (mut plus, mut minus) = (s, s);
            plus[p] += h;
            minus[p] -= h;
            let (vp, vm) = (at(&plus), at(&minus));
            for i in 0..rig_s.n_vertices() {
                shape.vertex_jacobian(&pose, &d_pose, &root, i, &mut scratch, &mut row);
                let fd = (Vector3::from(vp[i]) - Vector3::from(vm[i])) / (2.0 * h);
                let an = Vector3::from(row[p]);
                assert!(
                    (fd - an).norm() < 1e-7,
                    "param {p}, vertex {i}: {fd:?} vs {an:?}"
                );
            }
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        let bad = vec![ShapeParameter {
            stretches: vec![(7, Matrix3::identity())],
            ..ShapeParameter::default()
        }];
        assert!(matches!(
            Shape::new(rig(), &bad),
            Err(BodyError::IndexOutOfRange { .. })
        ));
        let shape = Shape::new(rig(), &params()).unwrap();
        assert!(matches!(
            shape.rig(&[0.0; 3]),
            Err(BodyError::WrongLength { array: "shape", .. })
        ));
        assert!(matches!(
            shape.origins(&[0.0, f64::NAN, 0.0, 0.0]),
            Err(BodyError::NotFinite { .. })
        ));
    }
}
