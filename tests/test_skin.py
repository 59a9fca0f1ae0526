"""Geodesic skin weights and the rig, through Python: the properties issue 3 asks for."""

import hullcap
import numpy as np
import pytest
from hullcap import _engine
from hullcap._implicit import capsule_union_mesh as capsule_body


def closest_distances(vertices, links):
    out = []
    for a, b in links:
        t = np.clip(((vertices - a) @ (b - a)) / ((b - a) @ (b - a)), 0, 1)
        out.append(np.linalg.norm(vertices - (a + t[:, None] * (b - a)), axis=1))
    return np.array(out).T  # (V, L)


def euclidean_weights(vertices, links, b=40.0):
    w = np.exp(-b * closest_distances(vertices, links))
    return w / w.sum(1, keepdims=True)


def dense(idx, w, n_links):
    out = np.zeros((len(idx), n_links))
    np.put_along_axis(out, idx, w, axis=1)
    return out


# Two legs 1 cm apart joined by a pelvis; links along the legs and across the pelvis.
LEGS = [((0.075, 0, 0.1), (0.075, 0, 0.85), 0.07), ((-0.075, 0, 0.1), (-0.075, 0, 0.85), 0.07),
        ((-0.075, 0, 0.92), (0.075, 0, 0.92), 0.09)]
LEG_LINKS = np.array([[[0.075, 0, 0.1], [0.075, 0, 0.85]], [[-0.075, 0, 0.1], [-0.075, 0, 0.85]],
                      [[-0.075, 0, 0.92], [0.075, 0, 0.92]]])


@pytest.fixture(scope="module")
def legs():
    return capsule_body(LEGS)


def test_weights_are_nonnegative_normalised_and_k_sparse(legs):
    v, f = legs
    for k in (1, 2, 3, 4):
        idx, w = hullcap.skin_weights(v, f, LEG_LINKS, k=k)
        kk = min(k, 3)
        assert idx.shape == w.shape == (len(v), kk)
        assert (w >= 0).all() and np.allclose(w.sum(1), 1.0, atol=1e-12)
        assert ((idx >= 0) & (idx < 3)).all()
        assert (np.diff(w, axis=1) <= 0).all(), "largest first"
    # k = 1 is the rigid segment model: each vertex wholly on its nearest link.
    _, w1 = hullcap.skin_weights(v, f, LEG_LINKS, k=1)
    assert (w1 == 1.0).all()


def test_inner_thigh_ignores_the_other_leg_where_euclidean_weights_do_not(legs):
    v, f = legs
    idx, w = hullcap.skin_weights(v, f, LEG_LINKS, k=3)
    geodesic = dense(idx, w, 3)
    euclid = euclidean_weights(v, LEG_LINKS)
    inner_left = (v[:, 0] > 0.0) & (v[:, 0] < 0.02) & (v[:, 2] > 0.25) & (v[:, 2] < 0.65)
    assert inner_left.sum() > 20
    assert geodesic[inner_left, 1].max() < 0.01  # the right leg's link
    assert euclid[inner_left, 1].mean() > 0.25


def test_torso_beside_a_hanging_arm_keeps_off_the_arm_link():
    """The paper's shoulder case: with the arm down, the torso's side is 5 cm from the arm's
    link but 15 cm from its own; straight-line weights hand it to the arm."""
    torso = ((0, 0, 0.9), (0, 0, 1.45), 0.15)
    arm = ((0.20, 0, 1.42), (0.20, 0, 0.85), 0.04)  # arm down, 1 cm from the torso
    shoulder = ((0.0, 0, 1.45), (0.20, 0, 1.45), 0.05)
    v, f = capsule_body([torso, arm, shoulder])
    links = np.array([[torso[0], torso[1]], [arm[0], arm[1]]], float)
    idx, w = hullcap.skin_weights(v, f, links, k=2)
    geodesic = dense(idx, w, 2)
    euclid = euclidean_weights(v, links)
    torso_side = (v[:, 0] > 0.14) & (v[:, 0] < 0.151) & (v[:, 2] < 1.1) & (v[:, 2] > 0.9)
    assert torso_side.sum() > 5
    assert geodesic[torso_side, 1].max() < 0.01
    assert euclid[torso_side, 1].mean() > 0.9


def test_link_distances_are_shortest_paths(legs):
    v, f = legs
    x, direct, t_vis, t_graph, t_dij = _engine.link_distances(v, f, LEG_LINKS)
    assert x.shape == (3, len(v)) and direct.shape == (len(v), 3)
    assert t_vis > 0 and t_dij > 0
    # Never longer than a visible straight arc, never shorter than the straight line.
    straight = closest_distances(v, LEG_LINKS).T
    assert (x <= direct.T + 1e-12).all()
    assert (x >= straight - 1e-12).all()
    # Each edge obeys the triangle inequality of a shortest path.
    e = np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    length = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    assert (x[:, e[:, 1]] <= x[:, e[:, 0]] + length + 1e-12).all()


def chain_rig(k=2):
    """Two joints along +x, a ring of vertices around each part, weights blended."""
    xs = np.linspace(0.0, 3.0, 31)
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    v = np.array([[x, 0.2 * np.cos(a), 0.2 * np.sin(a)] for x in xs for a in ang])
    n = v * [0, 1, 1]
    link = np.clip(v[:, 0].astype(int), 0, 2)
    other = np.where(link == 2, 1, link + 1)
    frac = v[:, 0] % 1.0
    wl = np.c_[link, other][:, :k]
    w = np.c_[0.6 + 0.3 * frac, 0.4 - 0.3 * frac][:, :k]
    w = w / w.sum(1, keepdims=True)
    return _engine.Rig([-1, 0, 1], [[0, 0, 0], [1, 0, 0], [2, 0, 0]], [1, 1, 2],
                       [[0, 0, 1], [0, 1, 0], [0, 0, 1]], [[-2, 2]] * 3, v, n, wl, w), v


def rotation(rx, ry, rz):
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    return (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))


def test_zero_pose_is_the_rest_mesh_exactly_and_root_motion_is_rigid():
    rig, rest = chain_rig()
    v, n, joints, rot = rig.pose([0.0, 0.0, 0.0])
    assert np.array_equal(v, rest)
    np.testing.assert_array_equal(joints, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    theta = [0.5, -0.4, 0.9]
    body, _, _, _ = rig.pose(theta)
    R, t = rotation(0.3, -0.7, 1.2), np.array([1.0, 2.0, -0.5])
    world, _, _, _ = rig.pose(theta, R, t)
    np.testing.assert_allclose(world, body @ R.T + t, atol=1e-12)


def test_jacobian_matches_finite_differences():
    rig, _ = chain_rig()
    theta = np.array([0.5, -0.4, 0.9])
    R, t = rotation(0.3, -0.7, 1.2), np.array([1.0, 2.0, -0.5])
    jac = rig.jacobian(theta, R, t)
    assert jac.shape == (31 * 8, 9, 3)
    h = 1e-6
    for p in range(9):
        tp, tm, Rp, Rm, sp, sm = theta.copy(), theta.copy(), R, R, t.copy(), t.copy()
        if p < 3:
            sp[p] += h
            sm[p] -= h
        elif p < 6:
            axis = np.eye(3)[p - 3]
            Rp, Rm = rotation(*(axis * h)) @ R, rotation(*(-axis * h)) @ R
        else:
            tp[p - 6] += h
            tm[p - 6] -= h
        fd = (rig.pose(tp, Rp, sp)[0] - rig.pose(tm, Rm, sm)[0]) / (2 * h)
        np.testing.assert_allclose(jac[:, p, :], fd, atol=1e-7, err_msg=f"parameter {p}")


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda v, f: hullcap.skin_weights(v, f, LEG_LINKS, k=0), r"k must be at least 1"),
        (lambda v, f: hullcap.skin_weights(v, f, LEG_LINKS, b=0.0), r"b must be positive"),
        (lambda v, f: hullcap.skin_weights(v, f + len(v), LEG_LINKS), r"faces\[0\] holds \d+, outside 0\.\.\d+"),
        (lambda v, f: hullcap.skin_weights(v, f[:, :2], LEG_LINKS), r"faces must have shape \(N, 3\)"),
        (lambda v, f: hullcap.skin_weights(v, f, LEG_LINKS[:, 0]), r"links must have shape \(N, 2, 3\)"),
        (lambda v, f: hullcap.skin_weights(v, f.astype(float), LEG_LINKS), r"faces must hold integers"),
        (lambda v, f: hullcap.skin_weights(np.where(np.arange(len(v))[:, None] == 5, np.nan, v), f, LEG_LINKS),
         r"vertices\[5\] is not finite"),
        (lambda v, f: hullcap.skin_weights(v, f, LEG_LINKS, groups=[0, 1]), r"groups has 2 entries, expected 3"),
    ],
)
def test_bad_skin_weight_input(legs, call, message):
    v, f = legs
    with pytest.raises(ValueError, match=message):
        call(v, f)


def test_bad_rig_input():
    rig, _ = chain_rig()
    with pytest.raises(ValueError, match="theta has 2 entries, expected 3"):
        rig.pose([0.0, 0.0])
    with pytest.raises(ValueError, match="not a rotation"):
        rig.pose([0.0] * 3, np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match=r"link 2: parent 2 must come before"):
        _engine.Rig([-1, 0, 2], np.zeros((3, 3)), [], np.zeros((0, 3)), np.zeros((0, 2)),
                    np.zeros((1, 3)), np.ones((1, 3)), [[0]], [[1.0]])
    with pytest.raises(ValueError, match=r"limits \[1, 0\]"):
        _engine.Rig([-1, 0], np.zeros((2, 3)), [1], [[1.0, 0, 0]], [[1.0, 0.0]],
                    np.zeros((1, 3)), np.ones((1, 3)), [[0]], [[1.0]])
