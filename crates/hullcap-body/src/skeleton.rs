//! The link model: a tree of joint links with revolute DOF, and its forward kinematics.

use crate::BodyError;
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use std::ops::Range;

/// One revolute degree of freedom of a joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Dof {
    /// The link this DOF turns (about its joint centre, relative to its parent).
    pub link: usize,
    /// The rotation axis in the link's frame before this DOF's rotation (unit).
    pub axis: Vector3<f64>,
    /// Lower joint limit, radians.
    pub lower: f64,
    /// Upper joint limit, radians.
    pub upper: f64,
}

/// The link tree; link 0 is the root (the pelvis), every parent comes before its children.
///
/// Link j's frame: T_j(θ) = T_parent(j)(θ) · Trans(o_j − o_parent) · R_j1(θ_1) ⋯ R_jn(θ_n),
/// where o_j is j's joint centre at rest (body frame) and R_jk rotates about DOF k's axis;
/// so T_j(0) = Trans(o_j) and a DOF's axis is given in the frame left by the DOF before it.
#[derive(Debug, Clone)]
pub struct Skeleton {
    parent: Vec<Option<usize>>,
    origin: Vec<Vector3<f64>>,
    dofs: Vec<Dof>,
    link_dofs: Vec<Range<usize>>,
    /// `in_subtree[l][j]`: link j is l or a descendant of l (moves when l's DOF turn).
    in_subtree: Vec<Vec<bool>>,
}

/// Forward kinematics of one pose, in the body frame.
#[derive(Debug, Clone)]
pub struct SkeletonPose {
    /// Per link: the rotation of its frame.
    pub rotation: Vec<Matrix3<f64>>,
    /// Per link: how far its joint centre moved from rest, δ_j = p_j − o_j (exactly zero
    /// at rest, so that the zero pose reproduces the rest mesh bit for bit).
    pub displacement: Vec<Vector3<f64>>,
    /// Per link: its joint centre p_j = o_j + δ_j.
    pub position: Vec<Vector3<f64>>,
    /// Per DOF: its axis (unit), through the joint centre of its link.
    pub dof_axis: Vec<Vector3<f64>>,
}

impl Skeleton {
    /// A skeleton from each link's parent (−1 for the root, link 0 only), rest joint centre
    /// (body frame, metres) and the DOF, grouped by link in link order.
    pub fn new(parent: &[i64], origin: &[[f64; 3]], dofs: Vec<Dof>) -> Result<Self, BodyError> {
        let n = parent.len();
        if n == 0 {
            return Err(BodyError::WrongLength {
                array: "parents",
                got: 0,
                expected: 1,
            });
        }
        if origin.len() != n {
            return Err(BodyError::WrongLength {
                array: "origins",
                got: origin.len(),
                expected: n,
            });
        }
        crate::error::check_finite(origin, "origins")?;
        let mut parents = Vec::with_capacity(n);
        for (link, &p) in parent.iter().enumerate() {
            let bad = |problem: String| Err(BodyError::BadLink { link, problem });
            match (link, p) {
                (0, -1) => parents.push(None),
                (0, p) => return bad(format!("the root (link 0) must have parent -1, got {p}")),
                (_, p) if p < 0 => return bad("only link 0 may be a root".into()),
                (_, p) if p as usize >= link => {
                    return bad(format!(
                        "parent {p} must come before the link (a cycle, or unordered links)"
                    ));
                }
                (_, p) => parents.push(Some(p as usize)),
            }
        }
        let mut link_dofs = vec![0..0; n];
        let mut dofs = dofs;
        for (k, dof) in dofs.iter_mut().enumerate() {
            let bad = |problem: String| {
                Err(BodyError::BadLink {
                    link: dof.link,
                    problem,
                })
            };
            if dof.link >= n {
                return Err(BodyError::IndexOutOfRange {
                    array: "dof links",
                    row: k,
                    index: dof.link as i64,
                    bound: n,
                });
            }
            if k > 0 && link_dofs[dof.link].end != k && !link_dofs[dof.link].is_empty() {
                return bad(format!("DOF {k} is not next to the other DOF of its link"));
            }
            let norm = dof.axis.norm();
            if !norm.is_finite() || norm < 1e-9 {
                return bad(format!("DOF {k} has a zero or non-finite axis"));
            }
            dof.axis /= norm;
            if !(dof.lower.is_finite() && dof.upper.is_finite() && dof.lower <= dof.upper) {
                return bad(format!(
                    "DOF {k} has limits [{}, {}] (both finite, radians, lower not above upper)",
                    dof.lower, dof.upper
                ));
            }
            if link_dofs[dof.link].is_empty() {
                link_dofs[dof.link] = k..k + 1;
            } else {
                link_dofs[dof.link].end = k + 1;
            }
        }
        let mut in_subtree = vec![vec![false; n]; n];
        #[allow(clippy::needless_range_loop)] // j is a link, marked in its ancestors' rows
        for j in 0..n {
            // Walk up from j, marking j as below each ancestor.
            let mut ancestor = Some(j);
            while let Some(l) = ancestor {
                in_subtree[l][j] = true;
                ancestor = parents[l];
            }
        }
        Ok(Skeleton {
            parent: parents,
            origin: origin.iter().map(|o| Vector3::from(*o)).collect(),
            dofs,
            link_dofs,
            in_subtree,
        })
    }

    /// Number of links.
    pub fn n_links(&self) -> usize {
        self.parent.len()
    }

    /// Number of joint DOF (the root's 6 are not counted).
    pub fn n_dofs(&self) -> usize {
        self.dofs.len()
    }

    /// The DOF, in order.
    pub fn dofs(&self) -> &[Dof] {
        &self.dofs
    }

    /// Link `j`'s joint centre at rest, body frame.
    pub fn origin(&self, j: usize) -> Vector3<f64> {
        self.origin[j]
    }

    /// Link `j`'s parent (`None` for the root).
    pub fn parent(&self, j: usize) -> Option<usize> {
        self.parent[j]
    }

    /// The same tree and DOF with other rest joint centres (`origins`, one per link).
    pub fn with_origins(&self, origins: &[Vector3<f64>]) -> Result<Skeleton, BodyError> {
        if origins.len() != self.n_links() {
            return Err(BodyError::WrongLength {
                array: "origins",
                got: origins.len(),
                expected: self.n_links(),
            });
        }
        if let Some(row) = origins
            .iter()
            .position(|o| !o.iter().all(|x| x.is_finite()))
        {
            return Err(BodyError::NotFinite {
                array: "origins",
                row,
            });
        }
        Ok(Skeleton {
            origin: origins.to_vec(),
            ..self.clone()
        })
    }

    /// Whether link `j` moves with link `l` (is `l` or below it).
    pub fn moves_with(&self, j: usize, l: usize) -> bool {
        self.in_subtree[l][j]
    }

    /// `theta` clamped into the joint limits.
    pub fn clamp(&self, theta: &mut [f64]) {
        for (t, d) in theta.iter_mut().zip(&self.dofs) {
            *t = t.clamp(d.lower, d.upper);
        }
    }

    /// Forward kinematics: every link's frame and every DOF's axis for joint angles `theta`.
    pub fn forward(&self, theta: &[f64]) -> Result<SkeletonPose, BodyError> {
        if theta.len() != self.dofs.len() {
            return Err(BodyError::WrongLength {
                array: "theta",
                got: theta.len(),
                expected: self.dofs.len(),
            });
        }
        if let Some(row) = theta.iter().position(|t| !t.is_finite()) {
            return Err(BodyError::NotFinite {
                array: "theta",
                row,
            });
        }
        let n = self.n_links();
        let mut rotation: Vec<Matrix3<f64>> = Vec::with_capacity(n);
        let mut displacement: Vec<Vector3<f64>> = Vec::with_capacity(n);
        let mut dof_axis = vec![Vector3::zeros(); self.dofs.len()];
        for j in 0..n {
            // p_j = p_q + R_q (o_j − o_q)  ⇔  δ_j = δ_q + (R_q − I)(o_j − o_q).
            let (mut r, delta) = match self.parent[j] {
                None => (Matrix3::identity(), Vector3::zeros()),
                Some(q) => {
                    let rq = rotation[q];
                    let bone = self.origin[j] - self.origin[q];
                    (rq, displacement[q] + (rq * bone - bone))
                }
            };
            for k in self.link_dofs[j].clone() {
                let axis = self.dofs[k].axis;
                dof_axis[k] = r * axis;
                r *= Rotation3::from_axis_angle(&Unit::new_unchecked(axis), theta[k]).into_inner();
            }
            rotation.push(r);
            displacement.push(delta);
        }
        let position = self
            .origin
            .iter()
            .zip(&displacement)
            .map(|(o, d)| o + d)
            .collect();
        Ok(SkeletonPose {
            rotation,
            displacement,
            position,
            dof_axis,
        })
    }
}

impl SkeletonPose {
    /// How far link `j`'s skinning transform T_j(θ)·T_j(0)⁻¹ moves the rest point `x`:
    /// (R_j − I)(x − o_j) + δ_j (exactly zero at rest).
    #[inline]
    pub fn skin_offset(&self, skeleton: &Skeleton, j: usize, x: &Vector3<f64>) -> Vector3<f64> {
        let arm = x - skeleton.origin[j];
        (self.rotation[j] * arm - arm) + self.displacement[j]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chain;

    #[test]
    fn zero_pose_is_the_rest_pose() {
        let s = chain();
        let p = s.forward(&[0.0; 3]).unwrap();
        for j in 0..3 {
            assert_eq!(p.rotation[j], Matrix3::identity());
            assert_eq!(p.position[j], s.origin(j));
        }
    }

    #[test]
    fn a_quarter_turn_swings_the_child() {
        let s = chain();
        let p = s.forward(&[std::f64::consts::FRAC_PI_2, 0.0, 0.0]).unwrap();
        assert!((p.position[2] - Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-12);
        // The second DOF's axis is carried by the first rotation: y turns into -x.
        assert!((p.dof_axis[1] - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_trees_are_refused() {
        let o = [[0.0; 3]; 3];
        assert!(matches!(
            Skeleton::new(&[-1, 2, 1], &o, vec![]),
            Err(BodyError::BadLink { link: 1, .. })
        ));
        assert!(matches!(
            Skeleton::new(&[-1, -1, 1], &o, vec![]),
            Err(BodyError::BadLink { link: 1, .. })
        ));
        assert!(matches!(
            Skeleton::new(&[0, 0, 1], &o, vec![]),
            Err(BodyError::BadLink { link: 0, .. })
        ));
        let zero = Dof {
            link: 1,
            axis: Vector3::zeros(),
            lower: 0.0,
            upper: 1.0,
        };
        assert!(matches!(
            Skeleton::new(&[-1, 0, 1], &o, vec![zero]),
            Err(BodyError::BadLink { .. })
        ));
        let reversed = Dof {
            link: 1,
            axis: Vector3::x(),
            lower: 1.0,
            upper: 0.0,
        };
        assert!(matches!(
            Skeleton::new(&[-1, 0, 1], &o, vec![reversed]),
            Err(BodyError::BadLink { .. })
        ));
    }

    #[test]
    fn clamping_respects_limits() {
        let s = chain();
        let mut t = [5.0, -5.0, 0.5];
        s.clamp(&mut t);
        assert_eq!(t, [2.0, -2.0, 0.5]);
    }
}
