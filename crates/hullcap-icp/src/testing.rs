//! A test body: a tube around a three-link chain along +x, skinned across its joints.

use crate::{Params, Target};
use hullcap_body::{Rig, RootPose, SkinWeights};
use nalgebra::{Rotation3, Vector3};

/// The tube's rig on the test chain (links at x = 0, 1, 2).
pub(crate) fn tube() -> Rig {
    let skeleton = hullcap_body::testing::chain();
    let (mut v, mut n, mut index, mut weight) = (vec![], vec![], vec![], vec![]);
    for s in 0..=60 {
        let x = s as f64 * 0.05;
        // Weight of the further link rises smoothly over ±0.15 around each joint.
        let j = ((x + 0.5) as u32).clamp(1, 2) - 1;
        let blend = ((x - (j + 1) as f64) / 0.3 + 0.5).clamp(0.0, 1.0);
        for a in 0..16 {
            let phi = a as f64 * std::f64::consts::TAU / 16.0 + 0.1 * s as f64;
            let (c, sn) = (phi.cos(), phi.sin());
            // An elliptic cross-section whose radii vary along the tube, so that neither
            // turning about nor sliding along its axis leaves the surface in place.
            let (ry, dry) = (
                0.25 * (1.0 + 0.3 * (3.0 * x).sin()),
                0.25 * 0.9 * (3.0 * x).cos(),
            );
            let (rz, drz) = (
                0.15 * (1.0 + 0.3 * (2.0 * x).cos()),
                -0.15 * 0.6 * (2.0 * x).sin(),
            );
            v.push([x, ry * c, rz * sn]);
            let nn =
                Vector3::new(-(dry * rz * c * c + drz * ry * sn * sn), rz * c, ry * sn).normalize();
            n.push(nn.into());
            index.extend([j, j + 1]);
            weight.extend([1.0 - blend, blend]);
        }
    }
    Rig::new(
        skeleton,
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

/// A root pose from a rotation vector and a translation.
pub(crate) fn root(omega: [f64; 3], t: [f64; 3]) -> RootPose {
    RootPose {
        rotation: Rotation3::new(Vector3::from(omega)).into_inner(),
        translation: Vector3::from(t),
    }
}

/// The rig posed at `truth`, as a target.
pub(crate) fn target_at(rig: &Rig, truth: &Params) -> Target {
    let posed = rig.pose(&truth.theta, &truth.root, None).unwrap();
    Target::new(&posed.vertices, &posed.normals, None).unwrap()
}
