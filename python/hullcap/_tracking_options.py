"""Every choice of a tracking run (:class:`TrackerOptions`), checked when it is made."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, is_dataclass

from hullcap._fitting import FitOptions
from hullcap._guided import GuidedOptions
from hullcap._reacquire import SearchOptions
from hullcap._subject import SubjectOptions
from hullcap.errors import OptionsError

__all__ = ["OVER_RELAXATION", "TrackerOptions", "quick_fit_options", "settings"]

NOT_RESULTS = frozenset({"read_ahead", "threads"})
"""Options that change how fast a run goes, not what it finds (:func:`settings` leaves them out)."""


OVER_RELAXATION = 1.5
"""How far the tracker's fits over-relax their steps (``FitOptions.over_relaxation``; why
and what it gains: ``TrackerOptions.fit``)."""


def quick_fit_options() -> FitOptions:
    """A fit of every parameter at once for at most 15 iterations, its steps over-relaxed
    as ``TrackerOptions.fit``'s, for a start a few steps from its minimum
    (``TrackerOptions.girdle_fit``, and ``quick_fit`` when asked); a new object each call,
    since fit options can be changed in place."""
    return FitOptions(hierarchical=False, iterations=15, tolerance=3e-4, reverse_weight=1.0,
                      over_relaxation=OVER_RELAXATION)


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
            from colour frames: 24.4 → 23.4 mm; docs/notebooks/accuracy.md). 2 cm: two voxels,
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
            frame on average) for no better joints (docs/notebooks/accuracy.md). The stages pair
            every second model point (``coarse=2``) and the final fit of everything
            together all of them: on 104 development-set frames fitted from the tracked
            predictions that took 45 ms a fit instead of 60, to the same joint error. The
            search uses it, and so does tracking unless `quick_fit` is set; the first
            seconds tracked for the subject's model use `calibration_fit`. Its steps,
            and the girdle fit's, are over-relaxed by :data:`OVER_RELAXATION` (design.md
            §4): over the development set with each sequence's model given, 13 % fewer
            iterations for joints as accurate or better (colour 20.35 / 13.22 →
            20.12 / 12.96 mm, exact 19.34 / 12.43 → 19.22 / 12.31; with 2, d04 from
            colour frames 1.1 mm worse). The subject's own fits stay plain: over-relaxed
            there, they moved the knee search's verdicts (d01's thigh from colour frames
            +10 %).
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
            (docs/notebooks/performance.md). The first seconds tracked to refine
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
            d01's one lost frame tracked (docs/notebooks/accuracy.md). Where a knee sits
            shows only in frames where it bends (:func:`hullcap._subject.bent_frames`),
            and people take a few seconds to bend one: in the first 3 s of d02 the tracked
            knees bent by 45° in a single landing, two or three usable frames, too few for
            the search to tell a move from noise (d02 thigh −6 % from exact masks). 5 s
            hold its second landing too, and over the development set the mean MPJPE fell
            from 24.8/16.7 to 24.5/16.6 mm (colour frames, with the scene's colours in
            the guided masks) and from 23.7/15.1 to 22.3/14.8 (exact masks)
            (docs/notebooks/accuracy.md). A sequence shorter than the window is tracked whole.
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
            candidates that beat the tracked fit, docs/notebooks/performance.md).
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
            (0.002 in the case measured, docs/notebooks/accuracy.md "A limb the hull lost"); a limb
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
            sequence's end (docs/notebooks/accuracy.md, "A limb the hull lost"). 0.1 s is three
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
            (docs/notebooks/accuracy.md); the fold it guards against came once, in one run.
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
            0.7 one run was lost from its 75th frame on (docs/notebooks/accuracy.md, "Hands as the
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
            whose hands never bend, 5.0 → 5.6 mm (docs/notebooks/accuracy.md). ``False``: the
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
    fit: FitOptions = field(default_factory=lambda: FitOptions(rounds=1, reverse_weight=1.0, coarse=2,
                                                               over_relaxation=OVER_RELAXATION))
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


def settings(options) -> dict[str, object]:
    """Every setting of `options` (a dataclass of options, nested ones and fit options
    included) that changes a run's results, by its dotted path (``"fit.max_distance"``), as
    JSON values: what a checkpoint records, so that a resume with other settings is refused
    with the difference named (:data:`NOT_RESULTS` are left out)."""
    out: dict[str, object] = {}

    def walk(value, path: str) -> None:
        if is_dataclass(value):
            for f in fields(value):
                if f.name not in NOT_RESULTS:
                    walk(getattr(value, f.name), f"{path}{f.name}.")
        elif isinstance(value, FitOptions):
            for key, v in value.to_dict().items():
                if key not in NOT_RESULTS:
                    out[f"{path}{key}"] = v
        elif isinstance(value, dict):
            for key, v in sorted(value.items()):
                walk(v, f"{path}{key}.")
        elif isinstance(value, tuple | list):
            out[path[:-1]] = [list(v) if isinstance(v, tuple) else v for v in value]
        else:
            out[path[:-1]] = value
    walk(options, "")
    return out
