"""A real take, end to end: Pose2Sim's balancing trial tracked from its videos and the lab's
calibration alone, and compared with Pose2Sim's own result (docs/real_take.md).

What a user does, one command after another (``hullcap``'s own command line): a sequence
folder holding the four videos (linked, in ``data/real/``), ``calib import --from pose2sim
--images`` (names matched, two videos adopted as the calibrated frame resized), ``track
--image-scale 0.5`` with no background image (the learned person segmenter alone; without
it the run must end with a clear error and a non-zero exit, which is checked instead), and
``compare --up pose2sim`` over hips, knees, ankles, shoulders, elbows and wrists, in the
calibration's world with no fitted rotation. Prints frames tracked and the per-joint
table, raw and with each joint's constant offset removed; draws frames 29 and 81 (the right
arm raised; the right arm stretched out, motion-blurred) in all four cameras, the fitted
model over the image and Pose2Sim's joints as green dots, to ``--stills``.

    .venv/bin/python benchmarks/bench_real.py [--take PATH] [--out DIR] [--stills docs/real_take.jpg]

The take's folder (``videos/``, ``calibration/Calib_qualisys.toml``, ``reference/*.trc``):
``--take``, ``$HULLCAP_REAL``, or ``real/p2s_balancing`` beside the repository.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import devset
from devset_stills import tile
from hullcap._compare import compare_run, reference_joints
from hullcap._person import available, missing
from hullcap._sequence import Sequence
from hullcap.export import load_result
from hullcap.export._overlay import draw_overlay

NAMES = {"r_hip": "RHip", "r_knee": "RKnee", "r_ankle": "RAnkle", "l_hip": "LHip", "l_knee": "LKnee",
         "l_ankle": "LAnkle", "r_shoulder": "RShoulder", "r_elbow": "RElbow", "r_wrist": "RWrist",
         "l_shoulder": "LShoulder", "l_elbow": "LElbow", "l_wrist": "LWrist"}
"""Our joints → Pose2Sim's (its Head is the top of the head, its Neck its own convention)."""
STILLS = (29, 81)
TARGET_MM = (40.0, 30.0)
"""The real-take issue's bar: mean over the joints, raw and with each joint's offset removed."""


def find(path=None) -> Path | None:
    """The take's folder, or None when it is not on this machine."""
    for candidate in (path, os.environ.get("HULLCAP_REAL"), devset.REPO.parent / "shared" / "real" / "p2s_balancing"):
        if candidate and (Path(candidate) / "videos").is_dir():
            return Path(candidate)
    return None


def hullcap(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """``hullcap ARGS`` as a user types it, its output shown (its messages on stderr too, not
    its progress bars)."""
    print("$ hullcap " + " ".join(args), flush=True)
    done = subprocess.run([sys.executable, "-m", "hullcap", *args], text=True, capture_output=True)
    said = [line for line in done.stderr.splitlines() if line.startswith("hullcap")]
    print("\n".join([done.stdout.rstrip(), *said]) + "\n", flush=True)
    if check and done.returncode != 0:
        raise SystemExit(f"hullcap {args[0]} failed (exit {done.returncode})")
    return done


def stills(trc: Path, sequence: Path, run: Path, out: Path) -> None:
    """Frames `STILLS` in every camera: the fitted model over the image and Pose2Sim's
    joints (its TRC file `trc`) as green dots, a row per frame."""
    seq, result = Sequence(sequence), load_result(run)
    ref_names, ref, times = reference_joints(trc, up="pose2sim")
    model = result.model
    rows = []
    for frame in STILLS:
        theirs = ref[int(np.argmin(np.abs(times - frame / result.fps)))]
        theirs = theirs[[ref_names.index(n) for n in NAMES.values()]]
        pose = model.pose(result.theta[frame], result.root_rotation[frame], result.root_translation[frame],
                          clamp=False)
        views = []
        for camera in seq.cameras:
            drawn = draw_overlay(seq.image(frame, camera.name), camera, pose.vertices, model.faces, pose.joints,
                                 model.joint_names, failed=bool(result.failed[frame]))
            views.append(tile(drawn, camera, pose.joints, theirs, radius=10))
        row = np.hstack(views)
        cv2.rectangle(row, (0, 0), (row.shape[1], 24), (255, 255, 255), -1)
        cv2.putText(row, f"frame {frame}: hullcap's fitted model; Pose2Sim's joints in green", (6, 17),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        rows.append(row)
    cv2.imwrite(str(out), np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(f"{out}: written")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--take", help="the take's folder (default: $HULLCAP_REAL, or real/p2s_balancing beside the "
                                   "repository)")
    ap.add_argument("--out", default=str(devset.REPO / "data" / "real"), help="where the sequence and run go")
    ap.add_argument("--stills", default=str(devset.REPO / "docs" / "real_take.jpg"),
                    help="the picture of frames 29 and 81")
    args = ap.parse_args()
    take = find(args.take)
    if take is None:
        ap.error("the real take is not here: pass --take or set HULLCAP_REAL")
    sequence, run = Path(args.out) / "p2s_balancing", Path(args.out) / "p2s_balancing-run"
    (sequence / "videos").mkdir(parents=True, exist_ok=True)
    for video in sorted((take / "videos").glob("*.mp4")):
        link = sequence / "videos" / video.name
        if not link.exists():
            link.symlink_to(video.resolve())
    hullcap("calib", "import", "--from", "pose2sim", str(take / "calibration" / "Calib_qualisys.toml"),
            "--images", str(sequence), "--out", str(sequence / "cameras.json"))
    if not available():
        done = hullcap("track", str(sequence), "--out", str(run), "--image-scale", "0.5", "--restart", check=False)
        ok = done.returncode != 0 and "learned person segmenter" in done.stderr
        print(f"without the learned segmenter ({missing()}): exit {done.returncode}, "
              f"{'a clear error: as it should' if ok else 'NOT the clear error expected'}")
        raise SystemExit(0 if ok else 1)
    t0 = time.perf_counter()
    hullcap("track", str(sequence), "--out", str(run), "--image-scale", "0.5", "--restart")
    seconds = time.perf_counter() - t0
    trc = next((take / "reference").glob("*_0-100.trc"))
    comparison = compare_run(run, trc, names=NAMES, up="pose2sim")
    print(comparison.table())
    result = load_result(run)
    tracked = int((~result.failed).sum())
    means = comparison.means()
    raw, removed = means["raw_mm"], means["offset_removed_mm"]
    print("\n| frames tracked | raw (mm) | offset removed (mm) | run, 2 cores (s) |")
    print("|---|---|---|---|")
    print(f"| {tracked} of {len(result.failed)} | {raw:.1f} | {removed:.1f} | {seconds:.0f} |")
    met = tracked == len(result.failed) and raw <= TARGET_MM[0] and removed <= TARGET_MM[1]
    print(f"bar: all frames, ≤ {TARGET_MM[0]:.0f} mm raw, ≤ {TARGET_MM[1]:.0f} mm offset removed: "
          f"{'met' if met else 'not met'}")
    stills(trc, sequence, run, Path(args.stills))


if __name__ == "__main__":
    main()
