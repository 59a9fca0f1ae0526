//! What a fit is asked to do: the one place where the fitting defaults live (the Python
//! side reads them from here).

use crate::IcpError;
use hullcap_kdtree::Gate;

/// What a pair's residual measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Residual {
    /// The distance between the points (the paper).
    PointToPoint,
    /// The distance from the model point to the target point's tangent plane.
    PointToPlane,
}

/// How each iteration steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solver {
    /// Damped Gauss–Newton on the IRLS normal equations (default).
    LevenbergMarquardt,
    /// Nonlinear conjugate gradients (Polak–Ribière) on the same energy, the paper's
    /// minimiser; the step length is the Gauss–Newton model's minimum along the
    /// direction, halved until the energy falls.
    ConjugateGradient,
}

/// Options of [`crate::fit`] and [`crate::fit_shape`]. Distances are metres, angles radians.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Point-to-point (paper) or point-to-plane residuals.
    pub residual: Residual,
    /// Levenberg–Marquardt (default) or conjugate gradients (paper).
    pub solver: Solver,
    /// Correspondence gates (both directions): largest distance (m) and normal angle (rad).
    pub gate: Gate,
    /// Lower bound of the robust scale σ (m).
    pub sigma_min: f64,
    /// Weight of the hull→model pairs against the model→hull pairs (0 = one-sided, the
    /// paper's energy). With weight w, the hull→model pairs together count w times as much
    /// as the model→hull pairs, whatever their numbers: each hull sample pulls the model
    /// point nearest to it (6-D, gated like the model→hull pairs, with the same robust
    /// weights), so a limb that has left the model's reach is pulled back. A part of the
    /// hull the model does not explain at all (a phantom volume between the views, a hole)
    /// lies many σ away and gets a Lorentzian weight near zero.
    pub reverse_weight: f64,
    /// Number of hull points that seek a model partner (spread evenly over the target).
    pub reverse_points: usize,
    /// Number of model vertices (spread evenly over the mesh) among which a hull point
    /// seeks its partner. 3 000 of a 9 000-vertex body lie about 2.5 cm apart; the pair
    /// is measured along the hull's normal, so that spacing costs little accuracy, and the
    /// kd-tree over them, rebuilt at every iteration, a third of the time of all of them.
    pub reverse_vertices: usize,
    /// Largest number of iterations per stage (each with new correspondences).
    pub iterations: usize,
    /// A stage ends when an iteration lowers the energy by less than this fraction.
    pub tolerance: f64,
    /// Hierarchical: largest number of passes over the stages; the fit ends when a pass
    /// changes the energy by less than `tolerance`.
    pub rounds: usize,
    /// Fit root then joint groups in turn (true), or all parameters at once.
    pub hierarchical: bool,
    /// After the hierarchical passes, one stage on all parameters together. Alternating
    /// stages crawl along valleys where the root and a joint trade off (a zig-zag of
    /// tiny steps); a joint Gauss–Newton step crosses them. Off = the paper's schedule.
    pub polish: bool,
    /// Coarse to fine: the hierarchy's stages pair every `coarse`-th model point, and a
    /// `coarse`-th of the hull samples and of the vertices they seek among; the polish and
    /// the statistics use them all. The stages only bring each part near its minimum,
    /// which fewer points find as well for less, and the polish then settles it on every
    /// point. 1 = every stage on every point. Hierarchical fits only.
    pub coarse: usize,
    /// Over-relaxation of the Levenberg–Marquardt steps: a step that goes on in the
    /// direction of the stage's last step (a positive dot product) is taken this many
    /// times over when the pose reached still has a lower energy at the iteration's pairs
    /// than the pose it left; otherwise the step as solved. Between re-pairings a step
    /// solves for pairs that hold the model back where it slides along the hull, and ICP
    /// then crawls towards its minimum in steps that each point the way of the last; a
    /// longer step in that direction is successive over-relaxation, which converges for
    /// factors below 2. 1 (the default) = every step as solved, the paper's iteration.
    pub over_relaxation: f64,
    /// Distance (m) under which a pair counts as an inlier in the statistics.
    pub inlier_distance: f64,
    /// Worker threads (`None` = all cores).
    pub threads: Option<usize>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            residual: Residual::PointToPoint,
            solver: Solver::LevenbergMarquardt,
            gate: Gate {
                max_distance: 0.15,
                max_angle: 60f64.to_radians(),
            },
            sigma_min: 0.004,
            reverse_weight: 0.0,
            reverse_points: 1500,
            reverse_vertices: 3000,
            iterations: 10,
            tolerance: 1e-3,
            rounds: 4,
            hierarchical: true,
            polish: true,
            coarse: 1,
            over_relaxation: 1.0,
            inlier_distance: 0.02,
            threads: None,
        }
    }
}

impl FitOptions {
    /// These options for the coarse stages (see [`FitOptions::coarse`]): a `coarse`-th of
    /// the hull samples and of the vertices they seek among.
    pub fn coarsened(&self) -> FitOptions {
        FitOptions {
            reverse_points: (self.reverse_points / self.coarse).max(1),
            reverse_vertices: (self.reverse_vertices / self.coarse).max(1),
            ..self.clone()
        }
    }

    /// Checks every number against its range.
    pub fn validate(&self) -> Result<(), IcpError> {
        let bad = |name, requirement, value| {
            Err(IcpError::BadParameter {
                name,
                requirement,
                value,
            })
        };
        for (name, value) in [
            ("sigma_min", self.sigma_min),
            ("inlier_distance", self.inlier_distance),
            ("max_distance", self.gate.max_distance),
            ("max_angle", self.gate.max_angle),
        ] {
            if value.is_nan() || value <= 0.0 {
                return bad(name, "positive", value);
            }
        }
        for (name, value) in [
            ("tolerance", self.tolerance),
            ("reverse_weight", self.reverse_weight),
        ] {
            if !(value >= 0.0 && value.is_finite()) {
                return bad(name, "non-negative and finite", value);
            }
        }
        for (name, value) in [
            ("iterations", self.iterations),
            ("rounds", self.rounds),
            ("reverse_points", self.reverse_points),
            ("reverse_vertices", self.reverse_vertices),
            ("coarse", self.coarse),
        ] {
            if value == 0 {
                return bad(name, "at least 1", 0.0);
            }
        }
        if !(1.0..2.0).contains(&self.over_relaxation) {
            return bad(
                "over_relaxation",
                "at least 1 and below 2",
                self.over_relaxation,
            );
        }
        if self.threads == Some(0) {
            return bad("threads", "at least 1", 0.0);
        }
        Ok(())
    }
}
