"""Each frame's visual hull in a tracking run (docs/design.md §7): the segmenter's masks,
guided by the model at its predicted pose, carved into the capture volume, with the
tolerance of a view that misses a part where the prediction puts the body, and the hull's
vertices no view vouches for left out of the fit's target when asked.
"""

from __future__ import annotations

import time
import warnings
from contextlib import contextmanager

import numpy as np

from hullcap._guided import dilated
from hullcap._hull import HullReport, doubtful_vertices, visual_hull
from hullcap._problems import ABSENT, ProblemLog
from hullcap._render import model_silhouettes
from hullcap._segmenter import Segmenter
from hullcap._threads import over_views
from hullcap._tracking_options import TrackerOptions
from hullcap.errors import HullError

__all__ = ["Carver", "PersonAbsent"]


class PersonAbsent(HullError):
    """A frame in which no view shows the person (every usable view's mask is empty): the
    person left the capture volume. The frame is recorded once, as a whole, in
    ``problems.json``; tracking finds the person again when they return."""


class Carver:
    """The visual hull of each frame of `segmenter`'s sequence, in the capture `volume`
    (``(lo, hi)`` metres), by `options`; views the hull leaves out go to `problems`, the
    seconds spent to `seconds`."""

    def __init__(self, segmenter: Segmenter, options: TrackerOptions, volume, problems: ProblemLog, seconds: dict):
        self.segmenter = segmenter
        self.cameras = segmenter.sequence.cameras
        self.options = options
        self.volume = volume
        self.problems = problems
        self.seconds = seconds
        self.voxel_size = options.voxel_size
        """The finest voxel of the hulls carved now (metres)."""

    @contextmanager
    def building(self):
        """While it lasts, hulls are carved as the subject's model is built
        (``TrackerOptions.subject_voxel_size``)."""
        self.voxel_size = self.options.subject_voxel_size or self.options.voxel_size
        try:
            yield
        finally:
            self.voxel_size = self.options.voxel_size

    @property
    def tolerance(self) -> int:
        """How many views may leave a voxel out (``TrackerOptions.hull_tolerance``; by
        default 1 for masks by background subtraction, 0 for the sequence's own)."""
        tolerance = self.options.hull_tolerance
        return tolerance if tolerance is not None else (0 if self.segmenter.given else 1)

    def carve(self, frame: int, prior=None, doubt: float | None = None):
        """``(hull, masks)`` of `frame`, with the model at a predicted pose as its prior
        (`prior`: ``(model, pose)`` or ``(model, pose, also)``, the model drawn at both): it
        guides the masks and says where a view that misses a part may be overruled. With
        `doubt` (metres, ``TrackerOptions.hull_doubt``), the hull less the vertices no
        guided view vouches for. :class:`PersonAbsent` when no view shows the person, and
        a ``HullError`` (a ``ValueError``) when there is no hull."""
        tolerance = self.tolerance
        # The prior's silhouettes serve the guided masks and the tolerant hull, nothing else.
        used = prior is not None and (tolerance > 0 or self.segmenter.guides)
        t0 = time.perf_counter()
        silhouettes = model_silhouettes(self.cameras, *prior) if used else None
        self.seconds["silhouettes"] += time.perf_counter() - t0  # the prediction, drawn for the masks
        masks, unsure = self.segmenter.segment(frame, silhouettes)
        broken = self.segmenter.broken
        if all((frame, cam.name) in broken for cam in self.cameras):
            raise HullError("no usable view: every camera's was left out")
        if not any(m.any() for m in masks):
            raise PersonAbsent(f"{ABSENT} (every mask is empty)")
        t0 = time.perf_counter()
        report = HullReport()
        outer = self.segmenter.guidance.outer
        priors = None if silhouettes is None or tolerance == 0 else \
            over_views(lambda view: _overrulable(*view, outer), zip(silhouettes, unsure))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # views left out are recorded in `problems`
                surface = visual_hull(masks, self.cameras, self.voxel_size, self.volume, report,
                                      tolerance=tolerance, priors=priors)
            if doubt is not None and any(u is not None for u in unsure):
                keep = ~doubtful_vertices(surface, masks, unsure, self.cameras, doubt, self.options.hull_doubt_views)
                surface = surface.subset(keep) if keep.any() else surface  # an empty target fits nothing
            return surface, masks
        finally:
            for name, why in report.skipped.items():
                if (frame, name) not in broken:
                    self.problems.add(frame, f"left out ({why})", name)
            self.seconds["hull"] += time.perf_counter() - t0


def _overrulable(silhouette: np.ndarray, unsure: np.ndarray | None, band: float) -> np.ndarray:
    """Where the tolerant hull may overrule a view: its predicted `silhouette` grown by
    `band` of its height (the prediction's error), less what the view's guided mask
    called background for sure (`unsure` False; None for a view not guided)."""
    grown = dilated(silhouette, band)
    return grown if unsure is None else grown & unsure
