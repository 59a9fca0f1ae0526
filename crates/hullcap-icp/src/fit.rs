//! The fitting loop: IRLS iterations of Levenberg–Marquardt or conjugate-gradient steps,
//! scheduled hierarchically or all at once.

use crate::normal_equations::{Correspondences, Hints, Problem, robust_sigma};
use crate::solve::levenberg_marquardt;
use crate::variants::{evaluate_variants, moving_vertices};
use crate::{FitOptions, IcpError, PosePrior, Solver, Target};
use hullcap_body::{Rig, RootPose, Skeleton, SkeletonPose};
use hullcap_core::resolve_threads;
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

/// A pose: the root's rotation and translation and the joint angles.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    /// World rotation and translation of the body frame.
    pub root: RootPose,
    /// Joint angles, radians.
    pub theta: Vec<f64>,
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
    /// Mean distance of the matched model→hull pairs (m).
    pub mean_residual: f64,
    /// Hull samples with a model point within the gates and within `inlier_distance`, as
    /// a fraction of all samples: how much of the hull the model explains.
    pub coverage: f64,
    /// Mean distance of the matched hull→model pairs (m).
    pub mean_reverse_residual: f64,
    /// The final robust scale σ (m).
    pub sigma: f64,
    /// Per link of the rig: how well the fit explains that part of the body.
    pub links: Vec<LinkCounts>,
}

/// What the statistics count for one link: its model points (by the link each is bound
/// to most) and how many of them are inliers; the hull samples whose nearest model vertex
/// is bound to it, and how many of those the model covers. A limb the fit has lost shows
/// here when the whole body's fractions barely move.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkCounts {
    /// Model points bound to the link.
    pub points: u32,
    /// Those within the gates and `inlier_distance` of the hull.
    pub inliers: u32,
    /// Hull samples nearest to the link's vertices.
    pub samples: u32,
    /// Those with a model partner within the gates and `inlier_distance`.
    pub covered: u32,
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
    fit_with_prior(rig, target, model_points, initial, groups, options, None)
}

/// [`fit`] with a Gaussian prior on the joint angles added to the energy (see
/// [`PosePrior`]); the statistics report the data's energy alone.
pub fn fit_with_prior(
    rig: &Rig,
    target: &Target,
    model_points: &[u32],
    initial: &Params,
    groups: &[Vec<usize>],
    options: &FitOptions,
    prior: Option<&PosePrior>,
) -> Result<(Params, FitStats), IcpError> {
    // Two hundred parallel loops a fit: one team of threads for all of them.
    let threads = resolve_threads(options.threads);
    hullcap_core::with_workers(threads, || {
        check(rig, model_points, initial, groups, options)?;
        if let Some(prior) = prior {
            prior.validate(rig.skeleton().n_dofs())?;
        }
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
        let problem = Problem {
            rig,
            target,
            kind: options.residual,
            threads,
        };
        let fitter = |model_points, options| Fitter {
            problem,
            model_points,
            options,
            prior,
            iterations: 0,
            kept: None,
            hints: Hints::default(),
        };
        let coarse = options.hierarchical && options.coarse > 1;
        let (coarse_points, coarse_options): (Vec<u32>, FitOptions);
        let mut staged = if coarse {
            coarse_points = model_points
                .iter()
                .step_by(options.coarse)
                .copied()
                .collect();
            coarse_options = options.coarsened();
            fitter(&coarse_points, &coarse_options)
        } else {
            fitter(model_points, options)
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
                staged.stage(&mut params, stage)?;
            }
            if coarse && rounds == max_rounds {
                break; // no round follows, and the polish and statistics use every point
            }
            let stats = staged.evaluate(&params)?;
            let settled =
                (previous - stats.energy).abs() <= options.tolerance * stats.energy.max(1e-12);
            previous = stats.energy;
            last = Some(stats);
            if settled {
                break;
            }
        }
        let (mut fine, coarse_iterations) = if coarse {
            last = None; // the statistics are those of every point
            let mut fine = fitter(model_points, options);
            fine.hints = std::mem::take(&mut staged.hints);
            (fine, staged.iterations)
        } else {
            (staged, 0)
        };
        if options.hierarchical && options.polish {
            let all: Vec<usize> = (0..6 + n_dofs).collect();
            fine.stage(&mut params, &all)?;
            last = None; // the pose moved: evaluate it afresh
        }
        let stats = match last {
            Some(stats) => stats,
            None => fine.evaluate(&params)?,
        };
        Ok((
            params,
            FitStats {
                iterations: coarse_iterations + fine.iterations,
                rounds,
                ..stats
            },
        ))
    })
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
    check_points(rig, model_points)?;
    let n = rig.skeleton().n_dofs();
    if let Some(&d) = groups.iter().flatten().find(|&&d| d >= n) {
        return Err(IcpError::BadIndex {
            what: "DOF",
            index: d,
            bound: n,
        });
    }
    options.validate()?;
    Ok(())
}

/// Refuses an empty or out-of-range list of model points.
pub(crate) fn check_points(rig: &Rig, model_points: &[u32]) -> Result<(), IcpError> {
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
    Ok(())
}

/// The statistics of a pose at fresh correspondences (both ways) and σ; the energy is
/// the one the fit minimises (one- or two-sided as `options` say).
pub(crate) fn evaluate(
    rig: &Rig,
    target: &Target,
    model_points: &[u32],
    params: &Params,
    options: &FitOptions,
    threads: usize,
) -> Result<FitStats, IcpError> {
    let problem = Problem {
        rig,
        target,
        kind: options.residual,
        threads,
    };
    let pose = rig.skeleton().forward(&params.theta)?;
    let found = problem.correspond(
        &pose,
        &params.root,
        model_points,
        options,
        true,
        &mut Hints::default(),
    )?;
    let sigma = robust_sigma(&found.forward, options.sigma_min);
    statistics(
        &problem,
        model_points,
        &params.root,
        &pose,
        &found,
        sigma,
        options,
    )
}

/// The statistics of pairs found both ways at a pose, with the energy the fit minimises
/// (over the model→hull pairs alone when the fit is one-sided).
pub(crate) fn statistics(
    problem: &Problem<'_>,
    model_points: &[u32],
    root: &RootPose,
    pose: &SkeletonPose,
    found: &Correspondences,
    sigma: f64,
    options: &FitOptions,
) -> Result<FitStats, IcpError> {
    let counted = if options.reverse_weight > 0.0 {
        &found.pairs[..]
    } else {
        &found.pairs[..found.forward.len()]
    };
    let energy = problem.energy(pose, root, counted, sigma)?;
    Ok(found.stats(problem.rig, model_points, energy, sigma, options))
}

/// The statistics of many poses of one rig against one target, without fitting (fresh
/// correspondences both ways at each pose): how a search ranks its candidates. The poses
/// are spread over `options.threads` threads, one pose per thread at a time.
pub fn evaluate_poses(
    rig: &Rig,
    target: &Target,
    model_points: &[u32],
    poses: &[Params],
    options: &FitOptions,
) -> Result<Vec<FitStats>, IcpError> {
    let threads = resolve_threads(options.threads);
    hullcap_core::with_workers(threads, || {
        options.validate()?;
        check_points(rig, model_points)?;
        for p in poses {
            p.root.validate()?;
            rig.skeleton().forward(&p.theta)?;
        }
        if let Some(moving) = moving_vertices(rig, poses) {
            let problem = Problem {
                rig,
                target,
                kind: options.residual,
                threads,
            };
            return evaluate_variants(&problem, model_points, poses, &moving, options);
        }
        per_pose(poses, threads, |params| {
            evaluate(rig, target, model_points, params, options, 1)
        })
    })
}

/// `evaluate(pose)` for each of `poses`, spread over `threads` threads, one pose per
/// thread at a time; the first error stands for all.
pub(crate) fn per_pose(
    poses: &[Params],
    threads: usize,
    evaluate: impl Fn(&Params) -> Result<FitStats, IcpError> + Sync,
) -> Result<Vec<FitStats>, IcpError> {
    let mut out: Vec<Option<Result<FitStats, IcpError>>> = vec![None; poses.len()];
    hullcap_core::for_each_chunk_mut(&mut out, threads, 1, |offset, chunk| {
        for (slot, params) in chunk.iter_mut().zip(&poses[offset..]) {
            *slot = Some(evaluate(params));
        }
    })?;
    out.into_iter()
        .map(|r| {
            r.unwrap_or(Err(IcpError::BadParameter {
                name: "poses",
                requirement: "all evaluated",
                value: 0.0,
            }))
        })
        .collect()
}

/// A pose's linearisation point: the skeleton's pose, the gated correspondences, and σ.
type Linearised = (SkeletonPose, Correspondences, f64);

struct Fitter<'a> {
    problem: Problem<'a>,
    model_points: &'a [u32],
    options: &'a FitOptions,
    prior: Option<&'a PosePrior>,
    iterations: usize,
    /// The last pairs found and the pose they were found at. The correspondences are
    /// the costly part of an iteration, and a stage often starts where the last one
    /// stopped: after a round's evaluation, or after a stage whose last step found no
    /// lower energy. Those pairs are then the same to the last bit and are not sought again.
    kept: Option<(Params, Linearised)>,
    /// The last searches' answers, which make the next ones faster.
    hints: Hints,
}

impl Fitter<'_> {
    /// The statistics of `params` (iterations and rounds left for the caller).
    fn evaluate(&mut self, params: &Params) -> Result<FitStats, IcpError> {
        if self.options.reverse_weight == 0.0 {
            // The stages' pairs are one-sided; the statistics need both ways.
            return evaluate(
                self.problem.rig,
                self.problem.target,
                self.model_points,
                params,
                self.options,
                self.problem.threads,
            );
        }
        let (pose, found, sigma) = self.pairs(params)?;
        let stats = statistics(
            &self.problem,
            self.model_points,
            &params.root,
            &pose,
            &found,
            sigma,
            self.options,
        )?;
        self.keep(params, (pose, found, sigma));
        Ok(stats)
    }

    /// The linearisation at `params`: the kept one when it was found there, else afresh.
    fn pairs(&mut self, params: &Params) -> Result<Linearised, IcpError> {
        if let Some((_, kept)) = self.kept.take_if(|(at, _)| at == params) {
            return Ok(kept);
        }
        let pose = self.problem.rig.skeleton().forward(&params.theta)?;
        let found = self.problem.correspond(
            &pose,
            &params.root,
            self.model_points,
            self.options,
            self.options.reverse_weight > 0.0,
            &mut self.hints,
        )?;
        let sigma = robust_sigma(&found.forward, self.options.sigma_min);
        Ok((pose, found, sigma))
    }

    fn keep(&mut self, params: &Params, linearised: Linearised) {
        self.kept = Some((params.clone(), linearised));
    }

    /// ICP iterations on the parameters `active` until they settle.
    fn stage(&mut self, params: &mut Params, active: &[usize]) -> Result<(), IcpError> {
        let mut damping = 1e-3;
        let mut previous_direction: Option<(DVector<f64>, DVector<f64>)> = None;
        let mut previous_step: Option<DVector<f64>> = None;
        for _ in 0..self.options.iterations {
            self.iterations += 1;
            let (pose, found, sigma) = self.pairs(params)?;
            let pairs = &found.pairs;
            if pairs.len() < active.len() {
                self.keep(params, (pose, found, sigma));
                return Ok(()); // too few partners to say anything
            }
            let sums =
                self.problem
                    .normal_equations(&pose, &params.root, pairs, sigma, active, None)?;
            let n = active.len();
            let mut h = DMatrix::from_row_slice(n, n, &sums.hessian);
            let mut g = DVector::from_vec(sums.gradient);
            let mut e0 = sums.energy;
            let kappa = self.prior.map_or(0.0, |p| p.kappa(pairs.len()));
            if let Some(prior) = self.prior {
                for (k, &a) in active.iter().enumerate().filter(|(_, a)| **a >= 6) {
                    let c = prior.curvature(a - 6, kappa);
                    h[(k, k)] += c;
                    g[k] += c * (params.theta[a - 6] - prior.mean[a - 6]);
                }
                e0 += prior.energy(&params.theta, kappa);
            }
            let energy_at = |candidate: &Params| -> Result<f64, IcpError> {
                let pose = self.problem.rig.skeleton().forward(&candidate.theta)?;
                let data = self.problem.energy(&pose, &candidate.root, pairs, sigma)?;
                Ok(data
                    + self
                        .prior
                        .map_or(0.0, |p| p.energy(&candidate.theta, kappa)))
            };
            let accepted = match self.options.solver {
                Solver::LevenbergMarquardt => {
                    // The accepted step comes back with its pose: it is what the
                    // over-relaxation lengthens and what the next step is compared with.
                    let plain = levenberg_marquardt(&h, &g, e0, &mut damping, |delta| {
                        let candidate =
                            params.stepped(self.problem.rig.skeleton(), active, delta.as_slice());
                        let e1 = energy_at(&candidate)?;
                        Ok(((candidate, delta.clone()), e1))
                    })?;
                    match plain {
                        Some(((candidate, delta), e1)) => {
                            let relaxed = self.over_relaxed(
                                params,
                                active,
                                &delta,
                                previous_step.as_ref(),
                                e0,
                                energy_at,
                            )?;
                            previous_step = Some(delta);
                            Some(relaxed.unwrap_or((candidate, e1)))
                        }
                        None => None,
                    }
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
                        let candidate = params.stepped(
                            self.problem.rig.skeleton(),
                            active,
                            (alpha * &direction).as_slice(),
                        );
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
                None => {
                    self.keep(params, (pose, found, sigma));
                    return Ok(());
                }
            }
        }
        Ok(())
    }

    /// The pose `FitOptions::over_relaxation` times the accepted step `delta` away from
    /// `params`, with its energy at the iteration's pairs (`energy_at`), when the step
    /// goes on in the direction of the stage's `previous` one and that energy is still
    /// below the iteration's `e0`; `None` otherwise, and always with a factor of 1.
    fn over_relaxed(
        &self,
        params: &Params,
        active: &[usize],
        delta: &DVector<f64>,
        previous: Option<&DVector<f64>>,
        e0: f64,
        energy_at: impl Fn(&Params) -> Result<f64, IcpError>,
    ) -> Result<Option<(Params, f64)>, IcpError> {
        let factor = self.options.over_relaxation;
        if factor <= 1.0 || !previous.is_some_and(|p| p.dot(delta) > 0.0) {
            return Ok(None);
        }
        let over = params.stepped(
            self.problem.rig.skeleton(),
            active,
            (factor * delta).as_slice(),
        );
        let e = energy_at(&over)?;
        Ok((e < e0).then_some((over, e)))
    }
}

impl Params {
    /// The pose moved by `delta` on the parameters `active`: t += δt,
    /// R ← exp([δω]×)·R (kept orthonormal), θ += δθ, then θ clamped into the joint limits.
    pub(crate) fn stepped(&self, skeleton: &Skeleton, active: &[usize], delta: &[f64]) -> Params {
        let mut out = self.clone();
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
        skeleton.clamp(&mut out.theta);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Residual;
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

    /// Stages on every third point, then the polish on all of them, recover the pose as
    /// well; the statistics count every model point.
    #[test]
    fn coarse_stages_then_every_point_recover_it_too() {
        let stats = recovers(&FitOptions {
            coarse: 3,
            rounds: 50,
            iterations: 20,
            tolerance: 1e-6,
            ..FitOptions::default()
        });
        let points: u32 = stats.links.iter().map(|c| c.points).sum();
        assert_eq!(points as usize, tube().n_vertices());
        assert!(stats.iterations > 0);
    }

    /// The sums over pairs are made block by block whatever the number of threads, so a fit
    /// (two-sided, several rounds) is the same to the last bit on 1, 2 or 3 threads.
    #[test]
    fn the_result_does_not_depend_on_the_number_of_threads() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        assert!(
            points.len() > 3 * 256,
            "too few pairs to share among threads"
        );
        let groups = vec![vec![0, 1], vec![2]];
        let fitted: Vec<Params> = [1, 2, 3]
            .iter()
            .map(|&threads| {
                let options = FitOptions {
                    threads: Some(threads),
                    reverse_weight: 1.0,
                    rounds: 3,
                    ..FitOptions::default()
                };
                fit(&rig, &target, &points, &start(), &groups, &options)
                    .unwrap()
                    .0
            })
            .collect();
        for other in &fitted[1..] {
            assert_eq!(other.theta, fitted[0].theta);
            assert_eq!(other.root.translation, fitted[0].root.translation);
            assert_eq!(other.root.rotation, fitted[0].root.rotation);
        }
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

    /// The last link's target has swung 1.2 rad away: the one-sided fit folds the link
    /// further the wrong way (its model points pair with what lies nearest in 6-D), while
    /// the hull→model pairs of the swung part pull it back.
    #[test]
    fn the_two_sided_energy_brings_back_a_limb_out_of_reach() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        let mut start = truth();
        start.theta[2] -= 1.2;
        let error = |reverse_weight: f64| {
            let options = FitOptions {
                reverse_weight,
                rounds: 8,
                iterations: 20,
                ..FitOptions::default()
            };
            let (got, _) = fit(
                &rig,
                &target,
                &points,
                &start,
                &[vec![0, 1], vec![2]],
                &options,
            )
            .unwrap();
            (got.theta[2] - truth().theta[2]).abs()
        };
        let (one_sided, two_sided) = (error(0.0), error(1.0));
        assert!(two_sided < 0.01, "two-sided: {two_sided} rad off");
        assert!(
            one_sided > 0.1,
            "one-sided: {one_sided} rad off (the test no longer tests anything)"
        );
    }

    /// A prior with τ = ∞ everywhere changes nothing; a stiff one on the last joint keeps
    /// that joint where the prior says (the others come near the truth, making up for it
    /// a little); a prior of the wrong length is refused.
    #[test]
    fn a_pose_prior_holds_what_it_is_asked_to_hold() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        let groups = vec![vec![0, 1], vec![2]];
        let options = FitOptions {
            rounds: 50,
            iterations: 20,
            tolerance: 1e-6,
            ..FitOptions::default()
        };
        let plain = fit(&rig, &target, &points, &start(), &groups, &options).unwrap();
        let free = PosePrior {
            mean: vec![0.0; 3],
            sigma: vec![f64::INFINITY; 3],
            prior_distance: 0.003,
        };
        let same = fit_with_prior(
            &rig,
            &target,
            &points,
            &start(),
            &groups,
            &options,
            Some(&free),
        )
        .unwrap();
        assert_eq!(same, plain);
        let held = PosePrior {
            mean: vec![0.0, 0.0, start().theta[2]],
            sigma: vec![f64::INFINITY, f64::INFINITY, 1e-3],
            prior_distance: 0.003,
        };
        let (got, _) = fit_with_prior(
            &rig,
            &target,
            &points,
            &start(),
            &groups,
            &options,
            Some(&held),
        )
        .unwrap();
        assert!(
            (got.theta[2] - start().theta[2]).abs() < 0.01,
            "{:?}",
            got.theta
        );
        assert!((plain.0.theta[2] - truth().theta[2]).abs() < 0.01);
        assert!(
            (got.theta[0] - truth().theta[0]).abs() < 0.1,
            "{:?}",
            got.theta
        );
        let short = PosePrior {
            mean: vec![0.0; 2],
            sigma: vec![1.0; 2],
            prior_distance: 0.003,
        };
        assert!(matches!(
            fit_with_prior(
                &rig,
                &target,
                &points,
                &start(),
                &groups,
                &options,
                Some(&short)
            ),
            Err(IcpError::BadParameter { .. })
        ));
    }

    #[test]
    fn link_counts_show_which_part_is_lost() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).collect();
        let mut off = truth();
        off.theta[2] -= 1.2; // the last link swung away
        let stats = evaluate(&rig, &target, &points, &off, &FitOptions::default(), 1).unwrap();
        let share = |c: &LinkCounts| {
            0.5 * (c.inliers as f64 / c.points.max(1) as f64
                + c.covered as f64 / c.samples.max(1) as f64)
        };
        let total: u32 = stats.links.iter().map(|c| c.points).sum();
        assert_eq!(total as usize, points.len());
        assert!(share(&stats.links[0]) > 0.95, "{:?}", stats.links);
        assert!(share(&stats.links[2]) < 0.5, "{:?}", stats.links);
    }

    #[test]
    fn evaluating_poses_ranks_the_true_pose_first() {
        let rig = tube();
        let target = target_at(&rig, &truth());
        let points: Vec<u32> = (0..rig.n_vertices() as u32).step_by(2).collect();
        let options = FitOptions::default();
        let got = evaluate_poses(&rig, &target, &points, &[start(), truth()], &options).unwrap();
        let alone = evaluate(&rig, &target, &points, &truth(), &options, 1).unwrap();
        assert_eq!(got[1], alone);
        assert!(got[1].inlier_fraction > 0.99 && got[1].coverage > 0.99);
        assert!(
            got[0].inlier_fraction + got[0].coverage < got[1].inlier_fraction + got[1].coverage
        );
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
        for bad in [
            FitOptions {
                sigma_min: 0.0,
                ..FitOptions::default()
            },
            FitOptions {
                coarse: 0,
                ..FitOptions::default()
            },
            FitOptions {
                over_relaxation: 2.0,
                ..FitOptions::default()
            },
            FitOptions {
                over_relaxation: 0.5,
                ..FitOptions::default()
            },
        ] {
            assert!(matches!(
                fit(&rig, &target, &points, &start, &[], &bad),
                Err(IcpError::BadParameter { .. })
            ));
        }
        start.theta.pop();
        assert!(matches!(
            fit(&rig, &target, &points, &start, &[], &opts),
            Err(IcpError::Body(_))
        ));
    }
}
