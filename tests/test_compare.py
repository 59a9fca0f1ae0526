"""A run's joints against a reference (hullcap._compare, ``hullcap compare``): offsets
removed in the world and in the body's frame, frames matched by time, TRC read back."""

import importlib.util
import json

import cv2
import numpy as np
import pytest
from hullcap import BodyModel
from hullcap._cli import main
from hullcap._compare import compare
from hullcap._results import TrackingResult
from hullcap.export import load_result, write_outputs
from hullcap.errors import ResultsError
from hullcap.export import read_trc, write_trc

TRUNK = ["pelvis", "neck", "l_hip", "r_hip"]


def turning_body(frames=40):
    """The trunk's joints of a body that turns once round its vertical axis."""
    rest = np.array([[0, 0, 1.0], [0, 0, 1.5], [0.1, 0, 0.9], [-0.1, 0, 0.9]])
    turns = np.linspace(0, 2 * np.pi, frames, endpoint=False)
    spin = np.array([[[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]] for a in turns])
    return spin, np.einsum("fij,kj->fki", spin, rest) + [0.5, 0.2, 0]


def test_an_offset_fixed_in_the_body_is_removed_in_the_bodys_frame_however_it_turns():
    # A tracker whose neck sits 3 cm in front of the reference's (a convention): a
    # constant in the body, none in the world.
    spin, truth = turning_body()
    times = np.arange(len(truth)) / 30.0
    back = spin[:, :, 1]  # the body frame's y points to the back: the world's y turned
    ours = truth.copy()
    ours[:, 1] -= 0.03 * back
    got = compare(TRUNK, ours, 30.0, TRUNK, truth, times)
    assert got.frames == len(truth) and got.missing == 0
    np.testing.assert_allclose(got.raw_mm, [0, 30, 0, 0], atol=1e-9)
    np.testing.assert_allclose(got.offset_removed_mm, [0, 30, 0, 0], atol=1e-6)  # its mean in the world is 0
    np.testing.assert_allclose(got.body_offset_removed_mm, 0, atol=1e-9)
    ours[::2, 2] += [0, 0, 0.01]  # the left hip 1 cm high every other frame: tracking's own error
    got = compare(TRUNK, ours, 30.0, TRUNK, truth, times)
    assert got.body_offset_removed_mm[2] == pytest.approx(5.0)
    assert got.means()["body_offset_removed_mm"] == pytest.approx(5.0 / 4)


def test_the_run_is_read_at_the_references_times():
    # Ours at 30 frames/s moving at 1 m/s along x; a reference at 10 frames/s whose clock
    # runs 0.05 s behind ours: linear motion interpolates exactly once shifted.
    t = np.arange(60) / 30.0
    ours = np.zeros((60, 1, 3))
    ours[:, 0, 0] = t
    ref_times = np.arange(25) / 10.0  # up to 2.4 s: the run ends at 1.97 s
    reference = np.zeros((25, 1, 3))
    reference[:, 0, 0] = ref_times + 0.05
    got = compare(["pelvis"], ours, 30.0, ["pelvis"], reference, ref_times, shift=0.05)
    assert got.body_offset_removed_mm is None  # no trunk to make a body frame from
    assert got.raw_mm[0] == pytest.approx(0, abs=1e-9)
    assert (got.frames, got.missing) == (20, 5)  # 0.05 to 1.95 s lie within the run
    assert compare(["pelvis"], ours, 30.0, ["pelvis"], reference, ref_times).raw_mm[0] == pytest.approx(50)
    ours[10] = np.nan  # a failed frame: the reference's frame at 0.35 s lies between it and the next
    got = compare(["pelvis"], ours, 30.0, ["pelvis"], reference, ref_times, shift=0.05)
    assert (got.frames, got.missing) == (19, 6)


def test_names_are_matched_or_mapped_and_mismatches_named():
    spin, truth = turning_body(4)
    times = np.arange(4) / 30.0
    theirs = ["root", "neck01", "upperleg01.L", "upperleg01.R"]
    mapping = dict(zip(TRUNK, theirs))
    assert compare(TRUNK, truth, 30.0, theirs, truth, times, mapping).raw_mm.max() == pytest.approx(0)
    with pytest.raises(ResultsError, match="share no name"):
        compare(TRUNK, truth, 30.0, theirs, truth, times)
    with pytest.raises(ResultsError, match=r"not found among the reference's .*: \['hip'\]"):
        compare(TRUNK, truth, 30.0, theirs, truth, times, {"pelvis": "hip"})
    with pytest.raises(ResultsError, match="within the run's tracked frames"):
        compare(TRUNK, truth, 30.0, TRUNK, truth, times + 5.0)


def test_a_reference_in_a_world_of_its_own_is_aligned_and_its_clock_found():
    # A marker system calibrated apart (its world turned 30° about z and moved), started
    # 0.12 s after the cameras, filming at 100 frames/s a body that turns and walks.
    frames = 90
    t = np.arange(frames) / 30.0
    spin, body = turning_body(frames)
    ours = body + np.stack([0.8 * t, 0.3 * np.sin(3 * t), 0.05 * np.sin(5 * t)], 1)[:, None]
    a = np.radians(30)
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ref_times = np.arange(200) / 100.0
    # The reference is ours seen 0.12 s later, in its own world.
    exact = np.stack([np.stack([np.interp(ref_times + 0.12, t, ours[:, j, d]) for d in range(3)], 1)
                      for j in range(4)], 1)
    reference = (exact - [1.0, 2.0, 0.0]) @ R  # its world: x_theirs = Rᵀ(x_ours − (1, 2, 0))
    got = compare(TRUNK, ours, 30.0, TRUNK, reference, ref_times, shift="auto", align=True)
    assert got.shift == pytest.approx(0.12, abs=1e-3)
    np.testing.assert_allclose(got.alignment[0], R, atol=1e-3)
    np.testing.assert_allclose(got.alignment[1], [1.0, 2.0, 0.0], atol=2e-3)
    assert got.means()["raw_mm"] < 2.0  # what is left: linear interpolation of ours between frames
    unaligned = compare(TRUNK, ours, 30.0, TRUNK, reference, ref_times, shift=0.12)
    assert unaligned.means()["raw_mm"] > 500


@pytest.mark.parametrize("up, units", [("y", "mm"), ("z", "m")])
def test_trc_reads_back_what_was_written(tmp_path, up, units):
    joints = np.random.default_rng(1).normal(size=(5, 3, 3))
    joints[2, 1] = np.nan
    write_trc(tmp_path / "j.trc", ["a", "b", "c"], joints, 25.0, units=units, up=up)
    names, positions, times = read_trc(tmp_path / "j.trc", up=up)
    assert names == ["a", "b", "c"]
    np.testing.assert_allclose(positions, joints, atol=1e-6, equal_nan=True)
    np.testing.assert_allclose(times, np.arange(5) / 25.0, atol=1e-6)


def test_trc_of_another_tool_and_bad_trc_files(tmp_path):
    # Centimetres, a marker missing as empty fields, the trailing ones left off a row.
    lines = ["PathFileType\t4\t(X/Y/Z)\tlab.trc",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
             "100\t100\t2\t2\tcm\t100\t1\t2", "Frame#\tTime\tRHJC\t\t\tLHJC\t\t", "\t\tX1\tY1\tZ1\tX2\tY2\tZ2", "",
             "1\t0.00\t10\t90\t-5\t\t\t", "2\t0.01\t11\t90\t-5"]
    (tmp_path / "lab.trc").write_text("\n".join(lines) + "\n")
    names, positions, times = read_trc(tmp_path / "lab.trc")
    assert names == ["RHJC", "LHJC"] and list(times) == [0.0, 0.01]
    np.testing.assert_allclose(positions[:, 0], [[0.10, 0.05, 0.90], [0.11, 0.05, 0.90]])  # y up → ours
    assert np.isnan(positions[:, 1]).all()
    (tmp_path / "bad.trc").write_text("\n".join(lines[:6] + ["1\t0.00\tten\t90\t-5"]) + "\n")
    with pytest.raises(ResultsError, match="bad.trc, line 7"):
        read_trc(tmp_path / "bad.trc")
    (tmp_path / "timeless.trc").write_text("\n".join(lines[:6] + ["1\t\t10\t90\t-5"]) + "\n")
    with pytest.raises(ResultsError, match="timeless.trc, line 7: no time"):
        read_trc(tmp_path / "timeless.trc")
    (tmp_path / "inch.trc").write_text("\n".join(lines).replace("\tcm\t", "\tin\t") + "\n")
    with pytest.raises(ResultsError, match="unknown units 'in'"):
        read_trc(tmp_path / "inch.trc")
    (tmp_path / "not.trc").write_text("x,y,z\n")
    with pytest.raises(ResultsError, match="not a TRC file"):
        read_trc(tmp_path / "not.trc")


def test_compare_command_against_a_runs_own_trc_export_and_another_run(tmp_path, capsys):
    model = BodyModel.template()
    rng = np.random.default_rng(2)
    n = 6
    result = TrackingResult.empty(model, n, 30.0)
    result.status[:] = 0  # good
    result.theta[:] = rng.normal(0, 0.2, (n, model.n_dofs))
    result.root_rotation[:] = np.eye(3)
    result.root_translation[:] = rng.normal(0, 0.1, (n, 3)) + [0, 0, 1.0]
    for f in range(n):
        result.joints[f] = model.joints(result.theta[f], result.root_rotation[f], result.root_translation[f])
    for run in ("a", "b"):
        (tmp_path / run).mkdir()
        model.save(tmp_path / run / "model")
        write_outputs(tmp_path / run, result)
        result.root_translation[:, 0] += 0.02  # run b lies 2 cm along x from run a
    assert main(["export", str(tmp_path / "a"), "--format", "trc"]) == 0
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "a"), str(tmp_path / "a" / "joints.trc"),
                 "--json", str(tmp_path / "same.json")]) == 0
    out = capsys.readouterr().out
    assert "in the body's frame (mm)" in out and f"{n} frames of the reference compared" in out
    same = json.loads((tmp_path / "same.json").read_text())
    assert same["frames"] == n and same["means"]["raw_mm"] < 1e-3
    if importlib.util.find_spec("ezc3d"):  # a C3D file of the joints: the same frames, in mm
        assert main(["export", str(tmp_path / "a"), "--format", "c3d"]) == 0
        assert main(["compare", str(tmp_path / "a"), str(tmp_path / "a" / "joints.c3d"),
                     "--json", str(tmp_path / "c3d.json")]) == 0
        c3d = json.loads((tmp_path / "c3d.json").read_text())
        assert c3d["frames"] == n and c3d["means"]["raw_mm"] < 1e-3
    assert main(["compare", str(tmp_path / "b"), str(tmp_path / "a"), "--json", str(tmp_path / "moved.json"),
                 "--plot", str(tmp_path / "moved.png")]) == 0
    picture = cv2.imread(str(tmp_path / "moved.png"))
    assert picture is not None and picture.shape[0] > 400
    moved = json.loads((tmp_path / "moved.json").read_text())["means"]
    assert moved["raw_mm"] == pytest.approx(20, abs=1e-6)  # a constant offset: all of it removed
    assert moved["offset_removed_mm"] == pytest.approx(0, abs=1e-6)
    # A sequence folder's ground truth (truth/joints.npz, as hullcap synth writes it) at its meta.json's rate.
    seq = tmp_path / "seq"
    (seq / "truth").mkdir(parents=True)
    (seq / "meta.json").write_text('{"fps": 30, "frames": 6}')
    truth = load_result(tmp_path / "a").joints  # run b lies 2 cm from it, all of which the offset removes
    np.savez(seq / "truth" / "joints.npz", names=np.array(model.joint_names), positions=truth)
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "b"), str(seq), "--json", str(tmp_path / "truth.json")]) == 0
    assert json.loads((tmp_path / "truth.json").read_text())["means"]["offset_removed_mm"] == pytest.approx(0, abs=1e-6)
    (seq / "meta.json").write_text('{"frames": 6}')
    assert main(["compare", str(tmp_path / "b"), str(seq)]) == 2
    assert "needs the sequence's fps" in capsys.readouterr().err
    assert main(["compare", str(tmp_path / "a"), str(tmp_path / "a" / "joints.csv")]) == 2
    assert "a .trc or .c3d file, a results folder or a sequence with ground truth" in capsys.readouterr().err
    assert main(["compare", str(tmp_path / "a"), str(tmp_path)]) == 2
    assert "neither a run's results folder" in capsys.readouterr().err


def test_pose2sims_trc_axes_are_read_into_our_world(tmp_path):
    """Pose2Sim writes a z-up calibration's world as a y-up TRC whose (x, y, z) is our
    (y, z, x): read with up="pose2sim", its points land where they are in our world."""
    from hullcap.export import read_trc

    ours = np.array([[[1.0, 2.0, 3.0], [-0.5, 0.25, 1.75]]])
    path = tmp_path / "pose2sim.trc"
    lines = ["PathFileType\t4\t(X/Y/Z)\tpose2sim.trc",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
             "60\t60\t1\t2\tm\t60\t1\t1", "Frame#\tTime\tA\t\t\tB", "\t\tX1\tY1\tZ1\tX2\tY2\tZ2",
             "1\t0.0\t" + "\t".join(f"{v}" for p in ours[0] for v in (p[1], p[2], p[0]))]
    path.write_text("\n".join(lines) + "\n")
    names, points, _ = read_trc(path, up="pose2sim")
    assert names == ["A", "B"] and np.allclose(points, ours)
    with pytest.raises(ValueError, match="TRC axes must be 'y' or 'z' or 'pose2sim', got 'x'"):
        read_trc(path, up="x")
