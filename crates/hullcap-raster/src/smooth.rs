//! A 3-D Gaussian blur of a mostly empty voxel grid, one axis after the other, skipping
//! the rows that only zeros reach.

use crate::RasterError;
use hullcap_core::{for_each_chunk_mut, resolve_threads};

/// The grid `values` (row-major, shape `shape`, the last axis fastest) convolved with a
/// Gaussian of `sigma` voxels cut at 3σ (radius `⌊3σ + ½⌋`, weights summing to 1),
/// zero beyond the grid: what SciPy's `gaussian_filter(..., mode="constant",
/// truncate=3.0)` computes, in single precision. A value is exactly 0 where no non-zero
/// value lies within the kernel's reach (a box of the radius on every axis).
///
/// Work is proportional to the rows (along the last axis) that some non-zero value
/// reaches, so the empty room around a visual hull costs almost nothing.
///
/// # Errors
/// [`RasterError::FieldSize`] when `values` does not hold `shape`'s values;
/// [`RasterError::BadSigma`] unless `sigma` is finite and positive (and at most 100).
pub fn gaussian_blur(
    values: &[u8],
    shape: [usize; 3],
    sigma: f64,
    threads: Option<usize>,
) -> Result<Vec<f32>, RasterError> {
    let [nx, ny, nz] = shape;
    if nx.checked_mul(ny).and_then(|p| p.checked_mul(nz)) != Some(values.len()) {
        return Err(RasterError::FieldSize {
            len: values.len(),
            shape,
        });
    }
    if !(sigma > 0.0 && sigma <= 100.0) {
        return Err(RasterError::BadSigma(sigma));
    }
    let blur = Blur {
        values,
        shape,
        kernel: kernel(sigma),
    };
    let mut out = vec![0.0f32; values.len()];
    if out.is_empty() {
        return Ok(out);
    }
    // Each thread blurs a run of slices (constant first index) along the last two axes
    // into a ring of slices, then along the first axis into its output slices.
    let mut slices: Vec<&mut [f32]> = out.chunks_mut(ny * nz).collect();
    for_each_chunk_mut(&mut slices, resolve_threads(threads), 8, |first, run| {
        let mut ring = Ring::new(&blur);
        for (offset, slice) in run.iter_mut().enumerate() {
            blur.along_x(first + offset, &mut ring, slice);
        }
    })?;
    Ok(out)
}

/// The grid and the weights.
struct Blur<'a> {
    values: &'a [u8],
    shape: [usize; 3],
    kernel: Vec<f32>,
}

/// The slices blurred along the last two axes that the current output slice reads: slice
/// `s` sits at `s mod (2·radius + 1)`, with, per row, whether any non-zero value reached it.
struct Ring {
    slices: Vec<(usize, Vec<f32>, Vec<bool>)>,
}

impl Ring {
    fn new(blur: &Blur<'_>) -> Self {
        let [_, ny, nz] = blur.shape;
        let slice = (usize::MAX, vec![0.0; ny * nz], vec![false; ny]);
        Self {
            slices: vec![slice; blur.kernel.len()],
        }
    }
}

impl Blur<'_> {
    fn radius(&self) -> usize {
        self.kernel.len() / 2
    }

    /// Output slice `i`: the ring's slices i − radius … i + radius, weighted.
    fn along_x(&self, i: usize, ring: &mut Ring, out: &mut [f32]) {
        let [nx, ny, nz] = self.shape;
        let radius = self.radius();
        let sources: Vec<(f32, usize)> = (0..self.kernel.len())
            .filter_map(|t| {
                let s = (i + t).checked_sub(radius).filter(|&s| s < nx)?;
                Some((self.kernel[t], s))
            })
            .collect();
        for &(_, s) in &sources {
            let slot = s % ring.slices.len();
            if ring.slices[slot].0 != s {
                let (index, blurred, reached) = &mut ring.slices[slot];
                self.along_zy(s, blurred, reached);
                *index = s;
            }
        }
        for j in 0..ny {
            let row = &mut out[j * nz..(j + 1) * nz];
            for &(w, s) in &sources {
                let (_, blurred, reached) = &ring.slices[s % ring.slices.len()];
                if reached[j] {
                    add_row(row, w, &blurred[j * nz..(j + 1) * nz]);
                }
            }
        }
    }

    /// Slice `s` of the values blurred along the last axis and then the middle one into
    /// `out` (every row written), with `reached[j]` false where row j is all zeros.
    fn along_zy(&self, s: usize, out: &mut [f32], reached: &mut [bool]) {
        let [_, ny, nz] = self.shape;
        let radius = self.radius();
        let values = &self.values[s * ny * nz..(s + 1) * ny * nz];
        let has: Vec<bool> = values
            .chunks(nz)
            .map(|r| r.iter().any(|&v| v != 0))
            .collect();
        let mut along_z = vec![0.0f32; ny * nz];
        for (j, row) in along_z.chunks_mut(nz).enumerate().filter(|&(j, _)| has[j]) {
            let source = &values[j * nz..(j + 1) * nz];
            for (t, &w) in self.kernel.iter().enumerate() {
                for (k, o) in shifted(nz, t, radius) {
                    row[o] += w * f32::from(source[k]);
                }
            }
        }
        out.fill(0.0);
        for j in 0..ny {
            reached[j] = false;
            for (t, &w) in self.kernel.iter().enumerate() {
                let Some(y) = (j + t).checked_sub(radius).filter(|&y| y < ny && has[y]) else {
                    continue;
                };
                add_row(
                    &mut out[j * nz..(j + 1) * nz],
                    w,
                    &along_z[y * nz..(y + 1) * nz],
                );
                reached[j] = true;
            }
        }
    }
}

/// The normalised Gaussian weights, radius `⌊3σ + ½⌋`.
fn kernel(sigma: f64) -> Vec<f32> {
    let radius = (3.0 * sigma + 0.5) as i64;
    let raw: Vec<f64> = (-radius..=radius)
        .map(|x| (-0.5 * (x as f64 / sigma).powi(2)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / sum) as f32).collect()
}

/// Pairs (source index, output index) of a row of `n` for kernel tap `t` of radius
/// `radius`: output k reads source k + t − radius where that is inside the row.
fn shifted(n: usize, t: usize, radius: usize) -> impl Iterator<Item = (usize, usize)> {
    let lo = radius.saturating_sub(t);
    let hi = (n + radius).saturating_sub(t).min(n);
    (lo..hi).map(move |k| (k + t - radius, k))
}

/// `out += w · row`.
fn add_row(out: &mut [f32], w: f32, row: &[f32]) {
    for (o, &v) in out.iter_mut().zip(row) {
        *o += w * v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The direct triple sum, in double precision.
    fn brute(values: &[u8], shape: [usize; 3], sigma: f64) -> Vec<f64> {
        let k = kernel(sigma);
        let r = (k.len() / 2) as i64;
        let [nx, ny, nz] = shape.map(|n| n as i64);
        let mut out = vec![0.0; values.len()];
        for i in 0..nx {
            for j in 0..ny {
                for l in 0..nz {
                    let mut sum = 0.0;
                    for a in -r..=r {
                        for b in -r..=r {
                            for c in -r..=r {
                                let (x, y, z) = (i + a, j + b, l + c);
                                if (0..nx).contains(&x)
                                    && (0..ny).contains(&y)
                                    && (0..nz).contains(&z)
                                {
                                    let v = values[((x * ny + y) * nz + z) as usize];
                                    sum += f64::from(k[(a + r) as usize])
                                        * f64::from(k[(b + r) as usize])
                                        * f64::from(k[(c + r) as usize])
                                        * f64::from(v);
                                }
                            }
                        }
                    }
                    out[((i * ny + j) * nz + l) as usize] = sum;
                }
            }
        }
        out
    }

    #[test]
    fn the_blur_is_the_direct_sum_with_zeros_where_nothing_reaches() {
        let shape = [9, 11, 13];
        let mut state = 12345u64;
        let values: Vec<u8> = (0..9 * 11 * 13)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                u8::from(state >> 60 == 0) // about one voxel in sixteen
            })
            .collect();
        for sigma in [0.3, 0.7, 1.2] {
            for threads in [1, 3] {
                let got = gaussian_blur(&values, shape, sigma, Some(threads)).unwrap();
                let want = brute(&values, shape, sigma);
                for (g, w) in got.iter().zip(&want) {
                    assert!((f64::from(*g) - w).abs() < 1e-6, "{g} vs {w}");
                    assert_eq!(*g == 0.0, *w == 0.0);
                }
            }
        }
        assert!(matches!(
            gaussian_blur(&values, shape, 0.0, None),
            Err(RasterError::BadSigma(_))
        ));
        assert!(gaussian_blur(&values[1..], shape, 0.7, None).is_err());
    }
}
