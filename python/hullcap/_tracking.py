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

import io
import math
import time
import warnings
from collections import defaultdict
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from hullcap._body import BodyModel
from hullcap._files import NPZ_ERRORS, atomic_write
from hullcap._fitting import FitOptions, FitResult, PoseParameters, PosePrior, fit, make_target, quality
from hullcap._guided import GuidedOptions, GuidedSegmenter, dilated
from hullcap._hull import HullReport, capture_volume, check_bounds, doubtful_vertices, visual_hull
from hullcap._problems import ProblemLog
from hullcap._progress import progress
from hullcap._reacquire import SearchOptions
from hullcap._render import render_silhouette
from hullcap._results import FAILED, GOOD, RECOVERED, TrackingResult, check_cutoff, write_outputs
from hullcap._sequence import Sequence
from hullcap._silhouette import background_model
from hullcap._subject import (SubjectOptions, bent_frames, build_subject, fitted_surface, place_model,
                              search_centres, with_hands)
from hullcap._threads import ReadAhead, over_fits, over_views
from hullcap._tracking_state import TrackingState
from hullcap.errors import OptionsError, ResultsError, SequenceError, TrackingError, ViewError

__all__ = ["Tracker", "TrackerOptions"]

# The checkpoint's arrays of what a run learnt besides its results (Tracker._learnt);
# what tracking carries from frame to frame has its own (TrackingState.carried).
LEARNT_TEACH_AT = "learnt_teach_at"
LEARNT_COLOURS = ("learnt_colours_subject", "learnt_colours_background")
CHECKPOINT = ".checkpoint.npz"
PROBLEMS = "problems.json"


def quick_fit_options() -> FitOptions:
    """A fit of every parameter at once for at most 15 iterations, for a start a few steps
    from its minimum (``TrackerOptions.girdle_fit``, and ``quick_fit`` when asked); a new
    object each call, since fit options can be changed in place."""
    return FitOptions(hierarchical=False, iterations=15, tolerance=3e-4, reverse_weight=1.0)


@dataclass(frozen=True)
class TrackerOptions:
    """Every choice of a tracking run.

    Attributes:
        voxel_size: hull resolution (metres).
        background: ``"statistical"`` or ``"mog2"``, used when the sequence has no
            silhouettes (or `use_silhouettes` is False).
        use_silhouettes: use the sequence's silhouettes when it has them.
        guided: with statistical background subtraction, guide each frame's silhouettes by
            the model at its predicted pose and by the subject's colours
            (:mod:`hullcap._guided`); the statistical test alone otherwise.
        guidance: the guided silhouettes' options (their outer band widened for the
            sequence's frame rate, :meth:`GuidedOptions.for_frame_rate`).
        hull_tolerance: views that may leave a voxel out and be overruled by the others
            (:func:`hullcap.visual_hull`): within the predicted model's silhouettes,
            dilated by the guided silhouettes' outer band, while tracking, and only where
            each view's guided mask was not sure of the background
            (``GuidedOptions.sure_background``); anywhere in the
            first frame, which has no prediction yet (its hull is then a little larger
            where one view alone carved).
            ``None``: 1 for silhouettes by background subtraction, which may miss a part in
            one view, 0 for the sequence's own silhouettes, which are taken as they are
            (every view overruled adds phantom volume to the hull).
        hull_doubt: while tracking with guided silhouettes, the hull's vertices whose
            place no view vouches for are left out of the fit's target
            (:func:`hullcap._hull.doubtful_vertices`): the point this many metres outside
            the vertex along its normal is left out by at least `hull_doubt_views` views,
            none of them sure of the background there. Trousers the colour of the floor
            that most views miss in a deep bend carve the thighs to half their width; the
            fit pulled the legs into what was left (hips twisted, the pelvis low), and
            with those vertices left out the legs follow their neighbours instead (d01
            from colour frames: 24.4 → 23.4 mm; docs/accuracy.md). 2 cm: two voxels,
            beyond the smoothing of the masks' log-odds (a pixel or two outside every
            outline is unsure). ``None`` fits the whole hull. Not while the subject's
            model is built (`refine_joints`): the knee's centre is found from small gains
            of quality at bent knees, whose creases the views see unsure; from trimmed
            hulls d02's gain fell below ``SubjectOptions.centre_min_gain``.
        hull_doubt_views: see `hull_doubt`. Where one view alone missed a part, the
            tolerant hull kept it already (`hull_tolerance`). On the development set 3
            made every sequence from colour frames better; 2 made d01 better still (22.8
            mm) but d02 and d04 worse by 0.2–0.3 mm.
        fit: the per-frame fit (two-sided by default; ``reverse_weight=0`` is the paper's
            one-sided energy), hierarchical as in the paper: root, then joint groups from
            the torso outwards, then all together. One pass over the stages
            (``rounds=1``): a frame starts a frame away from its pose, and on the
            development set a second pass took a third more iterations (43 against 32 a
            frame on average) for no better joints (docs/accuracy.md). The stages pair
            every second model point (``coarse=2``) and the final fit of everything
            together all of them: on 104 development-set frames fitted from the tracked
            predictions that took 45 ms a fit instead of 60, to the same joint error. The
            search uses it, and so does tracking unless `quick_fit` is set; the first
            seconds tracked for the subject's model use `calibration_fit`.
        quick_fit: when set, the fit from each start (the prediction, the last pose, the
            girdle start) instead of `fit`; for speed, every parameter at once
            (:func:`quick_fit_options`). A frame away the hierarchy's stages mostly buy
            iterations: on 15 frames of d02 (exact masks) that fit takes 10 iterations and
            61 ms where the hierarchical one (two rounds, the default then) takes 30 and
            136 ms, to the same joint error.
            When no start's quick fit passes, the hierarchical fit from the first start
            is tried before the search, and a quick fit from the girdle start counts only
            if it keeps the arms' lines (``SearchOptions.girdle_turn``). Off by default:
            over the development set it doubled the fit's speed (d02 6.5 → 11–13
            frames/s, d01 exact 6.0 → 10–13) and lowered the error of six runs of eight
            (d03 from exact masks +1.1 mm), but on the 4-camera d04 from colour frames one run of
            three lost the left forearm for 30 frames (MPJPE 17.9 → 26.5 mm), which the
            hierarchical fit never did in eight runs; since tracking makes one round of
            coarse stages it gains no speed, and d02 from colour frames lost 15 mm with it
            (docs/performance.md). The first seconds tracked to refine
            the subject's model (`refine_joints`) never use it: the model is built from
            those poses once, and quick fits there moved its limb lengths by up to 4.6
            percentage points.
        girdle_fit: the fit from the girdle start (:meth:`hullcap._reacquire.PoseSearch.
            girdle_start`), tried after the fit from the prediction wherever a raised arm's
            clavicle lies low: every parameter at once, for at most 15 iterations
            (:func:`quick_fit_options`). That start is the tracked fit with only the raised
            arms' elevation shared otherwise between shoulder and clavicle, a few steps
            from its own minimum, and the hierarchy's stages, which move the root and the
            torso first, mostly spend iterations there: on the 4-camera development
            sequence from colour frames its fits took 26 iterations each, a third of
            all, and 12 this way, winning 18 times against 20. ``None``: the same fit as
            the other starts (the first seconds tracked for the subject's model use that).
        subject: how the subject's model is built.
        refine_joints: after building the model, track the first `calibration_seconds`,
            fit the model's proportions and joint centres again over `calibration_frames`
            frames of them, give it the subject's surface (``subject.surface_reach``), and
            track from the start with the refined model.
        calibration_seconds, calibration_frames: see `refine_joints`. Without it, or
            with a model given, the guided masks know one frame's colours, and tracking
            teaches them from as many frames over as many seconds as it goes: over the development set with each
            sequence's model given, from colour frames, 23.0 / 15.4 mm → 22.6 / 14.9 and
            d01's one lost frame tracked (docs/accuracy.md). Where a knee sits
            shows only in frames where it bends (:func:`hullcap._subject.bent_frames`),
            and people take a few seconds to bend one: in the first 3 s of d02 the tracked
            knees bent by 45° in a single landing, two or three usable frames, too few for
            the search to tell a move from noise (d02 thigh −6 % from exact masks). 5 s
            hold its second landing too, and over the development set the mean MPJPE fell
            from 24.8/16.7 to 24.5/16.6 mm (colour frames, with the scene's colours in
            the guided masks) and from 23.7/15.1 to 22.3/14.8 (exact masks)
            (docs/accuracy.md). A sequence shorter than the window is tracked whole.
        calibration_fit: the fit of those first seconds, in place of `fit`: the model is
            built once from their poses, so they get two rounds over the hierarchy's
            stages. With one, the poses of the demo's window moved the knee search's best
            gain from 0.00187 to 0.00201, over its threshold (``SubjectOptions.
            centre_min_gain``, 0.002), and the knees of our own template 2 cm off (demo
            8.1 mm against 5.2). Nor are its stages coarse (``coarse=1``): with every
            second point there, the knee search moved d02's knee 3 cm the wrong way from
            colour frames (thigh −7 %, shin +7 %). Their searches fit candidates with
            `fit`, and a pose a search finds is fitted again with this one: 52 of the 54
            searches of d01's window (from colour frames) only confirmed the tracked fit,
            at 1.2 s each with this fit and 0.6 s with `fit` (before a search fitted only
            candidates that beat the tracked fit, docs/performance.md).
        quality_window: the accepted frames (most recent) whose median quality is the
            reference a new frame is judged against.
        quality_margin: a fit passes without a search when its quality is at most this far
            below the reference. Quality is a fraction of points (0…1); in good tracking it varies by
            a few hundredths from frame to frame.
        chain_margin: and when each limb chain's quality (:func:`hullcap._reacquire.
            chain_quality`) is at most this far below that chain's own reference. A whole
            body's quality barely moves when one arm is lost (an arm is a few per cent of
            the body); the arm's own falls from 0.7–0.95 to 0.2–0.55.
        min_quality: a fit below this never stands: the frame fails. In the first
            seconds tracked for the subject's model (`refine_joints`) no frame fails,
            but only the frames at or above it build the model.
        confirm_margin: when a fit is not good, the search from the hull says what the
            frame's hull can give: the tracked fit stands (good) unless the search found
            one better by more than this, which then stands (recovered); either way above
            `min_quality`, and the reference follows. The margins above only decide when
            to search; a frame fails when nothing explains its hull to `min_quality`.
        recheck_margin: once a search found nothing better than the tracked fit (the
            hull got worse, not the fit), the next frames pass without a search while
            their quality stays within this of that fit's, and each limb chain's within
            this times ``chain_margin / quality_margin``; a frame that drops further is
            searched again, and the bar is lifted as soon as a fit passes the reference
            again. Without this bar every frame of a stretch where the hull is poor (d01's
            legs the colour of the floor while the person bends over) was searched, at
            2.5 s a frame, until the reference's median caught up. The chains' bar is
            twice as wide because a chain's quality moves about twice as much as the whole
            body's from frame to frame (median 0.009–0.016 against 0.005–0.008 on the
            development set); with the body's margin for them too, most searches of d01's
            bend from colour frames came from one chain dipping by a few hundredths.
            ``None``: every frame that fails the reference is searched.
        min_subject_agreement: how well the subject's model, fitted in a frame, must
            agree with that frame's silhouettes (mean over the views of the intersection
            over union of the model's silhouette and the mask) for tracking to start there.
            A person in the calibration pose agrees to 0.6–0.7 with poor masks and 0.9–0.95
            with exact ones; blobs of noise, which the hull and the fit can still make
            something of, agree to less than 0.05.
        hinge_jump, hinge_hold, hinge_tolerance: a fit that turns an elbow or a knee more
            than `hinge_jump` (radians) away from the prediction is fitted again with that
            hinge held within `hinge_hold` of the prediction, and the held fit stands unless
            the free one explains the hull better by more than `hinge_tolerance` (the
            girdle start's tolerance). Where the hull loses a forearm (an arm the colour of
            the wall behind it), folding it onto the upper arm lets its points pair with
            the upper arm's and the head's hull and explains the hull a little better
            (0.002 in the case measured, docs/accuracy.md "A limb the hull lost"); a limb
            that really moved that far, and that the hull shows, is explained far better
            free. ``None``: no check.
        elbow_doubt, elbow_span: seconds for which an elbow that turned fast stays in
            doubt (0: never), and the time within which turning more than `hinge_jump` is
            fast. A fit whose elbow lies more than `hinge_jump` from its angle in a tracked
            frame of the last `elbow_span` seconds puts that elbow in doubt at that
            frame's angle: in the frames after it the guided masks are guided by the model
            drawn at the prediction and, united with it, at the prediction with the elbow
            at that angle, and a fit from that pose, the elbow held within `hinge_hold` of
            the angle, stands when it explains the hull better by more than
            `hinge_tolerance` (the guide drawn both ways favours the forearm as it was, and
            a real bend must not be held back by it). The doubt ends when a fit
            brings the elbow back within `hinge_hold`. A forearm folded where a frame's
            hull lost it (an arm the colour of the wall behind it), at once or over a few
            frames, is otherwise drawn into the next frame's guide, which keeps the real
            forearm out of the masks: on the development set such folds lasted to the
            sequence's end (docs/accuracy.md, "A limb the hull lost"). 0.1 s is three
            frames at 30 frames/s; 45° in that time (450°/s) a fold exceeds, and so do
            fast arms, for which the fit from the forearm as it was explains the hull
            worse and is not kept. Knees are left out: a running knee turns that fast at
            every stride, and a shin is seldom lost from the hull.
        reacquire: search from the hull when a fit is not good (else the frame fails).
        search: the search's options.
        motion_sigma: when set, a tracking fit (from the prediction, from the last pose,
            from the girdle start) holds every joint angle near its start by a Gaussian
            prior of this standard deviation (radians), so that a joint moves far within
            one frame only when the hull asks for it. Where the hull lost a limb (an arm
            the colour of the wall behind it in two views, the prediction elsewhere), the
            model's points of that limb pair with whatever lies near, and the fit once
            folded an elbow from 0° to 130° in one frame of the development set and kept
            it folded. With 30° such a fold costs as much as every pair lying 13 mm
            further off, and a change of 30° (a fast punch's elbow between frames at 30
            frames/s) 3 mm. Off by default (``None``, the paper's energy): over the
            development set it moved MPJPE by −1.4 to +1.4 mm, 0.25 mm worse on average
            (docs/accuracy.md); the fold it guards against came once, in one run.
        motion_prior_distance: metres of pair distance one `motion_sigma` is worth.
        hand_reach: the part of each hand (wrist to fingertips) the fits of tracking keep
            (:func:`hullcap._subject.with_hands`): the sequence is fitted with the
            subject's model whose hands are pulled toward the wrists to this fraction of
            their length. A visual hull keeps the palm but loses spread fingers: a hand
            of full length then meets a fingerless hand in the hull, and the fit may
            slide the whole arm along its line to match them (measured with hands rigid
            on the forearms, before `wrists`). The subject's model itself keeps its
            whole hands: it is built with them (built with short ones, the shape fit
            stretched the forearms to fill the hull's hands), saved with them, and the
            silhouettes are guided by it. ``None`` (default): 0.6 with the
            sequence's own silhouettes, 1 (the whole hands) with silhouettes by
            background subtraction. With exact masks 0.6 made every development run as
            good or better (mean 22.6 / 15.1 → 21.4 / 14.0 mm; d03's shoulders, arms
            raised, 14 mm low instead of 26); from colour frames it gained nothing, and at
            0.7 one run was lost from its 75th frame on (docs/accuracy.md, "Hands as the
            hull sees them").
        wrists: track with hands that turn at the wrists (:meth:`BodyModel.with_wrists`,
            two DOF each), added to the subject's model once it is built; the results
            and the saved model have them. The subject's model is built with the paper's
            29 DOF, whose hands turn rigidly with the forearms: the calibration pose
            holds the hands straight, and built with wrists (a trial) the forearms came
            out 6–9 % too long on three development bodies of four. In motion a
            rigid hand that the hull shows bent pulls its forearm toward it: with wrists
            the development set's mean error went 23.7 / 16.3 → 23.2 / 15.7 mm from colour
            frames and 21.3 / 13.9 → 20.8 / 13.5 from exact masks, the synthetic demo's,
            whose hands never bend, 5.0 → 5.6 mm (docs/accuracy.md). ``False``: the
            paper's 29 DOF throughout.
        read_ahead: frames decoded and put through the background test on a second
            thread while the engine fits the frame before (:mod:`hullcap._threads`); 0
            reads each frame when it is tracked. The results are the same either way.
    """

    voxel_size: float = 0.01
    background: str = "statistical"
    use_silhouettes: bool = True
    guided: bool = True
    guidance: GuidedOptions = field(default_factory=GuidedOptions)
    hull_tolerance: int | None = None
    hull_doubt: float | None = 0.02
    hull_doubt_views: int = 3
    fit: FitOptions = field(default_factory=lambda: FitOptions(rounds=1, reverse_weight=1.0, coarse=2))
    quick_fit: FitOptions | None = None
    girdle_fit: FitOptions | None = field(default_factory=quick_fit_options)
    subject: SubjectOptions = field(default_factory=SubjectOptions)
    refine_joints: bool = True
    calibration_seconds: float = 5.0
    calibration_frames: int = 8
    calibration_fit: FitOptions = field(default_factory=lambda: FitOptions(rounds=2, reverse_weight=1.0))
    quality_window: int = 30
    quality_margin: float = 0.1
    chain_margin: float = 0.2
    min_quality: float = 0.5
    recheck_margin: float | None = 0.05
    confirm_margin: float = 0.02
    min_subject_agreement: float = 0.5
    reacquire: bool = True
    search: SearchOptions = field(default_factory=SearchOptions)
    motion_sigma: float | None = None
    motion_prior_distance: float = 0.003
    hinge_jump: float | None = math.radians(45.0)
    hinge_hold: float = math.radians(10.0)
    hinge_tolerance: float = 0.005
    elbow_doubt: float = 0.5
    elbow_span: float = 0.1
    hand_reach: float | None = None
    wrists: bool = True
    read_ahead: int = 2
    seed: int = 0

    def __post_init__(self):
        if self.background not in ("statistical", "mog2"):
            raise OptionsError(f"background must be 'statistical' or 'mog2', got {self.background!r}")
        if not 0 < self.voxel_size < math.inf:
            raise OptionsError(f"voxel_size must be a positive number of metres, got {self.voxel_size}")
        if self.motion_sigma is not None and not (self.motion_sigma > 0 and self.motion_prior_distance >= 0):
            raise OptionsError(f"motion_sigma must be positive (or None) and motion_prior_distance >= 0, got "
                               f"{self.motion_sigma} and {self.motion_prior_distance}")
        if self.hand_reach is not None and not 0 < self.hand_reach <= 1:
            raise OptionsError(f"hand_reach must be in (0, 1], got {self.hand_reach}")
        if not ((self.hull_doubt is None or self.hull_doubt > 0) and self.hull_doubt_views >= 1):
            raise OptionsError(f"hull_doubt must be positive metres (or None) and hull_doubt_views >= 1, got "
                               f"{self.hull_doubt} and {self.hull_doubt_views}")
        if self.read_ahead < 0:
            raise OptionsError(f"read_ahead must be >= 0, got {self.read_ahead}")
        if not ((self.hinge_jump is None or self.hinge_jump > 0) and self.hinge_hold >= 0
                and self.hinge_tolerance >= 0):
            raise OptionsError("hinge_jump must be positive (or None), hinge_hold and hinge_tolerance >= 0")
        if not (self.elbow_doubt >= 0 and self.elbow_span > 0):
            raise OptionsError(f"elbow_doubt must be >= 0 and elbow_span > 0 (seconds), got {self.elbow_doubt} "
                               f"and {self.elbow_span}")
        if self.recheck_margin is not None and not self.recheck_margin >= 0:
            raise OptionsError(f"recheck_margin must be >= 0 (or None), got {self.recheck_margin}")
        if self.calibration_frames < 2 or self.calibration_seconds <= 0 or self.quality_window < 1:
            raise OptionsError("calibration_frames must be >= 2, calibration_seconds > 0, quality_window >= 1")


class Tracker:
    """Tracks a sequence folder (see the module documentation).

    Args:
        sequence: the input.
        model: the subject's model from an earlier run (``None``: build it).
        options: see :class:`TrackerOptions`.
    """

    def __init__(self, sequence: Sequence, model: BodyModel | None = None, options: TrackerOptions | None = None,
                 bounds=None):
        self.sequence = sequence
        self.model = model
        self.options = options or TrackerOptions()
        if bounds is None:
            bounds = capture_volume(sequence.cameras)
        self.bounds = check_bounds(bounds)
        """``(lo, hi)``: the capture volume the hull is carved in (metres)."""
        self._guidance = self.options.guidance.for_frame_rate(sequence.fps)
        self._backgrounds = None
        self._guided = None
        # Cameras without a usable background image, left out of every frame: name → why.
        self._no_background: dict[str, ViewError] = {}
        self._broken: set = set()  # (frame, camera) of views already left out
        self._ahead: ReadAhead | None = None
        # How many frames' colours the guided segmenters know since they last forgot, and
        # the frames from which tracking still teaches them, in order (`_teaching_frames`).
        self._colour_frames = 0
        self._teach_at: list[int] = []
        # The last frame segmented and its images (None for a view left out), which
        # teaching reads instead of decoding them again: a video camera's reader is the
        # read-ahead thread's meanwhile.
        self._segmented: tuple[int, list] = (-1, [])
        self.seconds: dict = defaultdict(float)
        self.problems = ProblemLog(warn=False)
        """Frames and views left out, and why (:mod:`hullcap._problems`)."""

    # -- one frame's input -------------------------------------------------------------

    @property
    def _given_silhouettes(self) -> bool:
        return self.options.use_silhouettes and self.sequence.has_silhouettes

    def masks(self, frame: int, priors=None) -> list[np.ndarray]:
        """The silhouettes of `frame`: given, or by background subtraction, guided by the
        predicted model's silhouettes `priors` (one bool mask per view) when the options
        say so."""
        return self._segment(frame, priors)[0]

    def _segment(self, frame: int, priors=None) -> tuple[list[np.ndarray], list[np.ndarray | None]]:
        """``(masks, unsure)``: :meth:`masks`, and for each view where its guided mask was
        not sure of the background (:meth:`GuidedSegmenter.segment`; None for a view not
        guided)."""
        t0 = time.perf_counter()
        inputs = self._ahead.take(frame) if self._ahead is not None else self._inputs(frame)

        def segmented(i: int):
            view = inputs[i]
            return self._guided[i].segment(view.image, None if priors is None else priors[i], view.evidence)

        to_segment = [i for i, view in enumerate(inputs) if isinstance(view, _Input) and view.mask is None]
        self._segmented = (frame, [inputs[i].image if i in to_segment else None for i in range(len(inputs))])
        segmented_views = dict(zip(to_segment, over_views(segmented, to_segment)))
        masks, unsure = [], []
        for i, (cam, view) in enumerate(zip(self.sequence.cameras, inputs)):
            if isinstance(view, ViewError):  # a missing or broken image or mask: leave that view out
                self._view_left_out(frame, cam, view)
                masks.append(np.zeros((cam.height, cam.width), np.uint8))
            elif view.mask is not None:
                masks.append(view.mask)
            else:
                masks.append(segmented_views[i][0])
            unsure.append(segmented_views[i][1] if i in segmented_views else None)
        self.seconds["silhouettes"] += time.perf_counter() - t0
        return masks, unsure

    def _inputs(self, frame: int) -> list[_Input | ViewError]:
        """What each camera gives for `frame` before any prediction: the given mask, the
        mask of the unguided background test, or the image with the guided segmenter's
        background evidence; or the ViewError that leaves it out. Runs on the read-ahead
        thread: it may not touch the problem log."""
        seq = self.sequence
        segmenters = None if self._given_silhouettes else self._segmenters()
        inputs: list[_Input | ViewError] = []
        for i, cam in enumerate(seq.cameras):
            if cam.name in self._no_background:
                inputs.append(self._no_background[cam.name])
                continue
            try:
                if self._given_silhouettes:
                    inputs.append(_Input(mask=seq.mask(frame, cam.name)))
                    continue
                image = seq.image(frame, cam.name)
            except ViewError as e:
                inputs.append(e)
                continue
            if segmenters is None:
                inputs.append(_Input(mask=self._backgrounds[i].mask(image)))
            else:
                inputs.append(_Input(image=image, evidence=segmenters[i].background.evidence(image)))
        return inputs

    def _images(self, frame: int) -> list[np.ndarray | None]:
        """Frame `frame` of every camera; ``None`` for a view that cannot be used (recorded)."""
        images = []
        for cam in self.sequence.cameras:
            try:
                images.append(self.sequence.image(frame, cam.name))
            except ViewError as e:
                self._view_left_out(frame, cam, e)
                images.append(None)
        return images

    def _view_left_out(self, frame: int, cam, error: ViewError) -> None:
        """Record that `cam` is left out of `frame`; a camera without its background is
        left out of every frame, and was said so once, at start-up."""
        if (frame, cam.name) not in self._broken:
            self._broken.add((frame, cam.name))
            if cam.name not in self._no_background:
                self.problems.add(frame, error.what, cam.name, error.file)

    @property
    def _hull_tolerance(self) -> int:
        tolerance = self.options.hull_tolerance
        return tolerance if tolerance is not None else (0 if self._given_silhouettes else 1)

    @property
    def _hand_reach(self) -> float:
        reach = self.options.hand_reach
        return reach if reach is not None else (0.6 if self._given_silhouettes else 1.0)

    def _segmenters(self):
        """The background models (None for a camera without a usable background image, in
        `_no_background`); the guided segmenters built on them, or None. A SequenceError
        when no camera has a background image."""
        if self._backgrounds is None:
            seq = self.sequence
            backgrounds = []
            for cam in seq.cameras:
                try:
                    backgrounds.append(background_model(seq.background(cam.name), self.options.background))
                except ViewError as e:
                    self._no_background[cam.name] = e
                    backgrounds.append(None)
            if len(self._no_background) == len(seq.cameras):
                first = next(iter(self._no_background.values()))
                raise SequenceError(
                    f"{seq.path}: no camera has a usable background image ({first}); background subtraction "
                    "needs background/<camera>.png of the empty scene for each camera, or give the sequence your "
                    "own masks in silhouettes/<camera>/ (docs/formats.md)")
            self._backgrounds = backgrounds
            if self.options.guided and self.options.background == "statistical":
                self._guided = [None if b is None else GuidedSegmenter(b, self._guidance) for b in backgrounds]
        return self._guided

    def _silhouettes(self, model: BodyModel, pose: PoseParameters,
                     also: PoseParameters | None = None) -> list[np.ndarray]:
        """The model's (H, W) bool silhouette at `pose` in every view, united with its
        silhouette at `also` when given."""
        faces, closed = model.faces, model.closed
        posed = [model.pose(p.theta, p.root_rotation, p.root_translation).vertices
                 for p in (pose, also) if p is not None]

        def drawn(cam):
            silhouettes = [render_silhouette(cam, v, faces, closed=closed) for v in posed]
            return silhouettes[0] if len(silhouettes) == 1 else np.logical_or.reduce(silhouettes)
        return over_views(drawn, self.sequence.cameras)

    def _guides(self) -> bool:
        """Whether silhouettes are guided by the model."""
        return not self._given_silhouettes and self._segmenters() is not None

    def _window_end(self, first: int, n: int) -> int:
        """The frame after the first `calibration_seconds` from `first` (at most `n`)."""
        return min(n, first + max(2, int(round(self.options.calibration_seconds * self.sequence.fps))))

    def _teaching_frames(self, first: int, n: int) -> list[int]:
        """The frames after `first`, spread over the first `calibration_seconds`, from which
        tracking teaches the guided segmenters colours as it goes, when they know fewer than
        `calibration_frames` frames' colours. A refined model's window taught them that many
        (:meth:`_refine`), the bends of the body among them; a given model, or one built
        without ``refine_joints``, was placed at one frame, whose colours alone they know.
        Each is taught at the first frame from it on that passes without a search."""
        if not self._guides() or self._colour_frames >= self.options.calibration_frames:
            return []
        return _spread(list(range(first, self._window_end(first, n))), self.options.calibration_frames)[1:]

    def learn_colours(self, frame: int, model: BodyModel, pose: PoseParameters, fresh: bool = False,
                      images: list | None = None) -> None:
        """Teach the guided segmenters the subject's and background's colours from a frame
        in which `model` is fitted at `pose` (`fresh`: forget what they knew); `images`:
        the frame's, when they were read already (None for a view left out). No-op when
        the silhouettes are not guided."""
        if not self._guides():
            return
        images = self._images(frame) if images is None else images
        self._colour_frames = 1 if fresh else self._colour_frames + 1
        for seg, img, sil in zip(self._guided, images, self._silhouettes(model, pose)):
            if seg is None:  # a camera without its background
                continue
            if fresh:
                seg.colours.clear()
            if img is not None:
                seg.learn(img, sil)

    def hull(self, frame: int, prior=None):
        """The visual hull of `frame`, with the model at a predicted pose as its prior
        (`prior`: ``(model, PoseParameters)``): it guides the silhouettes (:meth:`masks`)
        and says where a view that misses a part may be overruled (`hull_tolerance`).
        `HullError` (a `ValueError`) when there is no hull."""
        return self._carve(frame, prior)[0]

    def _carve(self, frame: int, prior=None, doubt: float | None = None):
        """``(hull, masks)`` of `frame` (see :meth:`hull`); with `doubt` (metres, see
        `hull_doubt`), the hull less the vertices no guided view vouches for."""
        tolerance = self._hull_tolerance
        # The prior's silhouettes serve the guided masks and the tolerant hull, nothing else.
        used = prior is not None and (tolerance > 0 or self._guides())
        t0 = time.perf_counter()
        silhouettes = self._silhouettes(*prior) if used else None
        self.seconds["silhouettes"] += time.perf_counter() - t0  # the prediction, drawn for the masks
        masks, unsure = self._segment(frame, silhouettes)
        t0 = time.perf_counter()
        report = HullReport()
        priors = None if silhouettes is None or tolerance == 0 else \
            over_views(lambda view: _overrulable(*view, self._guidance.outer), zip(silhouettes, unsure))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # views left out are recorded in `problems`
                surface = visual_hull(masks, self.sequence.cameras, self.options.voxel_size, self.bounds, report,
                                      tolerance=tolerance, priors=priors)
            if doubt is not None and any(u is not None for u in unsure):
                keep = ~doubtful_vertices(surface, masks, unsure, self.sequence.cameras, doubt,
                                          self.options.hull_doubt_views)
                surface = surface.subset(keep) if keep.any() else surface  # an empty target fits nothing
            return surface, masks
        finally:
            for name, why in report.skipped.items():
                if (frame, name) not in self._broken:
                    self.problems.add(frame, f"left out ({why})", name)
            self.seconds["hull"] += time.perf_counter() - t0

    def _agreement(self, masks, model: BodyModel, pose: PoseParameters) -> float:
        """Mean over the views of the IoU of `model`'s silhouette at `pose` and `masks`."""
        ious = []
        for mask, sil in zip(masks, self._silhouettes(model, pose)):
            union = np.logical_or(mask > 0, sil).sum()
            ious.append(np.logical_and(mask > 0, sil).sum() / union if union else 0.0)
        return float(np.mean(ious))

    # -- the sequence ------------------------------------------------------------------

    def run(self, out, resume: bool = True, show_progress: bool = True, frames: int | None = None,
            interpolate: bool = False, smooth_hz: float | None = None, overlays: bool = False) -> TrackingResult:
        """Track the sequence into folder `out` (see the module documentation): the results,
        ``report.png``, ``problems.json`` and, with `overlays`, ``overlay/<cam>.mp4``.
        `interpolate` and `smooth_hz` go to :func:`hullcap._results.write_outputs`. The
        checkpoint stays until every output is written, so an interruption at any point
        resumes without tracking again what was tracked."""
        from hullcap.export import write_overlays, write_report

        if frames is not None and frames < 1:
            raise OptionsError(f"frames must be at least 1, got {frames}")
        if smooth_hz is not None:
            check_cutoff(smooth_hz, self.sequence.fps)  # now, not after tracking
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        self.problems.warn = show_progress
        n = self._frames_to_track(frames)
        result, start, state = self._resume(out, n) if resume else (None, 0, None)
        if result is None:
            t0, before = time.perf_counter(), dict(self.seconds)
            model, start, anchor = self._subject(n, show_progress)
            self._teach_at = self._teaching_frames(start, n)
            # The subject's frames (the calibration pass too) count as 'subject' only, so
            # that the per-stage seconds are those of tracking the sequence once.
            self.seconds = defaultdict(float, before)
            self.seconds["subject"] += time.perf_counter() - t0
            tracked = model.with_wrists() if self.options.wrists else model
            tracked.save(out / "model")
            result = TrackingResult.empty(tracked, n, self.sequence.fps)
            state = self._tracking_state(tracked, start, anchor, built=model)
        bar = progress(range(start, n), total=n, desc=f"track {self.sequence.path.name}", enable=show_progress,
                       initial=start)
        with self._reading_ahead(range(start, n)):
            for frame in bar:
                self._track(state, result, frame)
                if frame % 10 == 0:
                    self._checkpoint(out, result, frame + 1, state)
        bar.close()
        self._checkpoint(out, result, n, state)
        result.seconds = dict(self.seconds)
        write_outputs(out, result, interpolate, smooth_hz)
        write_report(out / "report.png", result)
        if overlays:
            write_overlays(out, self.sequence, result, show_progress=show_progress)
        self.problems.save(out / PROBLEMS)
        (out / CHECKPOINT).unlink(missing_ok=True)
        return result

    @contextmanager
    def _reading_ahead(self, frames):
        """While it lasts, :meth:`masks` takes `frames`, in order, from the read-ahead
        thread (when the options ask for one)."""
        if self.options.read_ahead == 0 or not len(frames):
            yield
            return
        if not self._given_silhouettes:
            self._segmenters()  # built here, not on the other thread
        ahead = ReadAhead(self._inputs, frames, self.options.read_ahead)
        try:
            with ahead:
                self._ahead = ahead
                yield
        finally:
            self._ahead = None
            self.seconds["read ahead"] += ahead.seconds

    def _frames_to_track(self, frames: int | None) -> int:
        """How many frames to track, after the start-up checks: every camera's frames on
        disk against ``meta.json`` (recorded; frames that no camera has are not tracked)
        and the image size of every camera against its calibration."""
        seq = self.sequence
        n = len(seq) if frames is None else min(frames, len(seq))
        counts = seq.frame_counts(silhouettes=self._given_silhouettes)
        if any(k != len(seq) for k in counts.values()):
            on_disk = ", ".join(f"{name} {k}" for name, k in counts.items())
            self.problems.add(None, f"meta.json says {len(seq)} frames, on disk: {on_disk}; "
                                    f"a camera's missing frames leave its view out")
        if not self._given_silhouettes:
            seq.check_image_sizes()
            self._segmenters()
            for name, e in self._no_background.items():
                self.problems.add(None, f"left out of every frame: no usable background image ({e.what})", name,
                                  e.file)
        return max(1, min(n, max(counts.values())))

    def _subject(self, n: int, show_progress: bool):
        """``(model, first frame, its pose)``: the subject's model, built (and refined) at the
        first frame whose hull it explains, or the given one placed there."""
        options = self.options
        for frame in range(n):
            try:
                hull, masks = self._carve(frame)
            except ValueError as e:
                self.problems.add(frame, str(e))
                continue
            if self.model is not None:
                placed = place_model(self.model, hull, options=options.subject)
                if self._agreement(masks, self.model, placed.pose) >= options.min_subject_agreement:
                    self.learn_colours(frame, self.model, placed.pose, fresh=True)
                    return self.model, frame, placed
                continue
            try:
                subject = build_subject(hull, options=options.subject)
                # Silhouettes guided by the model just built see what the first ones missed
                # (clothes the colour of the room): build it again from them, twice.
                for _ in range(2 if self._guides() else 0):
                    self.learn_colours(frame, subject.model, subject.pose, fresh=True)
                    guided, masks = self._carve(frame, (subject.model, subject.pose))
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
        # knees placed from three frames; docs/accuracy.md). Only the frames whose fits
        # reach `min_quality` build the model.
        strict = replace(self.options, fit=self.options.calibration_fit, quick_fit=None, girdle_fit=None,
                         recheck_margin=None, search=replace(self.options.search, girdle_tolerance=0.0),
                         hull_doubt=None, min_quality=0.0)
        state = TrackingState(subject.model, strict, subject.fit, search_fit=self.options.fit)
        for frame in progress(range(first, last), total=last - first, desc="calibrate", enable=show_progress):
            self._track(state, window, frame)
        stands = window.quality >= self.options.min_quality
        good = [f for f in range(first, last) if not window.failed[f] and stands[f]]
        if len(good) < 2:
            return subject.model, first, subject.fit
        picks = _spread(good, self.options.calibration_frames)
        poses = [window.pose(f) for f in picks]
        for k, (f, pose) in enumerate(zip(picks, poses)):
            self.learn_colours(f, subject.model, pose, fresh=k == 0)
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
            measured = _spread(good, o.surface_frames)
            shown = [self.hull(f, (subject.model, window.pose(f))) for f in measured]
            at = over_fits(lambda job, threads: fit(model, make_target(job[0]), job[1], o.fit, threads=threads).pose,
                           [(h, window.pose(f)) for f, h in zip(measured, shown)])
            model, moved = fitted_surface(model, shown, at, o), True
        if not moved:
            return model, first, refined.fit
        return model, first, fit(model, make_target(hulls[0]), refined.pose, self.options.subject.fit)

    def _tracking_state(self, model: BodyModel, first: int | None = None, anchor: FitResult | None = None,
                        built: BodyModel | None = None) -> TrackingState:
        """The state of tracking a sequence with `model`: its fits take the model with the
        hands of ``options.hand_reach`` (by default as the silhouettes' source asks), the
        silhouettes are guided by `model` itself. The anchor (the fit at frame `first` of
        the subject's model as built, `built`, by default `model`; ``options.wrists`` may
        have given `model` wrists since) is fitted again with the model the fits take."""
        built = built or model
        fitted = with_hands(model, self._hand_reach)
        if anchor is not None and fitted is not built:
            target = make_target(self.hull(first, (built, anchor.pose)))
            anchor = fit(fitted, target, anchor.pose.carried(built, fitted), self.options.subject.fit)
        return TrackingState(fitted, self.options, anchor, guide=model)

    def _track(self, state: TrackingState, result: TrackingResult, frame: int) -> None:
        """Fit one frame, judge it, search when needed, and record it, by the state's
        options. Its silhouettes are guided by the predicted pose when the frame before
        was tracked (after a failure, a wrong prediction would hide the person it missed),
        with each elbow in doubt drawn as it was too (``TrackerOptions.elbow_doubt``)."""
        starts = state.starts(result, frame)
        follows = frame > 0 and not result.failed[frame - 1]
        before = state.as_before(starts[0]) if starts and follows else None
        prior = (state.guide, starts[0], before) if starts and (follows or state.anchor_only(result, frame)) else None
        try:
            surface = self._carve(frame, prior, state.options.hull_doubt)[0]
        except ValueError as e:  # no usable view in this frame
            self.problems.add(frame, str(e))
            result.fail(frame)
            return
        t0 = time.perf_counter()
        target = make_target(surface)
        best, iterations = None, 0
        options = state.options
        first = options.fit if options.quick_fit is None else options.quick_fit
        for start in starts:
            fitted = self._fit_from(state, target, start, first)
            iterations += fitted.iterations
            if best is None or quality(fitted) > quality(best):
                best = fitted
            if state.good(best):
                break
        if best is not None and not state.good(best) and options.quick_fit is not None:
            fitted = self._fit_from(state, target, starts[0], options.fit)  # the paper's schedule
            iterations += fitted.iterations
            if quality(fitted) > quality(best):
                best = fitted
        girdle = None if best is None else state.search.girdle_start(best.pose)
        if girdle is not None:
            girdle_options = first if options.girdle_fit is None else options.girdle_fit
            fitted = self._fit_from(state, target, girdle, girdle_options)
            iterations += fitted.iterations
            if state.takes_girdle_fit(best, fitted):
                best = fitted
        held = None if best is None or not starts else state.hinges_held(starts[0], best.pose)
        if held is not None:
            fitted = self._fit_from(state, target, starts[0], first, held)
            iterations += fitted.iterations
            if quality(fitted) >= quality(best) - options.hinge_tolerance:
                best = fitted
        if before is not None and best is not None:
            # An elbow turned fast in the frames before: the forearm as it was, held so,
            # stands when it explains the hull clearly better.
            fitted = self._fit_from(state, target, before, first, state.held_as_before())
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
                polished = self._fit_from(state, target, best.pose, options.fit)
                iterations += polished.iterations
                if quality(polished) > quality(best):
                    best = polished
        if best is None:  # nothing to start from and no search
            result.fail(frame)
            return
        result.record(frame, best, status, iterations, bar)
        if status != FAILED:
            state.remember_fit(best)
        self.seconds["fit"] += time.perf_counter() - t0
        if passed and self._teach_at and frame >= self._teach_at[0] and self._segmented[0] == frame:
            self._teach_at = [f for f in self._teach_at if f > frame]
            self.learn_colours(frame, state.guide, best.pose, images=self._segmented[1])

    def _fit_from(self, state: TrackingState, target, start: PoseParameters, options: FitOptions,
                  model: BodyModel | None = None) -> FitResult:
        """A tracking fit from `start` (of `model`, by default the state's), whose joints
        are held near it by the motion prior (``TrackerOptions.motion_sigma``)."""
        sigma = state.options.motion_sigma
        prior = None if sigma is None else PosePrior(start.theta, np.full(state.model.n_dofs, sigma),
                                                     state.options.motion_prior_distance)
        return fit(model or state.model, target, start, options, prior=prior)

    def _checkpoint(self, out: Path, result: TrackingResult, next_frame: int, state: TrackingState) -> None:
        buf = io.BytesIO()
        np.savez(buf, next_frame=next_frame, sequence=str(self.sequence.path.resolve()), **result.arrays(),
                 **self._learnt(), **state.carried())
        self.problems.save(out / PROBLEMS)
        atomic_write(out / CHECKPOINT, buf.getvalue())

    def _learnt(self) -> dict:
        """What the run has learnt besides its results, for the checkpoint: the guided
        segmenters' colours and the frames still to teach them from."""
        learnt = {LEARNT_TEACH_AT: np.asarray(self._teach_at, np.int64)}
        if self._guides():
            known = next(g for g in self._guided if g is not None)  # a camera without its background: none
            for name, part in zip(LEARNT_COLOURS, ("subject", "background")):
                none = np.zeros_like(getattr(known.colours, part))
                learnt[name] = np.stack([none if g is None else getattr(g.colours, part) for g in self._guided])
        return learnt

    def _relearn(self, arrays: dict) -> None:
        """Takes back from a checkpoint's `arrays` (and removes from them) what
        :meth:`_learnt` put there, so that a resumed run goes on as the interrupted one would."""
        teach_at = np.asarray(arrays.pop(LEARNT_TEACH_AT, np.empty(0, np.int64)))
        if teach_at.ndim != 1 or teach_at.dtype.kind not in "iu":
            raise ValueError(f"{LEARNT_TEACH_AT} is not a list of frames")
        self._teach_at = [int(f) for f in teach_at]
        colours = [arrays.pop(name, None) for name in LEARNT_COLOURS]
        if colours[0] is not None and self._guides():
            if any(len(c) != len(self._guided) for c in colours):
                raise ValueError(f"colours of {len(colours[0])} cameras, not {len(self._guided)}")
            for g, subject, background in zip(self._guided, *colours):
                if g is not None:
                    g.colours.restore(subject, background)

    def _resume(self, out: Path, n: int):
        """``(result, next frame, state)`` of the checkpoint in `out`, or ``(None, 0, None)``
        when there is none for this sequence."""
        path = out / CHECKPOINT
        if not path.is_file() or not (out / "model").is_dir():
            return None, 0, None
        try:
            with np.load(path) as z:
                if str(z["sequence"]) != str(self.sequence.path.resolve()) or len(z["failed"]) != n:
                    return None, 0, None
                arrays = {k: z[k] for k in z.files}
            self._relearn(arrays)
            result, start = TrackingResult.from_arrays(BodyModel.load(out / "model"), arrays), int(arrays["next_frame"])
            state = self._tracking_state(result.model)
            state.resume(arrays, result, start)
        except (*NPZ_ERRORS, TypeError) as e:
            raise ResultsError(f"{path}: the checkpoint is damaged ({e}); run again with --restart "
                               f"(resume=False) to start over") from None
        if (out / PROBLEMS).is_file():
            self.problems.extend(ProblemLog.load(out / PROBLEMS))
        return result, start, state


@dataclass
class _Input:
    """One camera's input of one frame: its mask, or its image and background evidence."""

    mask: np.ndarray | None = None
    image: np.ndarray | None = None
    evidence: np.ndarray | None = None


def _overrulable(silhouette: np.ndarray, unsure: np.ndarray | None, band: float) -> np.ndarray:
    """Where the tolerant hull may overrule a view: its predicted `silhouette` grown by
    `band` of its height (the prediction's error), less what the view's guided mask
    called background for sure (`unsure` False; None for a view not guided)."""
    grown = dilated(silhouette, band)
    return grown if unsure is None else grown & unsure


def _spread(frames: list[int], n: int) -> list[int]:
    """Up to `n` of `frames`, spread evenly over them (the first and the last among them)."""
    return sorted({frames[int(round(i))] for i in np.linspace(0, len(frames) - 1, n)})
