"""Each joint's confidence, from evidence the prediction did not make (docs/design.md §9,
"How sure a joint is"; docs/formats.md, ``joints.csv``).

A fit is judged against the hull and masks that the predicted pose helped to cut, so a
wrong model can explain its own evidence well. The learned segmenter's 2-D key points are
found in each camera image with no knowledge of the model: where the fitted joint, drawn
into a view, lands far from the person's key point of it, in most of the views that see
it, the image does not support the joint. Per frame and joint, :func:`key_point_offsets`
measures that distance in metres at the joint's depth, the median over the views that see
the key point; :func:`confidence` turns it into a number in [0, 1] once the run is over.

The learned segmenter's key points are not where our joint centres are (its hips sit higher
and wider than the hip joints), and by a different amount for each person: a joint's steady
offset over the take, up to :data:`CONVENTION`, is forgiven as such a difference. Joints
without a key point of their own (waist, chest, clavicles) take the confidence of the
joints that place them. Without the learned segmenter a joint is not judged: its
confidence is NaN.

Without key points a frame is still held against the background test, which the prediction
did not shape either: where, in most views, the test's foreground lies well beyond the
fitted model's silhouette (:func:`unexplained_share`), the model does not explain what the
cameras see (a model built without a torso the colour of the floor, knees placed far down
the legs), and the frame is ``uncertain``.
"""

from __future__ import annotations

import numpy as np

from hullcap._guided import dilated
from hullcap._person import MIN_VISIBILITY

__all__ = ["CONVENTION", "FAR", "NEAR", "UNEXPLAINED_ABOVE", "UNEXPLAINED_BAND", "UNEXPLAINED_SCALE", "UNSURE_BELOW",
           "confidence", "key_point_offsets", "unexplained_share"]

KEY_POINTS_OF = {
    "pelvis": (23, 24), "neck": (11, 12), "head": (7, 8),
    "l_shoulder": (11,), "l_elbow": (13,), "l_wrist": (15,), "r_shoulder": (12,), "r_elbow": (14,), "r_wrist": (16,),
    "l_hip": (23,), "l_knee": (25,), "l_ankle": (27,), "l_toe": (31,),
    "r_hip": (24,), "r_knee": (26,), "r_ankle": (28,), "r_toe": (32,),
}
"""Each joint's counterpart among MediaPipe's pose key points: the mean of these (the
pelvis between the hips, the neck between the shoulders, the head between the ears)."""
JUDGED_BY = {"waist": ("pelvis", "neck"), "chest": ("neck",), "l_clavicle": ("l_shoulder",),
             "r_clavicle": ("r_shoulder",)}
"""Joints without a key point take the least confidence of these."""
MIN_VIEWS = 2
"""A joint is judged in a frame when at least this many views see its key point."""
NEAR = 0.10
"""Metres off its key point (its steady offset forgiven) within which a joint has confidence 1."""
FAR = 0.20
"""Metres off beyond which it has confidence 0 (linear between)."""
CONVENTION = 0.08
"""The most of a joint's median offset over the take forgiven as a difference between its
centre and its key point's (metres)."""
UNSURE_BELOW = 0.5
"""A joint whose confidence is below this is ``uncertain``, and so is its frame."""
UNEXPLAINED_BAND = 0.05
"""A view's foreground pixel farther than this share of the person's height in the image
from the fitted model's silhouette is one the fit leaves unexplained (the outline of a
good fit lies within a few pixels of the mask's)."""
UNEXPLAINED_SCALE = 0.5
"""The image scale the share is measured at: the band is 15 pixels of a person 300 pixels
tall at full size, which half the size holds to a pixel, with a quarter of the pixels to
draw the model into and grow its silhouette over."""
UNEXPLAINED_ABOVE = 0.02
"""A frame whose views leave more than this share of their background test's foreground
unexplained (the median over the views) is ``uncertain``: good fits leave at most 0.8 % on
the development set from colour alone (docs/notebooks/accuracy.md, "What the fit leaves
unexplained")."""


def key_point_offsets(views, cameras, joint_names, joints: np.ndarray) -> np.ndarray:
    """(J,) how far each joint lies from the person's key point of it: in each view (a
    :class:`~hullcap._person.PersonView` or None per camera of `cameras`) that sees the key
    point, the image distance at the joint's depth (metres across the view's ray); the
    median over those views. `joints` are world metres named `joint_names`: (J, 3), or
    (V, J, 3), each view's joints at the frame of its key points (a view whose joints are
    not finite, a frame not fitted, does not count). NaN for a joint without a key point
    or seen by fewer than :data:`MIN_VIEWS` views."""
    out = np.full(len(joint_names), np.nan)
    judged = [(j, KEY_POINTS_OF[n]) for j, n in enumerate(joint_names) if n in KEY_POINTS_OF]
    joints = np.asarray(joints, float)
    each = joints if joints.ndim == 3 else np.broadcast_to(joints, (len(cameras), *joints.shape))
    if not judged:
        return out
    per_view = np.full((len(cameras), len(judged)), np.nan)
    for c, (view, cam) in enumerate(zip(views, cameras)):
        points = each[c][[j for j, _ in judged]]
        if view is None or not np.isfinite(points).all():
            continue
        pixels, depth = cam.project(points)
        for k, (_, key) in enumerate(judged):
            if view.visibility[list(key)].min() >= MIN_VISIBILITY and depth[k] > 0:
                seen = view.key_points[list(key)].mean(axis=0)
                per_view[c, k] = np.linalg.norm(pixels[k] - seen) * depth[k] / cam.K[0, 0]
    for k, (j, _) in enumerate(judged):
        seen = per_view[np.isfinite(per_view[:, k]), k]
        if len(seen) >= MIN_VIEWS:
            out[j] = np.median(seen)
    return out


def confidence(joint_names, offsets: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """(F, J) each joint's confidence in [0, 1] (NaN: not judged) from its `offsets`
    ((F, J), :func:`key_point_offsets` of each frame) over the frames `kept` ((F,) bool,
    those with a fitted pose): 1 within :data:`NEAR` of its key point once its steady
    offset (the median over the kept frames, at most :data:`CONVENTION`) is taken off, 0
    beyond :data:`FAR`. Joints of :data:`JUDGED_BY` take the least of theirs."""
    offsets = np.asarray(offsets, float)
    kept = np.asarray(kept, bool)
    out = np.full(offsets.shape, np.nan)
    seen = kept[:, None] & np.isfinite(offsets)
    for j in np.flatnonzero(seen.any(axis=0)):
        steady = min(float(np.median(offsets[seen[:, j], j])), CONVENTION)
        rows = seen[:, j]
        out[rows, j] = np.clip((FAR - (offsets[rows, j] - steady)) / (FAR - NEAR), 0.0, 1.0)
    names = list(joint_names)
    for joint, by in JUDGED_BY.items():
        if joint in names and all(b in names for b in by):
            with np.errstate(invalid="ignore"):
                out[:, names.index(joint)] = np.min(out[:, [names.index(b) for b in by]], axis=1)
    out[~kept] = np.nan
    return out


def unexplained_share(masks, silhouettes) -> float:
    """The median over the views of the share of each view's foreground (`masks`, (H, W),
    > 0 where the background test sees the person) outside the fitted model's silhouette
    in that view (`silhouettes`, (H, W) bool) grown by :data:`UNEXPLAINED_BAND` of its
    image height (:func:`hullcap._guided.dilated`); NaN where no view has both."""
    shares = []
    for mask, silhouette in zip(masks, silhouettes):
        seen = np.asarray(mask) > 0
        if not seen.any() or not silhouette.any():
            continue
        far = seen & ~dilated(silhouette, UNEXPLAINED_BAND)
        shares.append(np.count_nonzero(far) / np.count_nonzero(seen))
    return float(np.median(shares)) if shares else float("nan")
