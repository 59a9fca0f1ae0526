"""Skin weights and posing: time per stage, and our Dijkstra against SciPy's on one graph.

Until the template body lands (issue 3 is open), the body is the capsule person of
benchmarks/surfaces.py turned into a closed mesh by marching cubes, at two resolutions.
SciPy's `csgraph.dijkstra` gets the same graph (mesh edges plus one node per link joined
to the vertices it sees, as our engine found them) and runs once per link.

    python benchmarks/bench_skin.py
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from hullcap import _engine  # noqa: E402
from hullcap._implicit import capsule_union_mesh  # noqa: E402
from surfaces import CAPSULES  # noqa: E402


def scipy_dijkstra_seconds(v, f, direct):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    nv, nl = direct.shape
    e = np.unique(np.sort(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    length = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    vi, lj = np.nonzero(np.isfinite(direct))
    # Mesh edges both ways; link -> vertex arcs one way, so no path passes through another
    # link (the definition of x_ij: only link j's own arcs count).
    rows = np.concatenate([e[:, 0], e[:, 1], nv + lj])
    cols = np.concatenate([e[:, 1], e[:, 0], vi])
    data = np.concatenate([length, length, direct[vi, lj]])
    graph = coo_matrix((data, (rows, cols)), shape=(nv + nl, nv + nl)).tocsr()
    t0 = time.perf_counter()
    out = np.array([dijkstra(graph, directed=True, indices=nv + j)[:nv] for j in range(nl)])
    return time.perf_counter() - t0, out


def main() -> None:
    links = np.array([[a, b] for a, b, _ in CAPSULES], float)
    print(f"# skin weights and posing, {os.cpu_count()} cores\n")
    print("| vertices | links | visibility (s) | Dijkstra (s) | SciPy Dijkstra (s) | Dijkstra vs SciPy | total skin_weights (s) |")
    print("|---|---|---|---|---|---|---|")
    for voxel in (0.016, 0.008, 0.004):
        v, f = capsule_union_mesh(CAPSULES, voxel, pad=0.2)
        x, direct, t_vis, t_dij = _engine.link_distances(v, f, links)
        t_scipy, x_scipy = scipy_dijkstra_seconds(v, f, direct)
        np.testing.assert_allclose(x, x_scipy, rtol=1e-9)  # same graph, same answer
        t0 = time.perf_counter()
        _engine.skin_weights(v, f, links)
        total = time.perf_counter() - t0
        print(f"| {len(v):,} | {len(links)} | {t_vis:.3f} | {t_dij:.4f} | {t_scipy:.4f} | "
              f"{t_scipy / t_dij:.1f}× faster | {total:.3f} |")


if __name__ == "__main__":
    main()
