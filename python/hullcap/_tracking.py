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

import os
import time
from collections import defaultdict
from contextlib import suppress
from pathlib import Path

from hullcap._body import BodyModel
from hullcap._cameras import capture_volume, check_bounds
from hullcap._carver import Carver
from hullcap._checkpoint import PROBLEMS, Checkpoint, run_settings
from hullcap._files import NPZ_ERRORS
from hullcap._frame_fitter import FrameFitter
from hullcap._options import AT_LEAST_ONE, or_none
from hullcap._problems import ProblemLog
from hullcap._progress import StageSplit, progress
from hullcap._results import TrackingResult, check_cutoff
from hullcap._run_folder import check_room, check_writable, clear
from hullcap._segmenter import Segmenter
from hullcap._sequence import MIN_CAMERAS, Sequence
from hullcap._subject_builder import SubjectBuilder
from hullcap._tracking_options import TrackerOptions
from hullcap.errors import SequenceError
from hullcap.export import write_outputs, write_overlays, write_report

__all__ = ["Tracker", "TrackerOptions"]


class Tracker:
    """Tracks a sequence folder (see the module documentation).

    Args:
        sequence: the input: a :class:`Sequence`, or its folder.
        model: the subject's model from an earlier run (``None``: build it).
        options: see :class:`TrackerOptions`.
        volume: ``(lo, hi)`` or ``(x0, y0, z0, x1, y1, z1)``: the capture volume the hull is
            carved in, metres (``None``: what every camera sees).
    """

    def __init__(self, sequence: Sequence | str | os.PathLike, model: BodyModel | None = None,
                 options: TrackerOptions | None = None, volume=None):
        self.sequence = sequence = sequence if isinstance(sequence, Sequence) else Sequence(sequence)
        if len(sequence.cameras) < MIN_CAMERAS:
            raise SequenceError(f"{sequence.path}: one camera ({sequence.cameras.names[0]!r}) cannot make a visual "
                                f"hull: tracking needs at least {MIN_CAMERAS} calibrated views of the person")
        self.model = model
        self.options = options or TrackerOptions()
        self.volume = check_bounds(capture_volume(sequence.cameras) if volume is None else volume)
        """``(lo, hi)``: the capture volume the hull is carved in (metres)."""
        self.seconds: dict = defaultdict(float)
        self.problems = ProblemLog(warn=False)
        """Frames and views left out, and why (:mod:`hullcap._problems`)."""
        self.segmenter = Segmenter(sequence, self.options, self.problems, self.seconds)
        self.carver = Carver(self.segmenter, self.options, self.volume, self.problems, self.seconds)
        self.fitter = FrameFitter(self.carver, self.options, self.problems, self.seconds)
        self.subject = SubjectBuilder(self.fitter, self.options, self.problems)
        self.written: list[str] = []
        """The files and folders the last :meth:`run` wrote into its folder."""

    def masks(self, frame: int, priors=None) -> list:
        """The silhouettes of `frame` (:meth:`Segmenter.segment`)."""
        return self.segmenter.segment(frame, priors)[0]

    def hull(self, frame: int, prior=None):
        """The visual hull of `frame` (:meth:`Carver.carve`)."""
        return self.carver.carve(frame, prior)[0]

    def run(self, out, resume: bool = True, show_progress: bool = True, frames: int | None = None,
            interpolate: bool = False, smooth_hz: float | None = None, overlays: bool = False) -> TrackingResult:
        """Track the sequence into folder `out` (see the module documentation): the results,
        ``report.png``, ``problems.json`` and, with `overlays`, ``overlay/<cam>.mp4``.
        `interpolate` and `smooth_hz` go to :func:`hullcap.export.write_outputs`. The
        checkpoint stays until every output is written, so an interruption at any point
        resumes without tracking again what was tracked."""
        or_none(AT_LEAST_ONE).check("frames", frames)
        if smooth_hz is not None:
            check_cutoff(smooth_hz, self.sequence.fps)  # now, not after tracking
        out = Path(out)
        check_writable(out)
        self.problems.warn = show_progress
        n = self.segmenter.prepare(frames)
        check_room(out, n * (len(self.sequence.cameras) if overlays else 1))
        settings = run_settings(self.options, n, self.sequence, self.volume, self.model, self.segmenter.learned)
        checkpoint = Checkpoint(out, self.sequence, settings)
        result, start, state = self._resume(checkpoint, n) if resume else (None, 0, None)
        if result is None:
            clear(out)
            result, start, state = self._start(out, n, show_progress)
            # The subject's model is the work of minutes: kept before the first frame is tracked.
            checkpoint.write(result, start, state.carried(), self.segmenter.learnt(), self.problems)
        bar = progress(range(start, n), total=n, desc=f"track {self.sequence.path.name}", enable=show_progress,
                       initial=start)
        frame, carried, learnt = start, state.carried(), self.segmenter.learnt()
        split = StageSplit(self.seconds)
        try:
            with self.segmenter.reading_ahead(range(start, n)):
                for frame in bar:
                    if frame > start:
                        carried, learnt = state.carried(), self.segmenter.learnt()
                    self.fitter.track(state, result, frame)
                    bar.set_postfix_str(split.line(frame + 1 - start, self.segmenter.reading_seconds), refresh=False)
                    if frame % 10 == 0:
                        checkpoint.write(result, frame + 1, state.carried(), self.segmenter.learnt(), self.problems)
        except BaseException:
            # Interrupted, or a fault: every frame tracked before this one is kept, with the
            # state as this frame found it, so that a resume goes on as this run would have.
            with suppress(OSError):
                checkpoint.write(result, frame, carried, learnt, self.problems)
            raise
        bar.close()
        checkpoint.write(result, n, state.carried(), self.segmenter.learnt(), self.problems)
        result.seconds = dict(self.seconds)
        result.judge()
        self.written = ["model/", *write_outputs(out, result, interpolate, smooth_hz)]
        write_report(out / "report.png", result)
        self.written.append("report.png")
        if overlays:
            write_overlays(out, self.sequence, result, show_progress=show_progress)
            self.written.append("overlay/")
        self.problems.save(out / PROBLEMS)
        self.written.append(PROBLEMS)
        checkpoint.remove()
        return result

    def _start(self, out: Path, n: int, show_progress: bool):
        """``(empty result, first frame, tracking state)`` of a new run: the subject's model
        built (or the given one placed) and saved in ``out/model``."""
        t0, before = time.perf_counter(), dict(self.seconds)
        with self.segmenter.every_frame(), self.carver.building():
            model, start, anchor = self.subject.build(n, self.model, show_progress)
        window = list(range(start, self.subject.window_end(start, n)))
        self.segmenter.teach_at = self.segmenter.teaching_frames(window)
        # The subject's frames (the calibration pass too) count as 'subject' only, so that
        # the per-stage seconds are those of tracking the sequence once.
        self.seconds.clear()
        self.seconds.update(before)
        self.seconds["subject"] += time.perf_counter() - t0
        tracked = model.with_wrists() if self.options.wrists else model
        tracked.save(out / "model")
        state = self.fitter.state(tracked, start, anchor, built=model)
        result = TrackingResult.empty(tracked, n, self.sequence.fps)
        result.subject_frame = start
        return result, start, state

    def _resume(self, checkpoint: Checkpoint, n: int):
        """``(result, next frame, state)`` from `checkpoint`, or ``(None, 0, None)`` when
        there is none for this sequence."""
        arrays = checkpoint.read(n)
        if arrays is None:
            return None, 0, None
        try:
            self.segmenter.relearn(arrays)
            result = TrackingResult.from_arrays(BodyModel.load(checkpoint.out / "model"), arrays)
            start = int(arrays["next_frame"])
            state = self.fitter.state(result.model)
            state.resume(arrays, result, start)
        except (*NPZ_ERRORS, TypeError) as e:
            raise checkpoint.damaged(e) from None
        logged = checkpoint.problems()
        if logged is not None:
            self.problems.extend(logged)
        return result, start, state
