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
at each reference frame's time (plus a shift for two clocks that do not agree, given or
found), where the run tracked both frames around it. A reference in a world of its own
(a marker system calibrated apart from the cameras) can be brought into ours first by
the rigid motion that best lays its joints on ours.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hullcap.errors import ResultsError

__all__ = ["Comparison", "compare", "compare_run", "body_frames", "in_body_frame", "offset_removed_mm",
           "reference_joints"]

TRUNK = ("pelvis", "neck", "l_hip", "r_hip")
"""The joints the body's frame is made from (see :func:`body_frames`)."""


def body_frames(names, positions) -> np.ndarray:
    """(F, 3, 3) the body's frame in each of the (F, J, 3) `positions` of joints `names`,
    its axes as columns: x from the right hip to the left, z from the pelvis towards the
    neck (made square to x), y = z × x (towards the back). NaN in a frame where a joint
    of :data:`TRUNK` is NaN; ResultsError when `names` lacks one."""
    names = list(names)
    missing = [n for n in TRUNK if n not in names]
    if missing:
        raise ResultsError(f"the body's frame needs the joints {list(TRUNK)}; missing {missing}")
    at = {n: np.asarray(positions, float)[:, names.index(n)] for n in TRUNK}
    x = _unit(at["l_hip"] - at["r_hip"])
    up = at["neck"] - at["pelvis"]
    z = _unit(up - np.sum(up * x, axis=1, keepdims=True) * x)
    return np.stack([x, np.cross(z, x), z], axis=2)


def in_body_frame(names, reference, err: np.ndarray) -> np.ndarray:
    """The (F, J, 3) errors `err` turned into the body frame (:func:`body_frames`) of the
    (F, J, 3) `reference` joints `names`."""
    return np.einsum("fdb,fjd->fjb", body_frames(names, reference), err)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def offset_removed_mm(err: np.ndarray) -> np.ndarray:
    """(J,) per joint, the mean length in millimetres of the (F, J, 3) errors (metres,
    NaN where missing) once their mean over the frames is removed."""
    with np.errstate(invalid="ignore"):
        return np.nanmean(_lengths_mm(_without_offset(err)), axis=0)


def _without_offset(err: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return err - np.nanmean(err, axis=0)


def _lengths_mm(err: np.ndarray) -> np.ndarray:
    return np.linalg.norm(err, axis=-1) * 1e3


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
    shift: float = 0.0
    """Seconds added to the reference's times (given, or found)."""
    alignment: tuple[np.ndarray, np.ndarray] | None = None
    """``(R, t)``: the rigid motion x ↦ R·x + t that brought the reference into our
    world, when asked for."""
    times: np.ndarray | None = None
    """(K,) the compared frames' times (s, the reference's clock)."""
    over_time_mm: dict[str, np.ndarray] | None = None
    """Each figure's mean over the joints, per compared frame (K,)."""

    LABELS = {"raw_mm": "raw", "offset_removed_mm": "offset removed",
              "body_offset_removed_mm": "in the body's frame"}
    """The figures, by their keys in :meth:`to_dict` and ``over_time_mm``."""

    def _figures(self) -> dict[str, np.ndarray]:
        """The per-joint figures this comparison has, by key."""
        figures = {"raw_mm": self.raw_mm, "offset_removed_mm": self.offset_removed_mm,
                   "body_offset_removed_mm": self.body_offset_removed_mm}
        return {k: v for k, v in figures.items() if v is not None}

    def means(self) -> dict[str, float | None]:
        """The three figures' means over the joints (None for one it has not)."""
        figures = self._figures()
        return {k: float(np.nanmean(figures[k])) if k in figures else None for k in self.LABELS}

    def table(self) -> str:
        figures = self._figures()
        cols = [f"{self.LABELS[k]} (mm)" for k in figures]
        rows = [f"{'joint':<12} " + "  ".join(cols)]
        for j, name in enumerate(self.joint_names):
            rows.append(f"{name:<12} " + "  ".join(f"{f[j]:>{len(c)}.1f}" for f, c in zip(figures.values(), cols)))
        means = [m for m in self.means().values() if m is not None]
        rows.append(f"{'all joints':<12} " + "  ".join(f"{m:>{len(c)}.1f}" for m, c in zip(means, cols)))
        rows.append(f"{self.frames} frames of the reference compared"
                    + (f"; {self.missing} more without the run's joints" if self.missing else "")
                    + (f"; its times shifted by {self.shift:+.4f} s" if self.shift else ""))
        if self.alignment is not None:
            R, t = self.alignment
            angle = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))
            rows.append(f"the reference brought into our world: turned {angle:.2f}°, moved "
                        f"({t[0]:+.3f}, {t[1]:+.3f}, {t[2]:+.3f}) m")
        return "\n".join(rows)

    def plot(self, path, title: str = "") -> None:
        """A picture of the comparison (PNG): the errors over time, averaged over the
        joints, and each joint's three figures."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from hullcap._files import atomic_write

        figures, labels = self._figures(), self.LABELS
        fig, ax = plt.subplots(2, 1, figsize=(9, 4.5 + 0.16 * len(self.joint_names)),
                               gridspec_kw={"height_ratios": [2.2, 1.0 + 0.1 * len(self.joint_names)]})
        for key in figures:
            ax[0].plot(self.times, self.over_time_mm[key], lw=1.1, label=labels[key])
        ax[0].set(xlabel="time (s, the reference's clock)", ylabel="mean joint error (mm)")
        ax[0].legend(fontsize=8)
        y = np.arange(len(self.joint_names))
        height = 0.8 / len(figures)
        for k, (key, values) in enumerate(figures.items()):
            ax[1].barh(y + (k - (len(figures) - 1) / 2) * height, values, height, label=labels[key])
        ax[1].set_yticks(y, self.joint_names, fontsize=7)
        ax[1].invert_yaxis()
        ax[1].set(xlabel="mean error (mm)")
        for a in ax:
            a.grid(alpha=0.3)
        fig.suptitle(title or "Joint centres against the reference")
        ax[0].set_title(f"{self.frames} frames; " + ", ".join(f"{labels[k]} {np.nanmean(v):.1f} mm"
                                                                 for k, v in figures.items()), fontsize=9)
        fig.tight_layout()
        atomic_write(Path(path), lambda p: fig.savefig(p, dpi=100))
        plt.close(fig)

    def to_dict(self) -> dict:
        figures = self._figures()
        return {"frames": self.frames, "missing": self.missing, "shift_s": self.shift,
                "alignment": None if self.alignment is None else
                {"R": self.alignment[0].tolist(), "t": self.alignment[1].tolist()},
                "means": self.means(),
                "joints": {name: {k: round(float(figures[k][j]), 2) if k in figures else None for k in self.LABELS}
                           for j, name in enumerate(self.joint_names)}}


def compare(joint_names, joints, fps: float, reference_names, reference, reference_times,
            names: dict[str, str] | None = None, shift: float | str = 0.0, align: bool = False) -> Comparison:
    """Compare a run's (F, J, 3) `joints` (metres, frame f at f / `fps` s, NaN where
    failed) under `joint_names` with a reference's (K, M, 3) positions under
    `reference_names` at `reference_times` (s, plus `shift`; ``"auto"``: the shift
    within ±:data:`MAX_SHIFT` s under which the joints agree best once their offsets are
    removed). `names` maps our joint names to the reference's; by default every joint
    both have, under the same name. With `align` the reference is first moved by the
    rigid motion that lays its joints on ours best (least squares over every frame)."""
    joint_names, reference_names = list(joint_names), list(reference_names)
    joints, reference = np.asarray(joints, float), np.asarray(reference, float)
    times = np.asarray(reference_times, float)
    pairs = names if names is not None else {n: n for n in joint_names if n in reference_names}
    unknown = [n for n in pairs if n not in joint_names]
    absent = [r for r in pairs.values() if r not in reference_names]
    if unknown:
        raise ResultsError(f"joint names not found among ours {joint_names}: {unknown}")
    if absent:
        raise ResultsError(f"joint names not found among the reference's {reference_names}: {absent}")
    if not pairs:
        raise ResultsError(f"the run's joints {joint_names} and the reference's {reference_names} share no name: "
                           "map them (names)")
    ours = joints[:, [joint_names.index(n) for n in pairs]]
    theirs = reference[:, [reference_names.index(r) for r in pairs.values()]]
    if isinstance(shift, str):
        if shift != "auto":
            raise ResultsError(f"shift is a number of seconds or 'auto', got {shift!r}")
        shift = _best_shift(ours, fps, theirs, times, align)
    ours_at, theirs, compared, alignment = _matched(ours, fps, theirs, times + shift, align)
    if ours_at is None:
        raise ResultsError(f"no frame of the reference falls within the run's tracked frames (0 to "
                           f"{len(joints) / fps:.2f} s; the reference's times {times[0]:.2f} to {times[-1]:.2f} s, "
                           f"shifted by {shift} s)")
    err = ours_at - theirs
    lengths = {"raw_mm": _lengths_mm(err), "offset_removed_mm": _lengths_mm(_without_offset(err))}
    if all(n in pairs for n in TRUNK):
        lengths["body_offset_removed_mm"] = _lengths_mm(_without_offset(in_body_frame(list(pairs), theirs, err)))
    with np.errstate(invalid="ignore"):
        per_joint = {k: np.nanmean(v, axis=0) for k, v in lengths.items()}
        over_time = {k: np.nanmean(v, axis=1) for k, v in lengths.items()}
    return Comparison(tuple(pairs), int(compared.sum()), int((~compared).sum()), per_joint["raw_mm"],
                      per_joint["offset_removed_mm"], per_joint.get("body_offset_removed_mm"), float(shift), alignment,
                      (times + shift)[compared], over_time)


MAX_SHIFT = 1.0
"""The largest clock difference (s) ``shift="auto"`` looks for: two systems started by
hand, or a trigger's delay."""


def _matched(ours, fps: float, theirs, times, align: bool):
    """``(ours, theirs, compared, alignment)``: our joints at the reference's `times` and
    the reference's, on the frames where we have joints (`compared`, a mask of them),
    the reference moved into our world by `alignment` (``(R, t)``) when `align`; the
    first two None when no frame has ours."""
    ours_at = _interpolated(ours, fps, times)
    compared = ~np.isnan(ours_at).all(axis=(1, 2))
    if not compared.any():
        return None, None, compared, None
    ours_at, theirs = ours_at[compared], theirs[compared]
    alignment = _rigid(theirs, ours_at) if align else None
    if alignment is not None:
        theirs = theirs @ alignment[0].T + alignment[1]
    return ours_at, theirs, compared, alignment


def _best_shift(ours, fps: float, theirs, times, align: bool) -> float:
    """The shift (s) within ±:data:`MAX_SHIFT` under which the joints' mean error, each
    joint's offset removed, is least: on a grid of a quarter of our frame, then a
    fortieth around its best."""
    def cost(shift):
        at, other, compared, _ = _matched(ours, fps, theirs, times + shift, align)
        return np.inf if compared.sum() < 2 else float(np.nanmean(offset_removed_mm(at - other)))

    step = 0.25 / fps
    coarse = np.arange(-MAX_SHIFT, MAX_SHIFT + step / 2, step)
    best = coarse[int(np.argmin([cost(s) for s in coarse]))]
    fine = best + np.arange(-step, step + step / 20, step / 10)
    return float(fine[int(np.argmin([cost(s) for s in fine]))])


def _rigid(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)``, the rotation and translation that move the (K, J, 3) `source` points
    nearest the `target` ones in least squares (Kabsch), over the pairs both hold."""
    a, b = source.reshape(-1, 3), target.reshape(-1, 3)
    both = ~(np.isnan(a).any(1) | np.isnan(b).any(1))
    if both.sum() < 3:
        raise ResultsError("too few joints in both to align the reference (3 needed)")
    a, b = a[both], b[both]
    ca, cb = a.mean(0), b.mean(0)
    U, _, Vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, cb - R @ ca


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
    a TRC file (`up` its up axis), a C3D file (our world's axes; needs ezc3d), the
    results folder of another run (failed frames NaN), or a sequence folder with ground
    truth (:func:`~hullcap._evaluate.read_truth_joints`, at its ``meta.json``'s rate)."""
    from hullcap._evaluate import TRUTHS, read_truth_joints
    from hullcap._files import read_document
    from hullcap.export import load_result
    from hullcap.export import read_c3d, read_trc

    path = Path(path)
    if path.is_dir():
        if (path / "pose.npz").is_file():
            other = load_result(path)
            return list(other.model.joint_names), other.joints, np.arange(len(other.joints)) / other.fps
        truth = read_truth_joints(path)
        if truth is None:
            raise ResultsError(f"{path}: neither a run's results folder (pose.npz) nor a sequence with ground truth "
                               f"({' or '.join(TRUTHS)})")
        fps = read_document(path / "meta.json", ResultsError).get("fps")
        if not (isinstance(fps, (int, float)) and 0 < fps < np.inf):
            raise ResultsError(f"{path / 'meta.json'}: needs the sequence's fps, got {fps!r}")
        names, positions = truth
        return names, positions, np.arange(len(positions)) / fps
    suffix = path.suffix.lower()
    if suffix == ".trc":
        return read_trc(path, up=up)
    if suffix == ".c3d":
        labels, points, rate = read_c3d(path)
        return labels, points, np.arange(len(points)) / rate
    raise ResultsError(f"{path}: a reference is a .trc or .c3d file, a results folder or a sequence with ground truth")


def compare_run(out, reference, names=None, shift: float | str = 0.0, up: str = "y",
                align: bool = False) -> Comparison:
    """:func:`compare` a finished run's results folder `out` with the `reference` of
    :func:`reference_joints`; `names` a mapping or a JSON file of one (ours → theirs)."""
    from hullcap.export import load_result

    result = load_result(out)
    if names is not None and not isinstance(names, dict):
        try:
            names = json.loads(Path(names).read_text())
        except (OSError, ValueError) as e:
            raise ResultsError(f"{names}: not a readable JSON mapping of joint names ({e})") from None
        if not isinstance(names, dict) or not all(isinstance(v, str) for v in names.values()):
            raise ResultsError("the joint names' mapping must be a JSON object of our names to the reference's")
    ref_names, ref, times = reference_joints(reference, up)
    return compare(result.model.joint_names, result.joints, result.fps, ref_names, ref, times, names, shift, align)
