"""Parsers under fuzzing (Hypothesis): any bytes given as cameras.json, a sequence's
meta.json, an EasyMocap or Pose2Sim calibration, links.json, a body model's mesh.npz,
pose.npz, problems.json, a TRC file (the reference of ``hullcap compare``), a motion
file (``angles.mot``) or a JPEG frame read at half its size either load or raise an
exception of the hullcap family (hullcap.errors.HullcapError), never another one.

Inputs are random bytes, valid files with bytes changed, cut or inserted, (for the JSON
formats) valid documents with one value replaced by arbitrary JSON, and (for mesh.npz
and pose.npz) a valid archive with one array replaced by an arbitrary small one. The
number of examples is bounded so that the whole module runs in well under a minute.
"""

import atexit
import io
import json
import os
import shutil
import tempfile
from pathlib import Path

import cv2
import numpy as np
from hullcap import BodyModel
from hullcap._cameras import Cameras, ring
from hullcap._links import LinkModel
from hullcap._problems import ProblemLog
from hullcap.export import load_result
from hullcap._sequence import Sequence
from hullcap.errors import HullcapError
from hullcap.export import angle_table, read_mot, read_trc, write_mot, write_trc
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

# CI runs a fixed, reproducible set (derandomized); HULLCAP_FUZZ_EXAMPLES=5000 explores further.
EXAMPLES = int(os.environ.get("HULLCAP_FUZZ_EXAMPLES", "60"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow], database=None,
                derandomize="HULLCAP_FUZZ_EXAMPLES" not in os.environ)

JSON = st.recursive(st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True)
                    | st.text(max_size=8),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
                    max_leaves=12)


def mutated(valid: bytes):
    """Strategy: `valid` with some bytes replaced, a cut, an insertion — or random bytes."""
    edits = st.lists(st.tuples(st.integers(0, max(0, len(valid) - 1)), st.integers(0, 255)), max_size=8)

    def apply(args):
        changes, cut, insert_at, inserted = args
        data = bytearray(valid)
        for pos, value in changes:
            data[pos] = value
        data[insert_at:insert_at] = inserted
        return bytes(data[:cut])

    return st.one_of(
        st.binary(max_size=200),
        st.tuples(edits, st.integers(0, len(valid) + 16), st.integers(0, len(valid)), st.binary(max_size=8)).map(apply),
    )


def with_one_value_replaced(doc):
    """Strategy: the JSON document `doc` with one value somewhere in it replaced by any JSON."""
    paths = []

    def walk(node, path):
        paths.append(path)
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
        for k, v in items:
            walk(v, path + (k,))

    walk(doc, ())

    def replace(args):
        path, value = args
        if not path:
            return json.dumps(value).encode()
        copy = json.loads(json.dumps(doc))
        node = copy
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
        return json.dumps(copy).encode()

    return st.tuples(st.sampled_from(paths), JSON).map(replace)


def loads_or_hullcap_error(load, data: bytes, name: str):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        try:
            load(path)
        except HullcapError:
            pass


CAMERAS = ring(2, width=64, height_px=48)
CAMERAS_JSON = {"units": "m", "cameras": [c.to_dict() for c in CAMERAS]}


@FUZZ
@given(st.one_of(mutated(json.dumps(CAMERAS_JSON).encode()), with_one_value_replaced(CAMERAS_JSON)))
def test_cameras_json(data):
    loads_or_hullcap_error(Cameras.load, data, "cameras.json")


def written(write) -> bytes:
    """The bytes `write(path)` puts in a file."""
    with tempfile.TemporaryDirectory() as tmp:
        write(Path(tmp) / "file")
        return (Path(tmp) / "file").read_bytes()


def _trc(path):
    joints = np.arange(2 * 3 * 3, dtype=float).reshape(2, 3, 3) / 10
    joints[1, 2] = np.nan
    write_trc(path, ["pelvis", "neck", "l_hip"], joints, 30.0)


TRC = written(_trc)


@FUZZ
@given(mutated(TRC))
def test_trc(data):
    loads_or_hullcap_error(read_trc, data, "joints.trc")


def _mot(path):
    theta = np.arange(3 * 2, dtype=float).reshape(3, 2) / 10
    theta[1] = np.nan
    write_mot(path, *angle_table(["a", "b"], theta, np.zeros((3, 3)), np.tile(np.eye(3), (3, 1, 1)), 30.0))


MOT = written(_mot)


@FUZZ
@given(mutated(MOT))
def test_mot(data):
    loads_or_hullcap_error(read_mot, data, "angles.mot")


def _jpeg_sequence() -> tuple[Path, bytes]:
    """A one-camera sequence folder whose frame is a JPEG, for reading it reduced."""
    folder = Path(tempfile.mkdtemp())
    atexit.register(shutil.rmtree, folder, True)
    Cameras(ring(1, width=64, height_px=48)).save(folder / "cameras.json")
    (folder / "meta.json").write_text('{"fps": 30, "frames": 1}')
    (folder / "frames" / "cam0").mkdir(parents=True)
    ok, jpg = cv2.imencode(".jpg", np.random.default_rng(1).integers(0, 255, (48, 64, 3), dtype=np.uint8))
    return folder, jpg.tobytes()


JPEG_SEQUENCE, JPEG = _jpeg_sequence()


@FUZZ
@given(mutated(JPEG))
def test_a_jpeg_frame_read_at_half_its_size(data):
    """A frame's bytes, changed: read at half its size (its header parsed, then decoded
    reduced) it is an image of the scaled camera's size or a ViewError, never another
    exception."""
    (JPEG_SEQUENCE / "frames" / "cam0" / "000000.jpg").write_bytes(data)
    seq = Sequence(JPEG_SEQUENCE, image_scale=0.5)
    try:
        assert seq.image(0, 0).shape == (24, 32, 3)
    except HullcapError:
        pass


LINKS = LinkModel.standard().to_dict()


PROBLEMS = {"problems": [{"frame": 3, "camera": "cam1", "file": "frames/cam1/000003.jpg", "what": "unreadable"},
                         {"frame": None, "camera": None, "file": None, "what": "meta.json says 9 frames"}]}


@FUZZ
@given(st.one_of(mutated(json.dumps(PROBLEMS).encode()), with_one_value_replaced(PROBLEMS)))
@example(b'{"problems": [{"frame": [], "camera": null, "file": null, "what": "x"}]}')
@example(b'{"problems": [{"frame": 1, "camera": 5, "file": null, "what": "x"}, '
         b'{"frame": 2, "camera": "c", "file": null, "what": "y"}]}')
def test_problems_json(data):
    """A resumed run takes the problems back and sums them up at its end: what loads must
    serve both."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "problems.json"
        path.write_bytes(data)
        try:
            problems = ProblemLog.load(path)
        except HullcapError:
            return
        log = ProblemLog(warn=False)
        log.extend(problems)
        assert log.summary()


META = {"fps": 30, "frames": 3}


@FUZZ
@given(st.one_of(mutated(json.dumps(META).encode()), with_one_value_replaced(META)))
@example(b'{"fps": 30, "frames": Infinity}')
@example(b'{"fps": 1e400, "frames": 3}')
@example(b'{"fps": 1, "frames": 1e20}')
@example(b'{"fps": 30, "frames": 1' + b"0" * 400 + b"}")
def test_meta_json(data):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "cameras.json").write_text(json.dumps(CAMERAS_JSON))
        for cam in CAMERAS:
            (tmp / "frames" / cam.name).mkdir(parents=True)
        (tmp / "meta.json").write_bytes(data)
        try:
            seq = Sequence(tmp)
        except HullcapError:
            return
        assert 0 < seq.fps < np.inf and len(seq) >= 1


@FUZZ
@given(st.one_of(mutated(json.dumps(LINKS).encode()), with_one_value_replaced(LINKS)))
def test_links_json(data):
    loads_or_hullcap_error(LinkModel.load, data, "links.json")


def _easymocap_files() -> tuple[bytes, bytes]:
    intri = "%YAML:1.0\n---\nnames:\n   - \"c0\"\nK_c0: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n" \
            "   data: [ 50., 0., 31.5, 0., 50., 23.5, 0., 0., 1. ]\nH_c0: 48\nW_c0: 64\n"
    extri = "%YAML:1.0\n---\nnames:\n   - \"c0\"\nRot_c0: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n" \
            "   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\nT_c0: !!opencv-matrix\n   rows: 3\n   cols: 1\n" \
            "   dt: d\n   data: [ 0., 0., 3. ]\n"
    return intri.encode(), extri.encode()


INTRI, EXTRI = _easymocap_files()


@FUZZ
@given(mutated(INTRI), mutated(EXTRI))
def test_easymocap(intri, extri):
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "intri.yml").write_bytes(intri)
        (Path(tmp) / "extri.yml").write_bytes(extri)
        try:
            Cameras.from_easymocap(Path(tmp) / "intri.yml", Path(tmp) / "extri.yml")
        except HullcapError:
            pass


POSE2SIM = (b'[cam_01]\nname = "cam_01"\nsize = [ 64.0, 48.0,]\n'
            b"matrix = [ [ 50.0, 0.0, 31.5,], [ 0.0, 50.0, 23.5,], [ 0.0, 0.0, 1.0,],]\n"
            b"distortions = [ 0.0, 0.0, 0.0, 0.0,]\nrotation = [ 0.1, 0.2, 0.3,]\n"
            b"translation = [ 0.0, 0.0, 3.0,]\nfisheye = false\n\n[metadata]\nadjusted = false\nerror = 0.0\n")


@FUZZ
@given(mutated(POSE2SIM))
def test_pose2sim(data):
    loads_or_hullcap_error(Cameras.from_pose2sim, data, "Calib.toml")


def _pose_npz() -> bytes:
    frames = 3
    buf = io.BytesIO()
    np.savez(buf, root_translation=np.zeros((frames, 3)), root_rotation=np.tile(np.eye(3), (frames, 1, 1)),
             theta=np.zeros((frames, 29)), failed=np.zeros(frames, bool), iterations=np.zeros(frames, int),
             fps=np.array(30.0))
    return buf.getvalue()


POSE = _pose_npz()
MODEL = tempfile.mkdtemp(prefix="hullcap-fuzz-model-")
atexit.register(shutil.rmtree, MODEL, ignore_errors=True)
BodyModel.template().save(MODEL)
MESH = (Path(MODEL) / "mesh.npz").read_bytes()
with np.load(io.BytesIO(MESH)) as _z:
    MESH_ARRAYS = {k: _z[k] for k in _z.files}
ANY_ARRAY = hnp.arrays(st.sampled_from([np.float64, np.int32, np.int64, np.bool_, np.dtype("U3")]),
                       hnp.array_shapes(min_dims=0, max_dims=2, min_side=0, max_side=4))


def model_loads_or_hullcap_error(mesh: bytes):
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copy(Path(MODEL) / "links.json", Path(tmp) / "links.json")
        (Path(tmp) / "mesh.npz").write_bytes(mesh)
        try:
            BodyModel.load(tmp)
        except HullcapError:
            pass


@FUZZ
@given(mutated(MESH))
def test_mesh_npz(data):
    model_loads_or_hullcap_error(data)


@FUZZ
@given(st.sampled_from(sorted(MESH_ARRAYS)), ANY_ARRAY)
def test_mesh_npz_with_one_array_replaced(name, value):
    buf = io.BytesIO()
    np.savez(buf, **{**MESH_ARRAYS, name: value})
    model_loads_or_hullcap_error(buf.getvalue())


with np.load(io.BytesIO(POSE)) as _z:
    POSE_ARRAYS = {k: _z[k] for k in _z.files}


@FUZZ
@given(st.sampled_from(sorted(POSE_ARRAYS)), ANY_ARRAY)
@example("fps", np.array([30.0, 30.0]))
@example("failed", np.zeros(5, bool))
def test_pose_npz_with_one_array_replaced(name, value):
    """What loads is whole: every frame's pose and joints are there to read."""
    buf = io.BytesIO()
    np.savez(buf, **{**POSE_ARRAYS, name: value})
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copytree(MODEL, Path(tmp) / "model")
        (Path(tmp) / "pose.npz").write_bytes(buf.getvalue())
        try:
            result = load_result(tmp)
        except HullcapError:
            return
        assert result.joints.shape[0] == len(result.failed) == len(result.theta)


@FUZZ
@given(mutated(POSE))
def test_pose_npz(data):
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copytree(MODEL, Path(tmp) / "model")
        (Path(tmp) / "pose.npz").write_bytes(data)
        try:
            load_result(tmp)
        except HullcapError:
            pass


def test_the_valid_files_load():
    """The seeds of the fuzzing are valid: the fuzz tests start from loadable files."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "cameras.json").write_text(json.dumps(CAMERAS_JSON))
        assert len(Cameras.load(tmp / "cameras.json")) == 2
        (tmp / "links.json").write_text(json.dumps(LINKS))
        assert LinkModel.load(tmp / "links.json").n_dofs == 29
        (tmp / "intri.yml").write_bytes(INTRI)
        (tmp / "extri.yml").write_bytes(EXTRI)
        assert Cameras.from_easymocap(tmp / "intri.yml", tmp / "extri.yml").names == ["c0"]
        (tmp / "Calib.toml").write_bytes(POSE2SIM)
        assert Cameras.from_pose2sim(tmp / "Calib.toml").names == ["cam_01"]
        shutil.copytree(MODEL, tmp / "model")
        assert len(BodyModel.load(tmp / "model").vertices) == len(MESH_ARRAYS["vertices"])
        (tmp / "pose.npz").write_bytes(POSE)
        assert len(load_result(tmp).failed) == 3
