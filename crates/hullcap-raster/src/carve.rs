//! The visual hull's carving test: cells against the views' silhouettes, in one pass.

use crate::RasterError;
use crate::whole::nearest;
use hullcap_core::{for_each_chunk_mut, resolve_threads};

/// A calibrated camera: x_cam = R·X + t, then OpenCV's distortion (k1, k2, p1, p2, k3) and
/// the intrinsic matrix K (upper triangular).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Intrinsics, row-major.
    pub k: [[f64; 3]; 3],
    /// Distortion coefficients k1, k2, p1, p2, k3.
    pub dist: [f64; 5],
    /// World-to-camera rotation, row-major.
    pub r: [[f64; 3]; 3],
    /// World-to-camera translation.
    pub t: [f64; 3],
}

/// Depths at or below this (metres) are behind the camera: nothing there is sampled.
const NEAR: f64 = 1e-6;

impl Camera {
    /// The point's pixel (u, v) and camera depth z. The pixel is meaningless when z ≤ 0.
    #[inline]
    pub fn project(&self, p: &[f64; 3]) -> (f64, f64, f64) {
        let (r, t) = (&self.r, &self.t);
        let x = r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2] + t[0];
        let y = r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2] + t[1];
        let z = r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2] + t[2];
        let (mut a, mut b) = (x / z, y / z);
        let [k1, k2, p1, p2, k3] = self.dist;
        if self.dist.iter().any(|&d| d != 0.0) {
            let r2 = a * a + b * b;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            (a, b) = (
                a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a),
                b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b,
            );
        }
        let k = &self.k;
        (
            k[0][0] * a + k[0][1] * b + k[0][2],
            k[1][1] * b + k[1][2],
            z,
        )
    }
}

/// A signed distance image (pixels, positive inside) given in a box of the view: row-major
/// `width × height` values from pixel (`x0`, `y0`); beyond the box, minus the Chebyshev
/// distance (in pixels) to it, which never exceeds the distance to a silhouette inside
/// the box. An empty box (`width` or `height` 0) is an empty silhouette: every pixel lies
/// infinitely far outside. The whole image is the box from (0, 0) of the view's size.
///
/// A person fills a tenth of a frame: the distance transforms run in the silhouette's
/// box alone, and what lies beyond it is known without an image of it.
#[derive(Debug, Clone, Copy)]
pub struct BoxedDistance<'a> {
    /// The box's first column.
    pub x0: usize,
    /// The box's first row.
    pub y0: usize,
    /// The box's width in pixels.
    pub width: usize,
    /// The box's height in pixels.
    pub height: usize,
    /// Row-major, `width × height`.
    pub values: &'a [f32],
}

impl<'a> BoxedDistance<'a> {
    /// The whole `width × height` image `values`.
    pub fn whole(values: &'a [f32], width: usize, height: usize) -> Self {
        BoxedDistance {
            x0: 0,
            y0: 0,
            width,
            height,
            values,
        }
    }

    /// The signed distance at pixel (`u`, `v`).
    #[inline]
    fn at(&self, u: usize, v: usize) -> f32 {
        if self.width == 0 || self.height == 0 {
            return f32::NEG_INFINITY;
        }
        // Minus each axis's distance to the box's rows or columns (0 within them).
        let below = |p: usize, first: usize, len: usize| {
            if p < first {
                (first - p) as f32
            } else if p >= first + len {
                (p + 1 - first - len) as f32
            } else {
                0.0
            }
        };
        let (du, dv) = (
            below(u, self.x0, self.width),
            below(v, self.y0, self.height),
        );
        if du > 0.0 || dv > 0.0 {
            -du.max(dv)
        } else {
            self.values[(v - self.y0) * self.width + (u - self.x0)]
        }
    }
}

/// One view as the carving reads it: the camera, its image size, and the signed distance
/// to its silhouette's edge and, optionally, to the edge of its prior (where the body is
/// expected).
#[derive(Debug, Clone, Copy)]
pub struct CarveView<'a> {
    /// The calibration.
    pub camera: Camera,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Signed distance to the silhouette's edge.
    pub signed: BoxedDistance<'a>,
    /// Signed distance to the prior's edge; `None`: no prior (it covers everything). Only
    /// where it is negative (outside the prior) is it read as a distance: inside, any value
    /// of at least 0 gives the same verdicts.
    pub prior: Option<BoxedDistance<'a>>,
    /// Pixels per unit of lateral size at unit depth (the larger focal length): a
    /// sphere of radius r at depth z covers a disc of radius at most `focal · r / z`.
    pub focal: f64,
}

/// What the views say of a cell of the carving (see [`classify_cells`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Verdict {
    /// Carved away.
    Out = 0,
    /// Kept whole.
    In = 1,
    /// Neither: to be split (only when the radius is positive).
    Boundary = 2,
}

/// The carving's decision for each cell, given its centre and the radius of the sphere
/// around it (0 at the finest level, where the centre decides).
///
/// A view *leaves a cell out* when the centre's projection lies outside its silhouette by
/// more than the cell's image radius (`focal · radius / depth` pixels), and its prior
/// leaves it out likewise. A view that does not see the centre (behind the camera or
/// outside the image) neither leaves it out nor has it inside. The cell is [`Verdict::Out`]
/// when more than `tolerance` views leave it out, or when any view does and some view's
/// prior leaves it out too. Otherwise, above the finest level, it is [`Verdict::In`] when
/// every view sees it inside by more than its image radius and [`Verdict::Boundary`]
/// otherwise; at the finest level it is in when at least `min_views` views see it.
/// A cell is dropped from the remaining views as soon as it is out, which is most of the
/// empty room at the first view. Threads: `None` = all cores.
pub fn classify_cells(
    centres: &[[f64; 3]],
    radius: f64,
    views: &[CarveView<'_>],
    tolerance: usize,
    min_views: usize,
    threads: Option<usize>,
) -> Result<Vec<Verdict>, RasterError> {
    for (index, view) in views.iter().enumerate() {
        for image in std::iter::once(view.signed).chain(view.prior) {
            let outside =
                image.x0 + image.width > view.width || image.y0 + image.height > view.height;
            if image.values.len() != image.width * image.height || outside {
                return Err(RasterError::ImageSize {
                    index,
                    len: image.values.len(),
                    width: view.width,
                    height: view.height,
                });
            }
        }
    }
    let mut verdicts = vec![Verdict::Out; centres.len()];
    for_each_chunk_mut(
        &mut verdicts,
        resolve_threads(threads),
        4096,
        |offset, chunk| {
            for (verdict, centre) in chunk.iter_mut().zip(&centres[offset..]) {
                *verdict = classify(centre, radius, views, tolerance, min_views);
            }
        },
    )?;
    Ok(verdicts)
}

/// The occupancy of the finest voxels that the carving keeps (see [`carve`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Carved {
    /// The finest-voxel index of the box's first voxel (may be negative: the box keeps
    /// two empty voxels all round).
    pub first: [i64; 3],
    /// The box's shape in finest voxels.
    pub shape: [usize; 3],
    /// Row-major, the last axis fastest: true where the voxel is kept.
    pub occupancy: Vec<bool>,
    /// How many cells were tested, all levels together.
    pub tested: usize,
}

/// Coarse-to-fine carving of the box of `fine` voxels of side `h` whose first corner is
/// `lo`: the grid of cells of side `h · 2^levels` covering it is classified
/// ([`classify_cells`], with the radius of each level's cell, `side · √3 / 2`, and 0 at
/// the finest level), the cells in are kept whole, the boundary cells are split in eight,
/// and so on down to the finest voxels. The result is the bounding box of the kept voxels
/// grown by two empty voxels all round (a box of 1 × 1 × 1 empty voxel at index 0 when
/// nothing is kept).
///
/// # Errors
/// As [`classify_cells`].
#[allow(clippy::too_many_arguments)]
pub fn carve(
    lo: [f64; 3],
    h: f64,
    fine: [usize; 3],
    levels: u32,
    views: &[CarveView<'_>],
    tolerance: usize,
    min_views: usize,
    threads: Option<usize>,
) -> Result<Carved, RasterError> {
    let top = fine.map(|n| n.div_ceil(1 << levels).max(1));
    let mut cells: Vec<[i64; 3]> = Vec::with_capacity(top.iter().product());
    for i in 0..top[0] {
        for j in 0..top[1] {
            for k in 0..top[2] {
                cells.push([i, j, k].map(|v| v as i64));
            }
        }
    }
    let mut kept: Vec<([i64; 3], i64)> = Vec::new(); // (first finest voxel, side in voxels)
    let mut tested = 0;
    for level in (0..=levels).rev() {
        let side = 1i64 << level;
        let size = h * side as f64;
        let radius = if level > 0 {
            size * 3f64.sqrt() / 2.0
        } else {
            0.0
        };
        let centres: Vec<[f64; 3]> = cells
            .iter()
            .map(|c| std::array::from_fn(|d| lo[d] + (c[d] as f64 + 0.5) * size))
            .collect();
        tested += cells.len();
        let verdicts = classify_cells(&centres, radius, views, tolerance, min_views, threads)?;
        let mut split = Vec::new();
        for (cell, verdict) in cells.iter().zip(verdicts) {
            match verdict {
                Verdict::In => kept.push((cell.map(|v| v * side), side)),
                Verdict::Boundary => split.extend(
                    (0..8)
                        .map(|o| [o >> 2 & 1, o >> 1 & 1, o & 1].map(|b| b as i64))
                        .map(|o| std::array::from_fn(|d| 2 * cell[d] + o[d])),
                ),
                Verdict::Out => {}
            }
        }
        cells = split;
    }
    if kept.is_empty() {
        return Ok(Carved {
            first: [0; 3],
            shape: [1; 3],
            occupancy: vec![false],
            tested,
        });
    }
    let first: [i64; 3] =
        std::array::from_fn(|d| kept.iter().map(|(c, _)| c[d]).min().unwrap_or(0) - 2);
    let last: [i64; 3] =
        std::array::from_fn(|d| kept.iter().map(|(c, s)| c[d] + s).max().unwrap_or(0) + 2);
    let shape: [usize; 3] = std::array::from_fn(|d| (last[d] - first[d]) as usize);
    let mut occupancy = vec![false; shape.iter().product()];
    for (corner, side) in kept {
        let at: [usize; 3] = std::array::from_fn(|d| (corner[d] - first[d]) as usize);
        let side = side as usize;
        for i in at[0]..at[0] + side {
            for j in at[1]..at[1] + side {
                let row = (i * shape[1] + j) * shape[2];
                occupancy[row + at[2]..row + at[2] + side].fill(true);
            }
        }
    }
    Ok(Carved {
        first,
        shape,
        occupancy,
        tested,
    })
}

fn classify(
    centre: &[f64; 3],
    radius: f64,
    views: &[CarveView<'_>],
    tolerance: usize,
    min_views: usize,
) -> Verdict {
    let (mut left_out, mut seen_by) = (0, 0);
    let (mut all_inside, mut prior_out) = (true, false);
    for view in views {
        let Some((u, v, depth)) = pixel_in(centre, &view.camera, view.width, view.height) else {
            all_inside = false; // unseen: decided at the finest level
            continue;
        };
        let reach = view.focal * radius / depth;
        let signed = f64::from(view.signed.at(u, v));
        seen_by += 1;
        all_inside &= signed > reach;
        prior_out |= view
            .prior
            .is_some_and(|prior| f64::from(prior.at(u, v)) < -reach);
        if signed < -reach {
            left_out += 1;
            if left_out > tolerance {
                return Verdict::Out;
            }
        }
    }
    if left_out > 0 && prior_out {
        Verdict::Out
    } else if radius > 0.0 {
        if all_inside {
            Verdict::In
        } else {
            Verdict::Boundary
        }
    } else if seen_by >= min_views {
        Verdict::In
    } else {
        Verdict::Out
    }
}

/// One view as [`doubtful_points`] reads it: the camera, and its silhouette and where the
/// silhouette's verdict of background was not sure, row-major `width × height` each.
#[derive(Debug, Clone, Copy)]
pub struct CutView<'a> {
    /// The calibration.
    pub camera: Camera,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Non-zero where the silhouette keeps the pixel.
    pub mask: &'a [u8],
    /// True where its verdict of background was not sure; `None`: sure everywhere.
    pub unsure: Option<&'a [bool]>,
}

/// For each point, whether at least `min_views` views leave it out of their silhouettes
/// and none of them was sure of the background there: where a hull was cut by views that
/// were all unsure (docs/design.md §7). A point is read at its nearest pixel (ties to
/// even), as the carving reads it; views that do not see it (behind the camera, or
/// outside the image) say nothing of it. Threads share the points.
pub fn doubtful_points(
    points: &[[f64; 3]],
    views: &[CutView<'_>],
    min_views: usize,
    threads: Option<usize>,
) -> Result<Vec<bool>, RasterError> {
    for (index, view) in views.iter().enumerate() {
        let pixels = view.width * view.height;
        let mut lens = std::iter::once(view.mask.len()).chain(view.unsure.map(<[bool]>::len));
        if let Some(len) = lens.find(|&len| len != pixels) {
            return Err(RasterError::ImageSize {
                index,
                len,
                width: view.width,
                height: view.height,
            });
        }
    }
    let mut doubtful = vec![false; points.len()];
    for_each_chunk_mut(
        &mut doubtful,
        resolve_threads(threads),
        4096,
        |offset, chunk| {
            for (flag, point) in chunk.iter_mut().zip(&points[offset..]) {
                *flag = doubted(point, views, min_views);
            }
        },
    )?;
    Ok(doubtful)
}

/// One point of [`doubtful_points`]: the views that leave it out unsure are counted,
/// and one that leaves it out for sure settles it.
fn doubted(point: &[f64; 3], views: &[CutView<'_>], min_views: usize) -> bool {
    let mut unsure = 0;
    for view in views {
        let Some((u, v, _)) = pixel_in(point, &view.camera, view.width, view.height) else {
            continue;
        };
        let at = v * view.width + u;
        if view.mask[at] != 0 {
            continue;
        }
        if !view.unsure.is_some_and(|doubt| doubt[at]) {
            return false;
        }
        unsure += 1;
    }
    unsure >= min_views
}

/// The pixel (column, row) nearest the point's projection by `camera`, ties to even, and
/// the point's depth; `None` behind the camera or outside the `width × height` image.
#[inline]
fn pixel_in(
    point: &[f64; 3],
    camera: &Camera,
    width: usize,
    height: usize,
) -> Option<(usize, usize, f64)> {
    let (u, v, z) = camera.project(point);
    if z <= NEAR {
        return None;
    }
    let (u, v) = (nearest(u), nearest(v));
    let inside = u >= 0.0 && v >= 0.0 && u < width as f64 && v < height as f64;
    inside.then_some((u as usize, v as usize, z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 × 3 image seen by a camera at the origin looking along +z (f = 10, centre at
    /// pixel (1, 1)): the middle pixel is inside by 2 pixels, the others outside by 1.
    fn view(prior: Option<&[f32]>) -> CarveView<'_> {
        const SIGNED: [f32; 9] = [-1.0, -1.0, -1.0, -1.0, 2.0, -1.0, -1.0, -1.0, -1.0];
        let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let k = [[10.0, 0.0, 1.0], [0.0, 10.0, 1.0], [0.0, 0.0, 1.0]];
        let camera = Camera {
            k,
            dist: [0.0; 5],
            r: identity,
            t: [0.0; 3],
        };
        CarveView {
            camera,
            width: 3,
            height: 3,
            signed: BoxedDistance::whole(&SIGNED, 3, 3),
            prior: prior.map(|p| BoxedDistance::whole(p, 3, 3)),
            focal: 10.0,
        }
    }

    #[test]
    fn cells_are_out_in_or_split_by_their_image_radius() {
        // On the axis at depth 1: inside by 2 px; a radius of 0.1 covers 1 px, 0.5 covers 5.
        let centres = [
            [0.0, 0.0, 1.0],
            [0.1, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 1.0],
        ];
        let one = [view(None)];
        let verdicts = |radius, views: &[CarveView<'_>], tolerance, min_views| {
            classify_cells(&centres, radius, views, tolerance, min_views, Some(2)).unwrap()
        };
        use Verdict::*;
        assert_eq!(
            verdicts(0.1, &one, 0, 1),
            [In, Boundary, Boundary, Boundary]
        );
        assert_eq!(
            verdicts(0.5, &one, 0, 1),
            [Boundary, Boundary, Boundary, Boundary]
        );
        // At the finest level: out of the silhouette, unseen (behind, outside the image).
        assert_eq!(verdicts(0.0, &one, 0, 1), [In, Out, Out, Out]);
        assert_eq!(verdicts(0.0, &one, 1, 1), [In, In, Out, Out]);
        // A prior that leaves the cell out keeps a view's verdict from being overruled.
        let prior = [-5.0f32; 9];
        let with_prior = [view(Some(&prior))];
        assert_eq!(verdicts(0.0, &with_prior, 1, 1), [In, Out, Out, Out]);
        let two = [view(None), view(None)];
        assert_eq!(verdicts(0.0, &two, 0, 3), [Out, Out, Out, Out]);
        let short = [0.0f32; 4];
        let bad = [
            view(None),
            CarveView {
                signed: BoxedDistance::whole(&short, 3, 3),
                ..view(None)
            },
        ];
        assert!(matches!(
            classify_cells(&centres, 0.0, &bad, 0, 1, None),
            Err(RasterError::ImageSize {
                index: 1,
                len: 4,
                ..
            })
        ));
    }

    #[test]
    fn a_boxed_image_reads_as_the_whole_image_it_stands_for() {
        // A 2 × 1 box at (3, 2) of a 7 × 5 image, and that image written out.
        let values = [1.5f32, 0.5];
        let boxed = BoxedDistance {
            x0: 3,
            y0: 2,
            width: 2,
            height: 1,
            values: &values,
        };
        for v in 0..5usize {
            for u in 0..7usize {
                let du = if u < 3 { 3 - u } else { u.saturating_sub(4) };
                let dv = if v < 2 { 2 - v } else { v.saturating_sub(2) };
                let want = if du == 0 && dv == 0 {
                    values[u - 3]
                } else {
                    -(du.max(dv) as f32)
                };
                assert_eq!(boxed.at(u, v), want, "({u}, {v})");
            }
        }
        let empty = BoxedDistance {
            width: 0,
            values: &[],
            ..boxed
        };
        assert_eq!(empty.at(3, 2), f32::NEG_INFINITY);
        // A box reaching beyond its view is refused.
        let mut one = view(None);
        one.signed = BoxedDistance { x0: 2, ..boxed };
        assert!(matches!(
            classify_cells(&[[0.0, 0.0, 1.0]], 0.0, &[one], 0, 1, None),
            Err(RasterError::ImageSize { index: 0, .. })
        ));
    }

    #[test]
    fn doubtful_points_are_what_counting_every_view_by_hand_gives() {
        // Three cameras like `view`'s, shifted sideways, each with its own 3 × 3
        // silhouette and unsure image (the third sure everywhere); points on a grid at
        // depth 1 (half a pixel apart across, ties included; a pixel apart down) and one
        // behind the cameras.
        let shifts = [0.0, 0.1, -0.2];
        let masks: Vec<[u8; 9]> = (0..3)
            .map(|k| std::array::from_fn(|i| u8::from((i * 7 + k * 3) % 4 == 0)))
            .collect();
        let unsure: Vec<[bool; 9]> = (0..3)
            .map(|k| std::array::from_fn(|i| (i + k) % 3 != 0))
            .collect();
        let views: Vec<CutView<'_>> = (0..3)
            .map(|k| CutView {
                camera: Camera {
                    t: [shifts[k], 0.0, 0.0],
                    ..view(None).camera
                },
                width: 3,
                height: 3,
                mask: &masks[k],
                unsure: (k != 2).then_some(&unsure[k][..]),
            })
            .collect();
        let mut points: Vec<[f64; 3]> = (-4..=4)
            .flat_map(|i| (-3..=3).map(move |j| [f64::from(i) * 0.05, f64::from(j) * 0.1, 1.0]))
            .collect();
        points.push([0.0, 0.0, -1.0]);
        for min_views in 0..4 {
            let got = doubtful_points(&points, &views, min_views, Some(2)).unwrap();
            for (point, got) in points.iter().zip(got) {
                let (mut unsure_cuts, mut sure_cut) = (0, false);
                for (k, v) in views.iter().enumerate() {
                    if point[2] <= 0.0 {
                        continue;
                    }
                    let u = (10.0 * (point[0] + shifts[k]) / point[2] + 1.0).round_ties_even();
                    let r = (10.0 * point[1] / point[2] + 1.0).round_ties_even();
                    if !(0.0..3.0).contains(&u) || !(0.0..3.0).contains(&r) {
                        continue;
                    }
                    let at = r as usize * 3 + u as usize;
                    if v.mask[at] == 0 {
                        match v.unsure {
                            Some(doubt) if doubt[at] => unsure_cuts += 1,
                            _ => sure_cut = true,
                        }
                    }
                }
                assert_eq!(
                    got,
                    !sure_cut && unsure_cuts >= min_views,
                    "{point:?}, {min_views}"
                );
            }
        }
        let short = [0u8; 4];
        let bad = [
            views[0],
            CutView {
                mask: &short,
                ..views[1]
            },
        ];
        assert!(matches!(
            doubtful_points(&points, &bad, 1, None),
            Err(RasterError::ImageSize {
                index: 1,
                len: 4,
                ..
            })
        ));
    }
}
