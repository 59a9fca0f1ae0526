"""hullcap.NormalKDTree against a brute-force scan, its gates, and its input checks."""

import math
import sys
import threading

import hullcap
import numpy as np
import pytest
from conftest import random_cloud


def keys(points, normals, lam):
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return np.hstack([np.asarray(points, float), lam * n])


def brute(points, normals, qp, qn, lam, max_distance=math.inf, max_angle=math.pi):
    """Nearest 6-D key per query by scanning all of them, then the gates."""
    k, q = keys(points, normals, lam), keys(qp, qn, lam)
    d2 = ((q[:, None, :] - k[None, :, :]) ** 2).sum(axis=2)
    idx = d2.argmin(axis=1)
    dist = np.sqrt(d2[np.arange(len(q)), idx])
    space = np.linalg.norm(q[:, :3] - k[idx, :3], axis=1)
    cos = (q[:, 3:] * k[idx, 3:]).sum(axis=1) / lam**2
    ok = space <= max_distance
    if max_angle < math.pi:
        ok &= cos >= math.cos(max_angle)
    return np.where(ok, idx, -1), np.where(ok, dist, np.inf), d2


def check_against_brute(points, normals, qp, qn, **gate):
    tree = hullcap.NormalKDTree(points, normals)
    idx, dist = tree.query(qp, qn, **gate)
    want_idx, want_dist, d2 = brute(points, normals, qp, qn, tree.normal_weight, **gate)
    np.testing.assert_allclose(dist, want_dist, rtol=1e-12, atol=1e-12)
    assert ((idx < 0) == (want_idx < 0)).all()
    # Where the indices differ it must be a tie: the same distance to both keys.
    for i in np.flatnonzero(idx != want_idx):
        assert math.isclose(d2[i, idx[i]], d2[i, want_idx[i]], rel_tol=1e-12, abs_tol=1e-15)


@pytest.mark.parametrize("n", [1, 2, 50, 3000])
def test_matches_brute_force_on_random_clouds(rng, n):
    points, normals = random_cloud(rng, n)
    qp, qn = random_cloud(rng, 800)
    check_against_brute(points, normals, qp, qn)
    check_against_brute(points, normals, qp, qn, max_distance=0.2, max_angle=1.0)


def adversarial(rng):
    plane = np.c_[rng.uniform(-1, 1, (400, 2)), np.zeros(400)]
    yield "duplicates", np.tile([0.5, 0.5, 0.5], (300, 1)), np.tile([0.0, 0.0, 1.0], (300, 1))
    yield "plane", plane, rng.normal(size=(400, 3))
    yield "plane, equal normals", plane, np.tile([0.0, 0.0, 3.0], (400, 1))
    yield "one point", np.array([[0.1, 0.2, 0.3]]), np.array([[1.0, 0.0, 0.0]])
    grid = np.stack(np.meshgrid(*[np.linspace(-1, 1, 6)] * 3), -1).reshape(-1, 3)
    yield "grid", grid, np.eye(3)[np.arange(len(grid)) % 3]


def test_matches_brute_force_on_adversarial_clouds(rng):
    qp, qn = random_cloud(rng, 300)
    for name, points, normals in adversarial(rng):
        check_against_brute(points, normals, qp, qn)
        check_against_brute(points, normals, qp, qn, max_distance=0.4, max_angle=0.8)


def test_query_k_matches_sorted_brute_force(rng):
    points, normals = random_cloud(rng, 1000)
    qp, qn = random_cloud(rng, 200)
    tree = hullcap.NormalKDTree(points, normals, leaf_size=5)
    idx, dist = tree.query_k(qp, qn, 6)
    assert idx.shape == dist.shape == (200, 6)
    _, _, d2 = brute(points, normals, qp, qn, tree.normal_weight)
    np.testing.assert_allclose(dist, np.sqrt(np.sort(d2, axis=1)[:, :6]), rtol=1e-12)
    np.testing.assert_allclose(dist, np.sqrt(d2[np.arange(200)[:, None], idx]), rtol=1e-12)
    # More neighbours than points: the rest are -1 / inf.
    small = hullcap.NormalKDTree(points[:3], normals[:3])
    idx, dist = small.query_k(qp, qn, 5)
    assert (idx[:, 3:] == -1).all() and np.isinf(dist[:, 3:]).all()
    assert (np.sort(idx[:, :3], axis=1) == [0, 1, 2]).all()


def test_gates():
    tree = hullcap.NormalKDTree([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], normal_weight=0.1)
    up = [[0.0, 0.0, 1.0]] * 2
    idx, dist = tree.query([[0.4, 0, 0], [0.6, 0, 0]], up, max_distance=0.5)
    assert list(idx) == [0, -1]
    assert dist[0] == pytest.approx(0.4) and math.isinf(dist[1])
    tilted = [[math.sin(a), 0.0, math.cos(a)] for a in (0.4, 0.6)]
    idx, _ = tree.query([[0, 0, 0]] * 2, tilted, max_angle=0.5)
    assert list(idx) == [0, -1]


def test_normal_aware_pairing_beats_plain_nearest_neighbour():
    """The paper's Fig. 4/5: an arm vertex beside the torso pairs with the arm's surface."""
    torso = np.array([[0.0, 0.0, z] for z in np.linspace(0, 1, 11)])
    torso_n = np.tile([1.0, 0.0, 0.0], (11, 1))  # torso side faces +x, towards the arm
    arm = torso + [0.05, 0.0, 0.0]
    arm_n = np.tile([0.0, 1.0, 0.0], (11, 1))  # arm's front faces +y
    tree = hullcap.NormalKDTree(np.vstack([torso, arm]), np.vstack([torso_n, arm_n]))
    query = torso[:5] + [0.01, 0.0, 0.0]  # an arm vertex drawn close to the torso
    idx, _ = tree.query(query, np.tile([0.0, 1.0, 0.0], (5, 1)))
    assert (idx >= 11).all()


def test_default_normal_weight_is_diagonal_over_pi():
    points = np.array([[0.0, 0, 0], [3.0, 4.0, 0]])
    tree = hullcap.NormalKDTree(points, [[1.0, 0, 0]] * 2)
    assert tree.normal_weight == pytest.approx(5.0 / math.pi)
    assert len(tree) == 2
    assert "n=2" in repr(tree)


def test_accepts_lists_float32_and_non_contiguous(rng):
    points, normals = random_cloud(rng, 500)
    qp, qn = random_cloud(rng, 100)
    ref = hullcap.NormalKDTree(points, normals).query(qp, qn)
    wide = np.zeros((500, 6))
    wide[:, ::2] = points  # a strided, non-contiguous view
    alt = hullcap.NormalKDTree(wide[:, ::2], normals.tolist())
    np.testing.assert_array_equal(alt.query(qp.tolist(), qn)[0], ref[0])
    f32 = hullcap.NormalKDTree(points.astype(np.float32), normals.astype(np.float32))
    idx, _ = f32.query(qp.astype(np.float32), qn)
    assert (idx == ref[0]).mean() > 0.99


def test_thread_counts_agree(rng):
    points, normals = random_cloud(rng, 5000)
    qp, qn = random_cloud(rng, 4000)
    tree = hullcap.NormalKDTree(points, normals)
    one = tree.query(qp, qn, threads=1)
    for threads in (2, 3, 7, None):
        many = tree.query(qp, qn, threads=threads)
        np.testing.assert_array_equal(one[0], many[0])
        np.testing.assert_array_equal(one[1], many[1])


def test_queries_from_python_threads_share_one_tree(rng):
    """Several Python threads can query one tree at once and get the same answers."""
    points, normals = random_cloud(rng, 2000)
    qp, qn = random_cloud(rng, 2000)
    tree = hullcap.NormalKDTree(points, normals)
    want = tree.query(qp, qn)[0]
    results = [None] * 4

    def work(i):
        results[i] = tree.query(qp, qn, threads=1)[0]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r, want)


def test_a_query_releases_the_gil(rng):
    """Another Python thread runs while a query does. With a long switch interval the
    main thread keeps the GIL unless it lets go, so the counter advances during the query
    only if the engine releases it."""
    points, normals = random_cloud(rng, 5000)
    qp, qn = random_cloud(rng, 100_000)
    tree = hullcap.NormalKDTree(points, normals)
    ticks, stop = [0], threading.Event()

    def count():
        while not stop.is_set():
            ticks[0] += 1

    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.5)
    counter = threading.Thread(target=count)
    try:
        counter.start()
        before = ticks[0]
        tree.query(qp, qn, threads=1)
        during = ticks[0] - before
    finally:
        stop.set()
        counter.join()
        sys.setswitchinterval(interval)
    assert during > 0


BAD_BUILDS = [
    (dict(points=np.zeros((5, 2)), normals=np.ones((5, 3))), r"points must have shape \(N, 3\)"),
    (dict(points=np.zeros(3), normals=np.ones((1, 3))), r"points must have shape"),
    (dict(points=np.zeros((5, 3)), normals=np.ones((4, 3))), r"normals has 4 rows but points has 5"),
    (dict(points=np.array([["a", "b", "c"]]), normals=np.ones((1, 3))), r"points must hold real numbers"),
    (dict(points=np.zeros((2, 3), complex), normals=np.ones((2, 3))), r"points must hold real numbers"),
    (dict(points=[[0, 0, math.nan]], normals=[[1, 0, 0]]), r"points\[0\] is not finite"),
    (dict(points=[[0, 0, 0]], normals=[[1, math.inf, 0]]), r"normals\[0\] is not finite"),
    (dict(points=[[0, 0, 0], [1, 1, 1]], normals=[[1, 0, 0], [0, 0, 0]]), r"normals\[1\] has zero length"),
    (dict(points=np.zeros((0, 3)), normals=np.zeros((0, 3))), r"zero points"),
    (dict(points=[[0, 0, 0]], normals=[[1, 0, 0]], normal_weight=0.0), r"normal_weight must be positive"),
    (dict(points=[[0, 0, 0]], normals=[[1, 0, 0]], normal_weight=-2.0), r"normal_weight must be positive"),
    (dict(points=[[0, 0, 0]], normals=[[1, 0, 0]], normal_weight=math.nan), r"normal_weight must be positive"),
    (dict(points=[[0, 0, 0]], normals=[[1, 0, 0]], leaf_size=0), r"leaf_size must be at least 1"),
    (dict(points=[[0, 0], [1, 1, 1]], normals=[[1, 0, 0]] * 2), r"points is not an array"),
]


@pytest.mark.parametrize("kwargs, message", BAD_BUILDS)
def test_bad_builds_raise_value_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        hullcap.NormalKDTree(**kwargs)


def test_bad_queries_raise_value_error(rng):
    tree = hullcap.NormalKDTree(*random_cloud(rng, 20))
    ok = np.zeros((3, 3)), np.ones((3, 3))
    with pytest.raises(ValueError, match=r"points must have shape"):
        tree.query(np.zeros((3, 4)), ok[1])
    with pytest.raises(ValueError, match=r"query points\[1\] is not finite"):
        tree.query([[0, 0, 0], [math.nan, 0, 0], [0, 0, 0]], ok[1])
    with pytest.raises(ValueError, match=r"query normals\[2\] has zero length"):
        tree.query(ok[0], [[1, 0, 0], [1, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match=r"max_distance must be non-negative"):
        tree.query(*ok, max_distance=-1.0)
    with pytest.raises(ValueError, match=r"max_angle must be non-negative"):
        tree.query(*ok, max_angle=math.nan)
    with pytest.raises(ValueError, match=r"threads must be at least 1"):
        tree.query(*ok, threads=0)
    with pytest.raises(ValueError, match=r"k must be at least 1"):
        tree.query_k(*ok, k=0)
    idx, dist = tree.query(np.zeros((0, 3)), np.zeros((0, 3)))
    assert idx.shape == (0,) and idx.dtype == np.int64 and dist.dtype == np.float64
