"""The body model: link model file, template body, posing, scaling, files."""

import copy
import json

import hullcap
import numpy as np
import pytest
from hullcap import BodyModel, LinkModel
from hullcap._fitting import PoseParameters, yaw_rotation
from hullcap._links import STANDARD_LINKS
from hullcap._mesh import check_closed, is_closed


@pytest.fixture(scope="module")
def model():
    return BodyModel.template()


@pytest.fixture
def spec():
    return json.loads(STANDARD_LINKS.read_text())


def test_standard_link_model_has_the_papers_29_dof_and_canonical_joints():
    links = LinkModel.standard()
    assert links.n_dofs == 29
    per_joint = {}
    for d in links.dof_links:
        per_joint[links.joints[d]] = per_joint.get(links.joints[d], 0) + 1
    assert per_joint == {"waist": 3, "neck": 2, "l_clavicle": 2, "r_clavicle": 2, "l_shoulder": 3,
                         "r_shoulder": 3, "l_elbow": 1, "r_elbow": 1, "l_hip": 3, "r_hip": 3,
                         "l_knee": 1, "r_knee": 1, "l_ankle": 2, "r_ankle": 2}
    assert links.joint_names == (
        "pelvis", "waist", "chest", "neck", "head", "l_clavicle", "l_shoulder", "l_elbow",
        "l_wrist", "r_clavicle", "r_shoulder", "r_elbow", "r_wrist", "l_hip", "l_knee",
        "l_ankle", "l_toe", "r_hip", "r_knee", "r_ankle", "r_toe")
    assert set(links.structure_names) >= {"l_ribs", "skull", "l_iliac", "l_scapula"}
    # Hierarchy: every joint DOF in exactly one group, waist and hips first.
    flat = sorted(d for g in links.hierarchy for d in g)
    assert flat == list(range(29))
    assert {links.joints[links.dof_links[d]] for d in links.hierarchy[0]} == {"waist", "l_hip", "r_hip"}
    assert LinkModel.from_dict(links.to_dict()).hierarchy == links.hierarchy


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda s: s["links"][1].update(parent="spine"), "parent 'spine' is not a link"),
        (lambda s: s["links"][1].update(parent="head"), "link 'torso': parent 2 must come before the link"),
        (lambda s: s["links"][1]["dofs"][0].update(axis=[0, 0, 0]), "link 'torso': DOF 0 has a zero"),
        (lambda s: s["links"][1]["dofs"][0].update(axis=[1, 0]), "axis must be 3"),
        (lambda s: s["links"][1]["dofs"][0].update(limits=[30, -30]),
         "link 'torso': DOF 0 has limits .*lower not above upper"),
        (lambda s: s["links"].append(copy.deepcopy(s["links"][2])), "defined twice"),
        (lambda s: s["structure_links"][0].update(parent="tail"), "'tail' is not a link"),
        (lambda s: s["hierarchy"][3].remove("l_elbow"), "leaves joints out"),
    ],
)
def test_link_model_errors_name_the_entry(spec, edit, message):
    edit(spec)
    with pytest.raises(ValueError, match=message) as e:
        LinkModel.from_dict(spec, source="links.json")
    assert str(e.value).startswith("links.json: ")


def test_link_model_file_errors(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        LinkModel.load(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(ValueError, match="bad.json: not valid JSON"):
        LinkModel.load(tmp_path / "bad.json")


def test_template_is_a_closed_person_sized_mesh(model):
    v, f = model.vertices, model.faces
    assert 5000 <= len(v) <= 10000
    topo = check_closed(v, f)
    assert topo["closed"] and topo["euler"] == 2 and topo["components"] == 1
    assert model.closed and not is_closed(f[1:]) and not is_closed(np.concatenate([f, f[:1]]))
    assert not is_closed(np.concatenate([f[:1, [0, 2, 1]], f[1:]]))  # one triangle turned over
    assert 0.05 < topo["volume"] < 0.09  # m³: 50–90 kg at the density of water
    height = np.ptp(v[:, 2])
    assert 1.70 < height < 1.80
    assert 1.70 < np.ptp(v[:, 0]) < 1.85  # arm span ≈ height
    # Every joint lies inside the body: the surface points at its x and z (within 2 cm)
    # lie in front of it and behind it.
    pose = model.pose(root_translation=(0, 0, model.rest_root_height))
    assert abs(pose.vertices[:, 2].min()) < 1e-9
    for name, j in zip(model.joint_names, model.pose().joints):
        near = v[np.linalg.norm(v[:, [0, 2]] - j[[0, 2]], axis=1) < 0.02]
        assert near[:, 1].min() < j[1] < near[:, 1].max(), name


def test_rest_pose_is_exact_and_joints_follow_the_links(model):
    pose = model.pose()
    assert np.array_equal(pose.vertices, model.vertices)
    assert np.allclose(pose.joints[model.joint_names.index("l_knee")], [0.125, 0, -0.47])
    theta = np.zeros(29)
    theta[model.dof_names.index("l_knee_flexion")] = np.pi / 2
    bent = model.pose(theta)
    knee, ankle = (bent.joints[model.joint_names.index(n)] for n in ("l_knee", "l_ankle"))
    shin = ankle - knee
    assert shin[1] > 0.4 and abs(shin[2]) < 0.05  # the shin now points backwards
    # The head, on another branch of the tree, stays where it was.
    assert np.allclose(bent.joints[model.joint_names.index("head")], pose.joints[4])


def test_pure_root_motion_is_rigid(model):
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    t = np.array([0.3, -1.0, 0.97])
    pose = model.pose(root_rotation=R, root_translation=t)
    assert np.allclose(pose.vertices, model.vertices @ R.T + t, atol=1e-12)
    assert np.allclose(pose.normals, model.normals @ R.T, atol=1e-12)


def test_joints_alone_are_the_posed_joints_to_the_bit(model):
    """`joints` gives what `pose` does without posing the mesh, clamped or not, and refuses
    what `pose` refuses."""
    rng = np.random.default_rng(4)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    for clamp in (True, False):
        theta = rng.uniform(-1.5, 1.5, model.n_dofs)
        t = rng.normal(size=3)
        assert np.array_equal(model.joints(theta, R, t, clamp=clamp), model.pose(theta, R, t, clamp=clamp).joints)
    with pytest.raises(ValueError, match="theta must have 29"):
        model.joints(np.zeros(28))
    with pytest.raises(ValueError, match="root_rotation must have shape"):
        model.joints(root_rotation=np.eye(2))
    with pytest.raises(ValueError, match="rotation"):
        model.joints(root_rotation=2 * np.eye(3))


def test_clamping_respects_joint_limits(model):
    lim = model.link_model.dof_limits
    theta = np.full(29, 10.0)
    assert np.array_equal(model.clamp(theta), lim[:, 1])
    assert np.array_equal(model.clamp(-theta), lim[:, 0])
    assert np.array_equal(model.pose(theta).vertices, model.pose(lim[:, 1]).vertices)
    assert not np.array_equal(model.pose(theta, clamp=False).vertices, model.pose(lim[:, 1]).vertices)
    with pytest.raises(ValueError, match="theta must have 29"):
        model.pose(np.zeros(28))
    with pytest.raises(ValueError, match="NaN"):
        model.pose(np.full(29, np.nan))
    with pytest.raises(ValueError, match="root_rotation must have shape"):
        model.pose(root_rotation=np.eye(2))


@pytest.mark.parametrize("wrists", [False, True])
def test_analytic_derivatives_match_finite_differences_for_every_dof(model, wrists):
    model = model.with_wrists() if wrists else model
    rng = np.random.default_rng(3)
    lim = model.link_model.dof_limits
    theta = rng.uniform(lim[:, 0] * 0.5, lim[:, 1] * 0.5)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    R *= np.linalg.det(R)
    t = rng.normal(size=3)
    jac = model.jacobian(theta, R, t)
    assert jac.shape == (len(model.vertices), 6 + model.n_dofs, 3)
    h = 1e-6
    for p in range(6 + model.n_dofs):
        def posed(sign):
            th, rot, tr = theta.copy(), R, t.copy()
            if p < 3:
                tr[p] += sign * h
            elif p < 6:
                w = np.zeros(3)
                w[p - 3] = sign * h
                K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
                rot = (np.eye(3) + K + K @ K / 2) @ R
            else:
                th[p - 6] += sign * h
            return model.pose(th, rot, tr, clamp=False).vertices
        fd = (posed(1) - posed(-1)) / (2 * h)
        assert np.abs(fd - jac[:, p]).max() < 1e-6, model.all_dof_names[p]


def test_wrists_turn_the_hands_alone_and_keep_every_joint_of_the_papers_model(model, tmp_path):
    wrists = model.with_wrists()
    assert wrists.n_dofs == 33 and wrists.joint_names == model.joint_names
    assert wrists.with_wrists() is wrists
    links = wrists.link_model
    assert {links.joints[links.dof_links[d]] for d in links.hierarchy[-1]} == {"l_elbow", "r_elbow",
                                                                               "l_wrist", "r_wrist"}
    # Any pose of the paper's model, carried over with straight wrists: the same joints.
    rng = np.random.default_rng(5)
    lim = model.link_model.dof_limits
    pose = PoseParameters(rng.uniform(lim[:, 0], lim[:, 1]), yaw_rotation(0.7), np.array([0.1, 0.2, 1.0]))
    carried = pose.carried(model, wrists)
    a = model.pose(pose.theta, pose.root_rotation, pose.root_translation)
    b = wrists.pose(carried.theta, carried.root_rotation, carried.root_translation)
    assert np.allclose(a.joints, b.joints, atol=1e-12)
    assert np.array_equal(wrists.pose().vertices, model.pose().vertices)
    # A wrist turns its hand (the template's palms face down, thumbs forward) and nothing else.
    rest = wrists.pose()
    index, weight = wrists.skin
    for side, sign in (("l", 1), ("r", -1)):
        hand = links.names.index(f"{side}_hand")
        carries = ((index == hand) & (weight > 0)).any(axis=1)
        tip = np.argmax(sign * wrists.vertices[:, 0])
        for dof, moves in (("wrist_flexion", (2, -1)), ("wrist_deviation", (1, -1))):
            theta = np.zeros(wrists.n_dofs)
            theta[wrists.dof_names.index(f"{side}_{dof}")] = 0.5
            posed = wrists.pose(theta)
            moved = np.linalg.norm(posed.vertices - rest.vertices, axis=1) > 0
            assert moved[tip] and not (moved & ~carries).any(), dof
            axis, direction = moves
            assert direction * (posed.vertices[tip, axis] - rest.vertices[tip, axis]) > 0.05, dof
            assert np.allclose(posed.joints, rest.joints), dof
    # Saved and loaded with its hands.
    wrists.save(tmp_path / "subject")
    back = BodyModel.load(tmp_path / "subject")
    assert back.dof_names == wrists.dof_names and back.with_wrists() is back
    theta = rng.uniform(links.dof_limits[:, 0], links.dof_limits[:, 1])
    assert np.allclose(back.pose(theta).vertices, wrists.pose(theta).vertices)


def test_scaling_moves_joints_and_keeps_the_mesh_attached(model):
    tall = model.scaled(lengths={"l_thigh": 1.2, "l_shin": 1.1}, girths={"l_thigh": 0.8})
    j = dict(zip(tall.joint_names, tall.pose().joints))
    j0 = dict(zip(model.joint_names, model.pose().joints))
    assert np.isclose(np.linalg.norm(j["l_knee"] - j["l_hip"]),
                      1.2 * np.linalg.norm(j0["l_knee"] - j0["l_hip"]))
    assert np.isclose(np.linalg.norm(j["l_ankle"] - j["l_knee"]),
                      1.1 * np.linalg.norm(j0["l_ankle"] - j0["l_knee"]))
    assert np.allclose(j["r_ankle"], j0["r_ankle"])
    assert np.ptp(tall.vertices[:, 2]) > np.ptp(model.vertices[:, 2]) + 0.08
    assert check_closed(tall.vertices, tall.faces)["closed"]
    with pytest.raises(ValueError, match="unknown link 'tail'"):
        model.scaled(lengths={"tail": 2})
    with pytest.raises(ValueError, match="length scale of 'torso'"):
        model.scaled(lengths={"torso": 0})


def test_rigid_variant_binds_each_vertex_to_one_link(model):
    rigid = model.rigid()
    index, weight = rigid.skin
    assert index.shape == (len(model.vertices), 1) and np.all(weight == 1)
    # It agrees with the deformable model's strongest bone almost everywhere.
    assert np.mean(index[:, 0] == model.skin[0][:, 0]) > 0.95


def test_save_and_load_round_trip(model, tmp_path):
    small = model.scaled(girths={"torso": 1.1})
    small.save(tmp_path / "subject")
    back = BodyModel.load(tmp_path / "subject")
    assert np.array_equal(back.vertices, small.vertices)
    assert np.array_equal(back.faces, small.faces)
    for a, b in zip(back.skin, small.skin):
        assert np.array_equal(a, b)
    assert back.dof_names == small.dof_names and back.joint_names == small.joint_names
    theta = np.linspace(-0.3, 0.3, 29)
    assert np.allclose(back.pose(theta).vertices, small.pose(theta).vertices)
    with pytest.raises(ValueError, match="not a body model folder"):
        BodyModel.load(tmp_path / "nothing")
    (tmp_path / "subject" / "mesh.npz").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="mesh.npz: not a hullcap body mesh"):
        BodyModel.load(tmp_path / "subject")


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_posed_meshes_round_trip_through_ply_and_obj(model, tmp_path, suffix):
    pose = model.pose(np.full(29, 0.2), root_translation=(0, 0, 1))
    path = tmp_path / f"posed{suffix}"
    hullcap.write_mesh(path, pose.vertices, model.faces, pose.normals)
    v, f, n = hullcap.read_mesh(path)
    assert np.array_equal(f, model.faces)
    assert np.allclose(v, pose.vertices, atol=1e-6)
    assert np.allclose(n, pose.normals, atol=1e-5)
    with pytest.raises(ValueError, match="unknown mesh format"):
        hullcap.write_mesh(tmp_path / "x.stl", pose.vertices, model.faces)
    (tmp_path / f"broken{suffix}").write_bytes(b"ply\nformat ascii 1.0\n")
    with pytest.raises(ValueError, match="broken"):
        hullcap.read_mesh(tmp_path / f"broken{suffix}")


def test_ascii_ply_with_quads_is_read():
    import tempfile
    from pathlib import Path

    text = """ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
4 0 1 2 3
"""
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "quad.ply"
        p.write_text(text)
        v, f, n = hullcap.read_mesh(p)
    assert v.shape == (4, 3) and f.tolist() == [[0, 1, 2], [0, 2, 3]] and n is None


def test_new_joint_limits_keep_the_mesh_and_the_skin(model):
    limits = model.link_model.dof_limits.copy()
    limits[0] = (-0.1, 0.1)
    limited = model.with_dof_limits(limits)
    assert np.array_equal(limited.link_model.dof_limits, limits)
    assert np.array_equal(limited.vertices, model.vertices) and all(
        np.array_equal(a, b) for a, b in zip(limited.skin, model.skin))
    with pytest.raises(ValueError, match="limits"):
        model.with_dof_limits(limits[1:])
