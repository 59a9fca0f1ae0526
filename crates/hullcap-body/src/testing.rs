//! Small bodies for tests, shared with the crates that build on this one (enable the
//! `testing` feature).

use crate::{Dof, Skeleton};
use nalgebra::Vector3;

/// A three-link chain along +x: base at the origin, joints at x = 1 and x = 2; link 1
/// turns about z then y, link 2 about z; limits ±2 rad.
#[allow(clippy::unwrap_used)] // a fixed, valid skeleton
pub fn chain() -> Skeleton {
    let dof = |link, axis: [f64; 3]| Dof {
        link,
        axis: Vector3::from(axis),
        lower: -2.0,
        upper: 2.0,
    };
    Skeleton::new(
        &[-1, 0, 1],
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        vec![
            dof(1, [0.0, 0.0, 1.0]),
            dof(1, [0.0, 1.0, 0.0]),
            dof(2, [0.0, 0.0, 1.0]),
        ],
    )
    .unwrap()
}
