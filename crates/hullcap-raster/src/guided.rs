//! The log-odds of the model-guided silhouettes (`hullcap._guided`): the background
//! test's evidence, the predicted model's prior and the subject's colours summed per pixel
//! of the window around the predicted person, in one pass.
//!
//! In NumPy the same sum took eight passes over the window and as many temporaries (the
//! evidence clipped, split by sign, the prior scaled, each pixel's colour bin built from
//! three channels, its log-ratio looked up through a cast of the bins to 64-bit indices);
//! here it is one pass. The arithmetic is NumPy's, in the same order and in single
//! precision, so the sums are the same to the bit.

use crate::RasterError;

/// How the terms of [`guided_logit`] are weighed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogitWeights {
    /// The evidence is clipped into `[evidence_min, evidence_max]` first.
    pub evidence_min: f32,
    /// See `evidence_min`.
    pub evidence_max: f32,
    /// The factor of negative (background) evidence; positive evidence counts as it is.
    pub background: f32,
    /// The factor of the prior's ramp.
    pub prior: f32,
    /// The factor of the colour log-ratio, clipped into `±colour_limit` first.
    pub colour: f32,
    /// See `colour`.
    pub colour_limit: f32,
}

/// The subject's colours against the background's: `log_ratio[(b·bins + g)·bins + r]` for
/// the bins (`bins` a channel, a channel value `v` in bin `v·bins / 256`) of a pixel's three
/// channels in the image's order.
#[derive(Debug, Clone, Copy)]
pub struct ColourTable<'a> {
    /// One value per colour bin, `bins³` of them.
    pub log_ratio: &'a [f32],
    /// Bins a channel (1 to 256).
    pub bins: usize,
}

/// The window of an image that [`guided_logit`] reads: rows `top..top + height`, columns
/// `left..left + width` of an image `image_width` pixels wide.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// Its first row.
    pub top: usize,
    /// Its first column.
    pub left: usize,
    /// Its rows.
    pub height: usize,
    /// Its columns.
    pub width: usize,
}

/// Per pixel of `window` (row-major, `window.height · window.width` values):
///
/// `e' + prior·ramp + colour·clip(log_ratio(pixel), ±colour_limit)`,
///
/// where `e` is the background test's `evidence` clipped into the weights' bounds and
/// `e' = e` where it is positive, `background·e` elsewhere. `evidence` (one value a pixel)
/// and `image` (three channels a pixel) cover the whole image, `image_width` pixels wide;
/// `ramp` covers the window alone; without `colours` the colour term is left out.
///
/// # Errors
/// [`RasterError::BadGuidedInput`] when the window does not lie inside the image, an array
/// does not hold the values it should (`evidence` a multiple of `image_width` values,
/// `image` three times as many, `ramp` one a pixel of the window, the colour table `bins³`),
/// or a bound of the weights is NaN or the evidence's lower bound exceeds its upper.
pub fn guided_logit(
    evidence: &[f32],
    image: &[u8],
    image_width: usize,
    window: Window,
    ramp: &[f32],
    colours: Option<ColourTable<'_>>,
    weights: &LogitWeights,
) -> Result<Vec<f32>, RasterError> {
    weights.check()?;
    if let Some(c) = colours {
        c.check()?;
    }
    window.check(evidence, image, image_width, ramp)?;
    // Each channel's value to its share of the colour's index: bin·bins² for the first.
    let luts = colours.map(|c| {
        let n = c.bins as u32;
        let bin = |v: usize| ((v * c.bins) >> 8) as u32;
        [
            std::array::from_fn::<u32, 256, _>(|v| bin(v) * n * n),
            std::array::from_fn(|v| bin(v) * n),
            std::array::from_fn(bin),
        ]
    });
    let mut out = vec![0.0f32; window.height * window.width];
    for (row, logits) in out.chunks_exact_mut(window.width.max(1)).enumerate() {
        let first = (window.top + row) * image_width + window.left;
        let evidence = &evidence[first..first + window.width];
        let ramp = &ramp[row * window.width..(row + 1) * window.width];
        // The arithmetic first, a pass the compiler vectorises; then the colours, whose
        // table lookups it cannot.
        for ((logit, &e), &r) in logits.iter_mut().zip(evidence).zip(ramp) {
            let e = e.clamp(weights.evidence_min, weights.evidence_max);
            let e = if e > 0.0 { e } else { weights.background * e };
            *logit = e + weights.prior * r;
        }
        if let (Some(c), Some([l0, l1, l2])) = (colours, &luts) {
            let pixels = &image[3 * first..3 * (first + window.width)];
            for (logit, pixel) in logits.iter_mut().zip(pixels.chunks_exact(3)) {
                let k = l0[usize::from(pixel[0])]
                    + l1[usize::from(pixel[1])]
                    + l2[usize::from(pixel[2])];
                let ratio =
                    c.log_ratio[k as usize].clamp(-weights.colour_limit, weights.colour_limit);
                *logit += weights.colour * ratio;
            }
        }
    }
    Ok(out)
}

fn bad<T>(what: String) -> Result<T, RasterError> {
    Err(RasterError::BadGuidedInput(what))
}

impl LogitWeights {
    /// An error unless the bounds are numbers in order.
    fn check(&self) -> Result<(), RasterError> {
        if !(self.evidence_min <= self.evidence_max && self.colour_limit >= 0.0) {
            return bad(format!(
                "the evidence's bounds {}..{} and the colour's ±{} are not in order",
                self.evidence_min, self.evidence_max, self.colour_limit
            ));
        }
        Ok(())
    }
}

impl ColourTable<'_> {
    /// An error unless the table holds `bins³` values for 1 to 256 bins.
    fn check(&self) -> Result<(), RasterError> {
        if !(1..=256).contains(&self.bins) || self.log_ratio.len() != self.bins.pow(3) {
            return bad(format!(
                "a colour table of {} values for {} bins a channel (1 to 256 bins, bins³ values)",
                self.log_ratio.len(),
                self.bins
            ));
        }
        Ok(())
    }
}

impl Window {
    /// An error unless `evidence` is rows of `image_width` values, `image` three for
    /// each of them, the window lies within those rows and `ramp` holds one value for
    /// each of its pixels.
    fn check(
        &self,
        evidence: &[f32],
        image: &[u8],
        image_width: usize,
        ramp: &[f32],
    ) -> Result<(), RasterError> {
        if image_width == 0 || !evidence.len().is_multiple_of(image_width) {
            return bad(format!(
                "evidence holds {} values, not rows of {image_width}",
                evidence.len()
            ));
        }
        let image_height = evidence.len() / image_width;
        if image.len() != 3 * evidence.len() {
            return bad(format!(
                "the image holds {} values, not three for each of the evidence's {}",
                image.len(),
                evidence.len()
            ));
        }
        let (bottom, right) = (
            self.top.saturating_add(self.height),
            self.left.saturating_add(self.width),
        );
        if bottom > image_height || right > image_width {
            return bad(format!(
                "rows {}..{bottom} and columns {}..{right} do not lie in a {image_width}×{image_height} image",
                self.top, self.left
            ));
        }
        if ramp.len() != self.height * self.width {
            return bad(format!(
                "the ramp holds {} values, not one for each of the window's {}×{} pixels",
                ramp.len(),
                self.width,
                self.height
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WEIGHTS: LogitWeights = LogitWeights {
        evidence_min: -3.0,
        evidence_max: 2.0,
        background: 0.3,
        prior: 2.0,
        colour: 1.0,
        colour_limit: 4.0,
    };

    /// The sum written out the plain way, pixel by pixel, for a 5×4 image (the clips
    /// as NumPy's: a maximum, then a minimum).
    #[allow(clippy::manual_clamp)]
    fn reference(
        evidence: &[f32],
        image: &[u8],
        window: Window,
        ramp: &[f32],
        table: Option<(&[f32], usize)>,
    ) -> Vec<f32> {
        let mut out = vec![];
        for y in window.top..window.top + window.height {
            for x in window.left..window.left + window.width {
                let i = y * 5 + x;
                let e = evidence[i].max(-3.0).min(2.0);
                let mut v = if e > 0.0 { e } else { 0.3 * e };
                v += 2.0 * ramp[(y - window.top) * window.width + x - window.left];
                if let Some((t, bins)) = table {
                    let q = |c: usize| image[3 * i + c] as usize * bins / 256;
                    v += t[(q(0) * bins + q(1)) * bins + q(2)].max(-4.0).min(4.0);
                }
                out.push(v);
            }
        }
        out
    }

    fn inputs() -> (Vec<f32>, Vec<u8>, Vec<f32>) {
        let evidence: Vec<f32> = (0..20).map(|i| (i as f32 - 9.0) * 0.45).collect();
        let image: Vec<u8> = (0..60).map(|i| ((i * 97 + 13) % 256) as u8).collect();
        let table: Vec<f32> = (0..64).map(|k| (k as f32 - 30.0) * 0.2).collect();
        (evidence, image, table)
    }

    #[test]
    fn sums_the_terms_of_each_pixel_of_the_window() {
        let (evidence, image, table) = inputs();
        let window = Window {
            top: 1,
            left: 1,
            height: 3,
            width: 3,
        };
        let ramp: Vec<f32> = (0..9).map(|i| i as f32 / 4.0 - 1.0).collect();
        for colours in [None, Some((&table[..], 4))] {
            let got = guided_logit(
                &evidence,
                &image,
                5,
                window,
                &ramp,
                colours.map(|(log_ratio, bins)| ColourTable { log_ratio, bins }),
                &WEIGHTS,
            )
            .unwrap();
            assert_eq!(got, reference(&evidence, &image, window, &ramp, colours));
        }
    }

    #[test]
    fn refuses_windows_and_arrays_that_do_not_fit() {
        let (evidence, image, table) = inputs();
        let ramp = vec![0.0; 4];
        let window = Window {
            top: 2,
            left: 3,
            height: 2,
            width: 2,
        };
        let call = |evidence: &[f32], image: &[u8], window, ramp: &[f32], table: &[f32], bins| {
            guided_logit(
                evidence,
                image,
                5,
                window,
                ramp,
                Some(ColourTable {
                    log_ratio: table,
                    bins,
                }),
                &WEIGHTS,
            )
        };
        assert!(call(&evidence, &image, window, &ramp, &table, 4).is_ok());
        let beyond = Window {
            top: 2,
            left: 4,
            height: 2,
            width: 2,
        };
        let overflowing = Window {
            top: usize::MAX,
            ..window
        };
        for result in [
            call(&evidence, &image, beyond, &ramp, &table, 4),
            call(&evidence, &image, overflowing, &ramp, &table, 4),
            call(&evidence[..19], &image, window, &ramp, &table, 4),
            call(&evidence, &image[..57], window, &ramp, &table, 4),
            call(&evidence, &image, window, &ramp[..3], &table, 4),
            call(&evidence, &image, window, &ramp, &table[..63], 4),
            call(&evidence, &image, window, &ramp, &table, 0),
        ] {
            assert!(
                matches!(result, Err(RasterError::BadGuidedInput(_))),
                "{result:?}"
            );
        }
        for weights in [
            LogitWeights {
                evidence_min: 1.0,
                evidence_max: -1.0,
                ..WEIGHTS
            },
            LogitWeights {
                evidence_max: f32::NAN,
                ..WEIGHTS
            },
            LogitWeights {
                colour_limit: -1.0,
                ..WEIGHTS
            },
        ] {
            let result = guided_logit(&evidence, &image, 5, window, &ramp, None, &weights);
            assert!(
                matches!(result, Err(RasterError::BadGuidedInput(_))),
                "{result:?}"
            );
        }
    }
}
