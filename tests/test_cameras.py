"""Cameras: projection and its inverse, cameras.json, other tools' calibrations, scaled cameras."""

import json

import cv2
import numpy as np
import pytest
from hullcap import Camera, Cameras
from hullcap._cameras import ring
from conftest import distorted_camera


def test_projection_matches_opencv_and_back_projection_inverts_it(rng):
    cam = distorted_camera()
    X = rng.uniform(-0.8, 0.8, (200, 3)) + (0, 0, 1)
    px, z = cam.project(X)
    ref, _ = cv2.projectPoints(X, cv2.Rodrigues(cam.R)[0], cam.t, cam.K, cam.dist)
    assert np.abs(ref.reshape(-1, 2) - px).max() < 1e-9
    origin, d = cam.rays(px)
    assert np.allclose(origin + d * np.linalg.norm(X - origin, axis=1)[:, None], X, atol=1e-9)
    assert np.allclose(z, (X - origin) @ cam.R[2])


def test_back_projection_inverts_a_wide_lens_over_the_whole_image():
    """Our own removal of the distortion (Newton's method, not OpenCV's undistortPoints,
    whose signature differs between OpenCV 4 and 5) on a wide-angle lens with skew: every
    pixel's ray projects back onto that pixel."""
    base = ring(8)[1]
    K = base.K.copy()
    K[0, 1] = 0.5
    cam = Camera("wide", 640, 480, K, [-0.28, 0.09, 0.0015, -0.001, -0.012], base.R, base.t)
    uu, vv = np.meshgrid(np.linspace(0, 639, 33), np.linspace(0, 479, 25))
    px = np.stack([uu.ravel(), vv.ravel()], 1)
    origin, d = cam.rays(px)
    back, z = cam.project(origin + 3.0 * d)
    assert (z > 0).all()
    assert np.abs(back - px).max() < 1e-6


def test_cameras_json_round_trip_and_validation(tmp_path):
    cams = Cameras(list(ring(4)) + [distorted_camera()])
    cams.save(tmp_path / "cameras.json")
    back = Cameras.load(tmp_path / "cameras.json")
    assert back.names == cams.names
    for a, b in zip(cams, back):
        assert np.array_equal(a.K, b.K) and np.array_equal(a.R, b.R) and np.array_equal(a.dist, b.dist)
    doc = json.loads((tmp_path / "cameras.json").read_text())

    def broken(edit, message):
        d = json.loads(json.dumps(doc))
        edit(d["cameras"][2])
        (tmp_path / "bad.json").write_text(json.dumps(d))
        with pytest.raises(ValueError, match=message):
            Cameras.load(tmp_path / "bad.json")

    broken(lambda c: c["K"][1].__setitem__(0, 5.0), r"bad.json: camera 'cam2': K must be upper-triangular")
    broken(lambda c: c["K"][0].__setitem__(0, -600.0), r"camera 'cam2': K's focal lengths must be positive")
    broken(lambda c: c.update(R=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]), r"camera 'cam2': R is not a rotation \(det = -1")
    broken(lambda c: c.update(R=[[2, 0, 0], [0, 1, 0], [0, 0, 1]]), r"camera 'cam2': R is not a rotation")
    broken(lambda c: c.update(width=0), r"camera 'cam2': width must be a positive whole number of pixels, got 0")
    broken(lambda c: c.update(name="cam0"), r"names must be unique; repeated: \['cam0'\]")
    broken(lambda c: c.pop("t"), r"camera 'cam2': missing \['t'\]")
    with pytest.raises(ValueError, match="cannot read"):
        Cameras.load(tmp_path / "none.json")


def test_easymocap_and_pose2sim_calibrations_project_like_our_own(tmp_path, rng):
    cams = Cameras(list(ring(3)) + [distorted_camera()])
    X = rng.uniform(-0.8, 0.8, (50, 3)) + (0, 0, 1)
    # EasyMocap: OpenCV FileStorage, Rodrigues rotations, z-up world.
    fi = cv2.FileStorage(str(tmp_path / "intri.yml"), cv2.FILE_STORAGE_WRITE)
    fe = cv2.FileStorage(str(tmp_path / "extri.yml"), cv2.FILE_STORAGE_WRITE)
    fi.write("names", cams.names)
    fe.write("names", cams.names)
    for c in cams:
        fi.write(f"K_{c.name}", c.K)
        fi.write(f"dist_{c.name}", c.dist.reshape(1, 5))
        fe.write(f"R_{c.name}", cv2.Rodrigues(c.R)[0])
        fe.write(f"T_{c.name}", c.t.reshape(3, 1))
    fi.release()
    fe.release()
    easy = Cameras.from_easymocap(tmp_path / "intri.yml", tmp_path / "extri.yml", image_size=(640, 480))
    # Pose2Sim: TOML, a y-up world (x, y, z)_file = (x, z, −y)_ours.
    M = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])  # ours → file
    lines = []
    for c in cams:
        rvec = cv2.Rodrigues(c.R @ M.T)[0].ravel()
        lines += [f"[{c.name}]", f'name = "{c.name}"', f"size = [{c.width}.0, {c.height}.0]",
                  f"matrix = {c.K.tolist()}", f"distortions = {c.dist[:4].tolist()}",
                  f"rotation = {rvec.tolist()}", f"translation = {c.t.tolist()}", "fisheye = false", ""]
    lines += ["[metadata]", "adjusted = false", "error = 0.0"]
    (tmp_path / "Calib.toml").write_text("\n".join(lines))
    p2s = Cameras.from_pose2sim(tmp_path / "Calib.toml", up="y")
    for ours, a, b in zip(cams, easy, p2s):
        ref = ours.project(X)[0]
        assert np.abs(a.project(X)[0] - ref).max() < 1e-6, a.name
        dist = ours.dist.copy()
        dist[4] = 0  # Pose2Sim stores four coefficients
        ref4 = Camera("x", 640, 480, ours.K, dist, ours.R, ours.t).project(X)[0]
        assert np.abs(b.project(X)[0] - ref4).max() < 1e-6, b.name
    with pytest.raises(ValueError, match="no 'names'|no such file"):
        Cameras.from_easymocap(tmp_path / "missing.yml", tmp_path / "extri.yml")


@pytest.mark.parametrize("factor", [0.5, 0.37, 1.0])
def test_a_scaled_camera_projects_where_the_resized_image_shows_the_point(rng, factor):
    """A world point projects, through the scaled calibration (distortion and skew
    included), to where `cv2.resize` carries its pixel: (u + ½) · ratio − ½ on each axis."""
    K = np.array([[820.0, 1.5, 655.3], [0, 815.0, 361.8], [0, 0, 1]])
    cam = Camera("c", 1280, 720, K, [0.05, -0.02, 0.001, -0.002, 0.003], np.eye(3), [0.0, 0.0, 4.0])
    small = cam.scaled(factor)
    assert (small.width, small.height) == (round(1280 * factor), round(720 * factor))
    points = rng.uniform([-1.5, -1, -1], [1.5, 1, 1], (50, 3))
    (u, _), (v, _) = cam.project(points), small.project(points)
    ratio = np.array([small.width / 1280, small.height / 720])
    assert np.allclose(v, (u + 0.5) * ratio - 0.5, atol=1e-9)
    # And the resized image agrees: a bright dot drawn at one projection stays at its image.
    image = np.zeros((720, 1280), np.float32)
    x, y = np.rint(u[0]).astype(int)
    image[y - 8:y + 8, x - 8:x + 8] = 1.0  # centred on (x − ½, y − ½)
    resized = cv2.resize(image, (small.width, small.height), interpolation=cv2.INTER_AREA)
    weights = resized / resized.sum()
    centre = np.array([weights.sum(0) @ np.arange(small.width), weights.sum(1) @ np.arange(small.height)])
    assert np.abs(centre - (np.array([x, y]) * ratio - 0.5)).max() < 0.05
    with pytest.raises(ValueError, match=r"camera 'c\d*': image scale must be a fraction in \(0, 1\], got 1.5"):
        cam.scaled(1.5)
    assert Cameras([cam]).scaled(1) is not None and Cameras([cam]).scaled(1)[0] is cam
