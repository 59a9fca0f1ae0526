"""Joint angles over time, for biomechanics tools (docs/formats.md, "angles.mot and
angles.csv").

OpenSim reads joint angles as a motion file (``.mot``: a short header ending in
``endheader``, then tab-separated columns with ``time`` first, angles in degrees);
spreadsheets, pandas and MATLAB read CSV. Both carry one table: the time, the root's
position (the body frame's origin, world metres) and orientation, then every DOF of the
model in degrees, named as in ``pose.npz``. Failed frames are left out (their times are
missing from the file); ``hullcap export --interpolate`` fills them.

The root's orientation R (body frame → world, z up; the body frame's x is the subject's
left, y its back) is three angles with R = Rz(yaw) · Ry(roll) · Rx(pitch): yaw turns the
body about the vertical (positive to its left), roll leans it sideways (positive to its
left), pitch bends it forwards (positive). Any three angles lose one where the middle one
reaches ±90°; here that is lying on one's side, which motion capture of people on their
feet, bending to the floor included, stays far from. Each angle is unwrapped over time,
so that a person who turns round goes on to 180° and beyond instead of jumping by 360°.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import ResultsError

__all__ = ["ROOT_COLUMNS", "angle_table", "read_mot", "write_angles_csv", "write_mot"]

ROOT_COLUMNS = ("root_tx", "root_ty", "root_tz", "root_yaw", "root_roll", "root_pitch")
"""The root's columns: its position in metres, then its orientation in degrees."""


def root_angles(rotations) -> np.ndarray:
    """(F, 3) yaw, roll and pitch in radians of (F, 3, 3) rotations, R = Rz(yaw) ·
    Ry(roll) · Rx(pitch)."""
    R = np.asarray(rotations, float)
    yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    roll = np.arcsin(np.clip(-R[:, 2, 0], -1.0, 1.0))
    pitch = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    return np.stack([yaw, roll, pitch], axis=1)


def angle_table(dof_names, theta, root_translation, root_rotation, fps: float) -> tuple[list[str], np.ndarray]:
    """``(column names, (F, C) values)``, a row per frame: time in seconds, the root's
    position (metres) and angles (degrees, unwrapped over the fitted frames), then each
    DOF in degrees; NaN but for the time where the frame failed (its row of `theta` has
    NaN). The writers leave those rows out; a filter such as ``smooth_joints`` can run on
    the table first, each run of fitted frames on its own."""
    theta = np.asarray(theta, float)
    root_translation = np.asarray(root_translation, float)
    root_rotation = np.asarray(root_rotation, float)
    frames = len(theta)
    if theta.ndim != 2 or theta.shape[1] != len(dof_names) or root_translation.shape != (frames, 3) \
            or root_rotation.shape != (frames, 3, 3):
        raise ResultsError(f"angles need theta (F, {len(dof_names)}), root_translation (F, 3) and root_rotation "
                           f"(F, 3, 3) of one F; got {theta.shape}, {root_translation.shape} and "
                           f"{root_rotation.shape}")
    fitted = np.flatnonzero(np.isfinite(theta).all(1) & np.isfinite(root_translation).all(1)
                            & np.isfinite(root_rotation).all((1, 2)))
    if not len(fitted):
        raise ResultsError("no fitted frame to write angles of")
    names = ["time", *ROOT_COLUMNS, *dof_names]
    values = np.full((frames, len(names)), np.nan)
    values[:, 0] = np.arange(frames) / fps
    root = np.unwrap(root_angles(root_rotation[fitted]), axis=0)
    values[fitted, 1:] = np.column_stack([root_translation[fitted], np.degrees(root), np.degrees(theta[fitted])])
    return names, values


def _fitted_rows(values) -> np.ndarray:
    values = np.asarray(values, float)
    return values[np.isfinite(values).all(1)]


def write_mot(path, names, values) -> None:
    """Write an :func:`angle_table`'s fitted frames as an OpenSim motion file, atomically."""
    path = Path(path)
    values = _fitted_rows(values)
    header = [path.name, "version=1", f"nRows={len(values)}", f"nColumns={len(names)}", "inDegrees=yes",
              "endheader", "\t".join(names)]
    rows = ["\t".join(f"{v:.6f}" for v in row) for row in values]
    atomic_write(path, ("\n".join(header + rows) + "\n").encode())


def write_angles_csv(path, names, values) -> None:
    """Write an :func:`angle_table`'s fitted frames as CSV with a header row, atomically."""
    rows = [",".join(f"{v:.6f}" for v in row) for row in _fitted_rows(values)]
    atomic_write(Path(path), ("\n".join([",".join(names), *rows]) + "\n").encode())


def read_mot(path) -> tuple[list[str], np.ndarray]:
    """``(column names, (N, C) values)`` of an OpenSim motion or storage file (ours or
    another tool's: the header's lines up to ``endheader``, then a row of names and rows
    of numbers, tab- or space-separated)."""
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise ResultsError(f"{path}: not a readable motion file ({e})") from None
    end = next((i for i, line in enumerate(lines) if line.strip().lower() == "endheader"), None)
    if end is None or end + 1 >= len(lines):
        raise ResultsError(f"{path}: not an OpenSim motion file (no endheader and column names)")
    names = lines[end + 1].split()
    rows = []
    for number, line in enumerate(lines[end + 2:], start=end + 3):
        if not line.strip():
            continue
        fields = line.split()
        if len(fields) != len(names):
            raise ResultsError(f"{path}, line {number}: {len(fields)} values for {len(names)} columns")
        try:
            rows.append([float(v) for v in fields])
        except ValueError:
            raise ResultsError(f"{path}, line {number}: not a row of numbers") from None
    return names, np.asarray(rows, float).reshape(len(rows), len(names))
