"""The worst frame of each development sequence, as the tracker saw it: docs/devset_worst.jpg.

For every sequence with a run of ``bench_devset.py`` (colour frames by default), the frame
with the largest mean joint error (its ``frames.csv``) is drawn in two opposite cameras:
the fitted model's outline and skeleton over the image, the true joints as green dots,
each view cropped around the person. Run after ``bench_devset.py``:

    .venv/bin/python benchmarks/devset_stills.py [--mode colour] [--out docs/devset_worst.jpg]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import cv2
import numpy as np

import devset
from hullcap.export import load_result
from hullcap._sequence import Sequence
from hullcap.export._overlay import draw_overlay

TILE = 280


def worst_frame(run: Path) -> tuple[int, float]:
    rows = [r for r in csv.DictReader((run / "frames.csv").open()) if r["status"] != "failed"]
    worst = max(rows, key=lambda r: float(r["error_mm"]))
    return int(worst["frame"]), float(worst["error_mm"])


def tile(image, camera, joints, truth, radius: int = 4) -> np.ndarray:
    """`image` cropped to a square around the joints, with the true joints drawn as dots of
    `radius` pixels of the image, TILE px."""
    px, _ = camera.project(np.vstack([joints, truth]))
    for p in camera.project(truth)[0]:
        cv2.circle(image, tuple(int(round(c)) for c in p), radius, (0, 200, 0), -1, cv2.LINE_AA)
    lo, hi = px.min(0), px.max(0)
    centre, half = (lo + hi) / 2, 0.65 * max(hi - lo) + 30
    x0, y0 = (centre - half).astype(int)
    x1, y1 = (centre + half).astype(int)
    padded = cv2.copyMakeBorder(image, 2000, 2000, 2000, 2000, cv2.BORDER_CONSTANT, value=(40, 40, 40))
    crop = padded[y0 + 2000:y1 + 2000, x0 + 2000:x1 + 2000]
    return cv2.resize(crop, (TILE, TILE), interpolation=cv2.INTER_AREA)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mode", default="colour", choices=["colour", "exact"])
    ap.add_argument("--runs", default=str(devset.CACHE / "results"), help="where bench_devset.py wrote its runs")
    ap.add_argument("--out", default=str(devset.REPO / "docs" / "devset_worst.jpg"))
    args = ap.parse_args()
    where = devset.find()
    if where is None:
        raise SystemExit("the development set is not here: set HULLCAP_DEVSET")
    rows = []
    for name in devset.names(where):
        run = Path(args.runs) / f"{name}-{args.mode}"
        if not (run / "frames.csv").is_file():
            continue
        seq_path = devset.render(where, name)
        seq, result = Sequence(seq_path), load_result(run)
        truth = devset.Truth.load(where, seq_path)
        frame, error = worst_frame(run)
        model = result.model
        pose = model.pose(result.theta[frame], result.root_rotation[frame], result.root_translation[frame],
                          clamp=False)
        views = []
        for cam_index in (0, len(seq.cameras) // 2):
            camera = seq.cameras[cam_index]
            drawn = draw_overlay(seq.image(frame, cam_index), camera, pose.vertices, model.faces, pose.joints,
                                 model.joint_names)
            views.append(tile(drawn, camera, pose.joints, truth.positions[frame]))
        row = np.hstack(views)
        label = f"{name} ({args.mode}) frame {frame}: mean joint error {error:.0f} mm"
        cv2.rectangle(row, (0, 0), (row.shape[1], 24), (255, 255, 255), -1)
        cv2.putText(row, label, (6, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        rows.append(row)
        print(label)
    if not rows:
        raise SystemExit(f"no runs in {args.runs}: run benchmarks/bench_devset.py first")
    grid = np.vstack([np.hstack(rows[i:i + 2]) if i + 1 < len(rows) else np.hstack([rows[i], np.zeros_like(rows[i])])
                      for i in range(0, len(rows), 2)])
    cv2.imwrite(args.out, grid, [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(f"{args.out}: written")


if __name__ == "__main__":
    main()
