"""Accuracy and speed on the development set: realistic bodies driven by real motion.

Renders each sequence once into ``data/devset/`` (ignored by git), tracks it as
``hullcap track`` does, from the colour frames (the background test fused with the learned
person segmenter where it is installed, ``--segmenter colour`` the background test alone;
the table names the first ``learned``, the second ``colour``) and, with
``--silhouettes exact``, from the exact masks too (``surface``: given the true body surface
of each frame instead of its hull, what a perfect hull would give; with whole hands, since
that surface keeps the fingers a hull loses), and prints one table: per sequence
the subject model's limb-length errors against the truth, the mean joint error over the
30 static calibration frames, MPJPE raw and offset-removed over the whole sequence (each
joint's constant offset removed in the world, as the set's ``score.py`` does, and in the
body's own frame, where a difference of joint-centre conventions stays constant when the
person turns round), frames lost, frames re-acquired, false-good frames (marked good or
recovered, yet a mean joint error over 80 mm or a joint over 150 mm), 3DPCK@150 (the share
of joint positions within 150 mm of the truth, a lost frame's all misses), the tracked
masks' mean IoU with the exact ones (from colour frames) and frames/s;
then each run's
error per joint and the joint angles its fits held at a limit of the model (where an
angle is a bound, not a measurement: a limit the motion needs). Each run's folder
also gets ``frames.csv``: per frame the status, the fit's quality both ways and the true
mean joint error.
``--every K`` tracks every K-th frame only, the same motion filmed at 1/K of the frame
rate: K times as far between frames for the prediction and the guided masks.
``--cameras K`` tracks with K of each sequence's cameras, spread evenly round its rig: the
same take filmed by a smaller rig (a sequence of K cameras or fewer keeps them all).
``--models-from RUNS`` gives each run the subject's model of the same run in the folder
``RUNS`` (an earlier ``--out``) instead of building it, as ``hullcap track --model`` and
every take of a batch after its calibration take do.
``--jobs N`` tracks N runs at a time in processes of their own, each engine on its share
of the cores: the same joints to the byte (a fit does not depend on its threads), the
whole table sooner, but each run's frames/s then measure a machine it shared.

    .venv/bin/python benchmarks/bench_devset.py [--only d01_bend] [--silhouettes colour exact surface] [--every K]
        [--cameras K] [--models-from RUNS] [--segmenter auto|learned|colour] [--preset accurate|live] [--jobs N]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

import devset
from hullcap._body import BodyModel
from hullcap._carver import Carver
from hullcap._results import RECOVERED, STATUS_NAMES
from hullcap._options import GIVEN, add_flags
from hullcap._sequence import MIN_CAMERAS, Sequence
from hullcap._tracking import Tracker, TrackerOptions
from hullcap._tracking_options import PRESETS


class TrueSurfaceCarver(Carver):
    """A tracker's carver that gives each frame's true body surface
    (:class:`devset.TrueSurfaces`) where it would carve a hull; the exact masks for the
    rest (the start's agreement test)."""

    def __init__(self, carver: Carver, sequence: Sequence):
        super().__init__(carver.segmenter, carver.options, carver.volume, carver.problems, carver.seconds)
        self._surfaces = devset.TrueSurfaces(sequence.path)

    def carve(self, frame: int, prior=None, doubt=None):
        return self._surfaces(frame), self.segmenter.segment(frame, None)[0]


def run(devset_dir: Path, name: str, mode: str, out: Path, frames: int | None, options: TrackerOptions,
        every: int = 1, models_from: Path | None = None, cameras: int | None = None,
        show_progress: bool = True) -> dict:
    seq_path = devset.subsampled(devset.render(devset_dir, name), every)
    kept = devset.spread_cameras(Sequence(seq_path).cameras, cameras)
    seq = Sequence(seq_path, cameras=kept)
    # d01_bend-colour, d01_bend-every3-colour, d01_bend-cams4-colour
    run_dir = out / f"{seq_path.name}{'' if kept is None else f'-cams{len(kept)}'}-{mode}"
    truth = devset.Truth.load(devset_dir, seq_path)
    options = replace(options, ignore_silhouettes=mode == "colour")
    model = None if models_from is None else BodyModel.load(models_from / run_dir.name / "model")
    if mode == "surface":
        tracker = Tracker(seq, model=model, options=replace(options, hand_reach=1.0))
        tracker.carver = TrueSurfaceCarver(tracker.carver, seq)
    else:
        tracker = Tracker(seq, model=model, options=options)
    if tracker.segmenter.learned:  # from colour frames with the learned segmenter: its runs kept apart
        mode = "learned"
        run_dir = run_dir.with_name(run_dir.name.removesuffix("-colour") + "-learned")
    ious = _measuring_masks(tracker.segmenter, seq) if mode in ("colour", "learned") else {}
    (run_dir / "frames.csv").unlink(missing_ok=True)  # ours, not a run's: the run would refuse the folder
    t0 = time.perf_counter()
    result = tracker.run(run_dir, resume=False, show_progress=show_progress, frames=frames)
    seconds = time.perf_counter() - t0
    n = len(result.failed)
    want = truth.limb_lengths()
    got = devset.model_limb_lengths(result.model)
    whole = devset.score(truth, result.model.joint_names, result.joints, result.failed)
    static = devset.score(truth, result.model.joint_names, result.joints, result.failed,
                          slice(0, round(devset.CALIBRATION_SECONDS * seq.fps)))
    joint_err = np.linalg.norm(result.joints[:, [result.model.joint_names.index(j) for j in truth.names]]
                               - truth.positions[:n], axis=2)
    err = joint_err.mean(1)
    honesty = devset.honesty(joint_err, result.status)
    frames_csv = ["frame,status,inlier_fraction,coverage,quality,error_mm"] + [
        f"{f},{STATUS_NAMES[result.status[f]]},{result.inlier_fraction[f]:.4f},{result.coverage[f]:.4f},"
        f"{result.quality[f]:.4f},{1000 * err[f]:.1f}" for f in range(n)]
    (run_dir / "frames.csv").write_text("\n".join(frames_csv) + "\n")
    return {"sequence": seq_path.name, "silhouettes": mode, "cameras": len(seq.cameras), "frames": n,
            "limb_error_pct": {k: 100 * (got[k] - want[k]) / want[k] for k in want},
            "static_mm": static.mpjpe_mm, "mpjpe_mm": whole.mpjpe_mm,
            "mpjpe_offset_removed_mm": whole.mpjpe_offset_removed_mm,
            "mpjpe_body_offset_removed_mm": whole.mpjpe_body_offset_removed_mm, "lost": whole.lost,
            "reacquired": int((result.status == RECOVERED).sum()), **honesty,
            "mask_iou": float(np.mean(list(ious.values()))) if ious else float("nan"),
            "fps": n / seconds, "fit_fps": n / max(result.seconds.get("fit", 0.0), 1e-9),
            "worst_frame": int(np.nanargmax(np.where(result.failed, -1, err))),
            "per_joint_mm": whole.per_joint_mm, "limits_held": result.limits_held()}


def _measuring_masks(segmenter, seq: Sequence) -> dict[int, float]:
    """Make `segmenter` record, for each frame it segments, the mean over the views of its
    masks' IoU with the sequence's exact silhouettes (the last masks of a frame count: the
    tracked ones); the returned dict fills as the run goes."""
    ious: dict[int, float] = {}
    segment = segmenter.segment

    def measured(frame: int, priors=None):
        masks, unsure = segment(frame, priors)
        views = []
        for cam, mask in zip(seq.cameras, masks):
            exact = seq.mask(frame, cam.name) > 0
            union = np.count_nonzero(exact | (mask > 0))
            views.append(np.count_nonzero(exact & (mask > 0)) / union if union else 1.0)
        ious[frame] = float(np.mean(views))
        return masks, unsure

    segmenter.segment = measured
    return ious


def _run_sharing(threads: int, *args) -> dict:
    """:func:`run` in a worker process whose engine uses `threads` threads."""
    os.environ["HULLCAP_THREADS"] = str(threads)
    return run(*args, show_progress=False)


def run_all(jobs: list[tuple], workers: int) -> list[dict]:
    """The rows of :func:`run` for each argument tuple of `jobs`, in their order,
    `workers` runs at a time (each printed as it is taken)."""
    if workers <= 1:
        return [_printed(run(*args)) for args in jobs]
    threads = max(1, (os.cpu_count() or 1) // workers)
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(_run_sharing, threads, *args) for args in jobs]
        return [_printed(future.result()) for future in futures]


def _printed(row: dict) -> dict:
    """`row`, once its line of the table is printed."""
    print(table([row]).splitlines()[-1], flush=True)
    return row


def table(rows: list[dict]) -> str:
    limbs = list(devset.LIMBS)
    head = ("| sequence | cams | silhouettes | " + " | ".join(f"{limb} (%)" for limb in limbs)
            + " | static (mm) | MPJPE raw (mm) | offset removed (mm) | in the body's frame (mm) | lost | re-acquired"
            + " | false good | good ≤ 40 (%) | 3DPCK@150 (%) | mask IoU | frames/s | fit frames/s |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        lines.append(f"| {r['sequence']} | {r['cameras']} | {r['silhouettes']} | "
                     + " | ".join(f"{r['limb_error_pct'][limb]:+.1f}" for limb in limbs)
                     + f" | {r['static_mm']:.1f} | {r['mpjpe_mm']:.1f} | {r['mpjpe_offset_removed_mm']:.1f} | "
                       f"{r['mpjpe_body_offset_removed_mm']:.1f} | "
                       f"{r['lost']} of {r['frames']} | {r['reacquired']} | {r['false_good']} | {r['good_40']:.1f} | "
                       f"{r['pck150']:.1f} | "
                       f"{r['mask_iou']:.3f} | {r['fps']:.1f} | {r['fit_fps']:.1f} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--devset", help="the development set's folder (default $HULLCAP_DEVSET or ../shared/devset)")
    ap.add_argument("--only", nargs="+", help="these sequences only")
    ap.add_argument("--silhouettes", nargs="+", choices=["colour", "exact", "surface"], default=["colour"])
    ap.add_argument("--frames", type=int, help="track only the first N frames of each")
    ap.add_argument("--every", type=int, default=1, metavar="K",
                    help="track every K-th frame only (the motion at 1/K of the frame rate)")
    ap.add_argument("--out", default=str(devset.CACHE / "results"), help="where the runs are written")
    ap.add_argument("--json", help="also write the rows as JSON here")
    ap.add_argument("--no-refine-joints", dest="refine", action="store_false",
                    help="build the subject model from the calibration pose only")
    ap.add_argument("--models-from", metavar="RUNS",
                    help="give each run the subject's model of the same run in RUNS (an earlier --out)")
    ap.add_argument("--cameras", type=int, metavar="K",
                    help="track with K of each sequence's cameras, spread evenly round its rig (default: all)")
    add_flags(ap, TrackerOptions, ["segmenter", "learned_every"])
    ap.add_argument("--preset", choices=list(PRESETS), default="accurate",
                    help="the tracker's preset (hullcap track --preset); --segmenter and --learned-every over it")
    ap.add_argument("--jobs", type=int, default=1, metavar="N",
                    help="track N runs at a time (frames/s are then those of a shared machine)")
    args = ap.parse_args()
    devset_dir = devset.find(args.devset)
    if devset_dir is None:
        ap.error("the development set is not here: pass --devset or set HULLCAP_DEVSET")
    if args.every < 1:
        ap.error(f"--every must be 1 or more, got {args.every}")
    if args.jobs < 1:
        ap.error(f"--jobs must be 1 or more, got {args.jobs}")
    if args.cameras is not None and args.cameras < MIN_CAMERAS:
        ap.error(f"--cameras must be {MIN_CAMERAS} or more, got {args.cameras}")
    given = getattr(args, GIVEN, set())
    options = TrackerOptions.preset(args.preset, refine_joints=args.refine,
                                    **{k: getattr(args, k) for k in ("segmenter", "learned_every") if k in given})
    models_from = None if args.models_from is None else Path(args.models_from)
    names = args.only or devset.names(devset_dir)
    for name in names:  # rendered here, once, before any run reads it
        devset.subsampled(devset.render(devset_dir, name), args.every)
    rows = run_all([(devset_dir, name, mode, Path(args.out), args.frames, options, args.every, models_from,
                     args.cameras)
                    for name in names for mode in args.silhouettes], args.jobs)
    print("\n" + table(rows))
    if args.jobs > 1:
        print(f"({args.jobs} runs at a time: each run's frames/s measure a machine it shared)")
    print("\nper joint, raw (mm):")
    for r in rows:
        print(f"  {r['sequence']} / {r['silhouettes']}: " + ", ".join(f"{k} {v}" for k, v in r["per_joint_mm"].items()))
    print("\njoint angles held at a limit of the model (frames; the most held first):")
    for r in rows:
        held = ", ".join(f"{dof} ({side}) {n}" for dof, side, n in r["limits_held"][:6]) or "none"
        print(f"  {r['sequence']} / {r['silhouettes']}: {held}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
