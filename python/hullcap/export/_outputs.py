"""The files of a run's results folder that hold its poses and joints (docs/formats.md):
``joints.csv``, ``pose.npz``, and with them ``motion.bvh`` and ``model.glb``; and reading a
finished run back from its folder."""

from __future__ import annotations

import io
from dataclasses import replace
from pathlib import Path

import numpy as np

from hullcap._body import BodyModel
from hullcap._files import atomic_write, read_npz
from hullcap._results import INTERPOLATED, STATUS_NAMES, UNCERTAIN, TrackingResult, smooth_joints
from hullcap.errors import ResultsError
from hullcap.export._bvh import write_bvh
from hullcap.export._gltf import write_glb

__all__ = ["write_outputs", "write_joints_csv", "load_result"]


def write_outputs(out, result: TrackingResult, interpolate: bool = False, smooth_hz: float | None = None) -> list[str]:
    """Write ``joints.csv``, ``pose.npz``, ``motion.bvh`` and ``model.glb`` (these two
    when a frame has a pose), each atomically; with `interpolate`, failed frames between
    fitted ones are filled in the outputs (``pose.npz`` keeps the raw poses and says
    which); with `smooth_hz`, also ``joints_smooth.csv`` (see :func:`smooth_joints`).
    Returns the names written."""
    out = Path(out)
    shown = result.interpolated() if interpolate else result
    write_joints_csv(out / "joints.csv", shown)
    written = ["joints.csv"]
    if smooth_hz:
        write_joints_csv(out / "joints_smooth.csv", replace(shown, joints=smooth_joints(shown.joints, result.fps,
                                                                                         smooth_hz)))
        written.append("joints_smooth.csv")
    buf = io.BytesIO()
    arrays = result.arrays()
    arrays.pop("joints")
    if interpolate:
        arrays["interpolated"] = shown.status == INTERPOLATED
    np.savez(buf, **arrays)
    atomic_write(out / "pose.npz", buf.getvalue())
    written.append("pose.npz")
    if (~shown.failed).any():
        motion = (shown.model, shown.root_translation, shown.root_rotation, shown.theta, shown.fps)
        write_bvh(out / "motion.bvh", *motion)
        write_glb(out / "model.glb", *motion)
        written += ["motion.bvh", "model.glb"]
    return written


def write_joints_csv(path, result: TrackingResult, drop_uncertain: bool = False) -> None:
    """``joints.csv``: one row per frame with a pose and joint, with the joint's status and
    confidence (empty where it is not judged); without the rows of the joints marked
    uncertain when `drop_uncertain`."""
    lines = ["frame,time,joint,x,y,z,status,confidence"]
    names = result.model.joint_names
    confidence = result.confidence
    for f in np.flatnonzero(~result.failed):
        t = f / result.fps
        for j, (name, (x, y, z)) in enumerate(zip(names, result.joints[f])):
            if drop_uncertain and result.joint_status[f, j] == UNCERTAIN:
                continue
            c = confidence[f, j]
            lines.append(f"{f},{t:.6f},{name},{x:.6f},{y:.6f},{z:.6f},{STATUS_NAMES[result.joint_status[f, j]]},"
                         f"{'' if np.isnan(c) else f'{c:.3f}'}")
    atomic_write(Path(path), ("\n".join(lines) + "\n").encode())


def load_result(out) -> TrackingResult:
    """A finished run's results from its folder (``pose.npz`` and ``model/``)."""
    out = Path(out)
    path = out / "pose.npz"
    if not path.is_file():
        raise ResultsError(f"{out}: no pose.npz: not the results folder of a finished `hullcap track` run")
    try:
        a = read_npz(path, ResultsError, "readable pose.npz")
    except ResultsError as e:
        raise ResultsError(f"{e}; track the sequence again (hullcap track --restart) to rewrite it") from None
    model = BodyModel.load(out / "model")
    missing = {"root_translation", "root_rotation", "theta", "failed", "iterations", "fps"} - a.keys()
    if missing:
        raise ResultsError(f"{path}: missing {sorted(missing)}")
    try:
        return TrackingResult.from_arrays(model, a)
    except ResultsError as e:
        raise ResultsError(f"{path}: {e}") from None
