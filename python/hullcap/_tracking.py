"""Tracking a whole sequence (docs/design.md, "Tracking"): frame by frame, streamed,
resumable.

The subject's model is built at the first frame whose hull it explains (the calibration
pose) and, unless told otherwise, refined: the first seconds are tracked with it, and its
proportions and joint centres are fitted again over frames of that motion, where the
joints bend (:func:`hullcap.build_subject`). Tracking then starts over with the refined
model.

Each frame: silhouettes (given, or by background subtraction guided by the predicted
model) → visual hull → a fit from the pose predicted by constant velocity, then from the
last good pose → a judgement of the fit: its quality (how much of the hull it explains
both ways, ½(inlier fraction + coverage)), and each limb's, against the median of the
recent accepted frames. A fit below them starts a search from the hull itself
(:mod:`hullcap._reacquire`), which says what this frame's hull can give: the tracked fit
stands when the search finds nothing better (``good``), the search's fit when it does
(``recovered``), and the frame is ``failed`` when nothing explains its hull to
``min_quality``.

A broken image of one camera leaves that view out of that frame (the hull and fit use the
others) and is recorded in ``problems.json`` (:mod:`hullcap._problems`); only a frame with
too few usable views is lost.

Outputs (docs/formats.md): ``joints.csv``, ``pose.npz``, ``model/``, ``motion.bvh``,
``model.glb``, ``report.png``, ``problems.json`` (and overlays when asked), all written
atomically. A checkpoint (``.checkpoint.npz``) written every few frames, and kept until
every output is written, lets an interrupted run resume where it stopped.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import time
from collections import defaultdict
from contextlib import suppress
from dataclasses import replace
from pathlib import Path

import numpy as np

from hullcap._body import BodyModel
from hullcap._carver import Carver
from hullcap._cameras import capture_volume, check_bounds
from hullcap._files import NPZ_ERRORS, atomic_write
from hullcap._frame_fitter import FrameFitter
from hullcap._fitting import PoseParameters, fit, make_target
from hullcap._problems import ProblemLog
from hullcap._progress import progress
from hullcap._render import model_silhouettes
from hullcap._run_folder import check_room, check_writable, clear
from hullcap._results import TrackingResult, check_cutoff
from hullcap._segmenter import Segmenter, spread
from hullcap._sequence import MIN_CAMERAS, Sequence
from hullcap._subject import bent_frames, build_subject, fitted_surface, place_model, search_centres
from hullcap._threads import over_fits
from hullcap._tracking_options import TrackerOptions, settings
from hullcap._tracking_state import TrackingState
from hullcap.errors import OptionsError, ResultsError, SequenceError, TrackingError
from hullcap.export import write_outputs, write_overlays, write_report

__all__ = ["Tracker", "TrackerOptions"]

# The checkpoint's arrays of what a run learnt besides its results (Tracker._learnt);
# what tracking carries from frame to frame has its own (TrackingState.carried).
LEARNT_TEACH_AT = "learnt_teach_at"
LEARNT_COLOURS = ("learnt_colours_subject", "learnt_colours_background")
CHECKPOINT = ".checkpoint.npz"
PROBLEMS = "problems.json"


class Tracker:
    """Tracks a sequence folder (see the module documentation).

    Args:
        sequence: the input: a :class:`Sequence`, or its folder.
        model: the subject's model from an earlier run (``None``: build it).
        options: see :class:`TrackerOptions`.
    """

    def __init__(self, sequence: Sequence | str | os.PathLike, model: BodyModel | None = None,
                 options: TrackerOptions | None = None, bounds=None):
        self.sequence = sequence = sequence if isinstance(sequence, Sequence) else Sequence(sequence)
        if len(sequence.cameras) < MIN_CAMERAS:
            raise SequenceError(f"{sequence.path}: one camera ({sequence.cameras.names[0]!r}) cannot make a visual "
                                f"hull: tracking needs at least {MIN_CAMERAS} calibrated views of the person")
        self.model = model
        self.options = options or TrackerOptions()
        if bounds is None:
            bounds = capture_volume(sequence.cameras)
        self.bounds = check_bounds(bounds)
        """``(lo, hi)``: the capture volume the hull is carved in (metres)."""
        self.seconds: dict = defaultdict(float)
        self.problems = ProblemLog(warn=False)
        """Frames and views left out, and why (:mod:`hullcap._problems`)."""
        self.segmenter = Segmenter(sequence, self.options, self.problems, self.seconds)
        """Each frame's silhouettes (:mod:`hullcap._segmenter`)."""
        self.carver = Carver(self.segmenter, self.options, self.bounds, self.problems, self.seconds)
        """Each frame's visual hull (:mod:`hullcap._carver`)."""
        self.fitter = FrameFitter(self.carver, self.options, self.problems, self.seconds)
        """Each frame's fit, judgement and search (:mod:`hullcap._frame_fitter`)."""
        self.written: list[str] = []
        """The files and folders the last :meth:`run` wrote into its folder."""

    # -- one frame's input -------------------------------------------------------------

    @property
    def given_silhouettes(self) -> bool:
        """Whether it tracks from the sequence's own silhouettes (else it subtracts the
        background)."""
        return self.segmenter.given

    def masks(self, frame: int, priors=None) -> list[np.ndarray]:
        """The silhouettes of `frame`: given, or by background subtraction, guided by the
        predicted model's silhouettes `priors` (one bool mask per view) when the options
        say so."""
        return self.segmenter.segment(frame, priors)[0]

    def _window_end(self, first: int, n: int) -> int:
        """The frame after the first `calibration_seconds` from `first` (at most `n`)."""
        return min(n, first + max(2, int(round(self.options.calibration_seconds * self.sequence.fps))))

    def hull(self, frame: int, prior=None):
        """The visual hull of `frame`, with the model at a predicted pose as its prior
        (`prior`: ``(model, PoseParameters)``): it guides the silhouettes (:meth:`masks`)
        and says where a view that misses a part may be overruled (`hull_tolerance`).
        `HullError` (a `ValueError`) when there is no hull."""
        return self.carver.carve(frame, prior)[0]

    def _agreement(self, masks, model: BodyModel, pose: PoseParameters) -> float:
        """Mean over the views of the IoU of `model`'s silhouette at `pose` and `masks`."""
        ious = []
        for mask, sil in zip(masks, model_silhouettes(self.sequence.cameras, model, pose)):
            union = np.logical_or(mask > 0, sil).sum()
            ious.append(np.logical_and(mask > 0, sil).sum() / union if union else 0.0)
        return float(np.mean(ious))

    # -- the sequence ------------------------------------------------------------------

    def run(self, out, resume: bool = True, show_progress: bool = True, frames: int | None = None,
            interpolate: bool = False, smooth_hz: float | None = None, overlays: bool = False) -> TrackingResult:
        """Track the sequence into folder `out` (see the module documentation): the results,
        ``report.png``, ``problems.json`` and, with `overlays`, ``overlay/<cam>.mp4``.
        `interpolate` and `smooth_hz` go to :func:`hullcap.export.write_outputs`. The
        checkpoint stays until every output is written, so an interruption at any point
        resumes without tracking again what was tracked."""
        if frames is not None and frames < 1:
            raise OptionsError(f"frames must be at least 1, got {frames}")
        if smooth_hz is not None:
            check_cutoff(smooth_hz, self.sequence.fps)  # now, not after tracking
        out = Path(out)
        check_writable(out)
        self.problems.warn = show_progress
        n = self._frames_to_track(frames)
        check_room(out, n * (len(self.sequence.cameras) if overlays else 1))
        settings = self._settings(n)
        result, start, state = self._resume(out, n, settings) if resume else (None, 0, None)
        if result is None:
            clear(out)
            t0, before = time.perf_counter(), dict(self.seconds)
            model, start, anchor = self._subject(n, show_progress)
            window = list(range(start, self._window_end(start, n)))
            self.segmenter.teach_at = self.segmenter.teaching_frames(window)
            # The subject's frames (the calibration pass too) count as 'subject' only, so
            # that the per-stage seconds are those of tracking the sequence once.
            self.seconds.clear()
            self.seconds.update(before)
            self.seconds["subject"] += time.perf_counter() - t0
            tracked = model.with_wrists() if self.options.wrists else model
            tracked.save(out / "model")
            result = TrackingResult.empty(tracked, n, self.sequence.fps)
            state = self.fitter.state(tracked, start, anchor, built=model)
            # The subject's model is the work of minutes: kept before the first frame is tracked.
            self._checkpoint(out, result, start, settings, state.carried(), self.segmenter.learnt())
        bar = progress(range(start, n), total=n, desc=f"track {self.sequence.path.name}", enable=show_progress,
                       initial=start)
        frame, carried, learnt = start, state.carried(), self.segmenter.learnt()
        try:
            with self.segmenter.reading_ahead(range(start, n)):
                for frame in bar:
                    if frame > start:
                        carried, learnt = state.carried(), self.segmenter.learnt()
                    self.fitter.track(state, result, frame)
                    if frame % 10 == 0:
                        self._checkpoint(out, result, frame + 1, settings, state.carried(), self.segmenter.learnt())
        except BaseException:
            # Interrupted, or a fault: every frame tracked before this one is kept, with the
            # state as this frame found it, so that a resume goes on as this run would have.
            with suppress(OSError):
                self._checkpoint(out, result, frame, settings, carried, learnt)
            raise
        bar.close()
        self._checkpoint(out, result, n, settings, state.carried(), self.segmenter.learnt())
        result.seconds = dict(self.seconds)
        self.written = ["model/", *write_outputs(out, result, interpolate, smooth_hz)]
        write_report(out / "report.png", result)
        self.written.append("report.png")
        if overlays:
            write_overlays(out, self.sequence, result, show_progress=show_progress)
            self.written.append("overlay/")
        self.problems.save(out / PROBLEMS)
        self.written.append(PROBLEMS)
        (out / CHECKPOINT).unlink(missing_ok=True)
        return result

    def _settings(self, n: int) -> dict:
        """What decides this run's results besides the sequence (a checkpoint records it:
        :meth:`_resume`): the options, the frames, the image scale, the capture volume
        and the model given, if one was."""
        given = None
        if self.model is not None:
            digest = hashlib.sha256(np.ascontiguousarray(self.model.vertices).tobytes())
            digest.update(np.ascontiguousarray(self.model.links).tobytes())
            given = digest.hexdigest()[:16]
        return {**settings(self.options), "frames": n, "image_scale": self.sequence.image_scale,
                "volume": np.asarray(self.bounds).ravel().tolist(), "model given": given}

    def _frames_to_track(self, frames: int | None) -> int:
        """How many frames to track, after the start-up checks: every camera's frames on
        disk against ``meta.json`` (recorded; frames that no camera has are not tracked)
        and the image size of every camera against its calibration."""
        seq = self.sequence
        n = len(seq) if frames is None else min(frames, len(seq))
        counts = seq.frame_counts(silhouettes=self.given_silhouettes)
        on_disk = ", ".join(f"{name} {k}" for name, k in counts.items())
        if any(k < len(seq) for k in counts.values()):
            self.problems.add(None, f"meta.json says {len(seq)} frames, on disk: {on_disk}; "
                                    f"a camera's missing frames leave its view out")
        elif any(k > len(seq) for k in counts.values()):
            self.problems.add(None, f"meta.json says {len(seq)} frames, on disk: {on_disk}; "
                                    f"only the first {len(seq)} are tracked")
        if not self.given_silhouettes:
            seq.check_image_sizes()
        self.segmenter.prepare()
        return max(1, min(n, max(counts.values())))

    def _subject(self, n: int, show_progress: bool):
        """``(model, first frame, its pose)``: the subject's model, built (and refined) at the
        first frame whose hull it explains, or the given one placed there."""
        options = self.options
        for frame in range(n):
            try:
                hull, masks = self.carver.carve(frame)
            except ValueError as e:
                self.problems.add(frame, str(e))
                continue
            if self.model is not None:
                placed = place_model(self.model, hull, options=options.subject)
                if self._agreement(masks, self.model, placed.pose) >= options.min_subject_agreement:
                    self.segmenter.learn_colours(frame, self.model, placed.pose, fresh=True)
                    return self.model, frame, placed
                continue
            try:
                subject = build_subject(hull, options=options.subject)
                # Silhouettes guided by the model just built see what the first ones missed
                # (clothes the colour of the room): build it again from them, twice.
                for _ in range(2 if self.segmenter.guides else 0):
                    self.segmenter.learn_colours(frame, subject.model, subject.pose, fresh=True)
                    guided, masks = self.carver.carve(frame, (subject.model, subject.pose))
                    subject = build_subject(guided, poses=[subject.pose], options=options.subject)
            except ValueError as e:
                self.problems.add(frame, str(e))
                continue
            agreement = self._agreement(masks, subject.model, subject.pose)
            if agreement < options.min_subject_agreement:
                self.problems.add(frame, f"the body model fitted there agrees too little with the "
                                         f"silhouettes (mean IoU {agreement:.2f}) to start from")
                continue
            if not options.refine_joints:
                return subject.model, frame, subject.fit
            return self._refine(subject, frame, n, show_progress)
        last = f"; the last problem: {self.problems.items[-1]}" if len(self.problems) else ""
        raise TrackingError(f"{self.sequence.path}: no frame of the first {n} shows a body the model can start "
                            f"from{last}")

    def _refine(self, subject, first: int, n: int, show_progress: bool):
        """Track the first seconds with `subject`, fit its proportions and joint centres
        over frames of them, place the hinges' centres from the frames where they bend
        most (:func:`hullcap._subject.search_centres`), give it the subject's own surface
        (:func:`hullcap._subject.fitted_surface`), and return the refined model with its
        pose at `first`."""
        last = self._window_end(first, n)
        window = TrackingResult.empty(subject.model, n, self.sequence.fps)
        # The model is built from these poses: full fits (the girdle start's too, kept only
        # when it explains the hull better), and a search whenever one is not good. The
        # search fits its candidates as tracking does (it mostly confirms the tracked fit);
        # a pose it finds is fitted again in full. No frame of the window fails: a failed
        # frame leaves the next without the prior that guides its silhouettes, and the
        # first model, built from one standing frame, explains a bend less well than the
        # refined one will (d01 from colour frames fell under `min_quality` in its first
        # bend and never came back, which left two thirds of the window unused and the
        # knees placed from three frames; docs/notebooks/accuracy.md). Only the frames whose fits
        # reach `min_quality` build the model. Every fit here, the search's too, steps as
        # `calibration_fit` does (plain by default: the knee search turns on small
        # differences between these poses; `TrackerOptions.fit`).
        strict = replace(self.options, fit=self.options.calibration_fit, quick_fit=None, girdle_fit=None,
                         recheck_margin=None, search=replace(self.options.search, girdle_tolerance=0.0),
                         hull_doubt=None, min_quality=0.0)
        search_fit = self.options.fit.replace(over_relaxation=self.options.calibration_fit.over_relaxation)
        state = TrackingState(subject.model, strict, subject.fit, search_fit=search_fit)
        for frame in progress(range(first, last), total=last - first, desc="subject model", enable=show_progress):
            self.fitter.track(state, window, frame)
        stands = window.quality >= self.options.min_quality
        good = [f for f in range(first, last) if not window.failed[f] and stands[f]]
        if len(good) < 2:
            return subject.model, first, subject.fit
        picks = spread(good, self.options.calibration_frames)
        poses = [window.pose(f) for f in picks]
        for k, (f, pose) in enumerate(zip(picks, poses)):
            self.segmenter.learn_colours(f, subject.model, pose, fresh=k == 0)
        hulls = [self.hull(f, (subject.model, pose)) for f, pose in zip(picks, poses)]
        refined = build_subject(hulls, poses=poses, options=self.options.subject)
        model, moved = refined.model, False
        for joint, axis in self.options.subject.centre_search:
            frames = [good[i] for i in bent_frames(model, window.theta[good], joint, self.options.subject)]
            targets = [make_target(self.hull(f, (subject.model, window.pose(f)))) for f in frames]
            model, move = search_centres(model, joint, axis, targets, [window.pose(f) for f in frames],
                                         self.options.subject)
            moved |= move != 0
        o = self.options.subject
        if o.surface_reach is not None:
            measured = spread(good, o.surface_frames)
            shown = [self.hull(f, (subject.model, window.pose(f))) for f in measured]
            at = over_fits(lambda job, threads: fit(model, make_target(job[0]), job[1], o.fit, threads=threads).pose,
                           [(h, window.pose(f)) for f, h in zip(measured, shown)])
            model, moved = fitted_surface(model, shown, at, o), True
        if not moved:
            return model, first, refined.fit
        return model, first, fit(model, make_target(hulls[0]), refined.pose, self.options.subject.fit)

    def _checkpoint(self, out: Path, result: TrackingResult, next_frame: int, settings: dict, carried: dict,
                    learnt: dict) -> None:
        """Write the checkpoint: the results so far, the frame to go on from, the run's
        `settings`, and what tracking (`carried`, :meth:`TrackingState.carried`) and the
        segmenters (`learnt`, :meth:`_learnt`) carry to that frame."""
        buf = io.BytesIO()
        np.savez(buf, next_frame=next_frame, sequence=str(self.sequence.path.resolve()),
                 cameras=np.array(self.sequence.cameras.names), settings=json.dumps(settings),
                 **result.arrays(), **learnt, **carried)
        self.problems.save(out / PROBLEMS)
        atomic_write(out / CHECKPOINT, buf.getvalue())

    def _resume(self, out: Path, n: int, settings: dict):
        """``(result, next frame, state)`` of the checkpoint in `out`, or ``(None, 0, None)``
        when there is none for this sequence; ResultsError when it was made with other
        cameras or `settings`, naming the difference."""
        path = out / CHECKPOINT
        if not path.is_file() or not (out / "model").is_dir():
            return None, 0, None
        try:
            with np.load(path) as z:
                if str(z["sequence"]) != str(self.sequence.path.resolve()):
                    return None, 0, None
                cameras = self.sequence.cameras.names
                if "cameras" in z.files and z["cameras"].tolist() != cameras:
                    raise ResultsError(f"{path}: this run was tracked with the cameras "
                                       f"{', '.join(z['cameras'].tolist())}, not {', '.join(cameras)}: give the "
                                       f"same cameras to resume it, or --restart (resume=False) to start over")
                if "settings" in z.files:
                    _check_same_settings(path, json.loads(str(z["settings"])), settings)
                elif len(z["failed"]) != n:  # a checkpoint from before settings were kept
                    return None, 0, None
                arrays = {k: z[k] for k in z.files if k not in ("cameras", "settings")}
            self.segmenter.relearn(arrays)
            result, start = TrackingResult.from_arrays(BodyModel.load(out / "model"), arrays), int(arrays["next_frame"])
            state = self.fitter.state(result.model)
            state.resume(arrays, result, start)
        except ResultsError:
            raise
        except (*NPZ_ERRORS, TypeError, json.JSONDecodeError) as e:
            raise ResultsError(f"{path}: the checkpoint is damaged ({e}); run again with --restart "
                               f"(resume=False) to start over") from None
        if (out / PROBLEMS).is_file():
            self.problems.extend(ProblemLog.load(out / PROBLEMS))
        return result, start, state


def _check_same_settings(path: Path, then: dict, now: dict, shown: int = 4) -> None:
    """ResultsError naming the settings (up to `shown`) in which a checkpoint's run, `then`,
    differs from this one, `now`."""
    now = json.loads(json.dumps(now))  # as the checkpoint holds them: tuples as lists
    changed = [k for k in sorted(then.keys() | now.keys()) if then.get(k, "(none)") != now.get(k, "(none)")]
    if changed:
        listed = "; ".join(f"{k}: {then.get(k, '(none)')} then, {now.get(k, '(none)')} now" for k in changed[:shown])
        more = f" and {len(changed) - shown} more" if len(changed) > shown else ""
        raise ResultsError(f"{path}: this run was tracked with other settings ({listed}{more}): give the same "
                           f"options to resume it, or --restart (resume=False) to start over")
