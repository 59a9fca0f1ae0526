//! Non-penetrating geodesic skin weights (the paper's §2.2, eq. 1).
//!
//! x_ij is the length of the shortest path from vertex i to link j in the graph whose arcs
//! are the mesh edges plus, for every vertex, a straight arc to the closest point of each
//! link that crosses no triangle of the mesh (other than those at the vertex). A Dijkstra
//! search from each link (links in parallel) gives x_ij for every vertex, and
//! w_ij = exp(−b·x_ij) / Σ_j exp(−b·x_ij); the K largest are kept and renormalised.
//! Because no arc passes through the body, the inner thigh of one leg is far from the other
//! leg's link, though close to it in a straight line.

use crate::rig::SkinWeights;
use crate::{BodyError, TriangleBvh};
use std::cmp::Ordering;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Instant;

/// Parameters of [`skin_weights`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkinWeightOptions {
    /// Decay b of w = exp(−b·x), per metre. Larger = sharper, more rigid-looking bends;
    /// the default 40 m⁻¹ blends over a few centimetres (a vertex 2.5 cm nearer to one
    /// link than to another weighs e ≈ 2.7 times more).
    pub b: f64,
    /// Weights kept per vertex (K); 1 gives the rigid segment model.
    pub k: usize,
    /// Worker threads; `None` = all cores.
    pub threads: Option<usize>,
}

impl Default for SkinWeightOptions {
    fn default() -> Self {
        SkinWeightOptions {
            b: 40.0,
            k: 4,
            threads: None,
        }
    }
}

/// The geodesic distances x_ij and how long each stage took.
#[derive(Debug, Clone)]
pub struct LinkDistances {
    /// x_ij, row-major L × V (one row per link); +∞ where vertex i cannot reach link j.
    pub distances: Vec<f64>,
    /// The direct arcs, row-major V × L: the length to link j's closest point when that
    /// segment crosses no triangle, else +∞.
    pub direct: Vec<f64>,
    /// Seconds spent on the segment–mesh tests.
    pub visibility_seconds: f64,
    /// Seconds spent building the mesh's edge graph (once, shared by every link).
    pub graph_seconds: f64,
    /// Seconds spent in Dijkstra (all links).
    pub dijkstra_seconds: f64,
}

/// The closest point to `x` on the segment `s`.
fn closest_on_segment(x: &[f64; 3], s: &[[f64; 3]; 2]) -> [f64; 3] {
    let d = [s[1][0] - s[0][0], s[1][1] - s[0][1], s[1][2] - s[0][2]];
    let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let t = if len2 > 0.0 {
        (((x[0] - s[0][0]) * d[0] + (x[1] - s[0][1]) * d[1] + (x[2] - s[0][2]) * d[2]) / len2)
            .clamp(0.0, 1.0)
    } else {
        0.0
    };
    [s[0][0] + t * d[0], s[0][1] + t * d[1], s[0][2] + t * d[2]]
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Checks a triangle mesh: finite vertices, face indices in range.
pub(crate) fn check_mesh(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Result<(), BodyError> {
    crate::error::check_finite(vertices, "vertices")?;
    for (row, f) in faces.iter().enumerate() {
        if let Some(&i) = f.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(BodyError::IndexOutOfRange {
                array: "faces",
                row,
                index: i64::from(i),
                bound: vertices.len(),
            });
        }
    }
    Ok(())
}

/// x_ij for every vertex i and link segment j (see the module documentation).
pub fn link_distances(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    links: &[[[f64; 3]; 2]],
    threads: Option<usize>,
) -> Result<LinkDistances, BodyError> {
    check_mesh(vertices, faces)?;
    if links.is_empty() {
        return Err(BodyError::WrongLength {
            array: "links",
            got: 0,
            expected: 1,
        });
    }
    for (row, s) in links.iter().enumerate() {
        if !s.iter().flatten().all(|x| x.is_finite()) {
            return Err(BodyError::NotFinite {
                array: "links",
                row,
            });
        }
    }
    let threads = hullcap_core::resolve_threads(threads);
    let (nv, nl) = (vertices.len(), links.len());

    let started = Instant::now();
    let bvh = TriangleBvh::new(vertices, faces);
    let mut direct = vec![f64::INFINITY; nv * nl];
    let mut rows: Vec<&mut [f64]> = direct.chunks_mut(nl).collect();
    hullcap_core::for_each_chunk_mut(&mut rows, threads, 64, |offset, chunk| {
        for (i, row) in chunk.iter_mut().enumerate() {
            let v = &vertices[offset + i];
            for (slot, link) in row.iter_mut().zip(links) {
                let c = closest_on_segment(v, link);
                if !bvh.segment_crosses(v, &c, (offset + i) as u32) {
                    *slot = distance(v, &c);
                }
            }
        }
    })?;
    let visibility_seconds = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let graph = EdgeGraph::new(vertices, faces);
    let graph_seconds = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let mut distances = vec![f64::INFINITY; nl * nv];
    let mut per_link: Vec<&mut [f64]> = distances.chunks_mut(nv).collect();
    hullcap_core::for_each_chunk_mut(&mut per_link, threads, 1, |offset, chunk| {
        for (j, dist) in chunk.iter_mut().enumerate() {
            graph.dijkstra(|i| direct[i * nl + offset + j], dist);
        }
    })?;
    let dijkstra_seconds = started.elapsed().as_secs_f64();
    Ok(LinkDistances {
        distances,
        direct,
        visibility_seconds,
        graph_seconds,
        dijkstra_seconds,
    })
}

/// Skin weights of every vertex over link groups: `groups[j]` is the bone link segment j
/// moves with (a structure link belongs to its parent's group), `n_groups` their number.
/// Returns the K-sparse weights (indices are groups) and the distances they came from.
///
/// A vertex that reaches no link (a loose fragment whose every arc is blocked) falls back
/// to straight-line distances.
pub fn skin_weights(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    links: &[[[f64; 3]; 2]],
    groups: &[u32],
    n_groups: usize,
    options: &SkinWeightOptions,
) -> Result<(SkinWeights, LinkDistances), BodyError> {
    if !(options.b.is_finite() && options.b > 0.0) {
        return Err(BodyError::BadParameter {
            name: "b",
            requirement: "positive and finite",
            value: options.b,
        });
    }
    if options.k == 0 {
        return Err(BodyError::BadParameter {
            name: "k",
            requirement: "at least 1",
            value: 0.0,
        });
    }
    if groups.len() != links.len() {
        return Err(BodyError::WrongLength {
            array: "groups",
            got: groups.len(),
            expected: links.len(),
        });
    }
    if let Some(row) = groups.iter().position(|&g| g as usize >= n_groups) {
        return Err(BodyError::IndexOutOfRange {
            array: "groups",
            row,
            index: i64::from(groups[row]),
            bound: n_groups,
        });
    }
    let found = link_distances(vertices, faces, links, options.threads)?;
    let (nv, k) = (vertices.len(), options.k.min(n_groups));
    let mut index = vec![0u32; nv * k];
    let mut weight = vec![0.0; nv * k];
    let mut rows: Vec<(&mut [u32], &mut [f64])> =
        index.chunks_mut(k).zip(weight.chunks_mut(k)).collect();
    let threads = hullcap_core::resolve_threads(options.threads);
    hullcap_core::for_each_chunk_mut(&mut rows, threads, 256, |offset, chunk| {
        let mut x = vec![0.0; links.len()];
        let mut w = vec![(0.0, 0u32); n_groups];
        for (r, (idx_row, w_row)) in chunk.iter_mut().enumerate() {
            let i = offset + r;
            x.iter_mut()
                .enumerate()
                .for_each(|(j, xj)| *xj = found.distances[j * nv + i]);
            if x.iter().all(|v| v.is_infinite()) {
                x.iter_mut().zip(links).for_each(|(xj, s)| {
                    *xj = distance(&vertices[i], &closest_on_segment(&vertices[i], s))
                });
            }
            let x_min = x.iter().copied().fold(f64::INFINITY, f64::min);
            w.iter_mut()
                .enumerate()
                .for_each(|(g, e)| *e = (0.0, g as u32));
            for (j, &xj) in x.iter().enumerate() {
                w[groups[j] as usize].0 += (-options.b * (xj - x_min)).exp();
            }
            // The K largest, ties to the lower group index; then renormalised.
            w.sort_by(|a, b| {
                b.0.partial_cmp(&a.0)
                    .unwrap_or(Ordering::Equal)
                    .then(a.1.cmp(&b.1))
            });
            let total: f64 = w[..k].iter().map(|e| e.0).sum();
            for (c, e) in w[..k].iter().enumerate() {
                idx_row[c] = e.1;
                w_row[c] = e.0 / total;
            }
        }
    })?;
    Ok((SkinWeights { k, index, weight }, found))
}

/// The mesh's edges as an adjacency list (CSR) with Euclidean lengths.
struct EdgeGraph {
    start: Vec<usize>,
    target: Vec<u32>,
    length: Vec<f64>,
}

impl EdgeGraph {
    fn new(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Self {
        let mut edges: Vec<(u32, u32)> = faces
            .iter()
            .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
            .filter(|(a, b)| a != b)
            .flat_map(|(a, b)| [(a, b), (b, a)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let mut start = vec![0usize; vertices.len() + 1];
        for &(a, _) in &edges {
            start[a as usize + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let target = edges.iter().map(|&(_, b)| b).collect();
        let length = edges
            .iter()
            .map(|&(a, b)| distance(&vertices[a as usize], &vertices[b as usize]))
            .collect();
        EdgeGraph {
            start,
            target,
            length,
        }
    }

    /// Shortest distances from a source node joined to vertex i by an arc of length
    /// `arc(i)` (+∞ = no arc), written into `dist`.
    ///
    /// The source's arcs are sorted once and consumed in order beside a binary heap that
    /// holds only the distances improved through mesh edges: the heap stays small even
    /// when the link sees most of the mesh directly. Keys are the bit patterns of the
    /// (non-negative) distances, which order as the distances do.
    fn dijkstra(&self, arc: impl Fn(usize) -> f64, dist: &mut [f64]) {
        let mut seeds: Vec<(u64, u32)> = Vec::new();
        for (i, d) in dist.iter_mut().enumerate() {
            *d = arc(i);
            if d.is_finite() {
                seeds.push((d.to_bits(), i as u32));
            }
        }
        seeds.sort_unstable();
        let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
        let mut next_seed = 0;
        loop {
            let from_heap = match (heap.peek(), seeds.get(next_seed)) {
                (Some(Reverse(h)), Some(s)) => h < s,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (None, None) => break,
            };
            let (bits, i) = if from_heap {
                heap.pop().map_or((0, 0), |Reverse(e)| e)
            } else {
                next_seed += 1;
                seeds[next_seed - 1]
            };
            let i = i as usize;
            let d = f64::from_bits(bits);
            if d > dist[i] {
                continue;
            }
            let range = self.start[i]..self.start[i + 1];
            for (&j, &len) in self.target[range.clone()].iter().zip(&self.length[range]) {
                let nd = d + len;
                if nd < dist[j as usize] {
                    dist[j as usize] = nd;
                    heap.push(Reverse((nd.to_bits(), j)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Floyd–Warshall on the graph of the mesh edges plus one link's node and arcs (a path
    /// may not pass through another link), the oracle for Dijkstra; rows per link.
    fn floyd(vertices: &[[f64; 3]], faces: &[[u32; 3]], direct: &[f64], nl: usize) -> Vec<f64> {
        let nv = vertices.len();
        let n = nv + 1;
        let mut out = Vec::new();
        for j in 0..nl {
            let mut d = vec![f64::INFINITY; n * n];
            (0..n).for_each(|i| d[i * n + i] = 0.0);
            for f in faces {
                for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
                    let (a, b) = (a as usize, b as usize);
                    let len = distance(&vertices[a], &vertices[b]);
                    d[a * n + b] = d[a * n + b].min(len);
                    d[b * n + a] = d[b * n + a].min(len);
                }
            }
            for i in 0..nv {
                d[i * n + nv] = direct[i * nl + j];
                d[nv * n + i] = direct[i * nl + j];
            }
            for m in 0..n {
                for a in 0..n {
                    for b in 0..n {
                        let via = d[a * n + m] + d[m * n + b];
                        if via < d[a * n + b] {
                            d[a * n + b] = via;
                        }
                    }
                }
            }
            out.extend((0..nv).map(|i| d[nv * n + i]));
        }
        out
    }

    /// A closed box [0,1]^3 split into triangles (2 per side).
    fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        let f = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (v, f)
    }

    #[test]
    fn dijkstra_matches_floyd_warshall() {
        let (v, f) = cube();
        // One link inside the box, one outside it (beyond the x = 1 face).
        let links = [
            [[0.3, 0.5, 0.5], [0.6, 0.5, 0.5]],
            [[1.5, 0.2, 0.2], [1.5, 0.8, 0.8]],
        ];
        let got = link_distances(&v, &f, &links, Some(2)).unwrap();
        let want = floyd(&v, &f, &got.direct, links.len());
        for (g, w) in got.distances.iter().zip(&want) {
            assert!((g - w).abs() < 1e-12, "{g} vs {w}");
        }
        // From outside, the x = 0 corners are hidden by the box: reached around it.
        let (vertex, link, nl, nv) = (0, 1, 2, 8);
        assert!(got.direct[vertex * nl + link].is_infinite());
        assert!(got.distances[link * nv + vertex].is_finite());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn random_meshes_match_floyd_warshall(seed in 0u64..10_000, nv in 4usize..14, nf in 1usize..20) {
            let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let mut next = || { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (s >> 33) as f64 / (1u64 << 31) as f64 };
            let v: Vec<[f64; 3]> = (0..nv).map(|_| [next(), next(), next()]).collect();
            let f: Vec<[u32; 3]> = (0..nf).map(|_| [0, 1, 2].map(|_| (next() * nv as f64) as u32 % nv as u32)).collect();
            let links = [[[next(), next(), next()], [next(), next(), next()]], [[0.5, 0.5, 0.5], [0.5, 0.5, 0.5]]];
            let got = link_distances(&v, &f, &links, Some(1)).unwrap();
            let want = floyd(&v, &f, &got.direct, 2);
            for (g, w) in got.distances.iter().zip(&want) {
                prop_assert!((g == w) || (g - w).abs() < 1e-12, "{} vs {}", g, w);
            }
        }
    }

    #[test]
    fn weights_are_k_sparse_normalised_and_merge_groups() {
        let (v, f) = cube();
        let links = [
            [[0.2, 0.5, 0.5], [0.4, 0.5, 0.5]],
            [[0.6, 0.5, 0.5], [0.8, 0.5, 0.5]],
            [[0.8, 0.2, 0.5], [0.9, 0.3, 0.5]],
        ];
        let opts = SkinWeightOptions {
            b: 5.0,
            k: 2,
            threads: Some(2),
        };
        let (w, _) = skin_weights(&v, &f, &links, &[0, 1, 1], 2, &opts).unwrap();
        assert_eq!(w.k, 2);
        for i in 0..8 {
            let row = &w.weight[2 * i..2 * i + 2];
            assert!(row.iter().all(|&x| x >= 0.0));
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(row[0] >= row[1]);
        }
        // Corners at x = 1 lean to group 1, at x = 0 to group 0.
        assert_eq!(w.index[0], 0);
        let k = 2;
        assert_eq!(w.index[k], 1); // vertex 1, first weight
        let bad = SkinWeightOptions { b: 0.0, ..opts };
        assert!(matches!(
            skin_weights(&v, &f, &links, &[0, 1, 1], 2, &bad),
            Err(BodyError::BadParameter { name: "b", .. })
        ));
        assert!(matches!(
            skin_weights(&v, &f, &links, &[0, 1, 2], 2, &opts),
            Err(BodyError::IndexOutOfRange { .. })
        ));
        assert!(matches!(
            link_distances(&v, &[[0, 1, 9]], &links, None),
            Err(BodyError::IndexOutOfRange { array: "faces", .. })
        ));
    }
}
