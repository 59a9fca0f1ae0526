//! One IRLS linearisation: correspondences both ways, robust weights, and the normal
//! equations JᵀWJ, JᵀWr summed over the pairs in parallel chunks.
//!
//! Every pair, whichever direction found it, is a model vertex and a target point with
//! the residual r = v_i(θ) − t_k (or its component along the target normal), so the two
//! directions share one Jacobian and one accumulation; they differ only in the pair's
//! weight (1 for model→hull pairs, see [`FitOptions::reverse_weight`] for the others)
//! and in what the residual measures: a hull point seeks its partner among all the posed
//! model vertices (not only the sparser model points), and its pair is measured along the
//! hull's normal, so that the spacing of the model's vertices does not count as error.
//! (The vertices it chooses among are an even subset, [`FitOptions::reverse_vertices`]:
//! the kd-tree over them is rebuilt at every iteration.)

use crate::{FitOptions, FitStats, IcpError, LinkCounts, Residual, Target};
use hullcap_body::{Rig, RootPose, Shape, SkeletonPose};
use hullcap_kdtree::{BuildOptions, Gate, Neighbor, NormalKdTree};
use nalgebra::Vector3;

/// Posed model points: positions and unit normals, world frame.
pub(crate) type PosedPoints = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// A model vertex, its partner on the target, the pair's weight in the energy and what
/// its residual measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pair {
    pub vertex: u32,
    pub target: u32,
    pub weight: f64,
    pub kind: Residual,
}

/// The pairs of one pose, both directions, with their distances.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Correspondences {
    pub pairs: Vec<Pair>,
    /// Distance of each model→hull pair (the first `forward.len()` of `pairs`).
    pub forward: Vec<f64>,
    /// Distance from each hull sample to its model partner; +∞ where it has none.
    pub reverse: Vec<f64>,
    /// For each hull sample, the link its nearest model vertex (gated or not) is bound to.
    pub reverse_links: Vec<u32>,
}

/// Each query's answer at the last search of a fit, as hints for the next
/// ([`NormalKdTree::query_hinted`]): between iterations the model moves little, and a
/// search bounded from the start by the last partner's distance skips the cells that
/// cannot hold a nearer key. The pairs
/// are the same with hints or without.
///
/// A model point whose posed position and normal are those of its last search, to the
/// bit, is not searched again: its answer is the last one. A hierarchical stage turns
/// some joints only, and every vertex those joints do not move keeps its key (the
/// elbows' stage moves the forearms and hands alone). The answer is the one a search
/// would give: a search from the last partner keeps it unless a key lies strictly nearer,
/// and none did.
#[derive(Debug, Clone, Default)]
pub(crate) struct Hints {
    /// Per model vertex of the rig: the target point that was its nearest key, −1 for none.
    forward: Vec<i64>,
    /// Per model vertex: the key (posed position, then normal) `forward` was found for;
    /// NaN where it was never searched.
    forward_keys: Vec<[f64; 6]>,
    /// Per hull sample: its nearest posed vertex (an index into the evenly spread
    /// vertices), −1 for none.
    reverse: Vec<i64>,
    /// The numbers of samples and of spread vertices the reverse hints are for.
    reverse_shape: (usize, usize),
}

/// A posed model point's search key: its position, then its normal.
fn key(point: [f64; 3], normal: [f64; 3]) -> [f64; 6] {
    [
        point[0], point[1], point[2], normal[0], normal[1], normal[2],
    ]
}

impl Hints {
    /// Of `model_points` (posed at `points` with `normals`; the rig has `n_vertices`),
    /// those whose key changed since their last search, as indices into `model_points`,
    /// with their hints.
    fn forward_stale(
        &mut self,
        model_points: &[u32],
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        n_vertices: usize,
    ) -> (Vec<usize>, Vec<i64>) {
        if self.forward.len() != n_vertices {
            self.forward = vec![-1; n_vertices];
            self.forward_keys = vec![[f64::NAN; 6]; n_vertices];
        }
        model_points
            .iter()
            .enumerate()
            .filter(|&(i, &v)| self.forward_keys[v as usize] != key(points[i], normals[i]))
            .map(|(i, &v)| (i, self.forward[v as usize]))
            .unzip()
    }

    /// The reverse hints of `samples` hull samples against `vertices` spread vertices.
    fn reverse_of(&mut self, samples: usize, vertices: usize) -> &[i64] {
        if self.reverse_shape != (samples, vertices) {
            self.reverse = vec![-1; samples];
            self.reverse_shape = (samples, vertices);
        }
        &self.reverse
    }
}

impl Correspondences {
    /// The fit statistics of these pairs (iterations and rounds left at 0), with the
    /// counts of every link of `rig` (see [`LinkCounts`]).
    pub(crate) fn stats(
        &self,
        rig: &Rig,
        model_points: &[u32],
        energy: f64,
        sigma: f64,
        options: &FitOptions,
    ) -> FitStats {
        let n_model_points = model_points.len();
        let mut links = vec![LinkCounts::default(); rig.skeleton().n_links()];
        for &i in model_points {
            links[rig.dominant_link(i as usize)].points += 1;
        }
        for (p, &d) in self.pairs.iter().zip(&self.forward) {
            if d <= options.inlier_distance {
                links[rig.dominant_link(p.vertex as usize)].inliers += 1;
            }
        }
        for (&l, &d) in self.reverse_links.iter().zip(&self.reverse) {
            links[l as usize].samples += 1;
            if d <= options.inlier_distance {
                links[l as usize].covered += 1;
            }
        }
        let within = |d: &[f64]| d.iter().filter(|&&x| x <= options.inlier_distance).count() as f64;
        let mean = |d: &[f64]| {
            let finite: Vec<f64> = d.iter().copied().filter(|x| x.is_finite()).collect();
            if finite.is_empty() {
                f64::INFINITY
            } else {
                finite.iter().sum::<f64>() / finite.len() as f64
            }
        };
        FitStats {
            iterations: 0,
            rounds: 0,
            energy,
            inlier_fraction: within(&self.forward) / n_model_points.max(1) as f64,
            mean_residual: mean(&self.forward),
            coverage: within(&self.reverse) / self.reverse.len().max(1) as f64,
            mean_reverse_residual: mean(&self.reverse),
            sigma,
            links,
        }
    }
}

/// Sums over the pairs: Gauss–Newton Hessian, gradient and robust energy.
#[derive(Debug, Clone)]
pub(crate) struct Sums {
    /// JᵀWJ over the active parameters, row-major n × n.
    pub hessian: Vec<f64>,
    /// JᵀWr.
    pub gradient: Vec<f64>,
    /// Σ weight·ρ(d).
    pub energy: f64,
}

impl Sums {
    pub(crate) fn zeros(n: usize) -> Self {
        Sums {
            hessian: vec![0.0; n * n],
            gradient: vec![0.0; n],
            energy: 0.0,
        }
    }

    fn add(&mut self, other: &Sums) {
        for (a, b) in self.hessian.iter_mut().zip(&other.hessian) {
            *a += b;
        }
        for (a, b) in self.gradient.iter_mut().zip(&other.gradient) {
            *a += b;
        }
        self.energy += other.energy;
    }
}

/// The Lorentzian: ρ(d) = σ²·ln(1 + ½(d/σ)²), whose IRLS weight is ρ′(d)/d =
/// e(d) = (1 + ½(d/σ)²)⁻¹.
#[inline]
pub(crate) fn lorentzian(d: f64, sigma: f64) -> (f64, f64) {
    let u = 0.5 * (d / sigma) * (d / sigma);
    (sigma * sigma * u.ln_1p(), 1.0 / (1.0 + u))
}

/// The residual of model point `v` against target point `t`: (components, count,
/// distance).
#[inline]
fn residual(kind: Residual, target: &Target, v: &Vector3<f64>, t: usize) -> ([f64; 3], usize, f64) {
    let d = v - Vector3::from(target.points[t]);
    match kind {
        Residual::PointToPoint => ([d.x, d.y, d.z], 3, d.norm()),
        Residual::PointToPlane => {
            let r = d.dot(&Vector3::from(target.normals[t]));
            ([r, 0.0, 0.0], 1, r.abs())
        }
    }
}

/// About `count` indices of `0..n` spread evenly (every m-th).
pub fn spread(n: usize, count: usize) -> Vec<u32> {
    let step = (n / count.max(1)).max(1);
    (0..n as u32).step_by(step).collect()
}

/// σ from the median model→hull distance (1.4826·median estimates a Gaussian's σ),
/// bounded below by `sigma_min`.
pub(crate) fn robust_sigma(distances: &[f64], sigma_min: f64) -> f64 {
    if distances.is_empty() {
        return sigma_min;
    }
    let mut d = distances.to_vec();
    let mid = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    (1.4826 * *median).max(sigma_min)
}

/// The shape columns of the Jacobian (a fit of the body's proportions).
pub(crate) struct ShapeColumns<'a> {
    pub shape: &'a Shape,
    /// [`Shape::pose_derivatives`] at the pose being linearised.
    pub d_pose: &'a [Vector3<f64>],
}

/// The pairs summed into one partial sum (see `Problem::over_pairs`): small enough to share
/// the work evenly among threads, large enough that adding the partial sums costs little.
const PAIRS_PER_SUM: usize = 256;

/// What every pass over the model points needs: the rig, the target, the residual kind
/// and the number of threads.
#[derive(Clone, Copy)]
pub(crate) struct Problem<'a> {
    pub rig: &'a Rig,
    pub target: &'a Target,
    pub kind: Residual,
    pub threads: usize,
}

impl Problem<'_> {
    /// Model vertex `i` posed in the world (no normal).
    #[inline]
    fn world_vertex(&self, pose: &SkeletonPose, root: &RootPose, i: usize) -> Vector3<f64> {
        root.rotation * self.rig.skin_vertex(pose, i) + root.translation
    }

    /// `visit(accumulator, block)` over consecutive blocks of [`PAIRS_PER_SUM`] pairs, the
    /// blocks shared among the threads: one partial sum per block, in the order of the
    /// blocks. The blocks do not depend on the number of threads, so neither do the sums
    /// (floating-point addition is not associative): a fit gives the same result on any
    /// machine.
    fn over_pairs<T: Send>(
        &self,
        pairs: &[Pair],
        init: impl Fn() -> T,
        visit: impl Fn(&mut T, &[Pair]) + Sync,
    ) -> Result<Vec<T>, IcpError> {
        let blocks: Vec<&[Pair]> = pairs.chunks(PAIRS_PER_SUM).collect();
        let mut partial: Vec<T> = blocks.iter().map(|_| init()).collect();
        hullcap_core::for_each_chunk_mut(&mut partial, self.threads, 1, |offset, chunk| {
            for (acc, block) in chunk.iter_mut().zip(&blocks[offset..]) {
                visit(acc, block);
            }
        })?;
        Ok(partial)
    }

    /// The model points posed at (`pose`, `root`): positions and unit normals.
    pub(crate) fn posed_points(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        model_points: &[u32],
    ) -> Result<PosedPoints, IcpError> {
        let mut posed = vec![([0.0; 3], [0.0; 3]); model_points.len()];
        hullcap_core::for_each_chunk_mut(&mut posed, self.threads, 512, |offset, chunk| {
            for (slot, &i) in chunk.iter_mut().zip(&model_points[offset..]) {
                let (v, n) = self.rig.posed_vertex(pose, root, i as usize);
                *slot = (v.into(), n.into());
            }
        })?;
        Ok(posed.into_iter().unzip())
    }

    /// The gated pairs of the model points posed at (`pose`, `root`): each model point's
    /// nearest target key, then (with `reverse`) each hull sample's nearest posed model
    /// vertex (of an even subset), weighted by `options.reverse_weight`. `hints`: the
    /// answers of the last call, which speed the searches up and are updated.
    pub(crate) fn correspond(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        model_points: &[u32],
        options: &FitOptions,
        reverse: bool,
        hints: &mut Hints,
    ) -> Result<Correspondences, IcpError> {
        let (points, normals) = self.posed_points(pose, root, model_points)?;
        let n_vertices = self.rig.n_vertices();
        let (stale, stale_hints) = hints.forward_stale(model_points, &points, &normals, n_vertices);
        let searched = self.target.tree.query_hinted(
            &stale.iter().map(|&i| points[i]).collect::<Vec<_>>(),
            &stale.iter().map(|&i| normals[i]).collect::<Vec<_>>(),
            &options.gate,
            &stale_hints,
            Some(self.threads),
        )?;
        for (&i, nb) in stale.iter().zip(&searched) {
            let v = model_points[i] as usize;
            hints.forward[v] = nb.index;
            hints.forward_keys[v] = key(points[i], normals[i]);
        }
        let found: Vec<i64> = model_points
            .iter()
            .map(|&v| hints.forward[v as usize])
            .collect();
        let mut out = self.forward_pairs(model_points, &points, &found);
        if reverse {
            let every = spread(n_vertices, options.reverse_vertices);
            let vertices = self.posed_points(pose, root, &every)?;
            let samples = self.target.samples(options.reverse_points);
            let (sp, sn) = self.sample_keys(&samples);
            let found = self.vertex_tree(&vertices)?.query_hinted(
                &sp,
                &sn,
                &Gate::default(),
                hints.reverse_of(samples.len(), every.len()),
                Some(self.threads),
            )?;
            hints.reverse = found.iter().map(|nb| nb.index).collect();
            self.add_reverse_pairs(
                &mut out,
                &every,
                &vertices,
                &samples,
                &found,
                options,
                model_points.len(),
            );
        }
        Ok(out)
    }

    /// The model→hull pairs of the model points posed at `points`, given each one's
    /// gated nearest target key (−1 for none).
    pub(crate) fn forward_pairs(
        &self,
        model_points: &[u32],
        points: &[[f64; 3]],
        found: &[i64],
    ) -> Correspondences {
        let mut out = Correspondences::default();
        for ((&index, &vertex), p) in found.iter().zip(model_points).zip(points) {
            if index >= 0 {
                let t = index as usize;
                let (_, _, d) = residual(self.kind, self.target, &Vector3::from(*p), t);
                out.pairs.push(Pair {
                    vertex,
                    target: t as u32,
                    weight: 1.0,
                    kind: self.kind,
                });
                out.forward.push(d);
            }
        }
        out
    }

    /// A kd-tree over posed model vertices, with the target's λ.
    pub(crate) fn vertex_tree(
        &self,
        (points, normals): &PosedPoints,
    ) -> Result<NormalKdTree, IcpError> {
        Ok(NormalKdTree::build(
            points,
            normals,
            &BuildOptions {
                normal_weight: Some(self.target.normal_weight()),
                threads: Some(self.threads),
                ..BuildOptions::default()
            },
        )?)
    }

    /// The positions and normals of the target points `samples`.
    pub(crate) fn sample_keys(&self, samples: &[u32]) -> PosedPoints {
        samples
            .iter()
            .map(|&k| {
                (
                    self.target.points[k as usize],
                    self.target.normals[k as usize],
                )
            })
            .unzip()
    }

    /// Adds the hull→model pairs to `out`: each hull sample of `samples` with its
    /// nearest vertex `found` (ungated; an index into `every`, whose posed positions and
    /// normals are `vertices`), gated here, so that each sample's nearest vertex says
    /// which part of the body it belongs to even when the pair is refused.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_reverse_pairs(
        &self,
        out: &mut Correspondences,
        every: &[u32],
        (points, normals): &PosedPoints,
        samples: &[u32],
        found: &[Neighbor],
        options: &FitOptions,
        n_model_points: usize,
    ) {
        let weight = options.reverse_weight * n_model_points as f64 / samples.len() as f64;
        for (nb, &k) in found.iter().zip(samples) {
            let nearest = nb.index.max(0) as usize;
            let vertex = every[nearest];
            out.reverse_links
                .push(self.rig.dominant_link(vertex as usize) as u32);
            let p = Vector3::from(points[nearest]);
            let space = (p - Vector3::from(self.target.points[k as usize])).norm();
            let dot = Vector3::from(normals[nearest])
                .dot(&Vector3::from(self.target.normals[k as usize]));
            if nb.index < 0 || !options.gate.admits(space, dot) {
                out.reverse.push(f64::INFINITY);
                continue;
            }
            let (_, _, d) = residual(Residual::PointToPlane, self.target, &p, k as usize);
            out.pairs.push(Pair {
                vertex,
                target: k,
                weight,
                kind: Residual::PointToPlane,
            });
            out.reverse.push(d);
        }
    }

    /// The robust energy of the pairs at a pose (no derivatives).
    pub(crate) fn energy(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        pairs: &[Pair],
        sigma: f64,
    ) -> Result<f64, IcpError> {
        let partial = self.over_pairs(
            pairs,
            || 0.0,
            |sum, share| {
                for p in share {
                    let v = self.world_vertex(pose, root, p.vertex as usize);
                    let (_, _, d) = residual(p.kind, self.target, &v, p.target as usize);
                    *sum += p.weight * lorentzian(d, sigma).0;
                }
            },
        )?;
        Ok(partial.iter().sum())
    }

    /// JᵀWJ, JᵀWr and Σρ over the pairs for the pose parameters `active` (indices into
    /// t, ω, θ) followed, when `shape` is given, by every shape parameter; IRLS weights at
    /// scale `sigma`.
    pub(crate) fn normal_equations(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        pairs: &[Pair],
        sigma: f64,
        active: &[usize],
        shape: Option<&ShapeColumns<'_>>,
    ) -> Result<Sums, IcpError> {
        let n_shape = shape.map_or(0, |s| s.shape.n_params());
        let n = active.len() + n_shape;
        let partial = self.over_pairs(
            pairs,
            || Sums::zeros(n),
            |sums, share| {
                let mut row = vec![[0.0; 3]; active.len()];
                let mut shape_row = vec![[0.0; 3]; n_shape];
                let mut scratch = vec![Vector3::zeros(); n_shape];
                let mut j = vec![[0.0; 3]; n];
                let mut moving = Vec::with_capacity(n);
                for p in share {
                    let (i, t) = (p.vertex as usize, p.target as usize);
                    let v = self.world_vertex(pose, root, i);
                    let (r, m, d) = residual(p.kind, self.target, &v, t);
                    let (rho, e) = lorentzian(d, sigma);
                    let w = p.weight * e;
                    sums.energy += p.weight * rho;
                    self.rig
                        .vertex_jacobian_columns(pose, root, i, active, &mut row);
                    if let Some(s) = shape {
                        s.shape.vertex_jacobian(
                            pose,
                            s.d_pose,
                            root,
                            i,
                            &mut scratch,
                            &mut shape_row,
                        );
                    }
                    let columns = row.iter().chain(shape_row.iter());
                    match p.kind {
                        Residual::PointToPoint => {
                            for (slot, col) in j.iter_mut().zip(columns) {
                                *slot = *col;
                            }
                        }
                        Residual::PointToPlane => {
                            let nq = &self.target.normals[t];
                            for (slot, col) in j.iter_mut().zip(columns) {
                                *slot =
                                    [col[0] * nq[0] + col[1] * nq[1] + col[2] * nq[2], 0.0, 0.0];
                            }
                        }
                    }
                    // Only the parameters that move this vertex (its own links' chains and
                    // the root) have non-zero columns; the others would add exact zeros.
                    moving.clear();
                    moving.extend((0..n).filter(|&a| j[a] != [0.0; 3]));
                    if m == 1 {
                        // A point-to-plane pair: one number per column.
                        for (x, &a) in moving.iter().enumerate() {
                            let ja = j[a][0];
                            sums.gradient[a] += w * (ja * r[0]);
                            let row = &mut sums.hessian[a * n..(a + 1) * n];
                            for &b in &moving[x..] {
                                row[b] += w * (ja * j[b][0]);
                            }
                        }
                    } else {
                        for (x, &a) in moving.iter().enumerate() {
                            let ja = &j[a];
                            sums.gradient[a] += w * (0..m).map(|k| ja[k] * r[k]).sum::<f64>();
                            for &b in &moving[x..] {
                                let jb = &j[b];
                                sums.hessian[a * n + b] +=
                                    w * (0..m).map(|k| ja[k] * jb[k]).sum::<f64>();
                            }
                        }
                    }
                }
            },
        )?;
        let mut total = Sums::zeros(n);
        for s in &partial {
            total.add(s);
        }
        for a in 0..n {
            for b in 0..a {
                total.hessian[a * n + b] = total.hessian[b * n + a];
            }
        }
        Ok(total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Params;
    use crate::testing::{root, target_at, tube};

    /// Hints from the searches at one pose leave the pairs at the next pose as they are
    /// without hints, and the hints follow the answers; hints of another sampling are
    /// dropped.
    #[test]
    fn hints_leave_the_pairs_as_they_are() {
        let rig = tube();
        let truth = Params {
            root: root([0.1, -0.2, 0.3], [0.5, 0.0, 1.0]),
            theta: vec![0.4, -0.2, 0.6],
        };
        let target = target_at(&rig, &truth);
        let problem = Problem {
            rig: &rig,
            target: &target,
            kind: Residual::PointToPlane,
            threads: 2,
        };
        let options = FitOptions {
            gate: Gate {
                max_distance: 0.05,
                max_angle: 1.0,
            },
            reverse_weight: 1.0,
            reverse_points: 300,
            ..FitOptions::default()
        };
        let points: Vec<u32> = (0..rig.n_vertices() as u32).step_by(2).collect();
        let mut hints = Hints::default();
        // The pairs at `at` without hints and with `hints`, which they update.
        let both = |at: &Params, options: &FitOptions, hints: &mut Hints| {
            let pose = rig.skeleton().forward(&at.theta).unwrap();
            let cold = problem
                .correspond(
                    &pose,
                    &at.root,
                    &points,
                    options,
                    true,
                    &mut Hints::default(),
                )
                .unwrap();
            let warm = problem
                .correspond(&pose, &at.root, &points, options, true, hints)
                .unwrap();
            (cold, warm)
        };
        let mut at = truth.clone();
        for step in 0..4 {
            at.theta[step % 3] += 0.03;
            at.root.translation.x += 0.004;
            let (cold, warm) = both(&at, &options, &mut hints);
            assert_eq!(warm, cold, "step {step}");
            assert!(hints.forward.iter().any(|&h| h >= 0));
            assert_eq!(hints.reverse.len(), target.samples(300).len());
        }
        // The last joint turned alone (a hierarchical stage's step): the points it does
        // not move keep their keys and are not searched again, and the pairs are still
        // those of a search from nothing; at the same pose again nothing is searched.
        at.theta[2] += 0.05;
        let pose = rig.skeleton().forward(&at.theta).unwrap();
        let (p, n) = problem.posed_points(&pose, &at.root, &points).unwrap();
        let stale = |hints: &Hints| {
            let (stale, _) = hints
                .clone()
                .forward_stale(&points, &p, &n, rig.n_vertices());
            stale.len()
        };
        let moved = stale(&hints);
        assert!(
            moved > 0 && moved < points.len() / 2,
            "{moved} of {}",
            points.len()
        );
        let (cold, warm) = both(&at, &options, &mut hints);
        assert_eq!(warm, cold);
        assert_eq!(stale(&hints), 0);
        let coarser = FitOptions {
            reverse_points: 150,
            ..options
        };
        let (cold, warm) = both(&at, &coarser, &mut hints);
        assert_eq!(warm, cold);
        assert_eq!(hints.reverse.len(), target.samples(150).len());
        assert_ne!(target.samples(150).len(), target.samples(300).len());
    }

    /// The gradient JᵀWr is dE/dp of the robust energy for fixed pairs (both directions),
    /// and JᵀWJ is symmetric: checked against central differences of `energy`.
    #[test]
    fn gradient_matches_finite_differences() {
        let rig = tube();
        let truth = Params {
            root: root([0.1, -0.2, 0.3], [0.5, 0.0, 1.0]),
            theta: vec![0.4, -0.2, 0.6],
        };
        let target = target_at(&rig, &truth);
        let at = Params {
            root: root([0.12, -0.17, 0.33], [0.52, 0.01, 0.98]),
            theta: vec![0.3, -0.1, 0.5],
        };
        let pose = rig.skeleton().forward(&at.theta).unwrap();
        let points: Vec<u32> = (0..rig.n_vertices() as u32).step_by(3).collect();
        for (kind, reverse_weight) in [
            (Residual::PointToPoint, 0.0),
            (Residual::PointToPlane, 0.0),
            (Residual::PointToPoint, 0.7),
        ] {
            let problem = Problem {
                rig: &rig,
                target: &target,
                kind,
                threads: 2,
            };
            let options = FitOptions {
                gate: Gate {
                    max_distance: 1.0,
                    max_angle: 3.0,
                },
                reverse_weight,
                reverse_points: 300,
                ..FitOptions::default()
            };
            let found = problem
                .correspond(
                    &pose,
                    &at.root,
                    &points,
                    &options,
                    reverse_weight > 0.0,
                    &mut Hints::default(),
                )
                .unwrap();
            assert_eq!(found.reverse.is_empty(), reverse_weight == 0.0);
            let sigma = robust_sigma(&found.forward, 0.004);
            let active: Vec<usize> = (0..9).collect();
            let sums = problem
                .normal_equations(&pose, &at.root, &found.pairs, sigma, &active, None)
                .unwrap();
            let h = 1e-6;
            for a in 0..9 {
                let e = |s: f64| {
                    let mut p = at.clone();
                    match a {
                        0..=2 => p.root.translation[a] += s,
                        3..=5 => {
                            let mut w = Vector3::zeros();
                            w[a - 3] = s;
                            p.root.rotation =
                                nalgebra::Rotation3::new(w).into_inner() * p.root.rotation;
                        }
                        _ => p.theta[a - 6] += s,
                    }
                    let pose = rig.skeleton().forward(&p.theta).unwrap();
                    problem.energy(&pose, &p.root, &found.pairs, sigma).unwrap()
                };
                let fd = (e(h) - e(-h)) / (2.0 * h);
                let g = sums.gradient[a];
                assert!(
                    (fd - g).abs() <= 1e-6 * (1.0 + g.abs()),
                    "{kind:?} reverse {reverse_weight}, param {a}: {fd} vs {g}"
                );
            }
            for a in 0..9 {
                for b in 0..9 {
                    assert_eq!(sums.hessian[a * 9 + b], sums.hessian[b * 9 + a]);
                }
            }
        }
    }
}
