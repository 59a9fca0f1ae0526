"""The fitted motion as the exporters need it: each link's rotation relative to its parent
and the root's position, frame by frame."""

from __future__ import annotations

import numpy as np

from hullcap._cameras import Y_UP_TO_Z_UP
from hullcap.errors import OptionsError, ResultsError

Z_UP_TO_Y_UP = Y_UP_TO_Z_UP.T
"""(x, y, z) ours (z up) → (x, z, −y) in the y-up convention of BVH, glTF and OpenSim."""


POSE2SIM = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""(x, y, z) ours → (y, z, x): the y-up TRC that Pose2Sim writes of a z-up calibration's world."""
AXES = {"y": Z_UP_TO_Y_UP, "z": np.eye(3), "pose2sim": POSE2SIM}
"""The axes a file may have, by name: the rotation from our world to the file's."""


def change_of_axes(up: str, what: str, allowed: tuple[str, ...] = ("y", "z")) -> np.ndarray:
    """The rotation from our world to a file's whose axes are `up`, one of `allowed` names
    of :data:`AXES`; `what` names the format in the error."""
    if up not in allowed:
        raise OptionsError(f"{what} axes must be {' or '.join(repr(a) for a in allowed)}, got {up!r}")
    return AXES[up]


def local_motion(path, model, root_translation, root_rotation, theta) -> tuple[np.ndarray, np.ndarray]:
    """``(local (F, L, 3, 3), root_position (F, 3))``: every link's rotation relative to
    its parent (the root's is its world rotation) and the root's world position. Failed
    frames (NaN) repeat the last good one (the first good one before any)."""
    theta = np.asarray(theta, float)
    good = ~np.isnan(theta).any(1)
    if not good.any():
        raise ResultsError(f"{path}: no fitted frame to write")
    parents = model.link_model.parents
    n_links = len(parents)
    local = np.zeros((len(theta), n_links, 3, 3))
    root_position = np.zeros((len(theta), 3))
    last = int(np.flatnonzero(good)[0])
    for f in range(len(theta)):
        last = f if good[f] else last
        pose = model.pose(theta[last], root_rotation[last], root_translation[last], clamp=False)
        rot = pose.link_rotations
        for j in range(n_links):
            local[f, j] = rot[j] if parents[j] < 0 else rot[parents[j]].T @ rot[j]
        root_position[f] = pose.link_positions[0]
    return local, root_position
