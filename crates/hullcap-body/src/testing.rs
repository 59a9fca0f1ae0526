//! Small bodies for tests, shared with the crates that build on this one (enable the
//! `testing` feature).

use crate::{Dof, Rig, ShapeParameter, Skeleton, SkinWeights};
use nalgebra::{Matrix3, Vector3};

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

/// `samples` points scattered around [`chain`] every `spacing` along x, each blended over
/// the link it lies on and the next (`first` + up to 0.4 of the weight on its own), with
/// normals pointing away from the chain's axis.
#[allow(clippy::unwrap_used)] // valid by construction
pub fn blended_rig(samples: usize, spacing: f64, first: f64) -> Rig {
    let (mut v, mut n, mut index, mut weight) = (vec![], vec![], vec![], vec![]);
    for s in 0..samples {
        let (x, a) = (s as f64 * spacing, s as f64);
        v.push([x, 0.2 * a.sin(), 0.2 * a.cos()]);
        n.push([0.1, a.sin(), a.cos()]);
        let j = (x as u32).min(2);
        let other = if j == 2 { 1 } else { j + 1 };
        let w = first + 0.4 * x.fract();
        index.extend([j, other]);
        weight.extend([w, 1.0 - w]);
    }
    Rig::new(
        chain(),
        &v,
        &n,
        SkinWeights {
            k: 2,
            index,
            weight,
        },
    )
    .unwrap()
}

/// Shape parameters of [`chain`]: link 1's length (along x), link 2's girth (across x),
/// a shift of link 2's joint by `shift`, and a move of link `centre.0`'s centre by
/// `centre.1`.
pub fn chain_shape_parameters(shift: [f64; 3], centre: (usize, [f64; 3])) -> Vec<ShapeParameter> {
    let along = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    vec![
        ShapeParameter {
            stretches: vec![(1, along)],
            ..ShapeParameter::default()
        },
        ShapeParameter {
            stretches: vec![(2, Matrix3::identity() - along)],
            ..ShapeParameter::default()
        },
        ShapeParameter {
            shifts: vec![(2, Vector3::from(shift))],
            ..ShapeParameter::default()
        },
        ShapeParameter {
            centres: vec![(centre.0, Vector3::from(centre.1))],
            ..ShapeParameter::default()
        },
    ]
}
