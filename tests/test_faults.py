"""Broken inputs a real capture brings, each built from a copy of a small synthetic sequence:
one bad view leaves that view out of that frame, the run finishes and says what it left out;
interrupted outputs resume without tracking again; outputs follow the umask."""

import json
from dataclasses import replace
import os
import shutil
import stat

import cv2
import numpy as np
import pytest
from hullcap import Sequence, Tracker, TrackerOptions
from hullcap._cameras import ring
from hullcap._cli import main
from hullcap._frame_fitter import FrameFitter
from hullcap._person import available as person_available
from hullcap._subject_builder import SubjectBuilder
from hullcap._synth import synthesize
from hullcap.errors import CalibrationError, OptionsError, ResultsError, SequenceError

FRAMES = 8
FAST = TrackerOptions(refine_joints=False)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """Six cameras, colour frames and backgrounds (no silhouettes), eight frames."""
    out = tmp_path_factory.mktemp("faults") / "seq"
    cams = ring(6, radius=3.2, width=400, height_px=300, fov_deg=55)
    return synthesize(out, "squat", cams, subject="short", frames=FRAMES, show_progress=False)


def copy(clean, tmp_path):
    seq = tmp_path / "seq"
    shutil.copytree(clean, seq)
    return seq


def frame_file(seq, cam, frame):
    return seq / "frames" / cam / f"{frame:06d}.png"


def break_views(seq):
    """One fault per camera, each in another frame: (camera, frame, what problems.json says)."""
    # cam0 as a video two frames shorter than the others.
    (seq / "videos").mkdir()
    video = cv2.VideoWriter(str(seq / "videos" / "cam0.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 30, (400, 300))
    for f in range(FRAMES - 2):
        video.write(cv2.imread(str(frame_file(seq, "cam0", f))))
    video.release()
    shutil.rmtree(seq / "frames" / "cam0")
    # cam1 frame 3 of the wrong size; cam2 frame 4 a truncated PNG; cam3 frame 5 a truncated
    # JPEG in place of its PNG; cam4 frame 2 dropped; cam5 frame 1 blank (a camera that blinked).
    cv2.imwrite(str(frame_file(seq, "cam1", 3)), np.zeros((240, 320, 3), np.uint8) + 90)
    data = frame_file(seq, "cam2", 4).read_bytes()
    frame_file(seq, "cam2", 4).write_bytes(data[: len(data) // 3])
    ok, jpg = cv2.imencode(".jpg", cv2.imread(str(frame_file(seq, "cam3", 5))))
    frame_file(seq, "cam3", 5).unlink()
    (seq / "frames" / "cam3" / "000005.jpg").write_bytes(jpg.tobytes()[: len(jpg) // 2])
    frame_file(seq, "cam4", 2).unlink()
    cv2.imwrite(str(frame_file(seq, "cam5", 1)), np.zeros((300, 400, 3), np.uint8))
    # meta.json claims two frames more than any camera has.
    (seq / "meta.json").write_text(json.dumps({"fps": 30, "frames": FRAMES + 2}))
    return [("cam0", 6, "no frame 6"), ("cam0", 7, "no frame 7"), ("cam1", 3, "image is 320×240"),
            ("cam2", 4, "truncated PNG"), ("cam3", 5, "truncated JPEG"), ("cam4", 2, "missing"),
            ("cam5", 1, "blank image")]


def test_one_broken_view_leaves_only_that_view_out(clean, tmp_path, capsys):
    seq = copy(clean, tmp_path)
    faults = break_views(seq)
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--no-refine-joints"]) == 0
    captured = capsys.readouterr()
    assert f"{FRAMES} of {FRAMES} frames tracked (0 lost" in captured.out
    assert "problems: 7 views left out in 7 frames" in captured.out
    # One warning per camera, not one per frame: cam0 has two broken frames but warns once.
    warnings = [line for line in captured.err.splitlines() if line.startswith("hullcap: warning:")]
    assert sum("'cam0'" in w for w in warnings) == 1, warnings
    assert not any("background subtraction" in w for w in warnings)  # six cameras
    problems = json.loads((out / "problems.json").read_text())["problems"]
    for cam, frame, what in faults:
        assert any(p["camera"] == cam and p["frame"] == frame and what in p["what"] for p in problems), (cam, frame)
        assert not any(p["camera"] == cam and p["frame"] == frame and "left out" in p["what"] for p in problems)
    (meta,) = [p for p in problems if p["frame"] is None]
    assert "meta.json says 10 frames, on disk: cam0 6, cam1 8, cam2 8, cam3 8, cam4 7, cam5 8" in meta["what"]
    named = [p for p in problems if p["camera"] == "cam3" and p["frame"] == 5]
    assert named[0]["file"].endswith("frames/cam3/000005.jpg")
    # Every output was written, overlays included (the unreadable views drawn grey).
    for name in ("joints.csv", "pose.npz", "motion.bvh", "model.glb", "report.png"):
        assert (out / name).is_file(), name
    for cam in range(6):
        video = cv2.VideoCapture(str(out / "overlay" / f"cam{cam}.mp4"))
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == FRAMES
    assert not list(out.glob("**/.*part*")) and not (out / ".checkpoint.npz").exists()
    pose = np.load(out / "pose.npz")
    assert len(pose["failed"]) == FRAMES and not pose["failed"].any()


def test_a_camera_without_its_background_is_left_out_of_every_frame(clean, tmp_path):
    """Background subtraction needs each camera's empty scene: from colour alone, a camera
    without one is left out of the whole run (said once, not for every frame) and the
    others track; a sequence without any is refused before anything is tracked, saying
    what is needed. The learned segmenter, where it runs, segments such a camera alone."""
    from hullcap._evaluate import accuracy

    seq = copy(clean, tmp_path)
    (seq / "background" / "cam3.png").unlink()
    kinds = ("colour", "learned") if person_available() else ("colour",)
    for kind in kinds:
        out = tmp_path / f"out-{kind}"
        result = Tracker(Sequence(seq), options=replace(FAST, segmenter=kind)).run(out, show_progress=False)
        assert not result.failed.any() and accuracy(result, seq).mean_mm < 20
        problems = json.loads((out / "problems.json").read_text())["problems"]
        (left_out,) = [p for p in problems if p["camera"] == "cam3"]
        assert left_out["frame"] is None and left_out["file"].endswith("background/cam3.png")
        said = "left out of every frame" if kind == "colour" else "segmented by the learned person segmenter alone"
        assert f"{said}: no usable background image: missing, and there is no clip" in left_out["what"]
    shutil.rmtree(seq / "background")
    with pytest.raises(SequenceError, match=r"no camera has a usable background image .* background/<camera>.png"):
        Tracker(Sequence(seq), options=replace(FAST, segmenter="colour")).run(tmp_path / "out2", show_progress=False)
    assert not (tmp_path / "out2" / "pose.npz").exists()


def test_a_camera_whose_images_all_have_another_size_is_refused_at_start(clean, tmp_path):
    seq = copy(clean, tmp_path)
    for f in range(FRAMES):
        cv2.imwrite(str(frame_file(seq, "cam2", f)), np.full((150, 200, 3), 80, np.uint8))
    wrong = r"cam2/000000.png: image is 200×150, camera 'cam2' is calibrated for 400×300"
    with pytest.raises(SequenceError, match=wrong):
        Tracker(Sequence(seq), options=FAST).run(tmp_path / "out", show_progress=False)


def test_an_interruption_while_writing_overlays_resumes_without_tracking_again(clean, tmp_path, monkeypatch):
    import hullcap._tracking as tracking

    seq = Sequence(clean)
    out = tmp_path / "out"
    real = tracking.write_overlays

    def interrupted(out_, sequence, result, show_progress=True, still=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(tracking, "write_overlays", interrupted)
    with pytest.raises(KeyboardInterrupt):
        Tracker(seq, options=FAST).run(out, show_progress=False, overlays=True)
    assert (out / ".checkpoint.npz").is_file() and (out / "pose.npz").is_file()
    first = (out / "joints.csv").read_bytes()
    monkeypatch.setattr(tracking, "write_overlays", real)
    tracked = []
    monkeypatch.setattr(FrameFitter, "track", lambda self, *a: tracked.append(a))
    again = Tracker(seq, options=FAST)
    result = again.run(out, show_progress=False, overlays=True)
    assert tracked == [] and again.seconds.get("subject", 0) == 0
    assert (out / "joints.csv").read_bytes() == first and not result.failed.any()
    assert (out / "overlay" / "cam5.mp4").is_file() and not (out / ".checkpoint.npz").exists()


def test_outputs_follow_the_umask(clean, tmp_path):
    old = os.umask(0o027)
    try:
        out = tmp_path / "out"
        Tracker(Sequence(clean), options=FAST).run(out, show_progress=False, frames=2, overlays=True)
        assert main(["export", str(out), "--format", "trc"]) == 0
        synthesize(tmp_path / "synth", "squat", ring(4, width=160, height_px=120), frames=1, show_progress=False)
    finally:
        os.umask(old)
    for name in ("joints.csv", "pose.npz", "motion.bvh", "model.glb", "report.png", "problems.json",
                 "joints.trc", "model/links.json", "overlay/cam0.mp4", "../synth/cameras.json", "../synth/meta.json"):
        assert stat.S_IMODE((out / name).stat().st_mode) == 0o640, name


def test_damaged_checkpoint_and_pose_say_what_to_do(clean, tmp_path, capsys):
    seq = Sequence(clean)
    out = tmp_path / "out"
    Tracker(seq, options=FAST).run(out, show_progress=False, frames=2)
    (out / ".checkpoint.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(ResultsError, match="checkpoint is damaged.*--restart"):
        Tracker(seq, options=FAST).run(out, show_progress=False, frames=2)
    # A readable checkpoint whose carried state does not fit the model.
    with np.load(out / "pose.npz") as z:
        arrays = dict(z)
    np.savez(out / ".checkpoint.npz", **arrays, next_frame=1, sequence=str(clean.resolve()),
             carried_reference=np.empty(0), carried_chain_reference=np.empty(0), carried_confirmed=np.empty(0),
             carried_anchor=np.zeros(5), carried_search=np.asarray("{}"))
    with pytest.raises(ResultsError, match=r"checkpoint is damaged \(an anchor of 5 numbers"):
        Tracker(seq, options=FAST).run(out, show_progress=False, frames=2)
    np.savez(out / ".checkpoint.npz", **arrays, next_frame=1, sequence=str(clean.resolve()),
             learnt_teach_at=np.array([np.inf]))
    with pytest.raises(ResultsError, match=r"checkpoint is damaged \(learnt_teach_at is not a list of frames"):
        Tracker(seq, options=FAST).run(out, show_progress=False, frames=2)
    data = (out / "pose.npz").read_bytes()
    (out / "pose.npz").write_bytes(data[: len(data) // 2])
    assert main(["export", str(out), "--format", "bvh"]) == 2
    assert "not a readable pose.npz" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["export", str(tmp_path / "empty"), "--format", "bvh"]) == 2
    assert "no pose.npz: not the results folder" in capsys.readouterr().err


def test_bad_run_options_are_refused_before_anything_is_tracked(clean, tmp_path):
    """A cut-off beyond half the frame rate, or no frames to track, is said at once, not
    after the sequence was tracked; nothing is written. The same for synthesize."""
    tracker = Tracker(Sequence(clean), options=FAST)
    for kwargs, message in (({"smooth_hz": 20.0}, "between 0 and half the frame rate"),
                            ({"smooth_hz": float("nan")}, "between 0 and half the frame rate"),
                            ({"frames": 0}, "frames must be a whole number, at least 1")):
        with pytest.raises(OptionsError, match=message):
            tracker.run(tmp_path / "out", show_progress=False, **kwargs)
        assert not (tmp_path / "out").exists()
    for kwargs in ({"fps": float("inf")}, {"noise": float("nan")}, {"frames": 0}):
        with pytest.raises(OptionsError):
            synthesize(tmp_path / "synth", "squat", 4, show_progress=False, **kwargs)
        assert not (tmp_path / "synth").exists()


def test_a_camera_without_files_is_left_out_by_name(clean, tmp_path, monkeypatch, capsys):
    import hullcap._tracking as tracking

    seq = copy(clean, tmp_path)
    shutil.rmtree(seq / "frames" / "cam2")
    with pytest.raises(SequenceError, match="camera 'cam2' has no frames/cam2/"):
        Sequence(seq)
    five = Sequence(seq, leave_out=["cam2"])
    assert five.cameras.names == ["cam0", "cam1", "cam3", "cam4", "cam5"] and "5 of 6 cameras" in repr(five)
    assert Sequence(seq, cameras=["cam4", "cam0"]).cameras.names == ["cam0", "cam4"]  # the file's order
    for keep, leave_out, message in (
            (["cam9"], (), r"no camera named 'cam9'; the cameras are cam0, cam1, cam2"),
            (None, ["cam2", "cam2"], "camera 'cam2' named twice"),
            (["cam0", "cam1"], ["cam1"], "camera 'cam1' named twice"),
            ([], (), "no camera left of cam0"),
            (["cam3"], (), r"only camera 'cam3' is left of 6; a visual hull needs at least 2")):
        with pytest.raises(SequenceError, match=message):
            Sequence(seq, cameras=keep, leave_out=leave_out)
    with pytest.raises(TypeError, match=r"camera names come as a list, e.g. \['cam2'\]"):
        Sequence(seq, leave_out="cam2")
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--leave-out", "cam2", "--frames", "2",
                 "--no-refine-joints", "--segmenter", "colour"]) == 0
    captured = capsys.readouterr()
    assert "5 of 6 cameras" in captured.out
    # Fewer than six views from colour alone: the measured risk, and what to do about it.
    assert "hullcap: warning: 5 cameras and background subtraction alone" in captured.err
    assert "the learned segmenter, or a segmenter's masks in silhouettes/<cam>/, track better" in captured.err
    assert sorted(p.stem for p in (out / "overlay").glob("*.mp4")) == five.cameras.names
    # A run resumes only with the cameras it was tracked with.
    monkeypatch.setattr(tracking, "write_overlays", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(KeyboardInterrupt):
        Tracker(five, options=FAST).run(out, resume=False, show_progress=False, frames=2, overlays=True)
    four = Sequence(seq, leave_out=["cam2", "cam3"])
    with pytest.raises(ResultsError, match="tracked with the cameras cam0, cam1, cam3, cam4, cam5, not cam0, cam1, "
                                           r"cam4, cam5: give the same cameras to resume it, or --restart"):
        Tracker(four, options=FAST).run(out, show_progress=False, frames=2)
    assert not Tracker(five, options=FAST).run(out, show_progress=False, frames=2).failed.any()
    with pytest.raises(SystemExit):
        main(["track", str(seq), "--out", str(out), "--cameras", "cam0,,cam1"])
    assert "must be a list of camera names (cam0,cam2 on the command line), got 'cam0,,cam1'" in capsys.readouterr().err


def empty_room(seq, cam, frame):
    """Frame `frame` of camera `cam` replaced by the empty room: nobody in that view."""
    shutil.copy(seq / "background" / f"{cam}.png", frame_file(seq, cam, frame))


def nobody_in(seq, frames):
    """The empty room in every camera for `frames`."""
    for frame in frames:
        for cam in range(6):
            empty_room(seq, f"cam{cam}", frame)


def track(seq, out, *more):
    """`hullcap track` as a user runs it, quickly: its exit code."""
    return main(["track", str(seq), "--out", str(out), "--no-refine-joints", "--no-overlays", *more])


def test_a_view_without_the_person_is_left_out_once(clean, tmp_path, capsys):
    """A camera's frame that shows only the empty room (the person walked out of that
    view): an all-background mask is a normal mask, the view is left out of that frame,
    named once in problems.json, and the run ends well."""
    seq = copy(clean, tmp_path)
    empty_room(seq, "cam2", 5)
    assert track(seq, tmp_path / "out") == 0
    assert "1 view left out in 1 frame: cam2 frame 5" in capsys.readouterr().out
    problems = json.loads((tmp_path / "out" / "problems.json").read_text())["problems"]
    assert [(p["frame"], p["camera"]) for p in problems] == [(5, "cam2")]


def test_a_person_who_leaves_every_view_is_absent_then_found_again(clean, tmp_path, capsys):
    """The empty room in every camera for frames 3 and 4: each is reported once as absent
    (not as six views left out), the run goes on and tracks the person again when they
    come back, and exits 0."""
    from hullcap._evaluate import accuracy

    seq = copy(clean, tmp_path)
    nobody_in(seq, (3, 4))
    out = tmp_path / "out"
    assert track(seq, out) == 0
    said = capsys.readouterr().out
    assert f"{FRAMES - 2} of {FRAMES} frames tracked (2 lost" in said
    assert "problems: 2 frames without the person in any view: 3–4" in said
    problems = json.loads((out / "problems.json").read_text())["problems"]
    assert [(p["frame"], p["camera"]) for p in problems] == [(3, None), (4, None)]
    assert all(p["what"].startswith("absent: no view shows the person") for p in problems)
    pose = np.load(out / "pose.npz")
    assert pose["failed"].tolist() == [f in (3, 4) for f in range(FRAMES)]
    result = Tracker(Sequence(seq), options=FAST).run(tmp_path / "api", show_progress=False)
    assert accuracy(result, seq).mean_mm < 20  # the frames after the absence tracked as well as before


def test_a_take_whose_first_frames_show_nobody_starts_where_the_person_is_and_says_so(clean, tmp_path, capsys):
    """Nobody in frames 0 and 1: the subject's model is built from frame 2, the run says
    which frame and where to read why not the ones before, pose.npz keeps it, and
    report.png draws it."""
    from hullcap.export import load_result

    seq = copy(clean, tmp_path)
    nobody_in(seq, (0, 1))
    out = tmp_path / "out"
    assert track(seq, out) == 0
    said = capsys.readouterr().out
    assert ("the subject's model built from frame 2, the first whose visual hull it explains; frames 0–1 could not "
            "start it (why: problems.json)") in said
    problems = json.loads((out / "problems.json").read_text())["problems"]
    assert {p["frame"] for p in problems} == {0, 1}
    assert load_result(out).subject_frame == 2 and (out / "report.png").is_file()


def test_a_resume_with_other_settings_is_refused_naming_them(clean, tmp_path, monkeypatch, capsys):
    """Interrupted, then run again with another voxel size or without wrists: refused,
    with the setting named both ways, instead of a take tracked half one way and half the
    other; --restart starts over with the new settings."""
    seq = copy(clean, tmp_path)
    out = tmp_path / "out"
    real = FrameFitter.track
    monkeypatch.setattr(FrameFitter, "track", lambda self, state, result, frame:
                        (_ for _ in ()).throw(KeyboardInterrupt) if frame == 4 else real(self, state, result, frame))
    assert track(seq, out) == 130
    assert (out / ".checkpoint.npz").is_file()
    monkeypatch.setattr(FrameFitter, "track", real)
    capsys.readouterr()
    assert track(seq, out, "--voxel-size", "0.03") == 2
    assert "other settings (voxel_size: 0.01 then, 0.03 now)" in capsys.readouterr().err
    assert track(seq, out, "--no-wrists") == 2
    assert "wrists: True then, False now" in capsys.readouterr().err
    assert track(seq, out, "--no-wrists", "--restart") == 0
    assert "l_wrist_flexion" not in np.load(out / "pose.npz")["dof_names"].tolist()


def test_a_fault_mid_run_keeps_every_frame_tracked_before_it(clean, tmp_path, monkeypatch):
    """A fault at frame 6 (here a bug, raised by the fit): the checkpoint holds frames 0-5
    with the state frame 6 found, and the resume tracks only frames 6 on, to the same
    joints as a run that never stopped."""
    seq = Sequence(clean)
    real = FrameFitter.track
    tracked, faults = [], [6]

    def failing(self, state, result, frame):
        tracked.append(frame)
        if frame in faults:
            faults.remove(frame)
            raise RuntimeError("a fault")
        return real(self, state, result, frame)

    monkeypatch.setattr(FrameFitter, "track", failing)
    with pytest.raises(RuntimeError, match="a fault"):
        Tracker(seq, options=FAST).run(tmp_path / "out", show_progress=False)
    tracked.clear()
    resumed = Tracker(seq, options=FAST).run(tmp_path / "out", show_progress=False)
    assert tracked == [6, 7]
    monkeypatch.setattr(FrameFitter, "track", real)
    straight = Tracker(seq, options=FAST).run(tmp_path / "straight", show_progress=False)
    assert np.allclose(resumed.joints, straight.joints, atol=1e-9)


def test_the_subject_model_is_kept_as_soon_as_it_is_built(clean, tmp_path, monkeypatch):
    """Killed while tracking the first frame, after the minutes of building the subject's
    model: the resume does not build it again."""
    seq = Sequence(clean)
    monkeypatch.setattr(FrameFitter, "track", lambda *a: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(KeyboardInterrupt):
        Tracker(seq, options=FAST).run(tmp_path / "out", show_progress=False)
    monkeypatch.undo()
    again = Tracker(seq, options=FAST)
    assert not again.run(tmp_path / "out", show_progress=False).failed.any()
    assert again.seconds.get("subject", 0) == 0


def test_a_reused_folder_keeps_nothing_of_the_last_take(clean, tmp_path, capsys):
    """A take tracked into a folder where another was tracked with --smooth and exported:
    the last take's files go; a folder holding files no run wrote is refused, naming
    them."""
    seq = copy(clean, tmp_path)
    out = tmp_path / "out"
    assert track(seq, out, "--smooth", "6") == 0 and main(["export", str(out), "--format", "trc"]) == 0
    assert (out / "joints_smooth.csv").is_file() and (out / "joints.trc").is_file()
    assert track(seq, out, "--frames", "3", "--restart") == 0
    assert not (out / "joints_smooth.csv").exists() and not (out / "joints.trc").exists()
    assert "3 of 3 frames tracked" in capsys.readouterr().out
    (out / "notes.txt").write_text("mine")
    assert track(seq, out, "--restart") == 2
    assert "holds files that are not a run's (notes.txt)" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "mine"


def test_one_camera_is_refused_whatever_the_volume(clean, tmp_path, capsys):
    seq = copy(clean, tmp_path)
    cameras = json.loads((seq / "cameras.json").read_text())
    cameras["cameras"] = cameras["cameras"][:1]
    (seq / "cameras.json").write_text(json.dumps(cameras))
    for more in ((), ("--volume=-1,-1,0,1,1,2",)):
        assert track(seq, tmp_path / "out", *more) == 2
        err = capsys.readouterr().err
        assert "one camera ('cam0') cannot make a visual hull" in err and "capture volume" not in err
    assert not (tmp_path / "out" / "model").exists()


def test_a_run_that_tracks_nothing_fails_and_lists_only_what_it_wrote(clean, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(FrameFitter, "track", lambda self, state, result, frame: result.fail(frame))
    assert track(copy(clean, tmp_path), tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert f"no frame of {FRAMES} was tracked" in err
    assert "written: model/, joints.csv, pose.npz, report.png, problems.json" in err
    assert not (tmp_path / "out" / "motion.bvh").exists()


def test_an_unwritable_or_full_folder_is_refused_before_any_work(clean, tmp_path, monkeypatch):
    """Found at once, not after the subject's model was built; a write that fails for
    want of room names its file."""
    from hullcap import _run_folder
    from hullcap._files import atomic_write

    monkeypatch.setattr(SubjectBuilder, "build", lambda *a: pytest.fail("the subject's model was built"))
    # A folder that cannot be made (a file stands where it would go): what a read-only disk
    # gives too, without depending on who runs the test (root writes anywhere).
    (tmp_path / "a file").write_text("")
    with pytest.raises(ResultsError, match="cannot write the results there"):
        Tracker(Sequence(clean), options=FAST).run(tmp_path / "a file" / "out", show_progress=False)
    monkeypatch.setattr(_run_folder.shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(10**9, 10**9, 10**6))
    with pytest.raises(ResultsError, match=r"1 MB free, a run of 48 views needs about 53 MB"):
        Tracker(Sequence(clean), options=FAST).run(tmp_path / "full", show_progress=False, overlays=True)

    def full(path):
        raise OSError(28, "No space left on device")
    with pytest.raises(OSError, match=r"No space left on device: '.*pose.npz'"):
        atomic_write(tmp_path / "pose.npz", full)


@pytest.mark.parametrize("change, message", [
    (lambda cams, meta: cams[0]["K"][0].__setitem__(0, float("nan")),
     r"camera 'cam0': K must be finite numbers, got \[\[nan"),
    (lambda cams, meta: cams[0].__setitem__("width", "400"),
     r"camera 'cam0': width must be a positive whole number of pixels, got '400' \(a str\)"),
    (lambda cams, meta: meta.__setitem__("framez", 8),
     r"meta.json: unknown key 'framez' \(did you mean 'frames'\?\)"),
], ids=["nan focal length", "width as text", "unknown meta key"])
def test_a_bad_calibration_or_meta_says_what_it_got(clean, tmp_path, change, message):
    seq = copy(clean, tmp_path)
    cameras, meta = json.loads((seq / "cameras.json").read_text()), json.loads((seq / "meta.json").read_text())
    change(cameras["cameras"], meta)
    (seq / "cameras.json").write_text(json.dumps(cameras))
    (seq / "meta.json").write_text(json.dumps(meta))
    with pytest.raises((SequenceError, CalibrationError), match=message):
        Sequence(seq)


def test_a_meta_json_of_fewer_frames_than_the_files_tracks_those_without_a_false_warning(clean, tmp_path):
    seq = copy(clean, tmp_path)
    (seq / "meta.json").write_text(json.dumps({"fps": 30, "frames": FRAMES - 3}))
    tracker = Tracker(Sequence(seq), options=FAST)
    result = tracker.run(tmp_path / "out", show_progress=False)
    assert len(result.failed) == FRAMES - 3
    (said,) = [str(p) for p in tracker.problems]
    assert f"only the first {FRAMES - 3} are tracked" in said and "missing" not in said
