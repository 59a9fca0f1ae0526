"""A run's joint centres against a reference: a marker system's, another tracker's, a
truth's (docs/accuracy.md, "In the body's frame").

Two systems rarely put a joint's centre at the same place inside the body (the hip most:
each has its own regression or rig), so besides the raw error each joint's constant
offset over the frames is removed, as validation studies do. Removed in the world, an
offset that is constant in the body stays in the error as soon as the person turns
round; removed in the reference's own body frame (from its pelvis, neck and hips) it
goes whichever way the person faces. What is left is what the two disagree on from
frame to frame: the tracking's own error, when the reference is right.

The reference's frames are matched by time: the run's joints are interpolated linearly
at each reference frame's time (plus a shift for two clocks that do not agree), where
the run tracked both frames around it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hullcap.errors import ResultsError

__all__ = ["Comparison", "compare", "compare_run", "body_frames", "offset_removed_mm", "reference_joints"]

TRUNK = ("pelvis", "neck", "l_hip", "r_hip")
"""The joints the body's frame is made from (see :func:`body_frames`)."""


def body_frames(names, positions) -> np.ndarray:
    """(F, 3, 3) the body's frame in each of the (F, J, 3) `positions` of joints `names`,
    its axes as columns: x from the right hip to the left, z from the pelvis towards the
    neck (made square to x), y = z × x (towards the back). NaN where a joint of
    :data:`TRUNK` is missing."""
    names = list(names)
    missing = [n for n in TRUNK if n not in names]
    if missing:
        raise ResultsError(f"the body's frame needs the joints {list(TRUNK)}; missing {missing}")
    at = {n: np.asarray(positions, float)[:, names.index(n)] for n in TRUNK}
    x = _unit(at["l_hip"] - at["r_hip"])
    up = at["neck"] - at["pelvis"]
    z = _unit(up - np.sum(up * x, axis=1, keepdims=True) * x)
    return np.stack([x, np.cross(z, x), z], axis=2)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def offset_removed_mm(err: np.ndarray) -> np.ndarray:
    """(J,) per joint, the mean length in millimetres of the (F, J, 3) errors (metres,
    NaN where missing) once their mean over the frames is removed."""
    with np.errstate(invalid="ignore"):
        return np.nanmean(np.linalg.norm(err - np.nanmean(err, axis=0), axis=2), axis=0) * 1e3


@dataclass(frozen=True)
class Comparison:
    """Per joint (millimetres): the raw error, the error with its constant offset removed
    in the world, and in the reference's body frame (None without its pelvis, neck and
    hips); over `frames` reference frames, `missing` more of which had no joints of the
    run to compare (outside its time span, or failed)."""

    joint_names: tuple[str, ...]
    frames: int
    missing: int
    raw_mm: np.ndarray
    offset_removed_mm: np.ndarray
    body_offset_removed_mm: np.ndarray | None

    def means(self) -> dict[str, float | None]:
        """The three figures' means over the joints."""
        body = self.body_offset_removed_mm
        return {"raw_mm": float(np.nanmean(self.raw_mm)),
                "offset_removed_mm": float(np.nanmean(self.offset_removed_mm)),
                "body_offset_removed_mm": None if body is None else float(np.nanmean(body))}

    def table(self) -> str:
        body = self.body_offset_removed_mm
        cols = ["raw (mm)", "offset removed (mm)"] + ([] if body is None else ["in the body's frame (mm)"])
        rows = [f"{'joint':<12} " + "  ".join(f"{c:>{len(c)}}" for c in cols)]
        figures = [self.raw_mm, self.offset_removed_mm] + ([] if body is None else [body])
        for j, name in enumerate(self.joint_names):
            rows.append(f"{name:<12} " + "  ".join(f"{f[j]:>{len(c)}.1f}" for f, c in zip(figures, cols)))
        means = [v for v in self.means().values() if v is not None]
        rows.append(f"{'all joints':<12} " + "  ".join(f"{m:>{len(c)}.1f}" for m, c in zip(means, cols)))
        rows.append(f"{self.frames} frames of the reference compared"
                    + (f"; {self.missing} more without the run's joints" if self.missing else ""))
        return "\n".join(rows)

    def to_dict(self) -> dict:
        per_joint = {"raw_mm": self.raw_mm, "offset_removed_mm": self.offset_removed_mm,
                     "body_offset_removed_mm": self.body_offset_removed_mm}
        return {"frames": self.frames, "missing": self.missing, "means": self.means(),
                "joints": {name: {k: None if v is None else round(float(v[j]), 2) for k, v in per_joint.items()}
                           for j, name in enumerate(self.joint_names)}}


def compare(joint_names, joints, fps: float, reference_names, reference, reference_times,
            names: dict[str, str] | None = None, shift: float = 0.0) -> Comparison:
    """Compare a run's (F, J, 3) `joints` (metres, frame f at f / `fps` s, NaN where
    failed) under `joint_names` with a reference's (K, M, 3) positions under
    `reference_names` at `reference_times` (s, plus `shift`). `names` maps our joint
    names to the reference's; by default every joint both have, under the same name."""
    joint_names, reference_names = list(joint_names), list(reference_names)
    joints, reference = np.asarray(joints, float), np.asarray(reference, float)
    pairs = names if names is not None else {n: n for n in joint_names if n in reference_names}
    unknown = [n for n in pairs if n not in joint_names]
    absent = [r for r in pairs.values() if r not in reference_names]
    if unknown or absent:
        raise ResultsError("joint names not found: " + "; ".join(
            part for part in (f"ours {unknown} (ours: {joint_names})" if unknown else "",
                              f"the reference's {absent} (its: {reference_names})" if absent else "") if part))
    if not pairs:
        raise ResultsError(f"the run's joints {joint_names} and the reference's {reference_names} share no name: "
                           "map them (names)")
    ours_at = _interpolated(joints[:, [joint_names.index(n) for n in pairs]], fps,
                            np.asarray(reference_times, float) + shift)
    theirs = reference[:, [reference_names.index(r) for r in pairs.values()]]
    err = ours_at - theirs
    compared = ~np.isnan(ours_at).all(axis=(1, 2))
    if not compared.any():
        span = len(joints) / fps
        raise ResultsError(f"no frame of the reference falls within the run's tracked frames (0 to {span:.2f} s; "
                           f"the reference's times {reference_times[0]:.2f} to {reference_times[-1]:.2f} s, "
                           f"shifted by {shift} s)")
    err = err[compared]
    with np.errstate(invalid="ignore"):
        raw = np.nanmean(np.linalg.norm(err, axis=2), axis=0) * 1e3
    body = None
    if all(n in pairs for n in TRUNK):
        frames = body_frames(list(pairs), theirs[compared])
        body = offset_removed_mm(np.einsum("fdb,fjd->fjb", frames, err))
    return Comparison(tuple(pairs), int(compared.sum()), int((~compared).sum()), raw, offset_removed_mm(err), body)


def _interpolated(joints: np.ndarray, fps: float, times: np.ndarray) -> np.ndarray:
    """(K, J, 3) `joints` (frame f at f / `fps`) at `times`, linearly between the two
    frames around each; NaN outside the frames or where either of the two is NaN. A time
    within a thousandth of a frame of one (files keep times to the microsecond) is that
    frame's."""
    at = times * fps
    on_frame = np.abs(at - np.round(at)) < 1e-3  # a time on a frame needs no neighbour
    i = np.where(on_frame, np.round(at), np.floor(at)).astype(int)
    w = np.where(on_frame, 0.0, at - i)[:, None, None]
    inside = (i >= 0) & ((i + 1 < len(joints)) | (on_frame & (i < len(joints))))
    out = np.full((len(times),) + joints.shape[1:], np.nan)
    a = joints[i[inside]]
    b = joints[np.minimum(i[inside] + 1, len(joints) - 1)]
    out[inside] = np.where(on_frame[inside, None, None], a, (1 - w[inside]) * a + w[inside] * b)
    return out


def reference_joints(path, up: str = "y") -> tuple[list[str], np.ndarray, np.ndarray]:
    """``(names, (K, M, 3) metres in our world, (K,) times in seconds)`` of a reference:
    a TRC file (`up` its up axis), a C3D file (our world's axes; needs ezc3d), or the
    results folder of another run (failed frames NaN)."""
    from hullcap._results import load_result
    from hullcap.export import read_c3d, read_trc

    path = Path(path)
    if path.is_dir():
        other = load_result(path)
        return list(other.model.joint_names), other.joints, np.arange(len(other.joints)) / other.fps
    suffix = path.suffix.lower()
    if suffix == ".trc":
        return read_trc(path, up=up)
    if suffix == ".c3d":
        labels, points, rate = read_c3d(path)
        return labels, points, np.arange(len(points)) / rate
    raise ResultsError(f"{path}: a reference is a .trc or .c3d file, or a results folder")


def compare_run(out, reference, names=None, shift: float = 0.0, up: str = "y") -> Comparison:
    """:func:`compare` a finished run's results folder `out` with the `reference` of
    :func:`reference_joints`; `names` a mapping or a JSON file of one (ours → theirs)."""
    from hullcap._results import load_result

    result = load_result(out)
    if names is not None and not isinstance(names, dict):
        try:
            names = json.loads(Path(names).read_text())
        except (OSError, ValueError) as e:
            raise ResultsError(f"{names}: not a readable JSON mapping of joint names ({e})") from None
        if not isinstance(names, dict) or not all(isinstance(v, str) for v in names.values()):
            raise ResultsError("the joint names' mapping must be a JSON object of our names to the reference's")
    ref_names, ref, times = reference_joints(reference, up)
    return compare(result.model.joint_names, result.joints, result.fps, ref_names, ref, times, names, shift)
