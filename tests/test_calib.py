"""Calibrations of other tools' rigs: imported, described, and carving a hull around the person.

The fixture files are written here as text in each tool's own layout: an EasyMocap rig of
six cameras 5–6 m away on one side of the room (intri.yml / extri.yml, without image sizes)
and a Pose2Sim rig of four portrait phone cameras (Calib_scene.toml).
"""

import numpy as np
import pytest
from hullcap import Sequence, Tracker
from hullcap._cameras import Cameras, look_at
from hullcap._cli import main
from hullcap._cameras import capture_volume
from hullcap._synth import synthesize
from hullcap.errors import CalibrationError, HullError


def _matrix(name, m):
    m = np.atleast_2d(m)
    data = ", ".join(f"{v:.10g}" for v in m.ravel())
    return f"{name}: !!opencv-matrix\n   rows: {m.shape[0]}\n   cols: {m.shape[1]}\n   dt: d\n   data: [ {data} ]\n"


def _rodrigues(R):
    import cv2

    return cv2.Rodrigues(np.asarray(R, float))[0].ravel()


def easymocap_rig(folder, width=480, height=270):
    """Six cameras on one side of the room (y = −5…−6 m), looking at the person at the origin."""
    names = [f"{i:02d}" for i in range(1, 7)]
    f = 0.75 * width
    K = np.array([[f, 0, (width - 1) / 2], [0, f, (height - 1) / 2], [0, 0, 1]])
    intri = "%YAML:1.0\n---\nnames:\n" + "".join(f'   - "{n}"\n' for n in names)
    extri = "%YAML:1.0\n---\nnames:\n" + "".join(f'   - "{n}"\n' for n in names)
    for i, n in enumerate(names):
        x = -2.5 + i
        R, t = look_at((x, -5.0 - 0.2 * (i % 3), 1.3 + 0.5 * (i % 2)), (0.0, 0.0, 0.9))
        intri += _matrix(f"K_{n}", K) + _matrix(f"dist_{n}", np.zeros((1, 5)))
        extri += _matrix(f"R_{n}", _rodrigues(R)[:, None]) + _matrix(f"Rot_{n}", R) + _matrix(f"T_{n}", t[:, None])
    (folder / "intri.yml").write_text(intri)
    (folder / "extri.yml").write_text(extri)
    return width, height


def pose2sim_rig(folder, width=272, height=480):
    """Four portrait phone cameras around the person (Pose2Sim's Calib_scene.toml)."""
    text = ""
    f = 1.1 * width
    for i in range(4):
        a = np.radians(45 + 90 * i)
        R, t = look_at((3.5 * np.cos(a), 3.5 * np.sin(a), 1.2), (0.0, 0.0, 0.9))
        r = _rodrigues(R)
        text += (f'[cam_{i + 1:02d}]\nname = "cam_{i + 1:02d}"\nsize = [ {width}.0, {height}.0,]\n'
                 f"matrix = [ [ {f}, 0.0, {(width - 1) / 2},], [ 0.0, {f}, {(height - 1) / 2},], [ 0.0, 0.0, 1.0,],]\n"
                 "distortions = [ 0.0, 0.0, 0.0, 0.0,]\n"
                 f"rotation = [ {float(r[0])!r}, {float(r[1])!r}, {float(r[2])!r},]\n"
                 f"translation = [ {float(t[0])!r}, {float(t[1])!r}, {float(t[2])!r},]\nfisheye = false\n\n")
    text += "[metadata]\nadjusted = false\nerror = 0.0\n"
    (folder / "Calib_scene.toml").write_text(text)


def test_easymocap_rig_on_one_side_of_the_room_carves_a_hull_around_the_person(tmp_path, capsys):
    w, h = easymocap_rig(tmp_path)
    out = tmp_path / "cameras.json"
    assert main(["calib", "import", "--from", "easymocap", str(tmp_path / "intri.yml"), str(tmp_path / "extri.yml"),
                 "--size", f"{w}x{h}", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "6 cameras" in printed and "capture volume" in printed
    # All on one side: the rig says so (its hull is a deep wedge; see rig.MIN_SURROUND).
    assert "warning: less than 180° around the person" in printed
    cameras = Cameras.load(out)
    assert [c.width for c in cameras] == [w] * 6
    # The volume every camera sees holds the person at the origin, although no camera
    # centre is on the far side of them.
    lo, hi = capture_volume(cameras)
    assert (lo[:2] < [-0.5, -0.3]).all() and (hi[:2] > [0.5, 0.3]).all() and lo[2] <= 0 and hi[2] > 1.8
    synthesize(tmp_path / "seq", "squat", cameras, "short", frames=1, show_progress=False)
    hull = Tracker(Sequence(tmp_path / "seq")).hull(0)
    assert len(hull.vertices) > 1000 and 1.2 < np.ptp(hull.vertices[:, 2]) < 2.0


def test_swapped_and_malformed_sizes_are_caught(tmp_path):
    w, h = easymocap_rig(tmp_path)
    intri, extri = tmp_path / "intri.yml", tmp_path / "extri.yml"
    with pytest.raises(CalibrationError, match=r"principal point .* swapped"):
        Cameras.from_easymocap(intri, extri, image_size=(h, w))
    assert len(Cameras.from_easymocap(intri, extri, image_size=f"{w}x{h}")) == 6
    with pytest.raises(CalibrationError, match="WIDTHxHEIGHT"):
        Cameras.from_easymocap(intri, extri, image_size="480 by 270")
    with pytest.raises(CalibrationError, match="no image size for camera '01'"):
        Cameras.from_easymocap(intri, extri)
    sizes = {f"{i:02d}": (w, h) for i in range(1, 7)}
    assert len(Cameras.from_easymocap(intri, extri, image_size=sizes)) == 6


def test_pose2sim_portrait_phones_carve_a_hull(tmp_path, capsys):
    pose2sim_rig(tmp_path)
    out = tmp_path / "cameras.json"
    assert main(["calib", "import", "--from", "pose2sim", str(tmp_path / "Calib_scene.toml"), "--out", str(out)]) == 0
    cameras = Cameras.load(out)
    assert [(c.width, c.height) for c in cameras] == [(272, 480)] * 4
    synthesize(tmp_path / "seq", "squat", cameras, "short", frames=2, show_progress=False)
    hull = Tracker(Sequence(tmp_path / "seq")).hull(0)
    assert len(hull.vertices) > 1000 and 1.2 < np.ptp(hull.vertices[:, 2]) < 2.0
    capsys.readouterr()
    assert main(["track", str(tmp_path / "seq"), "--out", str(tmp_path / "out"), "--no-overlays"]) == 0
    assert "2 of 2 frames tracked (0 lost" in capsys.readouterr().out
    # `calib show` prints the rig and draws it.
    capsys.readouterr()
    assert main(["calib", "show", str(out), "--picture", str(tmp_path / "rig.png")]) == 0
    printed = capsys.readouterr().out
    assert "cam_01" in printed and "272×480" in printed and "axes meet near" in printed
    assert "surround that point over 270°" in printed and "warning" not in printed
    import cv2

    assert cv2.imread(str(tmp_path / "rig.png")).shape == (800, 800, 3)


def test_opencv_files_and_sizes_from_the_frames(tmp_path):
    """One FileStorage file per camera (as OpenCV's calibration sample writes); the image
    size read from one frame of each camera."""
    from hullcap._cameras import ring

    rig = ring(4, width=320, height_px=240)
    files = []
    for cam in rig:
        text = "%YAML:1.0\n---\n" + _matrix("camera_matrix", cam.K) \
            + _matrix("distortion_coefficients", cam.dist[None]) \
            + _matrix("rvec", _rodrigues(cam.R)[:, None]) + _matrix("tvec", cam.t[:, None])
        files.append(tmp_path / f"{cam.name}.yml")
        files[-1].write_text(text)
    synthesize(tmp_path / "seq", "squat", rig, "short", frames=1, show_progress=False)
    out = tmp_path / "cameras.json"
    assert main(["calib", "import", "--from", "opencv", *map(str, files), "--images", str(tmp_path / "seq"),
                 "--out", str(out)]) == 0
    again = Cameras.load(out)
    for a, b in zip(rig, again):
        assert a.name == b.name and (a.width, a.height) == (b.width, b.height)
        assert np.allclose(a.K, b.K) and np.allclose(a.R, b.R, atol=1e-9) and np.allclose(a.t, b.t)
    # Without a size anywhere: the error names the file and the way out.
    assert main(["calib", "import", "--from", "opencv", str(files[0]), "--out", str(out)]) == 2


def test_volume_given_on_the_command_line_and_an_empty_hull_names_it(tmp_path, capsys):
    seq = tmp_path / "seq"
    assert main(["synth", str(seq), "--frames", "1", "--cameras", "4", "--subject", "short"]) == 0
    tracker = Tracker(Sequence(seq), volume=((2.0, 2.0, 0.0), (3.0, 3.0, 2.0)))
    with pytest.raises(HullError, match=r"capture volume \(2.00, 2.00, 0.00\)–\(3.00, 3.00, 2.00\) m"):
        tracker.hull(0)
    with pytest.raises(HullError, match="x0 < x1"):
        Tracker(Sequence(seq), volume=((1, 0, 0), (0, 1, 1)))
    assert main(["track", str(seq), "--out", str(tmp_path / "o"), "--volume", "2,2,0,3,3,2"]) == 2
    captured = capsys.readouterr()
    assert "capture volume (2.00, 2.00, 0.00)–(3.00, 3.00, 2.00) m (given)" in captured.out
    assert "capture volume (2.00, 2.00, 0.00)–(3.00, 3.00, 2.00) m" in captured.err
    with pytest.raises(SystemExit):
        main(["track", str(seq), "--out", str(tmp_path / "o"), "--volume", "1,2,3"])
    assert "six numbers" in capsys.readouterr().err


def test_rotations_rounded_by_calibration_files_are_accepted():
    from hullcap._cameras import Camera

    R, t = look_at((3.0, -2.0, 1.5), (0.0, 0.0, 1.0))
    rounded = np.round(R, 5)
    cam = Camera("c", 640, 480, [[500, 0, 319.5], [0, 500, 239.5], [0, 0, 1]], np.zeros(5), rounded, t)
    assert np.abs(cam.R @ cam.R.T - np.eye(3)).max() < 1e-12 and np.abs(cam.R - R).max() < 1e-5
    with pytest.raises(CalibrationError, match="not a rotation"):
        Camera("c", 640, 480, [[500, 0, 319.5], [0, 500, 239.5], [0, 0, 1]], np.zeros(5), R * 1.01, t)


def test_cameras_are_matched_to_their_images_by_name_and_a_resized_video_adopted():
    from hullcap._cameras import ring
    from hullcap._rig import match_to_images, normalised_name

    assert normalised_name("cam_01") == normalised_name("Cam01") == normalised_name("cam1") == "cam1"
    assert normalised_name("cam10") != normalised_name("cam1")
    base = ring(3, width=1088, height_px=1920)
    calibrated = Cameras([type(c)(f"cam_0{i + 1}", c.width, c.height, c.K, c.dist, c.R, c.t)
                          for i, c in enumerate(base)])
    sizes = {"cam01": (1080, 1920), "cam02": (1088, 1920), "side": (1088, 1920)}
    with pytest.raises(CalibrationError, match=r"no images for camera cam_03 of the calibration; the images are of "
                                               r"cam01, cam02, side: .* --rename cam_03=NAME"):
        match_to_images(calibrated, sizes)
    cameras, notes = match_to_images(calibrated, sizes, {"cam_03": "side"})
    assert cameras.names == ["cam01", "cam02", "side"]
    assert "camera 'cam_01' is named 'cam01', as its images are" in notes
    assert any("its images are 1080×1920, calibrated 1088×1920: taken as the calibrated frame resized" in n
               for n in notes)
    # The resized camera sees a world point where the calibrated one does, scaled and centred.
    point = np.array([[0.3, -0.2, 1.2]])
    before, after = calibrated[0].project(point)[0][0], cameras[0].project(point)[0][0]
    scale = 1080 / 1088
    assert np.allclose(after, (before + 0.5) * scale - 0.5 + np.array([0.0, (1920 - 1920 * scale) / 2]), atol=1e-6)
    assert cameras[1].width == 1088 and np.array_equal(cameras[1].K, calibrated[1].K)
    with pytest.raises(CalibrationError, match=r"camera 'cam01': its images are 960×1920, calibrated 1088×1920: "
                                               r"not the calibrated frame resized"):
        match_to_images(calibrated, {**sizes, "cam01": (960, 1920)}, {"cam_03": "side"})
    with pytest.raises(CalibrationError, match="--rename names cam_09, which the calibration does not have"):
        match_to_images(calibrated, sizes, {"cam_09": "side"})
