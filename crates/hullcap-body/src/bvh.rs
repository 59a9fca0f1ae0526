//! A bounding-volume hierarchy over triangles, for "does this segment cross the mesh?".

/// Triangles per leaf.
const LEAF_TRIANGLES: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Inner: index of the right child (the left child is the next node). Leaf: first slot
    /// in `order`.
    first: u32,
    /// Triangles in a leaf; 0 for an inner node.
    count: u32,
}

/// Axis-aligned box tree over a triangle mesh (median splits on the longest axis of the
/// centroids), answering whether a segment crosses any triangle.
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    nodes: Vec<Node>,
    /// Triangles in leaf order, with their corners copied in (cache-friendly tests).
    triangles: Vec<([[f64; 3]; 3], [u32; 3])>,
}

impl TriangleBvh {
    /// The tree of `faces` (indices into `vertices`, already checked to be in range).
    pub fn new(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Self {
        let corners = |f: &[u32; 3]| f.map(|i| vertices[i as usize]);
        let centroid: Vec<[f64; 3]> = faces
            .iter()
            .map(|f| {
                let c = corners(f);
                [0, 1, 2].map(|d| (c[0][d] + c[1][d] + c[2][d]) / 3.0)
            })
            .collect();
        let mut order: Vec<u32> = (0..faces.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * faces.len() / LEAF_TRIANGLES + 1);
        if !faces.is_empty() {
            build(&mut nodes, &mut order, 0, &centroid, &|t| {
                corners(&faces[t as usize])
            });
        }
        let triangles = order
            .iter()
            .map(|&t| (corners(&faces[t as usize]), faces[t as usize]))
            .collect();
        TriangleBvh { nodes, triangles }
    }

    /// Whether the segment from `p` to `q` crosses a triangle, other than those having the
    /// vertex `skip_vertex` as a corner. Touching at the start (t < 1e-9) does not count.
    pub fn segment_crosses(&self, p: &[f64; 3], q: &[f64; 3], skip_vertex: u32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let dir = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let inv = dir.map(|d| 1.0 / d);
        // Median splits keep the depth near log2(triangles / 4): 64 levels is ample.
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = self.nodes[index as usize];
            if !slab_hit(&node.lo, &node.hi, p, &inv) {
                continue;
            }
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                for (corners, face) in &self.triangles[range] {
                    if !face.contains(&skip_vertex) && segment_triangle(p, &dir, corners) {
                        return true;
                    }
                }
            } else {
                stack[top] = index + 1;
                stack[top + 1] = node.first;
                top += 2;
            }
        }
        false
    }
}

fn build(
    nodes: &mut Vec<Node>,
    order: &mut [u32],
    offset: usize,
    centroid: &[[f64; 3]],
    corners: &dyn Fn(u32) -> [[f64; 3]; 3],
) -> u32 {
    let here = nodes.len() as u32;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &t in order.iter() {
        for c in corners(t) {
            for d in 0..3 {
                lo[d] = lo[d].min(c[d]);
                hi[d] = hi[d].max(c[d]);
            }
        }
    }
    nodes.push(Node {
        lo,
        hi,
        first: offset as u32,
        count: order.len() as u32,
    });
    if order.len() <= LEAF_TRIANGLES {
        return here;
    }
    let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &t in order.iter() {
        for d in 0..3 {
            clo[d] = clo[d].min(centroid[t as usize][d]);
            chi[d] = chi[d].max(centroid[t as usize][d]);
        }
    }
    let axis = (0..3).fold(0, |a, d| {
        if chi[d] - clo[d] > chi[a] - clo[a] {
            d
        } else {
            a
        }
    });
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroid[a as usize][axis].total_cmp(&centroid[b as usize][axis])
    });
    let (left, right) = order.split_at_mut(mid);
    build(nodes, left, offset, centroid, corners);
    let right_index = build(nodes, right, offset + mid, centroid, corners);
    nodes[here as usize].first = right_index;
    nodes[here as usize].count = 0;
    here
}

/// Whether the segment p + s·dir, s ∈ [0, 1], meets the box (slab test).
///
/// A segment parallel to a slab (dir[d] = 0, inv[d] = ±∞) is decided by whether p lies
/// within it; the general formula would give 0·∞ = NaN when p sits exactly on the slab's
/// plane, which grid-aligned meshes (marching cubes) produce all the time.
#[inline]
fn slab_hit(lo: &[f64; 3], hi: &[f64; 3], p: &[f64; 3], inv: &[f64; 3]) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for d in 0..3 {
        if inv[d].is_infinite() {
            if p[d] < lo[d] || p[d] > hi[d] {
                return false;
            }
            continue;
        }
        let a = (lo[d] - p[d]) * inv[d];
        let b = (hi[d] - p[d]) * inv[d];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Möller–Trumbore: does p + s·dir, s ∈ [1e-9, 1], meet the triangle?
#[inline]
fn segment_triangle(p: &[f64; 3], dir: &[f64; 3], c: &[[f64; 3]; 3]) -> bool {
    let sub = |a: &[f64; 3], b: &[f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: &[f64; 3], b: &[f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let e1 = sub(&c[1], &c[0]);
    let e2 = sub(&c[2], &c[0]);
    let pv = cross(dir, &e2);
    let det = dot(&e1, &pv);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv_det = 1.0 / det;
    let tv = sub(p, &c[0]);
    let u = dot(&tv, &pv) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let qv = cross(&tv, &e1);
    let v = dot(dir, &qv) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let s = dot(&e2, &qv) * inv_det;
    (1e-9..=1.0).contains(&s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron_grid() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        // Many small disjoint tetrahedra on a grid: a soup with lots of empty space.
        let mut v = Vec::new();
        let mut f = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                for k in 0..6 {
                    let o = [i as f64 * 0.3, j as f64 * 0.3, k as f64 * 0.3];
                    let b = v.len() as u32;
                    v.push(o);
                    v.push([o[0] + 0.1, o[1], o[2]]);
                    v.push([o[0], o[1] + 0.1, o[2]]);
                    v.push([o[0], o[1], o[2] + 0.1]);
                    f.extend([
                        [b, b + 2, b + 1],
                        [b, b + 1, b + 3],
                        [b, b + 3, b + 2],
                        [b + 1, b + 2, b + 3],
                    ]);
                }
            }
        }
        (v, f)
    }

    #[test]
    fn agrees_with_testing_every_triangle() {
        let (v, f) = tetrahedron_grid();
        let bvh = TriangleBvh::new(&v, &f);
        let mut state = 12345u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 10_000) as f64 / 10_000.0 * 1.8 - 0.1
        };
        let mut crossings = 0;
        for _ in 0..3000 {
            let p = [next(), next(), next()];
            let q = [next(), next(), next()];
            let skip = (next() * 100.0) as u32;
            let dir = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let brute = f.iter().any(|t| {
                !t.contains(&skip) && segment_triangle(&p, &dir, &t.map(|i| v[i as usize]))
            });
            assert_eq!(bvh.segment_crosses(&p, &q, skip), brute, "{p:?} -> {q:?}");
            crossings += brute as usize;
        }
        assert!(
            crossings > 300,
            "the test should exercise both answers ({crossings})"
        );
    }

    #[test]
    fn segments_in_the_plane_of_a_box_face_are_tested() {
        // A wall of triangles at x = 0 between z = 0 and z = 1; segments along x at
        // heights that are exactly the triangles' own z (box faces), as on a voxel grid.
        let mut v = Vec::new();
        let mut f = Vec::new();
        for k in 0..10 {
            let (z0, z1) = (k as f64 * 0.1, (k + 1) as f64 * 0.1);
            let b = v.len() as u32;
            v.extend([
                [0.0, -1.0, z0],
                [0.0, 1.0, z0],
                [0.0, 1.0, z1],
                [0.0, -1.0, z1],
            ]);
            f.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
        let bvh = TriangleBvh::new(&v, &f);
        for k in 0..=10 {
            let z = k as f64 * 0.1;
            assert!(
                bvh.segment_crosses(&[1.0, 0.3, z], &[-1.0, 0.3, z], 999),
                "z = {z}"
            );
            assert!(
                bvh.segment_crosses(&[1.0, 0.0, z], &[-1.0, 0.0, z], 999),
                "z = {z}"
            );
        }
    }

    #[test]
    fn triangles_at_the_skipped_vertex_do_not_count() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let f = [[0, 1, 2]];
        let bvh = TriangleBvh::new(&v, &f);
        let (p, q) = ([0.2, 0.2, 1.0], [0.2, 0.2, -1.0]);
        assert!(bvh.segment_crosses(&p, &q, 99));
        assert!(!bvh.segment_crosses(&p, &q, 1));
        assert!(!bvh.segment_crosses(&[0.2, 0.2, 1.0], &[0.2, 0.2, 0.5], 99));
    }
}
