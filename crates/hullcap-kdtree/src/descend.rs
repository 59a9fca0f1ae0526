//! The one depth-first descent that serves both the nearest and the k-nearest queries.

use crate::build::NormalKdTree;
use crate::keys::{Key, dist2};

/// The best keys found so far by a descent: the nearest one, or the k nearest.
pub(crate) trait Candidates {
    /// The squared distance a key must beat to be kept (the search radius until enough
    /// keys are found).
    fn bound(&self) -> f64;
    /// Keeps the key at leaf position `slot`, known to beat [`Candidates::bound`].
    fn keep(&mut self, d2: f64, slot: u32);
}

impl NormalKdTree {
    /// Depth-first search with incremental distance to the cell (Arya & Mount): `off[d]` is
    /// the query's offset from the current cell along `d`, `rd` = Σ off², a lower bound on
    /// the squared distance from `q` to any key in the cell; a cell is entered only when
    /// that bound beats the candidates' bound.
    pub(crate) fn descend<C: Candidates>(
        &self,
        node: u32,
        q: &Key,
        off: &mut [f64; 6],
        rd: f64,
        best: &mut C,
    ) {
        let nd = self.nodes[node as usize];
        if nd.is_leaf() {
            for slot in nd.a..nd.b {
                let d2 = dist2(q, &self.keys[slot as usize]);
                if d2 < best.bound() {
                    best.keep(d2, slot);
                }
            }
            return;
        }
        let dim = nd.dim as usize;
        let diff = q[dim] - nd.split;
        let (near, far) = if diff <= 0.0 {
            (nd.a, nd.b)
        } else {
            (nd.b, nd.a)
        };
        self.descend(near, q, off, rd, best);
        let old = off[dim];
        let far_rd = rd - old * old + diff * diff;
        if far_rd < best.bound() {
            off[dim] = diff;
            self.descend(far, q, off, far_rd, best);
            off[dim] = old;
        }
    }
}
