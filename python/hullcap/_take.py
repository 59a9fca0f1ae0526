"""One take tracked the way ``hullcap track`` tracks it, for the command and for a batch.

:class:`TakeOptions` are the command's options (the same names, with underscores, are the
keys of a take in ``session.toml``, docs/batch.md); :func:`track_take` runs the tracker
with them and returns a :class:`TakeSummary`. ``hullcap track`` and ``hullcap batch``
both call it, so that a take tracked in a batch gives the same files as on its own.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from hullcap.errors import OptionsError, TrackingError

__all__ = ["TakeOptions", "TakeSummary", "track_take"]

FEW_CAMERAS = 6
"""Below this many cameras ``hullcap track`` warns when it subtracts the background: on the
development set's adults filmed by 4 of their cameras, colour frames lost limbs for
seconds (MPJPE 34–48 mm) where exact masks gave 22–36 mm; docs/accuracy.md, "Fewer
cameras"."""
SAID_LIMITS = 4
"""How many of the joint angles held at a limit the end of a run names, the most held first."""


@dataclass(frozen=True)
class TakeOptions:
    """The options of ``hullcap track`` (see its ``--help`` or docs/cli.md).

    Attributes:
        voxel: visual hull voxel size (metres).
        background: ``"statistical"`` or ``"mog2"``, when the take has no silhouettes.
        ignore_silhouettes: subtract the background even when the take has silhouettes.
        volume: the capture volume ``(x0, y0, z0, x1, y1, z1)`` in metres (``None``: what
            every camera sees).
        frames: track only the first this many frames (``None``: all).
        refine_joints: refine the subject's model from the first seconds of motion (a
            given model is used as it is).
        hand_reach: the part of each hand the fits keep (``TrackerOptions.hand_reach``;
            1 = whole hands; ``None``: 0.6 with the take's own silhouettes, 1 otherwise).
        wrists: track with hands that turn at the wrists (``TrackerOptions.wrists``;
            ``False``: the paper's 29 DOF, hands rigid with the forearms).
        overlays: write ``overlay/<cam>.mp4``.
        interpolate: fill failed frames between fitted ones in the outputs.
        smooth: also write trajectories low-passed at this cut-off (Hz).
        image_scale: read every image resized by this factor in (0, 1]
            (:class:`~hullcap._sequence.Sequence`'s `image_scale`).
        cameras: track with only these cameras, by name (``None``: all).
        leave_out: track without these cameras, by name.
    """

    voxel: float = 0.01
    background: str = "statistical"
    ignore_silhouettes: bool = False
    volume: tuple[float, ...] | None = None
    frames: int | None = None
    refine_joints: bool = True
    hand_reach: float | None = None
    wrists: bool = True
    overlays: bool = True
    interpolate: bool = False
    smooth: float | None = None
    image_scale: float = 1.0
    cameras: tuple[str, ...] | None = None
    leave_out: tuple[str, ...] = ()

    @classmethod
    def from_table(cls, table: dict, where: str, base: TakeOptions | None = None) -> TakeOptions:
        """Options from a TOML table (`where` names it in errors) over `base`: every key
        must be a field, of its type."""
        base = base or cls()
        known = [f.name for f in fields(cls)]
        values = asdict(base)
        for key, value in table.items():
            if key not in known:
                raise OptionsError(f"{where}: unknown option {key!r}; options: {', '.join(known)}")
            values[key] = _checked(key, value, where)
        return cls(**values)


def _checked(key: str, value, where: str):
    """`value` of option `key` as its field wants it, or an error naming both."""
    def bad(want: str):
        return OptionsError(f"{where}: {key} must be {want}, got {value!r}")

    if key in ("ignore_silhouettes", "refine_joints", "wrists", "overlays", "interpolate"):
        if not isinstance(value, bool):
            raise bad("true or false")
        return value
    if key == "background":
        if value not in ("statistical", "mog2"):
            raise bad("'statistical' or 'mog2'")
        return value
    if key == "frames":
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise bad("a whole number of frames, at least 1")
        return value
    if key in ("cameras", "leave_out"):
        if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
            raise bad('a list of camera names, ["cam0", "cam2"]')
        return tuple(value)
    if key == "volume":
        if (not isinstance(value, list) or len(value) != 6
                or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
            raise bad("six numbers [x0, y0, z0, x1, y1, z1] in metres")
        return tuple(float(v) for v in value)
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < math.inf:
        raise bad("a positive number")
    if key in ("hand_reach", "image_scale") and value > 1:
        raise bad("a fraction in (0, 1]")
    return float(value)  # voxel, smooth, hand_reach, image_scale


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


def track_take(sequence, out, options: TakeOptions = TakeOptions(), model=None, resume: bool = True,
               show_progress: bool = True, say: Callable[[str], None] | None = None,
               warn: Callable[[str], None] | None = None) -> TakeSummary:
    """Track the sequence folder `sequence` into the results folder `out` as ``hullcap
    track`` does; `model` is a body model folder of the same subject (``None``: build one).
    `say` gets the lines the command prints, `warn` its warnings."""
    from hullcap._body import BodyModel
    from hullcap._cameras import axes_meeting_point, format_bounds
    from hullcap._results import RECOVERED
    from hullcap._rig import MIN_SURROUND, surround
    from hullcap._sequence import Sequence
    from hullcap._tracking import Tracker, TrackerOptions

    say = say or (lambda line: None)
    warn = warn or say
    t0 = time.perf_counter()
    seq = Sequence(sequence, image_scale=options.image_scale, cameras=options.cameras, leave_out=options.leave_out)
    body = BodyModel.load(model) if model is not None else None
    tracker_options = TrackerOptions(voxel_size=options.voxel, background=options.background,
                                     use_silhouettes=not options.ignore_silhouettes,
                                     refine_joints=options.refine_joints, hand_reach=options.hand_reach,
                                     wrists=options.wrists)
    tracker = Tracker(seq, model=body, options=tracker_options, volume=options.volume)
    say(f"{seq}: capture volume {format_bounds(tracker.volume)}"
        + (" (given)" if options.volume else " (every camera sees it; --volume to change)"))
    spread = surround(seq.cameras, axes_meeting_point(seq.cameras))
    if spread < MIN_SURROUND:
        warn(f"the cameras surround the person over only {spread:.0f}°: the visual hull reaches far along the "
             f"viewing direction and tracking may fail (hullcap calib show)")
    if len(seq.cameras) < FEW_CAMERAS and not tracker.segmenter.given:
        warn(f"{len(seq.cameras)} cameras and background subtraction: on the development set's adults filmed by "
             f"4 of their cameras, limbs the masks missed were lost for seconds, 34-48 mm mean joint error against "
             f"22-36 mm from exact masks (docs/accuracy.md, 'Fewer cameras'); a segmenter's masks in "
             f"silhouettes/<cam>/ track better with few views")
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
    if summary.problems:
        say(f"problems: {summary.problems} (all in {Path(out) / 'problems.json'})")
    held = result.limits_held()
    if held:
        say(limits_held_line(held))
    return summary


def limits_held_line(held) -> str:
    """The line the end of a run gives the joint angles held at a limit of the model
    (``TrackingResult.limits_held``), the first :data:`SAID_LIMITS` of them by name."""
    shown = ", ".join(f"{name} ({side}) {frames}" for name, side, frames in held[:SAID_LIMITS])
    more = f" and {len(held) - SAID_LIMITS} more" if len(held) > SAID_LIMITS else ""
    return (f"frames with a joint angle held at a limit of the model, where it is a bound and not a "
            f"measurement: {shown}{more} (report.png)")

