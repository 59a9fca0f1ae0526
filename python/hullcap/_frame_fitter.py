"""Fitting each frame of a tracking run (docs/design.md §4–5, §9): the model fitted to the
frame's hull from the predicted pose (and from the last good one, the girdle start, a hinge
held, an elbow as it was), judged against the recent frames, and searched for from the hull
itself when it is not good. What a pass carries from frame to frame is its
:class:`~hullcap._tracking_state.TrackingState`.
"""

from __future__ import annotations

import time

import numpy as np

from hullcap._body import BodyModel
from hullcap._carver import Carver
from hullcap._confidence import key_point_offsets
from hullcap._fitting import FitOptions, FitResult, PoseParameters, PosePrior, fit, make_target, quality
from hullcap._problems import ProblemLog
from hullcap._results import FAILED, GOOD, RECOVERED, TrackingResult
from hullcap._subject import with_hands
from hullcap._tracking_options import TrackerOptions
from hullcap._tracking_state import TrackingState

__all__ = ["FrameFitter"]


class FrameFitter:
    """Fits, judges and records each frame of `carver`'s sequence by `options`; frames
    without a hull go to `problems`, the seconds spent to `seconds`."""

    def __init__(self, carver: Carver, options: TrackerOptions, problems: ProblemLog, seconds: dict):
        self.carver = carver
        self.segmenter = carver.segmenter
        self.options = options
        self.problems = problems
        self.seconds = seconds

    @property
    def hand_reach(self) -> float:
        """The part of each hand the fits keep (``TrackerOptions.hand_reach``; by default
        0.6 with the sequence's own masks, 1 with background subtraction)."""
        reach = self.options.hand_reach
        return reach if reach is not None else (0.6 if self.segmenter.given else 1.0)

    def state(self, model: BodyModel, first: int | None = None, anchor: FitResult | None = None,
              built: BodyModel | None = None) -> TrackingState:
        """The state of tracking a sequence with `model`: its fits take the model with the
        hands of ``options.hand_reach`` (by default as the silhouettes' source asks), the
        silhouettes are guided by `model` itself. The anchor (the fit at frame `first` of
        the subject's model as built, `built`, by default `model`; ``options.wrists`` may
        have given `model` wrists since) is fitted again with the model the fits take."""
        built = built or model
        fitted = with_hands(model, self.hand_reach)
        if anchor is not None and fitted is not built:
            target = make_target(self.carver.carve(first, (built, anchor.pose))[0])
            anchor = fit(fitted, target, anchor.pose.carried(built, fitted), self.options.subject.fit)
        return TrackingState(fitted, self.options, anchor, guide=model)

    def track(self, state: TrackingState, result: TrackingResult, frame: int) -> None:
        """Fit one frame, judge it, search when needed, and record it, by the state's
        options. Its silhouettes are guided by the predicted pose when the frame before
        was tracked (after a failure, a wrong prediction would hide the person it missed),
        with each elbow in doubt drawn as it was too (``TrackerOptions.elbow_doubt``)."""
        starts = state.starts(result, frame)
        follows = frame > 0 and not result.failed[frame - 1]
        before = state.as_before(starts[0]) if starts and follows else None
        prior = (state.guide, starts[0], before) if starts and (follows or state.anchor_only(result, frame)) else None
        try:
            surface = self.carver.carve(frame, prior, state.options.hull_doubt)[0]
        except ValueError as e:  # no usable view in this frame
            self.problems.add(frame, str(e))
            result.fail(frame)
            return
        state.facing = self.segmenter.facing(frame)
        t0 = time.perf_counter()
        target = make_target(surface)
        best, iterations = None, 0
        options = state.options
        first = options.fit if options.quick_fit is None else options.quick_fit
        for start in starts:
            fitted = self.fit_from(state, target, start, first)
            iterations += fitted.iterations
            if best is None or quality(fitted) > quality(best):
                best = fitted
            if state.good(best):
                break
        if best is not None and not state.good(best) and options.quick_fit is not None:
            fitted = self.fit_from(state, target, starts[0], options.fit)  # the paper's schedule
            iterations += fitted.iterations
            if quality(fitted) > quality(best):
                best = fitted
        girdle = None if best is None else state.search.girdle_start(best.pose)
        if girdle is not None:
            girdle_options = first if options.girdle_fit is None else options.girdle_fit
            fitted = self.fit_from(state, target, girdle, girdle_options)
            iterations += fitted.iterations
            if state.takes_girdle_fit(best, fitted):
                best = fitted
        held = None if best is None or not starts else state.hinges_held(starts[0], best.pose)
        if held is not None:
            fitted = self.fit_from(state, target, starts[0], first, held)
            iterations += fitted.iterations
            if quality(fitted) >= quality(best) - options.hinge_tolerance:
                best = fitted
        if before is not None and best is not None:
            # An elbow turned fast in the frames before: the forearm as it was, held so,
            # stands when it explains the hull clearly better.
            fitted = self.fit_from(state, target, before, first, state.held_as_before())
            iterations += fitted.iterations
            if quality(fitted) > quality(best) + options.hinge_tolerance:
                best = fitted
        state.age_doubts(None if best is None else best.pose)
        if best is not None:
            state.doubt_turns(result, frame, best.pose)
        bar = state.floor()  # what a fit of this frame must reach to stand without a search
        status = GOOD if best is not None and state.good(best) else FAILED
        passed = status == GOOD  # without a search
        if status == FAILED and options.reacquire:
            found = best
            lost = [] if best is None else state.lost_chains(best)
            if lost and quality(best) >= state.floor():
                # Only limbs are lost: re-sample those first, the whole search if that fails.
                found, spent = state.search.resample(target, best, lost)
                iterations += spent
            if found is None or not state.good(found):
                # The search keeps `found` unless it finds better.
                found, spent = state.search.search(target, surface, state.recent(result, frame), state.anchor_pose,
                                                   found)
                iterations += spent
            best, status = state.decide(best, found)
            if status == RECOVERED and state.refit_found:
                polished = self.fit_from(state, target, best.pose, options.fit)
                iterations += polished.iterations
                if quality(polished) > quality(best):
                    best = polished
        if best is None:  # nothing to start from and no search
            result.fail(frame)
            return
        if status == FAILED and state.faces_away(best):
            self.problems.add(frame, "the fit faces away from the way the learned segmenter's key points say the "
                                     "person faces (left and right swapped)")
        result.record(frame, best, status, iterations, bar)
        if status != FAILED:
            state.remember_fit(best)
            result.unexplained[frame] = self.segmenter.unexplained(frame, result.model, best.pose)
            if self.segmenter.people[0] == frame:
                # each view's latest key points (a few frames old where the learned segmenter
                # runs every few frames) against the joints of the frame they were seen in
                recent = self.segmenter.recent_people(frame)
                views = [None if r is None else r[1] for r in recent]
                joints = np.stack([result.joints[frame if r is None else r[0]] for r in recent])
                result.key_point_offset[frame] = key_point_offsets(views, self.segmenter.sequence.cameras,
                                                                   result.model.joint_names, joints)
        self.seconds["fit"] += time.perf_counter() - t0
        if passed:
            self.segmenter.teach(frame, state.guide, best.pose)

    def fit_from(self, state: TrackingState, target, start: PoseParameters, options: FitOptions,
                 model: BodyModel | None = None) -> FitResult:
        """A tracking fit from `start` (of `model`, by default the state's), whose joints
        are held near it by the motion prior (``TrackerOptions.motion_sigma``)."""
        sigma = state.options.motion_sigma
        prior = None if sigma is None else PosePrior(start.theta, np.full(state.model.n_dofs, sigma),
                                                     state.options.motion_prior_distance)
        return fit(model or state.model, target, start, options, prior=prior)
