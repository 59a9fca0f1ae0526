"""C3D files of the joint centres, for biomechanics tools (Visual3D, OpenSim, Mokka…).

Written with ezc3d (``pip install ezc3d``, the ``c3d`` extra): one point per canonical
joint, labelled by its name, in millimetres (the C3D convention) in our world frame (z up),
at the sequence's frame rate; failed frames are written as missing (NaN). A point's
residual, where given, is the joint's distance from the learned segmenter's key point of it
(whole millimetres, at most :data:`MAX_RESIDUAL_MM`; 0 where not measured).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import HullcapError, ResultsError

__all__ = ["write_c3d", "read_c3d"]


def _ezc3d():
    try:
        import ezc3d
    except ImportError as e:
        raise HullcapError("C3D export needs ezc3d: pip install ezc3d (or hullcap[c3d])") from e
    return ezc3d


MAX_RESIDUAL_MM = 255
"""The largest residual a C3D point holds (one byte, in the point's units)."""


def write_c3d(path, joint_names, joints, fps: float, residuals=None) -> None:
    """Write (F, J, 3) joint positions (metres, NaN = missing) as C3D, atomically, with
    (F, J) `residuals` (metres, NaN = not measured; see the module documentation)."""
    ezc3d = _ezc3d()
    joints = np.asarray(joints, float)
    if joints.ndim != 3 or joints.shape[1:] != (len(joint_names), 3):
        raise ResultsError(f"joints must have shape (F, {len(joint_names)}, 3), got {joints.shape}")
    if residuals is not None and np.shape(residuals) != joints.shape[:2]:
        raise ResultsError(f"residuals must have shape {joints.shape[:2]}, got {np.shape(residuals)}")
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = np.array([fps])
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(joint_names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    points = np.ones((4, len(joint_names), len(joints)))
    points[:3] = joints.transpose(2, 1, 0) * 1000.0
    c3d["data"]["points"] = points
    if residuals is not None:
        mm = np.clip(np.nan_to_num(np.asarray(residuals, float) * 1000.0, nan=0.0), 0, MAX_RESIDUAL_MM).round()
        mm[np.isnan(joints).any(axis=2)] = -1.0  # a missing point
        c3d["data"]["meta_points"] = {"residuals": mm.T[None], "camera_masks": np.zeros((7, *mm.T.shape), bool)}
    atomic_write(Path(path), lambda tmp: c3d.write(str(tmp)))


def read_c3d(path, residuals: bool = False):
    """``(labels, (F, J, 3) metres, frame rate)`` of a C3D file's points, and with
    `residuals` their (F, J) residuals in the file's units (−1 for a missing point)."""
    ezc3d = _ezc3d()
    c3d = ezc3d.c3d(str(path))
    labels = list(c3d["parameters"]["POINT"]["LABELS"]["value"])
    unit = c3d["parameters"]["POINT"]["UNITS"]["value"][0].strip().lower()
    scale = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}.get(unit)
    if scale is None:
        raise ResultsError(f"{path}: unknown point unit {unit!r}")
    points = c3d["data"]["points"][:3].transpose(2, 1, 0) * scale
    rate = float(c3d["parameters"]["POINT"]["RATE"]["value"][0])
    if residuals:
        return labels, points, rate, c3d["data"]["meta_points"]["residuals"][0].T
    return labels, points, rate
