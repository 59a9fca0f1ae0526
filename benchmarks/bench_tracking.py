"""Tracking speed, stage by stage, against the floor of decoding the frames; and tracking
accuracy on rendered 8-camera sequences.

Speed (the default): for an 8-camera 640×480 development sequence (d01_bend, rendered
into data/devset/ by bench_devset.py) and for the project's own synthetic sequence, in one
run: the time of only decoding every frame of every camera (the floor), then tracking runs
from colour frames by the background test alone and with the learned segmenter (where
installed), each with the accurate preset (the defaults) and the live one (``hullcap track
--preset live``) side by side, the frames read ahead on a second thread; and one run of
the defaults reading each frame when it is tracked.
Prints per stage milliseconds per frame, frames/s of the fit alone and of tracking (the
whole run's wall time, outputs included, less the time spent on the subject's model), and
tracking's time over the floor.

    .venv/bin/python benchmarks/bench_tracking.py [--frames N] [--devset PATH]

Every frame of each sequence by default (d01's 195, the synthetic sequence's 93): the
first second of a development sequence is a calibration pose that stands still, whose
frames fit in a third of the time of the motion after it, so a short run flatters.

Accuracy (``--accuracy``): for two body proportions unlike the template's (``tall``, ``short``), the scripted motion
``all`` (arm swings, a torso twist, a squat, a jump with the arms up, a kick, a walk
and turn) is rendered at 640×480 and tracked twice: from the exact silhouettes and from
the colour frames by background subtraction. Prints the mean joint position error per
joint and overall, the joint-angle error, frames lost, and the speed of each stage.

    .venv/bin/python benchmarks/bench_tracking.py --accuracy [--frames 240]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import devset
from hullcap._evaluate import accuracy
from hullcap._person import available
from hullcap._sequence import Sequence
from hullcap._synth import synthesize
from hullcap._tracking import Tracker, TrackerOptions
from hullcap._tracking_options import PRESETS


def decode_seconds(seq: Sequence, frames: int) -> float:
    """Seconds to decode `frames` frames of every camera, one after another."""
    t0 = time.perf_counter()
    for f in range(frames):
        for cam in seq.cameras:
            seq.image(f, cam.name)
    return time.perf_counter() - t0


def speed(args) -> None:
    sequences = {}
    found = devset.find(args.devset)
    if found is None:
        print("development set not found (--devset PATH): the synthetic sequence only\n")
    else:
        sequences["d01_bend (development set)"] = devset.render(found, "d01_bend")
    tmp = tempfile.TemporaryDirectory()
    sequences["synthetic 'demo', short subject"] = synthesize(Path(tmp.name) / "demo", "demo", 8, "short",
                                                             show_progress=False)
    rows = []
    for label, path in sequences.items():
        seq = Sequence(path)
        n = len(seq) if args.frames is None else min(args.frames, len(seq))
        floor = decode_seconds(seq, n) / n
        segmenters = ["colour", "learned"] if available() else ["colour"]
        runs = [(preset, segmenter, 2) for segmenter in segmenters for preset in PRESETS] + [("accurate", "colour", 0)]
        for preset, segmenter, read_ahead in runs:
            options = TrackerOptions.preset(preset, ignore_silhouettes=True, read_ahead=read_ahead, segmenter=segmenter)
            t0 = time.perf_counter()
            result = Tracker(seq, options=options).run(Path(tmp.name) / f"out-{preset}-{segmenter}{read_ahead}",
                                                         resume=False, show_progress=False, frames=n)
            sec = {k: v / n for k, v in result.seconds.items()}
            tracking = (time.perf_counter() - t0) / n - sec["subject"]
            every = options.learned_every
            name = segmenter if segmenter == "colour" or every == 1 else f"{segmenter}, every {every} frames"
            rows.append((label, preset, name, read_ahead, 1000 * floor, 1000 * sec.get("read ahead", 0.0),
                         1000 * sec["silhouettes"], 1000 * sec["hull"], 1000 * sec["fit"], 1 / sec["fit"],
                         1 / tracking, tracking / floor, int(result.failed[:n].sum()), n))
    tmp.cleanup()
    frames = "every frame" if args.frames is None else f"first {args.frames} frames"
    print(f"# tracking speed from colour frames, 8 cameras 640×480, {frames}, {os.cpu_count()} cores\n")
    print("| sequence | preset | segmenter | read ahead | decoding alone (ms/frame) | read ahead thread (ms/frame) | "
          "silhouettes | hull | fit | fit (frames/s) | tracking (frames/s) | tracking / decoding | lost |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.0f} | {r[5]:.0f} | {r[6]:.0f} | {r[7]:.0f} | "
              f"{r[8]:.0f} | {r[9]:.1f} | {r[10]:.2f} | {r[11]:.1f}× | {r[12]} of {r[13]} |")
    print("\nsilhouettes (with drawing the prediction), hull, fit: milliseconds per frame on the tracking thread "
          "(with read-ahead, the decoding and background test run on the other thread and are not in that column).")


def accuracy_tables(args) -> None:
    rows, joint_tables = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for subject in args.subjects:
            seq_path = synthesize(Path(tmp) / subject, "all", 8, subject, frames=args.frames, seed=1,
                                  silhouettes=True, show_progress=False)
            seq = Sequence(seq_path)
            for label, given in (("exact silhouettes", True), ("background subtraction", False)):
                tracker = Tracker(seq, options=TrackerOptions(ignore_silhouettes=not given))
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
    print("\n| joint | " + " | ".join(f"{s} / {label}" for s, label in joint_tables) + " |")
    print("|---|" + "---|" * len(joint_tables))
    for i, name in enumerate(names):
        print(f"| {name} | " + " | ".join(f"{t[i]:.1f}" for t in joint_tables.values()) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--accuracy", action="store_true", help="the accuracy tables instead of the speed table")
    ap.add_argument("--frames", type=int, help="frames per sequence (default: all for speed, 240 for accuracy, "
                                               "where the jump ends near 230)")
    ap.add_argument("--subjects", nargs="+", default=["tall", "short"], help="with --accuracy")
    ap.add_argument("--devset", help="the development set's folder (default: see benchmarks/devset.py)")
    args = ap.parse_args()
    if args.accuracy:
        args.frames = args.frames or 240
        accuracy_tables(args)
    else:
        speed(args)


if __name__ == "__main__":
    main()
