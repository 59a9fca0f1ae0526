//! Test oracles: seeded clouds, adversarial clouds, and a brute-force scan.

use crate::build::NormalKdTree;
use crate::gate::Gate;
use crate::keys::{self, dist2};
use crate::nearest::Neighbor;

/// A small deterministic generator (xorshift64*), so tests need no extra crate.
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// Uniform in [-1, 1).
    pub(crate) fn signed(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        bits as f64 / (1u64 << 52) as f64 - 1.0
    }
    fn vector(&mut self) -> [f64; 3] {
        [self.signed(), self.signed(), self.signed()]
    }
    fn direction(&mut self) -> [f64; 3] {
        loop {
            let v = self.vector();
            if keys::unit(&v).is_some() && v.iter().map(|x| x * x).sum::<f64>() > 1e-6 {
                return v;
            }
        }
    }
}

/// `n` points in [-1, 1)³ with random (not unit-length) normals.
pub(crate) fn random_cloud(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut rng = Rng::new(seed);
    (0..n).map(|_| (rng.vector(), rng.direction())).unzip()
}

/// A named cloud: points and their normals.
pub(crate) type NamedCloud = (&'static str, Vec<[f64; 3]>, Vec<[f64; 3]>);

/// Clouds that break naive trees: duplicates, degenerate planes and lines, equal normals,
/// ties on a grid, a single point.
pub(crate) fn adversarial_clouds() -> Vec<NamedCloud> {
    let mut rng = Rng::new(99);
    let mut clouds = Vec::new();
    clouds.push(("one point", vec![[0.3, -0.2, 0.1]], vec![[0.0, 1.0, 0.0]]));
    clouds.push((
        "all duplicates",
        vec![[0.5, 0.5, 0.5]; 300],
        vec![[1.0, 0.0, 0.0]; 300],
    ));
    let three: Vec<[f64; 3]> = (0..300)
        .map(|i| [(i % 3) as f64 * 0.25, 0.0, 0.0])
        .collect();
    let three_n: Vec<[f64; 3]> = (0..300)
        .map(|i| {
            if i % 2 == 0 {
                [0.0, 0.0, 1.0]
            } else {
                [0.0, 1.0, 0.0]
            }
        })
        .collect();
    clouds.push(("three points repeated", three, three_n));
    let plane: Vec<[f64; 3]> = (0..400)
        .map(|_| [rng.signed(), rng.signed(), 0.0])
        .collect();
    let plane_n: Vec<[f64; 3]> = (0..400).map(|_| rng.direction()).collect();
    clouds.push(("points on a plane", plane.clone(), plane_n));
    clouds.push((
        "plane with equal normals",
        plane,
        vec![[0.0, 0.0, 1.0]; 400],
    ));
    let line: Vec<[f64; 3]> = (0..200).map(|i| [i as f64 * 0.01, 0.0, 0.0]).collect();
    clouds.push(("a line", line, vec![[0.0, 0.0, 2.0]; 200]));
    let grid: Vec<[f64; 3]> = (0..512)
        .map(|i| {
            [
                (i % 8) as f64 * 0.25 - 1.0,
                ((i / 8) % 8) as f64 * 0.25 - 1.0,
                (i / 64) as f64 * 0.25 - 1.0,
            ]
        })
        .collect();
    let grid_n: Vec<[f64; 3]> = (0..512)
        .map(|i| [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]][i % 3])
        .collect();
    clouds.push(("a grid with axis normals", grid, grid_n));
    clouds
}

/// The nearest key by scanning every key: lowest caller's index among exact ties, then
/// gated like the tree.
pub(crate) fn brute_nearest(
    tree: &NormalKdTree,
    p: &[f64; 3],
    n: &[f64; 3],
    gate: &Gate,
) -> Neighbor {
    let q = query_key(tree, p, n);
    let mut best = (f64::INFINITY, u32::MAX, 0usize);
    for (slot, k) in tree.keys.iter().enumerate() {
        let d2 = dist2(&q, k);
        let index = tree.order[slot];
        if d2 < best.0 || (d2 == best.0 && index < best.1) {
            best = (d2, index, slot);
        }
    }
    if !gate.prepare(tree.lambda).passes(&q, &tree.keys[best.2]) {
        return Neighbor::NONE;
    }
    Neighbor {
        index: i64::from(best.1),
        distance: best.0.sqrt(),
    }
}

/// The 6-D distance from the query to the key of the caller's `index`.
pub(crate) fn distance_to(tree: &NormalKdTree, p: &[f64; 3], n: &[f64; 3], index: i64) -> f64 {
    let slot = tree
        .order
        .iter()
        .position(|&i| i64::from(i) == index)
        .expect("index in tree");
    dist2(&query_key(tree, p, n), &tree.keys[slot]).sqrt()
}

fn query_key(tree: &NormalKdTree, p: &[f64; 3], n: &[f64; 3]) -> keys::Key {
    keys::key(p, n, tree.lambda)
}
