"""Fitting and tracking against ground truth; the command line."""

import shutil
import threading
import time

import cv2
import numpy as np
import pytest
from hullcap import BodyModel, FitOptions, PoseParameters, Surface, Tracker, TrackerOptions, fit
from hullcap._cameras import ring
from hullcap._carver import Carver
from hullcap._cli import main
from hullcap._evaluate import accuracy
from hullcap._frame_fitter import FrameFitter
from hullcap._render import model_silhouettes
from hullcap._results import GOOD
from hullcap._segmenter import Segmenter
from hullcap._sequence import Sequence
from hullcap._subject import with_hands
from hullcap._synth import synthesize
from hullcap._tracking_options import quick_fit_options
from hullcap.export import load_result


def turn(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


@pytest.fixture(scope="module")
def model():
    return BodyModel.template()


@pytest.mark.parametrize("options", [{}, {"residual": "point_to_plane"}])
def test_a_perturbed_pose_is_recovered_from_the_exact_mesh(model, options):
    rng = np.random.default_rng(7)
    lim = model.link_model.dof_limits
    theta = np.clip(rng.normal(0, 0.3, 29), lim[:, 0], lim[:, 1])
    truth = PoseParameters(theta, turn(0.6), np.array([0.3, -0.2, 0.95]))
    posed = model.pose(truth.theta, truth.root_rotation, truth.root_translation)
    start = PoseParameters(np.clip(theta + rng.normal(0, 0.1, 29), lim[:, 0], lim[:, 1]),
                           turn(0.68), truth.root_translation + (0.03, -0.02, 0.02))
    result = fit(model, Surface(posed.vertices, model.faces, posed.normals), start, FitOptions(**options))
    got = model.pose(result.pose.theta, result.pose.root_rotation, result.pose.root_translation)
    assert np.linalg.norm(got.joints - posed.joints, axis=1).max() < 0.002
    assert result.inlier_fraction > 0.99 and result.mean_residual < 0.002
    with pytest.raises(ValueError, match="initial.theta must have 29"):
        fit(model, Surface(posed.vertices, model.faces, posed.normals), PoseParameters(np.zeros(3)))


def test_a_pose_prior_holds_a_joint_the_mesh_would_move(model):
    """Through the binding: a stiff prior keeps the left elbow where it started although
    the mesh bends it 60°; an infinite one changes nothing; a prior of the wrong length is
    refused by name."""
    from hullcap._fitting import PosePrior

    elbow = model.dof_names.index("l_elbow_flexion")
    theta = np.zeros(model.n_dofs)
    theta[elbow] = np.radians(60)
    root = np.array([0.0, 0.0, 0.95])
    posed = model.pose(theta, root_translation=root)
    target = Surface(posed.vertices, model.faces, posed.normals)
    start = PoseParameters(np.zeros(model.n_dofs), np.eye(3), root)
    plain = fit(model, target, start)
    stiff = np.full(model.n_dofs, np.inf)
    stiff[elbow] = np.radians(1)
    held = fit(model, target, start, prior=PosePrior(start.theta, stiff, 0.003))
    free = fit(model, target, start, prior=PosePrior(start.theta, np.full(model.n_dofs, np.inf), 0.003))
    assert plain.pose.theta[elbow] == pytest.approx(np.radians(60), abs=np.radians(2))
    assert abs(held.pose.theta[elbow]) < np.radians(5)
    assert np.array_equal(free.pose.theta, plain.pose.theta)
    with pytest.raises(ValueError, match="pose prior mean and sigma lengths"):
        fit(model, target, start, prior=PosePrior(np.zeros(3), np.ones(3), 0.003))


def test_bent_wrists_are_recovered_with_wrists_and_left_unexplained_without(model):
    """The mesh of the model with wrists, one hand flexed 50° and the other deviated
    −25° (ulnar): fitted from straight wrists, the wrists' angles and every joint come
    back; the paper's model, whose hands are rigid, leaves the hands' surface unexplained."""
    wrists = model.with_wrists()
    theta = np.zeros(wrists.n_dofs)
    for name, degrees in (("l_elbow_flexion", 30), ("l_wrist_flexion", 50), ("r_wrist_deviation", -25),
                          ("l_shoulder_abduction", -40), ("r_shoulder_abduction", -40)):
        theta[wrists.dof_names.index(name)] = np.radians(degrees)
    root = np.array([0.0, 0.0, 0.95])
    posed = wrists.pose(theta, root_translation=root)
    target = Surface(posed.vertices, wrists.faces, posed.normals)
    bent = [wrists.dof_names.index(n) for n in wrists.dof_names if "wrist" in n]
    straight = theta.copy()
    straight[bent] = 0.0
    start = PoseParameters(straight, np.eye(3), root)
    turned = fit(wrists, target, start)
    assert np.degrees(np.abs(turned.pose.theta[bent] - theta[bent])).max() < 1
    got = wrists.pose(turned.pose.theta, turned.pose.root_rotation, turned.pose.root_translation)
    assert np.linalg.norm(got.joints - posed.joints, axis=1).max() < 0.001
    rigid = fit(model, target, start.carried(wrists, model))
    assert rigid.mean_residual > 0.001 > 100 * turned.mean_residual


def test_a_fit_a_search_confirmed_is_the_bar_until_the_hull_is_whole_again(model):
    """A hull that lost the left arm (as camouflage does): the fit fails the reference of
    whole frames; once the search found nothing better (decide keeps the tracked fit),
    a fit as good passes without a search, one that also lost the right arm does not,
    and a whole frame lifts the bar."""
    from dataclasses import replace

    from hullcap._fitting import make_target
    from hullcap._reacquire import CHAINS
    from hullcap._tracking_state import TrackingState

    root = np.array([0.0, 0.0, model.rest_root_height])
    posed = model.pose(np.zeros(model.n_dofs), root_translation=root)
    index, weight = model.skin
    owner = np.array(model.link_model.names)[index[np.arange(len(index)), weight.argmax(1)]]

    def hull_without(*links):
        keep = ~np.isin(owner, links)
        return make_target(Surface(posed.vertices[keep], model.faces[:0], posed.normals[keep]))

    options = TrackerOptions()
    start = PoseParameters(np.zeros(model.n_dofs), np.eye(3), root)
    whole, one_arm, two_arms = (fit(model, hull_without(*links), start, options.fit) for links in
                                [(), ("l_upper_arm", "l_forearm"),
                                 ("l_upper_arm", "l_forearm", "r_upper_arm", "r_forearm")])
    state = TrackingState(model, options, whole)
    assert not state.good(one_arm) and not state.good(two_arms)
    assert state.decide(one_arm, one_arm) == (one_arm, GOOD)
    state.remember_fit(one_arm)
    assert state.good(one_arm) and not state.passes_reference(one_arm)
    assert not state.good(two_arms)
    # A limb chain's quality moves about twice as much as the whole body's from frame to
    # frame, and its bar is twice as wide: the right arm may dip by 0.07, not by 0.15.
    right = state.chains[list(CHAINS).index("right arm")]

    def right_arm_dipped(by):
        counts = np.array(one_arm.link_counts, copy=True)
        need = int(np.rint(2 * by * counts[right, 0].sum()))
        for link in right:
            take = min(need, counts[link, 1])
            counts[link, 1] -= take
            need -= take
        return replace(one_arm, link_counts=counts)

    assert state.good(right_arm_dipped(0.07)) and not state.good(right_arm_dipped(0.15))
    state.remember_fit(whole)
    assert state.confirmed is None and not state.good(one_arm)


@pytest.fixture(scope="module")
def short_sequence(tmp_path_factory):
    out = tmp_path_factory.mktemp("track") / "seq"
    cams = ring(6, radius=3.2, width=400, height_px=300, fov_deg=55)
    return synthesize(out, "demo", cams, subject="short", frames=20, silhouettes=True, show_progress=False)


def test_tracker_follows_a_rendered_sequence(short_sequence, tmp_path):
    seq = Sequence(short_sequence)
    result = Tracker(seq).run(tmp_path / "out", show_progress=False)
    acc = accuracy(result, short_sequence)
    assert acc.failed == 0
    assert acc.mean_mm < 25, acc.table()
    # The outputs of docs/formats.md.
    header = (tmp_path / "out" / "joints.csv").read_text().splitlines()
    assert header[0] == "frame,time,joint,x,y,z,status,confidence" and len(header) == 1 + 20 * 21
    pose = np.load(tmp_path / "out" / "pose.npz")
    # The subject's model is built with the paper's 29 DOF; tracking adds the wrists.
    assert pose["theta"].shape == (20, 33) and not pose["failed"].any()
    assert BodyModel.load(tmp_path / "out" / "model").n_dofs == 33
    # The same subject tracked again with quick fits: as close, for fewer iterations.
    again = Tracker(seq, model=BodyModel.load(tmp_path / "out" / "model"),
                    options=TrackerOptions(quick_fit=quick_fit_options()))
    fast = again.run(tmp_path / "quick", show_progress=False)
    assert accuracy(fast, short_sequence).mean_mm < 25
    assert fast.iterations.sum() < 0.7 * result.iterations.sum()


def test_tracking_fits_short_hands_and_guides_the_silhouettes_with_whole_ones(short_sequence):
    """The hands asked for, and by default 0.6 with the sequence's own silhouettes only."""
    seq, model = Sequence(short_sequence), BodyModel.template()
    assert seq.has_silhouettes
    for options, reach in ((TrackerOptions(hand_reach=0.6), 0.6), (TrackerOptions(hand_reach=1.0), 1.0),
                           (TrackerOptions(), 0.6), (TrackerOptions(ignore_silhouettes=True), 1.0)):
        state = Tracker(seq, options=options).fitter.state(model)
        assert state.guide is model and state.search.model is state.model
        if reach == 1.0:
            assert state.model is model
        else:
            assert np.array_equal(state.model.vertices, with_hands(model, reach).vertices)
    # Hands that turn at the wrists are shortened alike.
    assert np.array_equal(with_hands(model.with_wrists(), 0.6).vertices, with_hands(model, 0.6).vertices)


def test_an_elbow_in_doubt_guides_the_masks_with_the_forearm_both_ways(short_sequence):
    """With an elbow in doubt the prediction is drawn with the forearm as predicted and
    as it was, united: the silhouettes of both poses, pixel for pixel."""
    seq, model = Sequence(short_sequence), BodyModel.template()
    theta = np.zeros(model.n_dofs)
    theta[list(model.dof_names).index("l_elbow_flexion")] = np.radians(150)
    root = (np.eye(3), np.array([0.0, 0.0, model.rest_root_height]))
    folded, straight = PoseParameters(theta, *root), PoseParameters(np.zeros(model.n_dofs), *root)

    def drawn(*poses):
        return model_silhouettes(seq.cameras, model, *poses)
    both = drawn(folded, straight)
    for union, a, b in zip(both, drawn(folded), drawn(straight)):
        assert np.array_equal(union, a | b)
    assert sum((u & ~a).sum() for u, a in zip(both, drawn(folded))) > 0


def test_a_real_bend_put_in_doubt_is_still_followed(short_sequence, tmp_path, monkeypatch):
    """With the bar of a fast turn lowered to 8° within 0.6 s, the demo's elbows, bending
    for real from frame 13, are put in doubt: those frames are guided with the forearm both
    ways and fitted once more from it as it was. The hull does not bear that fit out, and
    tracking follows the bend as it does without the doubt."""
    seq = Sequence(short_sequence)
    in_doubt = []
    carve = Carver.carve

    def carving(self, frame, prior=None, doubt=None):
        if prior is not None and prior[2:] and prior[2] is not None:
            in_doubt.append(frame)
        return carve(self, frame, prior, doubt)

    monkeypatch.setattr(Carver, "carve", carving)
    runs = {}
    for elbow_doubt in (0.5, 0.0):
        options = TrackerOptions(ignore_silhouettes=True, refine_joints=False, hinge_jump=np.radians(8),
                                 elbow_span=0.6, elbow_doubt=elbow_doubt)
        runs[elbow_doubt] = Tracker(seq, options=options).run(tmp_path / str(elbow_doubt), show_progress=False)
        if elbow_doubt:
            assert in_doubt, "no elbow was put in doubt"
            doubted, in_doubt[:] = list(in_doubt), []
    assert not in_doubt and not runs[0.5].failed.any()
    errors = {k: accuracy(run, short_sequence).mean_mm for k, run in runs.items()}
    assert errors[0.5] < errors[0.0] + 1.0, (doubted, errors)
    elbows = [runs[0.5].model.dof_names.index(f"{s}_elbow_flexion") for s in "lr"]
    assert np.degrees(np.abs(runs[0.5].theta[-1, elbows] - runs[0.0].theta[-1, elbows])).max() < 5


def test_the_papers_29_dof_throughout_when_asked(short_sequence, tmp_path):
    options = TrackerOptions(refine_joints=False, wrists=False)
    result = Tracker(Sequence(short_sequence), options=options).run(tmp_path / "out", show_progress=False, frames=3)
    assert result.model.n_dofs == 29 and result.theta.shape == (3, 29) and not result.failed.any()
    assert BodyModel.load(tmp_path / "out" / "model").n_dofs == 29


def test_a_blank_camera_and_a_missing_mask_do_not_stop_tracking(short_sequence, tmp_path):
    seq_dir = tmp_path / "seq"
    shutil.copytree(short_sequence, seq_dir)
    blank = seq_dir / "silhouettes" / "cam2" / "000005.png"
    cv2.imwrite(str(blank), np.zeros((300, 400), np.uint8))
    (seq_dir / "silhouettes" / "cam4" / "000007.png").unlink()
    tracker = Tracker(Sequence(seq_dir))
    result = tracker.run(tmp_path / "out", show_progress=False, frames=10)
    assert not result.failed.any()
    assert any(str(p).startswith("frame 5: camera 'cam2': left out") for p in tracker.problems)
    assert any(p.frame == 7 and p.camera == "cam4" and p.file.endswith("000007.png") and p.what.startswith("missing")
               for p in tracker.problems)
    assert accuracy(result, seq_dir).mean_mm < 30


def test_other_threads_change_nothing(short_sequence, tmp_path, monkeypatch):
    """From colour frames (guided silhouettes), one image broken: the run that decodes and
    subtracts the next frames on a second thread and treats each frame's views on two
    gives the same joints and problems as the run that does everything on one thread."""
    seq_dir = tmp_path / "seq"
    shutil.copytree(short_sequence, seq_dir)
    (seq_dir / "frames" / "cam1" / "000003.png").write_bytes(b"not a png")
    seq = Sequence(seq_dir)
    model = BodyModel.load(seq_dir / "truth" / "model")
    runs = []
    for read_ahead, threads in ((0, "1"), (2, "2")):
        monkeypatch.setenv("HULLCAP_THREADS", threads)
        options = TrackerOptions(ignore_silhouettes=True, read_ahead=read_ahead, refine_joints=False)
        tracker = Tracker(seq, model, options)
        result = tracker.run(tmp_path / f"out{read_ahead}", show_progress=False, frames=8)
        runs.append((result, [str(p) for p in tracker.problems]))
    (serial, serial_problems), (ahead, ahead_problems) = runs
    assert np.array_equal(serial.joints, ahead.joints) and np.array_equal(serial.status, ahead.status)
    assert serial_problems == ahead_problems and any("frame 3: camera 'cam1'" in p for p in ahead_problems)
    assert ahead.seconds["read ahead"] > 0 and "read ahead" not in serial.seconds


@pytest.mark.parametrize("own_silhouettes", [True, False], ids=["masks", "colour frames"])
def test_an_interrupted_run_resumes_where_it_stopped(short_sequence, tmp_path, monkeypatch, own_silhouettes):
    # From colour frames the guided masks depend on the colours the segmenters learnt
    # before the interruption (the first frame's, and those taught since): the
    # checkpoint keeps them.
    seq = Sequence(short_sequence)
    out = tmp_path / "out"
    options = TrackerOptions(refine_joints=False, ignore_silhouettes=not own_silhouettes)
    tracker = Tracker(seq, options=options)
    calls = {"n": 0}
    real = FrameFitter.track

    def interrupting(self, *args):
        calls["n"] += 1
        if calls["n"] == 13:
            raise KeyboardInterrupt
        return real(self, *args)

    monkeypatch.setattr(FrameFitter, "track", interrupting)
    with pytest.raises(KeyboardInterrupt):
        tracker.run(out, show_progress=False, frames=16)
    assert (out / ".checkpoint.npz").is_file() and not (out / "pose.npz").exists()
    monkeypatch.setattr(FrameFitter, "track", real)
    fresh = Tracker(seq, options=options)
    resumed = fresh.run(out, show_progress=False, frames=16)
    assert fresh.seconds.get("subject", 0) == 0  # the model came from the checkpoint's run
    assert not resumed.failed.any() and not (out / ".checkpoint.npz").exists()
    straight = Tracker(seq, options=options).run(tmp_path / "straight", show_progress=False, frames=16)
    assert np.allclose(resumed.joints, straight.joints, atol=1e-9)
    assert resumed.subject_frame == straight.subject_frame == 0  # kept by the checkpoint, then by pose.npz
    assert load_result(out).subject_frame == 0


def test_the_state_a_checkpoint_carries_comes_back_whole(model):
    # The references, the confirmed bar, the anchor, the search's random draws and the
    # elbows in doubt: what the results alone do not say, through a checkpoint's arrays
    # and back.
    import io

    from hullcap._tracking_state import TrackingState

    def state_of():
        return TrackingState(model, TrackerOptions(), anchor=None)

    state = state_of()
    chains = len(state.chains)
    rng = np.random.default_rng(3)
    state.reference.extend(rng.uniform(0.6, 0.9, 4))
    state.chain_reference.extend(rng.uniform(0.6, 0.9, (4, chains)))
    state.chain_reference[1][2] = np.nan  # a chain too small to judge
    state.confirmed = (0.71, rng.uniform(0.6, 0.9, chains))
    state.anchor_pose = PoseParameters(rng.normal(0, 0.1, len(model.dof_names)), np.eye(3)[[1, 0, 2]] * [1, 1, -1],
                                       np.array([0.1, -0.2, 0.9]))
    state.search._rng.uniform(size=5)  # draws move the search's generator on
    state.doubted = {state.elbows[0]: (0.25, 7), state.elbows[1]: (1.5, 2)}
    buf = io.BytesIO()
    np.savez(buf, **state.carried())
    buf.seek(0)
    back = state_of()
    back.take_back(dict(np.load(buf)))
    assert list(back.reference) == list(state.reference)
    assert np.array_equal(np.array(back.chain_reference), np.array(state.chain_reference), equal_nan=True)
    assert back.confirmed[0] == state.confirmed[0] and np.array_equal(back.confirmed[1], state.confirmed[1])
    for name in ("theta", "root_rotation", "root_translation"):
        assert np.array_equal(getattr(back.anchor_pose, name), getattr(state.anchor_pose, name))
    assert np.array_equal(back.search._rng.uniform(size=3), state.search._rng.uniform(size=3))
    assert back.doubted == state.doubted
    # Nothing confirmed, no anchor and no doubt yet come back as nothing; so does the doubt
    # of a checkpoint written before elbows were doubted.
    empty = state_of()
    empty.take_back(state_of().carried())
    assert empty.confirmed is None and empty.anchor_pose is None and not empty.reference and not empty.doubted
    older = {k: v for k, v in state.carried().items() if k != "carried_doubted"}
    empty.take_back(older)
    assert not empty.doubted
    with pytest.raises(ValueError, match="an anchor of 5 numbers"):
        state_of().take_back({**state.carried(), "carried_anchor": np.zeros(5)})
    knee = [i for i in state.hinges if i not in state.elbows][0]
    with pytest.raises(ValueError, match="elbows"):
        state_of().take_back({**state.carried(), "carried_doubted": np.array([[knee, 0.1, 3]])})


def test_a_given_model_teaches_the_guided_masks_colours_as_it_goes(short_sequence, tmp_path, monkeypatch):
    # Placed at one frame, a given model's segmenters know that frame's colours alone;
    # tracking teaches them from calibration_frames frames over calibration_seconds, as a
    # refined model's window does, each at the first frame from it on that needs no search.
    seq = Sequence(short_sequence)
    built = Tracker(seq, options=TrackerOptions(refine_joints=False)).run(tmp_path / "built", show_progress=False,
                                                                           frames=2)
    taught = []
    real = Segmenter.learn_colours

    def recording(self, frame, *args, **kwargs):
        taught.append(frame)
        return real(self, frame, *args, **kwargs)

    monkeypatch.setattr(Segmenter, "learn_colours", recording)
    options = TrackerOptions(ignore_silhouettes=True, calibration_seconds=0.4, calibration_frames=4)
    result = Tracker(seq, model=built.model, options=options).run(tmp_path / "given", show_progress=False,
                                                                   frames=16)
    # 0.4 s at 30 frames/s from frame 0: frames 0-11, four of them spread, the first the placement's.
    assert not result.failed.any() and (result.status == GOOD).all()
    assert taught == [0, 4, 7, 11]


def test_command_line_errors_name_the_problem(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main(["track", str(tmp_path / "empty"), "--out", str(tmp_path / "o")]) == 2
    assert "missing cameras.json" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["synth", str(tmp_path / "s"), "--motion", "moonwalk"])


def test_command_line_synth_then_track(tmp_path, capsys):
    seq = tmp_path / "seq"
    assert main(["synth", str(seq), "--frames", "3", "--cameras", "6", "--motion", "squat"]) == 0
    assert Sequence(seq).n_frames == 3
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "--hand-reach", "0.6"]) == 0
    assert "3 of 3 frames tracked (0 lost" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:  # refused as the command line is read, as every flag is
        main(["track", str(seq), "--out", str(tmp_path / "bad"), "--hand-reach", "1.5"])
    assert e.value.code == 2
    assert "argument --hand-reach: must be a fraction in (0, 1], got '1.5'" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("rest_mesh", ["template", "hull"])
def test_subject_model_is_built_from_the_first_hull(short_sequence, rest_mesh):
    from hullcap import build_subject, visual_hull
    from hullcap._subject import SubjectOptions

    seq = Sequence(short_sequence)
    hull = visual_hull(seq.masks(0), seq.cameras)
    subject = build_subject(hull, options=SubjectOptions(rest_mesh=rest_mesh))
    truth = np.load(short_sequence / "truth" / "joints.npz")["positions"][0]
    joints = subject.model.pose(subject.pose.theta, subject.pose.root_rotation, subject.pose.root_translation).joints
    assert np.linalg.norm(joints - truth, axis=1).mean() < 0.025
    if rest_mesh == "hull":
        assert len(subject.model.vertices) == len(hull.vertices)
        assert subject.fit.mean_residual < 0.005
    else:
        assert len(subject.model.vertices) == len(BodyModel.template().vertices)
    with pytest.raises(ValueError, match="rest_mesh must be"):
        SubjectOptions(rest_mesh="clay")


def test_views_side_by_side_keep_their_order_and_errors(monkeypatch):
    from hullcap._engine import threads
    from hullcap._threads import over_views

    monkeypatch.setenv("HULLCAP_THREADS", "3")
    assert threads() == 3
    assert over_views(lambda x: x * x, range(10)) == [x * x for x in range(10)]

    def broken(x):
        if x in (4, 6):
            raise ValueError(f"view {x}")
        return x

    with pytest.raises(ValueError, match="view 4"):  # the first in the items' order
        over_views(broken, range(8))
    # Views within views: with two threads the pool has one, and when the views it works
    # ask for views of their own, it must work them itself rather than wait for itself.
    monkeypatch.setenv("HULLCAP_THREADS", "2")
    nested: list = []
    caller = threading.Thread(target=lambda: nested.append(
        over_views(lambda x: sum(over_views(lambda y: y * y, range(x))), range(8))), daemon=True)
    caller.start()
    caller.join(timeout=30)
    assert not caller.is_alive(), "views within views wait for themselves"
    assert nested == [[sum(y * y for y in range(x)) for x in range(8)]]
    # Ctrl-C on the calling thread: the other threads take no further items.
    worked = []
    asking = threading.current_thread()

    def interrupted(x):
        if threading.current_thread() is asking:
            raise KeyboardInterrupt
        time.sleep(0.01)
        worked.append(x)

    with pytest.raises(KeyboardInterrupt):
        over_views(interrupted, range(50))
    assert len(worked) <= 2
    for value in ("0", "two", ""):
        monkeypatch.setenv("HULLCAP_THREADS", value)
        assert threads() >= 1


def test_fits_side_by_side_are_the_fits_made_one_after_another(monkeypatch):
    """Whole fits on the cores at once, each on its share of the engine's threads, give
    the fits made in order on every core, bit for bit; the first error is raised."""
    from hullcap._threads import over_fits

    model = BodyModel.template()
    theta = np.zeros(model.n_dofs)
    theta[model.dof_names.index("l_elbow_flexion")] = 0.8
    root = np.array([0.1, -0.2, model.rest_root_height])
    posed = model.pose(theta, root_translation=root)
    target = Surface(posed.vertices, model.faces, posed.normals)
    starts = [PoseParameters(np.zeros(model.n_dofs), np.eye(3), root + [dx, 0.0, 0.0]) for dx in (0.0, 0.03, -0.05)]
    options = FitOptions(rounds=1)
    for cores, share in (("2", [1, 1, 1]), ("6", [2, 2, 2])):
        monkeypatch.setenv("HULLCAP_THREADS", cores)
        one_by_one = [fit(model, target, start, options) for start in starts]
        assert len({r.energy for r in one_by_one}) == len(starts)  # so that the order shows
        given = []
        side_by_side = over_fits(lambda s, threads: given.append(threads) or fit(model, target, s, options,
                                                                                  threads=threads), starts)
        assert given == share
        for a, b in zip(one_by_one, side_by_side):
            assert np.array_equal(a.pose.theta, b.pose.theta) and a.energy == b.energy
            assert np.array_equal(a.pose.root_rotation, b.pose.root_rotation)
            assert np.array_equal(a.pose.root_translation, b.pose.root_translation)

    def broken(x, threads):
        if x == 2:
            raise ValueError("fit 2")
        return x

    with pytest.raises(ValueError, match="fit 2"):
        over_fits(broken, range(5))


def test_over_relaxed_fits_end_where_plain_ones_do_for_fewer_iterations(short_sequence):
    """The tracker's fits over-relax their steps (``TrackerOptions.fit``, design.md §4):
    each frame fitted from the true pose of the frame before ends where the steps as
    solved end, within a few millimetres, for fewer iterations in all."""
    from hullcap import build_subject, visual_hull

    seq = Sequence(short_sequence)
    subject = build_subject(visual_hull(seq.masks(0), seq.cameras))
    model = subject.model
    truth = np.load(short_sequence / "truth" / "pose.npz")
    over = TrackerOptions().fit
    assert over.over_relaxation > 1
    plain = over.replace(over_relaxation=1.0)
    iterations = {"over": 0, "plain": 0}
    for f in range(2, 20, 3):
        hull = visual_hull(seq.masks(f), seq.cameras)
        start = PoseParameters(truth["theta"][f - 1], truth["root_rotation"][f - 1], truth["root_translation"][f - 1])
        ends = {}
        for name, options in (("over", over), ("plain", plain)):
            result = fit(model, hull, start, options)
            iterations[name] += result.iterations
            ends[name] = model.pose(result.pose.theta, result.pose.root_rotation, result.pose.root_translation).joints
        apart = np.linalg.norm(ends["over"] - ends["plain"], axis=1)
        assert apart.mean() < 0.003, f"frame {f}: the fits' joints {apart.mean() * 1000:.1f} mm apart"
    assert iterations["over"] < iterations["plain"], iterations


def test_images_read_at_a_smaller_scale_track_the_same_person(short_sequence, tmp_path):
    """Every image, mask and background read at 3/4 of its size, the calibration scaled
    with them: the person is tracked as well from the smaller images, every frame."""
    seq = Sequence(short_sequence, image_scale=0.75)
    assert (seq.cameras[0].width, seq.cameras[0].height) == (300, 225)
    assert seq.image(0, 0).shape == (225, 300, 3) and seq.mask(0, 0).shape == (225, 300)
    assert set(np.unique(seq.mask(0, 0))) <= {0, 255}
    result = Tracker(seq).run(tmp_path / "out", show_progress=False)
    acc = accuracy(result, short_sequence)
    assert acc.failed == 0 and acc.mean_mm < 25, acc.table()


def test_the_progress_bar_splits_a_frames_time_by_stage_since_tracking_began():
    from hullcap._progress import StageSplit

    seconds = {"subject": 30.0, "silhouettes": 1.0}
    split = StageSplit(seconds)  # the subject's model and what came before are not tracking's
    seconds.update(silhouettes=1.5, hull=0.2, fit=0.8)
    assert split.line(10, reading=0.4) == "silhouettes 50, hull 20, fit 80, read ahead 40 ms/frame"
    assert split.line(0) == "silhouettes 500, hull 200, fit 800 ms/frame"


def test_the_live_preset_builds_the_subjects_model_from_finer_hulls_than_it_tracks_with(sequence):
    carver = Tracker(sequence, options=TrackerOptions.preset("live")).carver
    with carver.building():
        fine = carver.carve(0)[0]
    coarse = carver.carve(0)[0]
    # a surface of the same body at twice the voxel: about a quarter of the vertices
    assert 2.5 < len(fine.vertices) / len(coarse.vertices) < 6


def test_the_subjects_model_is_searched_for_as_the_default_fit_does_whichever_preset_tracks(sequence, monkeypatch):
    """The model's first seconds are tracked, and searched where a fit falls short, by the
    same fits whatever fit tracking takes after (the live preset's shorter one too): the
    model is built once and does not depend on how the sequence is tracked with it."""
    import hullcap._subject_builder as builder

    class Seen(Exception):
        pass

    def state(model, options, anchor, search_fit=None, guide=None):
        raise Seen(options.fit, search_fit)

    monkeypatch.setattr(builder, "TrackingState", state)
    fits = []
    for preset in ("accurate", "live"):
        options = TrackerOptions.preset(preset, ignore_silhouettes=True, segmenter="colour")
        tracker = Tracker(sequence, options=options)
        tracker.segmenter.prepare()
        with pytest.raises(Seen) as seen:
            tracker.subject.build(len(Sequence(sequence)), show_progress=False)
        fits.append(seen.value.args)
    assert fits[0] == fits[1]
    assert fits[0][1].iterations == TrackerOptions().fit.iterations != TrackerOptions.preset("live").fit.iterations


def _faces_as(names, joints, truth_names, truth) -> bool:
    """Whether the left hip lies to the same side of the right as the truth's (seen from above)."""
    ours = joints[names.index("l_hip")] - joints[names.index("r_hip")]
    theirs = truth[truth_names.index("l_hip")] - truth[truth_names.index("r_hip")]
    return float(np.dot(ours[:2], theirs[:2])) > 0


def test_with_nothing_to_say_which_way_the_person_faces_the_first_seconds_decide(sequence):
    """Knees and elbows bend one way only: placed facing backwards, with no key points to
    say otherwise, the subject's model is turned round, since that explains its first
    seconds better; placed the right way, it stays."""
    from hullcap._evaluate import read_truth_joints
    from hullcap._subject import build_subject

    # the first second: standing, then the arms lowered and an elbow bent
    options = TrackerOptions(ignore_silhouettes=True, segmenter="colour", calibration_seconds=1.0)
    tracker = Tracker(sequence, options=options)
    tracker.segmenter.prepare()
    builder, n = tracker.subject, len(Sequence(sequence))
    end = builder.window_end(0, n)
    truth_names, truth = read_truth_joints(sequence)

    def faces_right(subject) -> bool:
        joints = subject.model.joints(subject.pose.theta, subject.pose.root_rotation, subject.pose.root_translation)
        return _faces_as(list(subject.model.joint_names), joints, truth_names, truth[0])

    hull, _ = tracker.carver.carve(0)
    right = build_subject(hull, options=options.subject)
    assert faces_right(right)
    kept, _ = builder._heading(right, builder._track_window(right, 0, end, n, False), 0, end, n, False)
    assert kept is right and not builder.problems.items

    backwards_start = PoseParameters(right.pose.theta, np.diag([-1.0, -1.0, 1.0]) @ right.pose.root_rotation,
                                     right.pose.root_translation)
    backwards = build_subject(tracker.carver.carve(0, (right.model, backwards_start))[0], poses=[backwards_start],
                              options=options.subject)
    assert not faces_right(backwards)
    turned, window = builder._heading(backwards, builder._track_window(backwards, 0, end, n, False), 0, end, n, False)
    assert faces_right(turned)
    assert "turned round" in builder.problems.items[-1].what
    assert np.mean(window.quality[:end]) > 0.7
