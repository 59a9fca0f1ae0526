"""Accuracy of a tracking run against a synthetic sequence's ground truth."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hullcap._fitting import angles_by_name
from hullcap.errors import ResultsError

__all__ = ["Accuracy", "accuracy", "read_truth_joints", "true_joints"]

TRUTHS = ("truth/joints.npz", "gt/joints.npz")
"""Where a sequence folder keeps its ground-truth joints (``names``, ``positions`` F × J ×
3): ``hullcap synth``'s sequences, and the development set's."""


@dataclass(frozen=True)
class Accuracy:
    """Joint position errors (mm) per joint and overall, joint-angle error (degrees)
    and frames lost."""

    joint_names: tuple
    per_joint_mm: np.ndarray
    mean_mm: float
    max_mm: float
    angle_deg: float
    frames: int
    failed: int

    def table(self) -> str:
        rows = [f"{'joint':<12} {'mean error (mm)':>16}"]
        rows += [f"{n:<12} {e:16.1f}" for n, e in zip(self.joint_names, self.per_joint_mm)]
        rows.append(f"{'all joints':<12} {self.mean_mm:16.1f}   (worst single {self.max_mm:.1f} mm)")
        rows.append(f"joint angles: mean error {self.angle_deg:.2f}°; frames lost: {self.failed} of {self.frames}")
        return "\n".join(rows)


def read_truth_joints(sequence_path) -> tuple[list[str], np.ndarray] | None:
    """``(names, (F, J, 3) positions)`` of a sequence folder's ground-truth joints
    (:data:`TRUTHS`), or None when it has none; ResultsError naming the file when it is
    not readable ground truth."""
    from hullcap._files import NPZ_ERRORS

    truth = next((p for p in (Path(sequence_path) / t for t in TRUTHS) if p.is_file()), None)
    if truth is None:
        return None
    try:
        with np.load(truth) as z:
            names, positions = [str(n) for n in z["names"]], np.asarray(z["positions"], float)
    except NPZ_ERRORS as e:
        raise ResultsError(f"{truth}: not readable ground truth ({e})") from None
    if positions.ndim != 3 or positions.shape[1:] != (len(names), 3):
        raise ResultsError(f"{truth}: positions of shape {positions.shape} for {len(names)} names")
    return names, positions


def true_joints(result, sequence_path) -> np.ndarray:
    """(F, J, 3) the true joint positions of the frames `result` tracked, in the order of
    its model's joints, from the ground truth of the sequence (:func:`read_truth_joints`)."""
    truth = read_truth_joints(sequence_path)
    if truth is None:
        raise ResultsError(f"{sequence_path}: no ground truth ({' or '.join(TRUTHS)})")
    names, positions = truth
    return positions[: len(result.failed), [names.index(j) for j in result.model.joint_names]]


def accuracy(result, sequence_path) -> Accuracy:
    """Compare a :class:`~hullcap._tracking.TrackingResult` (or a run folder's
    ``pose.npz`` joints) with ``truth/`` of the sequence it tracked."""
    with np.load(Path(sequence_path) / "truth" / "pose.npz") as z:
        # A DOF the truth's model lacks (a wrist of BodyModel.with_wrists) is straight there.
        true_theta = angles_by_name(z["theta"], [str(n) for n in z["dof_names"]], result.model.dof_names)
    n = len(result.failed)
    ok = ~result.failed
    err = np.linalg.norm(result.joints[ok] - true_joints(result, sequence_path)[ok], axis=2) * 1000
    angle = np.degrees(np.abs(result.theta[ok] - true_theta[:n][ok])).mean() if ok.any() else np.nan
    return Accuracy(result.model.joint_names, err.mean(0), float(err.mean()), float(err.max()),
                    float(angle), n, int(result.failed.sum()))
