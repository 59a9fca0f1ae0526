"""Never lose the person: re-acquisition from the hull after a jump or unusable frames,
the per-frame status, interpolation of failed frames and smoothing."""

import cv2
import numpy as np
import pytest
from hullcap import BodyModel, Sequence, Tracker, TrackerOptions, smooth_joints
from hullcap._cameras import ring
from hullcap._carver import Carver
from hullcap._frame_fitter import FrameFitter
from hullcap._motions import motion_poses
from hullcap._reacquire import PoseSearch
from hullcap._results import FAILED, GOOD, INTERPOLATED, RECOVERED, TrackingResult
from hullcap._subject_builder import SubjectBuilder
from hullcap._synth import SUBJECTS, render_motion
from hullcap._take import limits_held_line
from hullcap.export import write_report

FRAMES = 30
JUMP = 14


def render(out, shift_after=None, shift=(0.0, 0.0, 0.0)):
    """The 'demo' motion of the 'short' subject, 6 cameras at 400×300, exact silhouettes;
    from frame `shift_after` on, the person stands `shift` metres away."""
    model = BodyModel.template().scaled(*SUBJECTS["short"])
    theta, rot, trans = motion_poses("demo", model.dof_names, 30.0, model.rest_root_height)
    theta, rot, trans = theta[:FRAMES], rot[:FRAMES], trans[:FRAMES].copy()
    if shift_after is not None:
        trans[shift_after:] += shift
    cams = ring(6, radius=4.2, width=400, height_px=300, fov_deg=62)
    seq = render_motion(out, cams, model, theta, rot, trans, silhouettes=True, show_progress=False)
    return seq, np.load(seq / "truth" / "joints.npz")["positions"], model


def errors(result, truth):
    return np.linalg.norm(result.joints - truth, axis=2).mean(1)


OPTIONS = TrackerOptions(refine_joints=False)


def test_a_person_who_jumps_a_metre_is_found_again_at_once(tmp_path):
    seq_path, truth, _ = render(tmp_path / "seq", JUMP, (0.7, 0.7, 0.0))
    result = Tracker(Sequence(seq_path), options=OPTIONS).run(tmp_path / "out", show_progress=False)
    e = errors(result, truth)
    assert not result.failed[JUMP + 3:].any(), result.status
    assert (result.status[JUMP:JUMP + 3] == RECOVERED).any(), result.status
    assert np.nanmax(e[JUMP + 3:]) < 0.05, e
    without = Tracker(Sequence(seq_path), options=TrackerOptions(refine_joints=False, reacquire=False))
    lost = without.run(tmp_path / "plain", show_progress=False)
    assert lost.failed[JUMP:].all()  # the search is what finds the person again


def test_unusable_first_frames_are_skipped_and_the_person_picked_up(tmp_path):
    seq_path, truth, _ = render(tmp_path / "seq")
    rng = np.random.default_rng(3)
    for f in range(20):  # blobs of noise where the person should be
        for cam in Sequence(seq_path).cameras:
            mask = np.zeros((cam.height, cam.width), np.uint8)
            for _ in range(6):
                x, y = rng.integers(0, cam.width - 40), rng.integers(0, cam.height - 40)
                mask[y:y + rng.integers(10, 40), x:x + rng.integers(10, 40)] = 255
            cv2.imwrite(str(seq_path / "silhouettes" / cam.name / f"{f:06d}.png"), mask)
    tracker = Tracker(Sequence(seq_path), options=OPTIONS)
    result = tracker.run(tmp_path / "out", show_progress=False)
    assert result.failed[:20].all()
    assert not result.failed[23:].any(), result.status
    assert np.nanmax(errors(result, truth)[23:]) < 0.05
    assert any(p.frame == 0 for p in tracker.problems)


def test_failed_frames_are_interpolated_only_when_asked_and_smoothing_keeps_raw(tmp_path):
    model = BodyModel.template()
    n = 40
    result = TrackingResult.empty(model, n, 30.0)
    t = np.arange(n) / 30.0
    for f in range(n):
        result.theta[f] = 0.0
        result.root_rotation[f] = np.eye(3)
        result.root_translation[f] = (t[f], 0.0, 1.0)
        result.joints[f] = model.pose(root_translation=result.root_translation[f]).joints
        result.status[f] = GOOD
    result.fail(10)
    result.fail(11)
    filled = result.interpolated()
    assert result.failed[10] and np.isnan(result.joints[10]).all()  # the raw result stays
    assert (filled.status[10:12] == INTERPOLATED).all()
    want = model.pose(root_translation=(10 / 30.0, 0.0, 1.0)).joints
    assert np.allclose(filled.joints[10], want, atol=1e-9)  # linear motion: exact
    smooth = smooth_joints(result.joints, 30.0, 6.0)
    assert np.isnan(smooth[10:12]).all()
    assert np.allclose(smooth[20:30], result.joints[20:30], atol=1e-3)  # a straight line passes
    noisy = result.joints + np.random.default_rng(0).normal(0, 0.005, result.joints.shape)
    assert np.nanstd(smooth_joints(noisy, 30.0, 3.0)[12:] - result.joints[12:]) < 0.6 * 0.005
    with pytest.raises(ValueError, match="half the frame rate"):
        smooth_joints(result.joints, 30.0, 20.0)
    assert FAILED == result.status[10]


def test_an_arm_raised_overhead_is_fitted_with_its_shoulder_girdle_lifted():
    """The exact mesh of arms raised overhead, the clavicles lifted 28°: a fit from the same
    arm line reached by the shoulders alone stays in that valley with the shoulder 6 cm
    low; the girdle start, which shares the elevation as the scapulohumeral rhythm does,
    explains the mesh fully and puts the shoulder back."""
    from hullcap._fitting import PoseParameters, fit, make_target, quality
    from hullcap._mesh import Surface

    model = BodyModel.template()
    names = list(model.dof_names)

    def raised(clavicle, abduction):
        theta = np.zeros(model.n_dofs)
        for side in "lr":
            theta[names.index(f"{side}_clavicle_elevation")] = np.radians(clavicle)
            theta[names.index(f"{side}_shoulder_abduction")] = np.radians(abduction)
            theta[names.index(f"{side}_shoulder_flexion")] = np.radians(10)
        return PoseParameters(theta, np.eye(3), np.array([0.0, 0.0, model.rest_root_height]))

    truth = model.pose(raised(28, 57).theta, root_translation=raised(28, 57).root_translation)
    target = make_target(Surface(truth.vertices, model.faces, truth.normals))
    shoulders = [model.joint_names.index(f"{side}_shoulder") for side in "lr"]

    def shoulder_error(fitted):
        p = fitted.pose
        joints = model.pose(p.theta, p.root_rotation, p.root_translation).joints
        return np.linalg.norm(joints[shoulders] - truth.joints[shoulders], axis=1).max()

    options = TrackerOptions().fit
    plain = fit(model, target, raised(0, 85), options)
    start = PoseSearch(model, options).girdle_start(plain.pose)
    assert shoulder_error(plain) > 0.04  # the valley the start is for
    for girdle_fit in (options, TrackerOptions().girdle_fit):  # the hierarchy's, and the tracker's
        girdle = fit(model, target, start, girdle_fit)
        assert quality(girdle) > quality(plain) + 0.02
        assert shoulder_error(girdle) < 0.02
    assert PoseSearch(model, options).girdle_start(girdle.pose) is None  # in rhythm: nothing to try
    search = PoseSearch(model, options)
    assert search.same_arm_lines(plain.pose, girdle.pose)  # the same arms, reached another way
    assert not search.same_arm_lines(plain.pose, raised(0, 25))  # arms lowered 60°: the search's to find


def test_the_girdle_fit_stands_within_its_tolerance_in_tracking_and_only_when_better_in_the_window(
        tmp_path, monkeypatch):
    """Tracking keeps the fit from the girdle start while it explains the hull at most
    `girdle_tolerance` less than the tracked fit and reaches the same arms; the first
    seconds tracked for the subject's model keep it only when it explains the hull better."""
    from types import SimpleNamespace

    from hullcap._fitting import PoseParameters
    from hullcap._reacquire import SearchOptions
    from hullcap._tracking_state import TrackingState
    from hullcap.errors import OptionsError

    model = BodyModel.template()
    names = list(model.dof_names)
    theta = np.zeros(model.n_dofs)
    for side in "lr":
        theta[names.index(f"{side}_shoulder_abduction")] = np.radians(85)
    pose = PoseParameters(theta, np.eye(3), np.array([0.0, 0.0, model.rest_root_height]))
    state = TrackingState(model, TrackerOptions(), None)
    girdle = state.search.girdle_start(pose)
    lowered = PoseParameters(np.zeros(model.n_dofs), pose.root_rotation, pose.root_translation)

    def result(p, q):
        return SimpleNamespace(pose=p, inlier_fraction=q, coverage=q)

    tracked, tolerance = result(pose, 0.83), SearchOptions().girdle_tolerance
    assert tolerance == 0.005
    assert state.takes_girdle_fit(tracked, result(girdle, 0.83 - 0.8 * tolerance))
    assert not state.takes_girdle_fit(tracked, result(girdle, 0.83 - 1.2 * tolerance))
    assert not state.takes_girdle_fit(tracked, result(lowered, 0.9))  # other arms: the search's to find
    with pytest.raises(OptionsError):
        SearchOptions(girdle_tolerance=-0.01)

    # The window's state, as SubjectBuilder._track_window builds it.
    seen = []
    monkeypatch.setattr(FrameFitter, "track", lambda self, state, *args: seen.append(state.search.options))
    seq_path, _, _ = render(tmp_path / "seq")
    Tracker(Sequence(seq_path), options=TrackerOptions(calibration_seconds=0.2)).run(
        tmp_path / "out", show_progress=False, frames=8)
    assert seen[0].girdle_tolerance == 0 and seen[-1].girdle_tolerance == tolerance


def test_the_calibration_window_keeps_its_prior_through_poor_fits(tmp_path, monkeypatch):
    """No frame of the window tracked for the subject's model fails: a fit under
    `min_quality` there leaves the next frame its prior (a failed frame would not, and on
    the development set that lost the later two thirds of a window), and it does not build
    the model. Frames 4-6 show a crate beside the person in every view, which no pose
    explains: their fits fall under the bar; the frames after them are still carved with a
    prior, and none of the three is among those the model is built from."""
    seq_path, _, _ = render(tmp_path / "seq")
    seq = Sequence(seq_path)
    crate = np.array([[x, y, z] for x in (1.1, 1.9) for y in (-0.4, 0.4) for z in (0.0, 0.8)])
    poor = (4, 5, 6)
    for f in poor:
        for cam in seq.cameras:
            path = seq_path / "silhouettes" / cam.name / f"{f:06d}.png"
            mask = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            corners = cam.project(crate)[0].round().astype(np.int32)
            cv2.fillConvexPoly(mask, cv2.convexHull(corners), 255)
            cv2.imwrite(str(path), mask)
    carved, hulls, window_done = [], [], []
    carve, track_window = Carver.carve, SubjectBuilder._track_window

    def spy_carve(self, frame, prior=None, doubt=None):
        (hulls if window_done else carved).append((frame, prior is not None))
        return carve(self, frame, prior, doubt)

    def spy_track_window(self, *args):
        window = track_window(self, *args)
        window_done.append(True)
        hulls.clear()  # those after the last window (with these masks, a second turns the model round to compare)
        return window

    monkeypatch.setattr(Carver, "carve", spy_carve)
    monkeypatch.setattr(SubjectBuilder, "_track_window", spy_track_window)
    options = TrackerOptions(calibration_seconds=0.4, calibration_frames=4, min_quality=0.75)
    window = round(options.calibration_seconds * seq.fps)  # 12 frames, the crate's among them
    _, first, _ = Tracker(seq, options=options).subject.build(FRAMES, show_progress=False)
    assert first == 0
    tracked = {}
    for f, with_prior in carved[1:]:  # the first frame, then the window in order
        tracked.setdefault(f, with_prior)
    assert [f for f in tracked if f < window] == list(range(window)), carved
    assert all(tracked[f] for f in range(1, window)), carved
    assert hulls and not {f for f, _ in hulls} & set(poor), hulls


def test_a_search_ranks_at_the_resolution_of_the_stages():
    """The tracker's fit pairs every second point in its stages; its search scores
    candidates on as many."""
    fit_options = TrackerOptions().fit
    rank = PoseSearch(BodyModel.template(), fit_options)._rank_options
    assert fit_options.coarse == 2 and rank.coarse == 1
    assert (rank.model_points, rank.reverse_points, rank.reverse_vertices) == (
        fit_options.model_points // 2, fit_options.reverse_points // 2, fit_options.reverse_vertices // 2)
    assert rank.replace(model_points=fit_options.model_points) == fit_options.replace(
        coarse=1, reverse_points=rank.reverse_points, reverse_vertices=rank.reverse_vertices)  # nothing else
    whole = TrackerOptions().calibration_fit
    assert PoseSearch(BodyModel.template(), whole)._rank_options == whole


def test_the_calibration_window_searches_as_tracking_does_and_refits_what_it_finds(tmp_path, monkeypatch):
    """The person jumps inside the window tracked for the subject's model: its search fits
    candidates as tracking does (one round, coarse stages) but with the window's steps as
    solved, not over-relaxed, and the pose it finds is fitted again with the window's own
    fit before it stands."""
    seq_path, truth, _ = render(tmp_path / "seq", JUMP, (0.7, 0.7, 0.0))
    options = TrackerOptions(calibration_seconds=1.0)  # the window holds the jump
    calls, in_window = [], []
    refine, search, fit_from = SubjectBuilder.refine, PoseSearch.search, FrameFitter.fit_from

    def spy_refine(self, *args, **kwargs):
        in_window.append(True)
        try:
            return refine(self, *args, **kwargs)
        finally:
            in_window.clear()

    def spy_search(self, *args):
        found, spent = search(self, *args)
        calls.append(("search", bool(in_window), self.fit_options, found.pose))
        return found, spent

    def spy_fit_from(self, state, target, start, fit_options):
        calls.append(("fit", bool(in_window), fit_options, start))
        return fit_from(self, state, target, start, fit_options)

    monkeypatch.setattr(SubjectBuilder, "refine", spy_refine)
    monkeypatch.setattr(PoseSearch, "search", spy_search)
    monkeypatch.setattr(FrameFitter, "fit_from", spy_fit_from)
    result = Tracker(Sequence(seq_path), options=options).run(tmp_path / "out", show_progress=False)
    window = [c for c in calls if c[1]]
    searches = [i for i, c in enumerate(window) if c[0] == "search"]
    as_tracking = options.fit.replace(over_relaxation=1.0)
    assert options.calibration_fit.over_relaxation == 1.0 and as_tracking != options.fit
    assert searches and all(window[i][2] == as_tracking for i in searches)
    refits = [i for i in searches if i + 1 < len(window) and window[i + 1][0] == "fit"
              and window[i + 1][2] is options.calibration_fit and window[i + 1][3] is window[i][3]]
    assert refits, window  # the pose the search found, fitted again with the window's fit
    assert not result.failed[JUMP + 3:].any() and np.nanmax(errors(result, truth)[JUMP + 3:]) < 0.05


def standing_template():
    """``(model, surface, target, moved)``: the template standing in its rest pose as a
    hull's surface and its target, and a function giving that pose moved by an offset
    (metres)."""
    from hullcap._fitting import PoseParameters, make_target
    from hullcap._mesh import Surface

    model = BodyModel.template()
    root = np.array([0.0, 0.0, model.rest_root_height])
    posed = model.pose(np.zeros(model.n_dofs), root_translation=root)
    surface = Surface(posed.vertices, model.faces, posed.normals)
    return model, surface, make_target(surface), lambda offset: PoseParameters(np.zeros(model.n_dofs), np.eye(3),
                                                                               root + offset)


def test_a_search_fits_only_candidates_that_explain_more_than_the_tracked_fit(monkeypatch):
    """A tracked fit that explains the whole body: no candidate of the search, before
    fitting, explains as much, none is fitted, and the chains are re-sampled from the
    tracked fit. A tracked fit a metre from the body: candidates are fitted, and the
    search finds the body."""
    from hullcap import _reacquire
    from hullcap._fitting import fit, quality

    model, surface, target, moved = standing_template()
    options = TrackerOptions()
    tracked = fit(model, target, moved(0.0), options.fit)
    far = fit(model, target, moved([1.0, 0.0, 0.0]), options.fit)
    fits, resampled = [], []
    monkeypatch.setattr(_reacquire, "fit", lambda *args, **kwargs: fits.append(1) or fit(*args, **kwargs))
    search = PoseSearch(model, options.fit)
    with monkeypatch.context() as m:
        m.setattr(PoseSearch, "resample", lambda self, target, start, chains: resampled.append(start) or (start, 0))
        found, spent = search.search(target, surface, [], None, tracked)
    assert found is tracked and resampled == [tracked] and spent == 0 and fits == []
    found, spent = search.search(target, surface, [], None, far)
    assert fits and spent > 0 and quality(found) > quality(far) + 0.3 and quality(found) > 0.9


def test_the_screen_passes_on_the_best_candidates_and_always_the_pose_to_beat():
    """A rough scoring on a quarter of the points passes the best `screen` candidates and
    the last pose (the one to beat) on to the scoring proper, which orders them as a
    ranking of every candidate would; the body's own pose comes first."""
    from hullcap._reacquire import SearchOptions
    from hullcap.errors import OptionsError

    model, _, target, moved = standing_template()
    rng = np.random.default_rng(5)
    poses = [moved(rng.normal(0.0, 0.08, 3)) for _ in range(12)]
    poses.insert(7, moved(0.0))
    poses.append(moved([1.0, 0.0, 0.0]))  # to beat: far off
    fit_options = TrackerOptions().fit
    every = PoseSearch(model, fit_options, SearchOptions(screen=0))._rank(target, poses)
    search = PoseSearch(model, fit_options, SearchOptions(screen=3))
    screened = search._rank(target, poses)
    assert len(every) == len(poses) and len(screened) == 4
    assert screened[0] is poses[7] and every[0] is poses[7] and screened[-1] is poses[-1]
    assert [id(p) for p in screened] == [id(p) for p in every if any(p is s for s in screened)]
    rank, rough = search._rank_options, search._screen_options
    assert (rough.model_points, rough.reverse_points, rough.reverse_vertices) == (
        rank.model_points // 4, rank.reverse_points // 4, rank.reverse_vertices // 4)
    for bad in ({"screen": -1}, {"screen_coarse": 0}, {"screen_margin": -0.1}, {"screen_margin": float("nan")}):
        with pytest.raises(OptionsError):
            SearchOptions(**bad)


def test_the_screen_drops_candidates_far_below_the_pose_to_beat(monkeypatch):
    """Candidates whose rough score lies more than `screen_margin` under the pose to beat's
    are not scored again, and when none is left the pose to beat stands at once; without a
    pose to beat the screen passes on its best by rank alone."""
    from hullcap._reacquire import SearchOptions

    model, _, target, moved = standing_template()
    rng = np.random.default_rng(6)
    near = [moved(rng.normal(0.0, 0.003, 3)) for _ in range(3)]
    far = [moved([0.5 + 0.1 * k, 0.0, 0.0]) for k in range(9)]
    beat = moved(0.0)
    search = PoseSearch(model, TrackerOptions().fit, SearchOptions(screen=8))
    scored = []
    qualities = PoseSearch._qualities
    monkeypatch.setattr(PoseSearch, "_qualities", lambda self, t, poses, o: scored.append(len(poses))
                        or qualities(self, t, poses, o))
    assert search._rank(target, far + [beat]) == [beat] and scored == [10]
    scored.clear()
    ranked = search._rank(target, far + near + [beat])
    assert scored == [13, 4] and {id(p) for p in ranked} == {id(p) for p in near + [beat]}
    scored.clear()
    assert len(search._rank(target, far + near, to_beat=False)) == 8 and scored == [12, 8]


def test_a_hinge_that_jumps_from_the_prediction_is_held_near_it():
    """An elbow or knee a fit turned more than `hinge_jump` from the prediction is limited
    to within `hinge_hold` of the prediction for the fit that checks it; nothing else is."""
    from hullcap._fitting import PoseParameters
    from hullcap._tracking_state import TrackingState
    from hullcap.errors import OptionsError

    model = BodyModel.template()
    names = list(model.dof_names)
    predicted = PoseParameters(np.zeros(model.n_dofs), np.eye(3), np.array([0.0, 0.0, model.rest_root_height]))
    theta = np.zeros(model.n_dofs)
    theta[names.index("l_elbow_flexion")] = np.radians(150)  # a fold
    theta[names.index("r_knee_flexion")] = np.radians(30)  # within the jump
    theta[names.index("l_shoulder_flexion")] = np.radians(90)  # not a hinge
    fitted = PoseParameters(theta, predicted.root_rotation, predicted.root_translation)
    options = TrackerOptions()
    state = TrackingState(model, options, None)
    held = state.hinges_held(predicted, fitted)
    before, after = model.link_model.dof_limits, held.link_model.dof_limits
    elbow = names.index("l_elbow_flexion")
    assert np.allclose(after[elbow], [max(before[elbow][0], -options.hinge_hold), options.hinge_hold])
    others = np.arange(model.n_dofs) != elbow
    assert np.array_equal(after[others], before[others])
    assert np.array_equal(held.vertices, model.vertices) and all(
        np.array_equal(a, b) for a, b in zip(held.skin, model.skin))
    assert state.hinges_held(predicted, predicted) is None
    assert TrackingState(model, TrackerOptions(hinge_jump=None), None).hinges_held(predicted, fitted) is None
    with pytest.raises(OptionsError, match="hinge_jump"):
        TrackerOptions(hinge_jump=0.0)


def test_an_elbow_that_turned_fast_keeps_the_forearm_as_it_was_in_doubt_for_a_while():
    """An elbow a fit turned more than `hinge_jump` from its angle in a tracked frame of
    the last `elbow_span` seconds is doubted at that frame's angle for `elbow_doubt`
    seconds, or until a fit brings it back within `hinge_hold`; a turn spread over more
    time is not doubted, nor one from a frame that failed, nor a knee's."""
    from hullcap._fitting import PoseParameters
    from hullcap._tracking_state import TrackingState
    from hullcap.errors import OptionsError

    model = BodyModel.template()
    names = list(model.dof_names)
    elbow, knee = names.index("l_elbow_flexion"), names.index("r_knee_flexion")

    def pose(**degrees):
        theta = np.zeros(model.n_dofs)
        for name, value in degrees.items():
            theta[names.index(name)] = np.radians(value)
        return PoseParameters(theta, np.eye(3), np.array([0.0, 0.0, model.rest_root_height]))

    def tracked(*elbows):
        """A result at 30 frames/s whose frames so far bent the left elbow so (None: failed)."""
        result = TrackingResult.empty(model, len(elbows) + 1, 30.0)
        for f, degrees in enumerate(elbows):
            if degrees is not None:
                result.theta[f] = pose(l_elbow_flexion=degrees).theta
                result.status[f] = GOOD
        return result, len(elbows)

    options = TrackerOptions(elbow_doubt=0.1, elbow_span=0.1)  # three frames each
    state = TrackingState(model, options, None)
    folded = pose(l_elbow_flexion=150, r_knee_flexion=100)
    assert state.as_before(folded) is None
    # 0° → 60° → 110° → 150°: a fold creeping 40–50° a frame, doubted from where it started.
    state.doubt_turns(*tracked(0, 60, 110), folded)
    assert state.doubted == {elbow: (0.0, 3)}  # not the knee, though it turned 100°
    before = state.as_before(folded)
    assert before.theta[elbow] == 0.0 and before.theta[knee] == folded.theta[knee]
    limits, own = state.held_as_before().link_model.dof_limits, model.link_model.dof_limits
    assert np.allclose(limits[elbow], [max(own[elbow][0], -options.hinge_hold), options.hinge_hold])
    assert np.array_equal(np.delete(limits, elbow, axis=0), np.delete(own, elbow, axis=0))
    state.doubt_turns(*tracked(90, 90, 90), pose())
    assert state.doubted[elbow][0] == 0.0  # an elbow in doubt keeps its angle
    state.age_doubts(folded)
    state.age_doubts(None)  # a failed frame
    assert state.doubted == {elbow: (0.0, 1)}
    state.age_doubts(folded)
    assert state.doubted == {}  # 0.1 s passed
    state.doubt_turns(*tracked(0, 0, 0), folded)
    state.age_doubts(pose(l_elbow_flexion=5))  # back within the hold
    assert state.doubted == {}
    state.doubt_turns(*tracked(0, 10, 20, 30, 40), pose(l_elbow_flexion=50))  # 10° a frame: 30° in the span
    assert state.doubted == {}
    state.doubt_turns(*tracked(0, 0, None, None, None), folded)  # nothing tracked in the span
    assert state.doubted == {}
    off = TrackingState(model, TrackerOptions(elbow_doubt=0), None)
    off.doubt_turns(*tracked(0, 0, 0), folded)
    assert off.doubted == {}
    for bad in ({"elbow_doubt": -1}, {"elbow_span": 0}):
        with pytest.raises(OptionsError, match=next(iter(bad))):
            TrackerOptions(**bad)


def test_angles_held_at_a_limit_are_found_and_drawn(tmp_path):
    model = BodyModel.template()
    names = list(model.dof_names)
    lo, hi = model.link_model.dof_limits.T
    result = TrackingResult.empty(model, 6, 30.0)
    for f in range(6):
        result.theta[f] = 0.5 * (lo + hi)
        result.root_rotation[f], result.root_translation[f] = np.eye(3), (0.0, 0.0, 1.0)
        result.status[f] = GOOD
    hip, ankle, elbow = (names.index(n) for n in ("r_hip_flexion", "l_ankle_inversion", "l_elbow_flexion"))
    result.theta[1:4, hip] = hi[hip] - np.radians(0.2)  # within the tolerance of the limit
    result.theta[4, hip] = hi[hip] - np.radians(2.0)    # clearly short of it
    result.theta[2, ankle] = lo[ankle]
    result.theta[:, elbow] = 0.0  # straight: the arm's own stop, not the model's bound
    result.fail(3)
    held = result.at_limits()
    assert held[:, hip].tolist() == [0, 1, 1, 0, 0, 0] and held[2, ankle] == -1
    assert not held[:, elbow].any() and not held[3].any()
    assert result.limits_held() == [("r_hip_flexion", "upper", 2), ("l_ankle_inversion", "lower", 1)]
    write_report(tmp_path / "report.png", result)
    assert cv2.imread(str(tmp_path / "report.png")) is not None
    assert "r_hip_flexion (upper) 2, l_ankle_inversion (lower) 1 (report.png)" in limits_held_line(result.limits_held())
    many = [(f"dof{k}", "upper", 10 - k) for k in range(6)]
    assert limits_held_line(many).endswith("dof3 (upper) 7 and 2 more (report.png)")
