"""NormalKDTree against SciPy's cKDTree and pykdtree on the same 6-D keys.

Build time and query throughput (k = 1), single-threaded and on all cores, measured side
by side in one process on a human-sized surface; prints a Markdown table and the ratios
the targets are stated in (docs/performance.md).

    python benchmarks/bench_kdtree.py            # N = 20 000 and 100 000, M = 20 000
    python benchmarks/bench_kdtree.py --quick    # N = 20 000 only, fewer repeats
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import hullcap
from surfaces import human_surface, noisy_queries


def best_of(repeats: int, fn):
    """Smallest wall time of `repeats` calls, and the last result."""
    best, result = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def six_d(points, normals, lam):
    return np.ascontiguousarray(np.hstack([points, lam * normals]))


def run(n: int, m: int, repeats: int, peers: dict) -> list[dict]:
    points, normals = human_surface(n, seed=1)
    qp, qn = noisy_queries(m, seed=2)
    rows = []

    build, tree = best_of(repeats, lambda: hullcap.NormalKDTree(points, normals))
    lam = tree.normal_weight
    keys, qkeys = six_d(points, normals, lam), six_d(qp, qn, lam)
    ours = {}
    for label, threads in (("1 thread", 1), ("all threads", None)):
        t, (idx, dist) = best_of(repeats, lambda: tree.query(qp, qn, threads=threads))
        ours[label] = dist
        rows.append(dict(n=n, impl="hullcap NormalKDTree", threads=label, build=build, query=t, m=m))

    for name, (make, query) in peers.items():
        build, peer = best_of(repeats, lambda: make(keys))
        for label, threads in (("1 thread", 1), ("all threads", -1)):
            t, dist = best_of(repeats, lambda: query(peer, qkeys, threads))
            # Same answers, or the comparison means nothing.
            np.testing.assert_allclose(dist, ours[label], rtol=1e-9, atol=1e-12, err_msg=name)
            rows.append(dict(n=n, impl=name, threads=label, build=build, query=t, m=m))
    return rows


def peers() -> dict:
    found = {}
    try:
        from scipy.spatial import cKDTree

        found["scipy cKDTree"] = (
            lambda k: cKDTree(k),
            lambda t, q, w: t.query(q, k=1, workers=w)[0],
        )
    except ImportError:
        print("(scipy not installed: `make bench` installs it)")
    try:
        from pykdtree.kdtree import KDTree
        from threadpoolctl import threadpool_limits

        def pyk_query(t, q, w):
            with threadpool_limits(limits=1 if w == 1 else None, user_api="openmp"):
                return t.query(q, k=1)[0]

        found["pykdtree"] = (lambda k: KDTree(k), pyk_query)
    except ImportError:
        print("(pykdtree/threadpoolctl not installed: `make bench` installs them)")
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 20 000 only, 3 repeats")
    parser.add_argument("--queries", type=int, default=20_000, help="M, queries per batch")
    args = parser.parse_args()
    sizes = [20_000] if args.quick else [20_000, 100_000]
    repeats = 3 if args.quick else 7
    found = peers()
    print(f"# kd-tree benchmark: 6-D keys (x, y, z, λn), k = 1, M = {args.queries} queries, "
          f"{os.cpu_count()} cores, best of {repeats}\n")
    print("| N | implementation | threads | build (ms) | queries/s |")
    print("|---|---|---|---|---|")
    rows = []
    for n in sizes:
        for r in run(n, args.queries, repeats, found):
            rows.append(r)
            print(f"| {r['n']:,} | {r['impl']} | {r['threads']} | {1e3 * r['build']:.1f} | "
                  f"{r['m'] / r['query'] / 1e6:.2f} M |")
    print()
    for n in sizes:
        ours = {r["threads"]: r for r in rows if r["n"] == n and r["impl"].startswith("hullcap")}
        for name in found:
            theirs = {r["threads"]: r for r in rows if r["n"] == n and r["impl"] == name}
            for label in ("1 thread", "all threads"):
                speed = theirs[label]["query"] / ours[label]["query"]
                print(f"N = {n:>7,}  {label:<11}  queries {speed:5.2f}x {name}")
            build = theirs["1 thread"]["build"] / ours["1 thread"]["build"]
            print(f"N = {n:>7,}  build        {build:5.2f}x faster than {name}")


if __name__ == "__main__":
    main()
