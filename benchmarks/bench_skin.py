"""Skin weights and posing of the template body: time per stage, our Dijkstra against
SciPy's on the same graph, and posing throughput.

The template (``data/body/template.npz``) and a 4× denser mesh of the same surface
(``make_template`` at half the voxel size). SciPy's ``csgraph.dijkstra`` gets the same
graph (mesh edges both ways, plus one node per link with one-way arcs to the vertices it
sees, as our engine found them) and runs once per link, single-threaded; ours runs the
links on all cores. Distances are checked equal.

    .venv/bin/python benchmarks/bench_skin.py
"""

from __future__ import annotations

import os
import time

import numpy as np
from hullcap import BodyModel, _engine
from hullcap._links import LinkModel
from hullcap.data.body import make_template  # type: ignore[attr-defined]


def scipy_dijkstra_seconds(v, f, direct):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    nv, nl = direct.shape
    e = np.unique(np.sort(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    length = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    vi, lj = np.nonzero(np.isfinite(direct))
    # Link -> vertex arcs one way only: no path may pass through another link.
    rows = np.concatenate([e[:, 0], e[:, 1], nv + lj])
    cols = np.concatenate([e[:, 1], e[:, 0], vi])
    data = np.concatenate([length, length, direct[vi, lj]])
    graph = coo_matrix((data, (rows, cols)), shape=(nv + nl, nv + nl)).tocsr()
    t0 = time.perf_counter()
    out = np.array([dijkstra(graph, directed=True, indices=nv + j)[:nv] for j in range(nl)])
    return time.perf_counter() - t0, out


def best_of(fn, repeats=5):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    links = LinkModel.standard()
    segments, groups = links.all_segments()
    print(f"# skin weights and posing of the template, {os.cpu_count()} cores, "
          f"{len(segments)} link segments ({len(links.names)} bones)\n")
    print("| mesh | vertices | visibility (s) | graph (s) | Dijkstra (s) | SciPy Dijkstra (s) | ours vs SciPy "
          "| total skin_weights (s) |")
    print("|---|---|---|---|---|---|---|---|")
    meshes = {"template": None, "4× denser": make_template.VOXEL / 2}
    models = {}
    for label, voxel in meshes.items():
        if voxel is None:
            model = BodyModel.template()
            v, f = model.vertices, model.faces
        else:
            from hullcap._implicit import field_mesh

            v, f = field_mesh(make_template.body_field, (-0.95, -0.2, -0.99), (0.95, 0.15, 0.80), voxel)
            model = BodyModel(links, v, f)
        models[label] = model
        x, direct, t_vis, t_graph, t_dij = _engine.link_distances(v, f, segments)
        t_scipy, x_scipy = scipy_dijkstra_seconds(v, f, direct)
        np.testing.assert_allclose(x, x_scipy, rtol=1e-9)
        total = best_of(lambda: _engine.skin_weights(v, f, segments, groups=groups), 3)
        print(f"| {label} | {len(v):,} | {t_vis:.3f} | {t_graph:.4f} | {t_dij:.4f} | {t_scipy:.4f} | "
              f"{t_scipy / t_dij:.1f}× faster | {total:.3f} |")
    print("\n| mesh | vertices | pose, 1 thread (ms) | pose, all threads (ms) | vertices/s (all threads) |")
    print("|---|---|---|---|---|")
    theta = np.random.default_rng(0).uniform(-0.3, 0.3, 29)
    for label, model in models.items():
        one = best_of(lambda: model.pose(theta, threads=1), 50)
        many = best_of(lambda: model.pose(theta), 50)
        print(f"| {label} | {len(model.vertices):,} | {1000 * one:.3f} | {1000 * many:.3f} | "
              f"{len(model.vertices) / many / 1e6:.1f} M |")


if __name__ == "__main__":
    main()
