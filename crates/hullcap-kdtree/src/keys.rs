//! Turning points with normals into 6-D keys, with the validation every input goes through.

use crate::KdTreeError;

/// A 6-D key: (x, y, z, λ·nx, λ·ny, λ·nz).
pub(crate) type Key = [f64; 6];

/// The paper's default λ: the normal's deviation range (0…π) balanced against the size of
/// the cloud, i.e. λ·π = the diagonal of the points' axis-aligned bounding box.
///
/// A cloud of a single point (or of coincident points) has no size; λ is then 1 m.
pub fn default_normal_weight(points: &[[f64; 3]]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    let diagonal = (0..3).map(|d| (hi[d] - lo[d]).powi(2)).sum::<f64>().sqrt();
    if diagonal.is_finite() && diagonal > 0.0 {
        diagonal / std::f64::consts::PI
    } else {
        1.0
    }
}

/// Checks that `points` and `normals` pair up, are finite, and that no normal is too short
/// to normalise; `names` are the arrays' names for the error.
pub(crate) fn validate(
    points: &[[f64; 3]],
    normals: &[[f64; 3]],
    names: (&'static str, &'static str),
) -> Result<(), KdTreeError> {
    if normals.len() != points.len() {
        return Err(KdTreeError::LengthMismatch {
            array: names.1,
            got: normals.len(),
            expected_from: names.0,
            expected: points.len(),
        });
    }
    if let Some(row) = points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(KdTreeError::NotFinite {
            array: names.0,
            row,
        });
    }
    match normals.iter().position(|n| unit(n).is_none()) {
        Some(row) => Err(normal_error(&normals[row], names.1, row)),
        None => Ok(()),
    }
}

fn normal_error(n: &[f64; 3], array: &'static str, row: usize) -> KdTreeError {
    if n.iter().all(|x| x.is_finite()) {
        KdTreeError::ZeroNormal { array, row }
    } else {
        KdTreeError::NotFinite { array, row }
    }
}

/// `n / |n|`, or `None` when `n` is not finite or zero.
pub(crate) fn unit(n: &[f64; 3]) -> Option<[f64; 3]> {
    let length = |n: &[f64; 3]| (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let len = length(n);
    if len.is_finite() && len > f64::MIN_POSITIVE.sqrt() {
        return Some(n.map(|x| x / len));
    }
    // Its squares overflow or underflow: scaled by its largest component first.
    let largest = n.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(n.iter().all(|x| x.is_finite()) && largest > 0.0) {
        return None;
    }
    let scaled = n.map(|x| x / largest);
    let len = length(&scaled);
    Some(scaled.map(|x| x / len))
}

/// The key of `point` with `normal` rescaled to unit length (checked by [`validate`]).
#[inline]
pub(crate) fn key(point: &[f64; 3], normal: &[f64; 3], lambda: f64) -> Key {
    let n = unit(normal).unwrap_or([0.0; 3]);
    [
        point[0],
        point[1],
        point[2],
        lambda * n[0],
        lambda * n[1],
        lambda * n[2],
    ]
}

/// Squared Euclidean distance between two keys.
#[inline(always)]
pub(crate) fn dist2(a: &Key, b: &Key) -> f64 {
    let mut s = 0.0;
    for d in 0..6 {
        let t = a[d] - b[d];
        s += t * t;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_weight_balances_pi_against_the_diagonal() {
        let pts = [[0.0, 0.0, 0.0], [3.0, 4.0, 0.0], [1.0, 1.0, 0.0]];
        assert!((default_normal_weight(&pts) * std::f64::consts::PI - 5.0).abs() < 1e-12);
        assert_eq!(default_normal_weight(&[[2.0, 2.0, 2.0]]), 1.0);
    }

    #[test]
    fn validation_names_the_array_and_row() {
        let p = [[0.0; 3], [0.0, f64::NAN, 0.0]];
        let n = [[1.0, 0.0, 0.0]; 2];
        assert_eq!(
            validate(&p, &n, ("points", "normals")),
            Err(KdTreeError::NotFinite {
                array: "points",
                row: 1
            })
        );
        let p = [[0.0; 3]; 2];
        let n = [[1.0, 0.0, 0.0], [0.0; 3]];
        assert_eq!(
            validate(&p, &n, ("points", "normals")),
            Err(KdTreeError::ZeroNormal {
                array: "normals",
                row: 1
            })
        );
        let n = [[1.0, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0]];
        assert_eq!(
            validate(&p, &n, ("points", "normals")),
            Err(KdTreeError::NotFinite {
                array: "normals",
                row: 1
            })
        );
        assert!(matches!(
            validate(&p, &n[..1], ("points", "normals")),
            Err(KdTreeError::LengthMismatch {
                got: 1,
                expected: 2,
                ..
            })
        ));
        assert_eq!(validate(&p, &[[3.0, 4.0, 0.0]; 2], ("p", "n")), Ok(()));
        assert_eq!(
            key(&[1.0, 2.0, 3.0], &[3.0, 4.0, 0.0], 2.0),
            [1.0, 2.0, 3.0, 1.2, 1.6, 0.0]
        );
    }

    #[test]
    fn a_normal_of_any_finite_non_zero_length_is_a_direction() {
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|d| (a[d] - b[d]).abs() < 1e-15);
        for scale in [1.0, 1e300, f64::MAX / 8.0, 1e-160, 1e-300, 5e-324] {
            let n = unit(&[3.0 * scale, -4.0 * scale, 0.0]).expect("a direction");
            assert!(close(n, [0.6, -0.8, 0.0]), "{scale:e}: {n:?}");
        }
        for bad in [[0.0; 3], [f64::NAN, 1.0, 0.0], [1.0, f64::INFINITY, 0.0]] {
            assert_eq!(unit(&bad), None, "{bad:?}");
        }
    }
}
