"""The results folder a run owns (docs/formats.md, "A run's folder").

A run writes only names of :data:`OUTPUTS` into its folder. Before a run starts over there,
it removes what an earlier run (or ``hullcap export``) wrote, so that no file of another
take is left beside the new ones; a folder that holds anything else is refused rather
than mixed with. Whether the folder can be written, and has room, is checked at once, not
after the minutes of building the subject's model.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from hullcap.errors import ResultsError

__all__ = ["OUTPUTS", "check_writable", "clear", "check_room"]

OUTPUTS = frozenset({
    "joints.csv", "joints_smooth.csv", "pose.npz", "model", "motion.bvh", "model.glb", "report.png",
    "problems.json", "overlay", ".checkpoint.npz",
    # hullcap export's files (its default names) and a batch's record of the take.
    "joints.trc", "joints.c3d", "angles.mot", "angles.csv", "take.json",
})
"""Every name a run, ``hullcap export`` or ``hullcap batch`` writes into a results folder."""

ROOM_BASE = 50e6
ROOM_PER_VIEW = 60e3
"""Bytes a run needs free before it starts: a margin for the model, report and poses, and
per camera and frame for the overlay videos (a 640 × 480 synthetic view takes about 10 kB
in MPEG-4; real footage and larger frames more)."""


def _ours(name: str) -> bool:
    """Whether `name` is a run's: an output, or the temporary file of an atomic write of
    one that was interrupted (``.joints.csv.k3j9x.part.csv``, :func:`hullcap._files.atomic_write`)."""
    return name in OUTPUTS or (".part" in name and any(name.startswith(f".{o}.") for o in OUTPUTS))


def check_writable(out: Path) -> None:
    """Create `out` and check that files can be written there; ResultsError saying why not."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as e:
        raise ResultsError(f"{out}: cannot write the results there ({e.strerror})") from None


def clear(out: Path) -> None:
    """Remove every output an earlier run left in `out` before a run starts over there;
    ResultsError naming them when the folder holds files that are not a run's."""
    out = Path(out)
    names = sorted(p.name for p in out.iterdir())
    foreign = [n for n in names if not _ours(n)]
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise ResultsError(f"{out}: holds files that are not a run's ({shown}); give an empty or new folder, or one "
                           f"an earlier run wrote")
    for name in names:
        path = out / name
        try:
            shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
        except OSError as e:
            raise ResultsError(f"{path}: cannot remove the earlier run's file ({e.strerror})") from None


def check_room(out: Path, views: int) -> None:
    """ResultsError when the disk of `out` has less room than a run of `views` camera
    frames with overlays needs (:data:`ROOM_PER_VIEW`)."""
    need = ROOM_BASE + ROOM_PER_VIEW * views
    free = shutil.disk_usage(out).free
    if free < need:
        raise ResultsError(f"{out}: {free / 1e6:.0f} MB free, a run of {views} views needs about {need / 1e6:.0f} "
                           f"MB (fewer with --no-overlays or --frames)")
