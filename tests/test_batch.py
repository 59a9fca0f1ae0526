"""hullcap batch: a session's takes on Ray give the files hullcap track gives for each
take alone; failures are retried once and reported; a re-run skips finished takes."""

import csv
from pathlib import Path

import pytest
import ray
from hullcap._cameras import ring
from hullcap._cli import main
from hullcap._session import load_session
from hullcap._synth import synthesize
from hullcap.errors import SessionError

SESSION_TOML = """\
[defaults]
overlays = false
refine_joints = false

[subjects]
anna = "anna_static"

[takes]
anna_squat = "anna"
ben_kick = {}
"""


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """Three small takes of two people: anna's calibration take and a squat tracked with
    its model, and ben's kick, which builds its own."""
    root = tmp_path_factory.mktemp("batch") / "session"
    cams = ring(6, radius=3.2, width=400, height_px=300, fov_deg=55)
    for name, motion, subject in [("anna_static", "demo", "short"), ("anna_squat", "squat", "short"),
                                  ("ben_kick", "kick", "tall")]:
        synthesize(root / name, motion, cams, subject=subject, frames=5, silhouettes=True, show_progress=False)
    (root / "session.toml").write_text(SESSION_TOML)
    return root


def test_a_batch_on_ray_gives_what_track_gives_for_each_take(session, tmp_path, capsys):
    out = tmp_path / "out"
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        assert main(["batch", str(session), "--out", str(out)]) == 0
    finally:
        ray.shutdown()
    said = capsys.readouterr().out
    assert "Ray (2 CPUs, 1 per take)" in said and "3 of 3 takes done" in said
    assert sorted(p.name for p in out.iterdir()) == ["anna_squat", "anna_static", "ben_kick", "summary.csv"]
    for take in ["anna_static", "anna_squat", "ben_kick"]:
        alone = ["track", str(session / take), "--out", str(tmp_path / "alone" / take), "--no-overlays",
                 "--no-refine-joints"]
        if take == "anna_squat":
            alone += ["--model", str(out / "anna_static" / "model")]
        assert main(alone) == 0
        assert (out / take / "joints.csv").read_bytes() == (tmp_path / "alone" / take / "joints.csv").read_bytes()
    with open(out / "summary.csv") as f:
        rows = {row["take"]: row for row in csv.DictReader(f)}
    assert {take: (row["frames"], row["lost"], row["state"]) for take, row in rows.items()} == {
        take: ("5", "0", "tracked") for take in ["anna_static", "anna_squat", "ben_kick"]}

    # A re-run skips the finished takes and leaves their files alone.
    stamp = (out / "ben_kick" / "joints.csv").stat().st_mtime_ns
    capsys.readouterr()
    assert main(["batch", str(session), "--out", str(out), "--sequential"]) == 0
    said = capsys.readouterr().out
    assert "3 done before" in said and said.count("done before") == 4  # the header and three rows
    assert (out / "ben_kick" / "joints.csv").stat().st_mtime_ns == stamp


def test_a_failed_take_is_tried_again_once_then_reported_and_its_subject_skipped(tmp_path, capsys):
    session = tmp_path / "session"
    for take in ["x_static", "x_walk"]:
        (session / take).mkdir(parents=True)
        (session / take / "cameras.json").write_text("{not json")
    (session / "session.toml").write_text('[subjects]\nx = "x_static"\n[takes]\nx_walk = "x"\n')
    out = tmp_path / "out"
    assert main(["batch", str(session), "--out", str(out), "--sequential"]) == 1
    said = capsys.readouterr().out
    assert said.count("x_static: failed (CalibrationError") == 1 and "trying once more" in said
    with open(out / "summary.csv") as f:
        rows = {row["take"]: row["state"] for row in csv.DictReader(f)}
    assert rows["x_static"].startswith("failed: CalibrationError") and "cameras.json" in rows["x_static"]
    assert rows["x_walk"] == "skipped: the take of its model, x_static, failed"
    assert not (out / "x_static").exists() and not (out / ".partial").exists()

    # Someone else's folder in the way of a take is not taken for a finished one.
    (out / "x_static").mkdir()
    assert main(["batch", str(session), "--out", str(out), "--sequential"]) == 2
    assert "not a take this batch finished (no readable take.json)" in capsys.readouterr().err


def _session(tmp_path, toml, takes=("a", "b")):
    for take in takes:
        (tmp_path / take).mkdir()
        (tmp_path / take / "cameras.json").write_text("{}")
    if toml is not None:
        (tmp_path / "session.toml").write_text(toml)
    return tmp_path


def test_a_session_without_session_toml_is_every_sequence_folder(tmp_path):
    (tmp_path / "notes").mkdir()
    takes = load_session(_session(tmp_path, None))
    assert [(t.name, t.subject, t.calibration) for t in takes] == [("a", None, None), ("b", None, None)]


def test_session_toml_gives_subjects_and_options_calibration_takes_first(tmp_path):
    takes = load_session(_session(tmp_path, '[defaults]\nvoxel_size = 0.02\n[subjects]\np = "b"\n'
                                            '[takes]\na = { subject = "p", frames = 7 }\n'
                                            'b = { frames = 9, image_scale = 0.5, leave_out = ["cam3"] }\n'))
    assert [(t.name, t.subject, t.calibration, t.options.tracking.voxel_size, t.options.frames, t.options.image_scale,
             t.options.leave_out) for t in takes] == [("b", "p", None, 0.02, 9, 0.5, ("cam3",)),
                                                      ("a", "p", "b", 0.02, 7, 1.0, ())]


def test_a_takes_preset_starts_its_tracker_options_from_that_preset(tmp_path):
    takes = load_session(_session(tmp_path, '[takes]\na = { preset = "live", voxel_size = 0.03 }\nb = {}\n'))
    options = {t.name: t.options for t in takes}
    live = options["a"].tracking
    assert (options["a"].preset, live.voxel_size, live.learned_every) == ("live", 0.03, 3)
    assert (options["b"].preset, options["b"].tracking.voxel_size) == ("accurate", 0.01)


@pytest.mark.parametrize("toml, message", [
    ("[take]\n", "unknown table 'take'"),
    ("[defaults]\nvoxels = 1\n", "session.toml [defaults]: unknown option 'voxels'"),
    ("[takes]\na = { frames = 0 }\n", "[takes] a: frames must be a whole number, at least 1"),
    ("[takes]\na = { volume = [0, 0, 0] }\n", "volume must be six numbers"),
    ("[takes]\na = { hand_reach = 1.5 }\n", "hand_reach must be a fraction in (0, 1], got 1.5"),
    ("[defaults]\nimage_scale = 2\n", "image_scale must be a fraction in (0, 1], got 2"),
    ("[defaults]\nvoxel_size = inf\n", "[defaults]: voxel_size must be a positive number, got inf"),
    ("[takes]\na = { volume = [0, 0, 0, 1, 1, nan] }\n", "volume must be six numbers"),
    ("[takes]\na = { cameras = \"cam0\" }\n", 'cameras must be a list of camera names'),
    ("[defaults]\nleave_out = [\"\"]\n", "leave_out must be a list of camera names"),
    ("[takes]\na = \"nobody\"\n", "subject 'nobody' has no calibration take in [subjects]"),
    ("[subjects]\np = \"c\"\n", "[subjects] p: "),
    ("[subjects]\np = \"../a\"\n", "must be the name of a folder directly in the session"),
    ("[takes]\nc = {}\n", "is not a sequence folder (no cameras.json)"),
    ("[subjects]\np = \"a\"\nq = \"b\"\n[takes]\na = \"q\"\n", "it is p's calibration take"),
    ("takes = 3\n", "[takes] must be a table"),
    ("[takes\n", "not valid TOML"),
])
def test_a_bad_session_toml_is_named_with_what_is_wrong(tmp_path, toml, message):
    with pytest.raises(SessionError) as e:
        load_session(_session(tmp_path, toml))
    assert message in str(e.value) and "session.toml" in str(e.value)


def test_the_session_toml_of_docs_batch_md_means_what_it_says(tmp_path):
    doc = (Path(__file__).resolve().parents[1] / "docs" / "batch.md").read_text()
    toml = doc.split("```toml\n", 1)[1].split("```", 1)[0]
    takes = load_session(_session(tmp_path, toml, ["anna_static", "anna_walk", "ben_static", "ben_jump", "warmup"]))
    assert [(t.name, t.subject, t.calibration, t.options.frames, t.options.tracking.voxel_size, t.options.overlays)
            for t in takes] == [("anna_static", "anna", None, None, 0.01, False),
                                ("ben_static", "ben", None, None, 0.01, False),
                                ("warmup", None, None, None, 0.008, False),
                                ("anna_walk", "anna", "anna_static", None, 0.01, False),
                                ("ben_jump", "ben", "ben_static", 300, 0.01, False)]


def test_the_local_ray_we_start_keeps_token_authentication_without_a_warning(monkeypatch, caplog):
    from hullcap._batch import RayRunner

    monkeypatch.delenv("RAY_AUTH_MODE", raising=False)
    with caplog.at_level("INFO"), RayRunner() as runner:
        assert "CPUs" in runner.name
    assert not [r for r in caplog.records if "Token authentication" in r.getMessage()]
