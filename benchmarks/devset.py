"""The development set: realistic bodies (not our template) driven by real motion capture.

The set lives outside the repository as packed sequences with their own renderer and
scorer (``render_packed.py``, ``score.py``, ``roles.json``). This module finds it, renders
a sequence once into an ignored cache folder (``data/devset/``), and scores a tracking
result against its ground truth the way its ``score.py`` does: per joint, the raw error
(MPJPE) and the error once each joint's constant offset over the frames is removed (what
differing joint-centre conventions of two rigs alone would explain).

Where the set is: ``--devset PATH``, else ``$HULLCAP_DEVSET``, else ``../shared/devset``
beside the repository.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
CACHE = REPO / "data" / "devset"
LIMBS = {"upper arm": ("shoulder", "elbow"), "forearm": ("elbow", "wrist"),
         "thigh": ("hip", "knee"), "shin": ("knee", "ankle")}
"""Limb lengths checked: the distance between two joints, both sides averaged."""
CALIBRATION_FRAMES = 30
"""Every development sequence starts with 1 s of a static calibration pose."""


def find(path=None) -> Path | None:
    """The development set's folder, or None when it is not on this machine."""
    for candidate in (path, os.environ.get("HULLCAP_DEVSET"), REPO.parent / "shared" / "devset"):
        if candidate and (Path(candidate) / "packed").is_dir():
            return Path(candidate)
    return None


def names(devset: Path) -> list[str]:
    return sorted(p.stem for p in (devset / "packed").glob("*.npz"))


def render(devset: Path, name: str, cache: Path = CACHE) -> Path:
    """The sequence folder of `name`, rendered into `cache` unless it is there already."""
    out = cache / name
    if not (out / "meta.json").is_file():
        subprocess.run([sys.executable, str(devset / "render_packed.py"), "--out", str(cache), "--only", name],
                       check=True)
    return out


@dataclass
class Truth:
    """The ground-truth joints of a sequence under our joint names (F × J × 3)."""

    names: list[str]
    positions: np.ndarray

    @classmethod
    def load(cls, devset: Path, sequence: Path) -> Truth:
        roles = json.loads((devset / "roles.json").read_text())
        with np.load(sequence / "gt" / "joints.npz") as z:
            theirs = [str(n) for n in z["names"]]
            pos = np.asarray(z["positions"], float)
        ours = [k for k, v in roles.items() if v in theirs]
        return cls(ours, pos[:, [theirs.index(roles[k]) for k in ours]])

    def limb_lengths(self) -> dict[str, float]:
        return _limb_lengths(self.names, self.positions)


def _limb_lengths(names, positions) -> dict[str, float]:
    """Median over frames of each limb's length, left and right averaged (metres)."""
    out = {}
    for limb, (a, b) in LIMBS.items():
        sides = [np.median(np.linalg.norm(positions[:, names.index(f"{s}_{a}")] -
                                          positions[:, names.index(f"{s}_{b}")], axis=-1))
                 for s in "lr"]
        out[limb] = float(np.mean(sides))
    return out


def model_limb_lengths(model) -> dict[str, float]:
    """The limb lengths of a body model at rest (metres)."""
    return _limb_lengths(list(model.joint_names), model.pose().joints[None])


@dataclass
class Score:
    frames: int
    lost: int
    mpjpe_mm: float
    mpjpe_offset_removed_mm: float
    per_joint_mm: dict[str, float]


def score(truth: Truth, joint_names, joints: np.ndarray, failed: np.ndarray,
          frames: slice = slice(None)) -> Score:
    """Raw and offset-removed joint errors over `frames` (as the set's ``score.py``):
    `joints` (F, J, 3) under `joint_names`, `failed` (F,) frames count as lost."""
    idx = [list(joint_names).index(n) for n in truth.names]
    got = np.asarray(joints, float)[frames][:, idx]
    want = truth.positions[: len(joints)][frames]
    lost = np.asarray(failed, bool)[frames]
    err = np.where(lost[:, None, None], np.nan, got - want)
    raw = np.nanmean(np.linalg.norm(err, axis=2), axis=0) * 1e3
    offset_removed = np.nanmean(np.linalg.norm(err - np.nanmean(err, axis=0), axis=2), axis=0) * 1e3
    return Score(len(lost), int(lost.sum()), float(raw.mean()), float(offset_removed.mean()),
                 dict(zip(truth.names, raw.round(1).tolist())))
