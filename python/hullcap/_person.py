"""The learned person segmenter (docs/segmentation.md): a camera image → each pixel's
probability of being the person, and the person's 2-D key points, whatever the colours of
the clothes and the room.

It runs MediaPipe's pose models (``pip install hullcap[segment]``: the model files come in
the ``hullcap-segment-models`` package, the runtime is LiteRT, ``ai-edge-litert``; nothing
is downloaded at run time): the pose detector finds the person's box in the whole image,
and the pose landmark model, given the square crop round that box turned upright, gives
the key points and a segmentation of the crop, which is drawn back into the image. Outside
the crop the probability is 0. Without the extra, :func:`available` says why and hullcap
segments by colour alone.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from hullcap._silhouette import MAX_HOLE, MIN_BLOB, clean_mask, clean_sizes
from hullcap.errors import OptionsError

__all__ = ["PersonSegmenter", "PersonView", "available", "facing_agreement", "missing"]

DETECTOR_SIZE = 224
LANDMARK_SIZE = 256
MIN_SCORE = 0.5
"""The least detector score (a probability) of a person; below it the view shows nobody."""
CROP_SCALE = 1.25
"""The crop's side over the detector's body diameter: a margin for the limbs it reaches."""
KEY_POINTS = 33
"""Key points of MediaPipe's pose topology (nose, eyes, ears, mouth, shoulders, elbows,
wrists, hands, hips, knees, ankles, heels, toes); of the model's six further points, the
first two (hip centre, body top) place the next frame's crop and the rest are not kept."""
CROP_POINTS = (33, 34)
"""The landmark model's hip centre and body top, the detector's two points again."""
TRACK_GAP = 3
"""The most frames from one image of a camera to the next over which the crop the landmark
model placed is kept instead of running the detector again."""


SIDES = {"shoulder": (11, 12), "hip": (23, 24)}
"""MediaPipe's key points of the person's left and right shoulders and hips."""
MIN_VISIBILITY = 0.5
"""Key points the model is less sure than this are in view do not vote on the heading."""
MIN_VOTERS = 2
"""Views that must have a say before the key points tell a heading: one view alone may have
left and right swapped (a person seen from behind taken for one facing the camera)."""


def missing() -> str | None:
    """Why the learned segmenter cannot run here (a sentence naming what to install), or
    None when it can."""
    try:
        import ai_edge_litert.interpreter  # noqa: F401
    except ImportError:
        return "the LiteRT runtime is not installed (pip install 'hullcap[segment]')"
    try:
        import hullcap_segment_models as models
    except ImportError:
        return ("its model files are not installed (the hullcap-segment-models package; in hullcap's repository: "
                "make segment-models)")
    absent = [p.name for p in (models.DETECTOR, models.LANDMARKS) if not p.is_file()]
    if absent:
        return f"hullcap-segment-models lacks {', '.join(absent)}: install it again (make segment-models)"
    return None


def available() -> bool:
    """Whether the learned segmenter can run here (:func:`missing`)."""
    return missing() is None


@dataclass
class PersonView:
    """What the learned segmenter saw of one person in one image.

    Attributes:
        probability: (H, W) float32, each pixel's probability of being the person.
        key_points: (33, 2) pixel positions of MediaPipe's pose key points.
        visibility: (33,) the model's probability that each key point is in view.
        score: the detector's score of the person (a probability), or the landmark
            model's where the crop was followed from the frame before.
    """

    probability: np.ndarray
    key_points: np.ndarray
    visibility: np.ndarray
    score: float

    def mask(self) -> np.ndarray:
        """(H, W) uint8 silhouette, 255 where the person is more likely than not, cleaned as
        the background models' masks are (:func:`hullcap._silhouette.clean_mask`)."""
        min_blob, max_hole = clean_sizes(self.probability.shape, MIN_BLOB, MAX_HOLE)
        return clean_mask(np.where(self.probability > 0.5, 255, 0).astype(np.uint8), min_blob, max_hole)


def _anchors() -> np.ndarray:
    """(2254, 2) the pose detector's anchor centres (fractions of its input): two per cell
    of its 28 × 28 grid (stride 8), two per cell of 14 × 14 (16), six per cell of 7 × 7
    (strides 32, 32, 32 share one grid)."""
    centres = []
    for grid, per_cell in ((28, 2), (14, 2), (7, 6)):
        c = (np.arange(grid) + 0.5) / grid
        xy = np.stack(np.meshgrid(c, c), axis=-1).reshape(-1, 2)
        centres.append(np.repeat(xy, per_cell, axis=0))
    return np.concatenate(centres)


_ANCHORS = _anchors()


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.clip(x, -80.0, 80.0)))


class PersonSegmenter:
    """The learned segmenter of one camera's images (one at a time: its interpreters are
    not shared between threads). OptionsError when it cannot run here (:func:`missing`).

    Given frame numbers, it follows the person as MediaPipe's video mode does: the
    landmark model's own hip centre and body top place the crop of the camera's next image
    (up to :data:`TRACK_GAP` frames on), and the detector runs only on a first image, after
    a gap, or when the landmark model no longer sees a person in the crop it was given."""

    def __init__(self):
        why = missing()
        if why is not None:
            raise OptionsError(f"the learned person segmenter cannot run: {why}")
        import hullcap_segment_models as models
        from ai_edge_litert.interpreter import Interpreter

        with _quiet_stderr():  # LiteRT says on stderr, once per model, which delegate it created
            self._detector = Interpreter(model_path=str(models.DETECTOR), num_threads=1)
            self._landmarks = Interpreter(model_path=str(models.LANDMARKS), num_threads=1)
            for model in (self._detector, self._landmarks):
                model.allocate_tensors()
        self._outputs = {d["name"]: d["index"] for d in self._landmarks.get_output_details()}
        self.followed: tuple[int, np.ndarray, np.ndarray] | None = None
        """``(frame, hip centre, body top)`` that place the crop of the camera's next frame
        (None: the detector places it); a resumed run restores it."""
        self.detections = 0
        """How many times the detector ran."""

    def find(self, image: np.ndarray, frame: int | None = None) -> PersonView | None:
        """The person in `image` (H × W × 3 BGR, as OpenCV reads it), or None when the
        detector finds nobody; `image` is the camera's frame `frame` (None: an image on its
        own, not followed from the one before)."""
        rgb = cv2.cvtColor(image, cv2.COLOR_BGR2RGB) if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
        followed, self.followed = self.followed, None
        if followed is not None and frame is not None and 0 < frame - followed[0] <= TRACK_GAP:
            person = self._landmarks_in(rgb, followed[1], followed[2], None, frame)
            if person is not None:
                return person
        found = self._detect(rgb)
        if found is None:
            return None
        score, hip, top = found
        return self._landmarks_in(rgb, hip, top, score, frame)

    def _landmarks_in(self, rgb: np.ndarray, hip: np.ndarray, top: np.ndarray, score: float | None,
                      frame: int | None) -> PersonView | None:
        """The person in the crop of `rgb` round `hip` and `top` (:func:`_crop_transform`),
        found by the detector with `score`, or (None) followed from the frame before, when
        None is returned if the landmark model sees no person in the crop. Remembers where
        the next frame's crop goes."""
        to_crop = _crop_transform(hip, top)
        crop = cv2.warpAffine(rgb, to_crop, (LANDMARK_SIZE, LANDMARK_SIZE), flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        model = self._landmarks
        model.set_tensor(model.get_input_details()[0]["index"], (crop.astype(np.float32) / 255.0)[None])
        model.invoke()
        presence = float(model.get_tensor(self._outputs["Identity_1"])[0, 0])
        if score is None:
            if presence < MIN_SCORE:
                return None
            score = presence
        points = model.get_tensor(self._outputs["Identity"])[0].reshape(-1, 5)
        logits = model.get_tensor(self._outputs["Identity_2"])[0, :, :, 0]
        h, w = rgb.shape[:2]
        probability = cv2.warpAffine(_sigmoid(logits).astype(np.float32), to_crop, (w, h),
                                     flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                     borderValue=0)
        back = cv2.invertAffineTransform(to_crop)
        key_points = points[:, :2] @ back[:, :2].T + back[:, 2]
        if frame is not None:
            self.followed = (frame, key_points[CROP_POINTS[0]], key_points[CROP_POINTS[1]])
        return PersonView(probability, key_points[:KEY_POINTS].astype(np.float32),
                          _sigmoid(points[:KEY_POINTS, 3]).astype(np.float32), score)

    def _detect(self, rgb: np.ndarray):
        """``(score, hip centre, body top)`` in pixels of the person the detector is surest
        of, among those it scores at least :data:`MIN_SCORE` the largest; None for nobody."""
        h, w = rgb.shape[:2]
        scale = DETECTOR_SIZE / max(h, w)
        offset = np.array([(DETECTOR_SIZE - w * scale) / 2, (DETECTOR_SIZE - h * scale) / 2])
        to_input = np.array([[scale, 0, offset[0]], [0, scale, offset[1]]], np.float32)
        square = cv2.warpAffine(rgb, to_input, (DETECTOR_SIZE, DETECTOR_SIZE), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        self.detections += 1
        model = self._detector
        model.set_tensor(model.get_input_details()[0]["index"], (square.astype(np.float32) / 127.5 - 1.0)[None])
        model.invoke()
        boxes, scores = (model.get_tensor(d["index"])[0] for d in model.get_output_details())
        scores = _sigmoid(scores[:, 0])
        people = np.flatnonzero(scores >= MIN_SCORE)
        if not len(people):
            return None
        # The subject is the nearest person, the largest box; a person further back in the
        # room is smaller.
        k = people[np.argmax(boxes[people, 2] * boxes[people, 3])]
        points = boxes[k, 4:8].reshape(2, 2) / DETECTOR_SIZE + _ANCHORS[k]
        hip, top = (points * DETECTOR_SIZE - offset) / scale
        return float(scores[k]), hip, top


@contextmanager
def _quiet_stderr():
    """Send what native code writes to the process's stderr to nowhere while it lasts."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _crop_transform(hip: np.ndarray, top: np.ndarray) -> np.ndarray:
    """The 2 × 3 affine map from the image to the landmark model's crop: a square centred
    on the hips, :data:`CROP_SCALE` times the body's diameter (twice hips to top) on a side,
    turned so that the body stands upright."""
    up = top - hip
    side = max(2.0 * CROP_SCALE * float(np.hypot(*up)), 1.0)
    angle = np.pi / 2 - np.arctan2(-up[1], up[0])  # the turn that brings `top` above the hips
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, s], [-s, c]]) * (LANDMARK_SIZE / side)
    shift = LANDMARK_SIZE / 2 - rotation @ hip
    return np.hstack([rotation, shift[:, None]]).astype(np.float32)


def facing_agreement(views, cameras, joints: dict[str, np.ndarray]) -> float:
    """How well a body whose joints are at `joints` (name → world point; ``l_shoulder``,
    ``r_shoulder``, ``l_hip``, ``r_hip``) faces the way the person of `views` (a
    :class:`PersonView` or None per camera of `cameras`) does, from -1 (backwards: its left
    where the person's right is) to 1; 0 when no view says.

    A hull in a calibration pose looks almost the same facing either way, but the key
    points tell left from right: in each view, the image direction from the person's right
    shoulder and hip to the left ones is compared with the body's, drawn into that view, and
    the views vote, each by the length of its own direction (a view from the side, where
    left and right overlap, says little); 0 too when fewer than :data:`MIN_VOTERS` views
    have a say."""
    votes, weight, voters = 0.0, 0.0, 0
    for view, cam in zip(views, cameras):
        if view is None:
            continue
        seen, drawn = np.zeros(2), np.zeros(2)
        for part, (left, right) in SIDES.items():
            if min(view.visibility[left], view.visibility[right]) < MIN_VISIBILITY:
                continue
            seen += view.key_points[left] - view.key_points[right]
            pixels = cam.project(np.array([joints[f"l_{part}"], joints[f"r_{part}"]]))[0]
            drawn += pixels[0] - pixels[1]
        length, model_length = np.linalg.norm(seen), np.linalg.norm(drawn)
        if length > 0 and model_length > 0:
            votes += float(seen @ drawn) / model_length
            weight += length
            voters += 1
    return votes / weight if weight > 0 and voters >= MIN_VOTERS else 0.0
