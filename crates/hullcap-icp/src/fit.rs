//! The fitting loop: IRLS iterations of Levenberg–Marquardt or conjugate-gradient steps,
//! scheduled hierarchically or all at once.

use crate::IcpError;
use crate::Target;
use crate::normal_equations::{Pair, Problem, robust_sigma};
use hullcap_body::{Rig, RootPose, SkeletonPose};
use hullcap_core::resolve_threads;
use hullcap_kdtree::Gate;
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

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

/// A pose: the root's rotation and translation and the joint angles.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    /// World rotation and translation of the body frame.
    pub root: RootPose,
    /// Joint angles, radians.
    pub theta: Vec<f64>,
}

/// Options of [`fit`].
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Point-to-point (paper) or point-to-plane residuals.
    pub residual: Residual,
    /// Levenberg–Marquardt (default) or conjugate gradients (paper).
    pub solver: Solver,
    /// Correspondence gates: largest distance (m) and normal angle (rad).
    pub gate: Gate,
    /// Lower bound of the robust scale σ (m).
    pub sigma_min: f64,
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
    /// Distance (m) under which a matched model point counts as an inlier in the stats.
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
            iterations: 10,
            tolerance: 1e-3,
            rounds: 4,
            hierarchical: true,
            polish: true,
            inlier_distance: 0.02,
            threads: None,
        }
    }
}

/// How a fit went.
#[derive(Debug, Clone, PartialEq)]
pub struct FitStats {
    /// Iterations (correspondence updates) over all stages and rounds.
    pub iterations: usize,
    /// Passes over the stages.
    pub rounds: usize,
    /// Final robust energy, at the final correspondences and σ.
    pub energy: f64,
    /// Model points matched within the gates and within `inlier_distance`, as a fraction
    /// of all model points.
    pub inlier_fraction: f64,
    /// Mean distance of the matched pairs (m).
    pub mean_residual: f64,
    /// The final robust scale σ (m).
    pub sigma: f64,
}

/// Fits the rig to the target from `initial`, moving only the model vertices
/// `model_points`. `groups` lists the joint DOF of each hierarchical stage after the root
/// (indices into θ); DOF in no group stay fixed in the hierarchical schedule.
pub fn fit(
    rig: &Rig,
    target: &Target,
    model_points: &[u32],
    initial: &Params,
    groups: &[Vec<usize>],
    options: &FitOptions,
) -> Result<(Params, FitStats), IcpError> {
    check(rig, model_points, initial, groups, options)?;
    let n_dofs = rig.skeleton().n_dofs();
    let stages: Vec<Vec<usize>> = if options.hierarchical {
        std::iter::once((0..6).collect())
            .chain(groups.iter().map(|g| g.iter().map(|d| 6 + d).collect()))
            .collect()
    } else {
        vec![(0..6 + n_dofs).collect()]
    };
    let mut params = initial.clone();
    rig.skeleton().clamp(&mut params.theta);
    let mut fitter = Fitter {
        problem: Problem {
            rig,
            target,
            kind: options.residual,
            threads: resolve_threads(options.threads),
        },
        model_points,
        options,
        iterations: 0,
    };
    let mut previous = f64::INFINITY;
    let mut last = None;
    let mut rounds = 0;
    let max_rounds = if options.hierarchical {
        options.rounds.max(1)
    } else {
        1
    };
    while rounds < max_rounds {
        rounds += 1;
        for stage in &stages {
            fitter.stage(&mut params, stage)?;
        }
        let stats = fitter.evaluate(&params)?;
        let settled =
            (previous - stats.energy).abs() <= options.tolerance * stats.energy.max(1e-12);
        previous = stats.energy;
        last = Some(stats);
        if settled {
            break;
        }
    }
    if options.hierarchical && options.polish {
        let all: Vec<usize> = (0..6 + n_dofs).collect();
        fitter.stage(&mut params, &all)?;
        last = None; // the pose moved: evaluate it afresh
    }
    let stats = match last {
        Some(stats) => stats,
        None => fitter.evaluate(&params)?,
    };
    Ok((
        params,
        FitStats {
            iterations: fitter.iterations,
            rounds,
            ..stats
        },
    ))
}

fn check(
    rig: &Rig,
    model_points: &[u32],
    initial: &Params,
    groups: &[Vec<usize>],
    options: &FitOptions,
) -> Result<(), IcpError> {
    initial.root.validate()?;
    rig.skeleton().forward(&initial.theta)?;
    if let Some(&i) = model_points
        .iter()
        .find(|&&i| i as usize >= rig.n_vertices())
    {
        return Err(IcpError::BadIndex {
            what: "model point",
            index: i as usize,
            bound: rig.n_vertices(),
        });
    }
    if model_points.is_empty() {
        return Err(IcpError::BadParameter {
            name: "model_points",
            requirement: "non-empty",
            value: 0.0,
        });
    }
    let n = rig.skeleton().n_dofs();
    if let Some(&d) = groups.iter().flatten().find(|&&d| d >= n) {
        return Err(IcpError::BadIndex {
            what: "DOF",
            index: d,
            bound: n,
        });
    }
    for (name, value, ok) in [
        ("sigma_min", options.sigma_min, options.sigma_min > 0.0),
        ("tolerance", options.tolerance, options.tolerance >= 0.0),
        (
            "inlier_distance",
            options.inlier_distance,
            options.inlier_distance > 0.0,
        ),
    ] {
        if !ok || !value.is_finite() {
            return Err(IcpError::BadParameter {
                name,
                requirement: "positive and finite",
                value,
            });
        }
    }
    Ok(())
}

struct Fitter<'a> {
    problem: Problem<'a>,
    model_points: &'a [u32],
    options: &'a FitOptions,
    iterations: usize,
}

impl Fitter<'_> {
    /// The statistics of `params` at fresh correspondences and σ (iterations and rounds
    /// left for the caller).
    fn evaluate(&self, params: &Params) -> Result<FitStats, IcpError> {
        let (pose, pairs, distances, sigma) = self.pairs(params)?;
        let energy = self.problem.energy(&pose, &params.root, &pairs, sigma)?;
        let inliers = distances
            .iter()
            .filter(|&&d| d <= self.options.inlier_distance)
            .count();
        let mean_residual = if distances.is_empty() {
            f64::INFINITY
        } else {
            distances.iter().sum::<f64>() / distances.len() as f64
        };
        Ok(FitStats {
            iterations: 0,
            rounds: 0,
            energy,
            inlier_fraction: inliers as f64 / self.model_points.len() as f64,
            mean_residual,
            sigma,
        })
    }

    /// The skeleton's pose, the gated correspondences with their distances, and σ.
    #[allow(clippy::type_complexity)]
    fn pairs(&self, params: &Params) -> Result<(SkeletonPose, Vec<Pair>, Vec<f64>, f64), IcpError> {
        let pose = self.problem.rig.skeleton().forward(&params.theta)?;
        let (pairs, distances) =
            self.problem
                .correspond(&pose, &params.root, self.model_points, &self.options.gate)?;
        let sigma = robust_sigma(&distances, self.options.sigma_min);
        Ok((pose, pairs, distances, sigma))
    }

    /// ICP iterations on the parameters `active` until they settle.
    fn stage(&mut self, params: &mut Params, active: &[usize]) -> Result<(), IcpError> {
        let mut damping = 1e-3;
        let mut previous_direction: Option<(DVector<f64>, DVector<f64>)> = None;
        for _ in 0..self.options.iterations {
            self.iterations += 1;
            let (pose, pairs, _, sigma) = self.pairs(params)?;
            if pairs.len() < active.len() {
                return Ok(()); // too few partners to say anything
            }
            let sums = self
                .problem
                .normal_equations(&pose, &params.root, &pairs, sigma, active)?;
            let n = active.len();
            let h = DMatrix::from_row_slice(n, n, &sums.hessian);
            let g = DVector::from_vec(sums.gradient);
            let e0 = sums.energy;
            let energy_at = |candidate: &Params| -> Result<f64, IcpError> {
                let pose = self.problem.rig.skeleton().forward(&candidate.theta)?;
                self.problem.energy(&pose, &candidate.root, &pairs, sigma)
            };
            let accepted = match self.options.solver {
                Solver::LevenbergMarquardt => {
                    let mut accepted = None;
                    for _ in 0..8 {
                        let mut a = h.clone();
                        for k in 0..n {
                            a[(k, k)] += damping * h[(k, k)].max(1e-9) + 1e-12;
                        }
                        let Some(delta) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                            damping *= 10.0;
                            continue;
                        };
                        let candidate = self.step(params, active, &delta);
                        let e1 = energy_at(&candidate)?;
                        if e1 < e0 {
                            damping = (damping / 3.0).max(1e-9);
                            accepted = Some((candidate, e1));
                            break;
                        }
                        damping *= 4.0;
                    }
                    accepted
                }
                Solver::ConjugateGradient => {
                    let mut direction = -&g;
                    if let Some((g_prev, d_prev)) = &previous_direction {
                        let beta =
                            (g.dot(&(&g - g_prev)) / g_prev.dot(g_prev).max(1e-300)).max(0.0);
                        direction += beta * d_prev;
                    }
                    if direction.dot(&g) >= 0.0 {
                        direction = -&g; // not a descent direction: restart
                    }
                    let curvature = direction.dot(&(&h * &direction));
                    let mut alpha = if curvature > 0.0 {
                        -g.dot(&direction) / curvature
                    } else {
                        1e-3
                    };
                    let mut accepted = None;
                    for _ in 0..10 {
                        let candidate = self.step(params, active, &(alpha * &direction));
                        let e1 = energy_at(&candidate)?;
                        if e1 < e0 {
                            accepted = Some((candidate, e1));
                            break;
                        }
                        alpha *= 0.5;
                    }
                    previous_direction = Some((g.clone(), direction));
                    accepted
                }
            };
            match accepted {
                Some((candidate, e1)) => {
                    *params = candidate;
                    if e0 - e1 <= self.options.tolerance * e0 {
                        return Ok(());
                    }
                }
                None => return Ok(()),
            }
        }
        Ok(())
    }

    /// `params` moved by `delta` on the parameters `active`: t += δt,
    /// R ← exp([δω]×)·R (kept orthonormal), θ += δθ, then θ clamped into the joint limits.
    fn step(&self, params: &Params, active: &[usize], delta: &DVector<f64>) -> Params {
        let mut out = params.clone();
        let mut omega = Vector3::zeros();
        for (&a, &d) in active.iter().zip(delta.iter()) {
            match a {
                0..=2 => out.root.translation[a] += d,
                3..=5 => omega[a - 3] = d,
                _ => out.theta[a - 6] += d,
            }
        }
        if omega != Vector3::zeros() {
            // Re-orthonormalised: rounding would otherwise build up over the steps of a
            // fit and, through the tracker's constant-velocity prediction (which
            // multiplies three fitted rotations), grow from frame to frame.
            let mut rotation = Rotation3::from_matrix_unchecked(
                Rotation3::new(omega).into_inner() * out.root.rotation,
            );
            rotation.renormalize();
            out.root.rotation = rotation.into_inner();
        }
        self.problem.rig.skeleton().clamp(&mut out.theta);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{root, target_at, tube};

    fn truth() -> Params {
        Params {
            root: root([0.05, -0.1, 0.2], [0.3, -0.2, 1.0]),
            theta: vec![0.5, -0.3, 0.7],
        }
    }

    fn start() -> Params {
        // Off by what one frame of fast motion gives: 0.1 rad per joint, 3–6 cm, 0.05 rad.
        Params {
            root: root([0.08, -0.06, 0.24], [0.27, -0.16, 1.03]),
            theta: vec![0.4, -0.2, 0.6],
        }
    }

    fn recovers(options: &FitOptions) -> FitStats {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        let groups = vec![vec![0, 1], vec![2]];
        let (got, stats) = fit(&rig, &target, &points, &start(), &groups, options).unwrap();
        let want = truth();
        for (g, w) in got.theta.iter().zip(&want.theta) {
            assert!(
                (g - w).abs() < 0.01,
                "{options:?}: θ {:?} vs {:?}",
                got.theta,
                want.theta
            );
        }
        assert!((got.root.translation - want.root.translation).norm() < 0.005);
        let angle =
            Rotation3::from_matrix(&(got.root.rotation * want.root.rotation.transpose())).angle();
        assert!(angle < 0.01, "{options:?}: root off by {angle} rad");
        assert!(
            stats.mean_residual < 0.005 && stats.inlier_fraction > 0.99,
            "{stats:?}"
        );
        stats
    }

    #[test]
    fn levenberg_marquardt_recovers_a_perturbed_pose() {
        let stats = recovers(&FitOptions {
            rounds: 50,
            iterations: 20,
            tolerance: 1e-6,
            ..FitOptions::default()
        });
        assert!(stats.iterations > 0);
    }

    #[test]
    fn point_to_plane_and_simultaneous_fits_recover_it_too() {
        recovers(&FitOptions {
            residual: Residual::PointToPlane,
            rounds: 8,
            iterations: 20,
            ..FitOptions::default()
        });
        recovers(&FitOptions {
            hierarchical: false,
            iterations: 60,
            ..FitOptions::default()
        });
    }

    #[test]
    fn conjugate_gradients_recover_it_with_more_iterations() {
        recovers(&FitOptions {
            solver: Solver::ConjugateGradient,
            iterations: 150,
            rounds: 10,
            tolerance: 1e-7,
            ..FitOptions::default()
        });
    }

    #[test]
    fn fitted_rotations_stay_orthonormal_through_predicted_starts() {
        // As tracking does: each fit starts from a constant-velocity prediction
        // R_b·R_aᵀ·R_b of the last two results, which multiplies their rounding errors.
        // Without re-orthonormalising in `step`, |RᵀR − I| grew until the input check
        // refused the pose (seen after ~150 frames of a real sequence).
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).step_by(4).collect();
        let options = FitOptions {
            iterations: 2,
            rounds: 1,
            ..FitOptions::default()
        };
        let mut previous = start().root.rotation;
        let mut params = start();
        for _ in 0..200 {
            let current = params.root.rotation;
            params.root.rotation = current * previous.transpose() * current;
            previous = current;
            params = fit(&rig, &target, &points, &params, &[vec![0, 1, 2]], &options)
                .unwrap()
                .0;
            let r = params.root.rotation;
            assert!((r.transpose() * r - nalgebra::Matrix3::identity()).amax() < 1e-12);
        }
    }

    #[test]
    fn joint_limits_hold_and_bad_input_is_refused() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        let mut start = start();
        start.theta = vec![5.0, -5.0, 5.0];
        let (got, _) = fit(
            &rig,
            &target,
            &points,
            &start,
            &[vec![0, 1, 2]],
            &FitOptions::default(),
        )
        .unwrap();
        assert!(got.theta.iter().all(|t| t.abs() <= 2.0));
        let opts = FitOptions::default();
        assert!(matches!(
            fit(&rig, &target, &[u32::MAX], &start, &[], &opts),
            Err(IcpError::BadIndex { .. })
        ));
        assert!(matches!(
            fit(&rig, &target, &points, &start, &[vec![7]], &opts),
            Err(IcpError::BadIndex { what: "DOF", .. })
        ));
        let bad = FitOptions {
            sigma_min: 0.0,
            ..FitOptions::default()
        };
        assert!(matches!(
            fit(&rig, &target, &points, &start, &[], &bad),
            Err(IcpError::BadParameter { .. })
        ));
        start.theta.pop();
        assert!(matches!(
            fit(&rig, &target, &points, &start, &[], &opts),
            Err(IcpError::Body(_))
        ));
    }
}
