"""Each joint's confidence: its offset from the learned segmenter's key points against
hand-worked values, the confidence it gives, and a run's judgement of its frames through
pose.npz and joints.csv."""

import numpy as np
import pytest
from hullcap._body import BodyModel
from hullcap._cameras import ring
from hullcap import _segmenter as segmenter_module
from hullcap._confidence import (CONVENTION, FAR, KEY_POINTS_OF, MIN_VIEWS, NEAR, UNEXPLAINED_ABOVE,
                                 UNEXPLAINED_BAND, UNEXPLAINED_SCALE, UNSURE_BELOW, confidence, key_point_offsets,
                                 unexplained_share)
from hullcap._fitting import PoseParameters
from hullcap._person import KEY_POINTS, PersonView
from hullcap._results import FAILED, GOOD, INTERPOLATED, RECOVERED, UNCERTAIN, TrackingResult
from hullcap._tracking import Tracker, TrackerOptions
from hullcap.errors import ResultsError
from hullcap.export import load_result, write_joints_csv, write_outputs

NAMES = list(BodyModel.template().joint_names)


def _seen(cameras, names, joints, shift_px=None):
    """Each camera's PersonView whose key points are `joints` drawn into it (every key point
    seen), with `shift_px` {(camera, joint name): pixels to the right} moved."""
    views = []
    for c, cam in enumerate(cameras):
        points = np.zeros((KEY_POINTS, 2), np.float32)
        for name, key in KEY_POINTS_OF.items():
            if len(key) == 1:  # the joints of one key point place it; the others are their means
                pixels = cam.project(joints[names.index(name)][None])[0][0]
                points[key[0]] = pixels + [(shift_px or {}).get((c, name), 0.0), 0.0]
        for a, b, name in ((7, 8, "head"),):  # the ears either side of the head's point
            head = cam.project(joints[names.index(name)][None])[0][0]
            points[a], points[b] = head - [5, 0], head + [5, 0]
        views.append(PersonView(np.zeros((4, 4), np.float32), points, np.ones(KEY_POINTS, np.float32), 0.9))
    return views


@pytest.fixture
def scene():
    cameras = ring(4, radius=3.0, width=640, height_px=480, fov_deg=55)
    return cameras, BodyModel.template().pose().joints


def test_a_joint_on_its_key_points_is_0_off_and_a_shifted_one_as_far_as_its_depth_makes_it(scene):
    cameras, joints = scene
    at = key_point_offsets(_seen(cameras, NAMES, joints), cameras, NAMES, joints)
    elbow = NAMES.index("l_elbow")
    assert at[elbow] == pytest.approx(0.0, abs=1e-6)
    for name in ("waist", "chest", "l_clavicle"):  # no key point of their own: not measured
        assert np.isnan(at[NAMES.index(name)])
    # 40 px in three of four views: the median is the shift, in metres at the joint's depth.
    shifts = {(c, "l_elbow"): 40.0 for c in range(3)}
    off = key_point_offsets(_seen(cameras, NAMES, joints, shifts), cameras, NAMES, joints)
    depths = [cam.project(joints[elbow][None])[1][0] for cam in cameras[:3]]
    expected = sorted([40.0 * d / cam.K[0, 0] for d, cam in zip(depths, cameras)] + [0.0])
    assert off[elbow] == pytest.approx(np.median(expected), rel=1e-3)


def test_each_views_key_points_are_measured_against_the_joints_of_the_frame_they_were_seen_in(scene):
    """Where the learned segmenter ran on a view a frame or two ago, its key points are held
    against the joints of that frame, not of this one: a body that moved is not off."""
    cameras, joints = scene
    moved = joints + [0.3, 0.0, 0.0]  # this frame's joints; two views were seen a frame before
    views = _seen(cameras[:2], NAMES, joints) + _seen(cameras[2:], NAMES, moved)
    each = np.stack([joints, joints, moved, moved])
    elbow = NAMES.index("l_elbow")
    assert key_point_offsets(views, cameras, NAMES, each)[elbow] == pytest.approx(0.0, abs=1e-6)
    assert key_point_offsets(views, cameras, NAMES, moved)[elbow] > 0.05  # against this frame's alone: off
    each[0] = np.nan  # a view whose frame was not fitted does not count
    assert key_point_offsets(views, cameras, NAMES, each)[elbow] == pytest.approx(0.0, abs=1e-6)


def test_fewer_views_than_the_least_or_key_points_out_of_view_leave_a_joint_unmeasured(scene):
    cameras, joints = scene
    views = _seen(cameras, NAMES, joints)
    knee = NAMES.index("r_knee")
    for view in views[1:]:
        view.visibility[KEY_POINTS_OF["r_knee"]] = 0.1
    assert MIN_VIEWS == 2 and np.isnan(key_point_offsets(views, cameras, NAMES, joints)[knee])
    assert np.isfinite(key_point_offsets([views[0], None, None, views[3]], cameras, NAMES, joints)[NAMES.index("head")])
    assert np.isnan(key_point_offsets([None] * 4, cameras, NAMES, joints)).all()


def test_confidence_forgives_a_steady_offset_up_to_the_convention_and_ramps_between_near_and_far():
    frames, j = 7, NAMES.index("l_knee")
    offsets = np.full((frames, len(NAMES)), np.nan)
    kept = np.ones(frames, bool)
    offsets[:, j] = 0.05  # a steady 5 cm: a convention, forgiven
    offsets[5, j] = 0.05 + (NEAR + FAR) / 2  # halfway up the ramp
    offsets[6, j] = 0.05 + FAR + 0.01  # beyond it
    c = confidence(NAMES, offsets, kept)
    assert np.allclose(c[:5, j], 1.0) and c[5, j] == pytest.approx(0.5) and c[6, j] == 0.0
    assert np.isnan(c[:, NAMES.index("l_hip")]).all()  # never measured: not judged
    # A steady offset beyond the convention is forgiven only up to it.
    offsets[:, j] = 0.30
    far_off = confidence(NAMES, offsets, kept)[0, j]
    assert far_off == pytest.approx(np.clip((FAR - (0.30 - CONVENTION)) / (FAR - NEAR), 0, 1))
    assert far_off == 0.0
    # Frames not kept are not judged, nor counted in the steady offset.
    kept[:3] = False
    offsets[:3, j] = 5.0
    offsets[3:, j] = 0.02
    c = confidence(NAMES, offsets, kept)
    assert np.isnan(c[:3, j]).all() and np.allclose(c[3:, j], 1.0)


def test_joints_without_a_key_point_take_the_least_confidence_of_the_joints_that_place_them():
    offsets = np.full((3, len(NAMES)), 0.0)
    offsets[:, [NAMES.index(n) for n in ("waist", "chest", "l_clavicle", "r_clavicle")]] = np.nan
    offsets[2, NAMES.index("neck")] = FAR + 1.0
    c = confidence(NAMES, offsets, np.ones(3, bool))
    assert c[2, NAMES.index("waist")] == c[2, NAMES.index("chest")] == 0.0
    assert c[1, NAMES.index("waist")] == c[2, NAMES.index("l_clavicle")] == 1.0


def _result(frames=6):
    model = BodyModel.template()
    result = TrackingResult.empty(model, frames, 30.0)
    theta, rotation, translation = np.zeros(model.n_dofs), np.eye(3), np.array([0.0, 0.0, 1.0])
    for f in range(frames):
        result.theta[f], result.root_rotation[f], result.root_translation[f] = theta, rotation, translation
        result.joints[f] = model.joints(theta, rotation, translation)
        result.status[f] = result.joint_status[f] = GOOD
        result.key_point_offset[f] = 0.03
    return result


def test_judge_marks_the_unsupported_joints_and_their_frames_uncertain_and_keeps_the_rest():
    result = _result()
    wrist = NAMES.index("r_wrist")
    result.key_point_offset[2, wrist] = 0.5
    result.status[3] = result.joint_status[3] = RECOVERED
    result.key_point_offset[3, wrist] = 0.5
    result.fail(4)
    result.key_point_offset[5] = np.nan  # no key points seen: not judged, stays good
    result.judge()
    assert list(result.status) == [GOOD, GOOD, UNCERTAIN, UNCERTAIN, FAILED, GOOD]
    judged = result.joint_status.copy()
    result.judge()  # again: the same
    assert list(result.status) == [GOOD, GOOD, UNCERTAIN, UNCERTAIN, FAILED, GOOD]
    assert np.array_equal(result.joint_status, judged)
    assert result.joint_status[2, wrist] == result.joint_status[3, wrist] == UNCERTAIN
    assert result.joint_status[2, NAMES.index("l_wrist")] == GOOD
    assert result.joint_status[3, NAMES.index("l_wrist")] == RECOVERED
    assert (result.joint_status[4] == FAILED).all()
    assert result.confidence[2, wrist] == 0.0 and result.confidence[2, wrist] < UNSURE_BELOW
    assert np.isnan(result.confidence[4]).all() and np.isnan(result.confidence[5]).all()
    filled = result.interpolated()
    assert filled.status[4] == INTERPOLATED and (filled.joint_status[4] == INTERPOLATED).all()
    assert np.isnan(filled.confidence[4]).all()


def test_the_unexplained_share_counts_the_foreground_beyond_the_band_round_the_fitted_silhouette():
    """Against pixels counted one by one: a fitted silhouette 100 px tall, a mask that
    holds it grown by less than the band, and a blob far from it."""
    silhouette = np.zeros((200, 200), bool)
    silhouette[50:150, 80:120] = True
    band = UNEXPLAINED_BAND * 100
    mask = np.zeros((200, 200), np.uint8)
    grow = 3  # even at its corners (4.2 px) within the band (5 px)
    assert np.hypot(grow, grow) < band
    mask[50 - grow:150 + grow, 80 - grow:120 + grow] = 255
    assert unexplained_share([mask], [silhouette]) == 0.0
    mask[0:20, 0:20] = 255  # an arm where the model has none
    ys, xs = np.nonzero(mask)
    inside = (ys >= 50) & (ys < 150) & (xs >= 80) & (xs < 120)
    beyond = [np.hypot(max(0, 80 - x, x - 119), max(0, 50 - y, y - 149)) > band
              for y, x in zip(ys[~inside], xs[~inside])]
    assert sum(beyond) == 400
    assert unexplained_share([mask], [silhouette]) == pytest.approx(400 / len(ys))
    # the median over the views; a view without foreground or silhouette does not count
    explained = mask.copy()
    explained[0:20, 0:20] = 0
    views = [mask, explained, explained, np.zeros_like(mask), mask]
    sils = [silhouette, silhouette, silhouette, silhouette, np.zeros_like(silhouette)]
    assert unexplained_share(views, sils) == 0.0
    assert np.isnan(unexplained_share([np.zeros_like(mask)], [silhouette]))


def test_a_frame_that_leaves_the_colour_foreground_unexplained_is_uncertain_every_joint():
    result = _result()
    result.unexplained[:] = [0.0, UNEXPLAINED_ABOVE / 2, 2 * UNEXPLAINED_ABOVE, 2 * UNEXPLAINED_ABOVE, np.nan, 0.0]
    result.status[3] = result.joint_status[3] = RECOVERED
    result.fail(5)
    result.judge()
    assert list(result.status) == [GOOD, GOOD, UNCERTAIN, UNCERTAIN, GOOD, FAILED]
    assert (result.joint_status[2] == UNCERTAIN).all() and (result.joint_status[1] == GOOD).all()
    assert np.isnan(result.unexplained[5])  # a failed frame measures nothing


def test_the_end_of_a_run_says_how_its_frames_were_judged():
    from hullcap._take import _judged_line

    result = _result()
    result.key_point_offset[:] = np.nan  # no key points: joints not judged
    assert _judged_line(result).startswith("joints not judged")
    result.unexplained[:] = [0.0, 0.5, 0.0, 0.0, 0.0, 0.0]
    result.judge()
    assert _judged_line(result).startswith("1 frames uncertain, the fit leaving the background test's foreground")
    result.key_point_offset[:] = 0.03
    assert "key points do not support" in _judged_line(result)


def test_status_and_confidence_round_trip_through_pose_npz_and_reach_joints_csv(tmp_path):
    result = _result()
    result.key_point_offset[1, NAMES.index("l_knee")] = 0.5
    result.unexplained[:3] = [0.0, 0.01, 0.015]  # under the bar: the frames stay as judged
    result.judge()
    result.model.save(tmp_path / "model")
    write_outputs(tmp_path, result)
    again = load_result(tmp_path)
    assert np.array_equal(again.status, result.status) and np.array_equal(again.joint_status, result.joint_status)
    assert np.array_equal(again.unexplained, result.unexplained, equal_nan=True)
    assert np.array_equal(again.confidence, result.confidence, equal_nan=True)
    with np.load(tmp_path / "pose.npz") as z:
        arrays = {k: z[k] for k in z.files}
    assert np.array_equal(arrays["confidence"], result.confidence, equal_nan=True)
    rows = [line.split(",") for line in (tmp_path / "joints.csv").read_text().splitlines()]
    assert rows[0][-2:] == ["status", "confidence"]
    knee = next(r for r in rows[1:] if r[0] == "1" and r[2] == "l_knee")
    assert knee[-2:] == ["uncertain", "0.000"]
    waist = next(r for r in rows[1:] if r[0] == "0" and r[2] == "waist")
    assert waist[-2:] == ["good", "1.000"]
    # Asked to, the exports leave the uncertain joints out as gaps, the rest as they were.
    from hullcap._cli import main
    from hullcap.export import read_trc

    assert main(["export", str(tmp_path), "--format", "trc", "--drop-uncertain", "--up", "z", "--units", "m"]) == 0
    _, trc, _ = read_trc(tmp_path / "joints.trc", up="z")
    knee = NAMES.index("l_knee")
    assert np.isnan(trc[1, knee]).all() and np.isfinite(np.delete(trc[1], knee, axis=0)).all()
    assert np.allclose(trc[0], result.joints[0], atol=1e-5)
    assert main(["export", str(tmp_path), "--format", "csv", "--drop-uncertain", "--to", str(tmp_path / "d.csv")]) == 0
    assert len((tmp_path / "d.csv").read_text().splitlines()) == len(rows) - 1
    assert main(["export", str(tmp_path), "--format", "bvh", "--drop-uncertain"]) == 2
    # Codes it does not know are named; a pose.npz from before joints were judged loads
    # with each joint its frame's status and none judged.
    np.savez(tmp_path / "pose.npz", **(arrays | {"joint_status": np.full_like(arrays["joint_status"], 9)}))
    with pytest.raises(ResultsError, match="joint_status holds codes other than 0–4"):
        load_result(tmp_path)
    older = {k: v for k, v in arrays.items() if k not in ("joint_status", "key_point_offset", "confidence")}
    np.savez(tmp_path / "pose.npz", **older)
    old = load_result(tmp_path)
    assert (old.joint_status == old.status[:, None]).all() and np.isnan(old.confidence).all()
    write_joints_csv(tmp_path / "old.csv", old)
    assert (tmp_path / "old.csv").read_text().splitlines()[1].endswith(",good,")  # not judged: no confidence


def test_the_background_test_judges_a_fit_at_half_the_image_size_as_at_full(sequence, monkeypatch):
    """The share of the background test's foreground a fit leaves unexplained, measured at
    half the image size as tracking does, is the full size's within half a point: next to
    nothing for the true body at its true pose, over the bar with it 30 cm aside."""
    model = BodyModel.load(sequence / "truth" / "model")
    truth = np.load(sequence / "truth" / "pose.npz")
    segmenter = Tracker(sequence, options=TrackerOptions(ignore_silhouettes=True, segmenter="colour")).segmenter
    segmenter.prepare()
    frame = 35
    segmenter.segment(frame)
    pose = PoseParameters(truth["theta"][frame], truth["root_rotation"][frame], truth["root_translation"][frame])
    aside = PoseParameters(pose.theta, pose.root_rotation, pose.root_translation + np.array([0.3, 0.0, 0.0]))
    shares = {}
    for scale in (1.0, UNEXPLAINED_SCALE):
        monkeypatch.setattr(segmenter_module, "UNEXPLAINED_SCALE", scale)
        shares[scale] = np.array([segmenter.unexplained(frame, model, p) for p in (pose, aside)])
    full, half = shares[1.0], shares[UNEXPLAINED_SCALE]
    assert UNEXPLAINED_SCALE < 1 and np.abs(half - full).max() < 0.005, shares
    assert half[0] < UNEXPLAINED_ABOVE / 4 and half[1] > 2 * UNEXPLAINED_ABOVE, shares
