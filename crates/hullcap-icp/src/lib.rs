//! Robust articulated ICP (the paper's §3, docs/design.md §4–5).
//!
//! The model's skinned vertices (a chosen subset) with their normals find their partners
//! on the target surface through the normal-aware 6-D kd-tree; the pose minimises
//! E = Σ_i ρ(d_i) where d_i is the distance of pair i (point-to-point, as in the paper, or
//! point-to-plane) and ρ the Lorentzian, by iteratively reweighted least squares with
//! weights e(d) = (1 + ½(d/σ)²)⁻¹ and σ re-estimated each iteration from the median
//! residual (bounded below). Each iteration takes new correspondences and one damped
//! Gauss–Newton (Levenberg–Marquardt) step, or a nonlinear conjugate-gradient step as in
//! the paper. The normal equations JᵀWJ and JᵀWr are summed in parallel chunks: the
//! Jacobian is never stored. Joint limits are enforced by clamping after every step.
//!
//! Hierarchical fitting (§3.3): the root (t, R) first, then each group of joints from the
//! torso outwards, each on its own parameters, repeated until the energy settles; or all
//! parameters at once.

mod error;
mod fit;
mod normal_equations;
mod options;
mod pose_prior;
mod shape_fit;
mod solve;
mod target;
mod variants;

pub use error::IcpError;
pub use fit::{FitStats, LinkCounts, Params, evaluate_poses, fit, fit_with_prior};
pub use normal_equations::spread;
pub use options::{FitOptions, Residual, Solver};
pub use pose_prior::PosePrior;
pub use shape_fit::{ShapeFit, ShapePrior, fit_shape};
pub use target::Target;

#[cfg(test)]
pub(crate) mod testing;
