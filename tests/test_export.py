"""Exports read back by independent readers."""

import numpy as np
import pytest

from hullcap import BodyModel
from hullcap.export import write_bvh

bvh = pytest.importorskip("bvh", reason="the independent BVH reader (pip install bvh)")


def rot(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def forward_kinematics(mocap, frame):
    """Joint positions from what the reader parsed: offsets, channels and the hierarchy."""
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
    return {n: t for n, (_, t) in world.items()}


def test_bvh_read_by_an_independent_parser_reproduces_the_joints(tmp_path):
    model = BodyModel.template().scaled({"l_thigh": 1.1, "r_thigh": 1.1}, {"torso": 0.9})
    rng = np.random.default_rng(5)
    lim = model.link_model.dof_limits
    frames = 6
    theta = np.clip(rng.normal(0, 0.5, (frames, 29)), lim[:, 0], lim[:, 1])
    angles = rng.uniform(-np.pi, np.pi, frames)
    R = np.array([rot("z", np.degrees(a)) @ rot("x", 10) for a in angles])
    t = rng.normal(0, 0.5, (frames, 3)) + (0, 0, 1)
    write_bvh(tmp_path / "motion.bvh", model, t, R, theta, fps=30)
    mocap = bvh.Bvh((tmp_path / "motion.bvh").read_text())
    assert mocap.nframes == frames and abs(mocap.frame_time - 1 / 30) < 1e-7
    assert set(mocap.get_joints_names()) == set(model.joint_names)
    for f in range(frames):
        ours = model.pose(theta[f], R[f], t[f]).joints
        theirs = forward_kinematics(mocap, f)
        for name, p in zip(model.joint_names, ours):
            assert np.linalg.norm(theirs[name] - p) < 1e-3, (f, name)


def test_export_command_rewrites_the_outputs_from_pose_npz(tmp_path, capsys):
    from hullcap.cli import main

    seq = tmp_path / "seq"
    assert main(["synth", str(seq), "--frames", "3", "--cameras", "6", "--subject", "short"]) == 0
    assert main(["track", str(seq), "--out", str(tmp_path / "out")]) == 0
    original = (tmp_path / "out" / "joints.csv").read_text()
    assert (tmp_path / "out" / "motion.bvh").is_file()
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
        assert fa[:3] == fb[:3]
        assert np.allclose([float(x) for x in fa[3:]], [float(x) for x in fb[3:]], atol=2e-6)
    assert main(["export", str(tmp_path / "out"), "--format", "bvh", "--to", str(tmp_path / "m.bvh")]) == 0
    mocap = bvh.Bvh((tmp_path / "m.bvh").read_text())
    assert mocap.nframes == 3
    assert main(["export", str(tmp_path / "nothing"), "--format", "bvh"]) == 2
    assert "not a body model folder" in capsys.readouterr().err
