//! Horprasert's background test of a colour image, per pixel, in one pass
//! (`hullcap._silhouette.StatisticalBackground`, docs/design.md §6).
//!
//! Each pixel of the empty scene has an expected colour E and a per-channel spread s; a
//! new colour I is compared along the line through E (the brightness distortion α, the
//! multiple of E nearest to I in units of s) and across it (the chromaticity distortion
//! CD, the distance from that multiple). The model hands its per-pixel constants over as
//! planes of `f32`: 1/s and E/s per channel, ‖E/s‖², and the reciprocal of CD's spread.
//!
//! The arithmetic is NumPy's former steps, one for one in single precision and in the
//! same order (no fused multiply-adds), so the values are theirs to the bit. In NumPy
//! each step read and wrote whole planes of floats, about twenty of them, which made the
//! test memory bound: 2.7 ms for a 640 × 480 image, the largest single cost of a frame's
//! silhouettes. One pass reads the image and the planes once.

use crate::RasterError;
use hullcap_core::{for_each_chunk_mut, resolve_threads};

/// A camera's background model: its per-pixel constants, row-major planes of one value a
/// pixel (channels in the images' order, B, G, R for OpenCV's).
#[derive(Debug, Clone, Copy)]
pub struct BackgroundPlanes<'a> {
    /// 1/s of each channel.
    pub inv_spread: [&'a [f32]; 3],
    /// E/s of each channel.
    pub scaled_mean: [&'a [f32]; 3],
    /// ‖E/s‖², positive.
    pub scaled_norm2: &'a [f32],
    /// 1 / (CD's spread over the background under noise alone).
    pub inv_cd_spread: &'a [f32],
}

/// What makes a pixel foreground (`hullcap._silhouette.Thresholds`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvidenceRule {
    /// Normalised CD above which the colour is the subject's.
    pub chromaticity: f32,
    /// α below which a darker pixel is foreground, not a shadow.
    pub darkest_shadow: f32,
    /// α above which a brighter pixel is foreground, not a highlight.
    pub brightest_highlight: f32,
    /// The evidence given where α alone decides.
    pub foreground: f32,
}

/// Pixels per chunk of the parallel pass: a chunk of a 640 × 480 image's rows is a few
/// tens of microseconds of work, worth a thread.
const MIN_CHUNK: usize = 1 << 14;

/// The evidence that each pixel of `image` (row-major, three `u8` channels a pixel) is
/// foreground: normalised CD less `rule.chromaticity` (negative within it), or
/// `rule.foreground` where α lies below `darkest_shadow` or above `brightest_highlight`.
///
/// # Errors
/// [`RasterError::BackgroundSize`] when the planes or the image do not hold one value
/// (three for the image) for each of the model's pixels.
pub fn background_evidence(
    image: &[u8],
    planes: &BackgroundPlanes<'_>,
    rule: &EvidenceRule,
    threads: Option<usize>,
) -> Result<Vec<f32>, RasterError> {
    let n = check(image, planes)?;
    let mut out = vec![0.0f32; n];
    for_each_chunk_mut(
        &mut out,
        resolve_threads(threads),
        MIN_CHUNK,
        |first, chunk| {
            let inv_cd_spread = &planes.inv_cd_spread[first..first + chunk.len()];
            Run::new(image, planes, first, chunk.len()).each(chunk, |p, alpha, cd, out| {
                let inv_cd_spread = &inv_cd_spread[p..p + out.len()];
                for (k, v) in out.iter_mut().enumerate() {
                    let far = alpha[k] < rule.darkest_shadow || alpha[k] > rule.brightest_highlight;
                    let normalised = cd[k] * inv_cd_spread[k] - rule.chromaticity;
                    *v = if far { rule.foreground } else { normalised };
                }
            });
        },
    )?;
    Ok(out)
}

/// The brightness and chromaticity distortions (α, CD) of each pixel of `image`, CD not
/// normalised (`planes.inv_cd_spread` is not read): the background model's own statistics
/// are made from them.
///
/// # Errors
/// As [`background_evidence`].
pub fn background_distortions(
    image: &[u8],
    planes: &BackgroundPlanes<'_>,
    threads: Option<usize>,
) -> Result<(Vec<f32>, Vec<f32>), RasterError> {
    let n = check(image, planes)?;
    let mut out = vec![(0.0f32, 0.0f32); n];
    for_each_chunk_mut(
        &mut out,
        resolve_threads(threads),
        MIN_CHUNK,
        |first, chunk| {
            Run::new(image, planes, first, chunk.len()).each(chunk, |_, alpha, cd, out| {
                for (k, v) in out.iter_mut().enumerate() {
                    *v = (alpha[k], cd[k]);
                }
            });
        },
    )?;
    Ok(out.into_iter().unzip())
}

/// Pixels taken together: the compiler turns the arithmetic of a group into vector
/// instructions. Pixel by pixel, with a bounds check for every read, the loop stayed
/// scalar and took twice as long.
const LANES: usize = 8;

/// A run of consecutive pixels: the image's values and the planes cut to it.
struct Run<'a> {
    image: &'a [u8],
    inv_spread: [&'a [f32]; 3],
    scaled_mean: [&'a [f32]; 3],
    scaled_norm2: &'a [f32],
}

impl<'a> Run<'a> {
    fn new(image: &'a [u8], planes: &BackgroundPlanes<'a>, first: usize, len: usize) -> Self {
        let cut = |plane: &'a [f32]| &plane[first..first + len];
        Run {
            image: &image[3 * first..3 * (first + len)],
            inv_spread: planes.inv_spread.map(cut),
            scaled_mean: planes.scaled_mean.map(cut),
            scaled_norm2: cut(planes.scaled_norm2),
        }
    }

    /// Hands the run's pixels to `group` a few at a time ([`LANES`], then one by one for
    /// the rest): `group(p, α, CD, out)` with the distortions of the run's pixels from
    /// the `p`-th on and `out`, their part of the run's output `out` (as long as the run).
    #[inline(always)]
    fn each<T>(&self, out: &mut [T], group: impl Fn(usize, &[f32], &[f32], &mut [T])) {
        let (groups, rest) = out.as_chunks_mut::<LANES>();
        for (g, lanes) in groups.iter_mut().enumerate() {
            let (alpha, cd) = self.distortions::<LANES>(g * LANES);
            group(g * LANES, &alpha, &cd, lanes);
        }
        let first = groups.len() * LANES;
        for (k, one) in rest.chunks_mut(1).enumerate() {
            let (alpha, cd) = self.distortions::<1>(first + k);
            group(first + k, &alpha, &cd, one);
        }
    }

    /// (α, CD) of the `N` pixels from `first`, in NumPy's order of operations: I/s per
    /// channel; α = (I/s · E/s) / ‖E/s‖²; CD² = ‖I/s‖² − (I/s · E/s)·α (the squared
    /// distance from α·E/s), clipped at 0.
    #[inline(always)]
    fn distortions<const N: usize>(&self, first: usize) -> ([f32; N], [f32; N]) {
        let group =
            |plane: &[f32]| -> [f32; N] { std::array::from_fn(|k| plane[first..first + N][k]) };
        let pixels = &self.image[3 * first..3 * (first + N)];
        let [s0, s1, s2] = self.inv_spread.map(group);
        let [e0, e1, e2] = self.scaled_mean.map(group);
        let norm2 = group(self.scaled_norm2);
        let mut alpha = [0.0f32; N];
        let mut cd = [0.0f32; N];
        for k in 0..N {
            let i0 = f32::from(pixels[3 * k]) * s0[k];
            let i1 = f32::from(pixels[3 * k + 1]) * s1[k];
            let i2 = f32::from(pixels[3 * k + 2]) * s2[k];
            let dot = i0 * e0[k] + i1 * e1[k] + i2 * e2[k];
            alpha[k] = dot / norm2[k];
            let cd2 = i0 * i0 + i1 * i1 + i2 * i2 - dot * alpha[k];
            cd[k] = cd2.max(0.0).sqrt();
        }
        (alpha, cd)
    }
}

/// The model's number of pixels, once every plane and the image agree on it.
fn check(image: &[u8], planes: &BackgroundPlanes<'_>) -> Result<usize, RasterError> {
    let n = planes.scaled_norm2.len();
    let named = [
        ("1/s", &planes.inv_spread[..]),
        ("E/s", &planes.scaled_mean[..]),
        ("the spread of CD", &[planes.inv_cd_spread][..]),
    ];
    for (what, group) in named {
        if let Some(plane) = group.iter().find(|plane| plane.len() != n) {
            return Err(RasterError::BackgroundSize {
                what,
                len: plane.len(),
                pixels: n,
            });
        }
    }
    if image.len() != 3 * n {
        return Err(RasterError::BackgroundSize {
            what: "the image (three values a pixel)",
            len: image.len(),
            pixels: n,
        });
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model of one grey background level `e` with spread `s` everywhere, `n` pixels.
    struct Uniform {
        inv_s: Vec<f32>,
        es: Vec<f32>,
        es2: Vec<f32>,
        inv_b: Vec<f32>,
    }

    impl Uniform {
        fn new(e: f32, s: f32, n: usize) -> Self {
            Uniform {
                inv_s: vec![1.0 / s; n],
                es: vec![e / s; n],
                es2: vec![3.0 * (e / s) * (e / s); n],
                inv_b: vec![1.0 / std::f32::consts::SQRT_2; n],
            }
        }

        fn planes(&self) -> BackgroundPlanes<'_> {
            BackgroundPlanes {
                inv_spread: [&self.inv_s, &self.inv_s, &self.inv_s],
                scaled_mean: [&self.es, &self.es, &self.es],
                scaled_norm2: &self.es2,
                inv_cd_spread: &self.inv_b,
            }
        }
    }

    const RULE: EvidenceRule = EvidenceRule {
        chromaticity: 3.0,
        darkest_shadow: 0.45,
        brightest_highlight: 1.35,
        foreground: 6.0,
    };

    #[test]
    fn the_background_itself_is_background_and_a_shadow_too() {
        let model = Uniform::new(100.0, 2.5, 4);
        let image = [100, 100, 100, 60, 60, 60, 100, 100, 100, 100, 100, 100];
        let ev = background_evidence(&image, &model.planes(), &RULE, Some(1)).unwrap();
        // The same colour: CD 0; a darker grey of the same hue (α = 0.6): CD 0 too.
        assert_eq!(ev, vec![-3.0; 4]);
        let (alpha, cd) = background_distortions(&image, &model.planes(), Some(1)).unwrap();
        assert!(
            (alpha[1] - 0.6).abs() < 1e-6 && cd[1].abs() < 1e-3,
            "{alpha:?} {cd:?}"
        );
    }

    #[test]
    fn another_hue_or_a_colour_far_darker_is_foreground() {
        let model = Uniform::new(100.0, 2.5, 3);
        // A red at the same brightness: far from the grey line; black: α 0 < 0.45.
        let image = [60, 60, 180, 0, 0, 0, 200, 200, 200];
        let ev = background_evidence(&image, &model.planes(), &RULE, Some(1)).unwrap();
        // I/s = (24, 24, 72), E/s = 40 each: α = 1, CD² = 24² + 24² + 72² − 120²/3.
        let cd = (24.0f32 * 24.0 + 24.0 * 24.0 + 72.0 * 72.0 - 120.0 * 120.0 / 3.0).sqrt();
        assert!(
            (ev[0] - (cd / std::f32::consts::SQRT_2 - 3.0)).abs() < 1e-4,
            "{ev:?}"
        );
        assert_eq!(&ev[1..], &[6.0, 6.0]); // black, and white (α = 2 > 1.35)
    }

    #[test]
    fn threads_change_nothing() {
        let n = 3 * MIN_CHUNK + 17;
        let model = Uniform::new(90.0, 2.5, n);
        let image: Vec<u8> = (0..3 * n).map(|i| (i * 37 % 251) as u8).collect();
        let one = background_evidence(&image, &model.planes(), &RULE, Some(1)).unwrap();
        for threads in [2, 3, 5] {
            let many = background_evidence(&image, &model.planes(), &RULE, Some(threads)).unwrap();
            assert_eq!(one, many, "{threads} threads");
        }
    }

    #[test]
    fn planes_and_images_of_other_sizes_are_refused() {
        let model = Uniform::new(100.0, 2.5, 4);
        let short = vec![0.5f32; 3];
        let mut planes = model.planes();
        planes.scaled_mean[1] = &short;
        let err = background_evidence(&[0; 12], &planes, &RULE, None).unwrap_err();
        assert!(err.to_string().contains("E/s"), "{err}");
        let err = background_distortions(&[0; 11], &model.planes(), None).unwrap_err();
        assert!(err.to_string().contains("image"), "{err}");
    }
}
