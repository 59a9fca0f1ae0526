"""Silhouettes: background subtraction against its arithmetic, mask clean-up, the guided masks."""

import shutil

import cv2
import numpy as np
import pytest
from hullcap._engine import background_distortions, background_evidence
from hullcap._sequence import Sequence
from hullcap._silhouette import FOREGROUND_EVIDENCE, StatisticalBackground, Thresholds, background_model
from hullcap._synth import synthesize
from hullcap.errors import ArrayError, ViewError


def test_background_subtraction_recovers_silhouettes_and_ignores_shadows(sequence):
    seq = Sequence(sequence)
    models = [StatisticalBackground(seq.background(i)) for i in range(4)]
    ious, shadow_fg = [], []
    for frame in (0, 15, 30, 41):
        for i, img in enumerate(seq.images(frame)):
            truth = cv2.imread(str(sequence / "truth" / "silhouettes" / f"cam{i}" / f"{frame:06d}.png"), 0) > 0
            mask = models[i].mask(img) > 0
            ious.append((mask & truth).sum() / (mask | truth).sum())
            # Shadow: pixels off the subject clearly darker than the empty scene.
            diff = seq.background(i).astype(int).sum(-1) - img.astype(int).sum(-1)
            shadow = (diff > 60) & ~cv2.dilate(truth.astype(np.uint8), np.ones((5, 5))).astype(bool)
            if shadow.sum() > 20:
                shadow_fg.append(mask[shadow].mean())
    assert np.mean(ious) >= 0.97 and min(ious) > 0.9, ious
    assert shadow_fg and max(shadow_fg) < 0.02, shadow_fg
    with pytest.raises(ValueError, match="unknown background subtraction method"):
        background_model(seq.background(0), "magic")
    with pytest.raises(ValueError, match="does not match the background"):
        models[0].mask(np.zeros((10, 10, 3), np.uint8))


def _reference_evidence(backgrounds, image, noise_floor=2.5, t=Thresholds()):
    """Horprasert's evidence written out in NumPy, step by step in single precision as
    `StatisticalBackground` computed it before the engine did."""
    stack = np.asarray(backgrounds)
    mean = stack.mean(0)
    spread = stack.std(0) if len(stack) > 1 else np.zeros_like(mean)
    inv_s = (1.0 / np.maximum(spread, noise_floor)).astype(np.float32)
    es = (mean * inv_s).astype(np.float32)
    es2 = np.maximum((es * es).sum(-1), 1e-6).astype(np.float32)

    def distortions(img):
        i_s = [cv2.multiply(p, inv_s[..., c], dtype=cv2.CV_32F) for c, p in enumerate(cv2.split(img))]
        dot = i_s[0] * es[..., 0] + i_s[1] * es[..., 1] + i_s[2] * es[..., 2]
        alpha = dot / es2
        cd2 = i_s[0] * i_s[0] + i_s[1] * i_s[1] + i_s[2] * i_s[2] - dot * alpha
        return alpha, np.sqrt(np.maximum(cd2, 0))

    b = np.full(es2.shape, np.sqrt(2.0), np.float32)
    if len(stack) > 1:
        b = np.maximum(b, np.sqrt(np.mean(np.array([distortions(img)[1] for img in stack]) ** 2, 0)))
    alpha, cd = distortions(image)
    ev = cd * (1.0 / b).astype(np.float32) - t.chromaticity
    ev[(alpha < t.darkest_shadow) | (alpha > t.brightest_highlight)] = FOREGROUND_EVIDENCE
    return ev


@pytest.mark.parametrize("images", [1, 4])
def test_the_engines_background_test_is_the_numpy_arithmetic_to_the_bit(images, rng):
    """The evidence of every pixel, for a model of one background image (spread = the
    noise floor) and of several (spread measured): equal to the NumPy steps bit for bit,
    on every kind of pixel (background, noise, shadow, highlight, another colour, black,
    white)."""
    scene = rng.integers(0, 256, (37, 53, 3)).astype(np.uint8)  # 1961 pixels: 8 at a time and a rest
    backgrounds = [np.clip(scene + rng.normal(0, 3, scene.shape), 0, 255).astype(np.uint8) for _ in range(images)]
    model = StatisticalBackground(backgrounds)
    for frame in (scene, backgrounds[0],
                  np.clip(scene * rng.uniform(0.2, 1.6, scene.shape[:2])[..., None], 0, 255).astype(np.uint8),
                  rng.integers(0, 256, scene.shape).astype(np.uint8), np.zeros_like(scene), np.full_like(scene, 255)):
        expected = _reference_evidence(backgrounds, frame)
        evidence = model.evidence(frame)
        assert evidence.dtype == np.float32 and evidence.shape == scene.shape[:2]
        np.testing.assert_array_equal(evidence, expected)
    alpha, cd = model._distortions(scene)
    assert alpha.shape == cd.shape == scene.shape[:2] and np.all(cd >= 0)


def test_the_engines_background_test_refuses_what_does_not_fit():
    planes = np.ones((8, 4, 5), np.float32)
    with pytest.raises(ArrayError, match="8 planes|got 7 planes"):
        background_evidence(np.zeros((4, 5, 3), np.uint8), planes[:7], (3.0, 0.45, 1.35, 6.0))
    with pytest.raises(ArrayError, match="image is 5×3 with 3 channels, the background model 5×4"):
        background_evidence(np.zeros((3, 5, 3), np.uint8), planes, (3.0, 0.45, 1.35, 6.0))
    with pytest.raises(ArrayError, match="image"):
        background_distortions(np.zeros((4, 5), np.uint8), planes)


@pytest.mark.parametrize("method", ["statistical", "mog2"])
def test_the_clean_up_scales_with_the_image(method):
    """Specks and holes are judged by their share of the image: the same scene at half the
    resolution keeps a blob a quarter the size, and a size in pixels is refused."""
    def scene(side):
        img = np.full((side * 3 // 4, side, 3), 90, np.uint8)
        return img, img.copy()

    for side, blob in ((640, 15), (320, 8)):  # 225 and 64 pixels: 1.1 and 1.3 times the least blob
        empty, frame = scene(side)
        frame[10:10 + blob, 10:10 + blob] = (20, 200, 240)
        model = background_model(empty, method)
        assert (model.min_blob, model.max_hole) == ((200, 2000) if side == 640 else (50, 500))
        assert (model.mask(frame) > 0).sum() >= blob * blob - 4 * blob  # kept (its outline may go)
        frame[10:10 + blob, 10:10 + blob] = 90
        frame[10:16, 10:16] = (20, 200, 240)  # 36 pixels: a speck at both sizes
        assert not model.mask(frame).any()
    with pytest.raises(ValueError, match="min_blob is a fraction of the image's area"):
        background_model(empty, method, min_blob=200)


def _reference_clean_mask(mask, min_blob, max_hole):
    """`clean_mask`'s rule written out with SciPy's labelling: open by a 3×3 square (as
    OpenCV does: erode with the outside counted as foreground, then dilate), drop
    8-connected blobs below `min_blob` pixels, fill 4-connected background components
    that touch no border and have at most `max_hole` pixels."""
    from scipy import ndimage

    square = np.ones((3, 3), bool)
    fg = ndimage.binary_dilation(ndimage.binary_erosion(mask > 0, square, border_value=1), square)
    labels, n = ndimage.label(fg, square)
    for k in range(1, n + 1):
        if (labels == k).sum() < min_blob:
            fg[labels == k] = False
    labels, n = ndimage.label(~fg)
    border = set(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    for k in range(1, n + 1):
        if k not in border and (max_hole is None or (labels == k).sum() <= max_hole):
            fg[labels == k] = True
    return np.where(fg, 255, 0).astype(np.uint8)


def test_mask_clean_up_drops_specks_and_fills_holes_as_labelling_every_component_does(rng):
    from hullcap._silhouette import clean_mask

    for _ in range(300):
        h, w = rng.integers(1, 40, 2)
        noise = rng.random((h, w))
        if rng.random() < 0.7:  # blobs with holes, as a silhouette has; else salt and pepper
            noise = cv2.GaussianBlur(noise, (0, 0), rng.uniform(0.3, 2.0))
        mask = _somewhere_in_a_frame(np.where(noise > rng.uniform(0.3, 0.7), 255, 0).astype(np.uint8), rng)
        min_blob, max_hole = int(rng.integers(1, 30)), None if rng.random() < 0.2 else int(rng.integers(0, 30))
        assert np.array_equal(clean_mask(mask, min_blob, max_hole), _reference_clean_mask(mask, min_blob, max_hole))
    for mask in (np.zeros((4, 5), np.uint8), np.full((4, 5), 255, np.uint8), np.full((1, 1), 255, np.uint8)):
        assert np.array_equal(clean_mask(mask, 1, 3), _reference_clean_mask(mask, 1, 3))


def _somewhere_in_a_frame(mask, rng):
    """`mask` as it is (touching the frame's borders), or placed in a larger empty frame
    at a random place, half the time each: the clean-up works in the foreground's box."""
    if rng.random() < 0.5:
        return mask
    (h, w), (ph, pw) = mask.shape, rng.integers(0, 12, 2)
    frame = np.zeros((h + ph + int(rng.integers(0, 12)), w + pw + int(rng.integers(0, 12))), np.uint8)
    frame[ph:ph + h, pw:pw + w] = mask
    return frame


def test_half_covered_outlines_are_the_rule_applied_to_the_whole_frame(rng):
    """`half_covered` works in the mask's box; written out over the whole frame: an
    outline pixel (foreground with a background pixel among its eight neighbours; outside
    the frame counts as foreground, as OpenCV's erosion has it) is dropped when its
    distortion is under half the largest among itself and its neighbours in the frame."""
    from scipy import ndimage

    from hullcap._silhouette import half_covered

    square = np.ones((3, 3), bool)
    for _ in range(200):
        h, w = rng.integers(1, 40, 2)
        blobs = cv2.GaussianBlur(rng.random((h, w)), (0, 0), rng.uniform(0.3, 2.0))
        mask = _somewhere_in_a_frame(np.where(blobs > rng.uniform(0.3, 0.7), 255, 0).astype(np.uint8), rng)
        evidence = rng.gamma(2.0, 3.0, mask.shape).astype(np.float32) - 3
        threshold = float(rng.uniform(3, 4))  # given as the background test's evidence and its threshold
        distortion = evidence + threshold
        fg = mask > 0
        ring = fg & ~ndimage.binary_erosion(fg, square, border_value=1)
        largest = ndimage.maximum_filter(distortion, size=3, mode="constant", cval=-np.inf)
        want = np.where(ring & (distortion < 0.5 * largest), 0, mask).astype(np.uint8)
        assert np.array_equal(half_covered(mask, distortion), want)
        assert np.array_equal(half_covered(mask, evidence, threshold), want)
    assert not half_covered(np.zeros((3, 4), np.uint8), np.ones((3, 4), np.float32)).any()


@pytest.mark.parametrize("form", ["folder", "video"])
def test_a_clip_of_the_empty_room_teaches_the_background_model_what_flickers(sequence, tmp_path, form):
    """cam0's background as a clip of the empty room in which a screen's colour swings
    between red and blue by ±20 grey levels: the model learnt from the clip keeps the
    screen as background in a frame where it is at its bluest, the model of one image
    does not; at most `most` frames are read, spread over the clip; two backgrounds for
    one camera are refused, naming both."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    still = cv2.imread(str(seq_path / "background" / "cam0.png"))
    rng = np.random.default_rng(7)
    screen = (slice(40, 90), slice(30, 110))

    def frame(level):
        img = still.astype(float) + rng.normal(0, 2.0, still.shape)
        img[screen + (0,)] += level  # blue up, red down: the same brightness, another hue
        img[screen + (2,)] -= level
        return np.clip(img, 0, 255).astype(np.uint8)

    levels = 20 * np.sin(np.linspace(0, 6 * np.pi, 24))
    clip = [frame(level) for level in levels]
    if form == "folder":
        (seq_path / "background" / "cam0").mkdir()
        for i, img in enumerate(clip):
            cv2.imwrite(str(seq_path / "background" / "cam0" / f"{i:06d}.png"), img)
    else:
        writer = cv2.VideoWriter(str(seq_path / "background" / "cam0.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30,
                                 still.shape[1::-1])
        for img in clip:
            writer.write(img)
        writer.release()
    with pytest.raises(ValueError, match=r"camera 'cam0' has 2 backgrounds \(cam0.png, cam0(/|\.avi)?"):
        Sequence(seq_path).backgrounds("cam0")
    (seq_path / "background" / "cam0.png").unlink()
    seq = Sequence(seq_path)
    few = seq.backgrounds("cam0", most=5)
    assert len(few) == 5
    tolerance = 0 if form == "folder" else 6  # MJPG's loss
    assert np.abs(few[0].astype(int) - clip[0]).mean() <= tolerance
    assert np.abs(few[-1].astype(int) - clip[-1]).mean() <= tolerance
    learnt = StatisticalBackground(seq.backgrounds("cam0"))
    assert len(seq.backgrounds("cam0")) == 24
    one = StatisticalBackground(seq.backgrounds("cam0")[0])
    bluest = frame(20.0)
    on_screen = lambda model: (model.mask(bluest)[screen] > 0).mean()  # noqa: E731
    assert on_screen(one) > 0.5 and on_screen(learnt) < 0.05
    # The image the rest of the pipeline shows for the background: the clip's mean.
    assert np.abs(seq.background("cam0").astype(int)[screen] - still[screen]).mean() < 12
    shutil.rmtree(seq_path / "background" / "cam0", ignore_errors=True)
    (seq_path / "background" / "cam0.avi").unlink(missing_ok=True)
    with pytest.raises(ViewError, match=r"cam0.png: missing, and there is no clip of the empty scene either"):
        seq.backgrounds("cam0")


def test_the_texture_test_sees_the_floor_through_a_shadow_but_not_through_cloth_of_its_colour(rng):
    from hullcap._guided import GuidedOptions, TextureTest

    # A tiled floor (joints darker than the tiles) with sensor noise, and a flat wall.
    h, w = 60, 80
    floor = np.full((h, w), 150.0)
    floor[::10, :] = floor[:, ::10] = 90.0
    floor = cv2.GaussianBlur(floor, (0, 0), 0.8)
    floor[:, 60:] = 150.0
    scene = np.repeat(floor[..., None], 3, 2)
    background = StatisticalBackground(np.clip(scene + rng.normal(0, 1.5, scene.shape), 0, 255).astype(np.uint8))
    options = GuidedOptions()
    test = TextureTest(background, options)

    frame = scene.copy()
    frame[10:40, 10:30] *= 0.6  # a shadow: darker, the same texture
    frame[30:55, 35:55] = floor.mean()  # cloth of the floor's mean colour, flat
    frame = np.clip(frame + rng.normal(0, 1.5, frame.shape), 0, 255).astype(np.uint8)
    evidence = test.evidence(frame)
    assert evidence.shape == (h, w) and evidence.dtype == np.float32
    # The empty scene itself: −1 where a window holds a joint, 0 inside a tile or on the wall.
    textured = test.evidence(np.clip(scene, 0, 255).astype(np.uint8)) == -1.0
    assert textured[:, :50].mean() > 0.5 and not textured[:, 64:].any()
    cloth, shadow = (slice(34, 51), slice(39, 51)), (slice(14, 36), slice(14, 26))
    assert np.all(evidence[cloth][textured[cloth]] == 1.0) and np.all(evidence[cloth][~textured[cloth]] == 0.0)
    assert np.all(evidence[shadow][textured[shadow]] == -1.0)  # still background
    assert np.all(evidence[:, 64:] == 0.0)  # no texture, no say
    roi = (slice(20, 58), slice(30, 70))
    inner = (slice(5, -5), slice(5, -5))
    assert np.array_equal(test.evidence(frame, roi)[inner], evidence[roi][inner])
    with pytest.raises(ValueError, match="texture_window"):
        GuidedOptions(texture_window=4)
    with pytest.raises(ValueError, match="texture_hidden"):
        GuidedOptions(texture_seen=0.4)


def test_the_priors_ramp_in_its_window_is_the_ramp_of_the_whole_region(rng):
    from hullcap._guided import _box, _ramp
    from hullcap._silhouette import signed_distance

    for _ in range(300):
        h, w = rng.integers(8, 120, 2)
        noise = cv2.GaussianBlur(rng.random((h, w)), (0, 0), rng.uniform(0.5, 4))
        prior = noise > np.quantile(noise, rng.uniform(0.5, 0.995))
        x, y, bw, bh = _box(prior)
        pad = int(rng.integers(0, 40))  # the region reaches the image's edge or stops short of it
        roi = (slice(max(0, y - pad), min(h, y + bh + pad)), slice(max(0, x - pad), min(w, x + bw + pad)))
        band, outer = max(1.0, rng.uniform(0.5, 12)), max(1.0, rng.uniform(0.5, 36))
        d = signed_distance(prior[roi])
        whole = np.clip(d / np.where(d > 0, np.float32(band), np.float32(outer)), -1.0, 1.0)
        assert np.array_equal(_ramp(prior, (x, y, bw, bh), roi, band, outer), whole)
        assert np.array_equal(_ramp(prior, (x, y, bw, bh), roi, band, band), np.clip(d / band, -1.0, 1.0))


def test_the_guided_band_widens_with_the_time_between_frames(tmp_path):
    from hullcap._guided import GuidedOptions
    from hullcap._tracking import Tracker

    options = GuidedOptions()
    assert options.outer == options.band
    slow = options.for_frame_rate(10)
    assert (slow.band, slow.outer) == (options.band, pytest.approx(3 * options.band))
    assert options.for_frame_rate(30) is options and options.for_frame_rate(60) is options
    for bad in (0.0, -5.0, float("nan")):
        with pytest.raises(ValueError, match="frame rate"):
            options.for_frame_rate(bad)
    for bad in ({"band_frame_rate": 0.0}, {"outer_band": -0.01}):
        with pytest.raises(ValueError, match="band_frame_rate"):
            GuidedOptions(**bad)
    # A sequence filmed at 12 frames/s is segmented, and its hull's tolerance bounded,
    # with the outer band widened by 30 / 12.
    seq = synthesize(tmp_path / "seq", "squat", 4, fps=12.0, frames=2, width=160, height=120, show_progress=False)
    tracker = Tracker(Sequence(seq))
    assert tracker.segmenter.guidance.outer == pytest.approx(2.5 * options.band)
    assert all(s.options is tracker.segmenter.guidance for s in tracker.segmenter._segmenters())


@pytest.mark.parametrize("scene_share", [0.0, 0.5])
def test_a_wall_the_colour_of_the_subjects_shirt_stays_background(scene_share, rng):
    from hullcap._guided import GuidedOptions, GuidedSegmenter

    # A grey floor below a brown panel; the person wears a brown shirt and blue trousers.
    h, w = 120, 160
    brown, blue = (40, 70, 120), (140, 60, 30)
    scene = np.full((h, w, 3), 120.0)
    scene[:25] = brown

    def noisy(img):
        return np.clip(img + rng.normal(0, 1.5, img.shape), 0, 255).astype(np.uint8)

    segmenter = GuidedSegmenter(StatisticalBackground(noisy(scene)), GuidedOptions(scene_share=scene_share))

    def frame(top):
        img, body = scene.copy(), np.zeros((h, w), bool)
        body[top:top + 70, 60:90] = True
        img[top:top + 35, 60:90] = brown
        img[top + 35:top + 70, 60:90] = blue
        return noisy(img), body

    segmenter.learn(*frame(45))  # the panel lies far from the person here
    image, body = frame(35)  # and within the guided region here
    mask = segmenter.mask(image, body) > 0
    assert mask[body].mean() > 0.95  # the shirt is the panel's colour, and the person's
    leak = mask[:25].mean()
    if scene_share:
        assert leak == 0.0
    else:  # knowing only the floor near the person, the colours call the panel subject
        assert leak > 0.1
    for share in (1.0, 1.5):
        with pytest.raises(ValueError, match="scene_share"):
            GuidedOptions(scene_share=share)


def test_a_guided_mask_is_unsure_where_it_missed_camouflage_and_sure_of_the_room_beside_it(rng):
    """What the tolerant hull may overrule: the trousers the floor's colour, which the mask
    mostly misses, and not the floor a few pixels beyond the predicted outline, where a
    view's tangent carves the phantom volume around the body."""
    from hullcap._guided import GuidedOptions, GuidedSegmenter
    from hullcap._silhouette import signed_distance

    h, w = 120, 160
    scene = np.full((h, w, 3), 120.0)

    def noisy(img):
        return np.clip(img + rng.normal(0, 1.5, img.shape), 0, 255).astype(np.uint8)

    background = StatisticalBackground(noisy(scene))
    body = np.zeros((h, w), bool)
    body[25:105, 60:90] = True
    person = scene.copy()
    person[25:65, 60:90] = (140, 60, 30)  # a blue shirt
    person[65:105, 60:90] = 121  # trousers the floor's grey
    image = noisy(person)
    outside = signed_distance(body)
    segmented = {}
    for sure in (2.0, 4.0):
        segmenter = GuidedSegmenter(background, GuidedOptions(sure_background=sure))
        segmenter.learn(image, body)
        segmented[sure] = mask, unsure = segmenter.segment(image, body)
        assert (mask[65:105, 60:90] > 0).mean() < 0.5  # the trousers are mostly missed
        assert unsure[25:105, 60:90].all()  # but nowhere for sure
    (mask, narrow), (wider_mask, wide) = segmented[2.0], segmented[4.0]
    assert not narrow[outside < -8].any()  # the room beyond the band: sure
    assert np.array_equal(mask, wider_mask)  # the mask itself does not depend on it
    assert (narrow <= wide).all() and wide.sum() > narrow.sum()
    assert GuidedSegmenter(background).segment(image, None)[1] is None  # no prior: the test alone
    with pytest.raises(ValueError, match="sure_background"):
        GuidedOptions(sure_background=-1.0)


@pytest.mark.parametrize("bins", [1, 7, 16, 41, 256])
def test_the_colour_models_log_ratio_is_the_histograms_of_each_colour(bins, rng):
    """Each pixel's colour falls in bin (level · bins) // 256 of each channel; the
    log-ratio of each colour is that of the add-one smoothed histograms, the background's
    mixed with the scene's, and follows what is learnt next."""
    from hullcap._guided import ColourModel, GuidedOptions

    scene = rng.uniform(0, 255.99, (30, 40, 3)).astype(np.float32)  # expected colours, as the segmenter has them
    model = ColourModel(bins, scene, 0.5)
    assert model.table() is None
    n = bins**3

    def index(img):
        q = img.astype(np.int64) * bins // 256  # whole grey levels
        return (q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]

    subject = np.zeros(n)
    background = np.zeros(n)
    counted_scene = np.bincount(index(scene).ravel(), minlength=n)
    for _ in range(2):  # learning again changes the ratios
        taught = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
        inside = rng.random((30, 40)) < 0.4
        model.learn(taught, inside, ~inside)
        subject += np.bincount(index(taught)[inside], minlength=n)
        background += np.bincount(index(taught)[~inside], minlength=n)
        p_subject = (subject + 1) / (subject.sum() + n)
        p_background = 0.5 * (background + 1) / (background.sum() + n) + 0.5 * counted_scene / counted_scene.sum()
        want = np.log(p_subject) - np.log(p_background)
        got = model.table()
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
        assert got.dtype == np.float32 and got.shape == (n,)
    model.clear()
    assert model.table() is None
    for bad in (0, 257):
        with pytest.raises(ValueError, match="bins"):
            GuidedOptions(bins=bad)


@pytest.mark.parametrize("bins", [1, 16, 41])
def test_the_guided_log_odds_are_numpys_sum_to_the_bit(bins, rng):
    """The engine's one pass gives the log-odds of NumPy's steps (the evidence clipped
    and split by sign, the prior's ramp, the colours' clipped log-ratio) to the bit, over
    a window of the view; a window or an array that does not fit is refused by name."""
    from hullcap._engine import guided_logit
    from hullcap.errors import RasterError

    evidence = rng.normal(0, 4, (30, 40)).astype(np.float32)  # beyond both bounds
    image = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    ramp = rng.uniform(-1, 1, (20, 25)).astype(np.float32)
    table = rng.normal(0, 3, bins**3).astype(np.float32)
    roi = (slice(6, 26), slice(10, 35))
    weights = (-3.0, FOREGROUND_EVIDENCE, 0.3, 2.0, 1.0, 4.0)
    ev = np.clip(evidence[roi], -3.0, FOREGROUND_EVIDENCE)
    plain = np.where(ev > 0, ev, 0.3 * ev) + 2.0 * ramp
    q = image[roi].astype(np.int64) * bins // 256
    coloured = plain + 1.0 * np.clip(table[(q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]], -4.0, 4.0)
    for colours, want in ((None, plain), ((table, bins), coloured)):
        got = guided_logit(evidence, image, (6, 10), ramp, weights, colours)
        assert got.dtype == np.float32 and got.shape == (20, 25)
        assert np.array_equal(got.view(np.uint32), want.astype(np.float32).view(np.uint32))
    with pytest.raises(RasterError, match="do not lie in a 40×30 image"):
        guided_logit(evidence, image, (11, 10), ramp, weights)
    with pytest.raises(RasterError, match=f"colour table of {bins**3 + 1} values"):
        guided_logit(evidence, image, (6, 10), ramp, weights, (np.append(table, 0.0), bins))
    with pytest.raises(RasterError, match="not in order"):
        guided_logit(evidence, image, (6, 10), ramp, (1.0, -1.0, 0.3, 2.0, 1.0, 4.0))
    with pytest.raises(ArrayError, match="image has the shape"):
        guided_logit(evidence, image[:, :, :1], (6, 10), ramp, weights)
