"""The engine's calls under hostile arguments (Hypothesis): arrays of any small shape and
of several dtypes, holding NaN, ±inf, 1e300 or denormals, and counts from −1 up, either
return or raise an exception of the hullcap family — never ``EngineError`` (a panic
caught at the boundary: an engine bug), never another exception, never a crash.

Counts are drawn up to 10⁵ (a count past all memory is a case of its own, in
test_errors.py), arrays up to 5 along each side, so that the module runs in seconds.
CI runs a fixed set (derandomized); HULLCAP_FUZZ_EXAMPLES=2000 explores further.
"""

import os

import numpy as np
import pytest
from hullcap import BodyModel, _engine
from hullcap.errors import EngineError, HullcapError
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

EXAMPLES = int(os.environ.get("HULLCAP_FUZZ_EXAMPLES", "40"))
# NumPy warns of the casts hostile values make (NaN to an integer, 1e300 to float32).
pytestmark = pytest.mark.filterwarnings("ignore:.*encountered in cast:RuntimeWarning")
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), database=None,
                derandomize="HULLCAP_FUZZ_EXAMPLES" not in os.environ)

HOSTILE = [np.nan, np.inf, -np.inf, 1e300, -1e300, 5e-324, 0.0, -0.0]
REALS = st.one_of(st.sampled_from(HOSTILE), st.floats(-10, 10))
COUNTS = st.one_of(st.sampled_from([-1, 0, 1, 2, 3]), st.integers(-2**40, 10**5))
DTYPES = st.sampled_from([np.float64, np.float32, np.int64, np.uint8, np.bool_])


def arrays(shape=None, min_dims=0, max_dims=3):
    """Arrays of a given or any small shape, real values hostile or not, in any dtype (an
    integer dtype takes the finite values; NaN and inf have no integer)."""
    shapes = hnp.array_shapes(min_dims=min_dims, max_dims=max_dims, min_side=0, max_side=5) if shape is None \
        else st.just(shape)

    def cast(args):
        values, dtype = args
        if np.dtype(dtype).kind in "iub":
            values = np.nan_to_num(values, nan=0.0, posinf=1.0, neginf=-1.0).clip(-1e6, 1e6)
        return values.astype(dtype)

    return st.tuples(shapes.flatmap(lambda s: hnp.arrays(np.float64, s, elements=REALS)), DTYPES).map(cast)


def shaped(shape):
    """Arrays of `shape` three times in four (hostile values the calls must read), of any
    small shape otherwise (what they must refuse)."""
    right = arrays(shape)
    return st.one_of(right, right, right, arrays())


def rows3():
    """(N, 3) arrays three times in four, of any small shape otherwise."""
    right = st.integers(0, 5).flatmap(lambda k: arrays((k, 3)))
    return st.one_of(right, right, right, arrays())


def survives(call):
    """Runs `call`: it returns, or raises a hullcap error or a TypeError (an argument of
    the wrong kind); an EngineError or anything else fails the test."""
    try:
        call()
    except EngineError:
        raise
    except (HullcapError, TypeError):
        pass


@FUZZ
@given(rows3(), rows3(), st.one_of(st.none(), REALS), COUNTS, rows3(), rows3(), REALS, REALS, COUNTS)
def test_the_kd_tree(points, normals, weight, leaf, queries, query_normals, max_distance, max_angle, k):
    try:
        tree = _engine.NormalKDTree(points, normals, weight, leaf)
    except (HullcapError, TypeError):
        return
    survives(lambda: tree.query(queries, query_normals, max_distance, max_angle))
    survives(lambda: tree.query_k(queries, query_normals, min(k, 10**4), max_distance, max_angle, threads=2))
    survives(lambda: _engine.Target(points, normals, weight))


@FUZZ
@given(rows3(), arrays(), COUNTS, COUNTS, REALS, st.booleans())
def test_rasterising(vertices, faces, width, height, near, closed):
    size = (min(width, 200), min(height, 200))
    survives(lambda: _engine.rasterize(vertices, faces, *size, near))
    survives(lambda: _engine.coverage(vertices, faces, *size, near, closed=closed))


def views(images):
    """Carving views of hostile calibrations over the drawn images."""
    camera = st.tuples(shaped((3, 3)), shaped((5,)), shaped((3, 3)), shaped((3,)), REALS)
    return st.lists(st.tuples(camera, images, st.one_of(st.none(), images)), max_size=3).map(
        lambda vs: [(*cam, signed, prior) for cam, signed, prior in vs])


@FUZZ
@given(rows3(), REALS, views(shaped((6, 5))), COUNTS, COUNTS, shaped((3,)), REALS,
       st.lists(st.integers(-1, 12), min_size=3, max_size=3), st.integers(-1, 6))
def test_carving(centres, radius, carve_views, tolerance, min_views, lo, voxel, fine, levels):
    survives(lambda: _engine.classify_cells(centres, radius, carve_views, tolerance, min_views))
    survives(lambda: _engine.carve(lo, voxel, fine, levels, carve_views, tolerance, min_views))
    masks = [(k, d, r, t, np.asarray(s).astype(np.uint8) if np.asarray(s).ndim == 2 else s, None)
             for k, d, r, t, _, s, _ in carve_views]
    survives(lambda: _engine.doubtful_points(centres, masks, min_views))


@FUZZ
@given(shaped((4, 5, 3)), shaped((8, 4, 5)), st.tuples(REALS, REALS, REALS, REALS), shaped((2, 3)),
       st.tuples(st.integers(-1, 5), st.integers(-1, 5)),
       st.tuples(*[REALS] * 6), st.one_of(st.none(), st.tuples(arrays(max_dims=1), COUNTS)))
def test_the_silhouettes_pixel_tests(image, planes, rule, ramp, origin, weights, colours):
    survives(lambda: _engine.background_evidence(image, planes, rule))
    survives(lambda: _engine.background_distortions(image, planes))
    evidence = planes[0] if planes.ndim == 3 and len(planes) else planes
    survives(lambda: _engine.guided_logit(evidence, image, origin, ramp, weights, colours))


@FUZZ
@given(shaped((4, 3, 5)), REALS)
def test_the_hulls_surface(values, level):
    survives(lambda: _engine.gaussian_blur(values, level))
    survives(lambda: _engine.isosurface(values, level))


@FUZZ
@given(rows3(), shaped((2, 3)), shaped((2, 2, 3)), REALS, COUNTS,
       st.one_of(st.none(), st.lists(COUNTS, max_size=4)))
def test_skin_weights(vertices, faces, links, b, k, groups):
    survives(lambda: _engine.skin_weights(vertices, faces, links, b, min(k, 10**4), groups))
    survives(lambda: _engine.link_distances(vertices, faces, links))


@pytest.fixture(scope="module")
def template():
    return BodyModel.template()


@FUZZ
@given(st.one_of(st.lists(REALS, min_size=29, max_size=29), st.lists(REALS, max_size=31)), shaped((3, 3)),
       shaped((3,)), rows3(), rows3(),
       st.one_of(st.none(), st.lists(COUNTS, max_size=3)), st.integers(0, 3))
def test_posing_and_fitting(template, theta, rotation, translation, points, normals, model_points, iterations):
    rig = template._rig
    survives(lambda: rig.pose(theta, rotation, translation))
    survives(lambda: rig.jacobian(theta, rotation, translation))
    try:
        target = _engine.Target(points, normals)
    except (HullcapError, TypeError):
        return
    options = _engine.FitOptions(iterations=max(iterations, 1), rounds=1)
    survives(lambda: _engine.fit(rig, target, theta, rotation, translation, [[0], [1, 2]], options, model_points))
    survives(lambda: _engine.evaluate(rig, target, [theta], [rotation], [translation], options, model_points))


@FUZZ
@given(st.lists(st.integers(-2, 3), max_size=4), rows3(), st.lists(st.integers(-1, 4), max_size=3), rows3(),
       shaped((2, 2)), rows3(), rows3(), shaped((5, 1)), shaped((5, 1)))
def test_building_a_rig(parents, origins, dof_links, axes, limits, vertices, normals, weight_links, weights):
    survives(lambda: _engine.link_tree_problem(parents, origins, dof_links, axes, limits))
    survives(lambda: _engine.Rig(parents, origins, dof_links, axes, limits, vertices, normals,
                                 np.asarray(weight_links).astype(np.int64), weights))


@FUZZ
@given(st.lists(st.tuples(st.integers(-2, 30), shaped((3, 3))), max_size=2),
       st.lists(st.tuples(st.integers(-2, 30), shaped((3,))), max_size=2), st.lists(REALS, max_size=2),
       st.lists(REALS, max_size=2), REALS, rows3(), rows3(), st.integers(1, 2))
def test_fitting_a_shape(template, stretches, shifts, initial, sigma, distance, points, normals, iterations):
    try:
        shape = _engine.Shape(template._rig, [stretches], [shifts], [[]])
    except (HullcapError, TypeError):
        return
    survives(lambda: shape.rest(initial))
    survives(lambda: shape.map_points(initial, [0, 1], points))
    try:
        target = _engine.Target(points, normals)
    except (HullcapError, TypeError):
        return
    zeros = [0.0] * template.n_dofs
    options = _engine.FitOptions(iterations=iterations, rounds=1)
    survives(lambda: _engine.fit_shape(shape, initial, [target], [zeros], [np.eye(3)], [np.zeros(3)], sigma,
                                       distance, options))
