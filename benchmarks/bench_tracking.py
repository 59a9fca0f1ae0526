"""Tracking accuracy and speed on rendered 8-camera sequences.

For two body proportions unlike the template's (``tall``, ``short``), the scripted motion
``all`` (arm swings, a torso twist, a squat, a jump with the arms up, a kick, a walk
and turn) is rendered at 640×480 and tracked twice: from the exact silhouettes and from
the colour frames by background subtraction. Prints the mean joint position error per
joint and overall, the joint-angle error, frames lost, and the speed of each stage.

    .venv/bin/python benchmarks/bench_tracking.py [--frames 240]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from hullcap._evaluate import accuracy
from hullcap._sequence import Sequence
from hullcap._synth import synthesize
from hullcap._tracking import Tracker, TrackerOptions


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=240, help="frames per sequence (the jump ends near 230)")
    ap.add_argument("--subjects", nargs="+", default=["tall", "short"])
    args = ap.parse_args()
    rows, joint_tables = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for subject in args.subjects:
            seq_path = synthesize(Path(tmp) / subject, "all", 8, subject, frames=args.frames, seed=1,
                                  silhouettes=True, show_progress=False)
            seq = Sequence(seq_path)
            for label, given in (("exact silhouettes", True), ("background subtraction", False)):
                tracker = Tracker(seq, options=TrackerOptions(use_silhouettes=given))
                t0 = time.perf_counter()
                result = tracker.run(Path(tmp) / f"{subject}-{given}", resume=False, show_progress=False)
                total = time.perf_counter() - t0
                acc = accuracy(result, seq_path)
                n = len(seq)
                sec = result.seconds
                rows.append((subject, label, acc.mean_mm, acc.max_mm, acc.angle_deg, acc.failed, n,
                             n / sec["fit"], n / total, 1000 * sec["silhouettes"] / n, 1000 * sec["hull"] / n,
                             1000 * sec["fit"] / n))
                joint_tables[(subject, label)] = acc.per_joint_mm
                names = acc.joint_names
    print(f"# tracking, 8 cameras 640×480, motion 'all' ({args.frames} frames), 2 cores\n")
    print("| subject | silhouettes | mean joint error (mm) | worst (mm) | angle error (°) | frames lost | "
          "fit (frames/s) | pipeline (frames/s) | masks (ms/frame) | hull (ms/frame) | fit (ms/frame) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.1f} | {r[3]:.1f} | {r[4]:.2f} | {r[5]} of {r[6]} | {r[7]:.1f} | "
              f"{r[8]:.1f} | {r[9]:.0f} | {r[10]:.0f} | {r[11]:.0f} |")
    print("\n| joint | " + " | ".join(f"{s} / {l}" for s, l in joint_tables) + " |")
    print("|---|" + "---|" * len(joint_tables))
    for i, name in enumerate(names):
        print(f"| {name} | " + " | ".join(f"{t[i]:.1f}" for t in joint_tables.values()) + " |")


if __name__ == "__main__":
    main()
