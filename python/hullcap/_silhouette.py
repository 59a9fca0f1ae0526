"""Silhouettes by statistical background subtraction (docs/design.md §6).

The model of Horprasert, Harwood and Davis (1999): each background pixel has an expected
colour E and a per-channel spread s. A new colour I is compared along and across the line
through E:

- brightness distortion α = argmin_α ‖(I − αE)/s‖² — how much brighter (α > 1) or darker
  (α < 1) the pixel is along its expected colour;
- chromaticity distortion CD = ‖(I − αE)/s‖ — how far it is from that colour line.

Each is normalised by its own spread over the background (measured over several background
images, and never below what the pixel noise alone gives, so one image is enough). A pixel
is foreground when its normalised CD is large, or when it is far darker than a shadow or
brighter than a highlight can be; shadows (darker, same chromaticity) and highlights stay
background. Small blobs are removed and holes filled afterwards.

OpenCV's MOG2 sits behind the same interface for comparison.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from hullcap._engine import background_distortions, background_evidence
from hullcap.errors import OptionsError, SequenceError

__all__ = ["BACKGROUND_MODELS", "StatisticalBackground", "Mog2Background", "background_model", "clean_mask",
           "clean_sizes", "half_covered", "signed_distance", "distance_outside"]


@dataclass(frozen=True)
class Thresholds:
    """Decision thresholds of the statistical model.

    Attributes:
        chromaticity: normalised CD above which a pixel is foreground (in units of the
            background's own CD spread).
        darkest_shadow: α below which a darker pixel is foreground, not shadow.
        brightest_highlight: α above which a brighter pixel is foreground.
        brightness: normalised |α − 1| below which a pixel is plain background; between it
            and the shadow/highlight bounds a pixel is shadow or highlight (background too).
    """

    chromaticity: float = 3.0
    darkest_shadow: float = 0.45
    brightest_highlight: float = 1.35
    brightness: float = 6.0


# The background models' clean-up (clean_mask) as fractions of the image's area: the
# sizes in pixels that served 640 × 480 cameras, kept at other resolutions for the same
# person in the same room (a fixed number of pixels drops parts of a person filmed at
# lower resolution).
MIN_BLOB = 200 / (640 * 480)
MAX_HOLE = 2000 / (640 * 480)

FOREGROUND_EVIDENCE = 6.0
"""Evidence given to a pixel whose brightness alone makes it foreground (see
:meth:`StatisticalBackground.evidence`)."""


class StatisticalBackground:
    """The Horprasert background model of one camera.

    Args:
        backgrounds: one or more (H, W, 3) uint8 images of the empty scene.
        noise_floor: the least per-channel standard deviation assumed (grey levels); with
            a single background image it is the spread.
        thresholds: see :class:`Thresholds`.
        min_blob: connected foreground regions smaller than this fraction of the image's
            area are dropped (200 pixels of a 640 × 480 image).
        max_hole: background regions enclosed by the subject up to this fraction of the
            image's area are filled (2000 pixels of a 640 × 480 image; ``None``: every
            enclosed hole).
    """

    def __init__(self, backgrounds: Sequence[np.ndarray] | np.ndarray, noise_floor: float = 2.5,
                 thresholds: Thresholds = Thresholds(), min_blob: float = MIN_BLOB,
                 max_hole: float | None = MAX_HOLE):
        stack = _stack(backgrounds)
        self.shape = stack.shape[1:3]
        self.thresholds = thresholds
        self.min_blob, self.max_hole = clean_sizes(self.shape, min_blob, max_hole)
        mean = stack.mean(0)
        self.mean = mean.astype(np.float32)
        """(H, W, 3) the expected colour E of each pixel (BGR, grey levels)."""
        self.noise_floor = noise_floor
        spread = stack.std(0) if len(stack) > 1 else np.zeros_like(mean)
        inv_s = (1.0 / np.maximum(spread, noise_floor)).astype(np.float32)
        es = (mean * inv_s).astype(np.float32)
        es2 = np.maximum((es * es).sum(-1), 1e-6).astype(np.float32)
        # The engine's planes (`_engine.background_evidence`): 1/s and E/s of each channel,
        # ‖E/s‖², and last 1/(the spread of CD), known once the distortions are.
        self._planes = np.empty((8, *self.shape), np.float32)
        self._planes[0:3] = np.moveaxis(inv_s, -1, 0)
        self._planes[3:6] = np.moveaxis(es, -1, 0)
        self._planes[6] = es2
        # Spread of α and CD under the noise alone: var(α) = 1/Σ(E/s)², and CD² is χ² with
        # two degrees of freedom (three channels, one fitted along E): RMS √2.
        a = 1.0 / np.sqrt(es2)
        b = np.full(self.shape, np.sqrt(2.0), np.float32)
        if len(stack) > 1:
            alphas, cds = zip(*(self._distortions(img) for img in stack))
            a = np.maximum(a, np.sqrt(np.mean((np.array(alphas) - 1.0) ** 2, 0)))
            b = np.maximum(b, np.sqrt(np.mean(np.array(cds) ** 2, 0)))
        self._inv_a = (1.0 / a).astype(np.float32)
        self._planes[7] = 1.0 / b

    def _distortions(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(α, CD): the brightness and chromaticity distortions of each pixel."""
        return background_distortions(image, self._planes)

    def _normalised(self, image: np.ndarray):
        """(α, CD in units of its noise spread, α − 1 in units of its noise spread)."""
        alpha, cd = self._distortions(_image(image, self.shape))
        return alpha, cd * self._planes[7], (alpha - 1.0) * self._inv_a

    def classify(self, image: np.ndarray) -> np.ndarray:
        """Per-pixel class: 0 background, 1 shadow, 2 highlight, 3 foreground (uint8),
        before any clean-up."""
        t = self.thresholds
        alpha, cd_n, alpha_n = self._normalised(image)
        out = np.zeros(self.shape, np.uint8)
        out[alpha_n < -t.brightness] = 1
        out[alpha_n > t.brightness] = 2
        out[(cd_n > t.chromaticity) | (alpha < t.darkest_shadow) | (alpha > t.brightest_highlight)] = 3
        return out

    def evidence(self, image: np.ndarray) -> np.ndarray:
        """(H, W) float32 evidence that each pixel is foreground, in units of the noise's
        spread: how far the normalised chromaticity distortion lies beyond its threshold
        (negative: within it), and +`FOREGROUND_EVIDENCE` where the brightness alone rules
        out a shadow or highlight. :meth:`classify`'s foreground is where it is > 0."""
        t = self.thresholds
        rule = (t.chromaticity, t.darkest_shadow, t.brightest_highlight, FOREGROUND_EVIDENCE)
        return background_evidence(_image(image, self.shape), self._planes, rule)

    def mask(self, image: np.ndarray, evidence: np.ndarray | None = None) -> np.ndarray:
        """(H, W) uint8 silhouette, 255 = subject, cleaned (see :func:`clean_mask`) and
        with its boundary pixels kept only where at least half covered
        (:func:`half_covered`); `evidence`: :meth:`evidence` of `image` when it was
        computed already."""
        if evidence is None:
            evidence = self.evidence(image)
        raw = np.where(evidence > 0, 255, 0).astype(np.uint8)
        return half_covered(clean_mask(raw, self.min_blob, self.max_hole), evidence, self.thresholds.chromaticity)


class Mog2Background:
    """OpenCV's Gaussian-mixture subtractor (MOG2), trained on the background images and
    then frozen, with the same clean-up as :class:`StatisticalBackground`."""

    def __init__(self, backgrounds: Sequence[np.ndarray] | np.ndarray, var_threshold: float = 16.0,
                 min_blob: float = MIN_BLOB, max_hole: float | None = MAX_HOLE):
        stack = _stack(backgrounds)
        self.shape = stack.shape[1:3]
        self.min_blob, self.max_hole = clean_sizes(self.shape, min_blob, max_hole)
        self._model = cv2.createBackgroundSubtractorMOG2(history=max(len(stack), 2),
                                                         varThreshold=var_threshold,
                                                         detectShadows=True)
        for _ in range(max(1, 10 // len(stack))):
            for img in stack:
                self._model.apply(img, learningRate=-1)

    def mask(self, image: np.ndarray) -> np.ndarray:
        raw = self._model.apply(_image(image, self.shape), learningRate=0)
        return clean_mask(np.where(raw == 255, 255, 0).astype(np.uint8), self.min_blob, self.max_hole)


BACKGROUND_MODELS = {"statistical": StatisticalBackground, "mog2": Mog2Background}
"""The background subtraction methods by name: Horprasert's statistical test (the
default) and OpenCV's mixture of Gaussians."""


def background_model(backgrounds, method: str, **options):
    """A background model of one camera by `method` (:data:`BACKGROUND_MODELS`); `options`
    go to its constructor."""
    if method not in BACKGROUND_MODELS:
        raise OptionsError(f"unknown background subtraction method {method!r} ({', '.join(BACKGROUND_MODELS)})")
    return BACKGROUND_MODELS[method](backgrounds, **options)


def clean_sizes(shape, min_blob: float, max_hole: float | None) -> tuple[int, int | None]:
    """``(min_blob, max_hole)`` in pixels for images of `shape`, from fractions of their
    area (see :data:`MIN_BLOB`)."""
    for name, fraction in (("min_blob", min_blob), ("max_hole", max_hole)):
        if fraction is not None and not 0 <= fraction <= 1:
            raise OptionsError(f"{name} is a fraction of the image's area, from 0 to 1; got {fraction}")
    area = shape[0] * shape[1]
    return max(1, round(min_blob * area)), None if max_hole is None else round(max_hole * area)


def clean_mask(mask: np.ndarray, min_blob: int = 200, max_hole: int | None = 2000) -> np.ndarray:
    """Drop foreground blobs (8-connected) smaller than `min_blob` pixels and fill enclosed
    background holes (4-connected, not touching the border) up to `max_hole` pixels (all
    of them if ``None``); 0/255 uint8 in and out."""
    fg = (np.asarray(mask) > 0).astype(np.uint8)
    fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    # Everything below happens in the foreground's box (about a third of a frame): the
    # same components, the same holes.
    x, y, w, h = cv2.boundingRect(fg)
    if w == 0:  # no foreground: nothing to clean (OpenCV 5 refuses an empty box below)
        return fg
    box = fg[y:y + h, x:x + w]
    _clear_components(box, 8, lambda size: size < min_blob)
    # Holes: the background that a flood from a frame of background round the box does not
    # reach (all background outside the box reaches the image's border). Labelling only
    # them is cheaper than labelling all of the background and asking which of its parts
    # touch the border.
    framed = cv2.copyMakeBorder(box, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    cv2.floodFill(framed, None, (0, 0), 1, flags=4)
    holes = (framed[1:-1, 1:-1] == 0).astype(np.uint8)
    if max_hole is not None:
        hx, hy, hw, hh = cv2.boundingRect(holes)
        _clear_components(holes[hy:hy + hh, hx:hx + hw], 4, lambda size: size > max_hole)
    cv2.bitwise_or(box, holes, dst=box)
    return fg * np.uint8(255)


def _clear_components(mask: np.ndarray, connectivity: int, clear) -> None:
    """Zero, in place, the components of the 0/1 uint8 `mask` whose pixel counts `clear`
    (a vectorised test of an array of counts) selects."""
    if not mask.any():
        return
    # The labelling's own counts and boxes: each chosen component (a few dozen at most,
    # specks of noise) is cleared within its box, not by a lookup over every pixel.
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=connectivity)
    chosen = np.flatnonzero(clear(stats[:, cv2.CC_STAT_AREA]))
    for k in chosen[chosen != 0]:  # label 0: the zeros
        x, y, w, h = stats[k, :4]
        window = mask[y:y + h, x:x + w]
        window[labels[y:y + h, x:x + w] == k] = 0


def half_covered(mask: np.ndarray, distortion: np.ndarray, offset: float = 0.0) -> np.ndarray:
    """`mask` (0/255) without the boundary pixels that the subject covers less than half.

    Lens blur mixes the subject's colour with the background's in the pixels along its
    outline, and a pixel covered by a tenth already distorts beyond the test's threshold:
    silhouettes come out a fraction of a pixel too large all round, which a hull of many
    views adds up. A mixed pixel's distortion is about its share of the subject times the
    distortion of the subject beside it, so a boundary pixel is kept when its distortion
    (`distortion` + `offset`, ≥ 0: the background test's evidence plus its threshold) is at
    least half the largest among its eight neighbours. Only the mask's box is read."""
    out = mask.copy()
    x, y, w, h = cv2.boundingRect(out)
    if w == 0:
        return out
    # The mask's box grown by the neighbours a boundary pixel looks at.
    y0, y1, x0, x1 = max(0, y - 1), min(out.shape[0], y + h + 1), max(0, x - 1), min(out.shape[1], x + w + 1)
    fg = (out[y0:y1, x0:x1] > 0).astype(np.uint8)
    ring = (fg > 0) & (cv2.erode(fg, np.ones((3, 3), np.uint8)) == 0)
    d = distortion[y0:y1, x0:x1] + offset
    neighbours = cv2.dilate(d.astype(np.float32), np.ones((3, 3), np.uint8))
    out[y0:y1, x0:x1][ring & (d < 0.5 * neighbours)] = 0
    return out


def signed_distance(mask: np.ndarray) -> np.ndarray:
    """(H, W) float32 pixels from each pixel to the nearest pixel of the other class,
    positive inside `mask` (bool, or > 0 inside)."""
    inside = (np.asarray(mask) > 0).astype(np.uint8)
    d_in = cv2.distanceTransform(inside, cv2.DIST_L2, 5)
    return np.subtract(d_in, distance_outside(inside), dtype=np.float32)  # each is 0 where the other is not


def distance_outside(mask: np.ndarray) -> np.ndarray:
    """(H, W) float32 pixels from each pixel outside `mask` (bool, or > 0 inside) to the
    nearest pixel inside it, 0 inside: minus :func:`signed_distance` outside the mask."""
    return cv2.distanceTransform((np.asarray(mask) <= 0).astype(np.uint8), cv2.DIST_L2, 5)


def _stack(backgrounds) -> np.ndarray:
    if isinstance(backgrounds, np.ndarray) and backgrounds.ndim == 3:
        backgrounds = [backgrounds]
    stack = np.asarray([np.asarray(b) for b in backgrounds])
    if stack.ndim != 4 or stack.shape[-1] != 3 or len(stack) == 0:
        raise SequenceError(f"background images must be (H, W, 3) colour images, got {stack.shape}")
    return stack


def _image(image, shape) -> np.ndarray:
    image = np.asarray(image)
    if image.shape[:2] != tuple(shape) or image.ndim != 3 or image.shape[2] != 3:
        raise SequenceError(f"image of shape {image.shape} does not match the background {tuple(shape) + (3,)}")
    return image
