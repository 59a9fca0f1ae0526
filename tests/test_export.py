"""Exports read back by independent readers."""

import numpy as np
import pytest
from hullcap import BodyModel
from hullcap.errors import ResultsError
from hullcap.export import write_bvh

bvh = pytest.importorskip("bvh", reason="the independent BVH reader (pip install bvh)")


def rot(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def forward_kinematics(mocap, frame, ends=False):
    """Joint positions from what the reader parsed: offsets, channels and the hierarchy;
    with `ends`, the positions of the joints' End Sites instead."""
    world = {}
    for name in mocap.get_joints_names():
        parent = mocap.joint_parent(name)
        channels = mocap.joint_channels(name)
        values = dict(zip(channels, mocap.frame_joint_channels(frame, name, channels)))
        R = np.eye(3)
        for ch in channels:
            if ch.endswith("rotation"):
                R = R @ rot(ch[0].lower(), values[ch])
        if parent is None:
            t = np.array([values["Xposition"], values["Yposition"], values["Zposition"]])
            world[name] = (R, t)
        else:
            Rp, tp = world[parent.name]
            world[name] = (Rp @ R, tp + Rp @ np.array(mocap.joint_offset(name)))
    if ends:
        sites = {name: [c for c in mocap.get_joint(name).children if c.value == ["End", "Site"]]
                 for name in mocap.get_joints_names()}
        return {n: world[n][1] + world[n][0] @ np.array([float(v) for v in site[0].children[0].value[1:]])
                for n, site in sites.items() if site}
    return {n: t for n, (_, t) in world.items()}


@pytest.mark.parametrize("up, units, wrists", [("y", "m", False), ("y", "cm", False), ("z", "m", False),
                                               ("y", "m", True)])
def test_bvh_read_by_an_independent_parser_reproduces_the_joints(tmp_path, up, units, wrists):
    """Read as Blender reads it by default (y up), the skeleton stands: head above pelvis
    along +y, and every joint is ours under (x, y, z) → (x, z, −y)."""
    from hullcap.export._motion import Z_UP_TO_Y_UP

    model = BodyModel.template().scaled({"l_thigh": 1.1, "r_thigh": 1.1}, {"torso": 0.9})
    model = model.with_wrists() if wrists else model
    rng = np.random.default_rng(5)
    lim = model.link_model.dof_limits
    frames = 6
    theta = np.clip(rng.normal(0, 0.5, (frames, model.n_dofs)), lim[:, 0], lim[:, 1])
    angles = rng.uniform(-np.pi, np.pi, frames)
    R = np.array([rot("z", np.degrees(a)) @ rot("x", 10) for a in angles])
    t = rng.normal(0, 0.5, (frames, 3)) + (0, 0, 1)
    write_bvh(tmp_path / "motion.bvh", model, t, R, theta, fps=30, up=up, units=units)
    mocap = bvh.Bvh((tmp_path / "motion.bvh").read_text())
    assert mocap.nframes == frames and abs(mocap.frame_time - 1 / 30) < 1e-7
    assert set(mocap.get_joints_names()) == set(model.joint_names)
    C = Z_UP_TO_Y_UP if up == "y" else np.eye(3)
    scale = {"m": 1.0, "cm": 100.0}[units]
    for f in range(frames):
        ours = model.pose(theta[f], R[f], t[f]).joints
        theirs = forward_kinematics(mocap, f)
        for name, p in zip(model.joint_names, ours):
            assert np.linalg.norm(theirs[name] - scale * C @ p) < 1e-3 * scale, (f, name)
    if wrists:  # each hand's bone ends at the hand's end, and turns with it
        index = {name: i for i, name in enumerate(model.link_model.names)}
        for f in range(frames):
            posed = model.pose(theta[f], R[f], t[f])
            tips = forward_kinematics(mocap, f, ends=True)
            for side in "lr":
                hand = index[f"{side}_hand"]
                tip = posed.link_positions[hand] + posed.link_rotations[hand] @ (
                    model.link_model.segments[hand, 1] - model.link_model.origins[hand])
                assert np.linalg.norm(tips[f"{side}_wrist"] - scale * C @ tip) < 1e-3 * scale, (f, side)
    rest = forward_kinematics(mocap, 0)
    vertical = 1 if up == "y" else 2
    axis = np.argmax(np.abs(rest["head"] - rest["pelvis"]))
    assert axis == vertical


def test_bvh_rejects_an_unknown_convention(tmp_path):
    from hullcap.errors import OptionsError

    model = BodyModel.template()
    with pytest.raises(OptionsError, match="BVH axes must be .y. or .z., got .x."):
        write_bvh(tmp_path / "m.bvh", model, np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 29)), 30, up="x")
    with pytest.raises(OptionsError, match="units"):
        write_bvh(tmp_path / "m.bvh", model, np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 29)), 30, units="mm")


def test_export_command_rewrites_the_outputs_from_pose_npz(tmp_path, capsys):
    from hullcap._cli import main

    seq = tmp_path / "seq"
    assert main(["synth", str(seq), "--frames", "3", "--cameras", "6", "--subject", "short"]) == 0
    assert main(["track", str(seq), "--out", str(tmp_path / "out")]) == 0
    original = (tmp_path / "out" / "joints.csv").read_text()
    assert (tmp_path / "out" / "motion.bvh").is_file() and (tmp_path / "out" / "model.glb").is_file()
    assert main(["export", str(tmp_path / "out"), "--format", "glb", "--to", str(tmp_path / "m.glb")]) == 0
    assert (tmp_path / "m.glb").read_bytes()[:4] == b"glTF"
    if __import__("importlib").util.find_spec("ezc3d"):
        from hullcap.export import read_c3d

        assert main(["export", str(tmp_path / "out"), "--format", "c3d"]) == 0
        labels, points, rate = read_c3d(tmp_path / "out" / "joints.c3d")
        assert labels[0] == "pelvis" and points.shape == (3, 21, 3) and rate == 30
    # Overlay videos, one per camera, complete; the report picture.
    import cv2

    for cam in range(6):
        video = cv2.VideoCapture(str(tmp_path / "out" / "overlay" / f"cam{cam}.mp4"))
        assert video.isOpened() and int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 3
        ok, frame = video.read()
        assert ok and frame.shape == (480, 640, 3)
    assert not list((tmp_path / "out" / "overlay").glob(".*part*"))
    report = cv2.imread(str(tmp_path / "out" / "report.png"))
    assert report is not None and report.shape[0] > 200
    assert main(["export", str(tmp_path / "out"), "--format", "csv", "--to", str(tmp_path / "again.csv")]) == 0
    again = (tmp_path / "again.csv").read_text().splitlines()
    for a, b in zip(original.splitlines()[1:], again[1:]):
        fa, fb = a.split(","), b.split(",")
        assert fa[:3] == fb[:3] and fa[6:] == fb[6:]
        assert np.allclose([float(x) for x in fa[3:6]], [float(x) for x in fb[3:6]], atol=2e-6)
    assert main(["export", str(tmp_path / "out"), "--format", "bvh", "--to", str(tmp_path / "m.bvh")]) == 0
    mocap = bvh.Bvh((tmp_path / "m.bvh").read_text())
    assert mocap.nframes == 3
    assert main(["export", str(tmp_path / "out"), "--format", "trc"]) == 0
    header = (tmp_path / "out" / "joints.trc").read_text().splitlines()[2].split("\t")
    assert header[2:5] == ["3", "21", "mm"]
    assert main(["export", str(tmp_path / "out"), "--format", "mot"]) == 0
    from hullcap.export import read_mot

    columns, angles = read_mot(tmp_path / "out" / "angles.mot")
    assert columns[:2] == ["time", "root_tx"] and "l_knee_flexion" in columns and angles.shape == (3, len(columns))
    assert main(["export", str(tmp_path / "out"), "--format", "angles", "--smooth", "6"]) == 0
    assert (tmp_path / "out" / "angles.csv").read_text().splitlines()[0] == ",".join(columns)
    assert main(["export", str(tmp_path / "out"), "--format", "glb", "--up", "z"]) == 2
    assert "apply to bvh and trc" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "out"), "--format", "trc", "--units", "cm"]) == 2
    assert "TRC units" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "nothing"), "--format", "bvh"]) == 2
    assert "no pose.npz: not the results folder" in capsys.readouterr().err
    # Each frame keeps the bar its fit was judged by, a quality short of the fit's own.
    from hullcap.export import load_result
    from hullcap.export import write_report

    result = load_result(tmp_path / "out")
    assert np.isfinite(result.bar).all() and (result.bar > 0).all() and (result.bar <= result.quality).all()
    assert result.subject_frame == 0
    # A subject frame outside the run is named; the pose.npz of a run from before the bar
    # and the subject frame were kept loads without them, and its report draws.
    with np.load(tmp_path / "out" / "pose.npz") as z:
        arrays = {k: z[k] for k in z.files}
    np.savez(tmp_path / "out" / "pose.npz", **(arrays | {"subject_frame": 7}))
    with pytest.raises(ResultsError, match=r"subject_frame must be a frame of the run \(0–2\) or -1, got 7"):
        load_result(tmp_path / "out")
    np.savez(tmp_path / "out" / "pose.npz", **{k: v for k, v in arrays.items() if k not in ("bar", "subject_frame")})
    older = load_result(tmp_path / "out")
    assert np.isnan(older.bar).all() and np.array_equal(older.theta, result.theta, equal_nan=True)
    assert older.subject_frame == -1
    write_report(tmp_path / "older.png", older)
    assert cv2.imread(str(tmp_path / "older.png")) is not None


def _accessor(gltf, blob, i):
    """An accessor's data, decoded by the reader's own tables."""
    acc = gltf.accessors[i]
    view = gltf.bufferViews[acc.bufferView]
    dtype = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}[acc.componentType]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    data = np.frombuffer(blob, dtype, acc.count * width, start).reshape(acc.count, width)
    assert view.byteOffset % 4 == 0 and start + data.nbytes <= view.byteOffset + view.byteLength
    return data


def _matrix(translation=None, rotation=None):
    M = np.eye(4)
    if rotation is not None:
        x, y, z, w = rotation
        M[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    if translation is not None:
        M[:3, 3] = translation
    return M


@pytest.mark.parametrize("wrists", [False, True])
def test_glb_read_by_an_independent_reader_skins_to_our_vertices(tmp_path, wrists):
    pygltflib = pytest.importorskip("pygltflib", reason="the independent glTF reader (pip install pygltflib)")
    from hullcap.export._gltf import write_glb
    from hullcap.export._motion import Z_UP_TO_Y_UP

    model = BodyModel.template().scaled({"torso": 1.05}, {"l_thigh": 0.9})
    model = model.with_wrists() if wrists else model
    rng = np.random.default_rng(11)
    lim = model.link_model.dof_limits
    theta = np.clip(rng.normal(0, 0.5, (4, model.n_dofs)), lim[:, 0], lim[:, 1])
    R = np.array([rot("z", a) for a in (0, 40, 120, -70)])
    t = rng.normal(0, 0.3, (4, 3)) + (0, 0, 1)
    write_glb(tmp_path / "model.glb", model, t, R, theta, fps=25)
    gltf = pygltflib.GLTF2().load(str(tmp_path / "model.glb"))
    blob = gltf.binary_blob()
    assert gltf.asset.version == "2.0" and len(blob) >= gltf.buffers[0].byteLength
    prim = gltf.meshes[0].primitives[0]
    pos = _accessor(gltf, blob, prim.attributes.POSITION)
    acc = gltf.accessors[prim.attributes.POSITION]
    assert np.allclose(acc.min, pos.min(0)) and np.allclose(acc.max, pos.max(0))
    joints = _accessor(gltf, blob, prim.attributes.JOINTS_0).astype(int)
    weights = _accessor(gltf, blob, prim.attributes.WEIGHTS_0).astype(float)
    assert np.abs(weights.sum(1) - 1).max() < 1e-6 and (weights >= 0).all()
    faces = _accessor(gltf, blob, prim.indices).reshape(-1, 3)
    assert faces.max() < len(pos)
    skin = gltf.skins[0]
    ibm = _accessor(gltf, blob, skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    assert joints.max() < len(skin.joints) and np.allclose(ibm[:, 3], (0, 0, 0, 1))
    anim = gltf.animations[0]
    times = _accessor(gltf, blob, anim.samplers[0].input)[:, 0]
    assert np.all(np.diff(times) > 0) and np.isclose(times[1], 1 / 25)
    parent = {c: i for i, n in enumerate(gltf.nodes) for c in (n.children or [])}
    for frame in range(4):
        local = {i: [n.translation, n.rotation] for i, n in enumerate(gltf.nodes)}
        for ch in anim.channels:
            value = _accessor(gltf, blob, anim.samplers[ch.sampler].output)[frame]
            local[ch.target.node][0 if ch.target.path == "translation" else 1] = value

        def world(i):
            M = _matrix(*local[i])
            return world(parent[i]) @ M if i in parent else M

        mats = np.array([world(j) @ ibm[k] for k, j in enumerate(skin.joints)])
        v4 = np.c_[pos, np.ones(len(pos))]
        skinned = np.einsum("vk,vkab,vb->va", weights, mats[joints], v4)[:, :3]
        ours = model.pose(theta[frame], R[frame], t[frame]).vertices @ Z_UP_TO_Y_UP.T
        assert np.abs(skinned - ours).max() < 1e-3, frame


def test_c3d_round_trip(tmp_path):
    pytest.importorskip("ezc3d", reason="C3D support (pip install ezc3d)")
    from hullcap.export._c3d import MAX_RESIDUAL_MM, read_c3d, write_c3d

    model = BodyModel.template()
    rng = np.random.default_rng(3)
    joints = rng.normal(0, 0.5, (7, len(model.joint_names), 3)) + (0, 0, 1)
    joints[4] = np.nan  # a failed frame
    write_c3d(tmp_path / "joints.c3d", model.joint_names, joints, fps=50)
    labels, back, rate = read_c3d(tmp_path / "joints.c3d")
    assert labels == list(model.joint_names) and rate == 50
    assert back.shape == joints.shape
    ok = ~np.isnan(joints).any((1, 2))
    assert np.abs(back[ok] - joints[ok]).max() < 1e-6  # float32 millimetres
    assert np.isnan(back[4]).all()
    with pytest.raises(ValueError, match="joints must have shape"):
        write_c3d(tmp_path / "x.c3d", model.joint_names, joints[:, :3], fps=50)
    # Residuals: each joint's key-point distance in whole millimetres, capped at one
    # byte's worth, 0 where not measured, -1 where the point is missing.
    offsets = np.full(joints.shape[:2], 0.0123)
    offsets[1, 2], offsets[2, 5], offsets[3, 0] = np.nan, 0.9, 0.0
    write_c3d(tmp_path / "r.c3d", model.joint_names, joints, fps=50, residuals=offsets)
    *_, residuals = read_c3d(tmp_path / "r.c3d", residuals=True)
    assert residuals.shape == offsets.shape and residuals[0, 0] == 12.0
    assert residuals[1, 2] == 0.0 and residuals[2, 5] == MAX_RESIDUAL_MM and residuals[3, 0] == 0.0
    assert (residuals[4] == -1).all()
    with pytest.raises(ValueError, match="residuals must have shape"):
        write_c3d(tmp_path / "x.c3d", model.joint_names, joints, fps=50, residuals=offsets[:3])


@pytest.mark.parametrize("up, units", [("y", "mm"), ("z", "m")])
def test_trc_read_by_an_independent_reader(tmp_path, up, units):
    """OpenSim's marker file, read back by trc-data-reader: markers named as our joints, the
    frame rate, the units, y up by default, and a failed frame as missing."""
    trc = pytest.importorskip("trc", reason="the independent TRC reader (pip install trc-data-reader)")
    from hullcap.export import write_trc
    from hullcap.export._motion import Z_UP_TO_Y_UP

    names = ["pelvis", "head", "l_wrist"]
    joints = np.random.default_rng(2).normal(0, 1, (5, 3, 3))
    joints[3] = np.nan
    write_trc(tmp_path / "joints.trc", names, joints, 25.0, units=units, up=up)
    data = trc.TRCData()
    data.load(str(tmp_path / "joints.trc"))
    assert data["Markers"] == names and data["NumFrames"] == 5 and data["DataRate"] == 25
    assert data["Units"] == units and data["Frame#"] == [1, 2, 3, 4, 5]
    assert np.allclose(data["Time"], np.arange(5) / 25)
    C = Z_UP_TO_Y_UP if up == "y" else np.eye(3)
    scale = 1000.0 if units == "mm" else 1.0
    for j, name in enumerate(names):
        theirs = np.array(data[name])
        assert np.isnan(theirs[3]).all()
        good = [0, 1, 2, 4]
        assert np.allclose(theirs[good], scale * joints[good, j] @ C.T, atol=1e-5 * scale)


def test_angles_rebuild_the_pose_and_round_trip_through_mot_and_csv(tmp_path):
    """The angle table of a motion that turns round twice, leans and bends, with one failed
    frame: its root angles rebuild each root rotation as Rz(yaw) Ry(roll) Rx(pitch), the
    yaw goes on past 180° instead of jumping, the DOF are theta in degrees; the .mot file
    reads back (by our reader and as OpenSim's header says) and the CSV by NumPy, both
    without the failed frame."""
    from hullcap.export import angle_table, read_mot, write_angles_csv, write_mot
    from hullcap.export._angles import ROOT_COLUMNS

    frames, dofs = 40, ["l_knee_flexion", "neck_twist"]
    rng = np.random.default_rng(3)
    yaw = np.linspace(0, 720, frames)
    roll = 20 * np.sin(np.linspace(0, 3, frames))
    pitch = np.linspace(-10, 85, frames)  # to a bend near the floor
    R = np.stack([rot("z", y) @ rot("y", r) @ rot("x", p) for y, r, p in zip(yaw, roll, pitch)])
    t = rng.normal(0, 1, (frames, 3))
    theta = rng.uniform(-1, 1, (frames, 2))
    theta[17] = np.nan
    names, values = angle_table(dofs, theta, t, R, 25.0)
    assert names == ["time", *ROOT_COLUMNS, *dofs]
    assert np.isnan(values[17, 1:]).all() and values[17, 0] == 17 / 25.0
    good = np.delete(np.arange(frames), 17)
    assert np.allclose(values[good, 1:4], t[good])
    assert np.allclose(values[good, 4], yaw[good]) and np.allclose(values[good, 5], roll[good])
    assert np.allclose(values[good, 6], pitch[good]) and np.allclose(values[good, 7:], np.degrees(theta[good]))
    write_mot(tmp_path / "angles.mot", names, values)
    lines = (tmp_path / "angles.mot").read_text().splitlines()
    assert lines[:6] == ["angles.mot", "version=1", f"nRows={frames - 1}", f"nColumns={len(names)}",
                         "inDegrees=yes", "endheader"]
    got_names, got = read_mot(tmp_path / "angles.mot")
    assert got_names == names and np.allclose(got, values[good], atol=1e-6)
    write_angles_csv(tmp_path / "angles.csv", names, values)
    table = np.genfromtxt(tmp_path / "angles.csv", delimiter=",", names=True)
    assert list(table.dtype.names) == names and np.allclose(table["root_yaw"], yaw[good], atol=1e-6)
    with pytest.raises(ValueError, match="theta"):
        angle_table(dofs, theta[:, :1], t, R, 25.0)
    (tmp_path / "bad.mot").write_text("endheader\ntime\ta\n0.0\t1.0\t2.0\n")
    with pytest.raises(ValueError, match=r"bad.mot, line 3: 3 values for 2 columns"):
        read_mot(tmp_path / "bad.mot")
