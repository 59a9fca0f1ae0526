"""A tracking run's checkpoint (docs/formats.md, "The run folder"): the results so far, the
frame to go on from, what tracking and the segmenters carry to it, and the settings the run
was made with, so that an interrupted run resumes as it would have gone on, and a resume
with other settings is refused with the difference named."""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

import numpy as np

from hullcap._body import BodyModel
from hullcap._files import NPZ_ERRORS, atomic_write
from hullcap._problems import ProblemLog
from hullcap._results import TrackingResult
from hullcap._sequence import Sequence
from hullcap._tracking_options import TrackerOptions, settings
from hullcap.errors import ResultsError

__all__ = ["CHECKPOINT", "PROBLEMS", "Checkpoint", "run_settings"]

CHECKPOINT = ".checkpoint.npz"
PROBLEMS = "problems.json"


def run_settings(options: TrackerOptions, frames: int, sequence: Sequence, volume,
                 model: BodyModel | None, learned: bool) -> dict:
    """What decides a run's results besides the sequence: the options, the number of
    `frames`, the image scale, the capture `volume`, a digest of the `model` given, and
    whether the learned segmenter ran (`learned`: by default, where it is installed)."""
    given = None
    if model is not None:
        digest = hashlib.sha256(np.ascontiguousarray(model.vertices).tobytes())
        digest.update(np.ascontiguousarray(model.links).tobytes())
        given = digest.hexdigest()[:16]
    return {**settings(options), "frames": frames, "image_scale": sequence.image_scale,
            "volume": np.asarray(volume).ravel().tolist(), "model given": given, "learned segmenter": learned}


class Checkpoint:
    """The checkpoint of a run of `sequence` with `settings` into folder `out`."""

    def __init__(self, out: Path, sequence: Sequence, settings: dict):
        self.out = Path(out)
        self.path = self.out / CHECKPOINT
        self.sequence = sequence
        self.settings = settings

    def write(self, result: TrackingResult, next_frame: int, carried: dict, learnt: dict,
              problems: ProblemLog) -> None:
        """Write it, and `problems` beside it: the results so far, the frame to go on from,
        what tracking (`carried`, ``TrackingState.carried``) and the segmenters (`learnt`,
        ``Segmenter.learnt``) carry to that frame."""
        buf = io.BytesIO()
        np.savez(buf, next_frame=next_frame, sequence=str(self.sequence.path.resolve()),
                 cameras=np.array(self.sequence.cameras.names), settings=json.dumps(self.settings),
                 **result.arrays(), **learnt, **carried)
        problems.save(self.out / PROBLEMS)
        atomic_write(self.path, buf.getvalue())

    def read(self, frames: int) -> dict | None:
        """Its arrays (``next_frame``, the results', what was carried and learnt), or
        ``None`` when there is none for this sequence; ResultsError when it was made with
        other cameras or settings, naming the difference, or is damaged."""
        if not self.path.is_file() or not (self.out / "model").is_dir():
            return None
        try:
            with np.load(self.path) as z:
                if str(z["sequence"]) != str(self.sequence.path.resolve()):
                    return None
                cameras = self.sequence.cameras.names
                if "cameras" in z.files and z["cameras"].tolist() != cameras:
                    raise ResultsError(f"{self.path}: this run was tracked with the cameras "
                                       f"{', '.join(z['cameras'].tolist())}, not {', '.join(cameras)}: give the "
                                       f"same cameras to resume it, or --restart (resume=False) to start over")
                if "settings" in z.files:
                    self._check_same_settings(json.loads(str(z["settings"])))
                elif len(z["failed"]) != frames:  # a checkpoint from before settings were kept
                    return None
                return {k: z[k] for k in z.files if k not in ("cameras", "settings")}
        except ResultsError:
            raise
        except (*NPZ_ERRORS, TypeError, json.JSONDecodeError) as e:
            raise self.damaged(e) from None

    def damaged(self, error: Exception) -> ResultsError:
        """The error for a checkpoint that cannot be read back, saying what to do."""
        return ResultsError(f"{self.path}: the checkpoint is damaged ({error}); run again with --restart "
                            f"(resume=False) to start over")

    def problems(self) -> list | None:
        """The problems written beside it (``ProblemLog.load``), if there are any."""
        path = self.out / PROBLEMS
        return ProblemLog.load(path) if path.is_file() else None

    def remove(self) -> None:
        """Delete it (every output is written)."""
        self.path.unlink(missing_ok=True)

    def _check_same_settings(self, then: dict, shown: int = 4) -> None:
        """ResultsError naming the settings (up to `shown`) in which the checkpoint's run,
        `then`, differs from this one."""
        now = json.loads(json.dumps(self.settings))  # as the checkpoint holds them: tuples as lists
        changed = [k for k in sorted(then.keys() | now.keys()) if then.get(k, "(none)") != now.get(k, "(none)")]
        if changed:
            listed = "; ".join(f"{k}: {then.get(k, '(none)')} then, {now.get(k, '(none)')} now"
                               for k in changed[:shown])
            more = f" and {len(changed) - shown} more" if len(changed) > shown else ""
            raise ResultsError(f"{self.path}: this run was tracked with other settings ({listed}{more}): give the "
                               f"same options to resume it, or --restart (resume=False) to start over")
