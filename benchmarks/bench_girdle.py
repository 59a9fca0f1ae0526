"""Raised arms on the development set: how low the tracked shoulders sit, and whether the
fit itself prefers them there (docs/notebooks/accuracy.md, "Raised arms").

For each run of ``bench_devset.py`` (its model and tracked poses), the frames where a
true wrist is 20 cm or more above its shoulder count as raised. The script prints the
mean height error of the shoulders there and elsewhere, then refits some raised frames
from their tracked pose as tracking fits them, and from that pose with each clavicle's
elevation set to 20°, 30° and 40° (the shoulder's abduction taking the difference, so
that the arm points the same way at the start). For each start: the clavicles'
elevation after the fit, the shoulders' height error, and the fit's quality (what the
tracker ranks fits by) and energy. Starts that end nearer the true shoulders with a lower
quality say the model's own fit prefers the low shoulder; starts that end there with a
higher one say tracking missed a better minimum. The refits take the run's saved model
with the hands tracking fits (``TrackerOptions.hand_reach``: by default 0.6 from exact
masks, whole hands from colour frames), as tracking does.

    .venv/bin/python benchmarks/bench_girdle.py [--runs DIR] [--frames 6]

About 15 s for the eight runs on 2 cores (the hulls of the chosen frames, four fits each;
three runs took 5 s).

``--section RUN FRAME`` draws instead one tracked frame of one run (``d03_punch_6cam-exact
88``) in the plane of the neck, the right shoulder and the right elbow: the true body
surface, the fitted model's surface and both skeletons (docs/raised_arm.png).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import devset
from hullcap._fitting import PoseParameters, fit, make_target, quality
from hullcap.export import load_result
from hullcap._sequence import Sequence
from hullcap._subject import with_hands
from hullcap._tracking import Tracker, TrackerOptions

RAISED = 0.20
"""A wrist this far (m) above its shoulder, in the truth, raises the arm."""
ELEVATIONS = (20.0, 30.0, 40.0)
"""Clavicle elevations (degrees) the extra starts set."""


def shoulder_height_errors(names, joints, truth: devset.Truth) -> np.ndarray:
    """(F, 2) height of our left and right shoulders minus the truth's (m)."""
    return np.stack([joints[:, list(names).index(f"{s}_shoulder"), 2] -
                     truth.positions[: len(joints), truth.names.index(f"{s}_shoulder"), 2] for s in "lr"], axis=1)


def raised_arms(truth: devset.Truth) -> np.ndarray:
    """(F, 2) bool: the truth's left and right wrist at least RAISED above its shoulder."""
    return np.stack([truth.positions[:, truth.names.index(f"{s}_wrist"), 2] -
                     truth.positions[:, truth.names.index(f"{s}_shoulder"), 2] >= RAISED for s in "lr"], axis=1)


def with_clavicles(model, pose: PoseParameters, degrees: float) -> PoseParameters:
    """`pose` with both clavicles' elevation set to `degrees`, each shoulder's abduction
    lowered by what its clavicle gained."""
    theta, dofs = pose.theta.copy(), list(model.dof_names)
    for s in "lr":
        clavicle, shoulder = dofs.index(f"{s}_clavicle_elevation"), dofs.index(f"{s}_shoulder_abduction")
        gain = np.radians(degrees) - theta[clavicle]
        theta[clavicle] += gain
        theta[shoulder] -= gain
    return PoseParameters(model.clamp(theta), pose.root_rotation, pose.root_translation)


def summary(result, truth: devset.Truth) -> np.ndarray:
    """Prints how low the shoulders sit with a raised arm; returns the frames with one."""
    raised = raised_arms(truth)[: len(result.joints)]
    dz = shoulder_height_errors(result.model.joint_names, result.joints, truth) * 1e3
    left, right = (np.nanmean(dz[:, i][raised[:, i]]) for i in (0, 1))
    either = raised.any(axis=1) & ~result.failed
    print(f"{either.sum()} of {len(either)} frames with a raised arm; shoulder height error there "
          f"{np.nanmean(dz[raised]):+.0f} mm (left {left:+.0f}, right {right:+.0f}), "
          f"elsewhere {np.nanmean(dz[~raised]):+.0f} mm")
    return np.flatnonzero(either)


def refits(sequence: Path, result, truth: devset.Truth, exact: bool, frames) -> None:
    """Prints the fits of `frames` from the tracked pose and from raised clavicles."""
    options = TrackerOptions(ignore_silhouettes=not exact)
    tracker = Tracker(Sequence(sequence), model=result.model, options=options)
    model = with_hands(result.model, tracker._hand_reach)  # the hands tracking fits
    dofs = list(model.dof_names)
    rows = {}
    for f in frames:
        target = make_target(tracker.hull(f, (result.model, result.pose(f - 1))))
        starts = {"tracked": result.pose(f)}
        starts.update({f"clavicles {d:.0f}°": with_clavicles(model, result.pose(f), d) for d in ELEVATIONS})
        for label, start in starts.items():
            fitted = fit(model, target, start, options.fit)
            p = fitted.pose
            joints = model.pose(p.theta, p.root_rotation, p.root_translation).joints[None]
            dz = shoulder_height_errors(model.joint_names, joints, devset.Truth(truth.names, truth.positions[[f]]))
            clavicles = np.degrees([p.theta[dofs.index(f"{s}_clavicle_elevation")] for s in "lr"])
            rows.setdefault(label, []).append((*clavicles, *(dz[0] * 1e3), quality(fitted), fitted.energy))
    print(f"  {len(frames)} raised frames refitted ({', '.join(map(str, frames))}); means over them:")
    print("  | start | clavicles after (°, l / r) | shoulder height error (mm, l / r) | quality | energy |")
    print("  |---|---|---|---|---|")
    for label, values in rows.items():
        m = np.mean(values, axis=0)
        print(f"  | {label} | {m[0]:.0f} / {m[1]:.0f} | {m[2]:+.0f} / {m[3]:+.0f} | {m[4]:.4f} | {m[5]:.4f} |")


def section(where: Path, runs: Path, run: str, frame: int, out: Path) -> None:
    """Writes `out`: `frame` of `run` cut by the plane of the true neck, right shoulder and
    right elbow, the true surface (green) and the tracked model's (red) within a slab."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = run.rsplit("-", 1)[0]
    sequence = devset.render(where, name)
    truth = devset.Truth.load(where, sequence)
    result = load_result(runs / run)
    p = result.pose(frame)
    posed = result.model.pose(p.theta, p.root_rotation, p.root_translation)
    true_joints = [truth.positions[frame, truth.names.index(j)] for j in ("neck", "r_shoulder", "r_elbow", "r_wrist")]
    neck, shoulder, elbow = true_joints[:3]
    u = (shoulder - neck) / np.linalg.norm(shoulder - neck)
    w = np.cross(u, elbow - shoulder)
    w /= np.linalg.norm(w)
    v = np.cross(w, u)

    def plane(points, slab):
        d = np.asarray(points) - neck
        keep = np.abs(d @ w) < slab
        return d[keep] @ u, d[keep] @ v

    fig, ax = plt.subplots(figsize=(6, 8))
    ax.scatter(*plane(devset.TrueSurfaces(sequence, samples=200_000)(frame).vertices, 0.006), s=1, c="green",
               label="true surface")
    ax.scatter(*plane(posed.vertices, 0.012), s=4, c="red", label="tracked model")
    names = list(result.model.joint_names)
    ours = [posed.joints[names.index(j)] for j in ("neck", "r_shoulder", "r_elbow", "r_wrist")]
    ax.plot(*plane(ours, np.inf), "o-", c="red", label="its joints")
    ax.plot(*plane(true_joints, np.inf), "k*-", ms=11, label="true joints")
    ax.set_aspect("equal")
    ax.set_xlabel("m, along the true neck → right shoulder")
    ax.legend(loc="lower right")
    ax.set_title(f"{run}, frame {frame}")
    fig.savefig(out, dpi=70, bbox_inches="tight")
    print(f"wrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", default=str(devset.CACHE / "results"), help="where bench_devset.py wrote its runs")
    ap.add_argument("--frames", type=int, default=6, help="raised frames refitted per run")
    ap.add_argument("--section", nargs=2, metavar=("RUN", "FRAME"),
                    help="draw one frame of one run in the plane of the neck, right shoulder and elbow")
    ap.add_argument("--out", default="docs/raised_arm.png", help="where --section writes its picture")
    args = ap.parse_args()
    if args.frames < 1:
        ap.error("--frames must be at least 1")
    where = devset.find()
    if where is None:
        raise SystemExit("the development set is not here: set HULLCAP_DEVSET")
    if args.section:
        run, frame = args.section
        if not frame.isdigit():
            ap.error(f"--section: FRAME must be a frame number, got {frame!r}")
        section(where, Path(args.runs), run, int(frame), Path(args.out))
        return
    found = False
    for name in devset.names(where):
        sequence = devset.render(where, name)
        truth = devset.Truth.load(where, sequence)
        for mode in ("colour", "exact"):
            run = Path(args.runs) / f"{name}-{mode}"
            if (run / "pose.npz").is_file():
                found = True
                result = load_result(run)
                print(f"{name} ({mode}): ", end="")
                raised = summary(result, truth)
                # Each hull is guided by the tracked pose of the frame before.
                raised = raised[(raised > 0) & ~result.failed[np.maximum(raised - 1, 0)]]
                if len(raised):
                    pick = np.linspace(0, len(raised) - 1, min(args.frames, len(raised))).round().astype(int)
                    refits(sequence, result, truth, mode == "exact", [int(f) for f in raised[pick]])
    if not found:
        raise SystemExit(f"no runs in {args.runs}: run benchmarks/bench_devset.py first")


if __name__ == "__main__":
    main()
