"""The exception family: each kind of fault raises its own class, a ValueError where the
input is at fault, with a message naming what is at fault; engine errors arrive mapped."""

import json

import hullcap
import numpy as np
import pytest
from hullcap import BodyModel, Sequence, errors, visual_hull
from hullcap._cameras import ring


def test_every_error_is_a_hullcap_error_and_input_errors_are_value_errors():
    for name in errors.__all__:
        cls = getattr(errors, name)
        assert issubclass(cls, errors.HullcapError)
        assert issubclass(cls, ValueError) != (cls in (errors.HullcapError, errors.EngineError)), name
    assert issubclass(errors.EngineError, RuntimeError)
    assert hullcap.HullcapError is errors.HullcapError


def test_each_kind_of_fault_raises_its_own_class(tmp_path):
    (tmp_path / "cameras.json").write_text(json.dumps({"units": "m", "cameras": [{"name": "cam0"}]}))
    with pytest.raises(errors.CalibrationError, match="cameras.json"):
        Sequence(tmp_path)
    with pytest.raises(errors.SequenceError, match="no such sequence folder"):
        Sequence(tmp_path / "nowhere")
    cams = ring(4, radius=3.0, width=64, height_px=48)
    with pytest.raises(errors.HullError, match="every mask is empty"):
        visual_hull([np.zeros((48, 64), np.uint8)] * 4, cams)
    with pytest.raises(errors.ModelError, match="model folder"):
        BodyModel.load(tmp_path / "no_model")
    with pytest.raises(errors.ResultsError, match="pose.npz"):
        (tmp_path / "out" / "model").mkdir(parents=True)
        BodyModel.template().save(tmp_path / "out" / "model")
        hullcap.load_result(tmp_path / "out")
    with pytest.raises(errors.OptionsError, match="voxel_size"):
        hullcap.TrackerOptions(voxel_size=0)
    with pytest.raises(errors.OptionsError, match="voxel_size must be a positive number, got inf"):
        hullcap.TrackerOptions(voxel_size=float("inf"))
    with pytest.raises(errors.HullError, match="voxel_size must be a positive number, got inf"):
        visual_hull([np.full((48, 64), 255, np.uint8)] * 4, cams, voxel_size=float("inf"))
    with pytest.raises(errors.HullError, match=r"voxel_size 1e-05 m gives .* voxels along the capture volume"):
        visual_hull([np.full((48, 64), 255, np.uint8)] * 4, cams, voxel_size=1e-5)
    with pytest.raises(errors.OptionsError, match="FitOptions.solver"):
        hullcap.FitOptions().replace(solver="newton")
    with pytest.raises(errors.OptionsError, match="FitOptions.coarse"):
        hullcap.FitOptions().replace(coarse=0)
    with pytest.raises(errors.OptionsError, match="FitOptions.over_relaxation must be at least 1 and below 2"):
        hullcap.FitOptions().replace(over_relaxation=2.0)


def test_engine_errors_arrive_as_their_kind():
    with pytest.raises(errors.FitError, match="zero points"):
        hullcap.NormalKDTree(np.zeros((0, 3)), np.zeros((0, 3)))
    with pytest.raises(errors.FitError, match=r"normals\[1\] is not finite"):
        hullcap.NormalKDTree(np.zeros((2, 3)), [[0, 0, 1], [np.nan, 0, 1]])
    model = BodyModel.template()
    links, groups = model.link_model.all_segments()
    with pytest.raises(errors.ModelError, match="not finite"):  # a vertex at infinity
        vertices = model.vertices.copy()
        vertices[3] = np.inf
        hullcap.skin_weights(vertices, model.faces, links, groups=groups)
    with pytest.raises(errors.ModelError, match="not a rotation"):
        model.pose(np.zeros(model.n_dofs), 2 * np.eye(3), np.zeros(3))
    with pytest.raises(errors.ArrayError, match=r"points must have shape \(N, 3\)"):
        hullcap.NormalKDTree(np.zeros((4, 2)), np.zeros((4, 3)))
    with pytest.raises(errors.ArrayError, match="faces.* outside"):
        hullcap.skin_weights(model.vertices, model.faces + len(model.vertices), links, groups=groups)
    with pytest.raises(errors.ArrayError, match="k must be at least 1"):
        hullcap.NormalKDTree(np.zeros((4, 3)), np.ones((4, 3))).query_k(np.zeros((1, 3)), np.ones((1, 3)), 0)
    from hullcap._engine import coverage

    triangle = np.array([[1.0, 1.0, 2.0], [8.0, 1.0, 2.0], [1.0, 8.0, 2.0]])
    assert coverage(triangle, [[0, 1, 2]], 10, 10).sum() > 0
    with pytest.raises(errors.ArrayError, match="faces.* outside"):
        coverage(triangle, [[0, 1, 3]], 10, 10)
    with pytest.raises(errors.ArrayError, match="width"):
        coverage(triangle, [[0, 1, 2]], 0, 10)
    with pytest.raises(errors.RasterError, match="image size 20000×10 is not allowed"):
        coverage(triangle, [[0, 1, 2]], 20000, 10)


def test_counts_out_of_all_reason_are_refused_not_a_crash():
    """Each of these once aborted the interpreter, hung or raised a builtin exception that
    named no argument (a sweep of the engine's calls with hostile values, 2026-11-28)."""
    from hullcap._engine import guided_logit

    tree = hullcap.NormalKDTree(np.random.default_rng(0).random((30, 3)), np.ones((30, 3)))
    # 2 × 2^40 answers: asked of the allocator, it aborted the process.
    with pytest.raises(errors.FitError, match="2 queries of 1099511627776 answers each do not fit in memory"):
        tree.query_k(np.zeros((2, 3)), np.ones((2, 3)), 2**40)
    # Past the tree's size the answers are padding; the search keeps only what exists.
    index, distance = tree.query_k(np.zeros((2, 3)), np.ones((2, 3)), 1000)
    assert (index[:, 30:] == -1).all() and np.isinf(distance[:, 30:]).all() and (index[:, :30] >= 0).all()
    with pytest.raises(errors.OptionsError, match="FitOptions.iterations cannot be -1"):
        hullcap.FitOptions(iterations=-1)
    with pytest.raises(errors.OptionsError, match="FitOptions.rounds cannot be 1000000000000000000000"):
        hullcap.FitOptions().replace(rounds=10**21)
    with pytest.raises(TypeError, match="FitOptions.threads cannot be two"):
        hullcap.FitOptions(threads="two")
    image, evidence = np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4), np.float32)
    with pytest.raises(errors.ArrayError, match=r"origin\[0\] must be at least 0, got -1"):
        guided_logit(evidence, image, (-1, 0), np.zeros((2, 2), np.float32), (0, 1, 1, 1, 1, 1))


def test_normals_of_any_finite_non_zero_length_are_directions():
    """A normal whose squares overflow (or underflow) a double is still a direction."""
    rng = np.random.default_rng(1)
    points, normals = rng.random((50, 3)), rng.normal(size=(50, 3))
    queries, query_normals = rng.random((20, 3)), rng.normal(size=(20, 3))
    want = hullcap.NormalKDTree(points, normals).query(queries, query_normals)
    for scale in (1e300, 1e-300):
        tree = hullcap.NormalKDTree(points, normals * scale)
        index, distance = tree.query(queries, query_normals * scale)
        np.testing.assert_array_equal(index, want[0])
        np.testing.assert_allclose(distance, want[1], rtol=1e-12)
    with pytest.raises(errors.FitError, match=r"normals\[0\] has zero length"):
        hullcap.NormalKDTree(points[:1], np.zeros((1, 3)))


def test_small_arrays_of_an_argument_are_read_from_anything_numpy_reads():
    """A shape's shifts and a root pose as lists, or of the wrong size: the lists were an
    AttributeError ('list' has no 'reshape'), an empty shift NumPy's own ValueError."""
    from hullcap._engine import Shape

    model = BodyModel.template()
    shape = Shape(model._rig, [[]], [[(0, [0.0, 0.0, 0.01])]], [[]])
    centres, _ = shape.rest([1.0])
    np.testing.assert_allclose(centres - shape.rest([0.0])[0], np.tile([0.0, 0.0, 0.01], (len(centres), 1)))
    with pytest.raises(errors.ArrayError, match="shape shift must be 3 values"):
        Shape(model._rig, [[]], [[(0, np.array([]))]], [[]])
    with pytest.raises(errors.ArrayError, match="root_rotation must be a 3×3 matrix"):
        model._rig.pose(np.zeros(model.n_dofs).tolist(), [[1.0, 0.0], [0.0, 1.0]])
    vertices, *_ = model._rig.pose(np.zeros(model.n_dofs).tolist(), np.eye(3).tolist(), [0.0, 0.0, 1.0])
    np.testing.assert_allclose(vertices, model.pose(np.zeros(model.n_dofs), np.eye(3), [0.0, 0.0, 1.0]).vertices)


def test_the_python_calls_take_what_a_user_passes_first(tmp_path):
    """A tracker given a folder's path instead of a Sequence (an AttributeError on 'str'
    before), a subject built from an empty or non-finite hull (NumPy's own ValueError)."""
    from hullcap._mesh import Surface

    with pytest.raises(errors.SequenceError, match="no such sequence folder"):
        hullcap.Tracker(str(tmp_path / "nowhere"))
    cams = ring(4, radius=3.0, width=64, height_px=48)
    (tmp_path / "cameras.json").write_text(json.dumps({"units": "m", "cameras": [c.to_dict() for c in cams]}))
    (tmp_path / "meta.json").write_text(json.dumps({"fps": 30, "frames": 1}))
    for cam in cams:
        (tmp_path / "frames" / cam.name).mkdir(parents=True)
    assert isinstance(hullcap.Tracker(tmp_path).sequence, Sequence)
    with pytest.raises(TypeError, match="for the file '.*cameras.json' use Cameras.load"):
        visual_hull([np.zeros((48, 64), np.uint8)] * 4, str(tmp_path / "cameras.json"))
    with pytest.raises(TypeError, match="Cameras takes Camera objects, got a dict"):
        hullcap.Cameras([c.to_dict() for c in cams])
    with pytest.raises(errors.FitError, match="hull 0 is empty"):
        hullcap.build_subject(Surface(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3))))
    with pytest.raises(errors.FitError, match="hull 0 is not finite"):
        hullcap.build_subject(Surface(np.full((4, 3), np.nan), np.zeros((0, 3), np.int64), np.ones((4, 3))))


def test_the_engine_stub_names_every_public_function_of_the_engine():
    """``_engine.pyi``'s ``__all__`` is the extension's public names, no more, no less."""
    import ast
    from pathlib import Path

    import hullcap._engine as engine

    stub = ast.parse((Path(hullcap.__file__).parent / "_engine.pyi").read_text())
    (listed,) = [node.value for node in stub.body if isinstance(node, ast.Assign)
                 and getattr(node.targets[0], "id", None) == "__all__"]
    named = {element.value for element in listed.elts} - {"__version__"}
    assert named == {name for name in dir(engine) if not name.startswith("_")}
