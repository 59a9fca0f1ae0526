"""The visual hull: carving against brute force, blur and isosurface against SciPy and marching
cubes, tolerance and doubt."""


import cv2
import numpy as np
import pytest
from hullcap._cameras import ring
from hullcap._hull import HullReport, visual_hull
from hullcap._implicit import capsule_union_mesh, field_mesh
from hullcap._mesh import check_closed, is_closed
from hullcap._render import render_silhouette
from hullcap.errors import ArrayError
from conftest import distorted_camera


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
    with pytest.raises(ArrayError, match="voxel_size finite and > 0"):
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
