"""Reproduce the paper's evaluation (§4.1) on our implementation, and go beyond it.

1. Two-joint object (paper Fig. 8–9): deformable vs rigid segment model against noisy
   targets, noise σ swept; joint-angle error and correspondence distance.
2. Torso twist (Fig. 10): the full body twisting and bending at the waist with the legs
   moving; deformable vs rigid, per-joint errors.
3. Hierarchical vs simultaneous fitting (Fig. 11): success rate and cost against the size
   of the initial offset.
4. Beyond the paper: Levenberg–Marquardt vs conjugate gradients, point-to-point vs
   point-to-plane.

Seeded and regenerable: ``make paper`` (or ``.venv/bin/python benchmarks/paper.py``)
writes PNG plots and ``docs/paper.md``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import cv2  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from hullcap import BodyModel, FitOptions, LinkModel, PoseParameters, Surface, fit  # noqa: E402
from hullcap._cameras import Camera, look_at  # noqa: E402
from hullcap._fitting import yaw_rotation  # noqa: E402
from hullcap._implicit import field_mesh, round_cone, smooth_union  # noqa: E402
from hullcap._render import shade  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"
SUCCESS_MM = 20.0


def two_joint_object() -> BodyModel:
    """Three links along +x (0.3 m each) with a 2-DOF and a 1-DOF joint, in a smooth tube
    that narrows at the joints."""
    spec = {
        "links": [
            {"name": "base", "parent": None, "joint": "base", "origin": [0, 0, 0],
             "segment": [[0.0, 0, 0], [0.28, 0, 0]], "dofs": []},
            {"name": "middle", "parent": "base", "joint": "j1", "origin": [0.3, 0, 0],
             "segment": [[0.32, 0, 0], [0.58, 0, 0]],
             "dofs": [{"name": "j1_bend", "axis": [0, 0, 1], "limits": [-120, 120]},
                      {"name": "j1_lift", "axis": [0, -1, 0], "limits": [-120, 120]}]},
            {"name": "tip", "parent": "middle", "joint": "j2", "origin": [0.6, 0, 0],
             "segment": [[0.62, 0, 0], [0.88, 0, 0]],
             "dofs": [{"name": "j2_bend", "axis": [0, 0, 1], "limits": [-120, 120]}]},
        ],
        "sites": [{"name": "end", "link": "tip", "position": [0.9, 0, 0]}],
        "joint_names": ["base", "j1", "j2", "end"],
        "hierarchy": [["j1"], ["j2"]],
    }
    links = LinkModel.from_dict(spec, "two-joint object")

    def field(p):
        d = None
        for a, b in (((0.0, 0, 0), (0.3, 0, 0)), ((0.3, 0, 0), (0.6, 0, 0)), ((0.6, 0, 0), (0.9, 0, 0))):
            # Each segment bulges in its middle: 6 cm at the joints, 8 cm mid-segment;
            # flattened in z so that turning about its axis shows.
            q = p * (1.0, 1.0, 1.4)
            c = round_cone(q, a, ((a[0] + b[0]) / 2, 0, 0), 0.06, 0.08)
            c = np.minimum(c, round_cone(q, ((a[0] + b[0]) / 2, 0, 0), b, 0.08, 0.06))
            d = c if d is None else smooth_union(d, c, 0.02)
        return d

    v, f = field_mesh(field, (-0.1, -0.1, -0.1), (1.0, 0.1, 0.1), 0.008)
    return BodyModel(links, v, f)


def angle_error_deg(a, b) -> float:
    return float(np.degrees(np.abs(np.asarray(a) - np.asarray(b))).mean())


def experiment_two_joint(rng, trials: int):
    model = two_joint_object()
    rigid = model.rigid()
    sigmas = [0.0, 0.005, 0.01, 0.015, 0.02, 0.03]
    rows = []
    typical = {}
    for sigma in sigmas:
        errs = {"deformable": [], "rigid": []}
        dists = {"deformable": [], "rigid": []}
        for _ in range(trials):
            truth = np.radians(rng.uniform(-50, 50, 3))
            posed = model.pose(truth)
            noisy = posed.vertices + rng.normal(0, sigma, posed.vertices.shape)
            target = Surface(noisy, model.faces, posed.normals)
            start = PoseParameters(truth + np.radians(rng.normal(0, 10, 3)))
            for name, m in (("deformable", model), ("rigid", rigid)):
                r = fit(m, target, start, FitOptions(sigma_min=max(sigma, 0.002), iterations=20, rounds=6),
                        model_points=np.arange(len(m.vertices)))
                errs[name].append(angle_error_deg(r.pose.theta, truth) + np.degrees(
                    np.arccos(np.clip((np.trace(r.pose.root_rotation) - 1) / 2, -1, 1))) / 3)
                dists[name].append(r.mean_residual)
                if sigma == 0.01 and f"{name} model" not in typical:
                    got = m.pose(r.pose.theta, r.pose.root_rotation, r.pose.root_translation)
                    typical[f"{name} model"] = (got.vertices, noisy)
        rows.append((sigma, np.mean(errs["deformable"]), np.mean(errs["rigid"]),
                     np.mean(dists["deformable"]), np.mean(dists["rigid"])))
    rows = np.array(rows)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    ax[0].plot(rows[:, 0] * 100, rows[:, 1], "o-", label="deformable model")
    ax[0].plot(rows[:, 0] * 100, rows[:, 2], "s--", label="rigid segment model")
    ax[0].set(xlabel="noise σ (cm)", ylabel="mean joint-angle error (°)", title="Two-joint object: angle error")
    ax[1].plot(rows[:, 0] * 100, rows[:, 3] * 1000, "o-", label="deformable model")
    ax[1].plot(rows[:, 0] * 100, rows[:, 4] * 1000, "s--", label="rigid segment model")
    ax[1].set(xlabel="noise σ (cm)", ylabel="mean correspondence distance (mm)", title="Correspondence distance")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig(DOCS / "paper_two_joint.png", dpi=110)
    plt.close(fig)
    _picture(model, typical, DOCS / "paper_two_joint_fit.png", eye=(0.45, -1.6, 0.9), at=(0.45, 0, 0), focal=420)
    return rows


def torso_twist_targets(model):
    """Poses of a twist with a bend at the waist while the legs step, frame by frame."""
    names = model.dof_names
    poses = []
    for k in range(12):
        a = k / 11
        th = np.zeros(model.n_dofs)
        th[names.index("waist_twist")] = np.radians(40 * np.sin(np.pi * a))
        th[names.index("waist_flexion")] = np.radians(25 * a)
        th[names.index("waist_lateral")] = np.radians(10 * np.sin(2 * np.pi * a))
        th[names.index("l_hip_flexion")] = np.radians(35 * np.sin(np.pi * a))
        th[names.index("l_knee_flexion")] = np.radians(50 * np.sin(np.pi * a))
        th[names.index("r_hip_flexion")] = np.radians(-15 * np.sin(np.pi * a))
        for side in "lr":
            th[names.index(f"{side}_shoulder_abduction")] = np.radians(-60)
        poses.append(th)
    return poses


def experiment_torso_twist(rng, noise=0.005):
    model = BodyModel.template()
    rigid = model.rigid()
    poses = torso_twist_targets(model)
    t = np.array([0.0, 0.0, model.rest_root_height])
    per_joint = {"deformable": [], "rigid": []}
    last = {}
    for name, m in (("deformable", model), ("rigid", rigid)):
        current = PoseParameters(poses[0], np.eye(3), t)
        for k, th in enumerate(poses):
            truth = model.pose(th, np.eye(3), t)
            target = Surface(truth.vertices + rng.normal(0, noise, truth.vertices.shape), model.faces, truth.normals)
            r = fit(m, target, current)
            current = r.pose
            got = m.pose(r.pose.theta, r.pose.root_rotation, r.pose.root_translation)
            per_joint[name].append(np.linalg.norm(got.joints - truth.joints, axis=1) * 1000)
            if k == len(poses) // 2:  # the deepest twist, for the picture
                last[f"{name} model"] = (got.vertices, truth.vertices)
    table = {k: np.mean(v, 0) for k, v in per_joint.items()}
    _picture(model, last, DOCS / "paper_torso_twist.png")
    return model.joint_names, table


def _picture(model, fitted, path, eye=(2.5, -4.5, 1.3), at=(0, 0, 0.9), focal=1100):
    """Each fitted model shaded, with the target's points over it (red)."""
    w, h = 360, 460
    K = [[focal, 0, (w - 1) / 2], [0, focal, (h - 1) / 2], [0, 0, 1]]
    R, tt = look_at(eye, at)
    cam = Camera("view", w, h, K, np.zeros(5), R, tt)
    panels = []
    for label, (verts, target) in fitted.items():
        img, _ = shade(cam, verts, model.faces)
        img = (img[..., ::-1] * 255).astype(np.uint8)
        px, _ = cam.project(target[::7])
        for u, v in np.rint(px).astype(int):
            if 0 <= u < w and 0 <= v < h:
                img[v, u] = (30, 30, 220)
        cv2.putText(img, label, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (40, 40, 40), 1, cv2.LINE_AA)
        panels.append(img)
    cv2.imwrite(str(path), np.hstack(panels))


def offset_trials(rng, magnitudes, trials):
    """(start, truth) pairs: truth a random pose, start off by `magnitude` degrees on
    every joint (and magnitude/4 degrees, magnitude mm on the root)."""
    model = BodyModel.template()
    lim = model.link_model.dof_limits
    out = {}
    for mag in magnitudes:
        cases = []
        for _ in range(trials):
            truth = np.clip(rng.normal(0, 0.25, 29), lim[:, 0] * 0.7, lim[:, 1] * 0.7)
            sign = rng.choice([-1, 1], 29)
            start = np.clip(truth + sign * np.radians(mag), lim[:, 0], lim[:, 1])
            yaw = np.radians(mag / 4) * rng.choice([-1, 1])
            cases.append((PoseParameters(start, yaw_rotation(yaw),
                                         np.array([0, 0, 0.97]) + rng.normal(0, mag / 1000, 3)), truth))
        out[mag] = cases
    return model, out


def run_sweep(model, cases, **options):
    rows = []
    for mag, pairs in cases.items():
        ok, its, secs, errs = [], [], [], []
        for start, truth in pairs:
            posed = model.pose(truth, np.eye(3), (0, 0, 0.97))
            target = Surface(posed.vertices, model.faces, posed.normals)
            t0 = time.perf_counter()
            r = fit(model, target, start, FitOptions(**options))
            secs.append(time.perf_counter() - t0)
            got = model.pose(r.pose.theta, r.pose.root_rotation, r.pose.root_translation)
            e = np.linalg.norm(got.joints - posed.joints, axis=1).mean() * 1000
            errs.append(e)
            ok.append(e < SUCCESS_MM)
            its.append(r.iterations)
        rows.append((mag, np.mean(ok), np.mean(its), np.mean(secs), np.median(errs)))
    return np.array(rows)


def experiment_hierarchy(rng, trials):
    model, cases = offset_trials(rng, [5, 10, 20, 30, 40], trials)
    hier = run_sweep(model, cases, hierarchical=True, polish=False, rounds=6)
    hier_polish = run_sweep(model, cases, hierarchical=True, polish=True, rounds=6)
    simul = run_sweep(model, cases, hierarchical=False, iterations=60)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    for rows, label, style in ((hier, "hierarchical (paper)", "o-"),
                               (hier_polish, "hierarchical + joint polish (ours)", "^-"),
                               (simul, "simultaneous", "s--")):
        ax[0].plot(rows[:, 0], rows[:, 1] * 100, style, label=label)
        ax[1].plot(rows[:, 0], rows[:, 3] * 1000, style, label=label)
    ax[0].set(xlabel="initial offset per joint (°)",
              ylabel=f"success rate (%) (mean joint error < {SUCCESS_MM:.0f} mm)",
              title="Hierarchical vs simultaneous fitting", ylim=(-5, 105))
    ax[1].set(xlabel="initial offset per joint (°)", ylabel="time per fit (ms)", title="Cost")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(DOCS / "paper_hierarchy.png", dpi=110)
    plt.close(fig)
    typical_fits(model, cases, 20, {"hierarchical": dict(polish=False, rounds=6),
                                    "hier. + polish": dict(rounds=6),
                                    "simultaneous": dict(hierarchical=False, iterations=60)},
                 DOCS / "paper_hierarchy_fit.png")
    return hier, hier_polish, simul, model, cases


def typical_fits(model, cases, magnitude, variants: dict, path):
    """Picture of the first trial at `magnitude`° fitted by each variant over its target."""
    start, truth = cases[magnitude][0]
    posed = model.pose(truth, np.eye(3), (0, 0, 0.97))
    target = Surface(posed.vertices, model.faces, posed.normals)
    shown = {}
    for label, options in variants.items():
        r = fit(model, target, start, FitOptions(**options))
        got = model.pose(r.pose.theta, r.pose.root_rotation, r.pose.root_translation)
        err = np.linalg.norm(got.joints - posed.joints, axis=1).mean() * 1000
        shown[f"{label}: {err:.0f} mm"] = (got.vertices, posed.vertices)
    _picture(model, shown, path)


def experiment_solvers(model, cases):
    small = {m: c for m, c in cases.items() if m in (5, 10, 20)}
    variants = {
        "LM, point-to-point": dict(),
        "LM, point-to-plane": dict(residual="point_to_plane"),
        "CG (paper), point-to-point": dict(solver="cg", iterations=40),
        "CG, point-to-plane": dict(solver="cg", residual="point_to_plane", iterations=40),
    }
    out = {name: run_sweep(model, small, **opts) for name, opts in variants.items()}
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6))
    for (name, rows), style in zip(out.items(), ("o-", "^-", "s--", "d--")):
        ax[0].plot(rows[:, 0], rows[:, 1] * 100, style, label=name)
        ax[1].plot(rows[:, 0], rows[:, 2], style, label=name)
        ax[2].plot(rows[:, 0], rows[:, 4], style, label=name)
    ax[0].set(xlabel="initial offset per joint (°)", ylabel="success rate (%)", ylim=(-5, 105))
    ax[1].set(xlabel="initial offset per joint (°)", ylabel="iterations")
    ax[2].set(xlabel="initial offset per joint (°)", ylabel="median joint error (mm)", yscale="symlog")
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.suptitle("Solver and residual (hierarchical with joint polish)")
    fig.tight_layout()
    fig.savefig(DOCS / "paper_solvers.png", dpi=110)
    plt.close(fig)
    typical_fits(model, small, 10, {"LM, point-to-plane": variants["LM, point-to-plane"],
                                    "CG (paper)": variants["CG (paper), point-to-point"]},
                 DOCS / "paper_solvers_fit.png")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=8, help="random trials per setting")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    two = experiment_two_joint(rng, args.trials)
    names, twist = experiment_torso_twist(rng)
    hier, hier_polish, simul, model, cases = experiment_hierarchy(rng, args.trials)
    solvers = experiment_solvers(model, cases)
    md = [
        "# The paper's evaluation, reproduced",
        "",
        f"Generated by `benchmarks/paper.py --trials {args.trials} --seed {args.seed}` "
        f"({time.perf_counter() - t0:.0f} s on 2 cores); every number below is regenerated by it.",
        "",
        "## 1. Two-joint object (paper Fig. 8–9)",
        "",
        "Three links (0.3 m each) with a 2-DOF and a 1-DOF joint inside a smooth tube (8 cm thick "
        "mid-segment, 6 cm at the joints). Target: the deformable model at random joint angles "
        "(±50°) with Gaussian noise σ on every vertex; start: 10° off per joint. The rigid segment "
        "model has the same mesh and joints, each vertex bound to its nearest link. "
        f"{args.trials} trials per σ. Error = mean joint-angle error plus a third of the root's "
        "rotation error (°).",
        "",
        "![two-joint object](paper_two_joint.png)",
        "",
        "The typical case at σ = 1 cm, each model fitted (shaded) with the noisy target's points (red):",
        "",
        "![two-joint fits](paper_two_joint_fit.png)",
        "",
        "| σ (cm) | deformable (°) | rigid (°) | rigid / deformable | corr. distance deformable (mm) | rigid (mm) |",
        "|---|---|---|---|---|---|",
    ]
    for s, d, r, cd, cr in two:
        md.append(f"| {100 * s:.1f} | {d:.2f} | {r:.2f} | {r / max(d, 1e-9):.1f}× | {1000 * cd:.1f} "
                  f"| {1000 * cr:.1f} |")
    paper_noise = two[(two[:, 0] > 0) & (two[:, 0] <= 0.02)]
    ratio = float(np.mean(paper_noise[:, 2] / paper_noise[:, 1]))
    md += ["", f"At σ = 0.5–2 cm the rigid model's angle error is **{ratio:.1f}×** the deformable "
           "model's (the paper reports about 2×); neither diverges as σ grows. Without noise it is "
           f"{two[0, 2] / max(two[0, 1], 1e-9):.1f}×; from σ ≈ 1 cm the vertex noise, not the model, "
           "dominates both errors and the two curves meet.", "",
           "## 2. Torso twist (paper Fig. 10)", "",
           "The template body twisting (±40°) and bending (25°) at the waist while the left leg "
           "steps (hip 35°, knee 50°), 12 frames, each target the deformable model's surface with "
           "5 mm noise, each fit starting from the previous frame's result. Mean joint position "
           "error per joint (mm):", "", "![torso twist](paper_torso_twist.png)", "",
           "| joint | deformable | rigid |", "|---|---|---|"]
    for i, n in enumerate(names):
        md.append(f"| {n} | {twist['deformable'][i]:.1f} | {twist['rigid'][i]:.1f} |")
    legs = [names.index(n) for n in ("l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle")]
    md += ["", f"Legs (hips, knees, ankles): deformable {np.mean(twist['deformable'][legs]):.1f} mm, "
           f"rigid {np.mean(twist['rigid'][legs]):.1f} mm; all joints: deformable "
           f"{np.mean(twist['deformable']):.1f} mm, rigid {np.mean(twist['rigid']):.1f} mm.", "",
           "## 3. Hierarchical vs simultaneous fitting (paper Fig. 11)", "",
           f"Random poses of the template; every joint started {', '.join(str(m) for m in cases)}° off "
           f"(random sign), the root a quarter of that in yaw and as many mm in position; exact "
           f"targets; success = mean joint position error under {SUCCESS_MM:.0f} mm; {args.trials} "
           "trials per offset.", "", "![hierarchy](paper_hierarchy.png)", "",
           "The first 20° trial fitted each way (shaded) over its target (red points), with its mean "
           "joint error:", "", "![hierarchy fits](paper_hierarchy_fit.png)", "",
           "| offset (°) | hierarchical: success | iterations | ms | + polish: success | iterations | ms "
           "| simultaneous: success | iterations | ms |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for a, b, c in zip(hier, hier_polish, simul):
        md.append(f"| {a[0]:.0f} | {100 * a[1]:.0f} % | {a[2]:.0f} | {1000 * a[3]:.0f} | {100 * b[1]:.0f} % | "
                  f"{b[2]:.0f} | {1000 * b[3]:.0f} | {100 * c[1]:.0f} % | {c[2]:.0f} | {1000 * c[3]:.0f} |")
    gap = float(np.mean(hier[:, 1] - simul[:, 1]) * 100)
    md += ["", f"Success-rate gap, hierarchical minus simultaneous, averaged over the offsets: "
           f"**{gap:+.0f} points**.", "", "## 4. Beyond the paper: solver and residual", "",
           "The same trials at 5, 10 and 20°, hierarchical with the joint polish.", "",
           "![solvers](paper_solvers.png)", "", "![solver fits, first 10° trial](paper_solvers_fit.png)", "",
           "| variant | offset (°) | success | iterations | ms | median joint error (mm) |",
           "|---|---|---|---|---|---|"]
    for name, rows in solvers.items():
        for r in rows:
            md.append(f"| {name} | {r[0]:.0f} | {100 * r[1]:.0f} % | {r[2]:.0f} | {1000 * r[3]:.0f} | {r[4]:.2f} |")
    (DOCS / "paper.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
