"""Whether a rig's views agree on the person (``hullcap calib check``).

Every view's silhouette bounds the visual hull, so the hull of all views, drawn back into
a camera, covers that camera's silhouette wherever the other views agree with it. Where it
does not, some view carved away what this one sees: a camera calibrated wrong (each view
then carves the others, and it most), or a silhouette with a hole or a background that
is wrong. Leaving each view out in turn tells which: the view whose absence lets the
others' silhouettes be covered most is the one that disagrees.

What the thresholds below rest on is in docs/notebooks/accuracy.md, "Views that
disagree".
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from hullcap._cameras import Cameras
from hullcap._files import atomic_write
from hullcap._hull import VOXEL_SIZE, visual_hull
from hullcap._render import render_silhouette
from hullcap.errors import HullError

__all__ = ["ViewAgreement", "view_agreement", "suspects", "describe_agreement", "draw_agreement",
           "SUSPECT_GAIN", "STANDS_OUT", "BROAD"]

SUSPECT_GAIN = 0.01
"""A view is suspected when leaving it out covers this much more of the other views'
silhouettes (a fraction of their pixels): a calibrated rig with exact masks stays under
half of it, a camera of an 8-camera ring turned by 1° over it."""

STANDS_OUT = 3.0
"""How many times the median gain of the other views the suspects' first must gain for
the verdict to be one camera (or it and the one facing it): a camera turned by 2° on
rings of 4, 6 and 8 cameras gains 4.3 to 22 times it."""

BROAD = 0.9
"""Leaving the first suspect out must bring the other views' mean part covered to at
least this, or the views disagree too much to blame one camera: a camera turned by 4°
leaves the others 0.89 covered and 0.99 without it, while masks whose holes (clothes the
colour of the room) carve every view leave them well below."""


@dataclass(frozen=True)
class ViewAgreement:
    """How one view agrees with the others on one frame."""

    camera: str
    pixels: int
    """The subject's pixels in the view's silhouette."""
    covered: float
    """The part of them the hull of every view, drawn back into the camera, covers."""
    gain: float
    """How much more of the other views' silhouettes the hull covers without this view
    (mean over them)."""


def _hull_of(masks: list[np.ndarray], cameras: Cameras, views: list[int], voxel_size: float):
    """The visual hull of the bool `masks` of `views` alone."""
    return visual_hull([masks[i].astype(np.uint8) * 255 for i in views], Cameras([cameras[i] for i in views]),
                       voxel_size)


def _covered(hull, camera, mask: np.ndarray) -> float:
    drawn = render_silhouette(camera, hull.vertices, hull.faces) > 0
    return float((drawn & mask).sum() / max(mask.sum(), 1))


def view_agreement(masks, cameras: Cameras, voxel_size: float = VOXEL_SIZE) -> list[ViewAgreement]:
    """Each view's :class:`ViewAgreement`: `masks` one per camera (non-zero = subject), at
    least three views with the subject in them. A hull per view left out: n + 1 hulls."""
    cameras = cameras if isinstance(cameras, Cameras) else Cameras(cameras)
    masks = [np.asarray(m) > 0 for m in masks]
    if len(masks) != len(cameras):
        raise HullError(f"{len(masks)} masks for {len(cameras)} cameras")
    seen = [i for i, m in enumerate(masks) if m.any()]
    if len(seen) < 3:
        raise HullError(f"the subject is in {len(seen)} views; telling which of them disagrees needs at least 3")
    whole = _hull_of(masks, cameras, seen, voxel_size)
    covered = {i: _covered(whole, cameras[i], masks[i]) for i in seen}
    gains = {}
    for left_out in seen:
        others = [i for i in seen if i != left_out]
        hull = _hull_of(masks, cameras, others, voxel_size)
        gains[left_out] = float(np.mean([_covered(hull, cameras[i], masks[i]) - covered[i] for i in others]))
    return [ViewAgreement(cam.name, int(masks[i].sum()), covered.get(i, 0.0), gains.get(i, 0.0))
            for i, cam in enumerate(cameras)]


def suspects(agreements: list[ViewAgreement]) -> list[str]:
    """The views that disagree with the others, most first: those whose absence gains the
    others more than :data:`SUSPECT_GAIN` and at least half what the first one's does, when
    the first gains :data:`STANDS_OUT` times the median of the rest (two cameras facing
    each other see mirror outlines, so both stand out when one of them is off); otherwise
    every view over :data:`SUSPECT_GAIN`, silhouettes that disagree broadly."""
    seen = [a for a in agreements if a.pixels]
    over = sorted((a for a in seen if a.gain > SUSPECT_GAIN), key=lambda a: a.gain, reverse=True)
    if not over:
        return []
    group = [a for a in over if a.gain >= over[0].gain / 2]
    rest = [a.gain for a in seen if a not in group]
    stands_out = not rest or over[0].gain >= STANDS_OUT * max(float(np.median(rest)), 0.0)
    return [a.camera for a in (group if stands_out else over)]


def describe_agreement(agreements: list[ViewAgreement], frame: int) -> str:
    """The table and verdict ``hullcap calib check`` prints."""
    lines = [f"frame {frame}: how much of each camera's silhouette the hull of every view covers, and how much "
             f"more of the others' it covers without that camera", "",
             f"{'camera':<12} {'subject px':>10} {'covered':>8} {'gain left out':>14}"]
    for a in agreements:
        lines.append(f"{a.camera:<12} {a.pixels:>10} {a.covered:>8.1%} {a.gain:>+14.1%}")
    lines.append("")
    suspected = suspects(agreements)
    seen = [a for a in agreements if a.pixels]
    mean = float(np.mean([a.covered for a in seen]))
    if suspected:  # the others as they would be covered without the first suspect
        first = next(a for a in seen if a.camera == suspected[0])
        mean_without = float(np.mean([a.covered for a in seen if a is not first])) + first.gain
    if len(suspected) > max(2, len(agreements) // 4) or (mean_without if suspected else mean) < BROAD:
        lines.append(f"the views disagree broadly (the hull of every view covers {mean:.0%} of their silhouettes): "
                     f"the silhouettes have holes or extra parts rather than one camera being off; the picture "
                     f"shows where (check the backgrounds)")
    elif not suspected:
        lines.append(f"the views agree: the hull of every view covers {mean:.0%} of their silhouettes on average")
    elif len(suspected) == 1:
        lines.append(f"camera {suspected[0]!r} disagrees with the others: check its calibration, or its background "
                     f"or silhouette (in the picture), or track without it (--leave-out {suspected[0]})")
    else:
        lines.append(f"cameras {' and '.join(map(repr, suspected))} disagree with the others alike (cameras facing "
                     f"each other see mirror outlines): check their calibrations, or their backgrounds or "
                     f"silhouettes (in the picture); checked again without the wrong one (--leave-out "
                     f"{suspected[0]}, then --leave-out {suspected[1]}), the others agree")
    return "\n".join(lines)


def draw_agreement(path, images, masks, cameras: Cameras, agreements: list[ViewAgreement],
                   voxel_size: float = VOXEL_SIZE, width: int = 320) -> None:
    """A sheet of every view at `width` pixels: the image dimmed, the silhouette green
    where the hull of every view covers it and red where other views carved it away,
    with the camera's figures; a suspected camera's name in red."""
    masks = [np.asarray(m) > 0 for m in masks]
    hull = _hull_of(masks, cameras, [i for i, m in enumerate(masks) if m.any()], voxel_size)
    suspected = set(suspects(agreements))
    tiles = []
    for cam, image, mask, agreement in zip(cameras, images, masks, agreements):
        drawn = render_silhouette(cam, hull.vertices, hull.faces) > 0
        tile = (np.zeros((cam.height, cam.width, 3), np.uint8) if image is None else image // 2).copy()
        tile[mask & drawn] = (0.4 * tile[mask & drawn] + (0, 150, 0)).astype(np.uint8)
        tile[mask & ~drawn] = (0, 0, 230)
        scale = width / cam.width
        tile = cv2.resize(tile, (width, round(cam.height * scale)), interpolation=cv2.INTER_AREA)
        colour = (60, 60, 255) if cam.name in suspected else (255, 255, 255)
        text = f"{cam.name}  covered {agreement.covered:.0%}  gain {agreement.gain:+.1%}"
        cv2.putText(tile, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv2.LINE_AA)
        tiles.append(tile)
    columns = min(4, len(tiles))
    height = max(t.shape[0] for t in tiles)
    tiles += [np.zeros_like(tiles[0])] * (-len(tiles) % columns)
    rows = [np.hstack([np.pad(t, ((0, height - t.shape[0]), (0, 0), (0, 0))) for t in tiles[r:r + columns]])
            for r in range(0, len(tiles), columns)]
    ok, data = cv2.imencode(".png", np.vstack(rows))
    atomic_write(Path(path), data.tobytes())
