"""What went wrong in a run, view by view: ``OUT/problems.json`` and the summary at the end.

A broken image of one camera (unreadable, truncated, missing, blank, of the wrong size, past
the end of a short video) leaves that view out of that frame; the hull and the fit use the
others. Each such event is a :class:`Problem`; the run keeps them all, writes them to
``problems.json`` (docs/formats.md) and prints one warning per camera as it goes and a
summary at the end, so nothing is lost without a word.
"""

from __future__ import annotations

import json
import sys
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path

from tqdm import tqdm

from hullcap._files import atomic_write, read_document
from hullcap.errors import ResultsError

__all__ = ["Problem", "ProblemLog", "ABSENT"]

ABSENT = "absent: no view shows the person"
"""How a frame in which the person is in no view begins its problem (the person left the
capture volume: a state of the take, not a fault of the run)."""


@dataclass(frozen=True)
class Problem:
    """One thing left out of a run.

    Attributes:
        frame: the frame (``None``: the whole sequence, found at start-up).
        camera: the camera's name (``None``: the frame as a whole).
        file: the file at fault, if one is.
        what: what was wrong, in words.
    """

    frame: int | None
    camera: str | None
    file: str | None
    what: str

    def __str__(self) -> str:
        where = [f"frame {self.frame}" if self.frame is not None else None,
                 f"camera {self.camera!r}" if self.camera is not None else None, self.file]
        return ": ".join([w for w in where if w] + [self.what])


class ProblemLog:
    """The problems of a run, in order, each once (a frame's views are read again when the
    frame is carved again: building the subject's model, then tracking); warns once per
    camera (and once for whole frames) on `stream` as they come."""

    def __init__(self, stream=None, warn: bool = True):
        self.items: list[Problem] = []
        self._known: set[Problem] = set()
        self.warn = warn
        """Whether to print a warning the first time a camera has a problem."""
        self._stream = stream
        self._warned: set = set()

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self):
        return iter(self.items)

    def add(self, frame: int | None, what: str, camera: str | None = None, file=None) -> Problem:
        problem = Problem(frame, camera, None if file is None else str(file), what)
        if problem in self._known:
            return problem
        self.items.append(problem)
        self._known.add(problem)
        if self.warn and camera not in self._warned:
            self._warned.add(camera)
            more = "further problems of this camera" if camera is not None else "further ones"
            tqdm.write(f"hullcap: warning: {problem} ({more} go to problems.json)", file=self._stream or sys.stderr)
        return problem

    def extend(self, problems) -> None:
        """Take `problems` (from a resumed run) without warning again; those already
        here (the start-up checks, made again) are not repeated."""
        for p in problems:
            if p not in self._known:
                self.items.append(p)
                self._known.add(p)
            self._warned.add(p.camera)

    def summary(self, limit: int = 4) -> str:
        """One line: how many views were left out in how many frames, the first few."""
        is_view = [p.camera is not None and p.frame is not None for p in self.items]
        views = [p for p, v in zip(self.items, is_view) if v]
        absent = [p.frame for p, v in zip(self.items, is_view) if not v and p.what.startswith(ABSENT)]
        other = [p for p, v in zip(self.items, is_view) if not v and not p.what.startswith(ABSENT)]
        parts = []
        if absent:
            parts.append(f"{len(absent)} frame{'s' * (len(absent) != 1)} without the person in any view: "
                         + _runs(absent))
        if views:
            left_out = {(p.frame, p.camera) for p in views}  # a view may have more than one problem
            frames = len({frame for frame, _ in left_out})
            shown = ", ".join(f"{p.camera} frame {p.frame} {p.what}" for p in views[:limit])
            parts.append(f"{len(left_out)} view{'s' * (len(left_out) != 1)} left out in {frames} "
                         f"frame{'s' * (frames != 1)}: {shown}{' …' if len(views) > limit else ''}")
            per_camera = Counter(camera for _, camera in left_out)
            if len(per_camera) > 1:
                parts.append("per camera " + ", ".join(f"{c} {k}" for c, k in sorted(per_camera.items())))
        if other:
            parts.append(f"{len(other)} other problem{'s' * (len(other) != 1)}: {other[0]}"
                         + (" …" if len(other) > 1 else ""))
        return "; ".join(parts) if parts else "no problems"

    def save(self, path) -> None:
        """``problems.json``: ``{"problems": [{frame, camera, file, what}, …]}``, atomically."""
        doc = {"problems": [asdict(p) for p in self.items]}
        atomic_write(Path(path), (json.dumps(doc, indent=1) + "\n").encode())

    @staticmethod
    def load(path) -> list[Problem]:
        """The problems a ``problems.json`` holds; a ResultsError names the file when an
        entry is not one (a frame that is not a whole number, a camera or file that is not
        a name)."""
        doc = read_document(path, ResultsError)
        try:
            entries = doc["problems"]
            if not isinstance(entries, list):
                raise TypeError(f"'problems' is {type(entries).__name__}, not a list")
            return [_problem(p) for p in entries]
        except (KeyError, TypeError) as e:
            raise ResultsError(f"{path}: not a problems.json ({e!r})") from None


def _runs(frames: list[int]) -> str:
    """Frames as runs: ``10–14, 20``."""
    runs: list[list[int]] = []
    for f in sorted(set(frames)):
        if runs and f == runs[-1][1] + 1:
            runs[-1][1] = f
        else:
            runs.append([f, f])
    return ", ".join(f"{a}–{b}" if b > a else f"{a}" for a, b in runs)


def _problem(entry) -> Problem:
    """A problem from its ``problems.json`` entry; TypeError or KeyError when it is none."""
    frame, camera, file = entry["frame"], entry["camera"], entry["file"]
    if frame is not None and (isinstance(frame, bool) or not isinstance(frame, int)):
        raise TypeError(f"frame {frame!r} is not a whole number")
    for name, value in (("camera", camera), ("file", file)):
        if value is not None and not isinstance(value, str):
            raise TypeError(f"{name} {value!r} is not a name")
    return Problem(frame, camera, file, str(entry["what"]))
