//! Statistics of poses that differ from the first only in some joints, as when a search
//! re-samples one limb with the rest of the body held: the model points and vertices
//! those joints do not move are posed and paired once for all the poses, and each pose
//! poses and pairs only what moves.
//!
//! The pairs are those of a fresh evaluation of each pose, in the same order, so the
//! statistics are too: a vertex bound to no link below a varying joint lies at the same
//! place, to the last bit, in every pose (its links' frames are computed from the same
//! angles), so its model→hull pair is the same; and each hull sample's nearest vertex is
//! the nearer of its nearest unmoved one, found once, and its nearest moved one. Only a
//! sample exactly as far from two vertices in the 6-D key space might be given the other
//! of the two (a full search takes whichever its tree meets first).

use crate::fit::{FitStats, Params, per_pose, statistics};
use crate::normal_equations::{PosedPoints, Problem, robust_sigma, spread};
use crate::{FitOptions, IcpError};
use hullcap_body::{Rig, RootPose, SkeletonPose};
use hullcap_kdtree::Neighbor;

/// Per rig vertex, whether it can move between `poses`; `None` unless all poses share the
/// first one's root motion (to the bit), at least one joint angle varies and some vertex
/// stays.
pub(crate) fn moving_vertices(rig: &Rig, poses: &[Params]) -> Option<Vec<bool>> {
    let first = poses.first()?;
    let root_bits = |p: &Params| {
        let (r, t) = (&p.root.rotation, &p.root.translation);
        r.iter()
            .chain(t.iter())
            .map(|x| x.to_bits())
            .collect::<Vec<_>>()
    };
    let root = root_bits(first);
    if poses.iter().any(|p| root_bits(p) != root) {
        return None;
    }
    let skeleton = rig.skeleton();
    let mut moving_links = vec![false; skeleton.n_links()];
    for (k, dof) in skeleton.dofs().iter().enumerate() {
        if poses
            .iter()
            .any(|p| p.theta[k].to_bits() != first.theta[k].to_bits())
        {
            for (j, moving) in moving_links.iter_mut().enumerate() {
                *moving |= skeleton.moves_with(j, dof.link);
            }
        }
    }
    let moving: Vec<bool> = (0..rig.n_vertices())
        .map(|i| rig.vertex_weights(i).any(|(j, _)| moving_links[j]))
        .collect();
    (moving.contains(&true) && moving.contains(&false)).then_some(moving)
}

/// What every pose shares: its unmoved model points and vertices, posed and paired once.
struct Held {
    /// Posed model points (all of them, at the first pose) and their nearest target keys
    /// (−1 for none).
    points: PosedPoints,
    found: Vec<i64>,
    /// The positions in `model_points` of the points that move.
    moving_points: Vec<usize>,
    /// The vertices hull samples seek their partner among, posed at the first pose.
    every: Vec<u32>,
    vertices: PosedPoints,
    /// The positions in `every` of the vertices that move.
    moving_vertices: Vec<usize>,
    samples: Vec<u32>,
    /// The samples' positions and normals.
    sample_keys: PosedPoints,
    /// Each hull sample's nearest unmoved vertex (an index into `every`), and how far it
    /// lies: a moved vertex is sought only nearer than that.
    nearest_held: Vec<Neighbor>,
    held_distance: Vec<f64>,
}

/// The statistics of each of `poses`, as [`crate::evaluate_poses`] gives them, where
/// `moving` is [`moving_vertices`] of the poses. The shared part uses `threads` threads;
/// the poses are then spread over them, one thread each.
pub(crate) fn evaluate_variants(
    problem: &Problem<'_>,
    model_points: &[u32],
    poses: &[Params],
    moving: &[bool],
    options: &FitOptions,
) -> Result<Vec<FitStats>, IcpError> {
    let held = hold(problem, model_points, &poses[0], moving, options)?;
    let one = Problem {
        threads: 1,
        ..*problem
    };
    per_pose(poses, problem.threads, |params| {
        evaluate_variant(&one, model_points, &held, params, options)
    })
}

fn hold(
    problem: &Problem<'_>,
    model_points: &[u32],
    first: &Params,
    moving: &[bool],
    options: &FitOptions,
) -> Result<Held, IcpError> {
    let pose = problem.rig.skeleton().forward(&first.theta)?;
    let points = problem.posed_points(&pose, &first.root, model_points)?;
    let found = problem
        .target
        .tree
        .query(&points.0, &points.1, &options.gate, Some(problem.threads))?
        .iter()
        .map(|nb| nb.index)
        .collect();
    let moving_points = positions(model_points, |v| moving[v]);
    let every = spread(problem.rig.n_vertices(), options.reverse_vertices);
    let vertices = problem.posed_points(&pose, &first.root, &every)?;
    let moving_vertices = positions(&every, |v| moving[v]);
    let held_vertices = positions(&every, |v| !moving[v]);
    let samples = problem.target.samples(options.reverse_points);
    let sample_keys = problem.sample_keys(&samples);
    let unbounded = vec![f64::INFINITY; samples.len()];
    let nearest_held = nearest_among(problem, &vertices, &held_vertices, &sample_keys, &unbounded)?;
    Ok(Held {
        points,
        found,
        moving_points,
        every,
        vertices,
        moving_vertices,
        samples,
        sample_keys,
        held_distance: nearest_held.iter().map(|nb| nb.distance).collect(),
        nearest_held,
    })
}

fn evaluate_variant(
    problem: &Problem<'_>,
    model_points: &[u32],
    held: &Held,
    params: &Params,
    options: &FitOptions,
) -> Result<FitStats, IcpError> {
    let pose = problem.rig.skeleton().forward(&params.theta)?;
    let root = &params.root;
    let mut points = held.points.clone();
    let (p, n) = repose(
        problem,
        &pose,
        root,
        model_points,
        &held.moving_points,
        &mut points,
    )?;
    let partners = problem.target.tree.query(&p, &n, &options.gate, Some(1))?;
    let mut found = held.found.clone();
    for (&k, partner) in held.moving_points.iter().zip(partners) {
        found[k] = partner.index;
    }
    let mut pairs = problem.forward_pairs(model_points, &points.0, &found);

    let mut vertices = held.vertices.clone();
    repose(
        problem,
        &pose,
        root,
        &held.every,
        &held.moving_vertices,
        &mut vertices,
    )?;
    let nearer = nearest_among(
        problem,
        &vertices,
        &held.moving_vertices,
        &held.sample_keys,
        &held.held_distance,
    )?;
    let nearest: Vec<Neighbor> = held
        .nearest_held
        .iter()
        .zip(&nearer)
        .map(|(unmoved, moved)| if moved.index >= 0 { *moved } else { *unmoved })
        .collect();
    problem.add_reverse_pairs(
        &mut pairs,
        &held.every,
        &vertices,
        &held.samples,
        &nearest,
        options,
        model_points.len(),
    );
    let sigma = robust_sigma(&pairs.forward, options.sigma_min);
    statistics(problem, model_points, root, &pose, &pairs, sigma, options)
}

/// The points `indices[k]`, for each k of `at`, posed at (`pose`, `root`) and written over
/// their places in `posed`; returns them as posed.
fn repose(
    problem: &Problem<'_>,
    pose: &SkeletonPose,
    root: &RootPose,
    indices: &[u32],
    at: &[usize],
    posed: &mut PosedPoints,
) -> Result<PosedPoints, IcpError> {
    let chosen: Vec<u32> = at.iter().map(|&k| indices[k]).collect();
    let (p, n) = problem.posed_points(pose, root, &chosen)?;
    for (i, &k) in at.iter().enumerate() {
        (posed.0[k], posed.1[k]) = (p[i], n[i]);
    }
    Ok((p, n))
}

/// The positions in `indices` of the vertices `keep` says yes to.
fn positions(indices: &[u32], keep: impl Fn(usize) -> bool) -> Vec<usize> {
    (0..indices.len())
        .filter(|&k| keep(indices[k] as usize))
        .collect()
}

/// The nearest (ungated) vertex of each hull sample (`points`, `normals`) among `vertices`
/// at positions `among` that is nearer than the sample's bound in `within`, as an index
/// into `vertices`; none (index −1, infinitely far) where there is no such vertex.
fn nearest_among(
    problem: &Problem<'_>,
    vertices: &PosedPoints,
    among: &[usize],
    (points, normals): &PosedPoints,
    within: &[f64],
) -> Result<Vec<Neighbor>, IcpError> {
    if among.is_empty() {
        return Ok(vec![Neighbor::NONE; points.len()]);
    }
    let subset: PosedPoints = among
        .iter()
        .map(|&k| (vertices.0[k], vertices.1[k]))
        .unzip();
    let found = problem.vertex_tree(&subset)?.query_within(
        points,
        normals,
        within,
        Some(problem.threads),
    )?;
    Ok(found
        .into_iter()
        .map(|nb| match usize::try_from(nb.index) {
            Ok(i) => Neighbor {
                index: among[i] as i64,
                ..nb
            },
            Err(_) => Neighbor::NONE,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate_poses;
    use crate::fit::evaluate;
    use crate::testing::{root, target_at, tube};

    fn posed(theta: [f64; 3]) -> Params {
        Params {
            root: root([0.05, -0.1, 0.2], [0.3, -0.2, 1.0]),
            theta: theta.to_vec(),
        }
    }

    /// Limb samples as a search draws them: the last joint turned, the rest held (about
    /// half the tube's vertices are bound to the last link).
    #[test]
    fn varying_some_joints_gives_the_statistics_of_fresh_evaluations() {
        let rig = tube();
        let target = target_at(&rig, &posed([0.5, -0.3, 0.7]));
        let points: Vec<u32> = (0..rig.n_vertices() as u32).step_by(3).collect();
        let options = FitOptions {
            reverse_vertices: 500,
            reverse_points: 300,
            ..FitOptions::default()
        };
        let poses: Vec<Params> = (0..13)
            .map(|s| posed([0.5, -0.3, 0.7 + 0.1 * (s - 6) as f64]))
            .collect();
        let moving = moving_vertices(&rig, &poses).expect("only some vertices move");
        let share = moving.iter().filter(|&&m| m).count() as f64 / rig.n_vertices() as f64;
        assert!((0.4..0.6).contains(&share), "{share}");
        let got = evaluate_poses(&rig, &target, &points, &poses, &options).unwrap();
        for (params, stats) in poses.iter().zip(&got) {
            let alone = evaluate(&rig, &target, &points, params, &options, 1).unwrap();
            assert_eq!(stats, &alone, "at {:?}", params.theta);
        }
        let coverage: Vec<f64> = got.iter().map(|s| s.coverage).collect();
        assert!(coverage[6] > 0.99 && coverage[0] < 0.8, "{coverage:?}");
    }

    #[test]
    fn poses_that_differ_in_the_root_or_not_at_all_are_evaluated_in_full() {
        let rig = tube();
        let a = posed([0.1, 0.2, 0.3]);
        let mut b = a.clone();
        b.theta[2] = 0.4;
        assert!(moving_vertices(&rig, &[a.clone(), b.clone()]).is_some());
        b.root.translation.x += 1e-12;
        assert!(moving_vertices(&rig, &[a.clone(), b]).is_none());
        assert!(moving_vertices(&rig, &[a.clone(), a.clone()]).is_none());
        let mut c = a.clone();
        c.theta[0] = 0.5; // every vertex is bound to the middle link or below it
        assert!(moving_vertices(&rig, &[a, c]).is_none());
    }
}
