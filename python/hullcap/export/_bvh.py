"""BVH motion files: the subject's skeleton and its motion, for Blender and friends.

One BVH joint per canonical joint (docs/design.md §1), named as in ``joints.csv``. Joints at a
link's centre of rotation carry that link's rotation relative to its parent; sites (chest,
head, toes, and the wrists of the paper's 29 DOF) are joints with rotation channels that
stay zero, so that every canonical joint appears by name. A joint without children ends
(its End Site) at its link's far end when it turns a link (a hand that turns at its wrist:
the bone a reader makes of it turns with the hand), where it is when it is a site. Offsets
come from the subject's model; the root carries its world position. Rotation channels are
in the order ``Zrotation Xrotation Yrotation`` (R = Rz·Rx·Ry, degrees).

By default the file is in the convention BVH readers assume (Blender's importer with its
default settings, MotionBuilder, the CMU files): y up, our (x, y, z) written as
(x, z, −y), in metres. ``up="z"`` writes our own world unchanged (import into Blender with
"Up: Z"); ``units="cm"`` scales offsets and positions by 100.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import OptionsError
from hullcap.export._motion import change_of_axes, local_motion

__all__ = ["write_bvh", "bvh_skeleton", "zxy_degrees"]


def bvh_skeleton(model):
    """``(names, parents, offsets, links)`` of the BVH joints, parents before children:
    every canonical joint, its parent joint, its offset from it at rest (metres) and the
    link whose rotation it carries (−1 for a site)."""
    links = model.link_model
    names, parents, offsets, carries = [], [], [], []
    position = {}
    order = sorted(range(len(links.joint_names)), key=lambda i: _depth(links, i))
    for i in order:
        name = links.joint_names[i]
        link = int(links.joint_links[i])
        at_origin = links.joints[link] == name
        if at_origin:
            parent_link = links.parents[link]
            parent = None if parent_link < 0 else links.joints[parent_link]
        else:
            parent = links.joints[link]
        names.append(name)
        parents.append(-1 if parent is None else names.index(parent))
        position[name] = links.joint_points[i]
        offsets.append(position[name] - (position[parent] if parent is not None else 0.0))
        carries.append(link if at_origin else -1)
    return names, parents, np.array(offsets), carries


def _depth(links, i) -> tuple:
    link = int(links.joint_links[i])
    depth = 0
    j = link
    while links.parents[j] >= 0:
        j = int(links.parents[j])
        depth += 1
    at_origin = links.joints[link] == links.joint_names[i]
    return (depth + (0 if at_origin else 0.5), i)


def zxy_degrees(R: np.ndarray) -> np.ndarray:
    """Angles (z, x, y) in degrees with R = Rz(z)·Rx(x)·Ry(y), for (..., 3, 3) R."""
    x = np.arcsin(np.clip(R[..., 2, 1], -1.0, 1.0))
    y = np.arctan2(-R[..., 2, 0], R[..., 2, 2])
    z = np.arctan2(-R[..., 0, 1], R[..., 1, 1])
    return np.degrees(np.stack([z, x, y], -1))


UNITS = {"m": 1.0, "cm": 100.0}


def write_bvh(path, model, root_translation, root_rotation, theta, fps: float, *, up: str = "y",
              units: str = "m") -> None:
    """Write the motion (F frames of root placement and joint angles; failed frames, NaN,
    repeat the last good one) as BVH, atomically: `up` "y" (what readers assume) or "z"
    (our world), lengths in `units` "m" or "cm"."""
    C = change_of_axes(up, "BVH")
    if units not in UNITS:
        raise OptionsError(f"BVH units must be one of {tuple(UNITS)}, got {units!r}")
    names, parents, offsets, carries = bvh_skeleton(model)
    links = model.link_model
    ends = np.array([links.segments[link, 1] - links.origins[link] if link >= 0 else np.zeros(3)
                     for link in carries])
    local, root_position = local_motion(path, model, root_translation, root_rotation, theta)
    # The change of axes C maps every position p to C·p and every rotation R to C·R·Cᵀ.
    local = C @ local @ C.T
    offsets = UNITS[units] * offsets @ C.T
    ends = UNITS[units] * ends @ C.T
    root_position = UNITS[units] * root_position @ C.T
    frames = len(local)
    angles = zxy_degrees(local)  # (F, L, 3)
    values = []
    for f in range(frames):
        row = list(root_position[f])
        for link in carries:
            row += [0.0, 0.0, 0.0] if link < 0 else list(angles[f, link])
        values.append(row)
    children = {i: [c for c, p in enumerate(parents) if p == i] for i in range(len(names))}
    lines = ["HIERARCHY"]

    def emit(i, indent):
        pad = "  " * indent
        head = "ROOT" if parents[i] < 0 else "JOINT"
        lines.append(f"{pad}{head} {names[i]}")
        lines.append(f"{pad}{{")
        off = offsets[i] if parents[i] >= 0 else np.zeros(3)
        lines.append(f"{pad}  OFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        channels = "Zrotation Xrotation Yrotation"
        if parents[i] < 0:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition {channels}")
        else:
            lines.append(f"{pad}  CHANNELS 3 {channels}")
        if children[i]:
            for c in children[i]:
                emit(c, indent + 1)
        else:
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            end = ends[i]
            lines.append(f"{pad}    OFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    order = []

    def walk(i):
        order.append(i)
        for c in children[i]:
            walk(c)

    for root in [i for i, p in enumerate(parents) if p < 0]:
        emit(root, 0)
        walk(root)
    # Channel values in the order the hierarchy lists the joints.
    per_joint = lambda row, i: row[:6] if parents[i] < 0 else row[3 + 3 * i: 6 + 3 * i]  # noqa: E731
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {1.0 / fps:.8f}"]
    for row in values:
        lines.append(" ".join(f"{v:.6f}" for i in order for v in per_joint(row, i)))
    atomic_write(Path(path), ("\n".join(lines) + "\n").encode())
