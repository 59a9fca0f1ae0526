"""Cameras of many pixels read at a fraction of their size (``hullcap track --image-scale``):
accuracy and time of a synthetic take rendered at 1280 × 960, tracked from colour frames
whole and at smaller scales, side by side in one run.

Each row tracks the same take (rendered once into a temporary folder) with the subject's
model built in the run: the mean and worst joint error against the truth, frames lost, and
the seconds of the whole run, of building the subject's model and of tracking the frames.

    .venv/bin/python benchmarks/bench_scale.py [--frames 60] [--scales 1 0.5 0.25] [--jpeg]

With ``--jpeg`` the frames are stored as JPEG (quality 95), as most cameras and recorders
write them, instead of the renderer's PNG: JPEG decodes reduced at a half scale or less.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
from hullcap._cameras import ring
from hullcap._evaluate import accuracy
from hullcap._sequence import Sequence
from hullcap._synth import synthesize
from hullcap._tracking import Tracker


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=60, help="frames of the demo motion (default 60)")
    ap.add_argument("--scales", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    ap.add_argument("--size", type=int, nargs=2, default=[1280, 960], metavar=("W", "H"))
    ap.add_argument("--jpeg", action="store_true", help="store the frames as JPEG (quality 95)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cams = ring(8, radius=4.0, width=args.size[0], height_px=args.size[1], fov_deg=55)
        take = synthesize(Path(tmp) / "take", "demo", cams, subject="tall", frames=args.frames, show_progress=False)
        if args.jpeg:
            for png in sorted((take / "frames").glob("*/*.png")):
                cv2.imwrite(str(png.with_suffix(".jpg")), cv2.imread(str(png)), [cv2.IMWRITE_JPEG_QUALITY, 95])
                png.unlink()
        print(f"# a synthetic take at {args.size[0]} × {args.size[1]}, 8 cameras, {args.frames} frames, "
              f"colour frames as {'JPEG' if args.jpeg else 'PNG'}, 2 cores\n")
        print("| image scale | images tracked | mean joint error (worst) | lost | whole run | subject's model | "
              "tracking |")
        print("|---|---|---|---|---|---|---|")
        for scale in args.scales:
            seq = Sequence(take, image_scale=scale)
            tracker = Tracker(seq)
            t0 = time.perf_counter()
            result = tracker.run(Path(tmp) / f"out{scale:g}", resume=False, show_progress=False)
            whole = time.perf_counter() - t0
            acc = accuracy(result, take)
            subject = tracker.seconds.get("subject", 0.0)
            cam = seq.cameras[0]
            print(f"| {scale:g} | {cam.width} × {cam.height} | {acc.mean_mm:.1f} mm ({acc.max_mm:.1f}) | "
                  f"{acc.failed} of {len(result.failed)} | {whole:.1f} s | {subject:.1f} s | {whole - subject:.1f} s |",
                  flush=True)


if __name__ == "__main__":
    main()
