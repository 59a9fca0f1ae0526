//! One IRLS linearisation: correspondences, robust weights, and the normal equations
//! JᵀWJ, JᵀWr summed over the pairs in parallel chunks.

use crate::{IcpError, Residual, Target};
use hullcap_body::{Rig, RootPose, SkeletonPose};
use hullcap_kdtree::Gate;
use nalgebra::Vector3;

/// A model vertex and its partner on the target.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    pub vertex: u32,
    pub target: u32,
}

/// Sums over the pairs: Gauss–Newton Hessian, gradient and robust energy.
#[derive(Debug, Clone)]
pub(crate) struct Sums {
    /// JᵀWJ over the active parameters, row-major n × n.
    pub hessian: Vec<f64>,
    /// JᵀWr.
    pub gradient: Vec<f64>,
    /// Σ ρ(d).
    pub energy: f64,
}

impl Sums {
    fn zeros(n: usize) -> Self {
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

/// σ from the median pair distance (1.4826·median estimates a Gaussian's σ), bounded
/// below by `sigma_min`.
pub(crate) fn robust_sigma(distances: &[f64], sigma_min: f64) -> f64 {
    if distances.is_empty() {
        return sigma_min;
    }
    let mut d = distances.to_vec();
    let mid = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    (1.4826 * *median).max(sigma_min)
}

/// What every pass over the model points needs: the rig, the target, the residual kind
/// and the number of threads.
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

    /// `visit(accumulator, pairs)` over one contiguous share of `pairs` per thread.
    fn over_pairs<T: Send>(
        &self,
        pairs: &[Pair],
        init: impl Fn() -> T,
        visit: impl Fn(&mut T, &[Pair]) + Sync,
    ) -> Result<Vec<T>, IcpError> {
        let mut partial: Vec<T> = (0..self.threads.max(1)).map(|_| init()).collect();
        let per = pairs.len().div_ceil(partial.len()).max(1);
        hullcap_core::for_each_chunk_mut(&mut partial, self.threads, 1, |offset, chunk| {
            for (c, acc) in chunk.iter_mut().enumerate() {
                let lo = ((offset + c) * per).min(pairs.len());
                visit(acc, &pairs[lo..(lo + per).min(pairs.len())]);
            }
        })?;
        Ok(partial)
    }

    /// Partners of the model points posed at (`pose`, `root`), gated; with each matched
    /// pair's distance.
    pub(crate) fn correspond(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        model_points: &[u32],
        gate: &Gate,
    ) -> Result<(Vec<Pair>, Vec<f64>), IcpError> {
        let mut posed = vec![([0.0; 3], [0.0; 3]); model_points.len()];
        hullcap_core::for_each_chunk_mut(&mut posed, self.threads, 512, |offset, chunk| {
            for (slot, &i) in chunk.iter_mut().zip(&model_points[offset..]) {
                let (v, n) = self.rig.posed_vertex(pose, root, i as usize);
                *slot = (v.into(), n.into());
            }
        })?;
        let (points, normals): (Vec<[f64; 3]>, Vec<[f64; 3]>) = posed.into_iter().unzip();
        let found = self
            .target
            .tree
            .query(&points, &normals, gate, Some(self.threads))?;
        let mut pairs = Vec::with_capacity(found.len());
        let mut distances = Vec::with_capacity(found.len());
        for ((nb, &vertex), p) in found.iter().zip(model_points).zip(&points) {
            if nb.index >= 0 {
                let t = nb.index as usize;
                let (_, _, d) = residual(self.kind, self.target, &Vector3::from(*p), t);
                pairs.push(Pair {
                    vertex,
                    target: t as u32,
                });
                distances.push(d);
            }
        }
        Ok((pairs, distances))
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
                    let (_, _, d) = residual(self.kind, self.target, &v, p.target as usize);
                    *sum += lorentzian(d, sigma).0;
                }
            },
        )?;
        Ok(partial.iter().sum())
    }

    /// JᵀWJ, JᵀWr and Σρ over the pairs for the parameters `active` (indices into
    /// t, ω, θ), with IRLS weights at scale `sigma`.
    pub(crate) fn normal_equations(
        &self,
        pose: &SkeletonPose,
        root: &RootPose,
        pairs: &[Pair],
        sigma: f64,
        active: &[usize],
    ) -> Result<Sums, IcpError> {
        let n = active.len();
        let partial = self.over_pairs(
            pairs,
            || Sums::zeros(n),
            |sums, share| {
                let mut row = vec![[0.0; 3]; self.rig.n_params()];
                let mut j = vec![[0.0; 3]; n];
                for p in share {
                    let (i, t) = (p.vertex as usize, p.target as usize);
                    let v = self.world_vertex(pose, root, i);
                    let (r, m, d) = residual(self.kind, self.target, &v, t);
                    let (rho, w) = lorentzian(d, sigma);
                    sums.energy += rho;
                    self.rig.vertex_jacobian(pose, root, i, &mut row);
                    let nq = &self.target.normals[t];
                    for (slot, &a) in j.iter_mut().zip(active) {
                        *slot = match self.kind {
                            Residual::PointToPoint => row[a],
                            Residual::PointToPlane => [
                                row[a][0] * nq[0] + row[a][1] * nq[1] + row[a][2] * nq[2],
                                0.0,
                                0.0,
                            ],
                        };
                    }
                    for (a, ja) in j.iter().enumerate() {
                        sums.gradient[a] += w * (0..m).map(|k| ja[k] * r[k]).sum::<f64>();
                        for (b, jb) in j.iter().enumerate().skip(a) {
                            sums.hessian[a * n + b] +=
                                w * (0..m).map(|k| ja[k] * jb[k]).sum::<f64>();
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

    /// The gradient JᵀWr is dE/dp of the robust energy for fixed pairs, and JᵀWJ is
    /// symmetric: checked against central differences of `energy`.
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
        for kind in [Residual::PointToPoint, Residual::PointToPlane] {
            let problem = Problem {
                rig: &rig,
                target: &target,
                kind,
                threads: 2,
            };
            let gate = Gate {
                max_distance: 1.0,
                max_angle: 3.0,
            };
            let (pairs, d) = problem.correspond(&pose, &at.root, &points, &gate).unwrap();
            let sigma = robust_sigma(&d, 0.004);
            let active: Vec<usize> = (0..9).collect();
            let sums = problem
                .normal_equations(&pose, &at.root, &pairs, sigma, &active)
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
                    problem.energy(&pose, &p.root, &pairs, sigma).unwrap()
                };
                let fd = (e(h) - e(-h)) / (2.0 * h);
                let g = sums.gradient[a];
                assert!(
                    (fd - g).abs() <= 1e-6 * (1.0 + g.abs()),
                    "{kind:?} param {a}: {fd} vs {g}"
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
