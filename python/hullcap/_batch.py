"""``hullcap batch``: every take of a session tracked, on Ray or one after another.

Each take is one task (:func:`run_take`), tracked as ``hullcap track`` tracks it
(:func:`hullcap._take.track_take`) into ``OUT/.partial/<take>/``; when every output is
written the folder is renamed to ``OUT/<take>/`` with a ``take.json`` of its summary, so
a take's folder is either absent or complete. A take that fails is reported and tried
once more (resuming where it stopped); a take that uses a subject's model waits for that
subject's calibration take, and is skipped if it failed. A re-run skips finished takes
and resumes interrupted ones. The end is a summary table, also in ``OUT/summary.csv``.

The runners: :class:`RayRunner` (one Ray task per take: on this machine, or a cluster
with an address) and :class:`InProcess` (the same tasks in order, in this process).
"""

from __future__ import annotations

import csv
import io
import json
import logging
import os
import shutil
import sys
import time
from collections import defaultdict, deque
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from hullcap._files import atomic_write
from hullcap._progress import progress
from hullcap._session import Take, load_session
from hullcap._take import TakeSummary, track_take
from hullcap.errors import OptionsError, SessionError

__all__ = ["run_batch", "run_take", "Job", "Outcome", "Row", "InProcess", "RayRunner", "TAKE_FILE", "SUMMARY"]

TAKE_FILE = "take.json"
SUMMARY = "summary.csv"
PARTIAL = ".partial"
ATTEMPTS = 2
RAY_AUTH_LOGGER = "ray._private.authentication.authentication_token_setup"
"""The logger of Ray's notice that a new local cluster has token authentication on."""


@dataclass(frozen=True)
class Job:
    """What a worker needs to track one take (absolute paths: a worker's folder differs);
    `threads` caps the engine's threads (``None``: all cores)."""

    take: Take
    partial: Path
    final: Path
    model: Path | None
    show_progress: bool = False
    threads: int | None = None


@dataclass(frozen=True)
class Outcome:
    """A task's result: a summary, or the error that stopped it (in words)."""

    summary: TakeSummary | None = None
    error: str | None = None


def run_take(job: Job) -> Outcome:
    """Track one take into its partial folder, then publish it (the task a worker runs).
    An error comes back as the outcome, so that the driver reports it the same way
    whichever runner ran the task."""
    if job.threads is not None:
        # This process is the worker's: the engine reads it at each call (the results
        # do not depend on it, docs/batch.md).
        os.environ["HULLCAP_THREADS"] = str(job.threads)
    try:
        if job.final.exists():
            raise SessionError(f"{job.final} appeared while the take was tracked (another batch on the same OUT?)")
        summary = track_take(job.take.path, job.partial, job.take.options, model=job.model,
                             show_progress=job.show_progress)
        record = {"take": job.take.name, "subject": job.take.subject, "model_from": job.take.calibration,
                  "sequence": str(job.take.path), **asdict(summary), "options": job.take.options.to_dict()}
        atomic_write(job.partial / TAKE_FILE, (json.dumps(record, indent=2) + "\n").encode())
        job.final.parent.mkdir(parents=True, exist_ok=True)
        os.replace(job.partial, job.final)
        return Outcome(summary=summary)
    except Exception as e:  # noqa: BLE001 - any failure of a take is reported, not raised
        return Outcome(error=f"{type(e).__name__}: {e}")


@dataclass
class Row:
    """One take in the summary: ``state`` is ``tracked``, ``done before``, ``failed`` or
    ``skipped``; ``note`` the error or the reason."""

    take: Take
    state: str
    summary: TakeSummary | None = None
    note: str = ""

    @property
    def finished(self) -> bool:
        return self.state in ("tracked", "done before")


class InProcess:
    """Runs the tasks one after another in this process, with each take's progress bar."""

    name = "one take after another in this process"
    shows_each_take = True  # each take's own progress bars

    def __init__(self):
        self._queue: deque[Job] = deque()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    @property
    def pending(self) -> int:
        return len(self._queue)

    def submit(self, job: Job) -> None:
        self._queue.append(replace(job, show_progress=True))

    def next_done(self) -> tuple[Job, Outcome]:
        job = self._queue.popleft()
        return job, run_take(job)


class RayRunner:
    """One Ray task per take, `cpus_per_take` CPUs each: on a local Ray started here
    (shut down at the end) or on the cluster at `address`."""

    def __init__(self, address: str | None = None, cpus_per_take: float = 1.0):
        try:
            import ray
        except ImportError:
            raise OptionsError("Ray is not installed: pip install 'hullcap[ray]' (or run the takes one after "
                               "another with --sequential)") from None
        if not cpus_per_take > 0:
            raise OptionsError(f"cpus_per_take must be positive, got {cpus_per_take}")
        self._ray = ray
        self._address = address
        self._cpus_per_take = cpus_per_take
        self._started = False
        self._refs: dict = {}
        self.name = "Ray"
        self.shows_each_take = False  # the workers' bars would interleave

    def __enter__(self):
        ray = self._ray
        if not ray.is_initialized():
            # A local cluster we start keeps Ray's token authentication, which Ray turns on
            # with a warning at every start; that warning tells a batch's user nothing.
            said = logging.getLogger(RAY_AUTH_LOGGER)
            level = said.level
            said.setLevel(logging.ERROR if self._address is None else level)
            try:
                ray.init(address=self._address, include_dashboard=False, log_to_driver=False,
                         logging_level="warning")
            finally:
                said.setLevel(level)
            self._started = True
        cpus = ray.cluster_resources().get("CPU", 0)
        self.name = f"Ray ({cpus:g} CPUs, {self._cpus_per_take:g} per take)"
        # Our own retry (once, resuming) replaces Ray's, so that a failure is reported.
        self._task = ray.remote(num_cpus=self._cpus_per_take, max_retries=0)(run_take)
        return self

    def __exit__(self, *exc):
        if self._started:
            self._ray.shutdown()
        return False

    @property
    def pending(self) -> int:
        return len(self._refs)

    def submit(self, job: Job) -> None:
        # The engine's threads on the CPUs Ray reserved, not on every core of the node.
        self._refs[self._task.remote(replace(job, threads=max(1, int(self._cpus_per_take))))] = job

    def next_done(self) -> tuple[Job, Outcome]:
        ray = self._ray
        (ref,), _ = ray.wait(list(self._refs), num_returns=1)
        job = self._refs.pop(ref)
        try:
            return job, ray.get(ref)
        except ray.exceptions.RayError as e:  # the worker died (killed, out of memory, a lost node)
            return job, Outcome(error=f"{type(e).__name__}: {str(e).splitlines()[0]}")


def run_batch(session, out, runner=None, restart: bool = False, say=print) -> list[Row]:
    """Track every take of `session` into `out` (see the module documentation) with
    `runner` (default :class:`InProcess`); `restart` tracks finished takes again. Returns
    one row per take, in the session's order, and writes them to ``OUT/summary.csv``."""
    takes = load_session(session)
    out = Path(out).resolve()
    runner = runner or InProcess()
    rows = {take.name: _finished(take, out, restart) for take in takes}
    waiting = defaultdict(list)  # calibration take → the takes that wait for its model
    ready = []
    for take in takes:
        if rows[take.name] is not None:
            continue
        if take.calibration is None or rows[take.calibration] is not None:
            ready.append(take)
        else:
            waiting[take.calibration].append(take)
    before = sum(row is not None for row in rows.values())
    subjects = len({t.subject for t in takes if t.subject is not None})
    attempts = defaultdict(int)
    t0 = time.perf_counter()

    def submit(job: Job) -> None:
        attempts[job.take.name] += 1
        runner.submit(job)

    with runner:
        say(f"{Path(session)}: {len(takes)} takes" + (f", {subjects} named subject(s)" if subjects else "")
            + (f", {before} done before" if before else "") + f"; {runner.name}")
        bar = progress(None, total=len(takes), desc="takes", unit="take", initial=before,
                       enable=not runner.shows_each_take)

        def tell(line: str) -> None:
            with bar.external_write_mode():
                say(line)

        for take in ready:
            submit(_job(take, out))
        while runner.pending:
            job, outcome = runner.next_done()
            take = job.take
            if outcome.error is not None and attempts[take.name] < ATTEMPTS:
                tell(f"{take.name}: failed ({outcome.error}); trying once more")
                submit(job)
                continue
            ended = [take]
            if outcome.error is None:
                rows[take.name] = Row(take, "tracked", outcome.summary)
                for other in waiting.pop(take.name, []):
                    submit(_job(other, out))
            else:
                rows[take.name] = Row(take, "failed", note=outcome.error)
                for other in waiting.pop(take.name, []):
                    rows[other.name] = Row(other, "skipped", note=f"the take of its model, {take.name}, failed")
                    ended.append(other)
            for t in ended:
                bar.update()
                tell(_line(rows[t.name]))
    bar.close()
    if (out / PARTIAL).is_dir() and not any((out / PARTIAL).iterdir()):
        (out / PARTIAL).rmdir()
    result = [rows[take.name] for take in takes]
    atomic_write(out / SUMMARY, _csv(result).encode())
    say(summary_table(result))
    done = sum(row.finished for row in result)
    say(f"{done} of {len(result)} takes done in {time.perf_counter() - t0:.0f} s; results in {out}, "
        f"this table in {out / SUMMARY}")
    return result


def _job(take: Take, out: Path) -> Job:
    model = out / take.calibration / "model" if take.calibration is not None else None
    return Job(take, out / PARTIAL / take.name, out / take.name, model)


def _finished(take: Take, out: Path, restart: bool) -> Row | None:
    """The row of a take finished by an earlier batch (``None``: to track); with
    `restart`, its results are removed instead."""
    final = out / take.name
    if restart:
        for folder in (final, out / PARTIAL / take.name):
            if folder.exists():
                shutil.rmtree(folder)
        return None
    if not final.exists():
        return None
    record = final / TAKE_FILE
    try:
        doc = json.loads(record.read_text())
        summary = TakeSummary(**{k: doc[k] for k in ("frames", "lost", "recovered", "seconds", "problems")})
    except (OSError, ValueError, KeyError, TypeError):
        raise SessionError(f"{final} is there but is not a take this batch finished (no readable {TAKE_FILE}): "
                           f"move it away, or run with --restart") from None
    return Row(take, "done before", summary)


def _line(row: Row) -> str:
    """A take's line when it ends."""
    who = f" ({row.take.subject}" + (f", model of {row.take.calibration})" if row.take.calibration else ")") \
        if row.take.subject else ""
    if row.summary is None:
        return f"{row.take.name}{who}: {row.state}: {row.note}"
    s = row.summary
    return (f"{row.take.name}{who}: {s.frames} frames, {s.lost} lost, {s.recovered} re-acquired, "
            f"{s.fps:.2f} frames/s, {s.seconds:.0f} s")


COLUMNS = ["take", "subject", "frames", "lost", "re-acquired", "frames/s", "seconds", "state"]


def _cells(row: Row) -> list[str]:
    s = row.summary
    numbers = [str(s.frames), str(s.lost), str(s.recovered), f"{s.fps:.2f}", f"{s.seconds:.1f}"] if s else [""] * 5
    state = row.state + (f": {row.note}" if row.note else "")
    return [row.take.name, row.take.subject or "", *numbers, state]


def summary_table(rows: list[Row]) -> str:
    """The rows as an aligned text table."""
    cells = [COLUMNS] + [_cells(row) for row in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip() for line in cells)


def _csv(rows: list[Row]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    writer.writerows(_cells(row) for row in rows)
    return buf.getvalue()


def default_runner(sequential: bool = False, address: str | None = None, cpus_per_take: float = 1.0,
                   warn=lambda line: print(line, file=sys.stderr)):
    """Ray when it is installed (or an address is given), else one take after another."""
    if sequential:
        if address is not None:
            raise OptionsError("--sequential and --address exclude each other")
        return InProcess()
    try:
        import ray  # noqa: F401
    except ImportError:
        if address is not None:
            raise OptionsError("--address needs Ray: pip install 'hullcap[ray]'") from None
        warn("hullcap: Ray is not installed (pip install 'hullcap[ray]'): the takes run one after another")
        return InProcess()
    return RayRunner(address, cpus_per_take)
