//! The rasteriser: bands of image rows in parallel, every band sees every triangle.

use crate::whole::{ceil, floor};
use hullcap_core::{WorkerPanicked, for_each_chunk_mut, resolve_threads};

/// Why a rasterisation was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterError {
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {vertex}, but there are {n} vertices")]
    BadIndex {
        /// The face's row.
        face: usize,
        /// The offending index.
        vertex: u32,
        /// Number of vertices.
        n: usize,
    },
    /// The image would be empty or absurdly large.
    #[error("image size {width}×{height} is not allowed (1 to 2^14 per side)")]
    BadSize {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// A grid's values do not fill its shape, or (for an isosurface) an axis has fewer
    /// than 2 points or the grid has 2^31 edges or more.
    #[error(
        "a grid of {len} values cannot have the shape {shape:?} (the values fill the shape; an isosurface needs 2 points per axis at least and fewer than 2^31 edges)"
    )]
    FieldSize {
        /// Its number of values.
        len: usize,
        /// The shape it was given.
        shape: [usize; 3],
    },
    /// A blur's width is not a positive number of voxels (at most 100).
    #[error("sigma must be positive and at most 100 voxels, got {0}")]
    BadSigma(f64),
    /// An image of a view does not hold `width × height` values.
    #[error("image {index} holds {len} values, not {width}×{height}")]
    ImageSize {
        /// Its place in the list.
        index: usize,
        /// Its number of values.
        len: usize,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// A background model's plane, or the image tested against it, does not hold one
    /// value for each of the model's pixels (three for the image).
    #[error("{what} holds {len} values for a background model of {pixels} pixels")]
    BackgroundSize {
        /// What it is.
        what: &'static str,
        /// Its number of values.
        len: usize,
        /// The model's pixels.
        pixels: usize,
    },
    /// The guided silhouettes' log-odds were asked for a window that does not lie in the
    /// image, given an array that does not hold the values it should, or bounds that are
    /// NaN or out of order.
    #[error("guided log-odds: {0}")]
    BadGuidedInput(String),
    /// A worker thread panicked.
    #[error(transparent)]
    Panicked(#[from] WorkerPanicked),
}

/// A depth buffer and the triangle seen at each pixel, row-major, `width × height`.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Camera depth (z) of the nearest surface; `f32::INFINITY` where nothing is seen.
    pub depth: Vec<f32>,
    /// Index of the triangle seen; −1 where nothing is seen.
    pub face: Vec<i32>,
}

/// A triangle in pixel space, ready for edge tests.
struct Screen {
    face: i32,
    /// Pixel bounding box, inclusive.
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
    /// Edge functions e_k(x, y) = a_k x + b_k y + c_k, normalised so the three sum to 1
    /// inside (barycentric coordinates).
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
    /// Whether a pixel exactly on edge k belongs to this triangle (top-left rule).
    owns_edge: [bool; 3],
    /// 1/z at the three corners.
    inv_z: [f64; 3],
}

impl Screen {
    /// The barycentric coordinates of the pixel centre (x, y) when the triangle covers
    /// it (the top-left rule on its edges), else `None`.
    #[inline]
    fn barycentric(&self, x: f64, y: f64) -> Option<[f64; 3]> {
        let mut bary = [0.0; 3];
        for (k, slot) in bary.iter_mut().enumerate() {
            let e = self.a[k] * x + self.b[k] * y + self.c[k];
            if e < 0.0 || (e == 0.0 && !self.owns_edge[k]) {
                return None;
            }
            *slot = e;
        }
        Some(bary)
    }

    /// Whether the triangle covers the pixel centre (x, y).
    #[inline]
    fn covers(&self, x: f64, y: f64) -> bool {
        self.barycentric(x, y).is_some()
    }
}

/// Rasterises triangles `faces` over `vertices` given as (u, v, z): pixel coordinates and
/// camera depth (metres, positive in front). Threads: `None` = all cores.
///
/// ```
/// let vertices = [[1.0, 1.0, 2.0], [8.0, 1.0, 2.0], [1.0, 8.0, 2.0]];
/// let out = hullcap_raster::rasterize(&vertices, &[[0, 1, 2]], 10, 10, 0.01, None).unwrap();
/// assert_eq!(out.face[2 * 10 + 2], 0);
/// assert_eq!(out.face[9 * 10 + 9], -1);
/// assert_eq!(out.depth[2 * 10 + 2], 2.0);
/// ```
pub fn rasterize(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    width: usize,
    height: usize,
    near: f64,
    threads: Option<usize>,
) -> Result<Rendered, RasterError> {
    let screens = screens(vertices, faces, width, height, near, false)?;
    let pixels = paint(
        &screens,
        width,
        height,
        threads,
        (f32::INFINITY, -1i32),
        draw_band,
    )?;
    let (depth, face) = pixels.into_iter().unzip();
    Ok(Rendered { depth, face })
}

/// The silhouette of the triangles: 1 where [`rasterize`] sees a triangle (`face ≥ 0`), 0
/// elsewhere, row-major, the same pixels to the last one; without depths, so cheaper.
/// Errors as [`rasterize`].
///
/// `closed`: the triangles bound a solid (each edge is shared by two of them, wound in
/// opposite directions) that lies wholly beyond `near`. Every line of sight that meets
/// such a solid enters it through a triangle of one winding in the image and leaves it
/// through one of the other, so the triangles of one winding alone cover the same
/// pixels: only those are drawn, half the triangles. On a mesh that is not closed this
/// leaves holes.
///
/// ```
/// let vertices = [[1.0, 1.0, 2.0], [8.0, 1.0, 2.0], [1.0, 8.0, 2.0]];
/// let seen = hullcap_raster::coverage(&vertices, &[[0, 1, 2]], 10, 10, 0.01, None, false).unwrap();
/// assert_eq!((seen[2 * 10 + 2], seen[9 * 10 + 9]), (1, 0));
/// ```
pub fn coverage(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    width: usize,
    height: usize,
    near: f64,
    threads: Option<usize>,
    closed: bool,
) -> Result<Vec<u8>, RasterError> {
    let screens = screens(vertices, faces, width, height, near, closed)?;
    Ok(paint(&screens, width, height, threads, 0u8, cover_band)?)
}

/// Image rows per band of the parallel drawing.
const BAND_ROWS: usize = 8;

/// A `width` × `height` image of `blank` pixels, its bands of [`BAND_ROWS`] rows drawn by
/// `band(screens, width, offset of the band's first pixel, the band)` on the threads.
fn paint<T: Copy + Send>(
    screens: &[Screen],
    width: usize,
    height: usize,
    threads: Option<usize>,
    blank: T,
    band: fn(&[Screen], usize, usize, &mut [T]),
) -> Result<Vec<T>, WorkerPanicked> {
    let mut pixels = vec![blank; width * height];
    for_each_chunk_mut(
        &mut pixels,
        resolve_threads(threads),
        width * BAND_ROWS,
        |offset, chunk| band(screens, width, offset, chunk),
    )?;
    Ok(pixels)
}

/// The triangles that can be seen, set up for edge tests; errors on a bad size or index.
/// `one_winding`: only those whose corners run one way round in the image (a positive
/// signed area in pixel coordinates).
fn screens(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    width: usize,
    height: usize,
    near: f64,
    one_winding: bool,
) -> Result<Vec<Screen>, RasterError> {
    const MAX_SIDE: usize = 1 << 14;
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(RasterError::BadSize { width, height });
    }
    let mut screens = Vec::with_capacity(faces.len());
    for (f, tri) in faces.iter().enumerate() {
        let mut corners = [[0.0; 3]; 3];
        for (k, &v) in tri.iter().enumerate() {
            corners[k] = *vertices.get(v as usize).ok_or(RasterError::BadIndex {
                face: f,
                vertex: v,
                n: vertices.len(),
            })?;
        }
        if let Some(s) = setup(f as i32, &corners, width, height, near, one_winding) {
            screens.push(s);
        }
    }
    Ok(screens)
}

fn setup(
    face: i32,
    p: &[[f64; 3]; 3],
    width: usize,
    height: usize,
    near: f64,
    one_winding: bool,
) -> Option<Screen> {
    // Written so that a NaN depth also skips the triangle.
    if p.iter().any(|c| {
        c[2].partial_cmp(&near) != Some(std::cmp::Ordering::Greater)
            || !c[0].is_finite()
            || !c[1].is_finite()
    }) {
        return None;
    }
    // The pixel centres the triangle's box holds; most of a body's small triangles far
    // from the image, or between two centres, end here before their edges are worked out.
    let lo = |d: usize| p.iter().map(|c| c[d]).fold(f64::INFINITY, f64::min);
    let hi = |d: usize| p.iter().map(|c| c[d]).fold(f64::NEG_INFINITY, f64::max);
    // Beyond 2⁵¹ pixels the clamps decide whatever `ceil` and `floor` give.
    let x0 = ceil(lo(0)).max(0.0);
    let y0 = ceil(lo(1)).max(0.0);
    let x1 = floor(hi(0)).min(width as f64 - 1.0);
    let y1 = floor(hi(1)).min(height as f64 - 1.0);
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let area =
        (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
    if area == 0.0 || !area.is_finite() || (one_winding && area < 0.0) {
        return None;
    }
    let (mut a, mut b, mut c) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    let mut owns_edge = [false; 3];
    for k in 0..3 {
        // Edge opposite corner k runs from corner i to corner j.
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let (ea, eb) = (p[i][1] - p[j][1], p[j][0] - p[i][0]);
        a[k] = ea / area;
        b[k] = eb / area;
        c[k] = (p[i][0] * p[j][1] - p[j][0] * p[i][1]) / area;
        // Top-left rule on the normalised edge function (inside is positive): own the
        // edge when its inward normal points down (+v) or, if horizontal, right (+u).
        owns_edge[k] = b[k] > 0.0 || (b[k] == 0.0 && a[k] > 0.0);
    }
    Some(Screen {
        face,
        x0: x0 as i32,
        x1: x1 as i32,
        y0: y0 as i32,
        y1: y1 as i32,
        a,
        b,
        c,
        owns_edge,
        inv_z: [1.0 / p[0][2], 1.0 / p[1][2], 1.0 / p[2][2]],
    })
}

/// Calls `visit(pixel − offset, x, y)` for every pixel (x, y) of triangle `s`'s box that
/// lies in the band `offset .. offset + band_len`; `visit` tests whether `s` covers it.
fn for_box_pixels(
    s: &Screen,
    width: usize,
    offset: usize,
    band_len: usize,
    mut visit: impl FnMut(usize, f64, f64),
) {
    let first_row = (offset / width) as i32;
    let last_row = ((offset + band_len - 1) / width) as i32;
    if s.y1 < first_row || s.y0 > last_row {
        return;
    }
    let (lo, hi) = (offset, offset + band_len);
    for y in s.y0.max(first_row)..=s.y1.min(last_row) {
        for x in s.x0..=s.x1 {
            let pixel = y as usize * width + x as usize;
            if (lo..hi).contains(&pixel) {
                visit(pixel - lo, f64::from(x), f64::from(y));
            }
        }
    }
}

/// Draws every triangle into the pixels `offset .. offset + band.len()` of the image.
fn draw_band(screens: &[Screen], width: usize, offset: usize, band: &mut [(f32, i32)]) {
    let n = band.len();
    for s in screens {
        for_box_pixels(s, width, offset, n, |i, x, y| {
            if let Some(bary) = s.barycentric(x, y) {
                let inv_z = bary[0] * s.inv_z[0] + bary[1] * s.inv_z[1] + bary[2] * s.inv_z[2];
                let z = (1.0 / inv_z) as f32;
                let slot = &mut band[i];
                if z < slot.0 || (z == slot.0 && s.face < slot.1) {
                    *slot = (z, s.face);
                }
            }
        });
    }
}

/// Marks with 1 the pixels `offset .. offset + band.len()` that any triangle covers.
/// A pixel already marked is not tested again: the marks are the same.
fn cover_band(screens: &[Screen], width: usize, offset: usize, band: &mut [u8]) {
    let n = band.len();
    for s in screens {
        for_box_pixels(s, width, offset, n, |i, x, y| {
            if band[i] == 0 && s.covers(x, y) {
                band[i] = 1;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of two triangles covering pixels 2..=5 in both directions.
    fn square(z: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = vec![[1.5, 1.5, z], [5.5, 1.5, z], [5.5, 5.5, z], [1.5, 5.5, z]];
        (v, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn a_square_covers_its_pixels_once_each() {
        let (v, f) = square(3.0);
        let out = rasterize(&v, &f, 8, 8, 0.01, Some(3)).unwrap();
        let covered = out.face.iter().filter(|&&f| f >= 0).count();
        assert_eq!(covered, 16);
        for y in 0..8 {
            for x in 0..8 {
                let inside = (2..=5).contains(&x) && (2..=5).contains(&y);
                assert_eq!(out.face[y * 8 + x] >= 0, inside, "pixel ({x}, {y})");
            }
        }
    }

    #[test]
    fn shared_edges_through_pixel_centres_are_drawn_once() {
        // A fan of triangles around a pixel centre: every pixel centre on an inner edge
        // must be owned by exactly one triangle, so the fan covers the same pixels as
        // the square it tiles.
        let c = [4.0, 4.0, 1.0];
        let ring = [
            [1.0, 1.0, 1.0],
            [7.0, 1.0, 1.0],
            [7.0, 7.0, 1.0],
            [1.0, 7.0, 1.0],
        ];
        let mut v = vec![c];
        v.extend(ring);
        let f = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let fan = rasterize(&v, &f, 9, 9, 0.01, Some(1)).unwrap();
        let mut counts = vec![0; 81];
        for tri in &f {
            let one = rasterize(&v, &[*tri], 9, 9, 0.01, Some(1)).unwrap();
            for (count, &face) in counts.iter_mut().zip(&one.face) {
                if face == 0 {
                    *count += 1;
                }
            }
        }
        assert!(
            counts.iter().all(|&c| c <= 1),
            "a pixel drawn twice: {counts:?}"
        );
        let covered = fan.face.iter().filter(|&&f| f >= 0).count();
        assert_eq!(covered, counts.iter().sum::<usize>());
    }

    #[test]
    fn nearer_surface_wins_and_depth_is_perspective_correct() {
        let (mut v, mut f) = square(3.0);
        let (v2, f2) = square(2.0);
        f.extend(f2.iter().map(|t| [t[0] + 4, t[1] + 4, t[2] + 4]));
        v.extend(v2);
        let out = rasterize(&v, &f, 8, 8, 0.01, None).unwrap();
        assert!(out.face[3 * 8 + 3] >= 2);
        assert_eq!(out.depth[3 * 8 + 3], 2.0);
        // A slanted triangle: depth from 1 to 3 along u; 1/z is linear in the image.
        let v = vec![[0.0, 0.0, 1.0], [10.0, 0.0, 3.0], [0.0, 10.0, 1.0]];
        let out = rasterize(&v, &[[0, 1, 2]], 11, 11, 0.01, None).unwrap();
        let expect = 1.0 / (1.0 - 0.5 + 0.5 / 3.0);
        assert!((f64::from(out.depth[5]) - expect).abs() < 1e-6);
    }

    #[test]
    fn threads_agree_and_bad_input_is_refused() {
        let (v, f) = square(3.0);
        let one = rasterize(&v, &f, 8, 40, 0.01, Some(1)).unwrap();
        let many = rasterize(&v, &f, 8, 40, 0.01, Some(7)).unwrap();
        assert_eq!(one.face, many.face);
        assert!(matches!(
            rasterize(&v, &[[0, 1, 9]], 8, 8, 0.01, None),
            Err(RasterError::BadIndex {
                face: 0,
                vertex: 9,
                ..
            })
        ));
        assert!(matches!(
            rasterize(&v, &f, 0, 8, 0.01, None),
            Err(RasterError::BadSize { .. })
        ));
        let behind = vec![[1.0, 1.0, -1.0], [5.0, 1.0, 2.0], [1.0, 5.0, 2.0]];
        let out = rasterize(&behind, &[[0, 1, 2]], 8, 8, 0.01, None).unwrap();
        assert!(out.face.iter().all(|&f| f == -1));
        assert!(matches!(
            coverage(&v, &[[0, 1, 9]], 8, 8, 0.01, None, false),
            Err(RasterError::BadIndex { .. })
        ));
        assert!(
            coverage(&behind, &[[0, 1, 2]], 8, 8, 0.01, None, false)
                .unwrap()
                .iter()
                .all(|&c| c == 0)
        );
    }

    #[test]
    fn coverage_is_where_a_triangle_is_seen() {
        // A soup of small overlapping triangles, some off the image, a third with corners on
        // pixel centres (edges through them), some behind the near plane.
        let mut state = 12345u64;
        let mut next = |scale: f64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * scale
        };
        let mut vertices = Vec::new();
        for i in 0..300 {
            let (u, v) = (next(90.0) - 10.0, next(70.0) - 10.0);
            for _ in 0..3 {
                let (du, dv) = (next(16.0) - 8.0, next(16.0) - 8.0);
                let (du, dv) = if i % 3 == 0 {
                    (du.round(), dv.round())
                } else {
                    (du, dv)
                };
                vertices.push([u.round() + du, v.round() + dv, next(4.0) - 0.5]);
            }
        }
        let faces: Vec<[u32; 3]> = (0..300u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let drawn = rasterize(&vertices, &faces, 71, 53, 0.01, Some(1)).unwrap();
        let seen: Vec<u8> = drawn.face.iter().map(|&f| u8::from(f >= 0)).collect();
        assert!(seen.contains(&1) && seen.contains(&0));
        for threads in [1, 3] {
            assert_eq!(
                coverage(&vertices, &faces, 71, 53, 0.01, Some(threads), false).unwrap(),
                seen
            );
        }
    }

    /// A closed, bumpy sphere of `rings` × `segments` (poles apart), centred at `centre`
    /// (camera space, metres), projected by a pinhole of focal length 300 px centred on
    /// (40.3, 30.6): vertices in pixel space and consistently wound faces.
    fn projected_sphere(
        centre: [f64; 3],
        radius: f64,
        rings: u32,
        segments: u32,
        first: u32,
    ) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut points = vec![[0.0, 0.0, radius]];
        for r in 1..rings {
            let polar = std::f64::consts::PI * f64::from(r) / f64::from(rings);
            for s in 0..segments {
                let azimuth = std::f64::consts::TAU * f64::from(s) / f64::from(segments);
                let bump = 1.0 + 0.15 * (3.0 * azimuth).sin() * (2.0 * polar).cos();
                let rr = radius * bump;
                points.push([
                    rr * polar.sin() * azimuth.cos(),
                    rr * polar.sin() * azimuth.sin(),
                    rr * polar.cos(),
                ]);
            }
        }
        points.push([0.0, 0.0, -radius]);
        let ring = |r: u32, s: u32| first + 1 + (r - 1) * segments + s % segments;
        let bottom = first + 1 + (rings - 1) * segments;
        let mut faces = Vec::new();
        for s in 0..segments {
            faces.push([first, ring(1, s), ring(1, s + 1)]);
            for r in 1..rings - 1 {
                faces.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
                faces.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
            }
            faces.push([ring(rings - 1, s), bottom, ring(rings - 1, s + 1)]);
        }
        let vertices = points
            .iter()
            .map(|p| {
                let (x, y, z) = (p[0] + centre[0], p[1] + centre[1], p[2] + centre[2]);
                [300.0 * x / z + 40.3, 300.0 * y / z + 30.6, z]
            })
            .collect();
        (vertices, faces)
    }

    #[test]
    fn a_closed_mesh_is_covered_by_one_winding() {
        // Two bumpy spheres that pass through each other, as a posed body's parts may.
        let (mut vertices, mut faces) = projected_sphere([0.0, 0.0, 2.0], 0.15, 13, 17, 0);
        let (v2, f2) = projected_sphere([0.12, -0.05, 2.3], 0.1, 9, 23, vertices.len() as u32);
        vertices.extend(v2);
        faces.extend(f2);
        let mut edges: Vec<(u32, u32)> = faces
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .collect();
        edges.sort_unstable();
        for &(a, b) in &edges {
            assert!(edges.binary_search(&(b, a)).is_ok(), "edge {a}-{b} is open");
        }
        let every = coverage(&vertices, &faces, 83, 61, 0.01, Some(2), false).unwrap();
        assert!(every.iter().filter(|&&c| c == 1).count() > 1000);
        assert_eq!(
            coverage(&vertices, &faces, 83, 61, 0.01, Some(2), true).unwrap(),
            every
        );
        // The triangles of the other winding alone cover the same pixels too.
        let reversed: Vec<[u32; 3]> = faces.iter().map(|t| [t[0], t[2], t[1]]).collect();
        assert_eq!(
            coverage(&vertices, &reversed, 83, 61, 0.01, Some(2), true).unwrap(),
            every
        );
        // Not a test that cannot fail: with the cap facing the camera cut off the first
        // sphere, the mesh is open and one of the two windings leaves its hole.
        let near_pole = 1 + 12 * 17;
        let open: Vec<[u32; 3]> = faces
            .iter()
            .filter(|t| !t.contains(&near_pole))
            .copied()
            .collect();
        let holes = [
            open.clone(),
            open.iter().map(|t| [t[0], t[2], t[1]]).collect(),
        ]
        .iter()
        .map(|f| coverage(&vertices, f, 83, 61, 0.01, Some(2), true).unwrap())
        .filter(|seen| *seen != every)
        .count();
        assert_eq!(holes, 1);
    }
}
