"""Work on other threads, so that both cores work at once: OpenCV, NumPy and the engine
do their work without the GIL.

- Ahead: while the engine fits frame t, frame t + 1 is decoded and put through the
  per-pixel background test and the learned segmenter on a second thread
  (:class:`ReadAhead`). Only what does not depend on the fit of frame t may run ahead.
- Side by side: a frame's views, each independent of the others (the prediction drawn
  into it, its guided mask, the hull's dilated prior and distance images), are processed
  on a few threads (:func:`over_views`).
- Whole fits side by side: independent fits (a search's candidates, the knee search's
  refits) run one per core, each on one engine thread (:func:`over_fits`): one fit
  spread over two cores waits at its serial steps and between its parallel loops.

The results are those of the same calls made in order, one after another
(tests/test_tracking.py checks a run with and without).
"""

from __future__ import annotations

import itertools
import queue
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor

from hullcap import _engine

__all__ = ["ReadAhead", "over_fits", "over_views"]

_pools: dict[tuple[str, int], ThreadPoolExecutor] = {}
_AHEAD_THREAD = "hullcap-read-ahead"


def over_views(work: Callable, items: Iterable) -> list:
    """``[work(item) for item in items]``, the items shared among as many threads as the
    engine runs on (``_engine.threads()``: ``$HULLCAP_THREADS`` when it is a positive
    number, else every core), as :func:`_shared` shares them. The read-ahead thread's views
    have a pool of their own: sharing the tracking thread's, each waited for the other's."""
    items = list(items)
    kind = "ahead" if threading.current_thread().name == _AHEAD_THREAD else "views"
    return _shared(kind, work, items, min(_engine.threads(), len(items)))


def over_fits(work: Callable, items: Iterable) -> list:
    """``[work(item, threads) for item in items]`` for independent work that is mostly
    the engine's (fits): the items shared among as many threads as the engine runs on (as
    :func:`_shared` shares them), each call told how many engine threads it may use (the
    engine's share of each). A fit's result does not depend on its threads (the engine's
    chunks are the same), so the results are those of the calls made in order on every
    core."""
    items = list(items)
    cores = _engine.threads()
    threads = min(cores, len(items))
    each = cores if threads <= 1 else max(1, cores // threads)
    return _shared("fits", lambda item: work(item, each), items, threads)


def _shared(kind: str, work: Callable, items: list, threads: int) -> list:
    """``[work(item) for item in items]`` on `threads` threads: the calling thread and
    ``threads - 1`` of the pool for `kind`, each taking the next item left. The exception
    of `work` at the first item that raised one is raised once every item is worked; an
    interruption of the calling thread (Ctrl-C) stops the others taking items. Called from
    `work` on a pool thread of the same kind, it works the items on that thread alone: the
    pool may have no other thread to give it."""
    if threads <= 1 or threading.current_thread().name.startswith(f"hullcap-{kind}_"):
        return [work(item) for item in items]
    results: list = [None] * len(items)
    errors: dict[int, Exception] = {}
    claim = itertools.count()  # next() holds the GIL: no item is taken twice
    stop = threading.Event()

    def drain() -> None:
        while not stop.is_set() and (k := next(claim)) < len(items):
            try:
                results[k] = work(items[k])
            except Exception as e:  # raised by the caller, in the items' order
                errors[k] = e

    helpers = [_pool(kind, threads - 1).submit(drain) for _ in range(threads - 1)]
    try:
        drain()
    finally:
        stop.set()
        for helper in helpers:
            helper.result()
    if errors:
        raise errors[min(errors)]
    return results


def _pool(kind: str, threads: int) -> ThreadPoolExecutor:
    """The pool of `threads` threads for `kind` of work, kept for the process, its threads
    named ``hullcap-<kind>_<n>``."""
    pool = _pools.get((kind, threads))
    if pool is None:
        pool = _pools[(kind, threads)] = ThreadPoolExecutor(threads, thread_name_prefix=f"hullcap-{kind}")
    return pool


class ReadAhead:
    """``work(item)`` for each of `items`, in order, on a second thread, at most `depth`
    results ahead of :meth:`take`. An exception of `work` is raised by the :meth:`take`
    of its item. Use it as a context manager, so that the thread stops with the loop that
    takes its results.

    Attributes:
        seconds: time spent in `work` on the second thread.
    """

    def __init__(self, work: Callable, items: Iterable, depth: int = 2):
        if depth < 1:
            raise ValueError(f"depth must be at least 1, got {depth}")
        self.seconds = 0.0
        self._results: queue.Queue = queue.Queue(maxsize=depth)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(work, list(items)), name=_AHEAD_THREAD,
                                        daemon=True)
        self._thread.start()

    def _run(self, work, items) -> None:
        for item in items:
            t0 = time.perf_counter()
            try:
                result = (item, work(item), None)
            except BaseException as e:  # handed to the consumer, which raises it
                result = (item, None, e)
            self.seconds += time.perf_counter() - t0
            while not self._stop.is_set():
                try:
                    self._results.put(result, timeout=0.05)
                    break
                except queue.Full:
                    continue
            if self._stop.is_set() or result[2] is not None:
                return

    def take(self, item):
        """The result of ``work(item)``; items must be taken in the order given."""
        got, value, error = self._results.get()
        if got != item:
            raise RuntimeError(f"read-ahead out of order: asked for {item!r}, the next is {got!r}")
        if error is not None:
            raise error
        return value

    def close(self) -> None:
        """Stop the thread (after the item it is working on) and wait for it."""
        self._stop.set()
        self._thread.join()

    def __enter__(self) -> ReadAhead:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
