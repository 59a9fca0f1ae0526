//! The gates that reject a nearest pair: too far apart in space, or normals too far apart.

/// Rejection thresholds for a (query, nearest key) pair.
///
/// The nearest key is always the exact 6-D nearest; a gate never substitutes a farther key
/// for a rejected one (the paper's rule: a rejected pair contributes nothing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gate {
    /// Largest distance in space (metres) between the query point and the target point.
    pub max_distance: f64,
    /// Largest angle (radians) between the query normal and the target normal.
    pub max_angle: f64,
}

impl Default for Gate {
    /// No gating: any distance, any angle.
    fn default() -> Self {
        Gate {
            max_distance: f64::INFINITY,
            max_angle: std::f64::consts::PI,
        }
    }
}

/// A gate prepared for one tree (its λ).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PreparedGate {
    max_distance2: f64,
    /// Smallest allowed dot product of the λ-scaled normal parts of two keys; `None` if any
    /// angle passes.
    min_normal_dot: Option<f64>,
    /// No key farther than this (squared, 6-D) can pass; searches start with it as their
    /// radius, which prunes most of the tree for gated queries.
    pub(crate) radius2: f64,
}

impl Gate {
    /// Whether a pair `distance` metres apart whose unit normals have dot product
    /// `normal_dot` passes.
    pub fn admits(&self, distance: f64, normal_dot: f64) -> bool {
        distance <= self.max_distance
            && normal_dot >= self.max_angle.min(std::f64::consts::PI).cos()
    }

    pub(crate) fn validate(&self) -> Result<(), crate::KdTreeError> {
        if self.max_distance.is_nan() || self.max_distance < 0.0 {
            return Err(crate::KdTreeError::BadParameter {
                name: "max_distance",
                requirement: "non-negative",
                value: self.max_distance,
            });
        }
        if self.max_angle.is_nan() || self.max_angle < 0.0 {
            return Err(crate::KdTreeError::BadParameter {
                name: "max_angle",
                requirement: "non-negative (radians)",
                value: self.max_angle,
            });
        }
        Ok(())
    }

    pub(crate) fn prepare(&self, lambda: f64) -> PreparedGate {
        let angle_gated = self.max_angle < std::f64::consts::PI;
        let cos_max = self.max_angle.cos();
        let lambda2 = lambda * lambda;
        // ‖n_a − n_b‖² = 2 − 2 cos(angle) for unit normals.
        let normal_part = if angle_gated {
            2.0 - 2.0 * cos_max
        } else {
            4.0
        };
        let radius2 = self.max_distance * self.max_distance + lambda2 * normal_part;
        PreparedGate {
            max_distance2: self.max_distance * self.max_distance,
            min_normal_dot: angle_gated.then_some(cos_max * lambda2),
            // Generous by a few ulps so that a key exactly on the gate is still found.
            radius2: radius2 * (1.0 + 1e-9) + f64::MIN_POSITIVE,
        }
    }
}

impl PreparedGate {
    /// Whether the pair of keys `q` (query) and `t` (target) passes.
    #[inline]
    pub(crate) fn passes(&self, q: &crate::keys::Key, t: &crate::keys::Key) -> bool {
        let space2: f64 = (0..3).map(|d| (q[d] - t[d]) * (q[d] - t[d])).sum();
        if space2 > self.max_distance2 {
            return false;
        }
        match self.min_normal_dot {
            Some(min_dot) => (3..6).map(|d| q[d] * t[d]).sum::<f64>() >= min_dot,
            None => true,
        }
    }
}
