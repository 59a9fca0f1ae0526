"""What tracking carries from frame to frame, and how it judges a fit (docs/design.md,
"Tracking"): the model it fits, the reference qualities of the recent accepted frames,
the bar a search confirmed, the anchor pose, and the predictions a frame's fits start
from. :class:`hullcap._tracking.Tracker` owns one per pass over a sequence."""

from __future__ import annotations

import warnings
from collections import deque
from itertools import islice

import numpy as np

from hullcap._body import BodyModel
from hullcap._fitting import FitOptions, FitResult, PoseParameters, quality
from hullcap._reacquire import CHAINS, PoseSearch, chain_links, chain_quality
from hullcap._results import FAILED, GOOD, RECOVERED, TrackingResult
from hullcap._subject import AWAY
from hullcap._tracking_options import TrackerOptions

__all__ = ["TrackingState"]

# A checkpoint's arrays of what the state carries (TrackingState.carried).
CARRIED_REFERENCE, CARRIED_CHAIN_REFERENCE = "carried_reference", "carried_chain_reference"
CARRIED_CONFIRMED, CARRIED_ANCHOR, CARRIED_SEARCH = "carried_confirmed", "carried_anchor", "carried_search"
CARRIED_DOUBTED = "carried_doubted"


class TrackingState:
    """What tracking carries from frame to frame: the model it fits and the one that
    guides the silhouettes (`guide`, default the same), the search, the reference quality
    and the pose tracking started from."""

    def __init__(self, model: BodyModel, options: TrackerOptions, anchor: FitResult | None,
                 search_fit: FitOptions | None = None, guide: BodyModel | None = None):
        self.model = model
        self.guide = guide or model
        self.options = options
        # The search fits its candidates with `search_fit` when given; a pose it finds is
        # then fitted again with the options' own fit (the subject's window, SubjectBuilder._track_window).
        self.search = PoseSearch(model, search_fit or options.fit, options.search, options.seed)
        self.refit_found = search_fit is not None
        self.chains = chain_links(model)
        self.hinges = [i for i, name in enumerate(model.dof_names) if name.endswith(("elbow_flexion", "knee_flexion"))]
        self.elbows = [i for i, name in enumerate(model.dof_names) if name.endswith("elbow_flexion")]
        # The limbs are judged on their own; the trunk, most of the body, by the whole.
        self.limbs = [c for c, name in enumerate(CHAINS) if name != "trunk"]
        self.reference: deque = deque(maxlen=options.quality_window)
        self.chain_reference: deque = deque(maxlen=options.quality_window)
        self._medians: tuple[float, np.ndarray] | None = None  # of the references, until they change
        self.anchor_pose = anchor.pose if anchor is not None else None
        # A tracked fit no search could beat, as (quality, chain qualities): the bar of
        # the frames after it (TrackerOptions.recheck_margin).
        self.confirmed: tuple[float, np.ndarray] | None = None
        self.facing = None
        """The way the person of the frame being fitted faces (``Segmenter.facing``), or
        None: a fit facing away from it does not stand."""
        # Elbows that turned fast, as {DOF: (the angle they turned from, frames left)}: the
        # frames after it keep the forearm as it was in view (TrackerOptions.elbow_doubt).
        self.doubted: dict[int, tuple[float, int]] = {}
        if anchor is not None:
            self.remember_fit(anchor)

    def hinges_held(self, predicted: PoseParameters, fitted: PoseParameters) -> BodyModel | None:
        """The model with each elbow and knee that `fitted` turned more than
        ``hinge_jump`` from `predicted` limited to within ``hinge_hold`` of it; ``None``
        when none did."""
        o = self.options
        if o.hinge_jump is None:
            return None
        jumped = [i for i in self.hinges if abs(fitted.theta[i] - predicted.theta[i]) > o.hinge_jump]
        if not jumped:
            return None
        return self._held({i: predicted.theta[i] for i in jumped})

    def _held(self, angles: dict[int, float]) -> BodyModel:
        """The model with each DOF of `angles` limited to within ``hinge_hold`` of its
        angle there."""
        own = self.model.link_model.dof_limits
        limits = own.copy()
        for i, angle in angles.items():
            limits[i] = np.clip(angle + np.array([-self.options.hinge_hold, self.options.hinge_hold]), *own[i])
        return self.model.with_dof_limits(limits)

    def doubt_turns(self, result: TrackingResult, frame: int, fitted: PoseParameters) -> None:
        """Put in doubt each elbow that `fitted` turned more than ``hinge_jump`` from
        where it was in a tracked frame of the last ``elbow_span`` seconds, at the angle
        of that frame furthest from the fit: for the next ``elbow_doubt`` seconds the
        forearm as it was stays in view. An elbow already in doubt keeps its angle."""
        o = self.options
        if not o.elbow_doubt or o.hinge_jump is None:
            return
        frames = [f for f in range(max(0, frame - max(1, round(o.elbow_span * result.fps))), frame)
                  if not result.failed[f]]
        if not frames:
            return
        for i in self.elbows:
            if i in self.doubted:
                continue
            angles = result.theta[frames, i]
            far = float(angles[np.argmax(np.abs(angles - fitted.theta[i]))])
            if abs(fitted.theta[i] - far) > o.hinge_jump:
                self.doubted[i] = (far, max(1, round(o.elbow_doubt * result.fps)))

    def as_before(self, pose: PoseParameters) -> PoseParameters | None:
        """`pose` with each elbow in doubt at its angle before the turn; ``None`` when no
        elbow is in doubt."""
        if not self.doubted:
            return None
        theta = pose.theta.copy()
        for i, (angle, _) in self.doubted.items():
            theta[i] = angle
        return PoseParameters(self.model.clamp(theta), pose.root_rotation, pose.root_translation)

    def held_as_before(self) -> BodyModel:
        """The model with each elbow in doubt limited to within ``hinge_hold`` of its
        angle before the turn."""
        return self._held({i: angle for i, (angle, _) in self.doubted.items()})

    def age_doubts(self, fitted: PoseParameters | None) -> None:
        """A frame passed: an elbow back within ``hinge_hold`` of its angle before the
        turn, or in doubt for ``elbow_doubt`` seconds, is in doubt no longer."""
        hold = self.options.hinge_hold
        self.doubted = {i: (angle, left - 1) for i, (angle, left) in self.doubted.items()
                        if left > 1 and (fitted is None or abs(fitted.theta[i] - angle) > hold)}

    def remember_fit(self, fitted) -> None:
        """Take an accepted fit's quality, and its chains', into the references."""
        if self.passes_reference(fitted):
            self.confirmed = None
        self.reference.append(quality(fitted))
        self.chain_reference.append(chain_quality(fitted.link_counts, self.chains))
        self._medians = None

    def remember(self, result: TrackingResult, upto: int) -> None:
        """Take the reference quality and the anchor from frames already tracked (resume)."""
        done = [f for f in range(upto) if not result.failed[f]]
        for f in done[-self.options.quality_window:]:
            self.reference.append(float(result.quality[f]))
            self.chain_reference.append(chain_quality(result.link_counts[f], self.chains))
        self._medians = None
        if done:
            self.anchor_pose = result.pose(done[0])

    def resume(self, arrays: dict, result: TrackingResult, upto: int) -> None:
        """The state of a checkpoint's `arrays`: what it carried (:meth:`take_back`), or,
        from a checkpoint written before the state was carried, what its results up to
        frame `upto` tell (:meth:`remember`)."""
        if CARRIED_SEARCH in arrays:
            self.take_back(arrays)
        else:
            self.remember(result, upto)

    def carried(self) -> dict:
        """What the state carries that the results do not hold, as a checkpoint's arrays
        (:meth:`take_back`): the references, the confirmed bar, the anchor, where the
        search's random draws stand and the elbows in doubt."""
        anchor = self.anchor_pose
        return {
            CARRIED_REFERENCE: np.asarray(self.reference, float),
            CARRIED_CHAIN_REFERENCE: np.asarray(self.chain_reference, float).reshape(-1, len(self.chains)),
            CARRIED_CONFIRMED: np.empty(0) if self.confirmed is None else np.r_[self.confirmed[0], self.confirmed[1]],
            CARRIED_ANCHOR: np.empty(0) if anchor is None else
            np.r_[anchor.theta, np.ravel(anchor.root_rotation), anchor.root_translation],
            CARRIED_SEARCH: np.asarray(self.search.random_state),
            CARRIED_DOUBTED: np.array([(i, angle, left) for i, (angle, left) in sorted(self.doubted.items())],
                                      float).reshape(-1, 3),
        }

    def take_back(self, arrays: dict) -> None:
        """The state as :meth:`carried` left it (resume); KeyError or ValueError when
        `arrays` do not hold it."""
        self.reference.extend(np.asarray(arrays[CARRIED_REFERENCE], float))
        self.chain_reference.extend(np.asarray(arrays[CARRIED_CHAIN_REFERENCE], float).reshape(-1, len(self.chains)))
        confirmed = np.asarray(arrays[CARRIED_CONFIRMED], float)
        self.confirmed = (float(confirmed[0]), confirmed[1:]) if len(confirmed) else None
        anchor, n = np.asarray(arrays[CARRIED_ANCHOR], float), self.model.n_dofs
        if len(anchor) not in (0, n + 12):
            raise ValueError(f"an anchor of {len(anchor)} numbers for a model of {n} DOF")
        self.anchor_pose = PoseParameters(anchor[:n], anchor[n:n + 9].reshape(3, 3), anchor[n + 9:]) \
            if len(anchor) else None
        self.search.random_state = str(arrays[CARRIED_SEARCH])
        doubted = np.asarray(arrays[CARRIED_DOUBTED], float).reshape(-1, 3) if CARRIED_DOUBTED in arrays \
            else np.empty((0, 3))  # a checkpoint from before elbows were doubted
        if not set(doubted[:, 0].astype(int)) <= set(self.elbows):
            raise ValueError(f"doubted DOF {doubted[:, 0].astype(int).tolist()} are not all this model's elbows")
        self.doubted = {int(i): (float(angle), int(left)) for i, angle, left in doubted}
        self._medians = None

    def anchor_only(self, result: TrackingResult, frame: int) -> bool:
        """Whether nothing before `frame` was tracked and the anchor is the prediction."""
        return self.anchor_pose is not None and result.failed[:frame].all()

    def _reference_medians(self) -> tuple[float, np.ndarray]:
        """The medians of the reference qualities, whole body and per chain (NaN for a
        chain never judged), worked out once for every fit judged until they change."""
        if self._medians is None:
            whole = float(np.median(self.reference)) if self.reference else 0.0
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a chain never judged: all NaN
                chains = np.nanmedian(np.array(self.chain_reference), axis=0) if self.chain_reference else None
            self._medians = (whole, chains)
        return self._medians

    def floor(self) -> float:
        """The least whole-body quality of a good fit."""
        return max(self.options.min_quality, self._reference_medians()[0] - self.options.quality_margin)

    def lost_chains(self, fitted: FitResult) -> list[int]:
        """The limb chains whose quality lies more than ``chain_margin`` below their
        reference."""
        reference = self._reference_medians()[1]
        if reference is None:
            return []
        return self._chains_below(fitted, reference, self.options.chain_margin)

    def _chains_below(self, fitted: FitResult, reference: np.ndarray, margin: float) -> list[int]:
        """The limb chains of `fitted` whose quality lies more than `margin` below
        `reference` (per chain); a chain not judged (NaN) on either side is not below."""
        q = chain_quality(fitted.link_counts, self.chains)
        return [c for c in self.limbs if q[c] < reference[c] - margin]

    def decide(self, tracked: FitResult | None, found: FitResult) -> tuple[FitResult, int]:
        """The fit that stands for a frame whose tracked fit did not pass, and its status,
        given the best the search `found` (see ``TrackerOptions.confirm_margin``)."""
        if self.good(found):
            self.confirmed = None
            return found, RECOVERED
        if quality(found) < self.options.min_quality or self.faces_away(found):
            return found, FAILED
        if (tracked is not None and not self.faces_away(tracked)
                and quality(tracked) + self.options.confirm_margin >= quality(found)):
            # The search explains this hull no better than the tracked fit: the hull got
            # worse (fewer views see the person, a limb hides another), not the fit.
            self.confirmed = (quality(tracked), chain_quality(tracked.link_counts, self.chains))
            return tracked, GOOD
        self.confirmed = None
        return found, RECOVERED  # the search explains it better: what this hull can give

    def passes_reference(self, fitted: FitResult) -> bool:
        """Whether a fit is as good as the accepted frames before it (``quality_margin``,
        ``chain_margin``)."""
        return quality(fitted) >= self.floor() and not self.lost_chains(fitted)

    def takes_girdle_fit(self, tracked: FitResult, fitted: FitResult) -> bool:
        """Whether the fit from the girdle start stands for `tracked`: it reaches the same
        arms (``SearchOptions.girdle_turn``) and explains the hull as well, or at most
        ``SearchOptions.girdle_tolerance`` less (there the rhythm decides)."""
        tolerance = self.search.options.girdle_tolerance
        return quality(fitted) > quality(tracked) - tolerance and self.search.same_arm_lines(tracked.pose, fitted.pose)

    def faces_away(self, fitted: FitResult) -> bool:
        """Whether the fit faces away from the way the person's key points say (a facing
        agreement below :data:`hullcap._subject.AWAY`): left and right swapped, which a
        hull alone cannot tell."""
        return self.facing is not None and self.facing(self.model, fitted.pose) < AWAY

    def good(self, fitted: FitResult) -> bool:
        """Whether a fit stands without a search: it does not face away from the person,
        and it passes the reference or is as good as the last fit a search confirmed
        (``recheck_margin``)."""
        if self.faces_away(fitted):
            return False
        if self.passes_reference(fitted):
            return True
        if self.confirmed is None or self.options.recheck_margin is None:
            return False
        bar, chains = self.confirmed
        o = self.options
        chain_margin = o.recheck_margin * (o.chain_margin / o.quality_margin if o.quality_margin > 0 else 1.0)
        return quality(fitted) >= max(o.min_quality, bar - o.recheck_margin) and not self._chains_below(
            fitted, chains, chain_margin)

    def recent(self, result: TrackingResult, frame: int) -> list[PoseParameters]:
        """Good poses before `frame`, newest first, spaced back over about a second."""
        good = [f for f in range(frame - 1, max(-1, frame - 1 - int(result.fps)), -1) if not result.failed[f]]
        picks = good[:: max(1, len(good) // max(1, self.options.search.recent))][: self.options.search.recent]
        return [result.pose(f) for f in picks]

    def starts(self, result: TrackingResult, frame: int) -> list[PoseParameters]:
        """Constant-velocity prediction from the last two frames when both are good, then
        the last good pose; the anchor when nothing was tracked yet."""
        good = list(islice((f for f in range(frame - 1, -1, -1) if not result.failed[f]), 2))
        if not good:
            return [self.anchor_pose] if self.anchor_pose is not None else []
        last = result.pose(good[0])
        if len(good) < 2 or good[0] - good[1] != 1 or good[0] != frame - 1:
            return [last]
        a, b = good[1], good[0]
        theta = self.model.clamp(2 * result.theta[b] - result.theta[a])
        turn = result.root_rotation[b] @ result.root_rotation[a].T
        predicted = PoseParameters(theta, turn @ result.root_rotation[b],
                                   2 * result.root_translation[b] - result.root_translation[a])
        return [predicted, last]
