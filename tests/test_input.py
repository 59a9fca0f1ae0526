"""Multi-view input: cameras and foreign calibrations, sequences, silhouettes, visual hull."""

import json
import shutil

import cv2
import numpy as np
import pytest
from hullcap import Camera, Cameras
from hullcap._cameras import ring
from hullcap._engine import background_distortions, background_evidence
from hullcap._hull import HullReport, visual_hull
from hullcap._implicit import capsule_union_mesh, field_mesh
from hullcap._mesh import check_closed, is_closed
from hullcap._render import render_silhouette
from hullcap._sequence import Sequence
from hullcap._silhouette import FOREGROUND_EVIDENCE, StatisticalBackground, Thresholds, background_model
from hullcap._synth import synthesize
from hullcap.errors import ArrayError, ViewError


def distorted_camera():
    base = ring(8)[1]
    return Camera("dist", 640, 480, base.K, [0.08, -0.04, 0.001, -0.002, 0.01], base.R, base.t)


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


def _numpy_verdicts(X, radius, views, tolerance, min_views):
    """The carving rule of `classify_cells`, written out in NumPy with the cameras'
    own projection."""
    left_out, seen = np.zeros(len(X), int), np.zeros(len(X), int)
    all_inside, prior_out = np.ones(len(X), bool), np.zeros(len(X), bool)
    for cam, focal, signed, prior in views:
        px, z = cam.project(X)
        with np.errstate(invalid="ignore"):  # pixels of points at the camera's centre plane
            u, v = np.rint(px[:, 0]).astype(np.int64), np.rint(px[:, 1]).astype(np.int64)
        ok = (z > 1e-6) & (u >= 0) & (u < signed.shape[1]) & (v >= 0) & (v < signed.shape[0])
        d, p = np.full(len(X), np.inf), np.full(len(X), np.inf)
        d[ok] = signed[v[ok], u[ok]]
        if prior is not None:
            p[ok] = prior[v[ok], u[ok]]
        reach = np.where(ok, focal * radius / np.where(ok, z, 1.0), 0.0)
        left_out += d < -reach
        seen += ok
        all_inside &= ok & (d > reach)
        prior_out |= p < -reach
    out = (left_out > tolerance) | ((left_out > 0) & prior_out)
    if radius > 0:
        return np.where(out, 0, np.where(all_inside, 1, 2))
    return np.where(out | (seen < min_views), 0, 1)


def test_the_engine_classifies_cells_as_the_numpy_projection_says(rng):
    """The hull's carving test (one engine pass over the cells) against the same rule in
    NumPy: distortion, points behind a camera and outside its image, the tolerance,
    priors, and cells' image radii included."""
    from hullcap._engine import classify_cells
    from hullcap.errors import ArrayError

    cams = [distorted_camera(), *ring(3, radius=2.5, width=320, height_px=240)]
    X = np.concatenate([rng.uniform(-1.5, 1.5, (20_000, 3)) + (0, 0, 1), cams[0].centre + rng.normal(0, 0.5, (500, 3))])
    views = []
    for k, cam in enumerate(cams):
        shape = (cam.height, cam.width)
        signed = rng.normal(2.0, 6.0, shape).astype(np.float32)
        prior = rng.normal(4.0, 6.0, shape).astype(np.float32) if k % 2 else None
        views.append((cam, float(max(cam.K[0, 0], cam.K[1, 1])), signed, prior))
    engine_views = [(c.K, c.dist, c.R, c.t, f, s, p) for c, f, s, p in views]
    counts = set()
    for radius in (0.0, 0.004, 0.03):
        for tolerance in (0, 1, 2):
            got = classify_cells(X, radius, engine_views, tolerance, 3, threads=2)
            want = _numpy_verdicts(X, radius, views, tolerance, 3)
            assert got.dtype == np.uint8 and np.array_equal(got, want), (radius, tolerance)
            counts.add(tuple(np.bincount(got, minlength=3) > 100))
    assert (True, True, True) in counts and (True, True, False) in counts  # every verdict exercised
    bad_prior = [engine_views[0][:6] + (np.zeros((2, 3)),), *engine_views[1:]]
    with pytest.raises(ArrayError, match=r"views\[0\].prior is 3×2, its signed image 640×480"):
        classify_cells(X, 0.0, bad_prior, 0, 3)
    with pytest.raises(ArrayError, match=r"views\[1\].dist must hold 5 numbers"):
        classify_cells(X, 0.0, [engine_views[0], (cams[1].K, cams[1].dist[:4]) + engine_views[1][2:]], 0, 3)
    with pytest.raises(ArrayError, match=r"views\[0\] must be \(K, dist"):
        classify_cells(X, 0.0, [engine_views[0][:5]], 0, 3)
    with pytest.raises(ArrayError, match="radius must be finite"):
        classify_cells(X, -1.0, engine_views, 0, 3)
    from hullcap._engine import carve

    with pytest.raises(ArrayError, match=r"views\[0\].prior is 3×2"):
        carve((0, 0, 0), 0.01, (10, 10, 10), 1, bad_prior, 0, 3)
    with pytest.raises(ArrayError, match="voxel finite and > 0"):
        carve((0, 0, 0), 0.0, (10, 10, 10), 1, engine_views, 0, 3)
    with pytest.raises(ArrayError, match="too large"):
        carve((0, 0, 0), 0.01, (10**5, 10**5, 10**5), 1, engine_views, 0, 3)
    nothing = [v[:5] + (np.full_like(v[5], -1e9), None) for v in engine_views]  # every pixel far outside
    first, occupancy, tested = carve((-0.05, -0.05, 0.95), 0.01, (10, 10, 10), 1, nothing, 0, 3)
    assert (first, occupancy.shape, occupancy.any(), tested) == ([0, 0, 0], (1, 1, 1), False, 125)


def test_a_boxed_distance_image_carves_as_the_whole_image_it_stands_for(rng):
    """The hull hands the carving each view's distances in the silhouette's box alone; the
    engine reads minus the Chebyshev distance to the box beyond it. The verdicts are those
    of that image written out whole, and an empty mask leaves every cell out. A prior's
    distances come without their inside (0 there): the verdicts are those of its whole
    signed distance."""
    from hullcap._engine import classify_cells
    from hullcap._hull import _boxed_signed_distance, _carving_view
    from hullcap._silhouette import signed_distance

    cams = [distorted_camera(), *ring(3, radius=2.5, width=320, height_px=240)]
    X = rng.uniform(-1.0, 1.0, (20_000, 3)) + (0, 0, 1)
    boxed, whole = [], []
    for cam in cams:
        mask = np.zeros((cam.height, cam.width), np.uint8)
        cv2.circle(mask, (cam.width // 2 + 9, cam.height // 2 - 5), cam.height // 5, 255, -1)
        values, x0, y0, _, _ = _boxed_signed_distance(mask)
        h, w = values.shape
        rows, cols = np.arange(cam.height), np.arange(cam.width)
        below_rows = np.minimum(np.minimum(rows - y0, y0 + h - 1 - rows), 0)
        below_cols = np.minimum(np.minimum(cols - x0, x0 + w - 1 - cols), 0)
        image = np.minimum(below_rows[:, None], below_cols[None, :]).astype(np.float32)
        image[y0:y0 + h, x0:x0 + w] = signed_distance(mask[y0:y0 + h, x0:x0 + w])
        view = _carving_view(cam, mask, mask > 0)
        boxed.append(view)
        whole.append(view[:5] + (image, image))
    for radius in (0.0, 0.01, 0.05, 0.2):
        got = classify_cells(X, radius, boxed, 1, 3)
        assert np.array_equal(got, classify_cells(X, radius, whole, 1, 3)), radius
        assert len(set(got)) == (2 if radius == 0 else 3)
    empty = [_carving_view(cam, np.zeros((cam.height, cam.width), np.uint8)) for cam in cams]
    assert not classify_cells(X, 0.0, empty, 0, 1).any()
    with pytest.raises(ArrayError, match=r"views\[0\].signed: a box of 3×2 at \(639, 0\) does not fit"):
        classify_cells(X, 0.0, [boxed[0][:5] + ((np.zeros((2, 3), np.float32), 639, 0, 640, 480), None)], 0, 1)


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


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    """A small rendered sequence: 4 cameras at 320×240, the first 42 frames of the demo."""
    out = tmp_path_factory.mktemp("seq") / "demo"
    cams = ring(4, radius=3.2, width=320, height_px=240, fov_deg=55)
    return synthesize(out, "demo", cams, subject="short", frames=42, show_progress=False)


def test_synthetic_sequence_has_the_layout_of_formats_md(sequence):
    seq = Sequence(sequence)
    assert len(seq) == 42 and seq.fps == 30 and len(seq.cameras) == 4
    assert seq.images(5)[0].shape == (240, 320, 3)
    joints = np.load(sequence / "truth" / "joints.npz")
    assert joints["positions"].shape == (42, 21, 3) and joints["names"][0] == "pelvis"
    pose = np.load(sequence / "truth" / "pose.npz")
    assert pose["theta"].shape == (42, 29) and pose["root_rotation"].shape == (42, 3, 3)
    vertices = np.load(sequence / "truth" / "vertices.npy", mmap_mode="r")
    assert vertices.shape[0] == 42 and vertices.dtype == np.float32
    # The feet stand on the floor in the calibration pose.
    assert abs(vertices[0, :, 2].min()) < 1e-3


def test_background_subtraction_recovers_silhouettes_and_ignores_shadows(sequence):
    seq = Sequence(sequence)
    models = [StatisticalBackground(seq.background(i)) for i in range(4)]
    ious, shadow_fg = [], []
    for frame in (0, 15, 30, 41):
        for i, img in enumerate(seq.images(frame)):
            truth = cv2.imread(str(sequence / "truth" / "silhouettes" / f"cam{i}" / f"{frame:06d}.png"), 0) > 0
            mask = models[i].mask(img) > 0
            ious.append((mask & truth).sum() / (mask | truth).sum())
            # Shadow: pixels off the subject clearly darker than the empty scene.
            diff = seq.background(i).astype(int).sum(-1) - img.astype(int).sum(-1)
            shadow = (diff > 60) & ~cv2.dilate(truth.astype(np.uint8), np.ones((5, 5))).astype(bool)
            if shadow.sum() > 20:
                shadow_fg.append(mask[shadow].mean())
    assert np.mean(ious) >= 0.97 and min(ious) > 0.9, ious
    assert shadow_fg and max(shadow_fg) < 0.02, shadow_fg
    with pytest.raises(ValueError, match="unknown background subtraction method"):
        background_model(seq.background(0), "magic")
    with pytest.raises(ValueError, match="does not match the background"):
        models[0].mask(np.zeros((10, 10, 3), np.uint8))


def _reference_evidence(backgrounds, image, noise_floor=2.5, t=Thresholds()):
    """Horprasert's evidence written out in NumPy, step by step in single precision as
    `StatisticalBackground` computed it before the engine did."""
    stack = np.asarray(backgrounds)
    mean = stack.mean(0)
    spread = stack.std(0) if len(stack) > 1 else np.zeros_like(mean)
    inv_s = (1.0 / np.maximum(spread, noise_floor)).astype(np.float32)
    es = (mean * inv_s).astype(np.float32)
    es2 = np.maximum((es * es).sum(-1), 1e-6).astype(np.float32)

    def distortions(img):
        i_s = [cv2.multiply(p, inv_s[..., c], dtype=cv2.CV_32F) for c, p in enumerate(cv2.split(img))]
        dot = i_s[0] * es[..., 0] + i_s[1] * es[..., 1] + i_s[2] * es[..., 2]
        alpha = dot / es2
        cd2 = i_s[0] * i_s[0] + i_s[1] * i_s[1] + i_s[2] * i_s[2] - dot * alpha
        return alpha, np.sqrt(np.maximum(cd2, 0))

    b = np.full(es2.shape, np.sqrt(2.0), np.float32)
    if len(stack) > 1:
        b = np.maximum(b, np.sqrt(np.mean(np.array([distortions(img)[1] for img in stack]) ** 2, 0)))
    alpha, cd = distortions(image)
    ev = cd * (1.0 / b).astype(np.float32) - t.chromaticity
    ev[(alpha < t.darkest_shadow) | (alpha > t.brightest_highlight)] = FOREGROUND_EVIDENCE
    return ev


@pytest.mark.parametrize("images", [1, 4])
def test_the_engines_background_test_is_the_numpy_arithmetic_to_the_bit(images, rng):
    """The evidence of every pixel, for a model of one background image (spread = the
    noise floor) and of several (spread measured): equal to the NumPy steps bit for bit,
    on every kind of pixel (background, noise, shadow, highlight, another colour, black,
    white)."""
    scene = rng.integers(0, 256, (37, 53, 3)).astype(np.uint8)  # 1961 pixels: 8 at a time and a rest
    backgrounds = [np.clip(scene + rng.normal(0, 3, scene.shape), 0, 255).astype(np.uint8) for _ in range(images)]
    model = StatisticalBackground(backgrounds)
    for frame in (scene, backgrounds[0],
                  np.clip(scene * rng.uniform(0.2, 1.6, scene.shape[:2])[..., None], 0, 255).astype(np.uint8),
                  rng.integers(0, 256, scene.shape).astype(np.uint8), np.zeros_like(scene), np.full_like(scene, 255)):
        expected = _reference_evidence(backgrounds, frame)
        evidence = model.evidence(frame)
        assert evidence.dtype == np.float32 and evidence.shape == scene.shape[:2]
        np.testing.assert_array_equal(evidence, expected)
    alpha, cd = model._distortions(scene)
    assert alpha.shape == cd.shape == scene.shape[:2] and np.all(cd >= 0)


def test_the_engines_background_test_refuses_what_does_not_fit():
    planes = np.ones((8, 4, 5), np.float32)
    with pytest.raises(ArrayError, match="8 planes|got 7 planes"):
        background_evidence(np.zeros((4, 5, 3), np.uint8), planes[:7], (3.0, 0.45, 1.35, 6.0))
    with pytest.raises(ArrayError, match="image is 5×3 with 3 channels, the background model 5×4"):
        background_evidence(np.zeros((3, 5, 3), np.uint8), planes, (3.0, 0.45, 1.35, 6.0))
    with pytest.raises(ArrayError, match="image"):
        background_distortions(np.zeros((4, 5), np.uint8), planes)


@pytest.mark.parametrize("method", ["statistical", "mog2"])
def test_the_clean_up_scales_with_the_image(method):
    """Specks and holes are judged by their share of the image: the same scene at half the
    resolution keeps a blob a quarter the size, and a size in pixels is refused."""
    def scene(side):
        img = np.full((side * 3 // 4, side, 3), 90, np.uint8)
        return img, img.copy()

    for side, blob in ((640, 15), (320, 8)):  # 225 and 64 pixels: 1.1 and 1.3 times the least blob
        empty, frame = scene(side)
        frame[10:10 + blob, 10:10 + blob] = (20, 200, 240)
        model = background_model(empty, method)
        assert (model.min_blob, model.max_hole) == ((200, 2000) if side == 640 else (50, 500))
        assert (model.mask(frame) > 0).sum() >= blob * blob - 4 * blob  # kept (its outline may go)
        frame[10:10 + blob, 10:10 + blob] = 90
        frame[10:16, 10:16] = (20, 200, 240)  # 36 pixels: a speck at both sizes
        assert not model.mask(frame).any()
    with pytest.raises(ValueError, match="min_blob is a fraction of the image's area"):
        background_model(empty, method, min_blob=200)


def _reference_clean_mask(mask, min_blob, max_hole):
    """`clean_mask`'s rule written out with SciPy's labelling: open by a 3×3 square (as
    OpenCV does: erode with the outside counted as foreground, then dilate), drop
    8-connected blobs below `min_blob` pixels, fill 4-connected background components
    that touch no border and have at most `max_hole` pixels."""
    from scipy import ndimage

    square = np.ones((3, 3), bool)
    fg = ndimage.binary_dilation(ndimage.binary_erosion(mask > 0, square, border_value=1), square)
    labels, n = ndimage.label(fg, square)
    for k in range(1, n + 1):
        if (labels == k).sum() < min_blob:
            fg[labels == k] = False
    labels, n = ndimage.label(~fg)
    border = set(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    for k in range(1, n + 1):
        if k not in border and (max_hole is None or (labels == k).sum() <= max_hole):
            fg[labels == k] = True
    return np.where(fg, 255, 0).astype(np.uint8)


def test_mask_clean_up_drops_specks_and_fills_holes_as_labelling_every_component_does(rng):
    from hullcap._silhouette import clean_mask

    for _ in range(300):
        h, w = rng.integers(1, 40, 2)
        noise = rng.random((h, w))
        if rng.random() < 0.7:  # blobs with holes, as a silhouette has; else salt and pepper
            noise = cv2.GaussianBlur(noise, (0, 0), rng.uniform(0.3, 2.0))
        mask = _somewhere_in_a_frame(np.where(noise > rng.uniform(0.3, 0.7), 255, 0).astype(np.uint8), rng)
        min_blob, max_hole = int(rng.integers(1, 30)), None if rng.random() < 0.2 else int(rng.integers(0, 30))
        assert np.array_equal(clean_mask(mask, min_blob, max_hole), _reference_clean_mask(mask, min_blob, max_hole))
    for mask in (np.zeros((4, 5), np.uint8), np.full((4, 5), 255, np.uint8), np.full((1, 1), 255, np.uint8)):
        assert np.array_equal(clean_mask(mask, 1, 3), _reference_clean_mask(mask, 1, 3))


def _somewhere_in_a_frame(mask, rng):
    """`mask` as it is (touching the frame's borders), or placed in a larger empty frame
    at a random place, half the time each: the clean-up works in the foreground's box."""
    if rng.random() < 0.5:
        return mask
    (h, w), (ph, pw) = mask.shape, rng.integers(0, 12, 2)
    frame = np.zeros((h + ph + int(rng.integers(0, 12)), w + pw + int(rng.integers(0, 12))), np.uint8)
    frame[ph:ph + h, pw:pw + w] = mask
    return frame


def test_half_covered_outlines_are_the_rule_applied_to_the_whole_frame(rng):
    """`half_covered` works in the mask's box; written out over the whole frame: an
    outline pixel (foreground with a background pixel among its eight neighbours; outside
    the frame counts as foreground, as OpenCV's erosion has it) is dropped when its
    distortion is under half the largest among itself and its neighbours in the frame."""
    from scipy import ndimage

    from hullcap._silhouette import half_covered

    square = np.ones((3, 3), bool)
    for _ in range(200):
        h, w = rng.integers(1, 40, 2)
        blobs = cv2.GaussianBlur(rng.random((h, w)), (0, 0), rng.uniform(0.3, 2.0))
        mask = _somewhere_in_a_frame(np.where(blobs > rng.uniform(0.3, 0.7), 255, 0).astype(np.uint8), rng)
        evidence = rng.gamma(2.0, 3.0, mask.shape).astype(np.float32) - 3
        threshold = float(rng.uniform(3, 4))  # given as the background test's evidence and its threshold
        distortion = evidence + threshold
        fg = mask > 0
        ring = fg & ~ndimage.binary_erosion(fg, square, border_value=1)
        largest = ndimage.maximum_filter(distortion, size=3, mode="constant", cval=-np.inf)
        want = np.where(ring & (distortion < 0.5 * largest), 0, mask).astype(np.uint8)
        assert np.array_equal(half_covered(mask, distortion), want)
        assert np.array_equal(half_covered(mask, evidence, threshold), want)
    assert not half_covered(np.zeros((3, 4), np.uint8), np.ones((3, 4), np.float32)).any()


def test_a_silhouette_is_where_the_z_buffer_sees_the_mesh_and_grows_as_a_whole_image_would():
    from hullcap._guided import dilated
    from hullcap._render import render_depth

    vertices, faces = capsule_union_mesh([((0.0, 0.0, 0.6), (0.1, 0.05, 1.4), 0.15),
                                          ((0.0, -0.2, 1.2), (0.0, 0.4, 1.25), 0.05)])
    assert is_closed(faces)
    for cam in ring(6, 2.5, 1.2, width=160, height_px=120):
        seen = render_silhouette(cam, vertices, faces)
        assert seen.dtype == bool and seen.any() and not seen.all()
        assert np.array_equal(seen, render_depth(cam, vertices, faces)[1] >= 0)
        assert np.array_equal(render_silhouette(cam, vertices, faces, closed=True), seen)  # a closed mesh
        for fraction in (0.01, 0.1, 0.5):
            r = max(1, round(fraction * cv2.boundingRect(seen.astype(np.uint8))[3]))
            whole = cv2.dilate(seen.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1,) * 2))
            assert np.array_equal(dilated(seen, fraction), whole > 0)
    empty = np.zeros((5, 7), bool)
    assert np.array_equal(dilated(empty, 0.1), empty)


def _masks(cameras, vertices, faces):
    return [render_silhouette(c, vertices, faces).astype(np.uint8) * 255 for c in cameras]


def test_hull_of_a_sphere_is_tight_where_the_views_constrain_it():
    cams = ring(8, radius=3.0)
    centre, radius, voxel = np.array([0.1, -0.05, 1.0]), 0.3, 0.01
    v, f = capsule_union_mesh([(centre, centre, radius)], 0.005)
    hull = visual_hull(_masks(cams, v, f), cams, voxel_size=voxel)
    topo = check_closed(hull.vertices, hull.faces)
    assert topo["closed"] and topo["components"] == 1 and topo["volume"] > 0
    d = hull.vertices - centre
    r = np.linalg.norm(d, axis=1)
    signed = r - radius
    assert signed.min() > -voxel  # never inside the true shape by more than a voxel
    # Where a camera looks straight at the sphere's rim, the silhouettes pin the hull.
    rim = np.zeros(len(r), bool)
    for c in cams:
        view = centre - c.centre
        view /= np.linalg.norm(view)
        rim |= np.abs((d / r[:, None]) @ view) < 0.05
    assert np.abs(signed[rim]).max() < voxel
    assert signed.max() < 0.1  # the unconstrained bulges between views stay bounded
    # Normals point outwards.
    assert np.mean(np.einsum("ij,ij->i", hull.normals, d / r[:, None]) > 0.5) > 0.99


@pytest.mark.parametrize("tolerance, with_prior", [(0, False), (1, False), (1, True)])
def test_coarse_to_fine_carving_keeps_exactly_what_carving_every_voxel_keeps(tolerance, with_prior):
    """Against brute force: every voxel of the grid tested in every view by its centre
    (the engine's finest-level test). One view misses a band of the body, to exercise
    the tolerance."""
    from hullcap._engine import classify_cells
    from hullcap._hull import HullReport, _carve, _carving_view

    cams = ring(6, radius=3.0, width=320, height_px=240)
    v, f = capsule_union_mesh([((0, 0, 0.7), (0, 0, 1.3), 0.2), ((0, 0, 1.0), (0.5, 0.1, 1.2), 0.08)], 0.005)
    masks = _masks(cams, np.array(v), f)
    priors = [m > 0 for m in masks] if with_prior else [None] * len(cams)
    if tolerance:
        masks[0][120:130] = 0
    views = [_carving_view(c, m, p) for c, m, p in zip(cams, masks, priors)]
    lo, hi, h = np.array([-0.8, -0.8, 0.2]), np.array([0.8, 0.8, 1.8]), 0.02
    origin, occupancy = _carve(views, lo, hi, h, HullReport(), 3, tolerance)
    n = np.ceil((hi - lo) / h).astype(int)
    cells = np.stack(np.meshgrid(*map(np.arange, n), indexing="ij"), -1).reshape(-1, 3)
    verdict = classify_cells(lo + (cells + 0.5) * h, 0.0, views, tolerance, 3)
    brute = cells[verdict == 1]
    got = np.argwhere(occupancy) + np.rint((origin - lo) / h).astype(int)
    assert len(brute) > 10_000
    assert sorted(map(tuple, got)) == sorted(map(tuple, brute))


def _blobs(rng, shape=(60, 56, 64), pad=0):
    """A ball, random blobs, a wire one voxel thin and a rod, inside `pad` empty voxels."""
    from scipy import ndimage

    noise = ndimage.gaussian_filter(rng.random(shape), 3.0)
    occupancy = noise > np.quantile(noise, 0.97)
    occupancy |= np.linalg.norm(np.indices(shape) - np.array([30, 28, 32])[:, None, None, None], axis=0) < 16
    occupancy[5, 3:30, 20] = True
    occupancy[50:53, 40:43, 3:60] = True
    return np.pad(occupancy, pad)


@pytest.mark.parametrize("sigma", [0.3, 0.7, 1.0])
def test_the_engines_blur_is_scipys_gaussian_filter(sigma, rng):
    """To float32 rounding, with zeros in the same places (blobs cut by the box's faces
    included), whatever the number of threads."""
    from scipy import ndimage

    from hullcap._engine import gaussian_blur

    occupancy = _blobs(rng)
    field = gaussian_blur(occupancy, sigma, threads=2)
    reference = ndimage.gaussian_filter(occupancy.astype(np.float64), sigma, mode="constant", truncate=3.0)
    assert field.dtype == np.float32 and field.shape == occupancy.shape
    np.testing.assert_allclose(field, reference, atol=1e-6)
    np.testing.assert_array_equal(field == 0, reference == 0)
    np.testing.assert_array_equal(gaussian_blur(occupancy, sigma, threads=1), field)
    with pytest.raises(ValueError, match="sigma"):
        gaussian_blur(occupancy, 0.0)
    with pytest.raises(ValueError, match="3-D"):
        gaussian_blur(occupancy[0], sigma)


@pytest.mark.parametrize("sigma", [0.3, 0.7, 1.0])
def test_the_engines_isosurface_has_marching_cubes_vertices_and_is_closed(sigma, rng):
    """Against scikit-image's marching cubes on the same field: the same vertices (each
    grid edge the level crosses, interpolated linearly), a surface as closed and as
    shaped (Euler characteristic, volume), wound outwards."""
    from scipy.spatial import cKDTree
    from skimage.measure import marching_cubes

    from hullcap._engine import gaussian_blur, isosurface

    field = gaussian_blur(_blobs(rng, pad=3), sigma)
    vertices, faces, normals = isosurface(field, 0.5)
    ref_vertices, ref_faces, _, _ = marching_cubes(field, 0.5, gradient_direction="ascent")
    assert len(vertices) == len(ref_vertices) > 5000
    assert cKDTree(ref_vertices).query(vertices)[0].max() < 1e-5
    topology, ref_topology = check_closed(vertices, faces), check_closed(ref_vertices, ref_faces)
    assert topology["closed"] and ref_topology["closed"]
    assert topology["euler"] == ref_topology["euler"]
    assert topology["components"] == ref_topology["components"]
    assert topology["volume"] == pytest.approx(ref_topology["volume"], rel=2e-3)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
    # Shared out among threads in runs of slabs, the same mesh in the same order.
    assert field.shape[0] > 2 * 16
    for threads in (1, 3):
        for mine, theirs in zip(isosurface(field, 0.5, threads=threads), (vertices, faces, normals)):
            np.testing.assert_array_equal(mine, theirs)
    with pytest.raises(ValueError, match="threads"):
        isosurface(field, 0.5, threads=0)


def test_isosurface_normals_follow_the_surface_of_a_smoothed_ball():
    """A ball of radius 5 voxels (an arm's thickness at 1 cm), smoothed as the hull is:
    the normals point outwards, within a few degrees of the true ones."""
    from hullcap._engine import gaussian_blur, isosurface

    centre = np.array([20.3, 19.6, 21.2])
    occupancy = np.linalg.norm(np.indices((40, 40, 42)) - centre[:, None, None, None], axis=0) < 5
    vertices, faces, normals = isosurface(gaussian_blur(occupancy, 0.7), 0.5)
    radial = (vertices - centre) / np.linalg.norm(vertices - centre, axis=1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.sum(normals * radial, axis=1), -1, 1)))
    assert angle.mean() < 10 and angle.max() < 30
    assert check_closed(vertices, faces)["volume"] > 0
    with pytest.raises(ValueError, match="level"):
        isosurface(occupancy, np.nan)
    with pytest.raises(ValueError, match="shape"):
        isosurface(np.zeros((1, 4, 4)), 0.5)


def test_hull_of_a_box_contains_it_and_hugs_its_faces():
    cams = ring(8, radius=3.0)
    lo, hi, voxel = np.array([-0.2, -0.15, 0.6]), np.array([0.25, 0.15, 1.5]), 0.01
    centre, half = (lo + hi) / 2, (hi - lo) / 2

    def box(p):
        q = np.abs(p - centre) - half
        return np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(-1), 0)

    v, f = field_mesh(box, lo - 0.02, hi + 0.02, 0.004)
    hull = visual_hull(_masks(cams, v, f), cams, voxel_size=voxel)
    sd = box(hull.vertices)
    assert sd.min() > -voxel
    # Face centres of the vertical sides are seen edge-on by no camera; the top and bottom
    # rims, and the vertical edges, are: the hull is within a voxel at the vertical edges.
    corners = np.array([[x, y] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])])
    near_edge = np.min(np.linalg.norm(hull.vertices[:, None, :2] - corners, axis=2), 1) < 0.03
    mid_height = np.abs(hull.vertices[:, 2] - centre[2]) < 0.3
    assert np.abs(sd[near_edge & mid_height]).max() < 3 * voxel
    q = np.abs(hull.vertices - centre) - half
    face_dir = np.argmax(q, axis=1)
    outward = np.zeros_like(hull.vertices)
    outward[np.arange(len(q)), face_dir] = np.sign((hull.vertices - centre)[np.arange(len(q)), face_dir])
    assert np.mean(np.einsum("ij,ij->i", hull.normals, outward) > 0.3) > 0.95


def test_a_hull_cut_by_views_that_were_unsure_is_doubtful_there_alone():
    """Four views miss a ball's top, unsure of it (clothes the colour of the room): a
    tolerance of one view cannot keep it, and the cut's flat face is doubtful; the rest
    of the ball, which every view cut where it saw the room for sure, is not. One of the
    four views sure of its cut vouches for what it cut, and asking for more views than
    cut it (five), for all of it. The engine's own call names a bad view."""
    from hullcap._engine import doubtful_points
    from hullcap._hull import doubtful_vertices
    from hullcap._tracking import TrackerOptions

    cams = ring(8, radius=3.0, width=320, height_px=240)
    centre, radius = np.array([0.0, 0.0, 1.0]), 0.3
    v, f = capsule_union_mesh([(centre, centre, radius)], 0.005)
    masks = _masks(cams, v, f)
    top = centre[2] + 0.15
    unsure = [np.zeros(m.shape, bool) for m in masks]
    for i in (0, 2, 4, 6):  # all round the ring, at one height: their cuts meet in a flat top
        row = int(cams[i].project(np.array([[0.0, 0.0, top]]))[0][0, 1])
        masks[i][:row] = 0
        unsure[i][:row] = True
    hull = visual_hull(masks, cams, voxel_size=0.01, tolerance=1)
    z = hull.vertices[:, 2]
    assert z.max() < top + 0.05 < centre[2] + radius  # cut: one view's tolerance cannot keep it
    doubt = doubtful_vertices(hull, masks, unsure, cams)
    flat = (z > top - 0.05) & (hull.normals[:, 2] > 0.9)
    assert flat.sum() > 1000 and doubt[flat].mean() > 0.8
    assert not doubt[z < top - 0.05].any()  # the ball's own surface stays
    assert not doubtful_vertices(hull, masks, unsure, cams, views=5).any()
    sure_of_it = [u if i else np.zeros_like(u) for i, u in enumerate(unsure)]  # view 0 saw the room
    vouched = doubtful_vertices(hull, masks, sure_of_it, cams)
    assert (vouched <= doubt).all() and vouched[flat].mean() < 0.5 * doubt[flat].mean()
    assert not doubtful_vertices(hull, masks, [None] * len(cams), cams).any()  # given masks: sure everywhere
    kept = hull.subset(~doubt)
    assert len(kept.vertices) == (~doubt).sum() and len(kept.faces) > 0.8 * len(hull.faces)
    np.testing.assert_array_equal(kept.vertices[kept.faces], hull.vertices[hull.faces[(~doubt)[hull.faces].all(1)]])
    with pytest.raises(ValueError, match="unsure"):
        doubtful_vertices(hull, masks, unsure[:-1], cams)
    c = cams[0]
    with pytest.raises(ArrayError, match=r"views\[0\]\.unsure is 3×2"):
        doubtful_points(hull.vertices, [(c.K, c.dist, c.R, c.t, masks[0], np.zeros((2, 3), bool))], 1)
    with pytest.raises(ArrayError, match=r"views\[0\] must be"):
        doubtful_points(hull.vertices, [(c.K, c.dist, c.R, c.t, masks[0])], 1)
    with pytest.raises(ArrayError, match="keep"):
        hull.subset(doubt[:-1])
    for bad in ({"hull_doubt": 0.0}, {"hull_doubt_views": 0}):
        with pytest.raises(ValueError, match="hull_doubt"):
            TrackerOptions(**bad)


def test_hull_skips_blank_views_and_refuses_bad_masks():
    cams = ring(8, radius=3.0)
    v, f = capsule_union_mesh([((0, 0, 1), (0, 0, 1.2), 0.25)], 0.01)
    masks = _masks(cams, v, f)
    full = visual_hull(masks, cams)
    masks[3] = np.zeros_like(masks[3])
    report = HullReport()
    with pytest.warns(UserWarning, match="cam3"):
        partial = visual_hull(masks, cams, report=report)
    assert report.skipped == {"cam3": "empty mask"}
    whole = check_closed(full.vertices, full.faces)["volume"]
    assert abs(check_closed(partial.vertices, partial.faces)["volume"] - whole) < 0.1 * whole
    # Overruling a view without priors to bound it: a view left out already overrules one,
    # or what that view shared with one other would stay as phantom volume.
    with pytest.warns(UserWarning, match="cam3"):
        tolerant = visual_hull(masks, cams, tolerance=1)
    assert abs(check_closed(tolerant.vertices, tolerant.faces)["volume"] - whole) < 0.1 * whole
    with pytest.raises(ValueError, match="every mask is empty"):
        visual_hull([np.zeros_like(m) for m in masks], cams)
    with pytest.raises(ValueError, match=r"camera 'cam1': mask of shape \(480, 100\), the camera's images are 640×480"):
        visual_hull([masks[0], masks[1][:, :100]] + masks[2:], cams)
    with pytest.raises(ValueError, match=r"camera 'cam0': mask of shape \(480, 640, 3\)"):
        visual_hull([np.dstack([masks[0]] * 3)] + masks[1:], cams)
    # Some of the cameras, as a slice or a list of them, with their masks.
    some = visual_hull(masks[:4], cams[:4])
    assert isinstance(cams[:4], type(cams)) and cams[:4].names == cams.names[:4]
    assert len(visual_hull(masks[:4], list(cams)[:4]).vertices) == len(some.vertices)
    with pytest.raises(ValueError, match="7 masks for 8 cameras"):
        visual_hull(masks[:7], cams)


def test_sequence_errors_name_the_file(sequence, tmp_path):
    bad = tmp_path / "bad"
    shutil.copytree(sequence, bad, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    seq = Sequence(bad)
    frame = bad / "frames" / "cam1" / "000003.png"
    cv2.imwrite(str(frame), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match=r"cam1/000003.png: image is 10×10, camera 'cam1' is calibrated for 320×240"):
        seq.images(3)
    frame.write_bytes(b"not a png")
    with pytest.raises(ValueError, match=r"cam1/000003.png: not a readable image"):
        seq.images(3)
    frame.unlink()
    with pytest.raises(ValueError, match=r"cam1/000003.png: missing"):
        seq.images(3)
    with pytest.raises(IndexError, match="frame 42 out of range"):
        seq.images(42)
    # Your own masks at another resolution are refused when the sequence is opened.
    (bad / "silhouettes" / "cam0").mkdir(parents=True)
    cv2.imwrite(str(bad / "silhouettes" / "cam0" / "000000.png"), np.zeros((120, 160), np.uint8))
    with pytest.raises(ValueError, match=r"cam0/000000.png: mask is 160×120, camera 'cam0' is calibrated for 320×240"):
        Sequence(bad)
    shutil.rmtree(bad / "silhouettes")
    shutil.rmtree(bad / "frames" / "cam2")
    with pytest.raises(ValueError, match="camera 'cam2' has no frames/cam2/"):
        Sequence(bad)
    (bad / "cameras.json").unlink()
    with pytest.raises(ValueError, match="missing cameras.json"):
        Sequence(bad)


@pytest.mark.parametrize("form", ["8-bit 0/255", "8-bit labels 0/1", "16-bit labels 0/1", "16-bit 0/65535",
                                  "colour, red on black", "cut-out (alpha)", "cut-out, soft edge"])
def test_masks_from_any_segmenter_read_as_the_same_silhouette(sequence, tmp_path, form):
    """One truth mask written as segmenters write them: the mask read back is > 0 exactly
    where the truth is (a 16-bit label of 1 once read as 0 everywhere, an 8-bit reduction)."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    truth = cv2.imread(str(sequence / "truth" / "silhouettes" / "cam1" / "000005.png"), cv2.IMREAD_GRAYSCALE) > 0
    image = cv2.imread(str(sequence / "frames" / "cam1" / "000005.png"))
    written = {
        "8-bit 0/255": truth.astype(np.uint8) * 255,
        "8-bit labels 0/1": truth.astype(np.uint8),
        "16-bit labels 0/1": truth.astype(np.uint16),
        "16-bit 0/65535": truth.astype(np.uint16) * 65535,
        "colour, red on black": np.dstack([np.zeros_like(truth), np.zeros_like(truth), truth]).astype(np.uint8),
        "cut-out (alpha)": np.dstack([image, truth.astype(np.uint8) * 255]),
        # A matte's fringe: the background a third opaque where it borders the subject.
        "cut-out, soft edge": np.dstack([image, np.where(truth, 255, 85 * cv2.dilate(truth.astype(np.uint8),
                                                                                 np.ones((3, 3)))).astype(np.uint8)]),
    }[form]
    (seq_path / "silhouettes" / "cam1").mkdir(parents=True)
    cv2.imwrite(str(seq_path / "silhouettes" / "cam1" / "000005.png"), written)
    mask = Sequence(seq_path).mask(5, "cam1")
    assert mask.shape == truth.shape and mask.dtype == np.uint8
    np.testing.assert_array_equal(mask > 0, truth)


@pytest.mark.parametrize("suffix, fourcc", [(".mp4", "mp4v"), (".avi", "MJPG")])
def test_a_mask_video_per_camera_reads_as_its_masks(sequence, tmp_path, suffix, fourcc):
    """The truth masks of every camera written as one video each (a video matting tool's
    output): the sequence has silhouettes, counts the videos' frames, and each mask read
    back is the truth but for the codec's loss along the outline; a mask image beside the
    video wins, and a video of another size is refused, naming it."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    truth_dir = sequence / "truth" / "silhouettes"
    (seq_path / "silhouettes").mkdir()
    cams = ("cam0", "cam1", "cam2", "cam3")
    for cam in cams:
        writer = cv2.VideoWriter(str(seq_path / "silhouettes" / f"{cam}{suffix}"), cv2.VideoWriter_fourcc(*fourcc),
                                 30, (320, 240))
        for frame in range(42):
            writer.write(cv2.cvtColor(cv2.imread(str(truth_dir / cam / f"{frame:06d}.png"), 0), cv2.COLOR_GRAY2BGR))
        writer.release()
    seq = Sequence(seq_path)
    assert seq.has_silhouettes and seq.frame_counts(silhouettes=True) == dict.fromkeys(cams, 42)
    for frame in (7, 3, 30):  # out of order: the reader seeks
        for cam in ("cam1", "cam3"):
            truth = cv2.imread(str(truth_dir / cam / f"{frame:06d}.png"), 0) > 0
            got = seq.mask(frame, cam) > 0
            assert (got & truth).sum() / (got | truth).sum() > 0.97, (frame, cam)
    (seq_path / "silhouettes" / "cam1").mkdir()
    cv2.imwrite(str(seq_path / "silhouettes" / "cam1" / "000007.png"), np.zeros((240, 320), np.uint8))
    assert not Sequence(seq_path).mask(7, "cam1").any()
    seq.close()
    writer = cv2.VideoWriter(str(seq_path / "silhouettes" / f"cam2{suffix}"), cv2.VideoWriter_fourcc(*fourcc), 30,
                             (160, 120))
    writer.write(np.zeros((120, 160, 3), np.uint8))
    writer.release()
    with pytest.raises(ValueError, match=rf"cam2{suffix}: mask is 160×120, camera 'cam2' is calibrated for 320×240"):
        Sequence(seq_path)


@pytest.mark.parametrize("suffix, fourcc", [(".mp4", "mp4v"), (".avi", "MJPG"), (".mov", "mp4v"), (".MKV", "MJPG")])
def test_a_camera_filmed_as_a_video_reads_as_its_frames_in_any_common_container(sequence, tmp_path, suffix, fourcc):
    """cam0's frames written as one video in `suffix`'s container: the same frame count,
    each frame within the codec's loss of the image it was made from, its size taken by
    `calib import --images` too; a second video for the same camera is refused, naming
    both; a file of another kind in videos/ is no video of a camera."""
    from hullcap._rig import image_sizes

    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    frames = sorted((seq_path / "frames" / "cam0").glob("*.png"))[:4]
    originals = [cv2.imread(str(f)) for f in frames]
    (seq_path / "videos").mkdir()
    video = seq_path / "videos" / f"cam0{suffix}"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*fourcc), 30, originals[0].shape[1::-1])
    assert writer.isOpened(), f"this OpenCV cannot write {suffix}"
    for image in originals:
        writer.write(image)
    writer.release()
    shutil.rmtree(seq_path / "frames" / "cam0")
    (seq_path / "videos" / "notes.txt").write_text("filmed on a Tuesday")
    seq = Sequence(seq_path)
    assert seq.frame_counts()["cam0"] == len(originals)
    for i in (2, 0, 3):  # out of order: the reader seeks
        got = seq.image(i, "cam0").astype(int)
        assert np.abs(got - originals[i]).mean() < 4.0
    seq.close()
    assert image_sizes(seq_path)["cam0"] == (originals[0].shape[1], originals[0].shape[0])
    shutil.copy(video, seq_path / "videos" / "cam0.m4v")
    with pytest.raises(ValueError, match=r"camera 'cam0' has 2 videos \(.*cam0\.m4v.*\); keep one"):
        Sequence(seq_path)


def test_a_sequence_of_videos_needs_no_meta_json(sequence, tmp_path):
    """Every camera a video and no meta.json: the videos' frame rate and their most frames
    (one video a frame short leaves that view out of the last frame); rates that disagree,
    or a camera of images, ask for meta.json, saying why."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    names = [c.name for c in Sequence(seq_path).cameras]
    (seq_path / "meta.json").unlink()
    (seq_path / "videos").mkdir()

    originals = {name: [cv2.imread(str(seq_path / "frames" / name / f"{f:06d}.png")) for f in range(6)]
                 for name in names}

    def film(name, frames, fps):
        images = originals[name][:frames]
        writer = cv2.VideoWriter(str(seq_path / "videos" / f"{name}.avi"), cv2.VideoWriter_fourcc(*"MJPG"), fps,
                                 images[0].shape[1::-1])
        for image in images:
            writer.write(image)
        writer.release()

    for i, name in enumerate(names[:-1]):
        film(name, 5 if i == 0 else 6, 25)
    with pytest.raises(ValueError, match=rf"meta.json: missing; .* every camera is a video: not {names[-1]}\)"):
        Sequence(seq_path)
    film(names[-1], 6, 25)
    for name in names:
        shutil.rmtree(seq_path / "frames" / name)
    seq = Sequence(seq_path)
    assert (seq.fps, len(seq)) == (25.0, 6)
    assert seq.frame_counts()[names[0]] == 5
    with pytest.raises(ViewError, match=rf"no frame 5 \(camera '{names[0]}'\)"):
        seq.image(5, names[0])
    seq.close()
    film(names[-1], 6, 30)
    with pytest.raises(ValueError, match=r"frame rates do not agree \(.*25, .* 30 frames/s\)"):
        Sequence(seq_path)


@pytest.mark.parametrize("form", ["folder", "video"])
def test_a_clip_of_the_empty_room_teaches_the_background_model_what_flickers(sequence, tmp_path, form):
    """cam0's background as a clip of the empty room in which a screen's colour swings
    between red and blue by ±20 grey levels: the model learnt from the clip keeps the
    screen as background in a frame where it is at its bluest, the model of one image
    does not; at most `most` frames are read, spread over the clip; two backgrounds for
    one camera are refused, naming both."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    still = cv2.imread(str(seq_path / "background" / "cam0.png"))
    rng = np.random.default_rng(7)
    screen = (slice(40, 90), slice(30, 110))

    def frame(level):
        img = still.astype(float) + rng.normal(0, 2.0, still.shape)
        img[screen + (0,)] += level  # blue up, red down: the same brightness, another hue
        img[screen + (2,)] -= level
        return np.clip(img, 0, 255).astype(np.uint8)

    levels = 20 * np.sin(np.linspace(0, 6 * np.pi, 24))
    clip = [frame(level) for level in levels]
    if form == "folder":
        (seq_path / "background" / "cam0").mkdir()
        for i, img in enumerate(clip):
            cv2.imwrite(str(seq_path / "background" / "cam0" / f"{i:06d}.png"), img)
    else:
        writer = cv2.VideoWriter(str(seq_path / "background" / "cam0.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30,
                                 still.shape[1::-1])
        for img in clip:
            writer.write(img)
        writer.release()
    with pytest.raises(ValueError, match=r"camera 'cam0' has 2 backgrounds \(cam0.png, cam0(/|\.avi)?"):
        Sequence(seq_path).backgrounds("cam0")
    (seq_path / "background" / "cam0.png").unlink()
    seq = Sequence(seq_path)
    few = seq.backgrounds("cam0", most=5)
    assert len(few) == 5
    tolerance = 0 if form == "folder" else 6  # MJPG's loss
    assert np.abs(few[0].astype(int) - clip[0]).mean() <= tolerance
    assert np.abs(few[-1].astype(int) - clip[-1]).mean() <= tolerance
    learnt = StatisticalBackground(seq.backgrounds("cam0"))
    assert len(seq.backgrounds("cam0")) == 24
    one = StatisticalBackground(seq.backgrounds("cam0")[0])
    bluest = frame(20.0)
    on_screen = lambda model: (model.mask(bluest)[screen] > 0).mean()  # noqa: E731
    assert on_screen(one) > 0.5 and on_screen(learnt) < 0.05
    # The image the rest of the pipeline shows for the background: the clip's mean.
    assert np.abs(seq.background("cam0").astype(int)[screen] - still[screen]).mean() < 12
    shutil.rmtree(seq_path / "background" / "cam0", ignore_errors=True)
    (seq_path / "background" / "cam0.avi").unlink(missing_ok=True)
    with pytest.raises(ViewError, match=r"cam0.png: missing \(camera 'cam0'; nor is there a clip"):
        seq.backgrounds("cam0")


def test_a_hole_in_one_view_is_overruled_where_the_others_and_the_prior_agree():
    """An arm (a horizontal capsule) that one camera's silhouette misses: the strict hull
    loses it, a hull that lets one view be overruled keeps it; with a prior that covers
    only the torso, the arm stays out."""
    cams = ring(8, radius=3.0)
    torso = ((0.0, 0.0, 0.8), (0.0, 0.0, 1.4), 0.15)
    arm = ((0.15, 0.0, 1.3), (0.6, 0.0, 1.3), 0.05)
    v, f = capsule_union_mesh([torso, arm], 0.005)
    masks = _masks(cams, v, f)
    tv, tf = capsule_union_mesh([torso], 0.005)
    arm_only = [(m > 0) & ~(t > 0) for m, t in zip(masks, _masks(cams, tv, tf))]
    masks[0] = np.where(arm_only[0], 0, masks[0]).astype(np.uint8)  # one view (side-on) misses the arm
    hand = np.array([0.55, 0.0, 1.3])

    def reaches_hand(hull):
        return np.linalg.norm(hull.vertices - hand, axis=1).min() < 0.06

    assert not reaches_hand(visual_hull(masks, cams))
    assert reaches_hand(visual_hull(masks, cams, tolerance=1))
    with_body = [m > 0 for m in _masks(cams, v, f)]
    assert reaches_hand(visual_hull(masks, cams, tolerance=1, priors=with_body))
    torso_only = [m > 0 for m in _masks(cams, tv, tf)]
    assert not reaches_hand(visual_hull(masks, cams, tolerance=1, priors=torso_only))
    # Two views missing it are not overruled.
    masks[4] = np.where(arm_only[4], 0, masks[4]).astype(np.uint8)
    assert not reaches_hand(visual_hull(masks, cams, tolerance=1))
    with pytest.raises(ValueError, match="7 priors for 8 cameras"):
        visual_hull(masks, cams, tolerance=1, priors=with_body[:7])


def test_the_texture_test_sees_the_floor_through_a_shadow_but_not_through_cloth_of_its_colour(rng):
    from hullcap._guided import GuidedOptions, TextureTest

    # A tiled floor (joints darker than the tiles) with sensor noise, and a flat wall.
    h, w = 60, 80
    floor = np.full((h, w), 150.0)
    floor[::10, :] = floor[:, ::10] = 90.0
    floor = cv2.GaussianBlur(floor, (0, 0), 0.8)
    floor[:, 60:] = 150.0
    scene = np.repeat(floor[..., None], 3, 2)
    background = StatisticalBackground(np.clip(scene + rng.normal(0, 1.5, scene.shape), 0, 255).astype(np.uint8))
    options = GuidedOptions()
    test = TextureTest(background, options)

    frame = scene.copy()
    frame[10:40, 10:30] *= 0.6  # a shadow: darker, the same texture
    frame[30:55, 35:55] = floor.mean()  # cloth of the floor's mean colour, flat
    frame = np.clip(frame + rng.normal(0, 1.5, frame.shape), 0, 255).astype(np.uint8)
    evidence = test.evidence(frame)
    assert evidence.shape == (h, w) and evidence.dtype == np.float32
    # The empty scene itself: −1 where a window holds a joint, 0 inside a tile or on the wall.
    textured = test.evidence(np.clip(scene, 0, 255).astype(np.uint8)) == -1.0
    assert textured[:, :50].mean() > 0.5 and not textured[:, 64:].any()
    cloth, shadow = (slice(34, 51), slice(39, 51)), (slice(14, 36), slice(14, 26))
    assert np.all(evidence[cloth][textured[cloth]] == 1.0) and np.all(evidence[cloth][~textured[cloth]] == 0.0)
    assert np.all(evidence[shadow][textured[shadow]] == -1.0)  # still background
    assert np.all(evidence[:, 64:] == 0.0)  # no texture, no say
    roi = (slice(20, 58), slice(30, 70))
    inner = (slice(5, -5), slice(5, -5))
    assert np.array_equal(test.evidence(frame, roi)[inner], evidence[roi][inner])
    with pytest.raises(ValueError, match="texture_window"):
        GuidedOptions(texture_window=4)
    with pytest.raises(ValueError, match="texture_hidden"):
        GuidedOptions(texture_seen=0.4)


def test_the_priors_ramp_in_its_window_is_the_ramp_of_the_whole_region(rng):
    from hullcap._guided import _box, _ramp
    from hullcap._silhouette import signed_distance

    for _ in range(300):
        h, w = rng.integers(8, 120, 2)
        noise = cv2.GaussianBlur(rng.random((h, w)), (0, 0), rng.uniform(0.5, 4))
        prior = noise > np.quantile(noise, rng.uniform(0.5, 0.995))
        x, y, bw, bh = _box(prior)
        pad = int(rng.integers(0, 40))  # the region reaches the image's edge or stops short of it
        roi = (slice(max(0, y - pad), min(h, y + bh + pad)), slice(max(0, x - pad), min(w, x + bw + pad)))
        band, outer = max(1.0, rng.uniform(0.5, 12)), max(1.0, rng.uniform(0.5, 36))
        d = signed_distance(prior[roi])
        whole = np.clip(d / np.where(d > 0, np.float32(band), np.float32(outer)), -1.0, 1.0)
        assert np.array_equal(_ramp(prior, (x, y, bw, bh), roi, band, outer), whole)
        assert np.array_equal(_ramp(prior, (x, y, bw, bh), roi, band, band), np.clip(d / band, -1.0, 1.0))


def test_the_guided_band_widens_with_the_time_between_frames(tmp_path):
    from hullcap._guided import GuidedOptions
    from hullcap._tracking import Tracker

    options = GuidedOptions()
    assert options.outer == options.band
    slow = options.for_frame_rate(10)
    assert (slow.band, slow.outer) == (options.band, pytest.approx(3 * options.band))
    assert options.for_frame_rate(30) is options and options.for_frame_rate(60) is options
    for bad in (0.0, -5.0, float("nan")):
        with pytest.raises(ValueError, match="frame rate"):
            options.for_frame_rate(bad)
    for bad in ({"band_frame_rate": 0.0}, {"outer_band": -0.01}):
        with pytest.raises(ValueError, match="band_frame_rate"):
            GuidedOptions(**bad)
    # A sequence filmed at 12 frames/s is segmented, and its hull's tolerance bounded,
    # with the outer band widened by 30 / 12.
    seq = synthesize(tmp_path / "seq", "squat", 4, fps=12.0, frames=2, width=160, height=120, show_progress=False)
    tracker = Tracker(Sequence(seq))
    assert tracker.segmenter.guidance.outer == pytest.approx(2.5 * options.band)
    assert all(s.options is tracker.segmenter.guidance for s in tracker.segmenter._segmenters())


@pytest.mark.parametrize("scene_share", [0.0, 0.5])
def test_a_wall_the_colour_of_the_subjects_shirt_stays_background(scene_share, rng):
    from hullcap._guided import GuidedOptions, GuidedSegmenter

    # A grey floor below a brown panel; the person wears a brown shirt and blue trousers.
    h, w = 120, 160
    brown, blue = (40, 70, 120), (140, 60, 30)
    scene = np.full((h, w, 3), 120.0)
    scene[:25] = brown

    def noisy(img):
        return np.clip(img + rng.normal(0, 1.5, img.shape), 0, 255).astype(np.uint8)

    segmenter = GuidedSegmenter(StatisticalBackground(noisy(scene)), GuidedOptions(scene_share=scene_share))

    def frame(top):
        img, body = scene.copy(), np.zeros((h, w), bool)
        body[top:top + 70, 60:90] = True
        img[top:top + 35, 60:90] = brown
        img[top + 35:top + 70, 60:90] = blue
        return noisy(img), body

    segmenter.learn(*frame(45))  # the panel lies far from the person here
    image, body = frame(35)  # and within the guided region here
    mask = segmenter.mask(image, body) > 0
    assert mask[body].mean() > 0.95  # the shirt is the panel's colour, and the person's
    leak = mask[:25].mean()
    if scene_share:
        assert leak == 0.0
    else:  # knowing only the floor near the person, the colours call the panel subject
        assert leak > 0.1
    for share in (1.0, 1.5):
        with pytest.raises(ValueError, match="scene_share"):
            GuidedOptions(scene_share=share)


def test_a_guided_mask_is_unsure_where_it_missed_camouflage_and_sure_of_the_room_beside_it(rng):
    """What the tolerant hull may overrule: the trousers the floor's colour, which the mask
    mostly misses, and not the floor a few pixels beyond the predicted outline, where a
    view's tangent carves the phantom volume around the body."""
    from hullcap._guided import GuidedOptions, GuidedSegmenter
    from hullcap._silhouette import signed_distance

    h, w = 120, 160
    scene = np.full((h, w, 3), 120.0)

    def noisy(img):
        return np.clip(img + rng.normal(0, 1.5, img.shape), 0, 255).astype(np.uint8)

    background = StatisticalBackground(noisy(scene))
    body = np.zeros((h, w), bool)
    body[25:105, 60:90] = True
    person = scene.copy()
    person[25:65, 60:90] = (140, 60, 30)  # a blue shirt
    person[65:105, 60:90] = 121  # trousers the floor's grey
    image = noisy(person)
    outside = signed_distance(body)
    segmented = {}
    for sure in (2.0, 4.0):
        segmenter = GuidedSegmenter(background, GuidedOptions(sure_background=sure))
        segmenter.learn(image, body)
        segmented[sure] = mask, unsure = segmenter.segment(image, body)
        assert (mask[65:105, 60:90] > 0).mean() < 0.5  # the trousers are mostly missed
        assert unsure[25:105, 60:90].all()  # but nowhere for sure
    (mask, narrow), (wider_mask, wide) = segmented[2.0], segmented[4.0]
    assert not narrow[outside < -8].any()  # the room beyond the band: sure
    assert np.array_equal(mask, wider_mask)  # the mask itself does not depend on it
    assert (narrow <= wide).all() and wide.sum() > narrow.sum()
    assert GuidedSegmenter(background).segment(image, None)[1] is None  # no prior: the test alone
    with pytest.raises(ValueError, match="sure_background"):
        GuidedOptions(sure_background=-1.0)


@pytest.mark.parametrize("bins", [1, 7, 16, 41, 256])
def test_the_colour_models_log_ratio_is_the_histograms_of_each_colour(bins, rng):
    """Each pixel's colour falls in bin (level · bins) // 256 of each channel; the
    log-ratio of each colour is that of the add-one smoothed histograms, the background's
    mixed with the scene's, and follows what is learnt next."""
    from hullcap._guided import ColourModel, GuidedOptions

    scene = rng.uniform(0, 255.99, (30, 40, 3)).astype(np.float32)  # expected colours, as the segmenter has them
    model = ColourModel(bins, scene, 0.5)
    assert model.table() is None
    n = bins**3

    def index(img):
        q = img.astype(np.int64) * bins // 256  # whole grey levels
        return (q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]

    subject = np.zeros(n)
    background = np.zeros(n)
    counted_scene = np.bincount(index(scene).ravel(), minlength=n)
    for _ in range(2):  # learning again changes the ratios
        taught = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
        inside = rng.random((30, 40)) < 0.4
        model.learn(taught, inside, ~inside)
        subject += np.bincount(index(taught)[inside], minlength=n)
        background += np.bincount(index(taught)[~inside], minlength=n)
        p_subject = (subject + 1) / (subject.sum() + n)
        p_background = 0.5 * (background + 1) / (background.sum() + n) + 0.5 * counted_scene / counted_scene.sum()
        want = np.log(p_subject) - np.log(p_background)
        got = model.table()
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
        assert got.dtype == np.float32 and got.shape == (n,)
    model.clear()
    assert model.table() is None
    for bad in (0, 257):
        with pytest.raises(ValueError, match="bins"):
            GuidedOptions(bins=bad)


@pytest.mark.parametrize("bins", [1, 16, 41])
def test_the_guided_log_odds_are_numpys_sum_to_the_bit(bins, rng):
    """The engine's one pass gives the log-odds of NumPy's steps (the evidence clipped
    and split by sign, the prior's ramp, the colours' clipped log-ratio) to the bit, over
    a window of the view; a window or an array that does not fit is refused by name."""
    from hullcap._engine import guided_logit
    from hullcap.errors import RasterError

    evidence = rng.normal(0, 4, (30, 40)).astype(np.float32)  # beyond both bounds
    image = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    ramp = rng.uniform(-1, 1, (20, 25)).astype(np.float32)
    table = rng.normal(0, 3, bins**3).astype(np.float32)
    roi = (slice(6, 26), slice(10, 35))
    weights = (-3.0, FOREGROUND_EVIDENCE, 0.3, 2.0, 1.0, 4.0)
    ev = np.clip(evidence[roi], -3.0, FOREGROUND_EVIDENCE)
    plain = np.where(ev > 0, ev, 0.3 * ev) + 2.0 * ramp
    q = image[roi].astype(np.int64) * bins // 256
    coloured = plain + 1.0 * np.clip(table[(q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]], -4.0, 4.0)
    for colours, want in ((None, plain), ((table, bins), coloured)):
        got = guided_logit(evidence, image, (6, 10), ramp, weights, colours)
        assert got.dtype == np.float32 and got.shape == (20, 25)
        assert np.array_equal(got.view(np.uint32), want.astype(np.float32).view(np.uint32))
    with pytest.raises(RasterError, match="do not lie in a 40×30 image"):
        guided_logit(evidence, image, (11, 10), ramp, weights)
    with pytest.raises(RasterError, match=f"colour table of {bins**3 + 1} values"):
        guided_logit(evidence, image, (6, 10), ramp, weights, (np.append(table, 0.0), bins))
    with pytest.raises(RasterError, match="not in order"):
        guided_logit(evidence, image, (6, 10), ramp, (1.0, -1.0, 0.3, 2.0, 1.0, 4.0))
    with pytest.raises(ArrayError, match="image has the shape"):
        guided_logit(evidence, image[:, :, :1], (6, 10), ramp, weights)


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
    with pytest.raises(ValueError, match=r"image scale must be in \(0, 1\]"):
        cam.scaled(1.5)
    assert Cameras([cam]).scaled(1) is not None and Cameras([cam]).scaled(1)[0] is cam


def test_a_sequence_read_at_a_smaller_scale_checks_files_against_their_own_size(sequence, tmp_path):
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    seq = Sequence(seq_path, image_scale=0.5)
    assert "images at 0.5 of their size" in repr(seq)
    assert seq.image(1, "cam0").shape == (120, 160, 3) and seq.background("cam0").shape == (120, 160, 3)
    whole = Sequence(seq_path).image(1, "cam0")
    assert np.array_equal(seq.image(1, "cam0"), cv2.resize(whole, (160, 120), interpolation=cv2.INTER_AREA))
    cv2.imwrite(str(seq_path / "frames" / "cam1" / "000002.png"), np.zeros((120, 160, 3), np.uint8) + 50)
    with pytest.raises(ValueError, match=r"image is 160×120, camera 'cam1' is calibrated for 320×240"):
        seq.image(2, "cam1")
    # A JPEG decodes at half its size (libjpeg's reduced decoding): as the whole image
    # resized, to JPEG's own loss; a JPEG of another size is still named with its size.
    frame = seq_path / "frames" / "cam2" / "000003.png"
    ok, jpg = cv2.imencode(".jpg", cv2.imread(str(frame)), [cv2.IMWRITE_JPEG_QUALITY, 95])
    frame.unlink()
    frame.with_suffix(".jpg").write_bytes(jpg.tobytes())
    halved = seq.image(3, "cam2").astype(int)
    resized = cv2.resize(Sequence(seq_path).image(3, "cam2"), (160, 120), interpolation=cv2.INTER_AREA)
    assert halved.shape == (120, 160, 3) and np.abs(halved - resized).mean() < 1.5
    reduced = cv2.imdecode(np.frombuffer(jpg.tobytes(), np.uint8), cv2.IMREAD_REDUCED_COLOR_2)
    assert np.array_equal(halved, reduced) and not np.array_equal(halved, resized)  # decoded reduced
    ok, jpg = cv2.imencode(".jpg", np.zeros((240, 319, 3), np.uint8) + 80)
    frame.with_suffix(".jpg").write_bytes(jpg.tobytes())
    with pytest.raises(ValueError, match=r"image is 319×240, camera 'cam2' is calibrated for 320×240"):
        seq.image(3, "cam2")
    with pytest.raises(ValueError, match=r"image_scale must be in \(0, 1\]"):
        Sequence(seq_path, image_scale=2)


def _turned(cameras, index: int, degrees: float):
    """`cameras` with camera `index` turned about its viewing axis by `degrees`."""
    a = np.radians(degrees)
    roll = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    c = cameras[index]
    return Cameras([Camera(c.name, c.width, c.height, c.K, c.dist, roll @ c.R, c.t) if i == index else cam
                    for i, cam in enumerate(cameras)])


def test_the_camera_that_disagrees_is_the_one_calibrated_wrong(sequence):
    """The exact masks of the calibration pose: every view agrees; with cam1 turned by 2°
    about its axis, cam1 and cam3 (which faces it, a mirror outline) stand out and no other
    does; three views are the least that can tell."""
    from hullcap._agreement import SUSPECT_GAIN, describe_agreement, suspects, view_agreement

    cams = Sequence(sequence).cameras
    masks = [cv2.imread(str(sequence / "truth" / "silhouettes" / c.name / "000000.png"), 0) for c in cams]
    calibrated = view_agreement(masks, cams)
    assert suspects(calibrated) == [] and all(a.covered > 0.98 and a.gain < SUSPECT_GAIN / 2 for a in calibrated)
    assert "the views agree" in describe_agreement(calibrated, 0)
    turned = view_agreement(masks, _turned(cams, 1, 2.0))
    assert sorted(suspects(turned)) == ["cam1", "cam3"]
    assert "cameras 'cam3' and 'cam1' disagree with the others alike" in describe_agreement(turned, 0)
    with pytest.raises(ValueError, match="the subject is in 2 views"):
        view_agreement([masks[0], masks[1], np.zeros_like(masks[2]), np.zeros_like(masks[3])], cams)


def test_one_camera_that_disagrees_is_named_with_how_to_track_without_it():
    """The verdict for a single suspect, from figures as an 8-camera ring with one camera
    turned by 2° gives them (docs/notebooks/accuracy.md, "Views that disagree")."""
    from hullcap._agreement import ViewAgreement, describe_agreement

    gains = [0.002, 0.003, 0.033, 0.002, 0.001, 0.003, 0.011, 0.002]
    agreements = [ViewAgreement(f"cam{i}", 4000, 0.97 - (0.05 if i == 2 else 0.0), g) for i, g in enumerate(gains)]
    said = describe_agreement(agreements, 0)
    assert "camera 'cam2' disagrees with the others" in said and "track without it (--leave-out cam2)" in said


def test_calib_check_names_the_camera_and_draws_every_view(sequence, tmp_path, capsys):
    """From background subtraction: the rig as rendered agrees; one camera of a 6-camera
    ring turned by 2° is named with the one facing it (mirror outlines), and the picture
    shows every view."""
    from hullcap._cli import main

    assert main(["calib", "check", str(sequence), "--picture", str(tmp_path / "ok.png")]) == 0
    assert "the views agree" in capsys.readouterr().out
    assert main(["calib", "check", str(sequence), "--frame", "42"]) == 2
    assert "--frame 42: " in (err := capsys.readouterr().err) and "has frames 0 to 41" in err
    six = synthesize(tmp_path / "six", "demo", ring(6, radius=3.2, width=320, height_px=240, fov_deg=55),
                     subject="short", frames=1, show_progress=False)
    cams = _turned(Cameras.load(six / "cameras.json"), 2, 2.0)
    (six / "cameras.json").write_text(json.dumps({"units": "m", "cameras": [c.to_dict() for c in cams]}))
    assert main(["calib", "check", str(six)]) == 0
    said = capsys.readouterr().out
    assert "cameras 'cam2' and 'cam5' disagree with the others alike" in said
    assert "(--leave-out cam2, then --leave-out cam5), the others agree" in said
    # Checked again without each: the others agree without the camera turned, not without its mirror.
    assert main(["calib", "check", str(six), "--leave-out", "cam5", "--picture", str(tmp_path / "5.png")]) == 0
    assert "the views agree" not in capsys.readouterr().out
    assert main(["calib", "check", str(six), "--leave-out", "cam2", "--picture", str(tmp_path / "2.png")]) == 0
    assert "the views agree" in capsys.readouterr().out
    sheet = cv2.imread(str(six / "cameras_check.png"))
    assert sheet.shape == (2 * 240, 4 * 320, 3)
