"""The learned person segmenter: its geometry against hand-worked values, its masks against
the exact silhouettes, its fusion with the background test, and a run without it."""

import sys
from collections import defaultdict

import numpy as np
import pytest
from hullcap import BodyModel, PoseParameters, Sequence, TrackerOptions
from hullcap._cameras import ring
from hullcap._guided import GuidedOptions, GuidedSegmenter, learned_logit
from hullcap._person import (_ANCHORS, CROP_SCALE, LANDMARK_SIZE, TRACK_GAP, PersonSegmenter, PersonView,
                             _crop_transform, available, facing_agreement, missing)
from hullcap._problems import ProblemLog
from hullcap._segmenter import Segmenter
from hullcap._silhouette import StatisticalBackground
from hullcap._synth import synthesize
from hullcap.errors import OptionsError, SequenceError

@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Four cameras at 320×240 round the first frames of the demo, with exact silhouettes."""
    cams = ring(4, radius=3.2, width=320, height_px=240, fov_deg=55)
    return synthesize(tmp_path_factory.mktemp("seq") / "demo", "demo", cams, subject="short", frames=12,
                      silhouettes=True, show_progress=False)


needs_the_extra = pytest.mark.skipif(not available(), reason=f"the learned segmenter cannot run here: {missing()}")


def test_the_detectors_anchors_are_its_three_grids():
    assert _ANCHORS.shape == (28 * 28 * 2 + 14 * 14 * 2 + 7 * 7 * 6, 2) == (2254, 2)
    assert np.allclose(_ANCHORS[:2], 0.5 / 28)  # two anchors at the first cell's centre
    assert np.allclose(_ANCHORS[2], [1.5 / 28, 0.5 / 28])  # then along the row
    assert np.allclose(_ANCHORS[1568], 0.5 / 14) and np.allclose(_ANCHORS[-6:], 6.5 / 7)


@pytest.mark.parametrize("up", [(0.0, -100.0), (100.0, 0.0), (-60.0, 80.0)])
def test_the_crop_centres_the_hips_and_stands_the_body_upright(up):
    hip = np.array([300.0, 200.0])
    top = hip + up
    crop = _crop_transform(hip, top)
    at = lambda p: crop[:, :2] @ p + crop[:, 2]  # noqa: E731
    assert np.allclose(at(hip), LANDMARK_SIZE / 2, atol=1e-3)
    # The top straight above the hips, half the crop's side over CROP_SCALE away.
    assert np.allclose(at(top), [LANDMARK_SIZE / 2, LANDMARK_SIZE / 2 - LANDMARK_SIZE / (2 * CROP_SCALE)], atol=1e-3)


def test_what_is_missing_is_named_with_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "ai_edge_litert", None)
    monkeypatch.setitem(sys.modules, "ai_edge_litert.interpreter", None)
    assert "pip install 'hullcap[segment]'" in missing() and not available()
    with pytest.raises(OptionsError, match="cannot run: the LiteRT runtime is not installed"):
        PersonSegmenter()
    monkeypatch.undo()
    monkeypatch.setitem(sys.modules, "hullcap_segment_models", None)
    if missing() is not None and "LiteRT" not in missing():
        assert "make segment-models" in missing()


def test_the_learned_term_is_the_clipped_log_odds():
    o = GuidedOptions(learned_weight=2.0, learned_clip=3.0)
    p = np.array([[0.0, 0.5, 0.8, 1.0]], np.float32)
    assert np.allclose(learned_logit(p, o), [[-6.0, 0.0, 2 * np.log(4.0), 6.0]], atol=1e-5)


def _scene(rng):
    """A textured room, a person-shaped block in it whose lower half has the room's colours
    (camouflage) and whose upper half differs."""
    room = rng.integers(90, 110, (120, 100, 3)).astype(np.uint8)
    frame = room.copy()
    frame[20:60, 40:60] = (200, 40, 40)  # clearly not the room
    body = np.zeros(room.shape[:2], bool)
    body[20:100, 40:60] = True  # its lower half is the room itself
    return room, frame, body


def test_the_learned_segmenter_covers_camouflage_and_colour_covers_what_it_misses(rng):
    room, frame, body = _scene(rng)
    background = StatisticalBackground([room, room.copy()])
    segmenter = GuidedSegmenter(background, GuidedOptions())
    alone, _ = segmenter.segment(frame, None)
    assert (alone > 0)[body].mean() < 0.6  # the background test sees the upper half only
    learned = np.where(body, 0.98, 0.02).astype(np.float32)
    learned[20:40, 40:60] = 0.02  # and the network misses part of the upper half (a blurred limb)
    fused, _ = segmenter.segment(frame, None, learned=learned)
    inside = (fused > 0)[body].mean()
    outside = (fused > 0)[~body].mean()
    assert inside > 0.95 and outside < 0.01, (inside, outside)
    guided, unsure = segmenter.segment(frame, body, learned=learned)  # with the prediction too
    assert (guided > 0)[body].mean() > 0.95 and (guided > 0)[~body].mean() < 0.01 and unsure is not None


@needs_the_extra
def test_the_learned_masks_match_the_exact_silhouettes_of_a_rendered_person(rendered):
    seq = Sequence(rendered)
    person = PersonSegmenter()
    for cam in seq.cameras:
        found = person.find(seq.image(10, cam.name))
        assert found is not None, cam.name
        exact = seq.mask(10, cam.name) > 0
        mask = found.mask() > 0
        assert (mask & exact).sum() / (mask | exact).sum() > 0.9, cam.name
        inside = exact[np.clip(found.key_points[:, 1].round().astype(int), 0, exact.shape[0] - 1),
                       np.clip(found.key_points[:, 0].round().astype(int), 0, exact.shape[1] - 1)]
        assert inside[[11, 12, 23, 24]].all(), cam.name  # shoulders and hips on the person
    blank = np.full((240, 320, 3), 100, np.uint8)
    assert person.find(blank) is None


@needs_the_extra
def test_a_followed_person_needs_the_detector_once_and_is_found_as_well(rendered):
    """Frame after frame of one camera, the landmark model's own points place the next crop:
    the detector runs on the first frame, after a gap longer than TRACK_GAP, and when the
    followed crop holds nobody; the masks are as good as the detector's."""
    seq = Sequence(rendered)
    cam = seq.cameras[0]
    followed, detected = PersonSegmenter(), PersonSegmenter()
    for frame in range(0, 12, 2):
        image, exact = seq.image(frame, cam.name), seq.mask(frame, cam.name) > 0
        for found in (followed.find(image, frame), detected.find(image)):
            mask = found.mask() > 0
            assert (mask & exact).sum() / (mask | exact).sum() > 0.9, frame
    assert followed.detections == 1 and detected.detections == 6
    followed.find(seq.image(11, cam.name), 11 + TRACK_GAP)  # too long after: detected again
    assert followed.detections == 2
    assert followed.find(np.full_like(image, 100), 12 + TRACK_GAP) is None  # nobody: the detector says so
    assert followed.detections == 3


def _without_background(rendered, tmp_path):
    """A copy of the sequence without its background images."""
    import shutil

    copy = tmp_path / "seq"
    shutil.copytree(rendered, copy, ignore=shutil.ignore_patterns("background", "silhouettes"))
    return Sequence(copy)


@needs_the_extra
def test_a_take_without_a_background_is_segmented_by_the_learned_segmenter_alone(rendered, tmp_path):
    seq = _without_background(rendered, tmp_path)
    problems = ProblemLog(warn=False)
    segmenter = Segmenter(seq, TrackerOptions(), problems, defaultdict(float))
    assert segmenter.prepare(5) == 5 and segmenter.learned and not segmenter.guides
    assert "segmented by the learned person segmenter alone" in str(problems.items[0])
    masks, unsure = segmenter.segment(3)
    for cam, mask in zip(seq.cameras, masks):
        exact = Sequence(rendered).mask(3, cam.name) > 0
        assert ((mask > 0) & exact).sum() / ((mask > 0) | exact).sum() > 0.9, cam.name
    assert unsure == [None] * len(masks)


@needs_the_extra
def test_a_view_without_a_background_is_segmented_on_every_frame_whatever_learned_every(rendered, tmp_path):
    """Where the learned segmenter runs every few frames, a view with no background image
    still needs it on every frame: nothing else gives that view a mask."""
    seq = _without_background(rendered, tmp_path)
    segmenter = Segmenter(seq, TrackerOptions(learned_every=3), ProblemLog(warn=False), defaultdict(float))
    segmenter.prepare(6)
    for frame in (4, 5):
        masks, _ = segmenter.segment(frame)
        assert all(person is not None for person in segmenter.people[1]), frame
        assert all((mask > 0).sum() > 100 for mask in masks), frame


@needs_the_extra
def test_learned_every_k_frames_runs_on_a_share_of_the_views_and_on_all_while_building(rendered):
    options = TrackerOptions(ignore_silhouettes=True, learned_every=2)
    segmenter = Segmenter(Sequence(rendered), options, ProblemLog(warn=False), defaultdict(float))
    segmenter.prepare()
    for frame in (4, 5):
        segmenter.segment(frame)
        ran = [person is not None for person in segmenter.people[1]]
        assert ran == [(frame + i) % 2 == 0 for i in range(4)], frame
    with segmenter.every_frame():
        segmenter.segment(5)
    assert all(person is not None for person in segmenter.people[1])
    segmenter.segment(5)
    assert sum(person is not None for person in segmenter.people[1]) == 2


@needs_the_extra
def test_every_views_latest_key_points_judge_the_heading_and_a_resume_keeps_them(rendered, monkeypatch):
    """With the learned segmenter every other frame a frame has key points in half its views;
    the heading is judged by each view's latest, and a checkpoint keeps them exactly."""
    import hullcap._segmenter as module

    def segmenter():
        made = Segmenter(Sequence(rendered), TrackerOptions(ignore_silhouettes=True, learned_every=2),
                         ProblemLog(warn=False), defaultdict(float))
        made.prepare()
        return made

    first = segmenter()
    for frame in (4, 5):
        first.segment(frame)
    voted = []
    monkeypatch.setattr(module, "facing_agreement", lambda views, cameras, joints: voted.append(views) or 0.0)
    model = BodyModel.template()
    first.facing(5)(model, PoseParameters.rest(model))
    assert all(view is not None for view in voted[0])  # frame 4's views and frame 5's
    assert first.facing(6) is None  # not the frame last segmented
    arrays = dict(first.learnt())
    second = segmenter()
    second.relearn(arrays)
    assert "learnt_people" not in arrays
    for (f1, p1), (f2, p2) in zip(first._latest_people, second._latest_people):
        assert f1 == f2 and np.array_equal(p1.key_points, p2.key_points)
        assert np.array_equal(p1.visibility, p2.visibility) and p1.score == p2.score


@needs_the_extra
def test_the_detector_places_every_crop_while_building_and_the_person_is_followed_after(rendered):
    segmenter = Segmenter(Sequence(rendered), TrackerOptions(ignore_silhouettes=True, learned_every=1),
                          ProblemLog(warn=False), defaultdict(float))
    segmenter.prepare()
    with segmenter.every_frame():
        for frame in (0, 1, 2):
            segmenter.segment(frame)
    people = segmenter._people
    assert [p.detections for p in people] == [3] * 4 and all(p.followed is None for p in people)
    for frame in (3, 4, 5):
        segmenter.segment(frame)
    assert [p.detections for p in people] == [4] * 4 and all(p.followed[0] == 5 for p in people)
    crops = segmenter.learnt()["learnt_crops"]
    assert crops.shape == (4, 5) and (crops[:, 0] == 5).all()


def test_without_a_background_or_the_learned_segmenter_the_error_says_what_to_do(rendered, tmp_path):
    seq = _without_background(rendered, tmp_path)
    segmenter = Segmenter(seq, TrackerOptions(segmenter="colour"), ProblemLog(warn=False), defaultdict(float))
    with pytest.raises(SequenceError, match="the learned person segmenter segments the views, but it was turned off"):
        segmenter.prepare()


def test_asking_for_the_learned_segmenter_where_it_cannot_run_is_refused(rendered, monkeypatch):
    monkeypatch.setitem(sys.modules, "ai_edge_litert", None)
    monkeypatch.setitem(sys.modules, "ai_edge_litert.interpreter", None)
    with pytest.raises(OptionsError, match="segmenter 'learned': the LiteRT runtime is not installed"):
        Segmenter(Sequence(rendered), TrackerOptions(segmenter="learned", ignore_silhouettes=True),
                  ProblemLog(warn=False), defaultdict(float))
    auto = Segmenter(Sequence(rendered), TrackerOptions(ignore_silhouettes=True), ProblemLog(warn=False),
                     defaultdict(float))
    assert not auto.learned  # by default, colour alone where it cannot run


def test_the_key_points_tell_a_body_facing_backwards_from_one_facing_the_person():
    cams = ring(6, radius=3.0)
    joints = {"l_shoulder": np.array([0.0, 0.2, 1.4]), "r_shoulder": np.array([0.0, -0.2, 1.4]),
              "l_hip": np.array([0.0, 0.12, 0.9]), "r_hip": np.array([0.0, -0.12, 0.9])}
    views = []
    for cam in cams:
        key_points = np.zeros((33, 2), np.float32)
        for name, index in (("l_shoulder", 11), ("r_shoulder", 12), ("l_hip", 23), ("r_hip", 24)):
            key_points[index] = cam.project(joints[name][None])[0][0]
        views.append(PersonView(np.zeros((cam.height, cam.width), np.float32), key_points, np.ones(33, np.float32),
                                0.9))
    assert facing_agreement(views, cams, joints) == pytest.approx(1.0)
    turned = {f"{'r' if k[0] == 'l' else 'l'}{k[1:]}": v for k, v in joints.items()}  # left and right swapped
    assert facing_agreement(views, cams, turned) == pytest.approx(-1.0)
    unsure = [PersonView(v.probability, v.key_points, np.zeros(33, np.float32), v.score) for v in views]
    assert facing_agreement(unsure, cams, joints) == 0.0 and facing_agreement([None] * 6, cams, joints) == 0.0
    # One view alone does not tell: its left and right may be swapped (a person seen from behind).
    alone = [views[0]] + [None] * 5
    assert facing_agreement(alone, cams, turned) == 0.0
    assert facing_agreement(alone[:1] + views[1:2] + [None] * 4, cams, turned) == pytest.approx(-1.0)


def test_a_take_tracked_from_colour_alone_says_so_once(rendered, tmp_path, monkeypatch):
    from hullcap._take import TakeOptions, track_take

    monkeypatch.setitem(sys.modules, "ai_edge_litert", None)
    monkeypatch.setitem(sys.modules, "ai_edge_litert.interpreter", None)
    warnings = []
    options = TakeOptions(tracking=TrackerOptions(ignore_silhouettes=True, refine_joints=False), frames=2,
                          overlays=False)
    track_take(rendered, tmp_path / "out", options, show_progress=False, warn=warnings.append)
    said = [w for w in warnings if w.startswith("silhouettes from colour alone")]
    assert len(said) == 1 and "the LiteRT runtime is not installed" in said[0] and "docs/segmentation.md" in said[0]


def test_a_fit_facing_away_from_the_persons_key_points_does_not_stand(rendered, tmp_path, monkeypatch):
    """Where the key points say the person faces the other way (as they would of a model
    placed backwards), no fit of the frame stands, and problems.json says why."""
    from hullcap import Tracker

    def facing(self, frame):
        return (lambda model, pose: -1.0) if frame >= 6 else None
    monkeypatch.setattr(Segmenter, "facing", facing)
    options = TrackerOptions(ignore_silhouettes=True, segmenter="colour", refine_joints=False)
    tracker = Tracker(rendered, options=options)
    result = tracker.run(tmp_path / "out", show_progress=False, frames=8)
    assert not result.failed[:6].any() and result.failed[6:8].all()
    assert {p.frame for p in tracker.problems.items if "faces away" in p.what} == {6, 7}
