"""The development set: realistic bodies (not our template) driven by real motion capture.

The set lives outside the repository as packed sequences with their own renderer and
scorer (``render_packed.py``, ``score.py``, ``roles.json``). This module finds it, renders
a sequence once into an ignored cache folder (``data/devset/``), and scores a tracking
result against its ground truth the way its ``score.py`` does: per joint, the raw error
(MPJPE) and the error once each joint's constant offset over the frames is removed (what
differing joint-centre conventions of two rigs alone would explain). It also removes
each joint's constant offset in the body's own frame (:mod:`hullcap._compare`): a
convention is a place inside the body, and where the person turns round (d02 turns by
180°) a constant offset in the body turns with it and is no constant in the world.

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

from hullcap._compare import in_body_frame, offset_removed_mm
from hullcap._results import FAILED, GOOD, RECOVERED
from hullcap._sequence import MIN_CAMERAS

REPO = Path(__file__).resolve().parent.parent
CACHE = REPO / "data" / "devset"
LIMBS = {"upper arm": ("shoulder", "elbow"), "forearm": ("elbow", "wrist"),
         "thigh": ("hip", "knee"), "shin": ("knee", "ankle")}
"""Limb lengths checked: the distance between two joints, both sides averaged."""
CALIBRATION_SECONDS = 1.0
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


def subsampled(sequence: Path, every: int) -> Path:
    """A sequence folder beside `sequence` holding every `every`-th of its frames, as a
    camera filming the same motion at 1/`every` of its frame rate would give them: the
    images (and silhouettes) as links to the originals, ``meta.json`` at the lower rate,
    the ground truth (``gt/``) of the frames kept. Made once; `sequence` itself for 1."""
    if every == 1:
        return sequence
    if every < 1:
        raise ValueError(f"every must be a positive whole number, got {every}")
    out = sequence.parent / f"{sequence.name}-every{every}"
    if (out / "meta.json").is_file():
        return out
    meta = json.loads((sequence / "meta.json").read_text())
    kept = range(0, int(meta["frames"]), every)
    out.mkdir(parents=True, exist_ok=True)
    for shared in ("cameras.json", "background", "gt/faces.npy"):
        if (sequence / shared).exists():
            (out / shared).parent.mkdir(parents=True, exist_ok=True)
            (out / shared).unlink(missing_ok=True)
            (out / shared).symlink_to((sequence / shared).resolve())
    for kind in ("frames", "silhouettes"):
        for cam in sorted(p for p in (sequence / kind).glob("*") if p.is_dir()):
            (out / kind / cam.name).mkdir(parents=True, exist_ok=True)
            for i, f in enumerate(kept):
                (src,) = cam.glob(f"{f:06d}.*")
                link = out / kind / cam.name / f"{i:06d}{src.suffix}"
                link.unlink(missing_ok=True)
                link.symlink_to(src.resolve())
    if (sequence / "gt" / "joints.npz").is_file():
        (out / "gt").mkdir(exist_ok=True)
        with np.load(sequence / "gt" / "joints.npz") as z:
            np.savez(out / "gt" / "joints.npz", **{k: z[k][::every] if k == "positions" else z[k] for k in z.files})
    if (sequence / "gt" / "vertices.npy").is_file():
        np.save(out / "gt" / "vertices.npy", np.load(sequence / "gt" / "vertices.npy", mmap_mode="r")[::every])
    meta.update(fps=meta["fps"] / every, frames=len(kept))
    (out / "meta.json").write_text(json.dumps(meta))  # last: it marks the folder complete
    return out


def spread_cameras(cameras, k: int | None) -> list[str] | None:
    """The names of `k` of `cameras` spread evenly round the rig (by the azimuth of each
    centre about theirs, every n/k-th from the file's first): a rig of fewer cameras filming the
    same take. ``None`` (every camera) when `k` is ``None`` or as many as there are."""
    if k is None or k >= len(cameras):
        return None
    if k < MIN_CAMERAS:
        raise ValueError(f"a visual hull needs at least {MIN_CAMERAS} cameras, got {k}")
    centres = np.array([c.centre for c in cameras])
    offset = centres[:, :2] - centres[:, :2].mean(0)
    ring = np.argsort(np.arctan2(offset[:, 1], offset[:, 0]), kind="stable").tolist()
    ring = ring[ring.index(0):] + ring[: ring.index(0)]  # from the first camera of the file
    picked = sorted(ring[int(i * len(cameras) / k + 0.5)] for i in range(k))
    return [cameras[i].name for i in picked]


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


SURFACE_SAMPLES = 25_000
"""Points drawn on a frame's true body surface: about as many as its hull has vertices."""


class TrueSurfaces:
    """The ground truth's body surface of each frame of a sequence as a hull would give it:
    points drawn uniformly by area on the mesh's largest connected part (the skin; the
    eyes and the inside of the mouth are parts of their own), with their faces' outward
    normals. The same points of the same triangles in every frame, so they move with the
    body. What tracking would get from a perfect hull (``bench_devset.py --silhouettes
    surface``)."""

    def __init__(self, sequence: Path, samples: int = SURFACE_SAMPLES, seed: int = 0):
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        self._vertices = np.load(sequence / "gt" / "vertices.npy", mmap_mode="r")
        faces = np.load(sequence / "gt" / "faces.npy")
        n = self._vertices.shape[1]
        edges = coo_matrix((np.ones(faces.size), (faces.ravel(), np.roll(faces, 1, axis=1).ravel())), shape=(n, n))
        _, part = connected_components(edges, directed=False)
        skin = part[faces[:, 0]] == np.bincount(part).argmax()
        rest = np.asarray(self._vertices[0], float)
        area = np.linalg.norm(np.cross(rest[faces[:, 1]] - rest[faces[:, 0]], rest[faces[:, 2]] - rest[faces[:, 0]]),
                              axis=1) * skin
        rng = np.random.default_rng(seed)
        self._faces = faces[rng.choice(len(faces), samples, p=area / area.sum())]
        u, v = rng.random(samples), rng.random(samples)
        outside = u + v > 1  # reflected back into the triangle: uniform over it
        u[outside], v[outside] = 1 - u[outside], 1 - v[outside]
        self._u, self._v = u[:, None], v[:, None]

    def __call__(self, frame: int):
        """The true surface of `frame` (a :class:`hullcap._mesh.Surface` without faces)."""
        from hullcap._mesh import Surface

        x = np.asarray(self._vertices[frame], float)
        a, b, c = (x[self._faces[:, k]] for k in range(3))
        normals = np.cross(b - a, c - a)
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        return Surface(a + self._u * (b - a) + self._v * (c - a), np.zeros((0, 3), np.int64), normals)


FALSE_GOOD_MEAN_MM = 80.0
FALSE_GOOD_JOINT_MM = 150.0
"""A frame the tracker calls good (or recovered) is false-good when its mean joint error is
over the first or any joint's over the second (a limb, not a convention, is wrong)."""
PCK_MM = 150.0
"""3DPCK's threshold: a joint within this distance of the truth counts as found."""
EASY_MM = 40.0
"""Frames whose mean joint error is under this should be marked good."""


def honesty(joint_err: np.ndarray, status: np.ndarray) -> dict:
    """``{"false_good": frames, "pck150": percent, "good_40": percent}`` of a run: its
    frames claimed (status good or recovered, :data:`hullcap._results.STATUS_NAMES`) whose
    error, `joint_err` (F, J) metres, makes them false-good (:data:`FALSE_GOOD_MEAN_MM`);
    the share of joint positions within :data:`PCK_MM`, a failed frame's joints all
    counted as misses; and the share of the frames under :data:`EASY_MM` mean error that
    are marked good (NaN without such frames): honesty not bought by doubting everything."""
    status = np.asarray(status)
    claimed = np.isin(status, (GOOD, RECOVERED))
    mm = 1000 * np.asarray(joint_err, float)
    with np.errstate(invalid="ignore"):
        wrong = claimed & ((mm.mean(1) > FALSE_GOOD_MEAN_MM) | (mm.max(1) > FALSE_GOOD_JOINT_MM))
        easy = mm.mean(1) < EASY_MM
        found = np.nan_to_num(mm, nan=np.inf)[status != FAILED] <= PCK_MM
    return {"false_good": int(wrong.sum()), "pck150": float(100 * found.sum() / max(1, joint_err.size)),
            "good_40": float(100 * (status[easy] == GOOD).mean()) if easy.any() else float("nan")}


def model_limb_lengths(model) -> dict[str, float]:
    """The limb lengths of a body model at rest (metres)."""
    return _limb_lengths(list(model.joint_names), model.pose().joints[None])


@dataclass
class Score:
    frames: int
    lost: int
    mpjpe_mm: float
    mpjpe_offset_removed_mm: float
    mpjpe_body_offset_removed_mm: float
    per_joint_mm: dict[str, float]


def score(truth: Truth, joint_names, joints: np.ndarray, failed: np.ndarray,
          frames: slice = slice(None)) -> Score:
    """Raw and offset-removed joint errors over `frames` (as the set's ``score.py``), and
    offset-removed in the truth's body frame (:func:`hullcap._compare.in_body_frame`):
    `joints` (F, J, 3) under `joint_names`, `failed` (F,) frames count as lost."""
    idx = [list(joint_names).index(n) for n in truth.names]
    got = np.asarray(joints, float)[frames][:, idx]
    want = truth.positions[: len(joints)][frames]
    lost = np.asarray(failed, bool)[frames]
    err = np.where(lost[:, None, None], np.nan, got - want)
    raw = np.nanmean(np.linalg.norm(err, axis=2), axis=0) * 1e3
    in_body = in_body_frame(truth.names, want, err)
    return Score(len(lost), int(lost.sum()), float(raw.mean()), float(offset_removed_mm(err).mean()),
                 float(offset_removed_mm(in_body).mean()), dict(zip(truth.names, raw.round(1).tolist())))
