"""Scripted motions of the body model for synthetic sequences (docs/design.md §11).

A motion is a list of keyframes ``(seconds, joint angles in degrees by DOF name, root
offset in metres, root yaw in degrees)``; poses between keyframes follow a smooth
(cosine) ease, so velocities are zero at each keyframe. Every motion starts in the
calibration pose (the rest T-pose) for a moment, as a real take would.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hullcap.errors import OptionsError

__all__ = ["MOTIONS", "motion_poses"]


@dataclass(frozen=True)
class Key:
    seconds: float
    angles: dict
    offset: tuple = (0.0, 0.0, 0.0)
    yaw: float = 0.0


def _both(name: str, value: float) -> dict:
    return {f"l_{name}": value, f"r_{name}": value}


ARMS_DOWN = {**_both("shoulder_abduction", -75), **_both("elbow_flexion", 15)}
CALIBRATION = [Key(0.0, {}), Key(0.3, {})]

MOTIONS: dict[str, list[Key]] = {
    "arm_swing": CALIBRATION + [
        Key(0.5, ARMS_DOWN),
        Key(0.5, {**ARMS_DOWN, "l_shoulder_flexion": 60, "r_shoulder_flexion": -30, "l_elbow_flexion": 40}),
        Key(0.5, {**ARMS_DOWN, "l_shoulder_flexion": -30, "r_shoulder_flexion": 60, "r_elbow_flexion": 40}),
        Key(0.5, {**ARMS_DOWN, "l_shoulder_flexion": 40, "r_shoulder_flexion": 40, **_both("elbow_flexion", 70)}),
    ],
    "twist": CALIBRATION + [
        Key(0.5, {**ARMS_DOWN, **_both("shoulder_abduction", -45)}),
        Key(0.6, {**_both("shoulder_abduction", -45), "waist_twist": 40, "neck_twist": 20, "waist_flexion": 10}),
        Key(0.7, {**_both("shoulder_abduction", -45), "waist_twist": -40, "neck_twist": -20, "waist_lateral": 15}),
        Key(0.5, {**_both("shoulder_abduction", -45)}),
    ],
    "squat": CALIBRATION + [
        Key(0.4, {**_both("shoulder_abduction", -10), **_both("shoulder_flexion", 70)}),
        Key(0.7, {**_both("shoulder_abduction", -10), **_both("shoulder_flexion", 80), **_both("hip_flexion", 85),
                  **_both("knee_flexion", 110), **_both("ankle_flexion", 25), "waist_flexion": 25},
            offset=(0.0, 0.12, -0.36)),
        Key(0.6, {**_both("shoulder_abduction", -10), **_both("shoulder_flexion", 70)}),
    ],
    "jump": CALIBRATION + [
        Key(0.4, {**_both("hip_flexion", 40), **_both("knee_flexion", 70), **_both("ankle_flexion", 20),
                  "waist_flexion": 15, **_both("shoulder_abduction", -70)}, offset=(0.0, 0.05, -0.15)),
        Key(0.3, {**_both("shoulder_abduction", 60), **_both("ankle_flexion", -30), **_both("clavicle_elevation", 20)},
            offset=(0.0, 0.0, 0.25)),
        Key(0.3, {**_both("hip_flexion", 30), **_both("knee_flexion", 50), **_both("ankle_flexion", 15),
                  **_both("shoulder_abduction", 20)}, offset=(0.0, 0.0, -0.1)),
        Key(0.4, {}),
    ],
    "kick": CALIBRATION + [
        Key(0.4, {**_both("shoulder_abduction", -50), "r_hip_abduction": 5}),
        Key(0.3, {**_both("shoulder_abduction", -50), "l_hip_flexion": -20, "l_knee_flexion": 80}),
        Key(0.3, {**_both("shoulder_abduction", -50), "l_hip_flexion": 75, "l_knee_flexion": 5,
                  "waist_flexion": -10, "l_ankle_flexion": -20}),
        Key(0.5, {**_both("shoulder_abduction", -50)}),
    ],
    "walk_turn": CALIBRATION + [
        Key(0.5, {**ARMS_DOWN, "l_hip_flexion": 25, "r_hip_flexion": -15, "r_knee_flexion": 30,
                  "l_shoulder_flexion": -20, "r_shoulder_flexion": 20}, offset=(0.0, -0.25, 0.0), yaw=20),
        Key(0.5, {**ARMS_DOWN, "r_hip_flexion": 25, "l_hip_flexion": -15, "l_knee_flexion": 30,
                  "r_shoulder_flexion": -20, "l_shoulder_flexion": 20}, offset=(0.15, -0.5, 0.0), yaw=50),
        Key(0.5, {**ARMS_DOWN}, offset=(0.3, -0.6, 0.0), yaw=90),
    ],
}
# A compact tour of everything, used by the demo and the tests.
MOTIONS["demo"] = CALIBRATION + [
    Key(0.4, ARMS_DOWN),
    Key(0.4, {**ARMS_DOWN, "l_shoulder_flexion": 60, "r_shoulder_flexion": -20, "l_elbow_flexion": 50}),
    Key(0.5, {**_both("shoulder_abduction", -45), "waist_twist": 35, "neck_twist": 15}),
    Key(0.5, {**_both("shoulder_abduction", -10), **_both("shoulder_flexion", 70), **_both("hip_flexion", 70),
              **_both("knee_flexion", 90), **_both("ankle_flexion", 20), "waist_flexion": 20},
        offset=(0.0, 0.1, -0.27)),
    Key(0.3, {**_both("shoulder_abduction", 60), **_both("ankle_flexion", -25)}, offset=(0.0, 0.0, 0.15)),
    Key(0.4, {**_both("shoulder_abduction", -50), "l_hip_flexion": 60, "l_knee_flexion": 30}),
    Key(0.3, {**_both("shoulder_abduction", -50)}),
]
MOTIONS["all"] = CALIBRATION + [k for name in ("arm_swing", "twist", "squat", "jump", "kick", "walk_turn")
                                for k in MOTIONS[name][2:]]


def motion_poses(name: str, dof_names, fps: float, rest_height: float):
    """Sample a motion at `fps`: ``(theta (F, D) radians, root_rotation (F, 3, 3),
    root_translation (F, 3))``; the root stands at ``(0, 0, rest_height)`` plus the
    keyframes' offsets."""
    if name not in MOTIONS:
        raise OptionsError(f"unknown motion {name!r}; motions: {sorted(MOTIONS)}")
    keys = MOTIONS[name]
    index = {n: i for i, n in enumerate(dof_names)}
    for k in keys:
        for dof in k.angles:
            if dof not in index:
                raise OptionsError(f"motion {name!r} names unknown DOF {dof!r}")
    times = np.cumsum([k.seconds for k in keys])
    values = np.zeros((len(keys), len(dof_names) + 4))
    for i, k in enumerate(keys):
        for dof, deg in k.angles.items():
            values[i, index[dof]] = np.radians(deg)
        values[i, -4:-1] = k.offset
        values[i, -1] = np.radians(k.yaw)
    n = int(np.floor(times[-1] * fps)) + 1
    t = np.arange(n) / fps
    seg = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(keys) - 2)
    u = np.clip((t - times[seg]) / np.maximum(times[seg + 1] - times[seg], 1e-9), 0, 1)
    ease = 0.5 - 0.5 * np.cos(np.pi * u)
    sampled = values[seg] + ease[:, None] * (values[seg + 1] - values[seg])
    yaw = sampled[:, -1]
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.zeros((n, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1
    return sampled[:, :-4], R, sampled[:, -4:-1] + (0.0, 0.0, rest_height)
