"""Accuracy of a tracking run against a synthetic sequence's ground truth."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hullcap._fitting import angles_by_name

__all__ = ["Accuracy", "accuracy", "true_joints"]


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


def true_joints(result, sequence_path) -> np.ndarray:
    """(F, J, 3) the true joint positions of the frames `result` tracked, in the order of
    its model's joints, from ``truth/`` of a synthetic sequence."""
    with np.load(Path(sequence_path) / "truth" / "joints.npz") as z:
        names = tuple(str(n) for n in z["names"])
        positions = z["positions"][: len(result.failed)]
    return positions[:, [names.index(j) for j in result.model.joint_names]]


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
