"""A session tracked by ``hullcap batch`` on Ray against the same takes one after another.

Renders a session (each subject: a calibration take and trials of other motions, colour
frames and backgrounds, 8 cameras 640×480), then tracks it twice in one run: on a local
Ray with this machine's cores (one take per core) and in-process one take after another.
Prints the wall time of both, their ratio, and whether every take's joints.csv is the
same both ways. Run: ``.venv/bin/python benchmarks/bench_batch.py [--subjects 2
--takes-per-subject 2 --frames 30]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from hullcap._batch import InProcess, RayRunner, run_batch
from hullcap._synth import SUBJECTS, synthesize

# hullcap._motions.MOTIONS without "all", in the order the figures of docs/performance.md used.
MOTIONS = ["demo", "squat", "kick", "arm_swing", "twist", "jump", "walk_turn"]


def make_session(root: Path, subjects: int, takes: int, frames: int) -> Path:
    people = [s for s in sorted(SUBJECTS) if s != "template"]
    lines = ["[defaults]", "overlays = false", "", "[subjects]"]
    trials = []
    for p in range(subjects):
        person = f"p{p}"
        for k in range(takes):
            name = f"{person}_{MOTIONS[(p + k) % len(MOTIONS)]}"
            synthesize(root / name, MOTIONS[(p + k) % len(MOTIONS)], 8, people[p % len(people)], frames=frames,
                       seed=p * 10 + k, show_progress=False)
            if k == 0:
                lines.append(f'{person} = "{name}"')
            else:
                trials.append(f'{name} = "{person}"')
    (root / "session.toml").write_text("\n".join(lines + ["", "[takes]"] + trials) + "\n")
    return root


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--subjects", type=int, default=2)
    ap.add_argument("--takes-per-subject", type=int, default=2)
    ap.add_argument("--frames", type=int, default=30)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        session = make_session(tmp / "session", args.subjects, args.takes_per_subject, args.frames)
        seconds = {}
        for name, runner in [("Ray", RayRunner()), ("one after another", InProcess())]:
            t0 = time.perf_counter()
            rows = run_batch(session, tmp / name, runner, say=lambda line: None)
            seconds[name] = time.perf_counter() - t0
            assert all(row.finished for row in rows), [row.note for row in rows]
        same = all((tmp / "Ray" / row.take.name / "joints.csv").read_bytes()
                   == (tmp / "one after another" / row.take.name / "joints.csv").read_bytes() for row in rows)
        n = len(rows)
        print(f"\n{n} takes of {args.subjects} subjects, {args.frames} frames each, 8 cameras 640x480, "
              f"{os.cpu_count()} cores")
        print(f"{'runner':<20} {'wall s':>8} {'takes/min':>10}")
        for name, s in seconds.items():
            print(f"{name:<20} {s:8.1f} {60 * n / s:10.2f}")
        print(f"Ray / one after another: {seconds['one after another'] / seconds['Ray']:.2f}x faster; "
              f"joints.csv {'identical' if same else 'DIFFERENT'} in every take")


if __name__ == "__main__":
    main()
