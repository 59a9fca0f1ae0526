"""Tracking a whole sequence (DESIGN.md §9): frame by frame, streamed, resumable.

For each frame: silhouettes (given, or by background subtraction) → visual hull → a fit
from the pose predicted by constant velocity → a check of the fit (inlier fraction and
mean residual); a bad fit is retried from the previous pose and from perturbed starts, and
a frame that still fails is marked failed while tracking goes on. The first frame builds
the subject's model (:mod:`hullcap.subject`) unless one is given.

Outputs (FORMATS.md): ``joints.csv``, ``pose.npz``, ``model/``, ``motion.bvh``,
``model.glb``; all written atomically.
A checkpoint (``.checkpoint.npz``) written every few frames lets an interrupted run
resume where it stopped.
"""

from __future__ import annotations

import io
import time
import warnings
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.body import BodyModel
from hullcap.export.bvh import write_bvh
from hullcap.export.gltf import write_glb
from hullcap.fitting import FitOptions, FitResult, PoseParameters, fit, make_target, yaw_rotation
from hullcap.hull import HullReport, capture_volume, visual_hull
from hullcap.progress import progress
from hullcap.sequence import Sequence
from hullcap.silhouette import background_model
from hullcap.subject import build_subject, place_model

__all__ = ["Tracker", "TrackingResult", "write_outputs", "load_result"]

CHECKPOINT = ".checkpoint.npz"


@dataclass
class TrackingResult:
    """Per-frame results of a run (F frames); failed frames hold NaN."""

    model: BodyModel
    fps: float
    theta: np.ndarray
    root_rotation: np.ndarray
    root_translation: np.ndarray
    joints: np.ndarray
    failed: np.ndarray
    energy: np.ndarray
    inlier_fraction: np.ndarray
    mean_residual: np.ndarray
    iterations: np.ndarray
    seconds: dict = field(default_factory=dict)
    """Seconds spent per stage: silhouettes, hull, fit, subject."""

    @classmethod
    def empty(cls, model: BodyModel, n: int, fps: float) -> TrackingResult:
        nan = lambda *shape: np.full((n, *shape), np.nan)  # noqa: E731
        return cls(model, fps, nan(model.n_dofs), nan(3, 3), nan(3), nan(len(model.joint_names), 3),
                   np.ones(n, bool), nan(), nan(), nan(), np.zeros(n, np.int64))

    @classmethod
    def from_arrays(cls, model: BodyModel, a) -> TrackingResult:
        """A result from the arrays of :meth:`arrays` (a checkpoint, or ``pose.npz``,
        whose joints are recomputed from the model)."""
        joints = a["joints"] if "joints" in a else None
        result = cls(model, float(a["fps"]), a["theta"], a["root_rotation"], a["root_translation"],
                     np.full((len(a["theta"]), len(model.joint_names), 3), np.nan) if joints is None else joints,
                     a["failed"], a["energy"], a["inlier_fraction"], a["mean_residual"], a["iterations"])
        if joints is None:
            for f in np.flatnonzero(~result.failed):
                result.joints[f] = model.pose(result.theta[f], result.root_rotation[f],
                                              result.root_translation[f], clamp=False).joints
        return result

    def record(self, frame: int, result: FitResult) -> None:
        p = result.pose
        self.theta[frame], self.root_rotation[frame], self.root_translation[frame] = p.theta, p.root_rotation, p.root_translation
        self.joints[frame] = self.model.pose(p.theta, p.root_rotation, p.root_translation).joints
        self.failed[frame] = False
        self.energy[frame], self.inlier_fraction[frame] = result.energy, result.inlier_fraction
        self.mean_residual[frame], self.iterations[frame] = result.mean_residual, result.iterations

    def arrays(self) -> dict:
        return {"root_translation": self.root_translation, "root_rotation": self.root_rotation,
                "theta": self.theta, "dof_names": np.array(self.model.dof_names),
                "joint_names": np.array(self.model.joint_names), "failed": self.failed,
                "energy": self.energy, "inlier_fraction": self.inlier_fraction,
                "mean_residual": self.mean_residual, "iterations": self.iterations,
                "joints": self.joints, "fps": self.fps}


@dataclass
class Tracker:
    """Tracks a sequence folder.

    Attributes:
        sequence: the input (:class:`~hullcap.sequence.Sequence`).
        model: the subject's model; ``None`` = build it from the first frame.
        voxel_size: hull resolution (metres).
        background: ``"statistical"`` or ``"mog2"``, used when the sequence has no
            silhouettes (or `use_silhouettes` is False).
        use_silhouettes: use the sequence's silhouettes when it has them.
        min_inlier_fraction, max_mean_residual: a fit passes when at least this fraction
            of model points lies within 2 cm of the hull and the mean pair distance is
            at most this (metres). A hull bulges beyond the body between the views
            (more with fewer cameras and in crouched poses): a good fit on 6–8 cameras
            has 75–85 % inliers and 13–16 mm mean distance, a lost limb far less.
        retries: perturbed restarts tried after a failed fit.
        fit_options: passed to :func:`hullcap.fitting.fit` (default: two hierarchical
            passes; a frame starts close to its answer).
    """

    sequence: Sequence
    model: BodyModel | None = None
    voxel_size: float = 0.01
    background: str = "statistical"
    use_silhouettes: bool = True
    min_inlier_fraction: float = 0.6
    max_mean_residual: float = 0.03
    retries: int = 4
    fit_options: FitOptions = field(default_factory=lambda: FitOptions(rounds=2))
    seed: int = 0

    def __post_init__(self):
        self._bounds = capture_volume(self.sequence.cameras)
        self._backgrounds = None
        self.seconds: dict = defaultdict(float)
        self.problems: list[str] = []
        """Frames and views left out, and why."""

    # -- one frame ---------------------------------------------------------------------

    def masks(self, frame: int) -> list[np.ndarray]:
        """The silhouettes of `frame`, given or by background subtraction."""
        t0 = time.perf_counter()
        seq = self.sequence
        if self.use_silhouettes and seq.has_silhouettes:
            masks = []
            for cam in seq.cameras:
                try:
                    masks.append(seq.mask(frame, cam.name))
                except ValueError as e:  # a missing or broken mask: leave that view out
                    self.problems.append(f"frame {frame}: {e}")
                    masks.append(np.zeros((cam.height, cam.width), np.uint8))
        else:
            if self._backgrounds is None:
                self._backgrounds = [background_model(seq.background(i), self.background)
                                     for i in range(len(seq.cameras))]
            masks = [m.mask(img) for m, img in zip(self._backgrounds, seq.images(frame))]
        self.seconds["silhouettes"] += time.perf_counter() - t0
        return masks

    def hull(self, frame: int):
        masks = self.masks(frame)
        t0 = time.perf_counter()
        report = HullReport()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # views left out are recorded in `problems`
            surface = visual_hull(masks, self.sequence.cameras, self.voxel_size, self._bounds, report)
        self.problems += [f"frame {frame}: camera {c!r} left out ({why})" for c, why in report.skipped.items()]
        self.seconds["hull"] += time.perf_counter() - t0
        return surface

    def passes(self, result: FitResult) -> bool:
        return (result.inlier_fraction >= self.min_inlier_fraction
                and result.mean_residual <= self.max_mean_residual)

    def fit_frame(self, model: BodyModel, surface, starts: list[PoseParameters]) -> tuple[FitResult, bool]:
        """Fit from each start in turn, then from `retries` perturbed copies of the first,
        until a fit passes. Returns the best fit and whether it passed."""
        t0 = time.perf_counter()
        target = make_target(surface)
        best = None
        for start in self._candidates(model, starts):
            result = fit(model, target, start, self.fit_options)
            if best is None or (self.passes(result), -result.energy) > (self.passes(best), -best.energy):
                best = result
            if self.passes(result):
                break
        self.seconds["fit"] += time.perf_counter() - t0
        return best, self.passes(best)

    def _candidates(self, model: BodyModel, starts: list[PoseParameters]):
        yield from starts
        rng = np.random.default_rng(self.seed)
        lim = model.link_model.dof_limits
        base = starts[0]
        for _ in range(self.retries):
            turn = yaw_rotation(rng.normal(0, 0.15))
            yield PoseParameters(np.clip(base.theta + rng.normal(0, 0.15, model.n_dofs), lim[:, 0], lim[:, 1]),
                                 turn @ base.root_rotation, base.root_translation + rng.normal(0, 0.03, 3))

    # -- the sequence ------------------------------------------------------------------

    def run(self, out, resume: bool = True, show_progress: bool = True, frames: int | None = None) -> TrackingResult:
        """Track the sequence into folder `out` (see the module documentation)."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        n = len(self.sequence) if frames is None else min(frames, len(self.sequence))
        result, start = self._resume(out, n) if resume else (None, 0)
        if result is None:
            model = self.model
            t0 = time.perf_counter()
            first = self.hull(0)
            if model is None:
                subject = build_subject(first)
                model, first_fit = subject.model, subject.fit
            else:
                first_fit = place_model(model, first)
            self.seconds["subject"] += time.perf_counter() - t0
            model.save(out / "model")
            result = TrackingResult.empty(model, n, self.sequence.fps)
            result.record(0, first_fit)
            result.failed[0] = not self.passes(first_fit)
            start = 1
        model = result.model
        bar = progress(range(start, n), total=n, desc=f"track {self.sequence.path.name}", enable=show_progress,
                       initial=start)
        for frame in bar:
            try:
                surface = self.hull(frame)
            except ValueError as e:  # no usable view in this frame
                self.problems.append(f"frame {frame}: {e}")
                result.failed[frame] = True
                continue
            fitted, ok = self.fit_frame(model, surface, self._starts(result, frame))
            result.record(frame, fitted)
            result.failed[frame] = not ok
            if frame % 10 == 0:
                self._checkpoint(out, result, frame + 1)
        result.seconds = dict(self.seconds)
        write_outputs(out, result)
        (out / CHECKPOINT).unlink(missing_ok=True)
        return result

    def _starts(self, result: TrackingResult, frame: int) -> list[PoseParameters]:
        """Constant-velocity prediction from the last two good frames, then the last good
        pose itself."""
        good = [f for f in range(frame - 1, -1, -1) if not result.failed[f]][:2]
        if not good:
            good = [0]
        last = PoseParameters(result.theta[good[0]], result.root_rotation[good[0]], result.root_translation[good[0]])
        if len(good) < 2 or good[0] - good[1] != 1 or good[0] != frame - 1:
            return [last]
        a, b = good[1], good[0]
        lim = result.model.link_model.dof_limits
        theta = np.clip(2 * result.theta[b] - result.theta[a], lim[:, 0], lim[:, 1])
        turn = result.root_rotation[b] @ result.root_rotation[a].T
        predicted = PoseParameters(theta, turn @ result.root_rotation[b],
                                   2 * result.root_translation[b] - result.root_translation[a])
        return [predicted, last]

    def _checkpoint(self, out: Path, result: TrackingResult, next_frame: int) -> None:
        buf = io.BytesIO()
        np.savez(buf, next_frame=next_frame, sequence=str(self.sequence.path.resolve()), **result.arrays())
        atomic_write(out / CHECKPOINT, buf.getvalue())

    def _resume(self, out: Path, n: int):
        path = out / CHECKPOINT
        if not path.is_file() or not (out / "model").is_dir():
            return None, 0
        with np.load(path) as z:
            if str(z["sequence"]) != str(self.sequence.path.resolve()) or len(z["failed"]) != n:
                return None, 0
            result = TrackingResult.from_arrays(BodyModel.load(out / "model"), {k: z[k] for k in z.files})
            return result, int(z["next_frame"])


def write_outputs(out, result: TrackingResult) -> None:
    """Write ``joints.csv``, ``pose.npz`` (FORMATS.md), ``motion.bvh`` and ``model.glb``,
    each atomically."""
    out = Path(out)
    write_joints_csv(out / "joints.csv", result)
    buf = io.BytesIO()
    arrays = result.arrays()
    arrays.pop("joints")
    np.savez(buf, **arrays)
    atomic_write(out / "pose.npz", buf.getvalue())
    if (~result.failed).any():
        motion = (result.model, result.root_translation, result.root_rotation, result.theta, result.fps)
        write_bvh(out / "motion.bvh", *motion)
        write_glb(out / "model.glb", *motion)


def write_joints_csv(path, result: TrackingResult) -> None:
    """``joints.csv``: one row per fitted frame and joint (FORMATS.md)."""
    lines = ["frame,time,joint,x,y,z"]
    names = result.model.joint_names
    for f in np.flatnonzero(~result.failed):
        t = f / result.fps
        for name, (x, y, z) in zip(names, result.joints[f]):
            lines.append(f"{f},{t:.6f},{name},{x:.6f},{y:.6f},{z:.6f}")
    atomic_write(Path(path), ("\n".join(lines) + "\n").encode())


def load_result(out) -> TrackingResult:
    """A finished run's results from its folder (``pose.npz`` and ``model/``)."""
    out = Path(out)
    model = BodyModel.load(out / "model")
    path = out / "pose.npz"
    try:
        with np.load(path) as z:
            a = {k: z[k] for k in z.files}
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: not a readable pose.npz ({e})") from e
    missing = set(TrackingResult.empty(model, 0, 1.0).arrays()) - {"joints"} - a.keys()
    if missing:
        raise ValueError(f"{path}: missing {sorted(missing)}")
    return TrackingResult.from_arrays(model, a)
