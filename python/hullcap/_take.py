"""One take tracked the way ``hullcap track`` tracks it, for the command and for a batch.

:class:`TakeOptions` are the command's options (the same names, with underscores, are the
keys of a take in ``session.toml``, docs/batch.md); :func:`track_take` runs the tracker
with them and returns a :class:`TakeSummary`. ``hullcap track`` and ``hullcap batch``
both call it, so that a take tracked in a batch gives the same files as on its own.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from hullcap._options import (AT_LEAST_ONE, BOOL, CAMERA_NAMES, FRACTION, POSITIVE, VOLUME, check_fields, flag_fields,
                              from_arguments, from_value, one_of, option, or_none, reference_table)
from hullcap._tracking_options import PRESETS, TrackerOptions
from hullcap.errors import OptionsError, TrackingError

__all__ = ["TakeOptions", "TakeSummary", "options_page", "track_take"]

FEW_CAMERAS = 6
"""Below this many cameras ``hullcap track`` warns when it subtracts the background: with
few views a limb the masks miss is not carved back by the others (docs/accuracy.md,
"Fewer cameras")."""
SAID_LIMITS = 4
"""How many of the joint angles held at a limit the end of a run names, the most held first."""


@dataclass(frozen=True)
class TakeOptions:
    """The options of ``hullcap track`` (see its ``--help`` or docs/cli.md): the tracker's
    that a take may set (:attr:`tracking`, the flag fields of :class:`TrackerOptions`) and
    the run's own below. ``session.toml`` takes them as flat keys (:meth:`from_table`)."""

    tracking: TrackerOptions = field(default_factory=TrackerOptions)
    preset: str = option("accurate", rule=one_of(*PRESETS), flag=True, metavar="NAME",
                         help="'accurate' (the default) or 'live': lighter settings for speed, at some accuracy "
                              "(docs/performance.md, \"The live preset\"); the tracker's options given with it "
                              "override its settings")
    volume: tuple[float, ...] | None = option(None, rule=or_none(VOLUME), flag=True, metavar="X0,Y0,Z0,X1,Y1,Z1",
                                              help="the capture volume to carve the hull in, metres (default: what "
                                                   "every camera sees)")
    frames: int | None = option(None, rule=or_none(AT_LEAST_ONE), flag=True, metavar="N",
                                help="track only the first N frames (default: all)")
    image_scale: float = option(1.0, rule=FRACTION, flag=True, metavar="S",
                                help="read every image resized by S in (0, 1], the calibration scaled with it: for "
                                     "cameras of more pixels than the hull needs, e.g. 0.5 for 1920x1080")
    cameras: tuple[str, ...] | None = option(None, rule=or_none(CAMERA_NAMES), flag=True, metavar="NAMES",
                                             help="track with only these cameras of cameras.json, by name, separated "
                                                  "by commas (default: all)")
    leave_out: tuple[str, ...] = option((), rule=CAMERA_NAMES, flag=True, metavar="NAMES",
                                        help="track without these cameras, by name, separated by commas: one "
                                             "`hullcap calib check` names, or one whose files are missing")
    overlays: bool = option(True, rule=BOOL, flag=True, help="write the overlay videos (overlay/<cam>.mp4)")
    interpolate: bool = option(False, rule=BOOL, flag=True,
                               help="fill failed frames between fitted ones from their neighbours in the outputs "
                                    "(marked 'interpolated'; pose.npz keeps the raw result)")
    smooth: float | None = option(None, rule=or_none(POSITIVE), flag=True, metavar="HZ",
                                  help="also low-pass filter the joint trajectories without lag (Butterworth, "
                                       "forwards and backwards) with this cut-off: track writes joints_smooth.csv, "
                                       "export filters what it writes")

    def __post_init__(self):
        check_fields(self)

    @classmethod
    def keys(cls) -> list[str]:
        """The keys a take's table in ``session.toml`` may have."""
        return [f.name for f in flag_fields(TrackerOptions)] + [f.name for f in flag_fields(cls)]

    @classmethod
    def from_table(cls, table: dict, where: str, base: TakeOptions | None = None) -> TakeOptions:
        """Options from a TOML table (`where` names it in errors) over `base`: every key
        must be an option, of its type. A table's ``preset`` starts the tracker's options
        afresh from that preset, its own tracker keys over it."""
        base = base or cls()
        ours = {f.name for f in flag_fields(cls)}
        tracking = {f.name for f in flag_fields(TrackerOptions)}
        own, theirs = {}, {}
        for key, value in table.items():
            if key in ours:
                own[key] = from_value(cls, key, value, where)
            elif key in tracking:
                theirs[key] = from_value(TrackerOptions, key, value, where)
            else:
                raise OptionsError(f"{where}: unknown option {key!r}; options: {', '.join(cls.keys())}")
        tracking = TrackerOptions.preset(own["preset"]) if "preset" in own else base.tracking
        return replace(base, tracking=replace(tracking, **theirs), **own)

    @classmethod
    def from_arguments(cls, args) -> TakeOptions:
        """The options a command line's parsed `args` give (:func:`hullcap._options.add_flags`)."""
        preset = TrackerOptions.preset(getattr(args, "preset", "accurate"))
        return from_arguments(cls, args, tracking=from_arguments(TrackerOptions, args, base=preset))

    def to_dict(self) -> dict:
        """The options as ``session.toml`` keys them (what ``take.json`` records)."""
        tracking = {f.name: getattr(self.tracking, f.name) for f in flag_fields(TrackerOptions)}
        return {**tracking, **{f.name: getattr(self, f.name) for f in flag_fields(type(self))}}


@dataclass(frozen=True)
class TakeSummary:
    """What a tracked take came to (one row of a batch's summary).

    Attributes:
        frames: frames tracked.
        lost: frames that failed.
        recovered: frames re-acquired by the search after a failure.
        seconds: wall time of the whole run (the subject's model too).
        problems: the problem log in one line (empty when there was none).
    """

    frames: int
    lost: int
    recovered: int
    seconds: float
    problems: str = ""

    @property
    def fps(self) -> float:
        """Frames per second of wall time."""
        return self.frames / self.seconds if self.seconds > 0 else 0.0


def _subject_line(frame: int, given: bool) -> str:
    """What a run says of the frame its subject's model came from."""
    how = "the given model placed at" if given else "the subject's model built from"
    before = f"; frames 0–{frame - 1} could not start it (why: problems.json)" if frame > 0 else ""
    return f"{how} frame {frame}, the first whose visual hull it explains{before}"


def track_take(sequence, out, options: TakeOptions = TakeOptions(), model=None, resume: bool = True,
               show_progress: bool = True, say: Callable[[str], None] | None = None,
               warn: Callable[[str], None] | None = None) -> TakeSummary:
    """Track the sequence folder `sequence` into the results folder `out` as ``hullcap
    track`` does; `model` is a body model folder of the same subject (``None``: build one).
    `say` gets the lines the command prints, `warn` its warnings."""
    from hullcap._body import BodyModel
    from hullcap._cameras import axes_meeting_point, format_bounds
    from hullcap._person import missing
    from hullcap._results import RECOVERED
    from hullcap._rig import MIN_SURROUND, surround
    from hullcap._sequence import Sequence
    from hullcap._tracking import Tracker

    say = say or (lambda line: None)
    warn = warn or say
    t0 = time.perf_counter()
    seq = Sequence(sequence, image_scale=options.image_scale, cameras=options.cameras, leave_out=options.leave_out)
    body = BodyModel.load(model) if model is not None else None
    tracker = Tracker(seq, model=body, options=options.tracking, volume=options.volume)
    say(f"{seq}: capture volume {format_bounds(tracker.volume)}"
        + (" (given)" if options.volume else " (every camera sees it; --volume to change)"))
    spread = surround(seq.cameras, axes_meeting_point(seq.cameras))
    if spread < MIN_SURROUND:
        warn(f"the cameras surround the person over only {spread:.0f}°: the visual hull reaches far along the "
             f"viewing direction and tracking may fail (hullcap calib show)")
    colour_alone = not tracker.segmenter.given and not tracker.segmenter.learned
    if colour_alone and options.tracking.segmenter == "auto":
        warn(f"silhouettes from colour alone: the learned person segmenter cannot run ({missing()}); clothes the "
             f"colour of the room go missing from the masks, and a take without background images cannot be "
             f"tracked (docs/segmentation.md)")
    if len(seq.cameras) < FEW_CAMERAS and colour_alone:
        warn(f"{len(seq.cameras)} cameras and background subtraction alone: on the development set's adults filmed by "
             f"4 of their cameras, limbs the masks missed were lost for seconds, 34-48 mm mean joint error against "
             f"22-36 mm from exact masks (docs/accuracy.md, 'Fewer cameras'); the learned segmenter, or a "
             f"segmenter's masks in silhouettes/<cam>/, track better with few views")
    result = tracker.run(out, resume=resume, show_progress=show_progress, frames=options.frames,
                         interpolate=options.interpolate, smooth_hz=options.smooth, overlays=options.overlays)
    summary = TakeSummary(frames=len(result.failed), lost=int(result.failed.sum()),
                          recovered=int((result.status == RECOVERED).sum()), seconds=time.perf_counter() - t0,
                          problems=tracker.problems.summary() if len(tracker.problems) else "")
    if summary.lost == summary.frames:
        raise TrackingError(f"{out}: no frame of {summary.frames} was tracked"
                            + (f" ({summary.problems})" if summary.problems else "")
                            + f"; written: {', '.join(tracker.written)} (report.png shows each frame's fit)")
    say(f"{out}: {summary.frames - summary.lost} of {summary.frames} frames tracked ({summary.lost} lost, "
        f"{summary.recovered} re-acquired); "
        f"{', '.join(tracker.written)}")
    say(_judged_line(result))
    if result.subject_frame >= 0:
        say(_subject_line(result.subject_frame, given=model is not None))
    if summary.problems:
        say(f"problems: {summary.problems} (all in {Path(out) / 'problems.json'})")
    held = result.limits_held()
    if held:
        say(limits_held_line(held))
    return summary


def _judged_line(result) -> str:
    """The line the end of a run gives how many frames have a joint marked uncertain, or
    that no joint could be judged."""
    from hullcap._results import UNCERTAIN

    frames = int((result.status == UNCERTAIN).sum())
    if not np.isfinite(result.confidence).any():
        if np.isfinite(result.unexplained).any():
            return (f"{frames} frames uncertain, the fit leaving the background test's foreground unexplained in "
                    "most views; joints not judged one by one: no key points of the person (the learned segmenter "
                    "did not run) (docs/accuracy.md, 'How sure a joint is')")
        return ("joints not judged: no key points of the person (the learned segmenter did not run), so 'good' "
                "says only that the fit explains the hull (docs/accuracy.md, 'How sure a joint is')")
    joints = np.flatnonzero((result.joint_status == UNCERTAIN).any(axis=0))
    which = f": {', '.join(result.model.joint_names[j] for j in joints)}" if frames else ""
    return (f"{frames} frames uncertain, a joint the person's key points do not support{which} "
            f"(joints.csv: each joint's status and confidence; report.png)")


def limits_held_line(held) -> str:
    """The line the end of a run gives the joint angles held at a limit of the model
    (``TrackingResult.limits_held``), the first :data:`SAID_LIMITS` of them by name."""
    shown = ", ".join(f"{name} ({side}) {frames}" for name, side, frames in held[:SAID_LIMITS])
    more = f" and {len(held) - SAID_LIMITS} more" if len(held) > SAID_LIMITS else ""
    return (f"frames with a joint angle held at a limit of the model, where it is a bound and not a "
            f"measurement: {shown}{more} (report.png)")


def options_page() -> str:
    """The options reference as Markdown, made from the option classes (docs/options.md)."""
    return "\n".join([
        "# Options reference", "",
        "Generated from the option classes by `hullcap._take.options_page()` (`make docs`); "
        "`tests/test_docs.py` checks it is current. Each option is declared once, with its default, rule and "
        "help, in the class that owns it; the flags of `hullcap track` ([cli.md](cli.md)) and the keys of "
        "`session.toml` ([batch.md](batch.md)) are made from these.", "",
        "## A take's options", "",
        "`hullcap track --<name-with-dashes>` (a true default is turned off by `--no-<name>`), a key of "
        "`session.toml`, or `TakeOptions` in Python (the tracker's among them in its `tracking`).", "",
        reference_table(TrackerOptions) + "\n" + reference_table(TakeOptions).split("\n", 2)[2], "",
        "## Every option of the tracker (`TrackerOptions`)", "",
        "Distances in metres, angles in radians, times in seconds, qualities fractions of points (0 to 1). Why "
        "the defaults are what they are, with the runs behind them: the accuracy notebook "
        "([notebooks/accuracy.md](notebooks/accuracy.md)).", "",
        reference_table(TrackerOptions, every=True), ""])
