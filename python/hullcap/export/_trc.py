"""TRC marker files of the joint centres, for OpenSim (docs/formats.md, "joints.trc").

OpenSim scales and drives musculoskeletal models from markers in this tab-separated
text format (the one Pose2Sim writes): a three-line file header (path type, then the
data rate, frame and marker counts and units), a two-line data header naming each
marker and its X/Y/Z columns, then one row per frame starting with the frame number
(from 1) and the time in seconds. Each canonical joint is a marker named as in
``joints.csv``. OpenSim's world is y up, so by default our (x, y, z) is written as
(x, z, −y); ``up="z"`` keeps our world. Failed frames are written as ``NaN`` (missing).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import OptionsError, ResultsError
from hullcap.export._motion import change_of_axes

__all__ = ["write_trc"]

UNITS = {"mm": 1000.0, "m": 1.0}


def write_trc(path, joint_names, joints, fps: float, *, units: str = "mm", up: str = "y") -> None:
    """Write (F, J, 3) joint positions (metres, NaN = missing) as a TRC file, atomically,
    in `units` "mm" or "m", with `up` "y" (OpenSim) or "z" (our world)."""
    if units not in UNITS:
        raise OptionsError(f"TRC units must be one of {tuple(UNITS)}, got {units!r}")
    joints = np.asarray(joints, float)
    if joints.ndim != 3 or joints.shape[1:] != (len(joint_names), 3):
        raise ResultsError(f"joints must have shape (F, {len(joint_names)}, 3), got {joints.shape}")
    C = change_of_axes(up, "TRC")
    points = UNITS[units] * joints @ C.T
    frames, markers = joints.shape[:2]
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{Path(path).name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{fps:g}\t{fps:g}\t{frames}\t{markers}\t{units}\t{fps:g}\t1\t{frames}",
        "Frame#\tTime\t" + "\t\t\t".join(joint_names) + "\t\t",
        "\t\t" + "\t".join(f"{a}{i}" for i in range(1, markers + 1) for a in "XYZ"),
        "",
    ]
    for f in range(frames):
        values = "\t".join("NaN" if np.isnan(v) else f"{v:.6f}" for v in points[f].ravel())
        lines.append(f"{f + 1}\t{f / fps:.6f}\t{values}")
    atomic_write(Path(path), ("\n".join(lines) + "\n").encode())
