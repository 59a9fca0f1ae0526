"""Progress bars for long work (tqdm), quiet when not wanted."""

from __future__ import annotations

import sys

from tqdm import tqdm

TRACKING_STAGES = ("silhouettes", "hull", "fit")
"""The stages of tracking a frame on the tracking thread, as ``Tracker.seconds`` names them."""


def progress(iterable, total: int | None = None, desc: str = "", enable: bool = True, unit: str = "frame",
             initial: int = 0):
    """`iterable` wrapped in a progress bar on stderr showing items per second."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, disable=not enable, file=sys.stderr, initial=initial,
                dynamic_ncols=True, leave=True, mininterval=0.5)


class StageSplit:
    """Where a tracking run's time goes, as a progress bar shows it: the milliseconds a
    frame each of :data:`TRACKING_STAGES` took since this was made, from the run's
    `seconds` (stage → seconds, which the run keeps adding to), and the read-ahead
    thread's, whose frames the tracking thread does not wait for unless it is behind."""

    def __init__(self, seconds: dict):
        self._seconds = seconds
        self._before = {stage: seconds.get(stage, 0.0) for stage in TRACKING_STAGES}

    def line(self, frames: int, reading: float = 0.0) -> str:
        """The split after `frames` frames, the read-ahead thread having spent `reading` s."""
        frames = max(frames, 1)
        parts = [f"{stage} {1000 * (self._seconds.get(stage, 0.0) - self._before[stage]) / frames:.0f}"
                 for stage in TRACKING_STAGES]
        if reading > 0:
            parts.append(f"read ahead {1000 * reading / frames:.0f}")
        return ", ".join(parts) + " ms/frame"
