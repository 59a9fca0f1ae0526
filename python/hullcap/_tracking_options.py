"""Every choice of a tracking run (:class:`TrackerOptions`), checked when it is made."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, is_dataclass

from hullcap._fitting import FitOptions
from hullcap._guided import GuidedOptions
from hullcap._hull import VOXEL_SIZE
from hullcap._options import (AT_LEAST_ONE, BOOL, FRACTION, NON_NEGATIVE, NON_NEGATIVE_INT, POSITIVE, Rule,
                              check_fields, one_of, option, or_none)
from hullcap._reacquire import SearchOptions
from hullcap._silhouette import BACKGROUND_MODELS
from hullcap._subject import SubjectOptions

__all__ = ["OVER_RELAXATION", "PRESETS", "TrackerOptions", "frame_fit_options", "quick_fit_options", "settings"]

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


def frame_fit_options(**changes) -> FitOptions:
    """The per-frame fit (``TrackerOptions.fit``): two-sided, hierarchical, one round of
    coarse stages, its steps over-relaxed; `changes` over that; a new object each call."""
    return FitOptions(rounds=1, reverse_weight=1.0, coarse=2, over_relaxation=OVER_RELAXATION).replace(**changes)


def _live() -> dict:
    """The settings the live preset changes (docs/performance.md, "The live preset": what
    each costs in accuracy and buys in speed)."""
    return {"voxel_size": 0.02, "subject_voxel_size": VOXEL_SIZE,
            "fit": frame_fit_options(iterations=6, tolerance=2e-3), "learned_every": 3}


PRESETS = {"accurate": dict, "live": _live}
"""Each preset's settings over the defaults (a function, so that each gets fresh fit
options): ``accurate``, the defaults; ``live``, lighter settings for speed."""


@dataclass(frozen=True)
class TrackerOptions:
    """Every choice of a tracking run, each with its help and its rule (:func:`hullcap.
    _options.option`); ``docs/options.md`` lists them, and the accuracy notebook
    (``docs/notebooks/accuracy.md``, "Why the tracker's defaults are what they are") gives
    the measurements behind the defaults. Angles in radians, distances in metres, times in
    seconds; qualities are fractions of points (0…1)."""

    # Silhouettes (hullcap._segmenter)
    background: str = option("statistical", rule=one_of(*BACKGROUND_MODELS), flag=True, metavar="METHOD",
                             help="background subtraction when the sequence has no silhouettes/ (or they are ignored)")
    ignore_silhouettes: bool = option(False, rule=BOOL, flag=True,
                                      help="subtract the background even when the sequence has silhouettes/")
    segmenter: str = option("auto", rule=one_of("auto", "learned", "colour"), flag=True, metavar="KIND",
                            help="where the sequence has no silhouettes/: 'learned', the learned person segmenter "
                                 "fused with the background test where there is a background image "
                                 "(hullcap[segment], docs/segmentation.md); 'colour', the background test alone; "
                                 "'auto', learned where it is installed")
    learned_every: int = option(2, rule=AT_LEAST_ONE, help="run the learned segmenter in each view every this "
                                                            "many frames, the views taking turns (every frame "
                                                            "while the subject's model is built, and in a view "
                                                            "without a background image); 1, every frame: slower, "
                                                            "and no more accurate on the development set "
                                                            "(docs/segmentation.md)")
    guided: bool = option(True, rule=BOOL, help="guide each frame's statistical test by the predicted model and "
                                                "the subject's colours (hullcap._guided)")
    guidance: GuidedOptions = option(factory=GuidedOptions, help="the guided silhouettes' options")
    read_ahead: int = option(2, rule=NON_NEGATIVE_INT, help="frames read and segmented on a second thread "
                                                            "while the frame before is fitted (0: none); "
                                                            "the results are the same")
    # The visual hull (hullcap._carver)
    voxel_size: float = option(VOXEL_SIZE, rule=POSITIVE, flag=True, metavar="METRES",
                               help="the visual hull's voxel size in metres")
    subject_voxel_size: float | None = option(None, rule=or_none(POSITIVE),
                                              help="the finest voxel of the hulls the subject's model is built "
                                                   "from (None: voxel_size): built once, it may take finer hulls "
                                                   "than tracking carves every frame")
    hull_tolerance: int | None = option(None, rule=or_none(NON_NEGATIVE_INT),
                                        help="views that may leave a voxel out where the prediction puts the body "
                                             "(None: 1 from background subtraction, 0 from given silhouettes)")
    hull_doubt: float | None = option(0.02, rule=or_none(POSITIVE),
                                      help="while tracking, leave out of the fit the hull's vertices no view "
                                           "vouches for this far outside them (None: fit the whole hull)")
    hull_doubt_views: int = option(3, rule=AT_LEAST_ONE, help="views that must leave that point out (hull_doubt)")
    # The subject's model (hullcap._subject_builder)
    subject: SubjectOptions = option(factory=SubjectOptions, help="how the subject's model is built")
    refine_joints: bool = option(True, rule=BOOL, flag=True,
                                 help="refine the subject's proportions, joint centres and surface from the first "
                                      "seconds of motion, then track from the start (a given model is used as it "
                                      "is)")
    calibration_seconds: float = option(5.0, rule=POSITIVE, help="the first seconds tracked to refine the model "
                                                                 "(and to teach the guided masks the colours)")
    calibration_frames: int = option(8, rule=Rule("a whole number >= 2", lambda v: isinstance(v, int) and v >= 2),
                                     help="frames of those seconds the model is refined over")
    calibration_fit: FitOptions = option(factory=lambda: FitOptions(rounds=2, reverse_weight=1.0),
                                         help="the fit of those seconds: two full rounds, the model is built "
                                              "from their poses")
    min_subject_agreement: float = option(0.5, rule=FRACTION, help="mean IoU of the model's and the masks' "
                                                                   "silhouettes for tracking to start at a frame")
    # Each frame's fit (hullcap._frame_fitter)
    fit: FitOptions = option(factory=frame_fit_options,
                             help="the per-frame fit: two-sided, hierarchical, one round of coarse stages")
    quick_fit: FitOptions | None = option(None, help="when set, the fit from each start in place of fit, for speed")
    girdle_fit: FitOptions | None = option(factory=quick_fit_options,
                                           help="the fit from the girdle start (None: as the other starts)")
    quality_window: int = option(30, rule=AT_LEAST_ONE, help="recent accepted frames whose median quality a "
                                                             "frame is judged against")
    quality_margin: float = option(0.1, rule=NON_NEGATIVE, help="a fit this far below that median is searched for")
    chain_margin: float = option(0.2, rule=NON_NEGATIVE, help="and so is a fit with a limb chain this far below "
                                                              "its own")
    min_quality: float = option(0.5, rule=NON_NEGATIVE, help="below this a fit never stands: the frame fails")
    recheck_margin: float | None = option(0.05, rule=or_none(NON_NEGATIVE),
                                          help="after a search found nothing better, frames within this of its "
                                               "quality pass without one (None: every frame below is searched)")
    confirm_margin: float = option(0.02, rule=NON_NEGATIVE,
                                   help="a search's fit replaces the tracked one when better by more than this")
    reacquire: bool = option(True, rule=BOOL, help="search from the hull when a fit is not good (else it fails)")
    search: SearchOptions = option(factory=SearchOptions, help="the search's options")
    motion_sigma: float | None = option(None, rule=or_none(POSITIVE),
                                        help="a Gaussian prior holding each joint angle near its start (radians; "
                                             "None: the paper's energy)")
    motion_prior_distance: float = option(0.003, rule=NON_NEGATIVE,
                                          help="metres of pair distance one motion_sigma is worth")
    hinge_jump: float | None = option(math.radians(45.0), rule=or_none(POSITIVE),
                                      help="an elbow or knee turned further than this from the prediction is "
                                           "fitted again held (radians; None: no check)")
    hinge_hold: float = option(math.radians(10.0), rule=NON_NEGATIVE,
                               help="how near the prediction a held hinge stays (radians)")
    hinge_tolerance: float = option(0.005, rule=NON_NEGATIVE,
                                    help="the free fit stands when it explains the hull better by more than this")
    elbow_doubt: float = option(0.5, rule=NON_NEGATIVE, help="seconds an elbow that turned fast stays in doubt "
                                                              "(0: never)")
    elbow_span: float = option(0.1, rule=POSITIVE, help="seconds within which turning more than hinge_jump is "
                                                        "fast")
    hand_reach: float | None = option(None, rule=or_none(FRACTION), flag=True, metavar="F",
                                      help="fit each hand pulled toward its wrist to this part of its length (1: "
                                           "whole hands; default 0.6 with the sequence's own silhouettes, 1 from "
                                           "background subtraction)")
    wrists: bool = option(True, rule=BOOL, flag=True,
                          help="track with hands that turn at the wrists, two DOF each (without: the paper's 29 "
                               "DOF, each hand rigid with its forearm)")
    seed: int = option(0, help="the seed of the search's random choices")

    def __post_init__(self):
        check_fields(self)

    @classmethod
    def preset(cls, name: str, **changes) -> TrackerOptions:
        """The options of preset `name` (:data:`PRESETS`: ``"accurate"``, the defaults;
        ``"live"``, lighter settings for speed), with `changes` over them."""
        one_of(*PRESETS).check("preset", name)
        return cls(**{**PRESETS[name](), **changes})


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
