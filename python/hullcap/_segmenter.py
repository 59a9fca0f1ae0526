"""The silhouettes of a tracking run (docs/design.md, "Silhouettes"; docs/segmentation.md):
each camera's mask of each frame, from the sequence's own masks, or from the evidence of the
background test and of the learned person segmenter (:mod:`hullcap._person`, when installed)
fused per pixel, guided by the model at its predicted pose and by the subject's colours
(:mod:`hullcap._guided`). A camera without a background image is segmented by the learned
segmenter alone, or left out without it.

One :class:`Segmenter` serves a run: it builds each camera's background model once, reads
frames ahead on a second thread while the engine fits the frame before
(:meth:`Segmenter.reading_ahead`), leaves out a view it cannot use (recorded once in the
run's problems), and learns the subject's colours from frames in which the model is
fitted.
"""

from __future__ import annotations

import time
from collections import defaultdict
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from hullcap._body import BodyModel
from hullcap._confidence import UNEXPLAINED_SCALE, unexplained_share
from hullcap._fitting import PoseParameters
from hullcap._guided import GuidedSegmenter
from hullcap._person import KEY_POINTS, PersonSegmenter, PersonView, facing_agreement, missing
from hullcap._problems import ProblemLog
from hullcap._render import model_silhouettes
from hullcap._sequence import Sequence
from hullcap._silhouette import background_model, clean_mask
from hullcap._threads import ReadAhead, over_views
from hullcap._tracking_options import TrackerOptions
from hullcap.errors import OptionsError, SequenceError, ViewError

__all__ = ["Segmenter"]

# The checkpoint's arrays of what the segmenter learnt (Segmenter.learnt).
LEARNT_TEACH_AT = "learnt_teach_at"
LEARNT_COLOURS = ("learnt_colours_subject", "learnt_colours_background")
LEARNT_CROPS = "learnt_crops"
"""Per camera: the frame, hip centre and body top the learned segmenter follows (frame -1: none)."""
LEARNT_PEOPLE = "learnt_people"
"""Per camera: the last frame the learned segmenter ran on (-1: none, or nobody found), and
the score, key points and their visibility it saw there (``Segmenter.recent_people``)."""


@dataclass
class _Input:
    """One camera's input of one frame: its mask, or its image and the background test's
    evidence; and what the learned segmenter saw (None where it did not run, or found
    nobody)."""

    mask: np.ndarray | None = None
    image: np.ndarray | None = None
    evidence: np.ndarray | None = None
    person: PersonView | None = None


class Segmenter:
    """Every camera's silhouettes of a sequence's frames, by `options` (see the module
    documentation); views left out go to `problems`, seconds spent to `seconds`."""

    def __init__(self, sequence: Sequence, options: TrackerOptions, problems: ProblemLog, seconds: defaultdict):
        self.sequence = sequence
        self.options = options
        self.problems = problems
        self.seconds = seconds
        self.guidance = options.guidance.for_frame_rate(sequence.fps)
        """The guided masks' options at the sequence's frame rate."""
        self._backgrounds = None
        self._guided = None
        self.learned = self._learned_wanted()
        """Whether the learned person segmenter runs (``TrackerOptions.segmenter``)."""
        self._people: list | None = None  # each camera's PersonSegmenter, once needed
        self._every_frame = False  # while True (the subject's model is built) the learned segmenter runs every frame
        # Cameras without a usable background image, left out of every frame: name → why.
        self.no_background: dict[str, ViewError] = {}
        self.broken: set = set()
        """``(frame, camera)`` of the views already left out."""
        self._ahead: ReadAhead | None = None
        # How many frames' colours the guided segmenters know since they last forgot, and
        # the frames from which tracking still teaches them, in order (`teaching_frames`).
        self._colour_frames = 0
        self.teach_at: list[int] = []
        # The last frame segmented and its images (None for a view left out), which
        # teaching reads instead of decoding them again: a video camera's reader is the
        # read-ahead thread's meanwhile.
        self._segmented: tuple[int, list] = (-1, [])
        # The last frame segmented and each view's input (a ViewError for one left out),
        # from which the background test's own masks are drawn when the fit is judged.
        self._inputs_seen: tuple[int, list] = (-1, [])
        # Each frame's crops the learned segmenters follow once it is read (written on the
        # read-ahead thread), and those of the last frame segmented, which the checkpoint keeps.
        self._crops_after: dict[int, list] = {}
        self._crops: list = []
        self.people: tuple[int, list[PersonView | None]] = (-1, [])
        """The last frame segmented and what the learned segmenter saw of the person in
        each of its views (None where it did not run or found nobody)."""
        self._latest_people: list[tuple[int, PersonView | None]] = []
        """Per view, the last frame the learned segmenter ran on and what it saw there."""

    @property
    def given(self) -> bool:
        """Whether the masks are the sequence's own (else by background subtraction)."""
        return not self.options.ignore_silhouettes and self.sequence.has_silhouettes

    def _learned_wanted(self) -> bool:
        """Whether the learned segmenter runs: asked (OptionsError when it cannot), or by
        default wherever it is installed; never with the sequence's own masks."""
        kind = self.options.segmenter
        if self.given or kind == "colour":
            return False
        why = missing()
        if kind == "learned" and why is not None:
            raise OptionsError(f"segmenter 'learned': {why}")
        return why is None

    @property
    def guides(self) -> bool:
        """Whether the masks are guided by the model."""
        return not self.given and self._segmenters() is not None

    def segment(self, frame: int, priors=None) -> tuple[list[np.ndarray], list[np.ndarray | None]]:
        """``(masks, unsure)`` of `frame`: each view's mask (an empty one for a view left
        out), guided by the predicted model's silhouettes `priors` (one bool image per view)
        when the options say so; and for each view where its guided mask was not sure of
        the background (:meth:`GuidedSegmenter.segment`; None for a view not guided)."""
        t0 = time.perf_counter()
        inputs = self._ahead.take(frame) if self._ahead is not None else self._inputs(frame)

        def segmented(i: int):
            view = inputs[i]
            learned = None if view.person is None else view.person.probability
            return self._guided[i].segment(view.image, None if priors is None else priors[i], view.evidence, learned)

        to_segment = [i for i, view in enumerate(inputs) if isinstance(view, _Input) and view.mask is None]
        self._segmented = (frame, [inputs[i].image if i in to_segment else None for i in range(len(inputs))])
        self._inputs_seen = (frame, inputs)
        self.people = (frame, [view.person if isinstance(view, _Input) else None for view in inputs])
        self._remember_people(frame, self.people[1])
        self._crops = self._crops_after.pop(frame, self._crops)
        segmented_views = dict(zip(to_segment, over_views(segmented, to_segment)))
        masks, unsure = [], []
        for i, (cam, view) in enumerate(zip(self.sequence.cameras, inputs)):
            if isinstance(view, ViewError):  # a missing or broken image or mask: leave that view out
                self.left_out(frame, cam, view)
                masks.append(np.zeros((cam.height, cam.width), np.uint8))
            elif view.mask is not None:
                masks.append(view.mask)
            else:
                masks.append(segmented_views[i][0])
            unsure.append(segmented_views[i][1] if i in segmented_views else None)
        self.seconds["silhouettes"] += time.perf_counter() - t0
        return masks, unsure

    def _inputs(self, frame: int) -> list[_Input | ViewError]:
        """What each camera gives for `frame` before any prediction: the given mask; the
        mask of the unguided background test or of the learned segmenter alone; or the
        image with the guided segmenter's background evidence and the learned segmenter's
        probabilities; or the ViewError that leaves it out. Runs on the read-ahead thread:
        it may not touch the problem log."""
        seq = self.sequence
        segmenters = None if self.given else self._segmenters()
        images: list[np.ndarray | ViewError] = []
        for cam in seq.cameras:
            if cam.name in self.no_background and not self.learned:
                images.append(self.no_background[cam.name])
                continue
            try:
                images.append(seq.mask(frame, cam.name) if self.given else seq.image(frame, cam.name))
            except ViewError as e:
                images.append(e)
        if self.given:
            return [image if isinstance(image, ViewError) else _Input(mask=image) for image in images]

        def view(i: int) -> _Input | ViewError:
            image = images[i]
            if isinstance(image, ViewError):
                return image
            # While the subject's model is built, the detector places every crop (the first
            # frames decide the model); after, the person is followed from frame to frame.
            followed = None if self._every_frame else frame
            person = self._people[i].find(image, followed) if self.learned and self.learned_runs(frame, i) else None
            background = self._backgrounds[i]
            if background is None:  # no background image: the learned segmenter alone
                mask = np.zeros(image.shape[:2], np.uint8) if person is None else person.mask()
                return _Input(mask=mask, person=person)
            if segmenters is None:
                return _Input(mask=background.mask(image), person=person)
            return _Input(image=image, evidence=segmenters[i].background.evidence(image), person=person)

        inputs = over_views(view, range(len(images)))
        if self.learned:
            self._crops_after[frame] = [p.followed for p in self._people]
        return inputs

    @contextmanager
    def every_frame(self):
        """While it lasts, the learned segmenter runs on every frame it is given, whatever
        ``learned_every`` says, its detector placing each crop (the subject's model is built
        and refined so)."""
        self._every_frame = True
        try:
            yield
        finally:
            self._every_frame = False

    def _remember_people(self, frame: int, views: list[PersonView | None]) -> None:
        """Keep, per view, what the learned segmenter saw (`views`) where it ran on `frame`."""
        if len(self._latest_people) != len(views):
            self._latest_people = [(-1, None)] * len(views)
        for i, person in enumerate(views):
            if self.learned and self.learned_runs(frame, i):
                self._latest_people[i] = (frame, person)

    def recent_people(self, frame: int) -> list[tuple[int, PersonView] | None]:
        """Per view, ``(frame seen, what the learned segmenter saw)`` of the last frame up
        to `frame` it ran on in that view, when that is one of the last ``learned_every``
        frames and it found the person there; else None."""
        return [(f, p) if p is not None and 0 <= frame - f < self.options.learned_every else None
                for f, p in self._latest_people]

    def facing(self, frame: int):
        """The way the person of `frame` (the frame last segmented) faces, as the learned
        segmenter's key points say: a function of a model and a pose, from -1 (facing away)
        to 1 (:func:`hullcap._person.facing_agreement`); None without key points. Where the
        learned segmenter runs in a view every few frames (``learned_every``), that view's
        latest key points vote: a person does not turn round between them."""
        seen, _ = self.people
        views = [None if r is None else r[1] for r in self.recent_people(frame)]
        if seen != frame or not any(v is not None for v in views):
            return None
        cameras = self.sequence.cameras

        def facing(model: BodyModel, pose: PoseParameters) -> float:
            joints = model.joints(pose.theta, pose.root_rotation, pose.root_translation)
            return facing_agreement(views, cameras, dict(zip(model.joint_names, joints)))
        return facing

    def unexplained(self, frame: int, model: BodyModel, pose: PoseParameters) -> float:
        """The share of the background test's foreground that `model` at `pose`, fitted to
        `frame` (the frame last segmented), leaves unexplained
        (:func:`hullcap._confidence.unexplained_share`): evidence the prediction did not
        shape; measured at :data:`~hullcap._confidence.UNEXPLAINED_SCALE` of the image
        size. NaN where the learned segmenter runs (its key points judge the joints),
        where the masks are the sequence's own, where no view has a background image, and
        while the subject's model is built (those frames are tracked again after)."""
        seen, inputs = self._inputs_seen
        if seen != frame or self.learned or self.given or self._backgrounds is None or self._every_frame:
            return float("nan")
        views = [i for i, view in enumerate(inputs) if isinstance(view, _Input) and self._backgrounds[i] is not None]
        if not views:
            return float("nan")

        cameras = {i: self.sequence.cameras[i].scaled(UNEXPLAINED_SCALE) for i in views}

        def mask(i: int) -> np.ndarray:  # the test's decision, cleaned (its outline's pixels matter not here)
            view, background = inputs[i], self._backgrounds[i]
            decided = view.mask if view.evidence is None else clean_mask(
                cv2.compare(view.evidence, 0.0, cv2.CMP_GT), background.min_blob, background.max_hole)
            return cv2.resize(decided, (cameras[i].width, cameras[i].height), interpolation=cv2.INTER_AREA) > 127
        return unexplained_share(over_views(mask, views), model_silhouettes([cameras[i] for i in views], model, pose))

    def learned_runs(self, frame: int, i: int) -> bool:
        """Whether the learned segmenter runs on view `i` at `frame`: on every frame while
        the subject's model is built, and in a view without a background image (it alone
        segments that view); else every ``learned_every`` frames, staggered over the views
        so that each frame has its share of them."""
        alone = self._backgrounds is not None and self._backgrounds[i] is None
        return self._every_frame or alone or (frame + i) % self.options.learned_every == 0

    def _images(self, frame: int) -> list[np.ndarray | None]:
        """Frame `frame` of every camera; ``None`` for a view that cannot be used (recorded)."""
        images = []
        for cam in self.sequence.cameras:
            try:
                images.append(self.sequence.image(frame, cam.name))
            except ViewError as e:
                self.left_out(frame, cam, e)
                images.append(None)
        return images

    def left_out(self, frame: int, cam, error: ViewError) -> None:
        """Record that `cam` is left out of `frame`; a camera without its background is
        left out of every frame, and was said so once, at start-up."""
        if (frame, cam.name) not in self.broken:
            self.broken.add((frame, cam.name))
            if cam.name not in self.no_background:
                self.problems.add(frame, error.what, cam.name, error.file)

    def prepare(self, frames: int | None = None) -> int:
        """The start-up checks of a run of the first `frames` frames (``None``: all), and how
        many frames it tracks: every camera's frames on disk against ``meta.json``
        (recorded; frames no camera has are not tracked), every camera's image size against
        its calibration, and each camera's background model built now (when the masks are
        not given), with every camera left out for want of one recorded."""
        seq = self.sequence
        n = len(seq) if frames is None else min(frames, len(seq))
        counts = seq.frame_counts(silhouettes=self.given)
        on_disk = ", ".join(f"{name} {k}" for name, k in counts.items())
        if any(k < len(seq) for k in counts.values()):
            self.problems.add(None, f"meta.json says {len(seq)} frames, on disk: {on_disk}; "
                                    f"a camera's missing frames leave its view out")
        elif any(k > len(seq) for k in counts.values()):
            self.problems.add(None, f"meta.json says {len(seq)} frames, on disk: {on_disk}; "
                                    f"only the first {len(seq)} are tracked")
        if not self.given:
            seq.check_image_sizes()
            self._segmenters()
            alone = "segmented by the learned person segmenter alone" if self.learned else "left out of every frame"
            for name, e in self.no_background.items():
                self.problems.add(None, f"{alone}: no usable background image: {e.what}", name, e.file)
        return max(1, min(n, max(counts.values())))

    def _segmenters(self):
        """The background models (None for a camera without a usable background image, in
        `no_background`) and the learned segmenters, built once; the guided segmenters
        built on the background models, or None. A SequenceError when no camera has a
        background image and the learned segmenter does not run."""
        if self._backgrounds is None:
            seq = self.sequence
            backgrounds = []
            for cam in seq.cameras:
                try:
                    backgrounds.append(background_model(seq.backgrounds(cam.name), self.options.background))
                except ViewError as e:
                    self.no_background[cam.name] = e
                    backgrounds.append(None)
            if len(self.no_background) == len(seq.cameras) and not self.learned:
                first = next(iter(self.no_background.values()))
                why = missing() or "it was turned off (segmenter 'colour')"
                raise SequenceError(
                    f"{seq.path}: no camera has a usable background image ({first}); background subtraction "
                    "needs background/<camera>.png of the empty scene for each camera (or a clip of it); without "
                    f"one, the learned person segmenter segments the views, but {why}; or give the sequence your "
                    "own masks in silhouettes/<camera>/ (docs/formats.md, docs/segmentation.md)")
            if self.learned:
                self._people = [PersonSegmenter() for _ in seq.cameras]
            self._backgrounds = backgrounds
            guided = self.options.guided and self.options.background == "statistical"
            if guided and any(b is not None for b in backgrounds):
                self._guided = [None if b is None else GuidedSegmenter(b, self.guidance) for b in backgrounds]
        return self._guided

    @property
    def reading_seconds(self) -> float:
        """Seconds the read-ahead thread has worked so far (0 while none reads ahead)."""
        return 0.0 if self._ahead is None else self._ahead.seconds

    @contextmanager
    def reading_ahead(self, frames):
        """While it lasts, :meth:`segment` takes `frames`, in order, from the read-ahead
        thread (when the options ask for one)."""
        if self.options.read_ahead == 0 or not len(frames):
            yield
            return
        if not self.given:
            self._segmenters()  # built here, not on the other thread
        ahead = ReadAhead(self._inputs, frames, self.options.read_ahead)
        try:
            with ahead:
                self._ahead = ahead
                yield
        finally:
            self._ahead = None
            self.seconds["read ahead"] += ahead.seconds

    # -- the subject's colours ----------------------------------------------------------

    def teaching_frames(self, window: list[int]) -> list[int]:
        """The frames of `window` (the first seconds from the first tracked frame), spread
        over it, from which tracking teaches the guided segmenters colours as it goes, when
        they know fewer than `calibration_frames` frames' colours. A refined model's window
        taught them that many, the bends of the body among them; a given model, or one
        built without ``refine_joints``, was placed at one frame, whose colours alone they
        know. Each is taught at the first frame from it on that passes without a search."""
        if not self.guides or self._colour_frames >= self.options.calibration_frames:
            return []
        return spread(window, self.options.calibration_frames)[1:]

    def learn_colours(self, frame: int, model: BodyModel, pose: PoseParameters, fresh: bool = False,
                      images: list | None = None) -> None:
        """Teach the guided segmenters the subject's and background's colours from a frame
        in which `model` is fitted at `pose` (`fresh`: forget what they knew); `images`:
        the frame's, when they were read already (None for a view left out). No-op when
        the silhouettes are not guided."""
        if not self.guides:
            return
        images = self._images(frame) if images is None else images
        self._colour_frames = 1 if fresh else self._colour_frames + 1
        for seg, img, sil in zip(self._guided, images, model_silhouettes(self.sequence.cameras, model, pose)):
            if seg is None:  # a camera without its background
                continue
            if fresh:
                seg.colours.clear()
            if img is not None:
                seg.learn(img, sil)

    def teach(self, frame: int, model: BodyModel, pose: PoseParameters) -> None:
        """Learn colours from `frame`, just segmented and fitted without a search (`model`
        at `pose`), when it is due to teach (:meth:`teaching_frames`)."""
        if self.teach_at and frame >= self.teach_at[0] and self._segmented[0] == frame:
            self.teach_at = [f for f in self.teach_at if f > frame]
            self.learn_colours(frame, model, pose, images=self._segmented[1])

    def learnt(self) -> dict:
        """What the segmenters have learnt, for the checkpoint: the guided segmenters'
        colours and the frames still to teach them from; the crops the learned segmenters
        follow after the last frame segmented."""
        learnt = {LEARNT_TEACH_AT: np.asarray(self.teach_at, np.int64)}
        if self._crops:
            learnt[LEARNT_CROPS] = np.array([[-1.0] * 5 if c is None else [c[0], *c[1], *c[2]] for c in self._crops])
        if self.learned and self._latest_people:
            width = 2 + 3 * KEY_POINTS
            learnt[LEARNT_PEOPLE] = np.array([
                [-1.0] * width if p is None else [f, p.score, *p.key_points.ravel(), *p.visibility]
                for f, p in self._latest_people])
        if self.guides:
            known = next(g for g in self._guided if g is not None)  # a camera without its background: none
            for name, part in zip(LEARNT_COLOURS, ("subject", "background")):
                none = np.zeros_like(getattr(known.colours, part))
                learnt[name] = np.stack([none if g is None else getattr(g.colours, part) for g in self._guided])
        return learnt

    def relearn(self, arrays: dict) -> None:
        """Takes back from a checkpoint's `arrays` (and removes from them) what
        :meth:`learnt` put there, so that a resumed run goes on as the interrupted one would."""
        teach_at = np.asarray(arrays.pop(LEARNT_TEACH_AT, np.empty(0, np.int64)))
        if teach_at.ndim != 1 or teach_at.dtype.kind not in "iu":
            raise ValueError(f"{LEARNT_TEACH_AT} is not a list of frames")
        self.teach_at = [int(f) for f in teach_at]
        crops = arrays.pop(LEARNT_CROPS, None)
        if crops is not None and self.learned:
            self._segmenters()
            if np.shape(crops) != (len(self._people), 5):
                raise ValueError(f"{LEARNT_CROPS} has shape {np.shape(crops)}, not ({len(self._people)}, 5)")
            for person, c in zip(self._people, np.asarray(crops, float)):
                # float32, as the landmark model gave them: the crop is computed from them as it was
                hip, top = c[1:3].astype(np.float32), c[3:5].astype(np.float32)
                person.followed = None if c[0] < 0 else (int(c[0]), hip, top)
        people = arrays.pop(LEARNT_PEOPLE, None)
        if people is not None and self.learned:
            self._latest_people = [_person_from_row(row, len(people)) for row in np.asarray(people, float)]
        colours = [arrays.pop(name, None) for name in LEARNT_COLOURS]
        if colours[0] is not None and self.guides:
            if any(len(c) != len(self._guided) for c in colours):
                raise ValueError(f"colours of {len(colours[0])} cameras, not {len(self._guided)}")
            for g, subject, background in zip(self._guided, *colours):
                if g is not None:
                    g.colours.restore(subject, background)


def _person_from_row(row: np.ndarray, cameras: int) -> tuple[int, PersonView | None]:
    """``(frame, what the learned segmenter saw)`` of one camera from a checkpoint's row of
    :data:`LEARNT_PEOPLE` (its key points only: no probabilities are kept)."""
    if row.shape != (2 + 3 * KEY_POINTS,):
        raise ValueError(f"{LEARNT_PEOPLE} has rows of {row.shape[0]} numbers, not {2 + 3 * KEY_POINTS} "
                         f"({cameras} cameras)")
    if row[0] < 0:
        return -1, None
    points = row[2:2 + 2 * KEY_POINTS].reshape(KEY_POINTS, 2).astype(np.float32)
    return int(row[0]), PersonView(np.zeros((0, 0), np.float32), points, row[2 + 2 * KEY_POINTS:].astype(np.float32),
                                   float(row[1]))


def spread(frames: list[int], n: int) -> list[int]:
    """Up to `n` of `frames`, spread evenly over them (the first and the last among them)."""
    return sorted({frames[int(round(i))] for i in np.linspace(0, len(frames) - 1, n)})
