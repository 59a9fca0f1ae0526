"""Time per ICP iteration: our articulated fit (35 DOF) against Open3D's rigid one.

10 000 model points of the body (a 4× denser template) fitted to 50 000 target points
(the body posed elsewhere, as a denser mesh). Ours: all 35 parameters at once
(``hierarchical=False``), Levenberg–Marquardt, point-to-plane, Lorentzian IRLS; Open3D:
``registration_icp`` point-to-plane with a Tukey robust kernel, 6 parameters. Both do
the same per iteration: correspondences for every model point, weights, a linear solve.

Open3D is a benchmark-only dependency (``pip install open3d``; on Debian its wheel needs
the ``libusb-1.0-0`` package to import).

    .venv/bin/python benchmarks/bench_icp.py
"""

from __future__ import annotations

import time

import numpy as np
from hullcap import BodyModel, FitOptions, PoseParameters, fit
from hullcap._fitting import make_target
from hullcap._implicit import field_mesh
from hullcap._links import LinkModel
from hullcap._mesh import Surface
from hullcap.data.body import make_template  # type: ignore[attr-defined]

BOX = ((-0.95, -0.2, -0.99), (0.95, 0.15, 0.80))


def main():
    links = LinkModel.standard()
    v, f = field_mesh(make_template.body_field, *BOX, make_template.VOXEL / 2)
    model = BodyModel(links, v, f)
    tv, tf = field_mesh(make_template.body_field, *BOX, 0.0068)
    target_model = BodyModel(links, tv, tf)
    rng = np.random.default_rng(0)
    theta = np.clip(rng.normal(0, 0.2, 29), links.dof_limits[:, 0], links.dof_limits[:, 1])
    posed = target_model.pose(theta, np.eye(3), (0.0, 0.0, 0.97))
    pick = rng.choice(len(posed.vertices), 50_000, replace=len(posed.vertices) < 50_000)
    target = Surface(posed.vertices[pick], np.zeros((0, 3), np.int64), posed.normals[pick])
    points = rng.choice(len(model.vertices), 10_000, replace=False)
    start = PoseParameters(theta + rng.normal(0, 0.03, 29), np.eye(3), np.array([0.01, -0.01, 0.98]))
    prepared = make_target(target)
    iterations = 15
    t0 = time.perf_counter()
    options = FitOptions(hierarchical=False, residual="point_to_plane", iterations=iterations, tolerance=0.0)
    result = fit(model, prepared, start, options, model_points=points)
    ours = (time.perf_counter() - t0) / result.iterations
    print("# ICP iteration, 10 000 model points, 50 000 target points, 2 cores\n")
    print(f"hullcap articulated (35 DOF, LM, point-to-plane, Lorentzian): {1000 * ours:.2f} ms per iteration "
          f"({result.iterations} iterations, mean residual {1000 * result.mean_residual:.2f} mm)")
    try:
        import open3d as o3d
    except ImportError as e:
        print(f"Open3D not available ({e}); pip install open3d to compare")
        return
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(
        model.pose(start.theta, start.root_rotation, start.root_translation).vertices[points]))
    dst = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target.vertices))
    dst.normals = o3d.utility.Vector3dVector(target.normals)
    loss = o3d.pipelines.registration.TukeyLoss(k=0.02)
    est = o3d.pipelines.registration.TransformationEstimationPointToPlane(loss)
    crit = o3d.pipelines.registration.ICPConvergenceCriteria(relative_fitness=0.0, relative_rmse=0.0,
                                                             max_iteration=iterations)
    t0 = time.perf_counter()
    reg = o3d.pipelines.registration.registration_icp(src, dst, 0.15, np.eye(4), est, crit)
    theirs = (time.perf_counter() - t0) / iterations
    print(f"Open3D registration_icp (rigid, 6 DOF, point-to-plane, Tukey):   {1000 * theirs:.2f} ms per iteration "
          f"(fitness {reg.fitness:.3f})")
    print(f"ours / Open3D per iteration: {ours / theirs:.2f}× (target ≤ 2×)")


if __name__ == "__main__":
    main()
