//! The damped Gauss–Newton (Levenberg–Marquardt) step shared by the pose fit and the
//! shape fit.

use crate::IcpError;
use nalgebra::{DMatrix, DVector};

/// Tries steps δ solving (H + λ·diag(H))·δ = −g with growing damping λ until `try_step`
/// gives an energy below `e0`; returns what `try_step` made of the accepted step and its
/// energy, or `None` when no step lowers the energy. `damping` carries λ from one
/// iteration to the next (shrunk after a success, grown after each failure).
pub(crate) fn levenberg_marquardt<T>(
    h: &DMatrix<f64>,
    g: &DVector<f64>,
    e0: f64,
    damping: &mut f64,
    mut try_step: impl FnMut(&DVector<f64>) -> Result<(T, f64), IcpError>,
) -> Result<Option<(T, f64)>, IcpError> {
    let n = g.len();
    for _ in 0..8 {
        let mut a = h.clone();
        for k in 0..n {
            a[(k, k)] += *damping * h[(k, k)].max(1e-9) + 1e-12;
        }
        let Some(delta) = a.cholesky().map(|c| c.solve(&(-g))) else {
            *damping *= 10.0;
            continue;
        };
        let (candidate, e1) = try_step(&delta)?;
        if e1 < e0 {
            *damping = (*damping / 3.0).max(1e-9);
            return Ok(Some((candidate, e1)));
        }
        *damping *= 4.0;
    }
    Ok(None)
}
