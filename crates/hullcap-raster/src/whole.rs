//! Rounding to whole numbers without libm: on baseline x86-64 (no SSE4.1) Rust's
//! `round_ties_even`, `floor` and `ceil` compile to calls of libm's `rint`, `floor` and
//! `ceil`, which the carving (twice per point and view) and the rasteriser (four times per
//! triangle) make often enough to show in a profile.

/// `x` rounded to the nearest integer, ties to even, as `f64::round_ties_even` does for
/// |x| < 2⁵¹ (beyond, the value is far outside any image anyway): adding and subtracting
/// 1.5·2⁵² leaves no fractional bits, so the addition rounds in the default mode (to
/// nearest, ties to even).
#[inline]
pub(crate) fn nearest(x: f64) -> f64 {
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
    (x + SHIFT) - SHIFT
}

/// The largest whole number not above `x`, as `f64::floor` for |x| < 2⁵¹ (up to the sign
/// of a zero).
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    let r = nearest(x);
    if r > x { r - 1.0 } else { r }
}

/// The smallest whole number not below `x`, as `f64::ceil` for |x| < 2⁵¹ (up to the sign
/// of a zero).
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    let r = nearest(x);
    if r < x { r + 1.0 } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Halves, quarters, numbers a hair off them, signed zeros and large values.
    fn values() -> Vec<f64> {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            1.5,
            2.5,
            -0.5,
            -1.5,
            -2.5,
            0.49999999999999994,
            1e15 + 0.5,
        ];
        values.extend((-4000..4000).map(|i| i as f64 * 0.25 + 0.001 * (i % 7) as f64));
        values.extend((0..1000).map(|i| (i as f64 * 0.7919).sin() * 1e6));
        values.extend([
            -0.3,
            0.3,
            1.0 - f64::EPSILON,
            -1.0 + f64::EPSILON / 2.0,
            7.0,
            -7.0,
        ]);
        values
    }

    #[test]
    fn nearest_rounds_like_round_ties_even() {
        for x in values() {
            assert_eq!(nearest(x), x.round_ties_even(), "x = {x}");
        }
    }

    #[test]
    fn floor_and_ceil_agree_with_the_standard_ones() {
        for x in values() {
            // `==` holds for 0.0 and −0.0 alike; only the sign of a zero may differ.
            assert!(
                floor(x) == x.floor(),
                "floor {x}: {} against {}",
                floor(x),
                x.floor()
            );
            assert!(
                ceil(x) == x.ceil(),
                "ceil {x}: {} against {}",
                ceil(x),
                x.ceil()
            );
        }
    }
}
