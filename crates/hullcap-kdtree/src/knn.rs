//! The k nearest keys of each query, gated, in parallel batches.

use crate::KdTreeError;
use crate::build::NormalKdTree;
use crate::descend::Candidates;
use crate::gate::{Gate, PreparedGate};
use crate::keys::Key;
use crate::nearest::Neighbor;

impl NormalKdTree {
    /// For each query, its `k` nearest keys, nearest first, as `M × k` rows (row-major).
    ///
    /// A neighbour whose pair fails `gate` is [`Neighbor::NONE`], in place (so the row keeps
    /// its order by distance); so are the slots past the tree's size when `k > len()`.
    pub fn query_k(
        &self,
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        k: usize,
        gate: &Gate,
        threads: Option<usize>,
    ) -> Result<Vec<Neighbor>, KdTreeError> {
        if k == 0 {
            return Err(KdTreeError::BadParameter {
                name: "k",
                requirement: "at least 1",
                value: 0.0,
            });
        }
        let threads = hullcap_core::resolve_threads(threads);
        let (queries, gate) = self.batch_queries(points, normals, gate, threads)?;
        self.answer_batch(
            &queries,
            k,
            threads,
            || KBest::new(k.min(self.keys.len())), // slots past the tree's size stay empty
            |best, _, q, row| {
                self.k_nearest_key(q, &gate, best, row);
            },
        )
    }

    fn k_nearest_key(&self, q: &Key, gate: &PreparedGate, best: &mut KBest, row: &mut [Neighbor]) {
        best.reset(gate.radius2);
        self.descend(0, q, &mut [0.0; 6], 0.0, best);
        for (slot, &(d2, pos)) in row.iter_mut().zip(&best.items) {
            if pos != u32::MAX && gate.passes(q, &self.keys[pos as usize]) {
                *slot = Neighbor {
                    index: i64::from(self.order[pos as usize]),
                    distance: d2.sqrt(),
                };
            }
        }
    }
}

/// The k best (squared distance, leaf slot) pairs so far, sorted ascending; empty places
/// hold the search radius and slot `u32::MAX`.
struct KBest {
    items: Vec<(f64, u32)>,
}

impl KBest {
    fn new(k: usize) -> Self {
        KBest {
            items: vec![(f64::INFINITY, u32::MAX); k],
        }
    }
    fn reset(&mut self, radius2: f64) {
        self.items
            .iter_mut()
            .for_each(|it| *it = (radius2, u32::MAX));
    }
}

impl Candidates for KBest {
    /// The k-th best so far.
    #[inline]
    fn bound(&self) -> f64 {
        self.items[self.items.len() - 1].0
    }
    /// Inserts a pair known to beat the k-th, keeping the order.
    fn keep(&mut self, d2: f64, slot: u32) {
        let mut i = self.items.len() - 1;
        while i > 0 && self.items[i - 1].0 > d2 {
            self.items[i] = self.items[i - 1];
            i -= 1;
        }
        self.items[i] = (d2, slot);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::keys::{self, dist2};
    use crate::testing::{adversarial_clouds, random_cloud};

    /// All distances from a query to every key, sorted, gated like the tree.
    fn brute_k(tree: &NormalKdTree, p: &[f64; 3], n: &[f64; 3], k: usize, gate: &Gate) -> Vec<f64> {
        let q = keys::key(p, n, tree.lambda);
        let g = gate.prepare(tree.lambda);
        let mut all: Vec<(f64, bool)> = tree
            .keys
            .iter()
            .map(|t| (dist2(&q, t), g.passes(&q, t)))
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        (0..k)
            .map(|i| match all.get(i) {
                Some(&(d2, true)) => d2.sqrt(),
                _ => f64::INFINITY,
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_random_and_adversarial() {
        let (q, qn) = random_cloud(200, 5);
        let mut clouds = adversarial_clouds();
        let (p, n) = random_cloud(3000, 6);
        clouds.push(("random", p, n));
        for (name, p, n) in clouds {
            for k in [1, 2, 5, 17] {
                for gate in [
                    Gate::default(),
                    Gate {
                        max_distance: 0.5,
                        max_angle: 1.2,
                    },
                ] {
                    let opts = BuildOptions {
                        normal_weight: None,
                        leaf_size: 5,
                        ..BuildOptions::default()
                    };
                    let tree = NormalKdTree::build(&p, &n, &opts).unwrap();
                    let got = tree.query_k(&q, &qn, k, &gate, Some(2)).unwrap();
                    for (i, row) in got.chunks(k).enumerate() {
                        let want = brute_k(&tree, &q[i], &qn[i], k, &gate);
                        let dist: Vec<f64> = row.iter().map(|nb| nb.distance).collect();
                        assert_eq!(dist, want, "{name}, k {k}, query {i}");
                        assert!(
                            row.iter()
                                .all(|nb| (nb.index < 0) == nb.distance.is_infinite())
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn first_of_k_is_the_nearest() {
        let (p, n) = random_cloud(2000, 8);
        let (q, qn) = random_cloud(500, 9);
        let tree = NormalKdTree::build(&p, &n, &BuildOptions::default()).unwrap();
        let one = tree.query(&q, &qn, &Gate::default(), None).unwrap();
        let four = tree.query_k(&q, &qn, 4, &Gate::default(), None).unwrap();
        for (i, nb) in one.iter().enumerate() {
            assert_eq!(nb.distance, four[4 * i].distance);
        }
        assert!(matches!(
            tree.query_k(&q, &qn, 0, &Gate::default(), None),
            Err(KdTreeError::BadParameter { name: "k", .. })
        ));
    }
}
