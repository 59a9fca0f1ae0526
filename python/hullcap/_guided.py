"""Silhouettes guided by the tracked model (docs/design.md, "Silhouettes").

Background subtraction alone cannot see clothes the colour of the room behind them: a
shirt like the floor is "background" to it, the hull loses the torso, and a hole in one
view carves a tunnel through all of it. While tracking, the model predicted for the
frame, drawn into each view, says where the person almost certainly is. Each pixel near
the person gets the log-odds that it is the subject from these sources, added:

- the statistical test (:meth:`StatisticalBackground.evidence`): how many noise spreads
  its colour lies from the background's, beyond the test's threshold; evidence for the
  background counts `background_weight` times as much, since a pixel the colour of the
  background behind it may be the subject in clothes of that colour (the case at hand);
- colour: log P(colour | subject) − log P(colour | background), from colour histograms
  of this camera learnt where the fitted model says body and not body, the background's
  mixed with the colours of the whole empty scene (:class:`ColourModel`);
- texture, when asked for (`texture_weight`): where the empty scene has texture (tiles'
  joints, brick, wood grain), whether it is still seen through a small window around the
  pixel: the normalised correlation of the window's grey levels with the background's is
  high where the scene shows (shadows and a camera's gain included, which scale it) and
  low where something covers it, whatever that something's colour (:class:`TextureTest`);
- the prior: ± `prior` deep inside or far outside the predicted silhouette, rising
  linearly across a band around its outline whose width is a fraction of the person's
  height in the image (the prediction is off by about that much; outside the outline the
  band widens at frame rates under 30 a second, where it is off by more).

The sum, smoothed over a pixel or two (neighbours agree), decides; the mask is then
cleaned as a silhouette should be (:func:`clean_mask`, sizes scaled with the person's
image size), and its outline pixels kept where the subject covers at least half of them
(:func:`half_covered`). Far from the predicted person (beyond `reach` of its height) the
statistical test decides alone, so a limb the prediction missed is still seen when its
colour differs from the background.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from hullcap._engine import guided_logit
from hullcap._silhouette import FOREGROUND_EVIDENCE, StatisticalBackground, clean_mask, half_covered, signed_distance
from hullcap.errors import OptionsError

__all__ = ["GuidedOptions", "ColourModel", "TextureTest", "GuidedSegmenter", "dilated"]


@dataclass(frozen=True)
class GuidedOptions:
    """Numbers of the model-guided silhouettes (log-odds are natural logarithms).

    Why each default is what it is, with the runs behind it: the accuracy notebook
    (docs/notebooks/accuracy.md, "Why the tracker's defaults are what they are").

    Attributes:
        prior: log-odds of the prior deep inside (+) or far outside (−) the predicted
            silhouette: 2 ≈ 7 to 1.
        band: half-width of the band over which the prior goes from 0 at the predicted
            outline to full, as a fraction of the person's image height (0.04: 10 px at 250
            px tall, about a frame's prediction error of a limb at `band_frame_rate`).
        outer_band: the same outside the predicted outline (``None``: `band`), where a limb
            that moved further than predicted lies.
        band_frame_rate: the frame rate (frames/s) the bands hold for.
        background_weight: weight of the statistical test's evidence for the background
            (negative evidence, at most 3 spreads) against its evidence for the subject.
        colour_weight: weight of the colour log-ratio (clipped to ±4).
        bins: colour histogram bins per channel (16: 16 grey levels per bin).
        scene_share: share of the whole empty scene's colours in the background's colour
            model (the rest: those learnt near the fitted model).
        learn_margin: a pixel teaches the subject's colours when it is this far inside the
            fitted model's outline, the background's when this far outside and within four
            such margins of it (fractions of the person's image height).
        smooth: standard deviation (pixels) of the smoothing of the log-odds.
        reach: beyond this many image heights of the person from its predicted box, only the
            statistical test decides.
        min_blob, max_hole: fractions of the person's image area: smaller foreground specks
            are dropped, smaller enclosed holes filled.
        texture_weight: log-odds of the texture test at its most certain (0: no texture test).
        texture_window: side (pixels, odd) of the window the correlation is taken over.
        texture_min_std: the background's grey-level standard deviation over the window
            below which it has no texture to hide and the test says nothing (5: twice the
            pixel noise assumed by the background model).
        texture_seen, texture_hidden: correlation at or above which the background counts as
            seen (−`texture_weight`), at or below which as hidden (+), linear between.
        learned_weight: weight of the learned person segmenter's log-odds (:mod:`hullcap._person`),
            where it ran: its certainty counts against the background test's and the
            colours', so that each covers what the other misses (0: left out).
        learned_clip: those log-odds are clipped to ±this: a confident verdict of the
            segmenter (4 ≈ 55 to 1) outweighs the background test's doubt (at most 3 noise
            spreads × `background_weight`) but not its certainty that a pixel differs from
            the room (up to ``FOREGROUND_EVIDENCE``), where a fast limb the network blurs
            still shows.
        sure_background: log-odds (after smoothing) at or below −this that call a pixel
            background for sure: the tolerant hull (``TrackerOptions.hull_tolerance``) never
            overrules the view there (:meth:`GuidedSegmenter.segment`).
    """

    prior: float = 2.0
    band: float = 0.04
    outer_band: float | None = None
    band_frame_rate: float = 30.0
    background_weight: float = 0.3
    colour_weight: float = 1.0
    bins: int = 16
    scene_share: float = 0.5
    learn_margin: float = 0.02
    smooth: float = 0.8
    reach: float = 0.3
    min_blob: float = 0.01
    max_hole: float = 0.005
    texture_weight: float = 0.0
    texture_window: int = 7
    texture_min_std: float = 5.0
    texture_seen: float = 0.8
    texture_hidden: float = 0.5
    sure_background: float = 2.0
    learned_weight: float = 1.0
    learned_clip: float = 4.0

    def __post_init__(self):
        if not (self.band > 0 and self.band_frame_rate > 0 and (self.outer_band is None or self.outer_band > 0)):
            raise OptionsError(f"GuidedOptions: band, outer_band and band_frame_rate must be positive, got "
                               f"{self.band}, {self.outer_band} and {self.band_frame_rate}")
        if not 1 <= self.bins <= 256:
            raise OptionsError(f"GuidedOptions.bins must lie in 1..256 (bins per 8-bit channel), got {self.bins}")
        if not 0 <= self.scene_share < 1:  # the band's colours always count: a scene lacks some
            raise OptionsError(f"GuidedOptions.scene_share must lie in [0, 1), got {self.scene_share}")
        if not (self.texture_weight >= 0 and self.texture_min_std >= 0):
            raise OptionsError("GuidedOptions: texture_weight and texture_min_std must be >= 0")
        if not (self.texture_window >= 3 and self.texture_window % 2 == 1):
            raise OptionsError(f"GuidedOptions.texture_window must be odd and >= 3, got {self.texture_window}")
        if not self.sure_background >= 0:
            raise OptionsError(f"GuidedOptions.sure_background must be >= 0 (log-odds), got {self.sure_background}")
        if not (self.learned_weight >= 0 and self.learned_clip > 0):
            raise OptionsError(f"GuidedOptions: learned_weight must be >= 0 and learned_clip > 0, got "
                               f"{self.learned_weight} and {self.learned_clip}")
        if not -1 <= self.texture_hidden < self.texture_seen <= 1:
            raise OptionsError("GuidedOptions: need -1 <= texture_hidden < texture_seen <= 1 (correlations), got "
                               f"{self.texture_hidden} and {self.texture_seen}")

    @property
    def outer(self) -> float:
        """The band outside the predicted outline."""
        return self.band if self.outer_band is None else self.outer_band

    def for_frame_rate(self, fps: float) -> GuidedOptions:
        """These options for frames `fps` a second: the outer band widened by
        ``band_frame_rate / fps`` when that is more than 1, unchanged otherwise."""
        if not fps > 0:
            raise OptionsError(f"a frame rate must be positive, got {fps}")
        if fps >= self.band_frame_rate:
            return self
        return replace(self, outer_band=self.outer * self.band_frame_rate / fps)


class ColourModel:
    """Colour histograms of the subject and of the background around it, one camera,
    and of the whole empty scene (`scene`, an (H, W, 3) image): the person may move in
    front of any of it, and a colour of the scene that never lay near the person while
    it learnt (a wall's panelling) is still background. The background's colour
    probability is the band's and the scene's mixed, the scene's share `scene_share`."""

    def __init__(self, bins: int, scene: np.ndarray, scene_share: float):
        self.bins = bins
        self._bin = ((np.arange(256) * bins) >> 8).astype(np.uint8)  # a grey level's bin
        self._dtype = np.uint16 if bins**3 <= 1 << 16 else np.uint32
        self.subject = np.zeros(bins**3)
        self.background = np.zeros(bins**3)
        self.scene = np.bincount(self._index(scene).ravel(), minlength=bins**3).astype(float)
        self.scene_share = scene_share
        self._table = None  # the log-ratio of each colour, once asked for after learning

    def clear(self) -> None:
        """Forget what was learnt (the scene stays)."""
        self.subject[:] = 0
        self.background[:] = 0
        self._table = None

    def restore(self, subject: np.ndarray, background: np.ndarray) -> None:
        """Take back the counts `subject` and `background` that another model of the same
        bins had learnt (a checkpoint); ValueError when they do not fit."""
        for name, counts in (("subject", subject), ("background", background)):
            if np.shape(counts) != self.subject.shape:
                raise ValueError(f"{name} colour counts of shape {np.shape(counts)}, not {self.subject.shape}")
        self.subject = np.asarray(subject, float).copy()
        self.background = np.asarray(background, float).copy()
        self._table = None

    @property
    def ready(self) -> bool:
        return self.subject.sum() > 0 and self.background.sum() > 0

    def _index(self, image: np.ndarray) -> np.ndarray:
        """Each pixel's colour bin; `image`: uint8, or grey levels as floats (the scene's
        expected colours), whose whole part counts."""
        q = cv2.LUT(image if image.dtype == np.uint8 else image.astype(np.uint8), self._bin)
        n = self._dtype(self.bins)
        return (q[..., 0].astype(self._dtype) * n + q[..., 1]) * n + q[..., 2]

    def learn(self, image: np.ndarray, subject: np.ndarray, background: np.ndarray) -> None:
        """Count the colours of `image` under the boolean masks `subject` and `background`."""
        idx = self._index(image)
        self.subject += np.bincount(idx[subject], minlength=self.bins**3)
        self.background += np.bincount(idx[background], minlength=self.bins**3)
        self._table = None

    def table(self) -> np.ndarray | None:
        """log P(colour | subject) − log P(colour | background) of each colour bin
        (add-one smoothed; bins³ float32, indexed (c0·bins + c1)·bins + c2 by the bins of
        a pixel's channels, ``value · bins // 256``), or None before anything was learnt."""
        if not self.ready:
            return None
        if self._table is None:
            s = np.log((self.subject + 1) / (self.subject.sum() + self.subject.size))
            band = (self.background + 1) / (self.background.sum() + self.background.size)
            b = np.log((1 - self.scene_share) * band + self.scene_share * self.scene / self.scene.sum())
            self._table = (s - b).astype(np.float32)
        return self._table


class TextureTest:
    """Whether the empty scene's texture still shows at each pixel, one camera.

    The normalised correlation of the grey levels in a window around each pixel with the
    empty scene's, over the windows where the scene is textured; +1 where it is hidden,
    −1 where it shows, 0 where the scene has no texture there (see
    :class:`GuidedOptions`, ``texture_*``). A window whose own grey levels are flat
    counts the background model's pixel noise as its variance, so that a uniform
    garment in front of the texture correlates with nothing.
    """

    def __init__(self, background: StatisticalBackground, options: GuidedOptions):
        self.options = options
        self._noise2 = np.float32(background.noise_floor ** 2)
        grey = _grey(background.mean)
        self._mean, var = self._moments(grey)
        self._grey = grey
        self._textured = var >= options.texture_min_std ** 2
        self._inv_std = np.where(self._textured, 1.0 / np.sqrt(np.maximum(var, 1e-6)), 0.0).astype(np.float32)

    def _moments(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = (self.options.texture_window,) * 2
        mean = cv2.boxFilter(grey, cv2.CV_32F, k)
        return mean, np.maximum(cv2.boxFilter(grey * grey, cv2.CV_32F, k) - mean * mean, 0)

    def evidence(self, image: np.ndarray, roi=(slice(None), slice(None))) -> np.ndarray:
        """Float32 in [−1, 1] over `image[roi]`: +1 where the scene's texture is hidden."""
        o = self.options
        grey = _grey(image[roi])
        mean, var = self._moments(grey)
        k = (o.texture_window,) * 2
        covariance = cv2.boxFilter(grey * self._grey[roi], cv2.CV_32F, k) - mean * self._mean[roi]
        correlation = covariance * self._inv_std[roi] / np.sqrt(np.maximum(var, self._noise2))
        hidden = (o.texture_seen - correlation) / (0.5 * (o.texture_seen - o.texture_hidden))
        return np.where(self._textured[roi], np.clip(hidden - 1.0, -1.0, 1.0), 0.0).astype(np.float32)


def _grey(image: np.ndarray) -> np.ndarray:
    """(H, W) float32 grey levels of a BGR image."""
    return cv2.cvtColor(np.ascontiguousarray(image, np.float32), cv2.COLOR_BGR2GRAY)


class GuidedSegmenter:
    """Model-guided silhouettes of one camera (see the module documentation)."""

    def __init__(self, background: StatisticalBackground, options: GuidedOptions | None = None):
        self.background = background
        self.options = options or GuidedOptions()
        self.colours = ColourModel(self.options.bins, background.mean, self.options.scene_share)
        self.texture = TextureTest(background, self.options) if self.options.texture_weight else None

    def learn(self, image: np.ndarray, model_silhouette: np.ndarray) -> None:
        """Learn colours from a frame in which the model is fitted: `model_silhouette` is
        its (H, W) bool silhouette in this view."""
        box = _box(model_silhouette)
        if box is None:
            return
        margin = max(1, int(round(self.options.learn_margin * box[3])))
        d = signed_distance(model_silhouette)
        self.colours.learn(image, d > margin, (d < -margin) & (d > -4 * margin))

    def mask(self, image: np.ndarray, prior: np.ndarray | None, evidence: np.ndarray | None = None) -> np.ndarray:
        """(H, W) uint8 silhouette, 255 = subject, given the predicted model's (H, W) bool
        silhouette `prior` (``None``: the statistical test alone); `evidence`: the
        background's ``evidence(image)`` when it was computed already."""
        return self.segment(image, prior, evidence)[0]

    def segment(self, image: np.ndarray, prior: np.ndarray | None, evidence: np.ndarray | None = None,
                learned: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """``(mask, unsure)``: :meth:`mask`'s silhouette, and (H, W) bool where its verdict
        was not sure background (log-odds above −``options.sure_background``; False far
        from the person, where the evidence without the prior decides), the only pixels
        where a tolerant hull may overrule this view; ``None`` without a prior. `learned`:
        the learned segmenter's probability of each pixel (:mod:`hullcap._person`), fused
        with the rest where given (:func:`learned_logit`)."""
        o = self.options
        if evidence is None:
            evidence = self.background.evidence(image)
        box = None if prior is None else _box(prior)
        if box is None:
            if learned is None:
                return self.background.mask(image, evidence), None
            unguided = _smoothed(self._evidence_logit(evidence) + learned_logit(learned, o), o.smooth)
            raw = cv2.compare(unguided, 0.0, cv2.CMP_GT)
            cleaned = clean_mask(raw, self.background.min_blob, self.background.max_hole)
            return half_covered(cleaned, evidence, self.background.thresholds.chromaticity), None
        x, y, w, h = box
        pad = int(round(o.reach * h))
        y0, y1 = max(0, y - pad), min(image.shape[0], y + h + pad)
        x0, x1 = max(0, x - pad), min(image.shape[1], x + w + pad)
        roi = (slice(y0, y1), slice(x0, x1))
        ramp = _ramp(prior, box, roi, max(1.0, o.band * h), max(1.0, o.outer * h))
        table = self.colours.table() if o.colour_weight else None
        logit = guided_logit(
            evidence, image, (y0, x0), ramp,
            (-3.0, FOREGROUND_EVIDENCE, o.background_weight, o.prior, o.colour_weight, 4.0),
            None if table is None else (table, self.colours.bins))
        if self.texture is not None:
            logit += o.texture_weight * self.texture.evidence(image, roi)
        if learned is None:
            raw = cv2.compare(evidence, 0.0, cv2.CMP_GT)
        else:
            learned = learned_logit(learned, o)
            logit += learned[roi]
            raw = cv2.compare(_smoothed(self._evidence_logit(evidence) + learned, o.smooth), 0.0, cv2.CMP_GT)
        logit = _smoothed(logit, o.smooth)
        raw[roi] = cv2.compare(logit, 0.0, cv2.CMP_GT)
        unsure = np.zeros(prior.shape, bool)
        unsure[roi] = logit > -o.sure_background
        area = float(np.count_nonzero(prior))
        cleaned = clean_mask(raw, max(1, int(o.min_blob * area)), int(o.max_hole * area))
        return half_covered(cleaned, evidence, self.background.thresholds.chromaticity), unsure

    def _evidence_logit(self, evidence: np.ndarray) -> np.ndarray:
        """The background test's term of the log-odds over a whole view, as
        :func:`~hullcap._engine.guided_logit` takes it: the evidence clipped into −3 …
        ``FOREGROUND_EVIDENCE``, its negative part weighed by ``background_weight``."""
        e = np.clip(evidence, -3.0, FOREGROUND_EVIDENCE)
        return np.where(e > 0, e, np.float32(self.options.background_weight) * e).astype(np.float32)


def learned_logit(probability: np.ndarray, options: GuidedOptions) -> np.ndarray:
    """The learned segmenter's term of the log-odds: ``learned_weight`` times its
    probability's log-odds clipped into ±``learned_clip`` ((H, W) float32)."""
    limit = 1.0 / (1.0 + np.exp(options.learned_clip))  # the probability whose log-odds is -learned_clip
    p = np.clip(probability, limit, 1.0 - limit)
    return (np.float32(options.learned_weight) * np.log(p / (1.0 - p))).astype(np.float32)


def _smoothed(logit: np.ndarray, sigma: float) -> np.ndarray:
    """`logit` blurred by a Gaussian of `sigma` pixels (0: as it is)."""
    return cv2.GaussianBlur(logit, (0, 0), sigma) if sigma > 0 else logit


def _ramp(prior: np.ndarray, box, roi, band: float, outer: float) -> np.ndarray:
    """Over `roi`, the signed distance to the outline of `prior` (bool, bounding `box`)
    divided by `band` inside it and by `outer` outside, clipped to ±1. Only pixels within
    those bands of the outline fall between, and they lie in the box grown by the larger:
    the distance transform runs in that window (with a margin) alone, where it gives the
    values of the whole region (a shortest chamfer path stays within the box of its two
    ends, and a ring of outside pixels surrounds the prior in the window)."""
    x, y, w, h = box
    (y0, y1), (x0, x1) = (roi[0].start, roi[0].stop), (roi[1].start, roi[1].stop)
    m = int(np.ceil(max(band, outer))) + 2
    wy0, wy1, wx0, wx1 = max(y0, y - m), min(y1, y + h + m), max(x0, x - m), min(x1, x + w + m)
    out = np.full((y1 - y0, x1 - x0), -1.0, np.float32)
    d = signed_distance(prior[wy0:wy1, wx0:wx1])
    scale = np.float32(band) if outer == band else np.where(d > 0, np.float32(band), np.float32(outer))
    out[wy0 - y0:wy1 - y0, wx0 - x0:wx1 - x0] = np.clip(d / scale, -1.0, 1.0)
    return out


def dilated(silhouette: np.ndarray, fraction: float) -> np.ndarray:
    """`silhouette` (bool) grown by `fraction` of its image height all round."""
    box = _box(silhouette)
    if box is None:
        return silhouette
    r = max(1, int(round(fraction * box[3])))
    # Only the box grown by r can change: dilating that window alone gives the same pixels.
    x, y, w, h = box
    window = (slice(max(0, y - r), y + h + r), slice(max(0, x - r), x + w + r))
    out = np.zeros_like(silhouette, bool)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    out[window] = cv2.dilate(silhouette[window].astype(np.uint8), kernel) > 0
    return out


def _box(silhouette: np.ndarray):
    """(x, y, width, height) of the silhouette's bounding box, or None when it is empty."""
    if not silhouette.any():
        return None
    return cv2.boundingRect(silhouette.astype(np.uint8))
