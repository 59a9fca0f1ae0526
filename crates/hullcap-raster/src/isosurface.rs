//! The surface where a sampled field crosses a level: marching cubes whose polygons are
//! worked out from each cube's six faces instead of being looked up in a table.
//!
//! A grid point is *above* when its value exceeds the level. Every grid edge between an
//! above and a not-above point holds one vertex, placed by linear interpolation and shared
//! by the four cubes around the edge. On each face of a cube the crossing edges are paired
//! into segments that keep the above corners on one side; a face with its two above
//! corners on a diagonal is resolved by the bilinear interpolant's value at its saddle
//! (the asymptotic decider), computed from the face's own four values in an order both
//! cubes sharing it use, so the two agree. The segments of a cube close into loops, each
//! loop is a polygon of the surface, and a fan of triangles covers it. Because neighbouring
//! cubes share the vertices and pair them the same way on the shared face, every edge of
//! the mesh lies in exactly two triangles: the surface is closed wherever it does not reach
//! the grid's border.
//!
//! The polygons are wound counter-clockwise seen from the side of the lower values (for a
//! field that is high inside a body, from outside). The normal at a vertex is the field's
//! gradient turned to point to the lower values: along its edge, the difference of the
//! edge's two values (the slope of the interpolation that placed the vertex); across it,
//! central differences (one-sided at the border) at the edge's two ends, interpolated.
//!
//! The cubes are marched slab by slab along the first axis, and on several threads the
//! slabs are shared out in runs, one per thread. A run's first plane is its seam with the
//! run before, which makes every vertex on that plane (each crossing edge there belongs to
//! cubes on both sides); the later run computes such a vertex only to place the centroids
//! of its own polygons and refers to it by a mark, and the runs are joined in order with
//! the marks replaced by the earlier run's numbers. The vertices, faces and normals are
//! those of one thread, in the same order, to the bit.

use crate::RasterError;
use hullcap_core::{for_each_chunk_mut, resolve_threads};

/// A triangle mesh in grid units: vertex (x, y, z) is the point at index (x, y, z) of the
/// field's first, second and third axes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Isosurface {
    /// Positions in grid units.
    pub vertices: Vec<[f64; 3]>,
    /// Vertex indices, counter-clockwise seen from the side of the lower values.
    pub faces: Vec<[u32; 3]>,
    /// Unit normals pointing towards the lower values (+x where the gradient vanishes).
    pub normals: Vec<[f64; 3]>,
}

/// The corner of a cube with bits (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1).
const fn corner_offset(c: usize) -> [usize; 3] {
    [c & 1, (c >> 1) & 1, (c >> 2) & 1]
}

/// The grid point at corner `c` of the cube whose first corner is `origin`.
fn corner_of(origin: [usize; 3], c: usize) -> [usize; 3] {
    let o = corner_offset(c);
    [origin[0] + o[0], origin[1] + o[1], origin[2] + o[2]]
}

/// The corner with offsets (x, y, z).
const fn corner_index(o: [usize; 3]) -> usize {
    o[0] | (o[1] << 1) | (o[2] << 2)
}

/// A cube's twelve edges: edge `4·axis + m` runs along `axis` from the corner whose two
/// other coordinates, taken in cyclic order after `axis`, are `(m & 1, m >> 1)`.
const fn edge_start(e: usize) -> (usize, usize) {
    let (axis, m) = (e / 4, e % 4);
    let mut o = [0; 3];
    o[(axis + 1) % 3] = m & 1;
    o[(axis + 2) % 3] = m >> 1;
    (axis, corner_index(o))
}

/// The edge between two corners that differ along one axis.
fn edge_between(a: usize, b: usize) -> usize {
    let (oa, ob) = (corner_offset(a), corner_offset(b));
    let axis = (0..3).find(|&k| oa[k] != ob[k]).unwrap_or(0);
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    4 * axis + oa[u] + 2 * oa[v]
}

/// Whether two edges of a cube lie on a common face: parallel edges one step apart, or
/// perpendicular edges at the same height along the axis perpendicular to both.
fn share_face(a: usize, b: usize) -> bool {
    let ((axis_a, ca), (axis_b, cb)) = (edge_start(a), edge_start(b));
    let (oa, ob) = (corner_offset(ca), corner_offset(cb));
    if axis_a == axis_b {
        (0..3).filter(|&k| oa[k] != ob[k]).count() == 1
    } else {
        let across = 3 - axis_a - axis_b;
        oa[across] == ob[across]
    }
}

/// One face of the cube: its corners counter-clockwise seen from outside the cube and
/// the edges between consecutive corners. Corners 0 and 2 are the same two points for
/// both cubes that share the face (see [`faces`]).
#[derive(Debug, Clone, Copy)]
struct Face {
    corners: [usize; 4],
    edges: [usize; 4],
}

/// The six faces, `2·a + s`: axis `a`, side `s`; in-plane axes b = a + 1 and c = a + 2
/// (cyclic), so that (b, c, a) is right-handed and the order (0,0), (1,0), (1,1), (0,1)
/// in (b, c) is counter-clockwise seen from +a; the face at side 0 is seen from −a, so
/// it lists (0,1) before (1,0).
fn faces() -> [Face; 6] {
    let mut out = [Face {
        corners: [0; 4],
        edges: [0; 4],
    }; 6];
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for s in 0..2 {
            let square: [(usize, usize); 4] = if s == 1 {
                [(0, 0), (1, 0), (1, 1), (0, 1)]
            } else {
                [(0, 0), (0, 1), (1, 1), (1, 0)]
            };
            let corners = square.map(|(ub, uc)| {
                let mut o = [0; 3];
                o[a] = s;
                o[b] = ub;
                o[c] = uc;
                corner_index(o)
            });
            let edges = [0, 1, 2, 3].map(|m| edge_between(corners[m], corners[(m + 1) % 4]));
            out[2 * a + s] = Face { corners, edges };
        }
    }
    out
}

/// A cube's surface for one case and one choice at each face whose above corners sit on
/// a diagonal, in cube edges: triangles, and the loops whose fan would put a diagonal in
/// a face of the cube, which get a vertex at their centroid instead (see [`cover`]).
#[derive(Debug, Clone, Default)]
struct Pattern {
    triangles: Vec<[u8; 3]>,
    centred: Vec<Vec<u8>>,
}

/// Everything the marching needs that depends on a cube's case alone, worked out once per
/// process from the faces.
struct Cases {
    faces: [Face; 6],
    /// Per case, bit f: face f has four crossings (its choice is read from the field).
    diagonal: [u8; 256],
    /// `patterns[64·case + choices]`, bit f of `choices` set when face f joins its above
    /// corners (only bits of `diagonal[case]` are ever set).
    patterns: Vec<Pattern>,
}

fn cases() -> &'static Cases {
    static CASES: std::sync::OnceLock<Cases> = std::sync::OnceLock::new();
    CASES.get_or_init(|| {
        let faces = faces();
        let mut diagonal = [0u8; 256];
        let mut patterns = vec![Pattern::default(); 256 * 64];
        for case in 1..255 {
            for (f, face) in faces.iter().enumerate() {
                if crossings(face, case).len() == 4 {
                    diagonal[case] |= 1 << f;
                }
            }
            let d = usize::from(diagonal[case]);
            for choices in (0..64).filter(|c| c & !d == 0) {
                patterns[64 * case + choices] = pattern(&faces, case, choices);
            }
        }
        Cases {
            faces,
            diagonal,
            patterns,
        }
    })
}

/// The sides m of `face` (from corner m to corner m + 1) that `case` crosses: 0, 2 or 4.
fn crossings(face: &Face, case: usize) -> Vec<usize> {
    let above = |c: usize| case >> c & 1 == 1;
    (0..4)
        .filter(|&m| above(face.corners[m]) != above(face.corners[(m + 1) % 4]))
        .collect()
}

/// The [`Pattern`] of `case` with the faces of `choices` joining their above corners.
fn pattern(faces: &[Face; 6], case: usize, choices: usize) -> Pattern {
    let above = |c: usize| case >> c & 1 == 1;
    // next[e]: the crossing edge that follows e along the cube's loops.
    let mut next = [usize::MAX; 12];
    for (f, face) in faces.iter().enumerate() {
        match crossings(face, case)[..] {
            [] => {}
            [a, b] => {
                // From where the walk enters the above corners to where it leaves them.
                let (enter, leave) = if above(face.corners[(a + 1) % 4]) {
                    (a, b)
                } else {
                    (b, a)
                };
                next[face.edges[enter]] = face.edges[leave];
            }
            _ => {
                // Walking from an edge that enters an above corner: enter, leave, enter,
                // leave.
                let first = if above(face.corners[1]) { 0 } else { 1 };
                let [c0, c1, c2, c3] = [0, 1, 2, 3].map(|m| face.edges[(first + m) % 4]);
                if choices >> f & 1 == 1 {
                    next[c2] = c1; // each segment cuts off a corner that is not above
                    next[c0] = c3;
                } else {
                    next[c0] = c1; // each segment cuts off an above corner
                    next[c2] = c3;
                }
            }
        }
    }
    let mut out = Pattern::default();
    let mut done = [false; 12];
    for start in 0..12 {
        if next[start] == usize::MAX || done[start] {
            continue;
        }
        let mut polygon = Vec::new();
        let mut e = start;
        while !done[e] {
            done[e] = true;
            polygon.push(e as u8);
            e = next[e];
        }
        cover(&polygon, &mut out);
    }
    out
}

/// Triangles over one loop of cube edges: a fan from a corner whose diagonals each join
/// two vertices on no common face of the cube. A diagonal within a face would lie where
/// the neighbouring cube's own triangles may also run, so the mesh would stop being
/// closed; this happens only for a loop through both segments of a face whose above
/// corners sit on a diagonal. If every corner has such a diagonal, the loop is kept to be
/// fanned from a vertex at its centroid.
fn cover(polygon: &[u8], out: &mut Pattern) {
    let n = polygon.len();
    let edge = |i: usize| usize::from(polygon[i % n]);
    let clear = |apex: usize| (2..n - 1).all(|m| !share_face(edge(apex), edge(apex + m)));
    match (0..n).find(|&apex| n == 3 || clear(apex)) {
        Some(apex) => {
            for m in 1..n - 1 {
                out.triangles
                    .push([apex, apex + m, apex + m + 1].map(|i| polygon[i % n]));
            }
        }
        None => out.centred.push(polygon.to_vec()),
    }
}

/// Which points of one plane lie above the level (1 or 0, at `j · nz + k`), and for each
/// row j whether some and whether all of them do (so that a row of cubes between two
/// planes wholly above or below is skipped by four lookups).
#[derive(Debug, Default)]
struct Signs {
    above: Vec<u8>,
    rows: Vec<(u8, u8)>,
}

/// Vertex numbers (plus one; 0 = none yet) of a set of grid edges, at `j · nz + k`, and
/// which of them are set: a slab sets a few hundred of its tens of thousands, and
/// clearing those alone spares the memory traffic of clearing every one.
#[derive(Debug, Clone)]
struct Slots {
    ids: Vec<u32>,
    touched: Vec<usize>,
}

impl Slots {
    fn new(n: usize) -> Self {
        Self {
            ids: vec![0; n],
            touched: Vec::new(),
        }
    }

    fn set(&mut self, at: usize, id: u32) {
        self.ids[at] = id + 1;
        self.touched.push(at);
    }

    fn clear(&mut self) {
        for &at in &self.touched {
            self.ids[at] = 0;
        }
        self.touched.clear();
    }
}

/// The grid edges in one plane of constant first index: along the second axis and along
/// the third.
#[derive(Debug, Clone)]
struct Plane {
    along_y: Slots,
    along_z: Slots,
}

impl Plane {
    fn new(n: usize) -> Self {
        Self {
            along_y: Slots::new(n),
            along_z: Slots::new(n),
        }
    }

    fn clear(&mut self) {
        self.along_y.clear();
        self.along_z.clear();
    }
}

/// The surface where `field` (row-major, shape `shape`, the last axis fastest) crosses
/// `level`; see the module documentation. Threads: `None` = all cores; the surface does
/// not depend on them.
///
/// # Errors
/// [`RasterError::FieldSize`] when `field` does not hold `shape`'s values or an axis has
/// fewer than two points, or the grid has too many edges to number in 32 bits;
/// [`RasterError::Panicked`] when a worker thread panicked.
pub fn isosurface(
    field: &[f32],
    shape: [usize; 3],
    level: f64,
    threads: Option<usize>,
) -> Result<Isosurface, RasterError> {
    let [nx, ny, nz] = shape;
    let n = nx.checked_mul(ny).and_then(|p| p.checked_mul(nz));
    let too_many = n.is_none_or(|n| n.saturating_mul(3) >= SEAM as usize);
    if shape.iter().any(|&s| s < 2) || too_many || n != Some(field.len()) {
        return Err(RasterError::FieldSize {
            len: field.len(),
            shape,
        });
    }
    let slabs = nx - 1;
    let runs = resolve_threads(threads).min(slabs / MIN_RUN_SLABS).max(1);
    let mut marched: Vec<Option<Run>> = vec![None; runs];
    for_each_chunk_mut(&mut marched, runs, 1, |r, out| {
        let (first, last) = (r * slabs / runs, (r + 1) * slabs / runs);
        out[0] = Some(Marcher::new(field, shape, level, first).march(first..last));
    })?;
    Ok(join(marched.into_iter().flatten().collect()))
}

/// Slabs a run must have at least before the work is shared out: below it, starting a
/// thread costs about what it saves.
const MIN_RUN_SLABS: usize = 16;

/// The mark of a vertex on a run's first plane (which the run before makes): this bit
/// and the vertex's place in [`Run::seam`].
const SEAM: u32 = 1 << 31;

/// What one run of slabs makes: its own vertices and faces (faces may refer to marked
/// seam vertices), the seam vertices it refers to (the axis and place of their edge on
/// its first plane), and the vertex numbers (plus one) of the edges on its last plane.
#[derive(Debug, Clone)]
struct Run {
    surface: Isosurface,
    seam: Vec<(usize, usize)>,
    last_plane: Plane,
}

/// The runs' surfaces one after another, each run's marks replaced by the numbers the
/// run before gave those vertices.
fn join(runs: Vec<Run>) -> Isosurface {
    let mut out = Isosurface::default();
    let mut before: Option<(u32, &Plane)> = None;
    for run in &runs {
        let offset = out.vertices.len() as u32;
        let number = |v: u32| -> u32 {
            let Some((start, plane)) = before.filter(|_| v & SEAM != 0) else {
                return v + offset; // unmarked (the first run has no seam)
            };
            let (axis, at) = run.seam[(v & !SEAM) as usize];
            let slot = if axis == 1 {
                plane.along_y.ids[at]
            } else {
                plane.along_z.ids[at]
            };
            assert!(
                slot != 0,
                "the run before makes every crossing edge of its last plane"
            );
            start + slot - 1
        };
        out.faces
            .extend(run.surface.faces.iter().map(|face| face.map(number)));
        out.vertices.extend_from_slice(&run.surface.vertices);
        out.normals.extend_from_slice(&run.surface.normals);
        before = Some((offset, &run.last_plane));
    }
    out
}

struct Marcher<'a> {
    field: &'a [f32],
    shape: [usize; 3],
    level: f64,
    cases: &'static Cases,
    /// The run's first plane: a seam whose vertices the run before makes (none for 0).
    first: usize,
    /// The edges in the planes i and i + 1 of the slab being marched.
    planes: [Plane; 2],
    /// The edges from plane i to plane i + 1, at `j · nz + k`.
    along_x: Slots,
    out: Isosurface,
    /// The seam's vertices this run refers to: their edges, positions and normals.
    seam: Vec<(usize, usize)>,
    seam_points: Vec<([f64; 3], [f64; 3])>,
}

impl<'a> Marcher<'a> {
    fn new(field: &'a [f32], shape: [usize; 3], level: f64, first: usize) -> Self {
        let [_, ny, nz] = shape;
        Marcher {
            field,
            shape,
            level,
            cases: cases(),
            first,
            planes: [Plane::new(ny * nz), Plane::new(ny * nz)],
            along_x: Slots::new(ny * nz),
            out: Isosurface::default(),
            seam: Vec::new(),
            seam_points: Vec::new(),
        }
    }

    /// Marches the slabs `slabs` (between planes i and i + 1 for each i).
    fn march(mut self, slabs: std::ops::Range<usize>) -> Run {
        let (mut lower, mut upper) = (Signs::default(), Signs::default());
        self.above(slabs.start, &mut lower);
        for i in slabs {
            self.above(i + 1, &mut upper);
            self.slab(i, &lower, &upper);
            std::mem::swap(&mut lower, &mut upper);
            self.planes.swap(0, 1);
            self.planes[1].clear();
            self.along_x.clear();
        }
        let [last_plane, _] = self.planes;
        Run {
            surface: self.out,
            seam: self.seam,
            last_plane,
        }
    }

    fn at(&self, p: [usize; 3]) -> f64 {
        let [_, ny, nz] = self.shape;
        f64::from(self.field[(p[0] * ny + p[1]) * nz + p[2]])
    }

    /// Which points of plane `i` are above the level, and which of its rows have some or
    /// all of their points above.
    fn above(&self, i: usize, out: &mut Signs) {
        let [_, ny, nz] = self.shape;
        let plane = &self.field[i * ny * nz..(i + 1) * ny * nz];
        out.above.clear();
        out.above
            .extend(plane.iter().map(|&v| u8::from(f64::from(v) > self.level)));
        out.rows.clear();
        out.rows.extend(
            out.above
                .chunks_exact(nz)
                .map(|row| row.iter().fold((0, 1), |(s, a), &b| (s | b, a & b))),
        );
    }

    /// The cubes between planes i and i + 1 (whose points above the level are `lower`
    /// and `upper`), skipping those wholly above or not.
    fn slab(&mut self, i: usize, lower: &Signs, upper: &Signs) {
        let [_, ny, nz] = self.shape;
        for j in 0..ny - 1 {
            let corners = [
                lower.rows[j],
                upper.rows[j],
                lower.rows[j + 1],
                upper.rows[j + 1],
            ];
            let (some, all) = corners
                .iter()
                .fold((0, 1), |(some, all), &(s, a)| (some | s, all & a));
            if some == all {
                continue; // every point of the row's cubes is above, or none is
            }
            let (near_row, far_row) = (j * nz..(j + 1) * nz, (j + 1) * nz..(j + 2) * nz);
            // Bit dx + 2·dy of a column is that corner of the cube's square.
            let rows = [
                &lower.above[near_row.clone()],
                &upper.above[near_row],
                &lower.above[far_row.clone()],
                &upper.above[far_row],
            ];
            let column = |k: usize| {
                usize::from(rows[0][k])
                    | usize::from(rows[1][k]) << 1
                    | usize::from(rows[2][k]) << 2
                    | usize::from(rows[3][k]) << 3
            };
            let mut near = column(0);
            for k in 0..nz - 1 {
                let far = column(k + 1);
                let case = near | (far << 4);
                near = far;
                if case != 0 && case != 255 {
                    self.cube([i, j, k], case);
                }
            }
        }
    }

    /// The triangles of the cube at `origin` whose corners above the level are the bits
    /// of `case`.
    fn cube(&mut self, origin: [usize; 3], case: usize) {
        let cases = self.cases;
        let diagonal = usize::from(cases.diagonal[case]);
        let mut choices = 0;
        for f in (0..6).filter(|f| diagonal >> f & 1 == 1) {
            if self.above_joined(origin, cases.faces[f]) {
                choices |= 1 << f;
            }
        }
        let pattern = &cases.patterns[64 * case + choices];
        let mut ids = [u32::MAX; 12];
        let mut id = |marcher: &mut Self, e: u8| {
            let e = usize::from(e);
            if ids[e] == u32::MAX {
                ids[e] = marcher.vertex(origin, e);
            }
            ids[e]
        };
        for triangle in &pattern.triangles {
            let face = triangle.map(|e| id(self, e));
            self.out.faces.push(face);
        }
        for polygon in &pattern.centred {
            let corners: Vec<u32> = polygon.iter().map(|&e| id(self, e)).collect();
            self.fan_from_centroid(&corners);
        }
    }

    /// Triangles from a new vertex at the centroid of `polygon` to each of its sides.
    fn fan_from_centroid(&mut self, polygon: &[u32]) {
        let n = polygon.len();
        let mean = |normals: bool| -> [f64; 3] {
            let sum = polygon.iter().fold([0.0; 3], |acc, &v| {
                let x = self.point(v, normals);
                [acc[0] + x[0], acc[1] + x[1], acc[2] + x[2]]
            });
            sum.map(|v| v / n as f64)
        };
        let centre = mean(false);
        let normal = unit(mean(true));
        let apex = self.out.vertices.len() as u32;
        self.out.vertices.push(centre);
        self.out.normals.push(normal);
        for m in 0..n {
            self.out
                .faces
                .push([apex, polygon[m], polygon[(m + 1) % n]]);
        }
    }

    /// The position (or with `normal`, the normal) of vertex `v`, marked or not.
    fn point(&self, v: u32, normal: bool) -> [f64; 3] {
        if v & SEAM != 0 {
            let (position, n) = self.seam_points[(v & !SEAM) as usize];
            return if normal { n } else { position };
        }
        let items = if normal {
            &self.out.normals
        } else {
            &self.out.vertices
        };
        items[v as usize]
    }

    /// Whether a face whose above corners sit on a diagonal joins them: the bilinear
    /// interpolant of its four values exceeds the level at its saddle. Both cubes that
    /// share the face evaluate the same expression on the same values.
    fn above_joined(&self, origin: [usize; 3], face: Face) -> bool {
        let [q0, q1, q2, q3] = face.corners.map(|c| self.at(corner_of(origin, c)));
        // q0, q2 and q1, q3 are the diagonals; both sides list q0 first, and swapping q1
        // and q3 changes neither sum nor product.
        let (on, across) = (q0 + q2, q1 + q3);
        let saddle = (q0 * q2 - q1 * q3) / (on - across);
        saddle > self.level
    }

    /// The vertex on the cube's edge `e`, made the first time any cube asks for it.
    fn vertex(&mut self, origin: [usize; 3], e: usize) -> u32 {
        let (axis, c) = edge_start(e);
        let p = corner_of(origin, c);
        let at = p[1] * self.shape[2] + p[2];
        let plane = p[0] - origin[0];
        let known = self.slots(axis, plane).ids[at];
        if known != 0 {
            return known - 1;
        }
        let on_seam = axis != 0 && self.first > 0 && p[0] == self.first;
        let id = if on_seam {
            SEAM | self.seam.len() as u32
        } else {
            self.out.vertices.len() as u32
        };
        self.slots(axis, plane).set(at, id);
        let mut q = p;
        q[axis] += 1;
        let (fp, fq) = (self.at(p), self.at(q));
        let t = (self.level - fp) / (fq - fp);
        let mut position = p.map(|v| v as f64);
        position[axis] += t;
        let (gp, gq) = (self.gradient(p), self.gradient(q));
        let mut g: [f64; 3] = std::array::from_fn(|d| -(gp[d] + t * (gq[d] - gp[d])));
        g[axis] = fp - fq;
        if on_seam {
            self.seam.push((axis, at));
            self.seam_points.push((position, unit(g)));
        } else {
            self.out.vertices.push(position);
            self.out.normals.push(unit(g));
        }
        id
    }

    /// The slots of the edges along `axis` in the slab's plane `plane` (0 or 1; the edges
    /// along the first axis lie between the two).
    fn slots(&mut self, axis: usize, plane: usize) -> &mut Slots {
        match axis {
            0 => &mut self.along_x,
            1 => &mut self.planes[plane].along_y,
            _ => &mut self.planes[plane].along_z,
        }
    }

    /// The field's gradient at a grid point: central differences, one-sided at the border.
    fn gradient(&self, p: [usize; 3]) -> [f64; 3] {
        std::array::from_fn(|d| {
            let (mut lo, mut hi) = (p, p);
            if p[d] > 0 {
                lo[d] -= 1;
            }
            if p[d] + 1 < self.shape[d] {
                hi[d] += 1;
            }
            (self.at(hi) - self.at(lo)) / (hi[d] - lo[d]) as f64
        })
    }
}

/// `v` scaled to length 1; +x when it is zero.
fn unit(v: [f64; 3]) -> [f64; 3] {
    let length = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if length > 0.0 {
        v.map(|x| x / length)
    } else {
        [1.0, 0.0, 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field sampled on an `n`³ grid from a function of grid coordinates.
    fn sampled(n: usize, mut f: impl FnMut([f64; 3]) -> f64) -> Vec<f32> {
        let mut out = Vec::with_capacity(n * n * n);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    out.push(f([i as f64, j as f64, k as f64]) as f32);
                }
            }
        }
        out
    }

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// Every directed edge once and its reverse once: closed and consistently wound.
    fn assert_closed(s: &Isosurface) {
        let mut directed = std::collections::HashMap::new();
        for f in &s.faces {
            for m in 0..3 {
                *directed.entry((f[m], f[(m + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &directed {
            assert_eq!(count, 1, "edge {a}→{b} used {count} times");
            assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}→{b} has no twin");
        }
    }

    /// The signed volume enclosed (positive when the faces are wound outwards).
    fn volume(s: &Isosurface) -> f64 {
        s.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| s.vertices[v as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn a_ball_is_closed_wound_outwards_with_vertices_on_the_level() {
        let (n, r) = (24, 8.3);
        let centre = [11.2, 11.7, 12.1];
        let f = |p: [f64; 3]| r - dot(sub(p, centre), sub(p, centre)).sqrt();
        let field = sampled(n, f);
        let s = isosurface(&field, [n, n, n], 0.0, None).unwrap();
        assert_closed(&s);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        assert!(
            (volume(&s) / exact - 1.0).abs() < 0.01,
            "{}",
            volume(&s) / exact
        );
        let mut worst: f64 = 1.0;
        for (v, normal) in s.vertices.iter().zip(&s.normals) {
            let d = sub(*v, centre);
            let radius = dot(d, d).sqrt();
            assert!((radius - r).abs() < 0.02, "vertex at radius {radius}");
            worst = worst.min(dot(*normal, d) / radius);
        }
        // Within 5° of the true normal everywhere (a sampled cone's gradient).
        assert!(worst > 5f64.to_radians().cos(), "cosine {worst}");
        for f in &s.faces {
            let [a, b, c] = f.map(|v| s.vertices[v as usize]);
            let outward = sub(a, centre);
            assert!(dot(cross(sub(b, a), sub(c, a)), outward) >= 0.0);
        }
    }

    /// Numbers in [0, 1) from a xorshift generator seeded with `state` (not 0).
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Shared out in runs of slabs, the surface is the one thread's to the bit: the same
    /// vertices, normals and faces in the same order, with runs that meet where the
    /// surface crosses their seam and polygons fanned from a centroid next to it.
    #[test]
    fn runs_on_threads_give_the_surface_of_one_thread() {
        let mut random = uniform(0x2545_f491_4f6c_dd1d);
        let shape = [5 * MIN_RUN_SLABS + 3, 9, 8];
        let [nx, ny, nz] = shape;
        let mut field = vec![0f32; nx * ny * nz];
        for x in 1..nx - 1 {
            for y in 1..ny - 1 {
                for z in 1..nz - 1 {
                    field[(x * ny + y) * nz + z] = random() as f32;
                }
            }
        }
        let one = isosurface(&field, shape, 0.5, Some(1)).unwrap();
        assert!(one.faces.len() > 1000);
        let centred = one
            .vertices
            .iter()
            .any(|v| v.iter().all(|c| c.fract() != 0.0));
        assert!(centred, "some polygon is fanned from its centroid");
        assert_closed(&one);
        for threads in [2, 3, 5, 8] {
            assert_eq!(isosurface(&field, shape, 0.5, Some(threads)).unwrap(), one);
        }
    }

    /// Random fields exercise every case, the ambiguous faces included: the mesh stays
    /// closed and wound one way, whatever the level.
    #[test]
    fn random_fields_give_closed_surfaces() {
        let mut random = uniform(0x9e37_79b9_7f4a_7c15);
        for trial in 0..40 {
            let n = 5 + trial % 4;
            // Zero on the border so that every surface closes inside the grid.
            let field = sampled(n, |p| {
                let inner = p.iter().all(|&v| v > 0.0 && v < (n - 1) as f64);
                if inner { random() } else { 0.0 }
            });
            let level = 0.2 + 0.6 * random();
            let s = isosurface(&field, [n, n, n], level, Some(1)).unwrap();
            assert_closed(&s);
            assert!(volume(&s) > 0.0 || s.faces.is_empty());
            for &[a, b, c] in &s.faces {
                assert!(a != b && b != c && a != c, "face {a} {b} {c}");
            }
        }
    }

    /// V − E + F: 2 for each closed piece shaped like a sphere.
    fn euler(s: &Isosurface) -> i64 {
        let mut edges = std::collections::HashSet::new();
        for f in &s.faces {
            for m in 0..3 {
                let (a, b) = (f[m], f[(m + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
            }
        }
        s.vertices.len() as i64 - edges.len() as i64 + s.faces.len() as i64
    }

    #[test]
    fn a_face_with_high_corners_on_a_diagonal_joins_them_when_its_saddle_is_high() {
        // On the face x = 1 of a 4³ grid, (y, z) = (1, 1) and (2, 2) are 1, the rest 0:
        // the bilinear interpolant's saddle is 0.5.
        let mut field = vec![0.0f32; 64];
        field[(4 + 1) * 4 + 1] = 1.0;
        field[(4 + 2) * 4 + 2] = 1.0;
        let joined = isosurface(&field, [4, 4, 4], 0.4, None).unwrap();
        let apart = isosurface(&field, [4, 4, 4], 0.6, None).unwrap();
        assert_closed(&joined);
        assert_closed(&apart);
        assert_eq!(euler(&joined), 2, "one piece");
        assert_eq!(euler(&apart), 4, "two pieces");
    }

    /// Against geometry: two edges share a face when all four of their ends lie in one
    /// plane x = c, y = c or z = c.
    #[test]
    fn edges_share_a_face_when_their_ends_lie_in_one_face() {
        let ends = |e: usize| {
            let (axis, c) = edge_start(e);
            let start = corner_offset(c);
            let mut end = start;
            end[axis] = 1;
            [start, end]
        };
        for a in 0..12 {
            for b in 0..12 {
                let points = [ends(a), ends(b)].concat();
                let coplanar = (0..3).any(|k| points.iter().all(|p| p[k] == points[0][k]));
                assert_eq!(share_face(a, b), a != b && coplanar, "edges {a} and {b}");
            }
        }
    }

    #[test]
    fn bad_shapes_are_refused() {
        assert!(matches!(
            isosurface(&[0.0; 8], [2, 2, 3], 0.5, None),
            Err(RasterError::FieldSize { len: 8, .. })
        ));
        assert!(isosurface(&[0.0; 4], [1, 2, 2], 0.5, None).is_err());
        assert_eq!(
            isosurface(&[0.0; 8], [2, 2, 2], 0.5, None).unwrap(),
            Isosurface::default()
        );
    }
}
