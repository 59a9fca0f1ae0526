"""Sequence folders: their layout, frames and masks as images or videos, errors that name the file."""

import shutil

import cv2
import numpy as np
import pytest
from hullcap._sequence import Sequence
from hullcap.errors import ViewError


def test_synthetic_sequence_has_the_layout_of_formats_md(sequence):
    seq = Sequence(sequence)
    assert len(seq) == 42 and seq.fps == 30 and len(seq.cameras) == 4
    assert seq.images(5)[0].shape == (240, 320, 3)
    joints = np.load(sequence / "truth" / "joints.npz")
    assert joints["positions"].shape == (42, 21, 3) and joints["names"][0] == "pelvis"
    pose = np.load(sequence / "truth" / "pose.npz")
    assert pose["theta"].shape == (42, 29) and pose["root_rotation"].shape == (42, 3, 3)
    vertices = np.load(sequence / "truth" / "vertices.npy", mmap_mode="r")
    assert vertices.shape[0] == 42 and vertices.dtype == np.float32
    # The feet stand on the floor in the calibration pose.
    assert abs(vertices[0, :, 2].min()) < 1e-3


def test_sequence_errors_name_the_file(sequence, tmp_path):
    bad = tmp_path / "bad"
    shutil.copytree(sequence, bad, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    seq = Sequence(bad)
    frame = bad / "frames" / "cam1" / "000003.png"
    cv2.imwrite(str(frame), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match=r"cam1/000003.png: image is 10×10, camera 'cam1' is calibrated for 320×240"):
        seq.images(3)
    frame.write_bytes(b"not a png")
    with pytest.raises(ValueError, match=r"cam1/000003.png: not a readable image"):
        seq.images(3)
    frame.unlink()
    with pytest.raises(ValueError, match=r"cam1/000003.png: missing"):
        seq.images(3)
    with pytest.raises(IndexError, match="frame 42 out of range"):
        seq.images(42)
    # Your own masks at another resolution are refused when the sequence is opened.
    (bad / "silhouettes" / "cam0").mkdir(parents=True)
    cv2.imwrite(str(bad / "silhouettes" / "cam0" / "000000.png"), np.zeros((120, 160), np.uint8))
    with pytest.raises(ValueError, match=r"cam0/000000.png: mask is 160×120, camera 'cam0' is calibrated for 320×240"):
        Sequence(bad)
    shutil.rmtree(bad / "silhouettes")
    shutil.rmtree(bad / "frames" / "cam2")
    with pytest.raises(ValueError, match="camera 'cam2' has no frames/cam2/"):
        Sequence(bad)
    (bad / "cameras.json").unlink()
    with pytest.raises(ValueError, match="missing cameras.json"):
        Sequence(bad)


@pytest.mark.parametrize("form", ["8-bit 0/255", "8-bit labels 0/1", "16-bit labels 0/1", "16-bit 0/65535",
                                  "colour, red on black", "cut-out (alpha)", "cut-out, soft edge"])
def test_masks_from_any_segmenter_read_as_the_same_silhouette(sequence, tmp_path, form):
    """One truth mask written as segmenters write them: the mask read back is > 0 exactly
    where the truth is (a 16-bit label of 1 once read as 0 everywhere, an 8-bit reduction)."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    truth = cv2.imread(str(sequence / "truth" / "silhouettes" / "cam1" / "000005.png"), cv2.IMREAD_GRAYSCALE) > 0
    image = cv2.imread(str(sequence / "frames" / "cam1" / "000005.png"))
    written = {
        "8-bit 0/255": truth.astype(np.uint8) * 255,
        "8-bit labels 0/1": truth.astype(np.uint8),
        "16-bit labels 0/1": truth.astype(np.uint16),
        "16-bit 0/65535": truth.astype(np.uint16) * 65535,
        "colour, red on black": np.dstack([np.zeros_like(truth), np.zeros_like(truth), truth]).astype(np.uint8),
        "cut-out (alpha)": np.dstack([image, truth.astype(np.uint8) * 255]),
        # A matte's fringe: the background a third opaque where it borders the subject.
        "cut-out, soft edge": np.dstack([image, np.where(truth, 255, 85 * cv2.dilate(truth.astype(np.uint8),
                                                                                 np.ones((3, 3)))).astype(np.uint8)]),
    }[form]
    (seq_path / "silhouettes" / "cam1").mkdir(parents=True)
    cv2.imwrite(str(seq_path / "silhouettes" / "cam1" / "000005.png"), written)
    mask = Sequence(seq_path).mask(5, "cam1")
    assert mask.shape == truth.shape and mask.dtype == np.uint8
    np.testing.assert_array_equal(mask > 0, truth)


@pytest.mark.parametrize("suffix, fourcc", [(".mp4", "mp4v"), (".avi", "MJPG")])
def test_a_mask_video_per_camera_reads_as_its_masks(sequence, tmp_path, suffix, fourcc):
    """The truth masks of every camera written as one video each (a video matting tool's
    output): the sequence has silhouettes, counts the videos' frames, and each mask read
    back is the truth but for the codec's loss along the outline; a mask image beside the
    video wins, and a video of another size is refused, naming it."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    truth_dir = sequence / "truth" / "silhouettes"
    (seq_path / "silhouettes").mkdir()
    cams = ("cam0", "cam1", "cam2", "cam3")
    for cam in cams:
        writer = cv2.VideoWriter(str(seq_path / "silhouettes" / f"{cam}{suffix}"), cv2.VideoWriter_fourcc(*fourcc),
                                 30, (320, 240))
        for frame in range(42):
            writer.write(cv2.cvtColor(cv2.imread(str(truth_dir / cam / f"{frame:06d}.png"), 0), cv2.COLOR_GRAY2BGR))
        writer.release()
    seq = Sequence(seq_path)
    assert seq.has_silhouettes and seq.frame_counts(silhouettes=True) == dict.fromkeys(cams, 42)
    for frame in (7, 3, 30):  # out of order: the reader seeks
        for cam in ("cam1", "cam3"):
            truth = cv2.imread(str(truth_dir / cam / f"{frame:06d}.png"), 0) > 0
            got = seq.mask(frame, cam) > 0
            assert (got & truth).sum() / (got | truth).sum() > 0.97, (frame, cam)
    (seq_path / "silhouettes" / "cam1").mkdir()
    cv2.imwrite(str(seq_path / "silhouettes" / "cam1" / "000007.png"), np.zeros((240, 320), np.uint8))
    assert not Sequence(seq_path).mask(7, "cam1").any()
    seq.close()
    writer = cv2.VideoWriter(str(seq_path / "silhouettes" / f"cam2{suffix}"), cv2.VideoWriter_fourcc(*fourcc), 30,
                             (160, 120))
    writer.write(np.zeros((120, 160, 3), np.uint8))
    writer.release()
    with pytest.raises(ValueError, match=rf"cam2{suffix}: mask is 160×120, camera 'cam2' is calibrated for 320×240"):
        Sequence(seq_path)


@pytest.mark.parametrize("suffix, fourcc", [(".mp4", "mp4v"), (".avi", "MJPG"), (".mov", "mp4v"), (".MKV", "MJPG")])
def test_a_camera_filmed_as_a_video_reads_as_its_frames_in_any_common_container(sequence, tmp_path, suffix, fourcc):
    """cam0's frames written as one video in `suffix`'s container: the same frame count,
    each frame within the codec's loss of the image it was made from, its size taken by
    `calib import --images` too; a second video for the same camera is refused, naming
    both; a file of another kind in videos/ is no video of a camera."""
    from hullcap._rig import image_sizes

    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    frames = sorted((seq_path / "frames" / "cam0").glob("*.png"))[:4]
    originals = [cv2.imread(str(f)) for f in frames]
    (seq_path / "videos").mkdir()
    video = seq_path / "videos" / f"cam0{suffix}"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*fourcc), 30, originals[0].shape[1::-1])
    assert writer.isOpened(), f"this OpenCV cannot write {suffix}"
    for image in originals:
        writer.write(image)
    writer.release()
    shutil.rmtree(seq_path / "frames" / "cam0")
    (seq_path / "videos" / "notes.txt").write_text("filmed on a Tuesday")
    seq = Sequence(seq_path)
    assert seq.frame_counts()["cam0"] == len(originals)
    for i in (2, 0, 3):  # out of order: the reader seeks
        got = seq.image(i, "cam0").astype(int)
        assert np.abs(got - originals[i]).mean() < 4.0
    seq.close()
    assert image_sizes(seq_path)["cam0"] == (originals[0].shape[1], originals[0].shape[0])
    shutil.copy(video, seq_path / "videos" / "cam0.m4v")
    with pytest.raises(ValueError, match=r"camera 'cam0' has 2 videos \(.*cam0\.m4v.*\); keep one"):
        Sequence(seq_path)


def test_a_sequence_of_videos_needs_no_meta_json(sequence, tmp_path):
    """Every camera a video and no meta.json: the videos' frame rate and their most frames
    (one video a frame short leaves that view out of the last frame); rates that disagree,
    or a camera of images, ask for meta.json, saying why."""
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    names = [c.name for c in Sequence(seq_path).cameras]
    (seq_path / "meta.json").unlink()
    (seq_path / "videos").mkdir()

    originals = {name: [cv2.imread(str(seq_path / "frames" / name / f"{f:06d}.png")) for f in range(6)]
                 for name in names}

    def film(name, frames, fps):
        images = originals[name][:frames]
        writer = cv2.VideoWriter(str(seq_path / "videos" / f"{name}.avi"), cv2.VideoWriter_fourcc(*"MJPG"), fps,
                                 images[0].shape[1::-1])
        for image in images:
            writer.write(image)
        writer.release()

    for i, name in enumerate(names[:-1]):
        film(name, 5 if i == 0 else 6, 25)
    with pytest.raises(ValueError, match=rf"meta.json: missing; .* every camera is a video: not {names[-1]}\)"):
        Sequence(seq_path)
    film(names[-1], 6, 25)
    for name in names:
        shutil.rmtree(seq_path / "frames" / name)
    seq = Sequence(seq_path)
    assert (seq.fps, len(seq)) == (25.0, 6)
    assert seq.frame_counts()[names[0]] == 5
    with pytest.raises(ViewError, match=rf"no frame 5 \(camera '{names[0]}'\)"):
        seq.image(5, names[0])
    seq.close()
    film(names[-1], 6, 30)
    with pytest.raises(ValueError, match=r"frame rates do not agree \(.*25, .* 30 frames/s\)"):
        Sequence(seq_path)


def test_a_sequence_read_at_a_smaller_scale_checks_files_against_their_own_size(sequence, tmp_path):
    seq_path = tmp_path / "seq"
    shutil.copytree(sequence, seq_path, ignore=shutil.ignore_patterns("truth", "vertices.npy"))
    seq = Sequence(seq_path, image_scale=0.5)
    assert "images at 0.5 of their size" in repr(seq)
    assert seq.image(1, "cam0").shape == (120, 160, 3) and seq.background("cam0").shape == (120, 160, 3)
    whole = Sequence(seq_path).image(1, "cam0")
    assert np.array_equal(seq.image(1, "cam0"), cv2.resize(whole, (160, 120), interpolation=cv2.INTER_AREA))
    cv2.imwrite(str(seq_path / "frames" / "cam1" / "000002.png"), np.zeros((120, 160, 3), np.uint8) + 50)
    with pytest.raises(ValueError, match=r"image is 160×120, camera 'cam1' is calibrated for 320×240"):
        seq.image(2, "cam1")
    # A JPEG decodes at half its size (libjpeg's reduced decoding): as the whole image
    # resized, to JPEG's own loss; a JPEG of another size is still named with its size.
    frame = seq_path / "frames" / "cam2" / "000003.png"
    ok, jpg = cv2.imencode(".jpg", cv2.imread(str(frame)), [cv2.IMWRITE_JPEG_QUALITY, 95])
    frame.unlink()
    frame.with_suffix(".jpg").write_bytes(jpg.tobytes())
    halved = seq.image(3, "cam2").astype(int)
    resized = cv2.resize(Sequence(seq_path).image(3, "cam2"), (160, 120), interpolation=cv2.INTER_AREA)
    assert halved.shape == (120, 160, 3) and np.abs(halved - resized).mean() < 1.5
    reduced = cv2.imdecode(np.frombuffer(jpg.tobytes(), np.uint8), cv2.IMREAD_REDUCED_COLOR_2)
    assert np.array_equal(halved, reduced) and not np.array_equal(halved, resized)  # decoded reduced
    ok, jpg = cv2.imencode(".jpg", np.zeros((240, 319, 3), np.uint8) + 80)
    frame.with_suffix(".jpg").write_bytes(jpg.tobytes())
    with pytest.raises(ValueError, match=r"image is 319×240, camera 'cam2' is calibrated for 320×240"):
        seq.image(3, "cam2")
    with pytest.raises(ValueError, match=r"image_scale must be a fraction in \(0, 1\]"):
        Sequence(seq_path, image_scale=2)
