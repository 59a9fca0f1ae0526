"""The fitted motion as the exporters need it: each link's rotation relative to its parent
and the root's position, frame by frame."""

from __future__ import annotations

import numpy as np

from hullcap.errors import ResultsError

Z_UP_TO_Y_UP = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
"""(x, y, z) ours (z up) → (x, z, −y) in the y-up convention of BVH and glTF: −90° about x."""


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
