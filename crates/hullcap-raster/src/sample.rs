//! Images sampled at the projections of world points: the visual hull's lookups.

use crate::RasterError;
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

/// `x` rounded to the nearest integer, ties to even, as `f64::round_ties_even` does for
/// |x| < 2⁵¹ (beyond, the value is far outside any image anyway): adding and subtracting
/// 1.5·2⁵² leaves no fractional bits, so the addition rounds in the default mode (to
/// nearest, ties to even). `round_ties_even` itself is a library call on baseline x86-64
/// (no SSE4.1), and it was most of the lookup's time.
#[inline]
fn nearest(x: f64) -> f64 {
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
    (x + SHIFT) - SHIFT
}

/// For each point, the value of every image at the pixel nearest its projection (ties to
/// even, like NumPy's `rint`) and its camera depth. Points behind the camera or projecting
/// outside the image get `f32::INFINITY` from every image and (behind only) an infinite
/// depth. `images` are row-major `width × height`. Threads: `None` = all cores.
///
/// ```
/// use hullcap_raster::{Camera, sample_at_projections};
/// let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let k = [[10.0, 0.0, 1.0], [0.0, 10.0, 1.0], [0.0, 0.0, 1.0]];
/// let camera = Camera { k, dist: [0.0; 5], r: identity, t: [0.0; 3] };
/// let image: Vec<f32> = (0..9).map(|i| i as f32).collect(); // 3 × 3
/// let points = [[0.0, 0.0, 2.0], [0.1, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 1.0]];
/// let (values, depth) = sample_at_projections(&points, &camera, &[&image], 3, 3, None).unwrap();
/// assert_eq!(values[0], [4.0, 5.0, f32::INFINITY, f32::INFINITY]);
/// assert_eq!(depth, [2.0, 1.0, f64::INFINITY, 1.0]);
/// ```
pub fn sample_at_projections(
    points: &[[f64; 3]],
    camera: &Camera,
    images: &[&[f32]],
    width: usize,
    height: usize,
    threads: Option<usize>,
) -> Result<(Vec<Vec<f32>>, Vec<f64>), RasterError> {
    for (index, image) in images.iter().enumerate() {
        if image.len() != width * height || image.len() > u32::MAX as usize {
            return Err(RasterError::ImageSize {
                index,
                len: image.len(),
                width,
                height,
            });
        }
    }
    // Pass 1, in parallel: each point's pixel index (u32::MAX: none) and depth.
    let mut found = vec![(u32::MAX, f64::INFINITY); points.len()];
    for_each_chunk_mut(
        &mut found,
        resolve_threads(threads),
        4096,
        |offset, chunk| {
            for (slot, p) in chunk.iter_mut().zip(&points[offset..]) {
                let (u, v, z) = camera.project(p);
                if z <= NEAR {
                    continue;
                }
                let (u, v) = (nearest(u), nearest(v));
                let inside = u >= 0.0 && v >= 0.0 && u < width as f64 && v < height as f64;
                let pixel = if inside {
                    (v as usize * width + u as usize) as u32
                } else {
                    u32::MAX
                };
                *slot = (pixel, z);
            }
        },
    )?;
    // Pass 2: the lookups (memory-bound, cheap next to the projections).
    let values = images
        .iter()
        .map(|image| {
            found
                .iter()
                .map(|&(pixel, _)| {
                    if pixel == u32::MAX {
                        f32::INFINITY
                    } else {
                        image[pixel as usize]
                    }
                })
                .collect()
        })
        .collect();
    Ok((values, found.into_iter().map(|(_, z)| z).collect()))
}

#[cfg(test)]
mod tests {
    use super::nearest;

    #[test]
    fn nearest_rounds_like_round_ties_even() {
        let mut values = vec![0.0, -0.0, 0.5, 1.5, 2.5, -0.5, -1.5, -2.5, 0.49999999999999994, 1e15 + 0.5];
        values.extend((-4000..4000).map(|i| i as f64 * 0.25 + 0.001 * (i % 7) as f64));
        values.extend((0..1000).map(|i| (i as f64 * 0.7919).sin() * 1e6));
        for x in values {
            assert_eq!(nearest(x), x.round_ties_even(), "x = {x}");
        }
    }
}
