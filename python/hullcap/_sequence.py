"""Reading a multi-view sequence folder (docs/formats.md), frame by frame.

Nothing is loaded before it is asked for: ``seq.images(i)`` reads frame i of every camera,
``seq.masks(i)`` its silhouettes when the folder has them, ``seq.image(i, cam)`` one view.
A problem of the folder raises :class:`~hullcap.errors.SequenceError`; one of a single
view (a missing, unreadable, truncated, blank or wrongly sized image) its subclass
:class:`~hullcap.errors.ViewError`, naming the file and camera, so that a caller can leave
that one view out. :meth:`Sequence.frame_counts` says how many
frames each camera has on disk (``meta.json`` may claim more).
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path

import cv2
import numpy as np

from hullcap._cameras import Cameras
from hullcap._files import read_document
from hullcap._options import FRACTION
from hullcap.errors import CalibrationError, SequenceError, ViewError

__all__ = ["Sequence", "VIDEO_SUFFIXES", "BACKGROUND_FRAMES"]

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v")
"""Containers ``videos/<cam>.*`` may be in: those the cameras and recorders of labs write
that OpenCV's FFmpeg reads (its codecs decide what is inside them)."""

REDUCED = {2: {True: cv2.IMREAD_REDUCED_COLOR_2, False: cv2.IMREAD_REDUCED_GRAYSCALE_2},
           4: {True: cv2.IMREAD_REDUCED_COLOR_4, False: cv2.IMREAD_REDUCED_GRAYSCALE_4},
           8: {True: cv2.IMREAD_REDUCED_COLOR_8, False: cv2.IMREAD_REDUCED_GRAYSCALE_8}}
"""OpenCV's flags decoding a JPEG at 1/2, 1/4 or 1/8 of its size, by reduction and colour."""

NUMBERED = re.compile(r"^\d{6}\.(png|jpg)$")
"""A frame's file name in ``frames/<cam>/``, ``silhouettes/<cam>/`` or a background clip's
folder."""

MAX_FRAMES = 1_000_000
"""The most frames a sequence may have: as many as six-digit file names number (over nine
hours at 30 frames/s). A ``meta.json`` claiming more is refused as a mistake."""

MIN_CAMERAS = 2
"""The fewest cameras a subset of a sequence's may keep (``cameras=``, ``leave_out=``): one
view carves a cone, not a body."""

BACKGROUND_FRAMES = 30
"""The most frames of a background clip :meth:`Sequence.backgrounds` reads: enough for a
standard deviation per pixel within about 13 % of its own (1/√(2n)), and a second of
30 frames/s, so that building the model takes no longer than tracking a few frames."""


class Sequence:
    """A sequence folder: ``cameras.json``, ``meta.json`` (optional when every camera is a
    video), ``frames/<cam>/`` or ``videos/<cam>.mp4`` (or another of
    :data:`VIDEO_SUFFIXES`), ``background/<cam>.png`` (or a clip of the empty scene,
    :meth:`backgrounds`), optional ``silhouettes/<cam>/`` or ``silhouettes/<cam>.mp4``.

    `image_scale` < 1 reads every image, mask and background resized by that factor, and
    :attr:`cameras` is the calibration of the resized images (:meth:`Camera.scaled`): for
    cameras of more pixels than the 1 cm voxels of the hull need (3 m from a 1920 × 1080
    camera of 60–90° field, a pixel spans 2–3 mm), at a fraction of the cost of every stage.
    Files are checked against the calibration of their own size (``cameras.json``).

    `cameras` (names) keeps only those cameras of ``cameras.json`` and `leave_out` (names)
    drops those (:meth:`Cameras.subset`): a camera ``hullcap calib check`` names, one whose
    files are missing, or a smaller rig out of a larger one. The others' files are not read;
    at least :data:`MIN_CAMERAS` must stay."""

    def __init__(self, path, image_scale: float = 1.0, cameras=None, leave_out=()):
        self.path = Path(path)
        if not self.path.is_dir():
            raise SequenceError(f"{self.path}: no such sequence folder")
        if not (self.path / "cameras.json").is_file():
            raise SequenceError(f"{self.path}: missing cameras.json")
        FRACTION.check("image_scale", image_scale)
        self.image_scale = float(image_scale)
        every = Cameras.load(self.path / "cameras.json")
        try:
            self._native = every.subset(cameras, leave_out)
        except CalibrationError as e:
            raise SequenceError(f"{self.path}: {e}") from None
        self._cameras_in_file = len(every)
        if len(self._native) < MIN_CAMERAS <= len(every):
            raise SequenceError(f"{self.path}: only camera {self._native.names[0]!r} is left of {len(every)}; a "
                                f"visual hull needs at least {MIN_CAMERAS} views")
        self.cameras = self._native.scaled(self.image_scale)
        # JPEG decodes at 1/2, 1/4 or 1/8 of its size for a fraction of the work: the
        # smallest of those still at least as large as the images asked for.
        self._jpeg_reduction = max((r for r in (1, 2, 4, 8) if 1 / r >= self.image_scale), default=1)
        self._video_paths = self._find_videos("videos")
        self._mask_video_paths = self._find_videos("silhouettes")
        meta_path = self.path / "meta.json"
        meta = read_document(meta_path, SequenceError) if meta_path.is_file() else self._meta_from_videos(meta_path)
        unknown = sorted(set(meta) - {"fps", "frames"})
        if unknown:
            raise SequenceError(f"{meta_path}: unknown key {unknown[0]!r}{_did_you_mean(unknown[0], ('fps', 'frames'))}"
                                f"; meta.json holds \"fps\" and \"frames\" only")
        try:
            self.fps = float(meta["fps"])
            frames = float(meta["frames"])
        except (KeyError, TypeError, ValueError, OverflowError) as e:
            raise SequenceError(f"{meta_path}: needs {{\"fps\": …, \"frames\": …}} ({e!r})") from e
        if not (0 < self.fps < math.inf and 0 < frames <= MAX_FRAMES and frames == int(frames)):
            raise SequenceError(f"{meta_path}: fps must be a positive number and frames a whole number from 1 to "
                                f"{MAX_FRAMES:,}, got {meta['fps']!r} and {meta['frames']!r}")
        self.n_frames = int(frames)
        self._videos: dict[Path, cv2.VideoCapture] = {}
        self._video_pos: dict[Path, int] = {}
        for cam in self._native:
            has_frames = (self.path / "frames" / cam.name).is_dir()
            has_masks = self._has_masks(cam.name)
            if not (has_frames or cam.name in self._video_paths or has_masks):
                raise SequenceError(f"{self.path}: camera {cam.name!r} has no frames/{cam.name}/, "
                                    f"videos/{cam.name}.mp4 (or {', '.join(VIDEO_SUFFIXES[1:])}), "
                                    f"silhouettes/{cam.name}/ or silhouettes/{cam.name}.mp4")
            if has_masks:
                self._check_mask_size(cam)

    def _find_videos(self, folder: str) -> dict[str, Path]:
        """Each camera's video in `folder` (``videos/``, or ``silhouettes/`` for mask
        videos), by camera name; two for one camera (say ``cam0.mp4`` and ``cam0.avi``)
        are an error naming both, since either could be the take."""
        where = self.path / folder
        found = {cam.name: _at_most_one(_videos_named(where, cam.name), where, cam.name, "videos")
                 for cam in self._native}
        return {name: path for name, path in found.items() if path is not None}

    def _has_masks(self, name: str) -> bool:
        """Whether camera `name` has silhouettes: a folder of masks or a mask video."""
        return (self.path / "silhouettes" / name).is_dir() or name in self._mask_video_paths

    def _meta_from_videos(self, meta_path: Path) -> dict:
        """``meta.json``'s numbers for a sequence without one whose every camera is a
        video: the videos' frame rate, when they agree to 0.1 %, and the most frames any
        of them has (a shorter one leaves its view out of the frames it lacks)."""
        missing = [cam.name for cam in self.cameras if cam.name not in self._video_paths]
        if missing:
            raise SequenceError(f"{meta_path}: missing; write the frame rate and the number of frames, "
                                f'{{"fps": 30, "frames": 240}} (it can be left out only when every camera '
                                f"is a video: not {', '.join(missing)})")
        rates, counts = {}, {}
        for name, path in self._video_paths.items():
            rates[name], counts[name] = _video_length(path)
            if not 0 < counts[name] <= MAX_FRAMES:
                raise SequenceError(f"{path}: not a readable video (camera {name!r}; its container says "
                                    f"{counts[name]} frames), and no meta.json says how long the sequence is")
        fps = float(np.median(list(rates.values())))
        if not fps > 0 or any(abs(r - fps) > 1e-3 * fps for r in rates.values()):
            said = ", ".join(f"{n} {r:g}" for n, r in rates.items())
            raise SequenceError(f"{meta_path}: missing, and the videos' frame rates do not agree ({said} frames/s): "
                                f'write the take\'s own, {{"fps": …, "frames": …}}')
        return {"fps": fps, "frames": max(counts.values())}

    def _check_mask_size(self, cam) -> None:
        """Masks of another size than the camera's images are a mistake for the whole
        camera (another segmenter's resolution, a crop): refuse them at once, naming the
        first such file, rather than leave the view out of every frame."""
        first = next(iter(sorted((self.path / "silhouettes" / cam.name).glob("*.png"))), None)
        video = self._mask_video_paths.get(cam.name)
        if first is not None:
            img = cv2.imread(str(first), cv2.IMREAD_GRAYSCALE)
        elif video is not None:
            first, img = video, first_frame(video)
        else:
            return
        if img is not None and img.shape[:2] != (cam.height, cam.width):
            raise SequenceError(f"{first}: mask is {img.shape[1]}×{img.shape[0]}, camera {cam.name!r} is "
                             f"calibrated for {cam.width}×{cam.height}: silhouettes must have the size of "
                             f"the camera's images")

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        scale = f", images at {self.image_scale:g} of their size" if self.image_scale != 1 else ""
        of = f" of {self._cameras_in_file}" if self._cameras_in_file != len(self.cameras) else ""
        return (f"Sequence({str(self.path)!r}, {len(self.cameras)}{of} cameras, {self.n_frames} frames at "
                f"{self.fps:g} fps{scale})")

    @property
    def has_silhouettes(self) -> bool:
        return all(self._has_masks(c.name) for c in self.cameras)

    def background(self, camera) -> np.ndarray:
        """The empty scene as `camera` (name or index) sees it, (H, W, 3) uint8 BGR: its
        background image, or the per-pixel mean of its background clip's frames."""
        images = self.backgrounds(camera)
        if len(images) == 1:
            return images[0]
        return np.rint(np.mean(images, axis=0)).astype(np.uint8)

    def backgrounds(self, camera, most: int = BACKGROUND_FRAMES) -> list[np.ndarray]:
        """The empty scene's frames of `camera` (name or index), (H, W, 3) uint8 BGR each:
        ``background/<cam>.png`` (or ``.jpg``), one image; or a clip of the empty room,
        ``background/<cam>/`` (numbered images) or ``background/<cam>.mp4`` (or another
        of :data:`VIDEO_SUFFIXES`), of which at most `most` frames spread evenly over it.
        From a clip Horprasert's model learns how much each pixel varies (flicker, sensor
        noise, a monitor in the room); from one image only the noise it assumes
        (``StatisticalBackground.noise_floor``). A ViewError when the camera has none, or
        a frame cannot be used; a SequenceError when it has more than one of them."""
        cam = self._native[camera]
        folder = self.path / "background"
        found = [p for p in (folder / f"{cam.name}.png", folder / f"{cam.name}.jpg", folder / cam.name)
                 if p.exists()]
        path = _at_most_one(found + _videos_named(folder, cam.name), folder, cam.name, "backgrounds")
        if path is None:
            raise ViewError(folder / f"{cam.name}.png", f"missing, and there is no clip of the empty scene "
                                                        f"either (background/{cam.name}/ or background/{cam.name}.mp4)")
        if path.suffix.lower() in (".png", ".jpg"):
            images = [self._read(path, cam, colour=True)]
        elif path.is_dir():
            files = sorted(p for p in path.iterdir() if NUMBERED.match(p.name))
            if not files:
                raise ViewError(path, f"no numbered images (000000.png …) of the empty scene (camera {cam.name!r})")
            images = [self._read(files[i], cam, colour=True) for i in _spread(len(files), most)]
        else:
            images = self._clip(path, cam, most)
        return [self._rescaled(img, cam.name) for img in images]

    def _clip(self, path: Path, cam, most: int) -> list[np.ndarray]:
        """At most `most` frames of the video `path`, spread evenly over it."""
        n = _video_length(path)[1]
        if n <= 0:
            raise ViewError(path, f"not a readable video (camera {cam.name!r})")
        cap = cv2.VideoCapture(str(path))
        try:
            images = []
            for i in _spread(n, most):
                cap.set(cv2.CAP_PROP_POS_FRAMES, i)
                ok, img = cap.read()
                if not ok:
                    break  # a container that counts more frames than it holds
                images.append(_sized(img, path, cam, "video"))
        finally:
            cap.release()
        if not images:
            raise ViewError(path, f"no frame could be read (camera {cam.name!r})")
        return images

    def images(self, frame: int) -> list[np.ndarray]:
        """Frame `frame` of every camera, (H, W, 3) uint8 BGR each, in camera order."""
        return [self.image(frame, cam.name) for cam in self.cameras]

    def image(self, frame: int, camera) -> np.ndarray:
        """Frame `frame` of `camera` (name or index), (H, W, 3) uint8 BGR. A blank image
        (every pixel the same: a camera that dropped out) is an error too."""
        self._check_frame(frame)
        cam = self._native[camera]
        png = self.path / "frames" / cam.name / f"{frame:06d}.png"
        path = next((p for p in (png, png.with_suffix(".jpg")) if p.is_file()), None)
        video = self._video_paths.get(cam.name)
        if path is None and video is not None:
            path, img = video, self._video_frame(video, cam, frame)
        else:  # a missing image is the PNG's error
            path = path or png
            img = self._read(path, cam, colour=True, reduce=self._jpeg_reduction)
        if (img[::16, ::16] == img.flat[0]).all() and (img == img.flat[0]).all():
            raise ViewError(path, f"blank image (every pixel {img.flat[0]}; camera {cam.name!r}, frame {frame})")
        return self._rescaled(img, cam.name)

    def check_image_sizes(self) -> None:
        """Refuse a camera whose images all have another size than its calibration (the
        first and the last frame on disk both differ: the wrong camera's files, another
        resolution), naming the file; a single odd frame is left to the tracker."""
        for cam in self.cameras:
            wrong = []
            for frame in sorted({0, self.n_frames - 1}):
                try:
                    self.image(frame, cam.name)
                except ViewError as e:
                    wrong.append(e if e.wrong_size else None)
            if wrong and all(wrong):
                raise wrong[0]

    def frame_counts(self, silhouettes: bool = False) -> dict[str, int]:
        """Frames on disk per camera: numbered images in ``frames/<cam>/``, else the
        video's frame count; with `silhouettes`, the masks in ``silhouettes/<cam>/``, else
        the mask video's frame count."""
        counts = {}
        for cam in self.cameras:
            folder = self.path / ("silhouettes" if silhouettes else "frames") / cam.name
            video = (self._mask_video_paths if silhouettes else self._video_paths).get(cam.name)
            if folder.is_dir():
                counts[cam.name] = len({p.stem for p in folder.iterdir() if NUMBERED.match(p.name)})
            else:
                counts[cam.name] = 0 if video is None else _video_length(video)[1]
        return counts

    def masks(self, frame: int) -> list[np.ndarray]:
        """The given silhouettes of frame `frame` (0/255 uint8), in camera order."""
        return [self.mask(frame, c.name) for c in self.cameras]

    def mask(self, frame: int, camera) -> np.ndarray:
        """The given silhouette of `camera` (name or index) in frame `frame`, (H, W) uint8,
        > 0 where the subject is (a mask of 16 bits, three channels or an alpha channel
        read as docs/formats.md says); resized by `image_scale`, a pixel is subject where
        the subject covered at least half of it."""
        self._check_frame(frame)
        cam = self._native[camera]
        path = self.path / "silhouettes" / cam.name / f"{frame:06d}.png"
        video = self._mask_video_paths.get(cam.name)
        if video is None or path.is_file():
            mask = self._read(path, cam, colour=False)
        else:
            # A video's compression leaves small values round the subject and over the
            # background: its masks are the pixels at least half on.
            mask = np.where(self._video_frame(video, cam, frame).max(axis=2) >= 128, 255, 0).astype(np.uint8)
        if self.image_scale == 1:
            return mask
        return np.where(self._rescaled(np.where(mask > 0, 255, 0).astype(np.uint8), cam.name) >= 128, 255,
                        0).astype(np.uint8)

    def _rescaled(self, img: np.ndarray, name: str) -> np.ndarray:
        """`img` of camera `name` at :attr:`cameras`' size (each output pixel the mean of
        the pixels it covers)."""
        if self.image_scale == 1:
            return img
        cam = self.cameras[name]
        return cv2.resize(img, (cam.width, cam.height), interpolation=cv2.INTER_AREA)

    def _check_frame(self, frame):
        if not 0 <= frame < self.n_frames:
            raise IndexError(f"{self.path}: frame {frame} out of range 0..{self.n_frames - 1}")

    def _read(self, path: Path, cam, colour: bool, reduce: int = 1) -> np.ndarray:
        """The image `path` of camera `cam`, checked against the camera's size; a JPEG with
        `reduce` 2, 4 or 8 decoded at that fraction of its size (each side rounded up)."""
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            raise ViewError(path, f"missing (camera {cam.name!r})") from None
        except OSError as e:
            raise ViewError(path, f"cannot be read ({e.strerror}; camera {cam.name!r})") from None
        # libjpeg decodes a cut-off JPEG into a half-grey image with only a console message
        # naming no file, and libpng complains on the console too: a file must end with its
        # format's end marker (JPEG's EOI, PNG's IEND chunk).
        if data.startswith(b"\xff\xd8") and not data.rstrip(b"\0").endswith(b"\xff\xd9"):
            raise ViewError(path, f"truncated JPEG (camera {cam.name!r})")
        if data.startswith(b"\x89PNG") and not data.endswith(b"IEND\xaeB`\x82"):
            raise ViewError(path, f"truncated PNG (camera {cam.name!r})")
        # A JPEG of the camera's own size (its frame header says) may decode reduced.
        reduced = reduce > 1 and data.startswith(b"\xff\xd8") and _jpeg_size(data) == (cam.width, cam.height)
        flag = REDUCED[reduce][colour] if reduced else cv2.IMREAD_COLOR if colour else cv2.IMREAD_UNCHANGED
        img = cv2.imdecode(np.frombuffer(data, np.uint8), flag) if data else None
        if img is None:
            raise ViewError(path, f"not a readable image (camera {cam.name!r})")
        if not colour:
            img = _mask_of(img)
        return img if reduced else _sized(img, path, cam, "image")

    def _video_frame(self, path: Path, cam, frame: int) -> np.ndarray:
        """Frame `frame` of camera `cam`'s video `path` (its frames or its masks); the
        reader seeks only when that is not the frame after the one it read last."""
        cap = self._videos.get(path)
        if cap is None:
            cap = cv2.VideoCapture(str(path))
            if not cap.isOpened():
                raise ViewError(path, f"not a readable video (camera {cam.name!r})")
            self._videos[path] = cap
            self._video_pos[path] = 0
        if self._video_pos[path] != frame:
            cap.set(cv2.CAP_PROP_POS_FRAMES, frame)
        ok, img = cap.read()
        if not ok:
            raise ViewError(path, f"no frame {frame} (camera {cam.name!r})")
        self._video_pos[path] = frame + 1
        return _sized(img, path, cam, "video")

    def close(self) -> None:
        for cap in self._videos.values():
            cap.release()
        self._videos.clear()


def _mask_of(img: np.ndarray) -> np.ndarray:
    """A mask file as decoded (any depth, any channels) as one 8-bit channel, > 0 where the
    subject is: a single channel as it is (16-bit values, which a reduction to 8 bits
    would turn from 1 to 0, become 255); of three channels, any of them non-zero; of
    four, the alpha channel alone, at least half opaque (a cut-out: transparent where the
    background is, its edge pixels as opaque as the subject covers them)."""
    if img.ndim == 3 and img.shape[2] == 4:
        alpha = img[..., 3]
        return np.where(alpha > np.iinfo(alpha.dtype).max // 2, 255, 0).astype(np.uint8)
    if img.ndim == 3:
        img = img.max(axis=2)
    if img.dtype == np.uint8:
        return img
    return np.where(img > 0, 255, 0).astype(np.uint8)


def _sized(img: np.ndarray, path: Path, cam, what: str) -> np.ndarray:
    """`img` as read from `path` ("image" or "video", `what`), when it has `cam`'s size."""
    if img.shape[:2] != (cam.height, cam.width):
        raise ViewError(path, f"{what} is {img.shape[1]}×{img.shape[0]}, camera {cam.name!r} is calibrated for "
                              f"{cam.width}×{cam.height}", wrong_size=True)
    return img


def _videos_named(folder: Path, name: str) -> list[Path]:
    """The videos (:data:`VIDEO_SUFFIXES`) in `folder` whose name is `name` and a suffix."""
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if p.stem == name and p.suffix.lower() in VIDEO_SUFFIXES and p.is_file())


def _at_most_one(found: list[Path], folder: Path, name: str, what: str) -> Path | None:
    """The one file of `found` (camera `name`'s `what`), None for none; more than one is
    an error naming them all, since any of them could be the one meant."""
    if len(found) > 1:
        raise SequenceError(f"{folder}: camera {name!r} has {len(found)} {what} ({', '.join(p.name for p in found)}); "
                            f"keep one")
    return found[0] if found else None


def first_frame(path: Path) -> np.ndarray | None:
    """The video's first frame, None when it cannot be read."""
    cap = cv2.VideoCapture(str(path))
    try:
        ok, img = cap.read() if cap.isOpened() else (False, None)
        return img if ok else None
    finally:
        cap.release()


def _video_length(path: Path) -> tuple[float, int]:
    """``(frames/s, frames)`` the video's container says, ``(0, 0)`` when it cannot be opened."""
    cap = cv2.VideoCapture(str(path))
    try:
        return (cap.get(cv2.CAP_PROP_FPS), int(cap.get(cv2.CAP_PROP_FRAME_COUNT))) if cap.isOpened() else (0.0, 0)
    finally:
        cap.release()


def _spread(n: int, most: int) -> list[int]:
    """At most `most` of the indices 0 … n − 1, spread evenly, first and last included."""
    if most < 1:
        raise ValueError(f"most must be at least 1, got {most}")
    return sorted({round(i) for i in np.linspace(0, n - 1, min(n, most))})


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` from a JPEG's frame header (its SOF segment), or None where
    the markers before it do not parse."""
    i = 2
    while i + 9 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        length = int.from_bytes(data[i + 2:i + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            return int.from_bytes(data[i + 7:i + 9], "big"), int.from_bytes(data[i + 5:i + 7], "big")
        i += 2 + length
    return None


def _did_you_mean(name: str, known) -> str:
    """`` (did you mean 'frames'?)`` when `name` is close to one of `known`, else nothing."""
    close = difflib.get_close_matches(name, known, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
