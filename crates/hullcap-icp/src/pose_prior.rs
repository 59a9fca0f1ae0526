//! A Gaussian prior on a fit's joint angles (docs/design.md §9): a joint moves far from
//! where its fit started only when the target asks for it.
//!
//! E_prior = ½·κ·Σ_d ((θ_d − μ_d) / τ_d)²,   κ = N·ε²,
//!
//! with N the number of pairs of the iteration and ε = `prior_distance`, the convention of
//! [`crate::ShapePrior`]: one τ costs as much as every pair lying ε further off. A DOF with
//! τ = ∞ is free. The prior adds κ/τ_d² to the diagonal of the normal equations and
//! κ(θ_d − μ_d)/τ_d² to the gradient; the statistics of a fit report the data's energy
//! alone.

use crate::IcpError;

/// A Gaussian prior on the joint angles of [`crate::fit_with_prior`].
#[derive(Debug, Clone, PartialEq)]
pub struct PosePrior {
    /// μ_d, radians, one per joint DOF.
    pub mean: Vec<f64>,
    /// τ_d, radians, positive (∞: no prior on that DOF).
    pub sigma: Vec<f64>,
    /// ε, metres: the pair distance one τ is worth.
    pub prior_distance: f64,
}

impl PosePrior {
    /// Refuses a prior of another length than the skeleton's DOF or with bad numbers.
    pub(crate) fn validate(&self, n_dofs: usize) -> Result<(), IcpError> {
        if self.mean.len() != n_dofs || self.sigma.len() != n_dofs {
            return Err(IcpError::BadParameter {
                name: "pose prior mean and sigma lengths",
                requirement: "one per joint DOF",
                value: self.mean.len().min(self.sigma.len()) as f64,
            });
        }
        if let Some(&bad) = self.mean.iter().find(|m| !m.is_finite()) {
            return Err(IcpError::BadParameter {
                name: "pose prior mean",
                requirement: "finite",
                value: bad,
            });
        }
        if let Some(&bad) = self.sigma.iter().find(|&&t| t.is_nan() || t <= 0.0) {
            return Err(IcpError::BadParameter {
                name: "pose prior sigma",
                requirement: "positive (infinite: no prior)",
                value: bad,
            });
        }
        if !(self.prior_distance >= 0.0 && self.prior_distance.is_finite()) {
            return Err(IcpError::BadParameter {
                name: "pose prior prior_distance",
                requirement: "non-negative and finite",
                value: self.prior_distance,
            });
        }
        Ok(())
    }

    /// κ for an iteration with `pairs` pairs.
    pub(crate) fn kappa(&self, pairs: usize) -> f64 {
        pairs as f64 * self.prior_distance * self.prior_distance
    }

    /// κ/τ_d²: the prior's curvature along DOF d.
    pub(crate) fn curvature(&self, d: usize, kappa: f64) -> f64 {
        kappa / (self.sigma[d] * self.sigma[d])
    }

    /// E_prior at `theta`.
    pub(crate) fn energy(&self, theta: &[f64], kappa: f64) -> f64 {
        theta
            .iter()
            .enumerate()
            .map(|(d, &t)| 0.5 * self.curvature(d, kappa) * (t - self.mean[d]).powi(2))
            .sum()
    }
}
