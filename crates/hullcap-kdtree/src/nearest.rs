//! The exact nearest key of each query, gated, in parallel batches.

use crate::KdTreeError;
use crate::build::NormalKdTree;
use crate::descend::Candidates;
use crate::gate::Gate;
use crate::keys::{Key, dist2};

/// The answer for one query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbor {
    /// The caller's index of the nearest key, or −1 when that pair is gated out (or, for
    /// k-nearest queries, when the tree has fewer than k points).
    pub index: i64,
    /// Euclidean distance between the query's key and that key in the 6-D space
    /// (√(‖Δp‖² + λ²‖Δn‖²)); +∞ where `index` is −1.
    pub distance: f64,
}

impl Default for Neighbor {
    fn default() -> Self {
        Neighbor::NONE
    }
}

impl Neighbor {
    /// The answer for a query with no admissible neighbour.
    pub const NONE: Neighbor = Neighbor {
        index: -1,
        distance: f64::INFINITY,
    };
}

impl NormalKdTree {
    /// For each query point with its normal (any non-zero length), the nearest key of the
    /// tree, or [`Neighbor::NONE`] where that nearest pair fails `gate`.
    ///
    /// `threads`: `None` = all cores. Errors on mismatched lengths, non-finite values,
    /// zero normals, or a bad gate.
    pub fn query(
        &self,
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        gate: &Gate,
        threads: Option<usize>,
    ) -> Result<Vec<Neighbor>, KdTreeError> {
        self.nearest_keys(points, normals, gate, |_| None, threads)
    }

    /// [`NormalKdTree::query`] with a hint per query: the caller's index of a key that is
    /// probably near it (the query's answer at the last iteration of a fit whose points
    /// moved a little since), or −1 for none. The answers are `query`'s (the nearest key,
    /// gated): a hint only sets the search's first bound, the distance to the hinted key,
    /// which spares the descent the cells that cannot hold a nearer key. Where another
    /// key lies at exactly the hinted key's distance, the hinted one is returned.
    ///
    /// # Errors
    /// As [`NormalKdTree::query`]; [`KdTreeError::LengthMismatch`] when `hints` does not
    /// have one entry per query and [`KdTreeError::BadParameter`] for a hint that is not
    /// −1 or the index of a key.
    pub fn query_hinted(
        &self,
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        gate: &Gate,
        hints: &[i64],
        threads: Option<usize>,
    ) -> Result<Vec<Neighbor>, KdTreeError> {
        one_per_query("hints", hints.len(), points.len())?;
        if let Some(&bad) = hints
            .iter()
            .find(|&&h| h < -1 || h >= self.keys.len() as i64)
        {
            return Err(KdTreeError::BadParameter {
                name: "hints",
                requirement: "-1 or the index of a key of the tree",
                value: bad as f64,
            });
        }
        self.nearest_keys(
            points,
            normals,
            gate,
            |i| (hints[i] >= 0).then(|| self.slot[hints[i] as usize]),
            threads,
        )
    }

    /// The gated nearest key of each query, the search of query `i` bounded from the
    /// start by the key at leaf position `hint(i)` when there is one.
    fn nearest_keys(
        &self,
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        gate: &Gate,
        hint: impl Fn(usize) -> Option<u32> + Sync,
        threads: Option<usize>,
    ) -> Result<Vec<Neighbor>, KdTreeError> {
        let threads = hullcap_core::resolve_threads(threads);
        let (queries, gate) = self.batch_queries(points, normals, gate, threads)?;
        self.answer_batch(
            &queries,
            1,
            threads,
            || (),
            |_, i, q, row| {
                let mut start = Best::within(gate.radius2);
                if let Some(slot) = hint(i) {
                    let d2 = dist2(q, &self.keys[slot as usize]);
                    if d2 < start.dist2 {
                        start = Best { dist2: d2, slot };
                    }
                }
                let best = self.nearest_from(q, start);
                row[0] = if best.slot == u32::MAX || !gate.passes(q, &self.keys[best.slot as usize])
                {
                    Neighbor::NONE
                } else {
                    best.neighbor(self)
                };
            },
        )
    }

    /// The nearest key of each query among those strictly nearer than its own bound
    /// `within[i]` (a 6-D distance, +∞ for none), or none (index −1) where no key is; no
    /// gate. For a search over part of a cloud bounded by the nearest key already found in
    /// the rest: it looks only where a nearer key can be, which costs little when most
    /// queries lie far from this part.
    ///
    /// # Errors
    /// As [`NormalKdTree::query`]; [`KdTreeError::LengthMismatch`] when `within` does not
    /// have one bound per query and [`KdTreeError::BadParameter`] for a NaN or negative
    /// bound.
    pub fn query_within(
        &self,
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        within: &[f64],
        threads: Option<usize>,
    ) -> Result<Vec<Neighbor>, KdTreeError> {
        one_per_query("within", within.len(), points.len())?;
        if let Some(&bad) = within.iter().find(|b| b.is_nan() || **b < 0.0) {
            return Err(KdTreeError::BadParameter {
                name: "within",
                requirement: "a non-negative distance or +inf",
                value: bad,
            });
        }
        let threads = hullcap_core::resolve_threads(threads);
        let (queries, _) = self.batch_queries(points, normals, &Gate::default(), threads)?;
        self.answer_batch(
            &queries,
            1,
            threads,
            || (),
            |_, i, q, row| {
                row[0] = self
                    .nearest_from(q, Best::within(within[i] * within[i]))
                    .neighbor(self);
            },
        )
    }

    /// The nearest key to `q` that beats `best` (the search's first bound and answer),
    /// or `best` itself when none does.
    fn nearest_from(&self, q: &Key, mut best: Best) -> Best {
        self.descend(0, q, &mut [0.0; 6], 0.0, &mut best);
        best
    }
}

/// An error unless the array `array` has one entry (`got`) per query (`queries`).
fn one_per_query(array: &'static str, got: usize, queries: usize) -> Result<(), KdTreeError> {
    if got != queries {
        return Err(KdTreeError::LengthMismatch {
            array,
            got,
            expected_from: "query points",
            expected: queries,
        });
    }
    Ok(())
}

#[derive(Clone, Copy)]
struct Best {
    dist2: f64,
    /// Position in leaf order; `u32::MAX` = none found yet.
    slot: u32,
}

impl Best {
    /// Nothing found yet, and only a key strictly within the squared 6-D distance
    /// `radius2` will do.
    fn within(radius2: f64) -> Best {
        Best {
            dist2: radius2,
            slot: u32::MAX,
        }
    }

    /// The key found as the caller's index and its distance; none when none was.
    fn neighbor(self, tree: &NormalKdTree) -> Neighbor {
        if self.slot == u32::MAX {
            return Neighbor::NONE;
        }
        Neighbor {
            index: i64::from(tree.order[self.slot as usize]),
            distance: self.dist2.sqrt(),
        }
    }
}

impl Candidates for Best {
    #[inline]
    fn bound(&self) -> f64 {
        self.dist2
    }
    #[inline]
    fn keep(&mut self, dist2: f64, slot: u32) {
        *self = Best { dist2, slot };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::testing::{adversarial_clouds, brute_nearest, distance_to, random_cloud};
    use proptest::prelude::*;

    fn assert_matches_brute(
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        queries: &[[f64; 3]],
        qn: &[[f64; 3]],
        gate: &Gate,
        leaf: usize,
    ) {
        let opts = BuildOptions {
            normal_weight: None,
            leaf_size: leaf,
            ..BuildOptions::default()
        };
        let tree = NormalKdTree::build(points, normals, &opts).unwrap();
        let got = tree.query(queries, qn, gate, Some(3)).unwrap();
        for (i, g) in got.iter().enumerate() {
            let want = brute_nearest(&tree, &queries[i], &qn[i], gate);
            assert_eq!(g.distance, want.distance, "query {i}: {g:?} vs {want:?}");
            if g.index != want.index {
                // Only a tie may pick another key, at exactly the same distance.
                assert_eq!(
                    distance_to(&tree, &queries[i], &qn[i], g.index),
                    want.distance
                );
            }
        }
    }

    #[test]
    fn matches_brute_force_on_random_clouds() {
        for (n, seed) in [(1, 1), (2, 2), (13, 3), (500, 4), (5000, 5)] {
            let (p, pn) = random_cloud(n, seed);
            let (q, qn) = random_cloud(700, seed + 100);
            for leaf in [1, 4, 12, 64] {
                assert_matches_brute(&p, &pn, &q, &qn, &Gate::default(), leaf);
            }
        }
    }

    #[test]
    fn matches_brute_force_on_adversarial_clouds() {
        let (q, qn) = random_cloud(300, 77);
        for (name, p, pn) in adversarial_clouds() {
            for leaf in [1, 3, 16] {
                for gate in [
                    Gate::default(),
                    Gate {
                        max_distance: 0.3,
                        max_angle: 1.0,
                    },
                ] {
                    let opts = BuildOptions {
                        normal_weight: None,
                        leaf_size: leaf,
                        ..BuildOptions::default()
                    };
                    let tree = NormalKdTree::build(&p, &pn, &opts).unwrap();
                    let got = tree.query(&q, &qn, &gate, Some(2)).unwrap();
                    for (i, g) in got.iter().enumerate() {
                        let want = brute_nearest(&tree, &q[i], &qn[i], &gate);
                        assert_eq!(g.distance, want.distance, "{name}, leaf {leaf}, query {i}");
                    }
                }
            }
        }
    }

    /// A bounded query finds the brute-force nearest key when it lies strictly within
    /// the query's bound, and nothing otherwise.
    #[test]
    fn bounded_queries_match_brute_force_within_their_bounds() {
        let mut rng = crate::testing::Rng::new(9);
        for (n, seed) in [(1, 21), (40, 22), (3000, 23)] {
            let (p, pn) = random_cloud(n, seed);
            let (q, qn) = random_cloud(600, seed + 100);
            let tree = NormalKdTree::build(&p, &pn, &BuildOptions::default()).unwrap();
            let nearest: Vec<Neighbor> = (0..q.len())
                .map(|i| brute_nearest(&tree, &q[i], &qn[i], &Gate::default()))
                .collect();
            // Bounds around each query's nearest distance, exactly at it, and unbounded.
            let within: Vec<f64> = nearest
                .iter()
                .enumerate()
                .map(|(i, nb)| match i % 4 {
                    0 => nb.distance,
                    1 => f64::INFINITY,
                    _ => nb.distance * (1.0 + 0.5 * rng.signed()),
                })
                .collect();
            let got = tree.query_within(&q, &qn, &within, Some(2)).unwrap();
            let mut found = 0;
            for (i, (g, want)) in got.iter().zip(&nearest).enumerate() {
                if i % 4 == 0 {
                    // Exactly at the bound, rounding decides: the nearest key or none.
                    assert!(
                        *g == Neighbor::NONE || g.distance == want.distance,
                        "n {n}, query {i}"
                    );
                } else if want.distance < within[i] {
                    assert_eq!(g.distance, want.distance, "n {n}, query {i}");
                    found += 1;
                } else {
                    assert_eq!(*g, Neighbor::NONE, "n {n}, query {i}, bound {}", within[i]);
                }
            }
            assert!(found > q.len() / 4 && found < q.len(), "{found}");
        }
        let tree =
            NormalKdTree::build(&[[0.0; 3]], &[[0.0, 0.0, 1.0]], &BuildOptions::default()).unwrap();
        let one = ([[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]);
        assert!(matches!(
            tree.query_within(&one.0, &one.1, &[], None),
            Err(KdTreeError::LengthMismatch {
                array: "within",
                ..
            })
        ));
        for bad in [f64::NAN, -1.0] {
            assert!(matches!(
                tree.query_within(&one.0, &one.1, &[bad], None),
                Err(KdTreeError::BadParameter { name: "within", .. })
            ));
        }
    }

    /// A hinted query gives the unhinted answer whatever the hints: none, the nearest
    /// key itself, a key nearby, or any key at all; gated or not.
    #[test]
    fn hinted_queries_match_brute_force_whatever_the_hints() {
        let mut rng = crate::testing::Rng::new(31);
        for (n, seed) in [(1, 41), (40, 42), (3000, 43)] {
            let (p, pn) = random_cloud(n, seed);
            let (q, qn) = random_cloud(600, seed + 100);
            for leaf in [1, 16] {
                let opts = BuildOptions {
                    leaf_size: leaf,
                    ..BuildOptions::default()
                };
                let tree = NormalKdTree::build(&p, &pn, &opts).unwrap();
                for gate in [
                    Gate::default(),
                    Gate {
                        max_distance: 0.2,
                        max_angle: 1.0,
                    },
                ] {
                    let ungated: Vec<Neighbor> = (0..q.len())
                        .map(|i| brute_nearest(&tree, &q[i], &qn[i], &Gate::default()))
                        .collect();
                    let hints: Vec<i64> = ungated
                        .iter()
                        .enumerate()
                        .map(|(i, nb)| match i % 4 {
                            0 => -1,
                            1 => nb.index,
                            2 => (nb.index + 1) % n as i64,
                            _ => ((0.5 + 0.5 * rng.signed()) * n as f64) as i64 % n as i64,
                        })
                        .collect();
                    let got = tree.query_hinted(&q, &qn, &gate, &hints, Some(2)).unwrap();
                    let cold = tree.query(&q, &qn, &gate, Some(2)).unwrap();
                    for (i, (g, c)) in got.iter().zip(&cold).enumerate() {
                        let want = brute_nearest(&tree, &q[i], &qn[i], &gate);
                        assert_eq!(g.distance, want.distance, "n {n}, leaf {leaf}, query {i}");
                        assert_eq!(g, c, "n {n}, leaf {leaf}, query {i}: hinted and not");
                    }
                }
            }
        }
        let tree =
            NormalKdTree::build(&[[0.0; 3]], &[[0.0, 0.0, 1.0]], &BuildOptions::default()).unwrap();
        let one = ([[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]]);
        let g = Gate::default();
        assert!(matches!(
            tree.query_hinted(&one.0, &one.1, &g, &[], None),
            Err(KdTreeError::LengthMismatch { array: "hints", .. })
        ));
        for bad in [-2, 1] {
            assert!(matches!(
                tree.query_hinted(&one.0, &one.1, &g, &[bad], None),
                Err(KdTreeError::BadParameter { name: "hints", .. })
            ));
        }
    }

    #[test]
    fn gates_reject_by_distance_and_by_angle() {
        let p = [[0.0, 0.0, 0.0]];
        let n = [[0.0, 0.0, 1.0]];
        let opts = BuildOptions {
            normal_weight: Some(0.1),
            leaf_size: 4,
            ..BuildOptions::default()
        };
        let tree = NormalKdTree::build(&p, &n, &opts).unwrap();
        let near_gate = Gate {
            max_distance: 0.5,
            max_angle: 0.5,
        };
        // In space 0.4 away, same normal: passes; 0.6 away: rejected.
        let hit = tree
            .query(
                &[[0.4, 0.0, 0.0], [0.6, 0.0, 0.0]],
                &[[0.0, 0.0, 1.0]; 2],
                &near_gate,
                None,
            )
            .unwrap();
        assert_eq!(hit[0].index, 0);
        assert!((hit[0].distance - 0.4).abs() < 1e-15);
        assert_eq!(hit[1], Neighbor::NONE);
        // Normals 0.4 rad apart pass, 0.6 rad apart do not.
        let tilt = |a: f64| [a.sin(), 0.0, a.cos()];
        let hit = tree
            .query(&[[0.0; 3]; 2], &[tilt(0.4), tilt(0.6)], &near_gate, None)
            .unwrap();
        assert_eq!(hit[0].index, 0);
        assert_eq!(hit[1], Neighbor::NONE);
        // A pair exactly on the distance gate passes.
        let hit = tree
            .query(&[[0.5, 0.0, 0.0]], &[[0.0, 0.0, 1.0]], &near_gate, None)
            .unwrap();
        assert_eq!(hit[0].index, 0);
    }

    #[test]
    fn a_gated_nearest_is_not_replaced_by_a_farther_key() {
        // The 6-D nearest (index 0) faces away; index 1 faces the query's way but is farther.
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let n = [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]];
        let opts = BuildOptions {
            normal_weight: Some(0.01),
            leaf_size: 1,
            ..BuildOptions::default()
        };
        let tree = NormalKdTree::build(&p, &n, &opts).unwrap();
        let gate = Gate {
            max_distance: 2.0,
            max_angle: 0.1,
        };
        let hit = tree
            .query(&[[0.0; 3]], &[[0.0, 0.0, 1.0]], &gate, None)
            .unwrap();
        assert_eq!(hit[0], Neighbor::NONE);
    }

    #[test]
    fn bad_queries_are_refused() {
        let (p, n) = random_cloud(10, 1);
        let tree = NormalKdTree::build(&p, &n, &BuildOptions::default()).unwrap();
        let g = Gate::default();
        assert!(matches!(
            tree.query(&p, &n[..3], &g, None),
            Err(KdTreeError::LengthMismatch { .. })
        ));
        let bad = Gate {
            max_distance: -1.0,
            ..g
        };
        assert!(matches!(
            tree.query(&p, &n, &bad, None),
            Err(KdTreeError::BadParameter {
                name: "max_distance",
                ..
            })
        ));
        let bad = Gate {
            max_angle: f64::NAN,
            ..g
        };
        assert!(matches!(
            tree.query(&p, &n, &bad, None),
            Err(KdTreeError::BadParameter {
                name: "max_angle",
                ..
            })
        ));
        assert_eq!(tree.query(&[], &[], &g, None).unwrap(), vec![]);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn any_cloud_any_query_matches_brute_force(
            n in 1usize..200,
            seed in 0u64..1000,
            leaf in 1usize..20,
            lambda in 0.01f64..3.0,
            max_distance in prop_oneof![Just(f64::INFINITY), 0.0f64..2.0],
            max_angle in prop_oneof![Just(std::f64::consts::PI), 0.0f64..3.2],
        ) {
            let (p, pn) = random_cloud(n, seed);
            let (q, qn) = random_cloud(50, seed ^ 0xABCD);
            let opts = BuildOptions { normal_weight: Some(lambda), leaf_size: leaf, ..BuildOptions::default() };
            let tree = NormalKdTree::build(&p, &pn, &opts).unwrap();
            let gate = Gate { max_distance, max_angle };
            let got = tree.query(&q, &qn, &gate, Some(1)).unwrap();
            for (i, g) in got.iter().enumerate() {
                let want = brute_nearest(&tree, &q[i], &qn[i], &gate);
                prop_assert_eq!(g.distance, want.distance);
                prop_assert_eq!(g.index < 0, want.index < 0);
            }
        }
    }
}
