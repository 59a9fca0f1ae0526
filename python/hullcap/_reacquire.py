"""Finding the person again from the hull itself (docs/design.md, "Tracking").

When a frame's fit explains its hull far worse than the recent frames did, perturbing the
last pose does not help: the model has drifted and the person is elsewhere. The search
starts from the hull instead:

1. candidate poses: recent good poses, the calibration pose and a few canonical ones
   (arms down, arms up, a crouch, either leg raised), each turned to several headings
   about the vertical and moved so that its centroid lies on the hull's;
2. all candidates scored at once by the engine (how much of the hull each explains both
   ways, without fitting, at the resolution of the fit's stages: first roughly, on a
   quarter of those points, and then the best of that screen again at that resolution),
   and the best few fitted in full, those that explain more of the hull than the frame's
   tracked fit does;
3. each limb chain of the best fit re-sampled on its own (joint angles drawn within their
   limits, the rest of the body held), scored, and the best sample fitted when it explains
   more of the hull.

One local minimum needs no search, only a second start (:meth:`PoseSearch.girdle_start`):
an arm raised above the shoulder can be reached by the shoulder joint alone or with the
shoulder girdle (the clavicle) lifted as well. Both put the arm along the same line, and
the hull cannot tell them apart along a straight arm; but only the second lifts the
shoulder where a person's shoulder goes, and the fit, which changes the two angles by
small steps along that valley, rarely crosses from the first to the second.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from itertools import takewhile

import numpy as np

from hullcap import _engine
from hullcap._body import BodyModel
from hullcap._engine import FitOptions
from hullcap._fitting import FitResult, PoseParameters, fit, quality, yaw_rotation
from hullcap._threads import over_fits
from hullcap.errors import OptionsError

__all__ = ["SearchOptions", "PoseSearch", "CANONICAL_POSES", "CHAINS", "chain_links", "chain_quality"]

CANONICAL_POSES = {
    "arms down": {"shoulder_abduction": -75, "elbow_flexion": 15},
    "arms up": {"shoulder_abduction": 80, "clavicle_elevation": 20},
    "crouch": {"hip_flexion": 90, "knee_flexion": 110, "ankle_flexion": 25, "shoulder_flexion": 60,
               "shoulder_abduction": -20, "waist_flexion": 20},
    "left leg raised": {"l_hip_flexion": 70, "l_knee_flexion": 60, "shoulder_abduction": -60},
    "right leg raised": {"r_hip_flexion": 70, "r_knee_flexion": 60, "shoulder_abduction": -60},
}
"""Poses of the library besides the recent and calibration ones: joint angles in degrees by
DOF name, where a name without ``l_``/``r_`` means both sides."""

CHAINS = {
    "left arm": ("l_clavicle", "l_upper_arm", "l_forearm", "l_hand"),
    "right arm": ("r_clavicle", "r_upper_arm", "r_forearm", "r_hand"),
    "left leg": ("l_thigh", "l_shin", "l_foot"),
    "right leg": ("r_thigh", "r_shin", "r_foot"),
    "trunk": ("torso", "head"),
}
"""Links re-sampled together by the search's last step."""


@dataclass(frozen=True)
class SearchOptions:
    """Numbers of the search.

    Why each default is what it is, with the runs behind it: the accuracy notebook
    (docs/notebooks/accuracy.md, "Why the tracker's defaults are what they are").

    Attributes:
        headings: headings about the vertical each library pose is tried at, evenly spaced
            from the last good heading.
        keep: candidates fitted in full after scoring.
        chain_samples: joint-angle draws per limb chain.
        screen: candidates a rough scoring passes on to the scoring proper (the pose to beat
            always goes on too).
        screen_coarse: the rough scoring counts a ``screen_coarse``-th of the model points,
            hull samples and model vertices of the scoring proper.
        screen_margin: nor does the screen pass on a candidate whose rough score lies more
            than this below the pose to beat's (a fraction of points, like the quality).
        recent: recent good poses taken into the library (the newest, and others spaced back
            over about a second).
        girdle_share: the part of an arm's elevation above the horizontal that the shoulder
            girdle (the clavicle's elevation) takes in :meth:`PoseSearch.girdle_start`'s
            start: 1/3, the scapulohumeral rhythm (above the first 30° of elevation the
            shoulder joint turns 2° for each degree of the girdle).
        girdle_margin: that start is tried when the clavicle of a raised arm lies more than
            this below its share (radians).
        girdle_turn: the fit from that start stands for the same arms reached another way
            only while each arm's line (shoulder to wrist) stays within this angle of the
            fit it started from (radians).
        girdle_tolerance: and while its quality is at most this much below the fit from the
            prediction (a fraction of points, like the quality): along a straight arm the
            hull hardly tells the two apart, so within that the rhythm decides.
    """

    headings: int = 8
    keep: int = 3
    chain_samples: int = 48
    screen: int = 8
    screen_coarse: int = 4
    screen_margin: float = 0.1
    recent: int = 3
    girdle_share: float = 1 / 3
    girdle_margin: float = math.radians(10.0)
    girdle_turn: float = math.radians(15.0)
    girdle_tolerance: float = 0.005

    def __post_init__(self):
        if min(self.headings, self.keep, self.chain_samples, self.recent, self.screen_coarse) < 1:
            raise OptionsError("SearchOptions: headings, keep, chain_samples, recent and screen_coarse must be at "
                               "least 1")
        if self.screen < 0:
            raise OptionsError(f"SearchOptions: screen must be 0 (off) or more, got {self.screen}")
        if not self.screen_margin >= 0:
            raise OptionsError(f"SearchOptions: screen_margin must be 0 or more, got {self.screen_margin}")
        if not (0 <= self.girdle_share < 1 and self.girdle_margin > 0 and self.girdle_turn > 0):
            raise OptionsError(f"SearchOptions: girdle_share must be in [0, 1), girdle_margin and girdle_turn "
                               f"positive, got {self.girdle_share}, {self.girdle_margin} and {self.girdle_turn}")
        if not 0 <= self.girdle_tolerance < 1:
            raise OptionsError(f"SearchOptions: girdle_tolerance must be in [0, 1), got {self.girdle_tolerance}")


def chain_links(model: BodyModel) -> list[np.ndarray]:
    """The link indices of each chain of :data:`CHAINS` present in `model`."""
    names = model.link_model.names
    return [np.array([names.index(n) for n in chain if n in names], int) for chain in CHAINS.values()]


MIN_PART_COUNT = 20
"""Fewer model points or hull samples than this say nothing about a chain's fit."""


def chain_quality(link_counts, chains: list[np.ndarray]) -> np.ndarray:
    """(C,) ½(inlier fraction + coverage) of each chain from a fit's ``link_counts``;
    NaN for a chain with too few points or samples to judge (:data:`MIN_PART_COUNT`)."""
    counts = np.asarray(link_counts, float)
    out = np.full(len(chains), np.nan)
    for c, links in enumerate(chains):
        points, inliers, samples, covered = counts[links].sum(0)
        if points >= MIN_PART_COUNT and samples >= MIN_PART_COUNT:
            out[c] = 0.5 * (inliers / points + covered / samples)
    return out


class PoseSearch:
    """The re-acquisition search for one model (see the module documentation)."""

    def __init__(self, model: BodyModel, fit_options: FitOptions, options: SearchOptions | None = None,
                 seed: int = 0):
        self.model = model
        self.fit_options = fit_options
        # Candidates are ranked at the resolution of the fit's stages (FitOptions.coarse):
        # the ranking only chooses what to fit, and the fits compare in full.
        self._rank_options = fit_options.coarsened()
        self.options = options or SearchOptions()
        self._screen_options = self._rank_options.replace(coarse=self.options.screen_coarse).coarsened()
        self._rng = np.random.default_rng(seed)
        self._canonical = [_angles(model, spec) for spec in CANONICAL_POSES.values()]
        self._canonical_centroids = [self._centroid(theta) for theta in self._canonical]
        dof_links = model.link_model.dof_links
        self._chains = [np.flatnonzero(np.isin(dof_links, links)) for links in chain_links(model)]
        self._girdle = _girdle_dofs(model)
        names = model.joint_names
        self._arms = [(names.index(f"{s}_shoulder"), names.index(f"{s}_wrist")) for s in "lr"
                      if f"{s}_shoulder" in names and f"{s}_wrist" in names]

    @property
    def random_state(self) -> str:
        """Where its random draws stand, as JSON (a checkpoint's); set it to go on from there."""
        return json.dumps(self._rng.bit_generator.state)

    @random_state.setter
    def random_state(self, state: str) -> None:
        self._rng.bit_generator.state = json.loads(state)

    def girdle_start(self, pose: PoseParameters) -> PoseParameters | None:
        """`pose` with each raised arm's elevation shared between the shoulder and the
        girdle as ``options.girdle_share`` says, when the girdle of a raised arm lies more
        than ``options.girdle_margin`` below that share; ``None`` when no arm does (or the
        model has no clavicles). The caller fits from it and keeps the better fit: the
        data decide, the rhythm only says where to look (see the module documentation)."""
        share = self.options.girdle_share
        if share == 0 or not self._girdle:
            return None
        theta = np.array(pose.theta, float)
        moved = False
        for clavicle, shoulder in self._girdle:
            total = theta[clavicle] + theta[shoulder]  # both turn the arm about the same axis at rest
            if total > 0 and theta[clavicle] < share * total - self.options.girdle_margin:
                theta[clavicle], theta[shoulder] = share * total, (1 - share) * total
                moved = True
        return PoseParameters(self.model.clamp(theta), pose.root_rotation, pose.root_translation) if moved else None

    def same_arm_lines(self, before: PoseParameters, after: PoseParameters) -> bool:
        """Whether every arm's line (shoulder to wrist) of `after` lies within
        ``options.girdle_turn`` of that of `before`: a fit from :meth:`girdle_start`
        counts only then."""
        a, b = (self.model.joints(p.theta, p.root_rotation, p.root_translation) for p in (before, after))
        for shoulder, wrist in self._arms:
            u, v = a[wrist] - a[shoulder], b[wrist] - b[shoulder]
            cos = u @ v / max(np.linalg.norm(u) * np.linalg.norm(v), 1e-12)
            if cos < math.cos(self.options.girdle_turn):
                return False
        return True

    def resample(self, target, start: FitResult, chains) -> tuple[FitResult, int]:
        """`start` with each chain of `chains` (indices into :data:`CHAINS`) re-sampled on
        its own (see the module documentation, step 3); returns the best fit and the ICP
        iterations spent."""
        best, iterations = start, 0
        for c in chains:
            dofs = self._chains[c]
            if not len(dofs):
                continue
            lim = self.model.link_model.dof_limits[dofs]
            samples = []
            for _ in range(self.options.chain_samples):
                theta = best.pose.theta.copy()
                theta[dofs] = self._rng.uniform(lim[:, 0], lim[:, 1])
                samples.append(PoseParameters(theta, best.pose.root_rotation, best.pose.root_translation))
            top = self._rank(target, samples + [best.pose])
            if top[0] is best.pose:
                continue
            result = fit(self.model, target, top[0], self.fit_options)
            iterations += result.iterations
            if quality(result) > quality(best):
                best = result
        return best, iterations

    def search(self, target, surface, recent: list[PoseParameters], calibration: PoseParameters | None,
               tracked: FitResult | None = None) -> tuple[FitResult, int]:
        """The best fit found from the hull, `tracked` (the frame's fit so far) included;
        returns it and the ICP iterations spent. A candidate is fitted only when, before
        fitting, it explains the hull better than `tracked` does, as a chain's draw is
        (:meth:`resample`)."""
        centre = surface.vertices.mean(0)
        library = [p.theta for p in recent[: self.options.recent]]
        if calibration is not None:
            library.append(calibration.theta)
        offsets = [self._centroid(theta) for theta in library] + self._canonical_centroids
        library += self._canonical
        last = recent[0].root_rotation if recent else np.eye(3)  # headings spaced from it
        candidates = []
        for theta, offset in zip(library, offsets):
            for k in range(self.options.headings):
                R = yaw_rotation(2 * np.pi * k / self.options.headings) @ last
                candidates.append(PoseParameters(theta, R, centre - R @ offset))
        ranked = self._rank(target, candidates + ([] if tracked is None else [tracked.pose]),
                            to_beat=tracked is not None)
        better = takewhile(lambda pose: tracked is None or pose is not tracked.pose, ranked[: self.options.keep])
        iterations = 0
        best = tracked
        for result in over_fits(lambda pose, threads: fit(self.model, target, pose, self.fit_options, threads=threads),
                                better):
            iterations += result.iterations
            if best is None or quality(result) > quality(best):
                best = result
        best, spent = self.resample(target, best, range(len(self._chains)))
        return best, iterations + spent

    def _centroid(self, theta) -> np.ndarray:
        """The posed mesh's centroid in the body frame."""
        return self.model.pose(theta).vertices.mean(0)

    def _rank(self, target, poses: list[PoseParameters], to_beat: bool = True) -> list[PoseParameters]:
        """The best of `poses` by how much of the hull each explains, best first. With
        `to_beat`, the last pose is the one to beat: always among them, and the screen
        passes on only candidates near it (``SearchOptions.screen``, ``screen_margin``)."""
        screen = self.options.screen
        if screen and len(poses) > screen + 1:
            rough = self._qualities(target, poses, self._screen_options)
            if not to_beat:
                passed = np.sort(np.argsort(-rough, kind="stable")[:screen])
            else:
                passed = np.argsort(-rough[:-1], kind="stable")[:screen]
                passed = passed[rough[passed] >= rough[-1] - self.options.screen_margin]
                if not len(passed):
                    return [poses[-1]]
                passed = np.append(np.sort(passed), len(poses) - 1)
            poses = [poses[i] for i in passed]
        order = np.argsort(-self._qualities(target, poses, self._rank_options), kind="stable")
        return [poses[i] for i in order]

    def _qualities(self, target, poses: list[PoseParameters], options: FitOptions) -> np.ndarray:
        stats = _engine.evaluate(self.model._rig, target, [np.asarray(p.theta, float).tolist() for p in poses],
                                 [np.asarray(p.root_rotation, float) for p in poses],
                                 [np.asarray(p.root_translation, float) for p in poses], options)
        return np.array([quality(s) for s in stats])


def _girdle_dofs(model: BodyModel) -> list[tuple[int, int]]:
    """``(clavicle elevation, shoulder abduction)`` DOF indices of each side that has both."""
    names = model.dof_names
    return [(names.index(f"{s}_clavicle_elevation"), names.index(f"{s}_shoulder_abduction")) for s in "lr"
            if f"{s}_clavicle_elevation" in names and f"{s}_shoulder_abduction" in names]


def _angles(model: BodyModel, spec: dict) -> np.ndarray:
    """The joint angles of a :data:`CANONICAL_POSES` entry, within the model's limits."""
    theta = np.zeros(model.n_dofs)
    for name, degrees in spec.items():
        theta[model.link_model.dof_indices(name)] = np.radians(degrees)
    return model.clamp(theta)
