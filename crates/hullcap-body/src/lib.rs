//! The articulated deformable body model of the paper's §2 (docs/design.md §1–2).
//!
//! - [`Skeleton`]: a tree of joint links with revolute DOF, forward kinematics T_j(θ)
//!   and the axes and centres every DOF turns about.
//! - [`skin_weights`]: x_ij = the shortest path from vertex i to link j that does not pass
//!   through the body (mesh edges plus direct arcs that cross no triangle, tested with a
//!   [`TriangleBvh`]), by Dijkstra from each link; w_ij ∝ exp(−b·x_ij), the K largest kept.
//! - [`Rig`]: skinning m′_i(θ) = Σ_j w_ij T_j(θ) T_j(0)⁻¹ m_i (eq. 2) with normals, under a
//!   root motion (R, t), and its analytic derivatives with respect to every DOF.
//! - [`Shape`]: the body's proportions as parameters (per-link stretches, joint shifts),
//!   the rest body linear in them, and the posed vertices' derivatives with respect to them.
//!
//! Frames: the body frame has x = the subject's left, y = back (the subject faces −y),
//! z = up, origin at the point the root turns about. At rest every link frame is the body
//! frame moved to its joint centre (no rest rotations), so T_j(0) is a pure translation.

mod bvh;
mod error;
mod rig;
mod shape;
mod skeleton;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
mod weights;

pub use bvh::TriangleBvh;
pub use error::BodyError;
pub use rig::{Posed, Rig, RootPose, SkinWeights};
pub use shape::{Shape, ShapeParameter};
pub use skeleton::{Dof, Skeleton, SkeletonPose};
pub use weights::{LinkDistances, SkinWeightOptions, link_distances, skin_weights};
