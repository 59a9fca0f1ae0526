"""Progress bars for long work (tqdm), quiet when not wanted."""

from __future__ import annotations

import sys

from tqdm import tqdm


def progress(iterable, total: int | None = None, desc: str = "", enable: bool = True, unit: str = "frame",
             initial: int = 0):
    """`iterable` wrapped in a progress bar on stderr showing items per second."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, disable=not enable, file=sys.stderr, initial=initial,
                dynamic_ncols=True, leave=True, mininterval=0.5)
