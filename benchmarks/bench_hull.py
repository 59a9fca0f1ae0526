"""Background subtraction and visual hull: time per frame and quality, 8 cameras 640×480.

The hull is timed side by side with a naive carving of the same volume in NumPy (every
1 cm voxel centre projected into every view), its surface (the engine's blur and
isosurface) beside SciPy's Gaussian filter and scikit-image's marching cubes on the same
occupancy, and the mask quality (IoU against the exact silhouettes) beside OpenCV's MOG2.
Run: ``.venv/bin/python benchmarks/bench_hull.py``.

``--devset d01_bend …`` instead prints, per camera of those development sequences, the IoU
against the exact masks (mean and worst frame) and the time per camera frame of
Horprasert's test, MOG2 and the model-guided silhouettes, without and with the texture test
(``GuidedOptions.texture_weight=3``), and beside them two yardsticks: the exact masks
themselves one pixel smaller and one pixel larger all round (eroded or dilated by a 3 × 3
square), what an outline off by one pixel scores at the size the person has in the images.
The guide is what the tracker had: the model of a ``bench_devset.py`` colour run of the
sequence (its ``model/`` and ``pose.npz``) at the frame before, its colours learnt at the
first tracked frame.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from hullcap._hull import HullReport, _carve, _carving_view, _mesh, visual_hull
from hullcap._sequence import Sequence
from hullcap._silhouette import Mog2Background, StatisticalBackground
from hullcap._synth import synthesize

BOUNDS = (np.array([-1.0, -1.0, 0.0]), np.array([1.0, 1.0, 2.2]))


def naive_hull_voxels(masks, cameras, voxel=0.01, bounds=BOUNDS):
    """Occupied voxel count by testing every voxel centre of the volume in every view."""
    lo, hi = bounds
    axes = [np.arange(lo[d] + voxel / 2, hi[d], voxel) for d in range(3)]
    inside_total = 0
    # Slab by slab along x so memory stays bounded.
    yz = np.stack(np.meshgrid(axes[1], axes[2], indexing="ij"), -1).reshape(-1, 2)
    for x in axes[0]:
        pts = np.column_stack([np.full(len(yz), x), yz])
        inside = np.ones(len(pts), bool)
        for cam, m in zip(cameras, masks):
            px, z = cam.project(pts)
            u, v = np.rint(px[:, 0]).astype(int), np.rint(px[:, 1]).astype(int)
            ok = (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height) & (z > 0)
            hit = np.zeros(len(pts), bool)
            hit[ok] = m[v[ok], u[ok]] > 0
            inside &= hit
        inside_total += inside.sum()
    return inside_total


def reference_surface(occupancy, h=0.01, sigma=0.7):
    """The hull's surface as SciPy and scikit-image make it: (vertices, faces)."""
    from scipy import ndimage
    from skimage.measure import marching_cubes

    field = ndimage.gaussian_filter(occupancy.astype(np.float32), sigma, mode="constant", truncate=3.0)
    vertices, faces, _, _ = marching_cubes(field, 0.5, spacing=(h, h, h), gradient_direction="ascent")
    return vertices, faces


def iou(mask, truth) -> float:
    m = mask > 0
    return float((m & truth).sum() / max(1, (m | truth).sum()))


def devset_table(names, step: int) -> None:
    """Per-camera IoU and time of the three segmenters on development sequences."""

    import devset
    from hullcap._guided import GuidedOptions, GuidedSegmenter
    from hullcap._render import render_silhouette
    from hullcap.export import load_result

    where = devset.find()
    if where is None:
        raise SystemExit("the development set is not here: set HULLCAP_DEVSET")
    methods = ("Horprasert", "MOG2", "model-guided", "guided + texture")
    square = np.ones((3, 3), np.uint8)
    yardsticks = {"exact − 1 px": lambda truth: cv2.erode(truth.astype(np.uint8), square),
                  "exact + 1 px": lambda truth: cv2.dilate(truth.astype(np.uint8), square)}
    for name in names:
        seq = Sequence(devset.render(where, name))
        run = devset.CACHE / "results" / f"{name}-colour"
        if not (run / "pose.npz").is_file():
            raise SystemExit(f"{run}: no tracked run to guide by; run benchmarks/bench_devset.py --only {name} first")
        result = load_result(run)
        model = result.model

        def silhouettes(f):
            pose = model.pose(result.theta[f], result.root_rotation[f], result.root_translation[f], clamp=False)
            return [render_silhouette(cam, pose.vertices, model.faces, closed=model.closed) for cam in seq.cameras]

        stat = [StatisticalBackground(seq.background(i)) for i in range(len(seq.cameras))]
        mog = [Mog2Background(seq.background(i)) for i in range(len(seq.cameras))]
        guided = [GuidedSegmenter(b) for b in stat]
        textured = [GuidedSegmenter(b, GuidedOptions(texture_weight=3.0)) for b in stat]
        first = int(np.flatnonzero(~result.failed)[0])
        for seg, tex, img, sil in zip(guided, textured, seq.images(first), silhouettes(first)):
            seg.learn(img, sil)
            tex.learn(img, sil)
        scores = {m: [[] for _ in seq.cameras] for m in (*methods, *yardsticks)}
        seconds = dict.fromkeys(methods, 0.0)
        frames = range(first + 1, len(seq), step)
        for f in frames:
            prior = silhouettes(f - 1) if not result.failed[f - 1] else [None] * len(seq.cameras)
            for i, img in enumerate(seq.images(f)):
                truth = seq.mask(f, i) > 0
                for method, segment in (("Horprasert", lambda: stat[i].mask(img)), ("MOG2", lambda: mog[i].mask(img)),
                                        ("model-guided", lambda: guided[i].mask(img, prior[i])),
                                        ("guided + texture", lambda: textured[i].mask(img, prior[i]))):
                    t0 = time.perf_counter()
                    mask = segment()
                    seconds[method] += time.perf_counter() - t0
                    scores[method][i].append(iou(mask, truth))
                for yardstick, off_by_one in yardsticks.items():
                    scores[yardstick][i].append(iou(off_by_one(truth), truth))
        n = len(frames) * len(seq.cameras)
        print(f"\n{name}: {len(seq.cameras)} cameras, every {step}th frame from {first + 1} ({len(frames)} frames); "
              "IoU against the exact masks, mean / worst frame")
        columns = (*methods, *yardsticks)
        print("| camera | " + " | ".join(columns) + " |")
        print("|---|" + "---|" * len(columns))
        for i, cam in enumerate(seq.cameras):
            print(f"| {cam.name} | " + " | ".join(f"{np.mean(scores[m][i]):.3f} / {np.min(scores[m][i]):.3f}"
                                               for m in columns) + " |")
        print("| all | " + " | ".join(f"**{np.mean(scores[m]):.3f}** / {np.min(scores[m]):.3f}" for m in columns)
              + " |")
        print("| ms per camera frame | " + " | ".join([f"{1000 * seconds[m] / n:.1f}" for m in methods]
                                                   + ["–"] * len(yardsticks)) + " |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=12, help="frames timed")
    ap.add_argument("--devset", nargs="+", metavar="SEQUENCE",
                    help="per-camera IoU table of these development sequences")
    ap.add_argument("--step", type=int, default=3, help="with --devset: every STEPth frame (default 3)")
    args = ap.parse_args()
    if args.devset:
        devset_table(args.devset, args.step)
        return
    with tempfile.TemporaryDirectory() as tmp:
        seq_path = synthesize(Path(tmp) / "seq", "demo", 8, "tall", show_progress=False)
        seq = Sequence(seq_path)
        frames = np.linspace(0, len(seq) - 1, args.frames).astype(int)
        stat = [StatisticalBackground(seq.background(i)) for i in range(8)]
        mog = [Mog2Background(seq.background(i)) for i in range(8)]
        t_stat = t_mog = 0.0
        iou_stat, iou_mog = [], []
        hull_times, carve, mesh, naive_times, ours_mesh, ref_mesh = [], [], [], [], [], []
        truth_v = np.load(seq_path / "truth" / "vertices.npy", mmap_mode="r")
        hull_err = []
        for k, f in enumerate(frames):
            imgs = seq.images(f)
            masks = []
            for i, img in enumerate(imgs):
                truth = cv2.imread(str(seq_path / "truth" / "silhouettes" / f"cam{i}" / f"{f:06d}.png"), 0) > 0
                t0 = time.perf_counter()
                m = stat[i].mask(img)
                t_stat += time.perf_counter() - t0
                t0 = time.perf_counter()
                mm = mog[i].mask(img)
                t_mog += time.perf_counter() - t0
                masks.append(m)
                iou_stat.append(iou(m, truth))
                iou_mog.append(iou(mm, truth))
            rep = HullReport()
            t0 = time.perf_counter()
            hull = visual_hull(masks, seq.cameras, 0.01, volume=BOUNDS, report=rep)
            hull_times.append(time.perf_counter() - t0)
            carve.append(rep.carve_seconds)
            mesh.append(rep.mesh_seconds)
            views = [_carving_view(c, m) for c, m in zip(seq.cameras, masks)]
            origin, occupancy = _carve(views, *BOUNDS, 0.01, HullReport(), 3, 0)
            t0 = time.perf_counter()
            _mesh(occupancy, origin, 0.01, 0.7)
            ours_mesh.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            reference_surface(occupancy)
            ref_mesh.append(time.perf_counter() - t0)
            # Accuracy: distance from each true surface vertex to the nearest hull vertex.
            from scipy.spatial import cKDTree

            d, _ = cKDTree(hull.vertices).query(np.asarray(truth_v[f], float))
            hull_err.append(np.median(d))
            if k < 3:
                t0 = time.perf_counter()
                naive_hull_voxels(masks, seq.cameras)
                naive_times.append(time.perf_counter() - t0)
        n_masks = len(iou_stat)
        print(f"8 cameras 640×480, {len(frames)} frames of the demo motion, 2 cores")
        print(f"background subtraction (Horprasert): {1000 * t_stat / n_masks:6.1f} ms per camera frame, "
              f"IoU mean {np.mean(iou_stat):.4f} min {np.min(iou_stat):.4f}")
        print(f"background subtraction (MOG2):       {1000 * t_mog / n_masks:6.1f} ms per camera frame, "
              f"IoU mean {np.mean(iou_mog):.4f} min {np.min(iou_mog):.4f}")
        h, n = np.mean(hull_times), np.mean(naive_times)
        print(f"visual hull at 1 cm: {1000 * h:6.1f} ms per frame (carving {1000 * np.mean(carve):.1f} ms, "
              f"surface {1000 * np.mean(mesh):.1f} ms, the rest distance transforms)")
        m, r = np.mean(ours_mesh), np.mean(ref_mesh)
        print(f"surface of the same occupancy: engine blur + isosurface {1000 * m:.1f} ms, SciPy Gaussian filter "
              f"+ scikit-image marching cubes {1000 * r:.1f} ms → ours is {r / m:.1f}× faster")
        print(f"naive full-grid carving of the same 2×2×2.2 m volume: {1000 * n:7.1f} ms per frame "
              f"→ ours is {n / h:.1f}× faster")
        print(f"hull accuracy: median distance from true surface to hull {1000 * np.mean(hull_err):.1f} mm")


if __name__ == "__main__":
    main()
