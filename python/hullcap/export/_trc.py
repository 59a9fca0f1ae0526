"""TRC marker files of the joint centres, for OpenSim (docs/formats.md, "joints.trc").

OpenSim scales and drives musculoskeletal models from markers in this tab-separated
text format (the one Pose2Sim writes): a three-line file header (path type, then the
data rate, frame and marker counts and units), a two-line data header naming each
marker and its X/Y/Z columns, then one row per frame starting with the frame number
(from 1) and the time in seconds. Each canonical joint is a marker named as in
``joints.csv``. OpenSim's world is y up, so by default our (x, y, z) is written as
(x, z, −y); ``up="z"`` keeps our world. Failed frames are written as ``NaN`` (missing).
:func:`read_trc` reads such files back, and those of other tools (a missing marker as
``NaN`` or an empty field).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import OptionsError, ResultsError
from hullcap.export._motion import change_of_axes

__all__ = ["read_trc", "write_trc"]

UNITS = {"mm": 1000.0, "m": 1.0}
"""Units :func:`write_trc` writes, as values per metre."""
READ_UNITS = UNITS | {"cm": 100.0}
"""Units :func:`read_trc` reads, as values per metre."""


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


def read_trc(path, *, up: str = "y") -> tuple[list[str], np.ndarray, np.ndarray]:
    """``(marker names, (F, M, 3) positions in metres in our world, (F,) times in
    seconds)`` of a TRC file whose up axis is `up` ("y", OpenSim's; "z", ours; "pose2sim",
    Pose2Sim's y-up file of a z-up calibration, :data:`~hullcap.export._motion.POSE2SIM`).
    The units come from the file's header; a missing value (``NaN`` or an empty field) is NaN."""
    path = Path(path)
    C = change_of_axes(up, "TRC", ("y", "z", "pose2sim"))
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise ResultsError(f"{path}: not a readable TRC file ({e})") from None
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise ResultsError(f"{path}: not a TRC file (no PathFileType header)")
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    units = header.get("Units", "").strip().lower()
    if units not in READ_UNITS:
        raise ResultsError(f"{path}: unknown units {units!r} (the header's Units: {tuple(READ_UNITS)})")
    names = [n.strip() for n in lines[3].split("\t")[2:] if n.strip()]
    if not names:
        raise ResultsError(f"{path}: no marker names on line 4")
    rows = []
    for number, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        fields = line.split("\t")
        if len(fields) < 2 + 3 * len(names):
            fields += [""] * (2 + 3 * len(names) - len(fields))  # trailing missing markers
        try:
            row = [float(v) if v.strip() else np.nan for v in fields[1:2 + 3 * len(names)]]
        except ValueError:
            raise ResultsError(f"{path}, line {number}: not a row of numbers") from None
        if not np.isfinite(row[0]):
            raise ResultsError(f"{path}, line {number}: no time")
        rows.append(row)
    if not rows:
        raise ResultsError(f"{path}: no frames")
    data = np.asarray(rows, float)
    positions = data[:, 1:].reshape(len(rows), len(names), 3) / READ_UNITS[units]
    return names, positions @ C, data[:, 0]
