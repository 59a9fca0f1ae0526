//! Building the tree: median splits on the dimension of largest variance, flat arrays.

use crate::KdTreeError;
use crate::keys::{self, Key};

/// Points per leaf bucket unless told otherwise (measured best on the benchmark cloud).
pub const DEFAULT_LEAF_SIZE: usize = 16;

/// Marks a leaf in [`Node::dim`].
const LEAF: u32 = u32::MAX;

/// How to build a [`NormalKdTree`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuildOptions {
    /// λ, metres per unit of normal difference; `None` = [`crate::default_normal_weight`].
    pub normal_weight: Option<f64>,
    /// Most points in a leaf bucket (at least 1).
    pub leaf_size: usize,
    /// Threads for the build (`None`: [`hullcap_core::resolve_threads`]); the tree does
    /// not depend on it.
    pub threads: Option<usize>,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            normal_weight: None,
            leaf_size: DEFAULT_LEAF_SIZE,
            threads: None,
        }
    }
}

/// Subtrees with fewer points than this are built on the thread that reaches them: below
/// it, starting a thread costs about what it saves (a fit's tree of a few thousand
/// vertices, rebuilt at every iteration, is faster on one thread).
const PARALLEL_MIN_POINTS: usize = 4096;

/// One node of the tree, inner or leaf, 24 bytes.
///
/// Inner: keys in `a` have `key[dim] <= split`, keys in `b` have `key[dim] >= split`
/// (`a`, `b` are node indices). Leaf (`dim == LEAF`): its keys are `keys[a..b]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Node {
    pub(crate) split: f64,
    pub(crate) dim: u32,
    pub(crate) a: u32,
    pub(crate) b: u32,
}

impl Node {
    #[inline(always)]
    pub(crate) fn is_leaf(&self) -> bool {
        self.dim == LEAF
    }
}

/// The normal-aware 6-D kd-tree over a target cloud; see the crate documentation.
#[derive(Debug, Clone)]
pub struct NormalKdTree {
    /// Nodes, root first.
    pub(crate) nodes: Vec<Node>,
    /// Keys in leaf order: each leaf's keys are contiguous.
    pub(crate) keys: Vec<Key>,
    /// `order[k]` = the caller's index of `keys[k]`.
    pub(crate) order: Vec<u32>,
    /// `slot[i]` = where the caller's key `i` lies in `keys` (the inverse of `order`).
    pub(crate) slot: Vec<u32>,
    pub(crate) lambda: f64,
    leaf_size: usize,
}

impl NormalKdTree {
    /// Builds the tree of `points` (N×3, metres) with `normals` (N×3, any non-zero length;
    /// they are normalised).
    ///
    /// Errors: no points, mismatched lengths, non-finite values, zero normals, λ ≤ 0 or not
    /// finite, a leaf size of 0.
    pub fn build(
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        options: &BuildOptions,
    ) -> Result<Self, KdTreeError> {
        if points.is_empty() {
            return Err(KdTreeError::Empty);
        }
        if points.len() >= u32::MAX as usize {
            return Err(KdTreeError::TooMany(points.len()));
        }
        if options.leaf_size == 0 {
            return Err(KdTreeError::BadParameter {
                name: "leaf_size",
                requirement: "at least 1",
                value: 0.0,
            });
        }
        keys::validate(points, normals, ("points", "normals"))?;
        let lambda = match options.normal_weight {
            None => keys::default_normal_weight(points),
            Some(l) if l.is_finite() && l > 0.0 => l,
            Some(l) => {
                return Err(KdTreeError::BadParameter {
                    name: "normal_weight",
                    requirement: "positive and finite",
                    value: l,
                });
            }
        };
        let keys: Vec<Key> = points
            .iter()
            .zip(normals)
            .map(|(p, n)| keys::key(p, n, lambda))
            .collect();
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * points.len().div_ceil(options.leaf_size));
        let threads = hullcap_core::resolve_threads(options.threads);
        split(&keys, &mut order, 0, &mut nodes, options.leaf_size, threads)?;
        let keys = order.iter().map(|&i| keys[i as usize]).collect();
        let mut slot = vec![0u32; order.len()];
        for (k, &i) in order.iter().enumerate() {
            slot[i as usize] = k as u32;
        }
        Ok(NormalKdTree {
            nodes,
            keys,
            order,
            slot,
            lambda,
            leaf_size: options.leaf_size,
        })
    }

    /// Number of points in the tree.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Always false: a tree has at least one point.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// λ, metres per unit of normal difference.
    pub fn normal_weight(&self) -> f64 {
        self.lambda
    }

    /// Most points in a leaf bucket.
    pub fn leaf_size(&self) -> usize {
        self.leaf_size
    }

    /// Number of nodes (inner and leaves).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

/// Builds the subtree of `order` (a slice of the caller's indices starting at `offset` in
/// leaf order), appending its nodes in depth-first order; returns the index of its root.
/// With `threads` > 1 a large subtree's right half is built on another thread into its
/// own list, then appended with its node indices shifted: the same nodes as one thread
/// would append.
fn split(
    keys: &[Key],
    order: &mut [u32],
    offset: usize,
    nodes: &mut Vec<Node>,
    leaf_size: usize,
    threads: usize,
) -> Result<u32, KdTreeError> {
    let here = nodes.len() as u32;
    if order.len() <= leaf_size {
        nodes.push(Node {
            split: 0.0,
            dim: LEAF,
            a: offset as u32,
            b: (offset + order.len()) as u32,
        });
        return Ok(here);
    }
    let dim = widest_dimension(keys, order);
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&i, &j| {
        keys[i as usize][dim].total_cmp(&keys[j as usize][dim])
    });
    let split_value = keys[order[mid] as usize][dim];
    nodes.push(Node {
        split: split_value,
        dim: dim as u32,
        a: 0,
        b: 0,
    });
    let parallel = threads > 1 && order.len() >= PARALLEL_MIN_POINTS;
    let (left, right) = order.split_at_mut(mid);
    let (a, b) = if parallel {
        let mut right_nodes = Vec::with_capacity(2 * right.len().div_ceil(leaf_size));
        let (a, b) = std::thread::scope(|scope| {
            let worker = scope.spawn(|| {
                split(
                    keys,
                    right,
                    offset + mid,
                    &mut right_nodes,
                    leaf_size,
                    threads - threads / 2,
                )
            });
            let a = split(keys, left, offset, nodes, leaf_size, threads / 2);
            let b = worker
                .join()
                .map_err(|payload| hullcap_core::WorkerPanicked::from_payload(payload.as_ref()));
            (a, b)
        });
        let (a, b) = (a?, b??);
        let shift = nodes.len() as u32;
        nodes.extend(right_nodes.into_iter().map(|mut node| {
            if !node.is_leaf() {
                node.a += shift;
                node.b += shift;
            }
            node
        }));
        (a, b + shift)
    } else {
        let a = split(keys, left, offset, nodes, leaf_size, 1)?;
        let b = split(keys, right, offset + mid, nodes, leaf_size, 1)?;
        (a, b)
    };
    nodes[here as usize].a = a;
    nodes[here as usize].b = b;
    Ok(here)
}

/// The dimension along which the keys of `order` have the largest variance.
fn widest_dimension(keys: &[Key], order: &[u32]) -> usize {
    let n = order.len() as f64;
    let mut mean = [0.0; 6];
    for &i in order {
        let k = &keys[i as usize];
        for d in 0..6 {
            mean[d] += k[d];
        }
    }
    mean.iter_mut().for_each(|m| *m /= n);
    let mut var = [0.0; 6];
    for &i in order {
        let k = &keys[i as usize];
        for d in 0..6 {
            let t = k[d] - mean[d];
            var[d] += t * t;
        }
    }
    (0..6).fold(0, |best, d| if var[d] > var[best] { d } else { best })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::random_cloud;

    #[test]
    fn every_point_lands_in_exactly_one_leaf_within_bounds() {
        let (p, n) = random_cloud(1000, 3);
        let tree = NormalKdTree::build(
            &p,
            &n,
            &BuildOptions {
                normal_weight: None,
                leaf_size: 7,
                ..BuildOptions::default()
            },
        )
        .unwrap();
        let mut seen = vec![false; p.len()];
        for &i in &tree.order {
            assert!(!seen[i as usize]);
            seen[i as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        // `slot` finds each caller's key in leaf order.
        for (i, &k) in tree.slot.iter().enumerate() {
            assert_eq!(tree.order[k as usize] as usize, i);
        }
        for node in tree.nodes.iter().filter(|n| n.is_leaf()) {
            assert!(node.b > node.a && (node.b - node.a) as usize <= 7);
        }
        // Every inner node separates its two subtrees on its split value.
        fn check(tree: &NormalKdTree, node: u32, lo: &mut [f64; 6], hi: &mut [f64; 6]) {
            let nd = tree.nodes[node as usize];
            if nd.is_leaf() {
                for k in &tree.keys[nd.a as usize..nd.b as usize] {
                    assert!((0..6).all(|d| lo[d] <= k[d] && k[d] <= hi[d]));
                }
                return;
            }
            let d = nd.dim as usize;
            let saved = hi[d];
            hi[d] = nd.split;
            check(tree, nd.a, lo, hi);
            hi[d] = saved;
            let saved = lo[d];
            lo[d] = nd.split;
            check(tree, nd.b, lo, hi);
            lo[d] = saved;
        }
        check(
            &tree,
            0,
            &mut [f64::NEG_INFINITY; 6],
            &mut [f64::INFINITY; 6],
        );
    }

    #[test]
    fn the_tree_does_not_depend_on_the_number_of_threads() {
        let (p, n) = random_cloud(20_000, 5);
        let build = |threads| {
            let options = BuildOptions {
                threads: Some(threads),
                ..BuildOptions::default()
            };
            NormalKdTree::build(&p, &n, &options).unwrap()
        };
        let one = build(1);
        for threads in [2, 3, 8] {
            let other = build(threads);
            assert_eq!(one.order, other.order, "threads={threads}");
            assert_eq!(one.keys, other.keys);
            assert_eq!(one.nodes.len(), other.nodes.len());
            for (a, b) in one.nodes.iter().zip(&other.nodes) {
                assert_eq!(
                    (a.split.to_bits(), a.dim, a.a, a.b),
                    (b.split.to_bits(), b.dim, b.a, b.b)
                );
            }
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        let p = [[0.0; 3]];
        let n = [[0.0, 0.0, 1.0]];
        for l in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let opts = BuildOptions {
                normal_weight: Some(l),
                leaf_size: 8,
                ..BuildOptions::default()
            };
            assert!(matches!(
                NormalKdTree::build(&p, &n, &opts),
                Err(KdTreeError::BadParameter {
                    name: "normal_weight",
                    ..
                })
            ));
        }
        let opts = BuildOptions {
            normal_weight: None,
            leaf_size: 0,
            ..BuildOptions::default()
        };
        assert!(matches!(
            NormalKdTree::build(&p, &n, &opts),
            Err(KdTreeError::BadParameter { .. })
        ));
        assert_eq!(
            NormalKdTree::build(&[], &[], &BuildOptions::default()).unwrap_err(),
            KdTreeError::Empty
        );
    }
}
