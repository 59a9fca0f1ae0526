"""The subject's model for a tracking run (docs/design.md §2, §8): built at the first frame
whose hull it explains (the calibration pose), or a given model placed there, and then
refined from the first seconds of motion, where the joints bend. With nothing to say which
way the person faces, those seconds also decide it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from hullcap._body import BodyModel
from hullcap._carver import Carver
from hullcap._fitting import FitResult, PoseParameters, fit, make_target, yaw_rotation
from hullcap._frame_fitter import FrameFitter
from hullcap._problems import ProblemLog
from hullcap._progress import progress
from hullcap._render import model_silhouettes
from hullcap._results import TrackingResult
from hullcap._segmenter import spread
from hullcap._subject import SubjectFit, bent_frames, build_subject, fitted_surface, place_model, search_centres
from hullcap._threads import over_fits
from hullcap._tracking_options import TrackerOptions, frame_fit_options
from hullcap._tracking_state import TrackingState
from hullcap.errors import TrackingError

__all__ = ["SubjectBuilder"]


class SubjectBuilder:
    """Builds (or places) the subject's model from `fitter`'s frames by `options`; frames
    it cannot start from go to `problems`."""

    def __init__(self, fitter: FrameFitter, options: TrackerOptions, problems: ProblemLog):
        self.fitter = fitter
        self.carver: Carver = fitter.carver
        self.segmenter = fitter.segmenter
        self.sequence = self.segmenter.sequence
        self.options = options
        self.problems = problems

    def window_end(self, first: int, n: int) -> int:
        """The frame after the first ``calibration_seconds`` from `first` (at most `n`)."""
        return min(n, first + max(2, int(round(self.options.calibration_seconds * self.sequence.fps))))

    def agreement(self, masks, model: BodyModel, pose: PoseParameters) -> float:
        """Mean over the views of the IoU of `model`'s silhouette at `pose` and `masks`."""
        ious = []
        for mask, sil in zip(masks, model_silhouettes(self.sequence.cameras, model, pose)):
            union = np.logical_or(mask > 0, sil).sum()
            ious.append(np.logical_and(mask > 0, sil).sum() / union if union else 0.0)
        return float(np.mean(ious))

    def build(self, n: int, given: BodyModel | None = None,
              show_progress: bool = True) -> tuple[BodyModel, int, FitResult]:
        """``(model, first frame, its fit)``: the subject's model built (and refined) at the
        first of `n` frames whose hull it explains, or the `given` one placed there."""
        options = self.options
        for frame in range(n):
            try:
                hull, masks = self.carver.carve(frame)
            except ValueError as e:
                self.problems.add(frame, str(e))
                continue
            facing = self.segmenter.facing(frame)
            if given is not None:
                placed = place_model(given, hull, options=options.subject, facing=facing)
                agreement = self.agreement(masks, given, placed.pose)
                if agreement >= options.min_subject_agreement:
                    self.segmenter.learn_colours(frame, given, placed.pose, fresh=True)
                    return given, frame, placed
                self.problems.add(frame, f"the given model placed there agrees too little with the silhouettes "
                                         f"(mean IoU {agreement:.2f}) to start from")
                continue
            try:
                subject = build_subject(hull, options=options.subject, facing=facing)
                # Silhouettes guided by the model just built see what the first ones missed
                # (clothes the colour of the room): build it again from them, twice.
                for _ in range(2 if self.segmenter.guides else 0):
                    subject, masks = self._built_at(frame, subject.model, subject.pose)
            except ValueError as e:
                self.problems.add(frame, str(e))
                continue
            agreement = self.agreement(masks, subject.model, subject.pose)
            if agreement < options.min_subject_agreement:
                self.problems.add(frame, f"the body model fitted there agrees too little with the "
                                         f"silhouettes (mean IoU {agreement:.2f}) to start from")
                continue
            if not options.refine_joints:
                return subject.model, frame, subject.fit
            return self.refine(subject, frame, n, show_progress, heading_known=facing is not None)
        last = f"; the last problem: {self.problems.items[-1]}" if len(self.problems) else ""
        raise TrackingError(f"{self.sequence.path}: no frame of the first {n} shows a body the model can start "
                            f"from{last}")

    def refine(self, subject: SubjectFit, first: int, n: int, show_progress: bool,
               heading_known: bool = True) -> tuple[BodyModel, int, FitResult]:
        """Track the first seconds with `subject` (or, unless `heading_known`, with it
        turned round if that explains them better: :meth:`_heading`), fit its proportions
        and joint centres over frames of them, place the hinges' centres from the frames
        where they bend most (:func:`hullcap._subject.search_centres`), give it the
        subject's own surface (:func:`hullcap._subject.fitted_surface`), and return the
        refined model with its fit at `first`."""
        end = self.window_end(first, n)
        window = self._track_window(subject, first, end, n, show_progress)
        if not heading_known:
            subject, window = self._heading(subject, window, first, end, n, show_progress)
        stands = window.quality >= self.options.min_quality
        good = [f for f in range(first, end) if not window.failed[f] and stands[f]]
        if len(good) < 2:
            return subject.model, first, subject.fit

        def hull(f: int):
            return self.carver.carve(f, (subject.model, window.pose(f)))[0]

        picks = spread(good, self.options.calibration_frames)
        poses = [window.pose(f) for f in picks]
        for k, (f, pose) in enumerate(zip(picks, poses)):
            self.segmenter.learn_colours(f, subject.model, pose, fresh=k == 0)
        hulls = [hull(f) for f in picks]
        o = self.options.subject
        refined = build_subject(hulls, poses=poses, options=o)
        model, moved = refined.model, False
        for joint, axis in o.centre_search:
            frames = [good[i] for i in bent_frames(model, window.theta[good], joint, o)]
            targets = [make_target(hull(f)) for f in frames]
            model, move = search_centres(model, joint, axis, targets, [window.pose(f) for f in frames], o)
            moved |= move != 0
        if o.surface_reach is not None:
            measured = spread(good, o.surface_frames)
            shown = [hull(f) for f in measured]
            at = over_fits(lambda job, threads: fit(model, make_target(job[0]), job[1], o.fit, threads=threads).pose,
                           [(h, window.pose(f)) for f, h in zip(measured, shown)])
            model, moved = fitted_surface(model, shown, at, o), True
        if not moved:
            return model, first, refined.fit
        return model, first, fit(model, make_target(hulls[0]), refined.pose, o.fit)

    def _built_at(self, frame: int, model: BodyModel, pose: PoseParameters):
        """``(subject, masks)``: the subject's model built again from `frame`'s hull, its
        silhouettes guided by `model` at `pose` (colours learnt from it afresh), starting
        from `pose`; ValueError where it cannot be."""
        self.segmenter.learn_colours(frame, model, pose, fresh=True)
        hull, masks = self.carver.carve(frame, (model, pose))
        return build_subject(hull, poses=[pose], options=self.options.subject, calibration=True), masks

    def _heading(self, subject: SubjectFit, window: TrackingResult, first: int, end: int, n: int,
                 show_progress: bool) -> tuple[SubjectFit, TrackingResult]:
        """``(subject, window)``, or the subject turned round with the first seconds tracked
        from that, whichever explains those seconds better (the mean quality of frames
        `first` … `end` − 1). A hull shows front and back alike, but knees and elbows bend
        one way only: a model facing backwards, which the first frame alone may not tell
        (the hull of a standing person), cannot follow them and explains a moving person
        worse. Asked only when nothing else said which way the person faces (the learned
        segmenter's key points)."""
        pose = subject.pose
        turned_start = PoseParameters(pose.theta, yaw_rotation(np.pi) @ np.asarray(pose.root_rotation, float),
                                      pose.root_translation)
        try:
            turned, _ = self._built_at(first, subject.model, turned_start)
        except ValueError as e:
            self.problems.add(first, f"the subject's model turned round could not be built to compare "
                                     f"headings ({e}); it faces as first placed")
            self.segmenter.learn_colours(first, subject.model, subject.pose, fresh=True)
            return subject, window
        self.segmenter.learn_colours(first, turned.model, turned.pose, fresh=True)
        other = self._track_window(turned, first, end, n, show_progress, "subject model, turned round")
        kept, turned_round = np.mean(window.quality[first:end]), np.mean(other.quality[first:end])
        if turned_round > kept:
            self.problems.add(first, f"the subject's model turned round: facing the other way it explains the "
                                     f"first {end - first} frames better (mean quality {turned_round:.3f} "
                                     f"against {kept:.3f} as first placed)")
            return turned, other
        self.segmenter.learn_colours(first, subject.model, subject.pose, fresh=True)
        return subject, window

    def _track_window(self, subject: SubjectFit, first: int, last: int, n: int,
                      show_progress: bool, desc: str = "subject model") -> TrackingResult:
        """Frames `first` … `last` − 1 tracked with the model as first built, to build the
        refined one from.

        Every fit here steps as ``calibration_fit`` does (the knee search turns on small
        differences between these poses), the search's too, and a pose the search finds
        is fitted again in full. The search fits its candidates as the default per-frame
        fit does, whatever fit tracking takes after (a preset's, or one given): the model
        does not depend on how the sequence is tracked with it. No frame fails: a failed
        frame leaves the next without the prior that guides its silhouettes, and a model
        built from one standing frame explains a bend less well than the refined one will;
        only the frames whose fits reach ``min_quality`` build the model."""
        options = self.options
        strict = replace(options, fit=options.calibration_fit, quick_fit=None, girdle_fit=None,
                         recheck_margin=None, search=replace(options.search, girdle_tolerance=0.0),
                         hull_doubt=None, min_quality=0.0)
        search_fit = frame_fit_options(over_relaxation=options.calibration_fit.over_relaxation)
        state = TrackingState(subject.model, strict, subject.fit, search_fit=search_fit)
        window = TrackingResult.empty(subject.model, n, self.sequence.fps)
        for frame in progress(range(first, last), total=last - first, desc=desc, enable=show_progress):
            self.fitter.track(state, window, frame)
        return window
