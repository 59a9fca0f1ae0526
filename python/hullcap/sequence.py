"""Reading a multi-view sequence folder (docs/formats.md), frame by frame.

Nothing is loaded before it is asked for: ``seq.images(i)`` reads frame i of every camera,
``seq.masks(i)`` its silhouettes when the folder has them. Each problem (a missing
camera folder, an unreadable or wrongly sized image) raises ``ValueError`` naming the file.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from hullcap._files import read_document
from hullcap.cameras import Cameras
from hullcap.errors import SequenceError

__all__ = ["Sequence"]


class Sequence:
    """A sequence folder: ``cameras.json``, ``meta.json``, ``frames/<cam>/`` or
    ``videos/<cam>.mp4``, ``background/<cam>.png``, optional ``silhouettes/<cam>/``."""

    def __init__(self, path):
        self.path = Path(path)
        if not self.path.is_dir():
            raise SequenceError(f"{self.path}: no such sequence folder")
        if not (self.path / "cameras.json").is_file():
            raise SequenceError(f"{self.path}: missing cameras.json")
        self.cameras = Cameras.load(self.path / "cameras.json")
        meta_path = self.path / "meta.json"
        meta = read_document(meta_path, SequenceError)
        try:
            self.fps = float(meta["fps"])
            self.n_frames = int(meta["frames"])
        except (KeyError, TypeError, ValueError) as e:
            raise SequenceError(f"{meta_path}: needs {{\"fps\": …, \"frames\": …}} ({e!r})") from e
        if not (self.fps > 0 and self.n_frames > 0):
            raise SequenceError(f"{meta_path}: fps and frames must be positive")
        self._videos: dict[str, cv2.VideoCapture] = {}
        self._video_pos: dict[str, int] = {}
        for cam in self.cameras:
            has_frames = (self.path / "frames" / cam.name).is_dir()
            has_video = (self.path / "videos" / f"{cam.name}.mp4").is_file()
            has_masks = (self.path / "silhouettes" / cam.name).is_dir()
            if not (has_frames or has_video or has_masks):
                raise SequenceError(f"{self.path}: camera {cam.name!r} has no frames/{cam.name}/, "
                                 f"videos/{cam.name}.mp4 or silhouettes/{cam.name}/")
            if has_masks:
                self._check_mask_size(cam)

    def _check_mask_size(self, cam) -> None:
        """Masks of another size than the camera's images are a mistake for the whole
        camera (another segmenter's resolution, a crop): refuse them at once, naming the
        first such file, rather than leave the view out of every frame."""
        first = next(iter(sorted((self.path / "silhouettes" / cam.name).glob("*.png"))), None)
        if first is None:
            return
        img = cv2.imread(str(first), cv2.IMREAD_GRAYSCALE)
        if img is not None and img.shape != (cam.height, cam.width):
            raise SequenceError(f"{first}: mask is {img.shape[1]}×{img.shape[0]}, camera {cam.name!r} is "
                             f"calibrated for {cam.width}×{cam.height}: silhouettes must have the size of "
                             f"the camera's images")

    def __len__(self) -> int:
        return self.n_frames

    def __repr__(self) -> str:
        return f"Sequence({str(self.path)!r}, {len(self.cameras)} cameras, {self.n_frames} frames at {self.fps:g} fps)"

    @property
    def has_silhouettes(self) -> bool:
        return all((self.path / "silhouettes" / c.name).is_dir() for c in self.cameras)

    def background(self, camera) -> np.ndarray:
        """The empty-scene image of `camera` (name or index), (H, W, 3) uint8 BGR."""
        cam = self.cameras[camera]
        return self._read(self.path / "background" / f"{cam.name}.png", cam, colour=True)

    def images(self, frame: int) -> list[np.ndarray]:
        """Frame `frame` of every camera, (H, W, 3) uint8 BGR each, in camera order."""
        self._check_frame(frame)
        out = []
        for cam in self.cameras:
            png = self.path / "frames" / cam.name / f"{frame:06d}.png"
            jpg = png.with_suffix(".jpg")
            if png.is_file() or jpg.is_file() or not (self.path / "videos" / f"{cam.name}.mp4").is_file():
                out.append(self._read(png if png.is_file() or not jpg.is_file() else jpg, cam, colour=True))
            else:
                out.append(self._video_frame(cam, frame))
        return out

    def masks(self, frame: int) -> list[np.ndarray]:
        """The given silhouettes of frame `frame` (0/255 uint8), in camera order."""
        return [self.mask(frame, c.name) for c in self.cameras]

    def mask(self, frame: int, camera) -> np.ndarray:
        """The given silhouette of `camera` (name or index) in frame `frame`."""
        self._check_frame(frame)
        cam = self.cameras[camera]
        return self._read(self.path / "silhouettes" / cam.name / f"{frame:06d}.png", cam, colour=False)

    def _check_frame(self, frame):
        if not 0 <= frame < self.n_frames:
            raise IndexError(f"{self.path}: frame {frame} out of range 0..{self.n_frames - 1}")

    def _read(self, path: Path, cam, colour: bool) -> np.ndarray:
        if not path.is_file():
            raise SequenceError(f"{path}: missing (camera {cam.name!r})")
        img = cv2.imread(str(path), cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SequenceError(f"{path}: not a readable image (camera {cam.name!r})")
        if img.shape[:2] != (cam.height, cam.width):
            raise SequenceError(f"{path}: image is {img.shape[1]}×{img.shape[0]}, camera {cam.name!r} "
                             f"is calibrated for {cam.width}×{cam.height}")
        return img

    def _video_frame(self, cam, frame: int) -> np.ndarray:
        path = self.path / "videos" / f"{cam.name}.mp4"
        cap = self._videos.get(cam.name)
        if cap is None:
            cap = cv2.VideoCapture(str(path))
            if not cap.isOpened():
                raise SequenceError(f"{path}: not a readable video (camera {cam.name!r})")
            self._videos[cam.name] = cap
            self._video_pos[cam.name] = 0
        if self._video_pos[cam.name] != frame:
            cap.set(cv2.CAP_PROP_POS_FRAMES, frame)
        ok, img = cap.read()
        if not ok:
            raise SequenceError(f"{path}: no frame {frame} (camera {cam.name!r})")
        self._video_pos[cam.name] = frame + 1
        if img.shape[:2] != (cam.height, cam.width):
            raise SequenceError(f"{path}: video is {img.shape[1]}×{img.shape[0]}, camera {cam.name!r} "
                             f"is calibrated for {cam.width}×{cam.height}")
        return img

    def close(self) -> None:
        for cap in self._videos.values():
            cap.release()
        self._videos.clear()
