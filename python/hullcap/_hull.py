"""The visual hull (docs/design.md §7): coarse-to-fine voxel carving, then the surface of
the smoothed occupancy.

A voxel is carved when, in some view, its whole footprint lies outside the silhouette.
The footprint of a cube of side h centred at X is inside the disc of radius
f·(√3/2·h)/z around X's projection, so comparing that radius with the mask's distance
transform at the projection decides conservatively: outside by more than the radius →
the voxel is out; inside by more than it in every view → the voxel is in; otherwise it is
on the boundary and is split in eight. At the target size the voxel's centre decides.
Views whose image does not contain a point cannot carve it (a point must be in the
image of `min_views` views to be kept), and a camera whose mask is
empty while others see the subject is reported and left out.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cv2
import numpy as np

from hullcap._cameras import Cameras, capture_volume, check_bounds, format_bounds
from hullcap._engine import carve, doubtful_points, gaussian_blur, isosurface
from hullcap._mesh import Surface
from hullcap._options import POSITIVE
from hullcap._silhouette import distance_outside, signed_distance
from hullcap._threads import over_views
from hullcap.errors import HullError

__all__ = ["VOXEL_SIZE", "visual_hull", "doubtful_vertices", "HullReport"]

VOXEL_SIZE = 0.01
"""The hull's voxel size by default, metres."""


@dataclass
class HullReport:
    """How a hull was made: the views skipped and why, voxel counts, stage times (s)."""

    skipped: dict[str, str] = field(default_factory=dict)
    voxels_tested: int = 0
    carve_seconds: float = 0.0
    mesh_seconds: float = 0.0


def _boxed_signed_distance(mask, outside_only: bool = False) -> tuple:
    """A mask's signed distance to its edge (pixels, positive inside) as the engine's
    carving takes it: ``(values, x0, y0, width, height)``, the distance transforms run
    only in the mask's bounding box grown by a pixel all round, at column `x0` and row `y0`
    of the `width` × `height` image. They are exact there (the mask and the ring of
    background around it lie inside). Beyond the box the engine reads minus the Chebyshev
    distance to the box, which never exceeds the distance to the mask: carving then prunes
    a little less far from the person, and decides by the sign alone at the finest level,
    where the sign is exact. A person fills a tenth of a frame, so this is several times
    cheaper than the whole image's transforms; an empty mask is an empty box. With
    `outside_only` the values inside the mask are 0, not the distance to its edge: all a
    prior is asked is whether a point lies outside it by more than a cell's reach."""
    m = np.asarray(mask)
    m = m.view(np.uint8) if m.dtype == bool else m if m.dtype == np.uint8 else (m > 0).astype(np.uint8)
    H, W = m.shape
    x, y, w, h = cv2.boundingRect(m)
    if w == 0:
        return np.zeros((0, 0), np.float32), 0, 0, W, H
    x0, y0, x1, y1 = max(0, x - 1), max(0, y - 1), min(W, x + w + 1), min(H, y + h + 1)
    box = m[y0:y1, x0:x1]
    return np.negative(distance_outside(box)) if outside_only else signed_distance(box), x0, y0, W, H


def _carving_view(camera, mask, prior=None) -> tuple:
    """One camera's mask as the engine's carving takes it (`carve`, `classify_cells`): the
    camera, its larger focal length, and the signed distance to the silhouette's edge
    and to the prior's (None without one)."""
    focal = float(max(camera.K[0, 0], camera.K[1, 1]))
    prior = None if prior is None else _boxed_signed_distance(prior, outside_only=True)
    return camera.K, camera.dist, camera.R, camera.t, focal, _boxed_signed_distance(mask), prior


def visual_hull(masks, cameras: Cameras, voxel_size: float = VOXEL_SIZE, volume=None,
                report: HullReport | None = None, smooth: float = 0.7,
                min_views: int = 3, tolerance: int = 0, priors=None) -> Surface:
    """The visual hull of silhouettes as a closed, outward-oriented surface.

    Args:
        masks: one (H, W) uint8 mask per camera, in the cameras' order (non-zero = subject).
        cameras: the calibration: :class:`Cameras`, or a slice or list of some of them.
        voxel_size: the finest voxel (metres).
        volume: ``((x0, y0, z0), (x1, y1, z1))`` capture volume; default: the region every
            camera sees (:func:`capture_volume`).
        report: filled with the views skipped, voxel counts and stage times.
        smooth: Gaussian smoothing (in voxels) of the occupancy before marching cubes; it
            turns voxel stairs into a smooth surface with useful normals (0 = none).
        min_views: a voxel is kept only if at least this many views have it in their
            image (views that do not see a point cannot carve it, so a point that few
            cameras see is barely constrained).
        tolerance: how many views may leave a voxel out and be overruled by all the
            others: a part of the body that one silhouette misses (clothes the colour of
            the wall behind) would otherwise be cut from the hull as a tunnel through it.
            It applies only where at least four views agree.
        priors: one (H, W) mask per camera of where the body is expected and the view
            may have missed it (the tracker's: the predicted model's silhouette, dilated
            by its uncertainty, less what the view's guided mask saw as background for
            sure): a voxel kept against a view must lie inside every view's prior.
            Without priors the tolerance holds everywhere, and the hull grows by what
            one view alone carved off; each view left out (an empty mask) then counts
            against it, since the phantom volume a missing view no longer carves grows
            with every view overruled as well.

    Returns:
        A :class:`~hullcap._mesh.Surface`: vertices (metres), faces, unit outward normals.

    Raises:
        ValueError: a mask of the wrong shape or count, every mask empty, or a hull that
            is empty (silhouettes that no point in the volume satisfies).
    """
    report = report if report is not None else HullReport()
    cameras = cameras if isinstance(cameras, Cameras) else Cameras(cameras)  # a list of some of them, say
    if len(masks) != len(cameras):
        raise HullError(f"{len(masks)} masks for {len(cameras)} cameras")
    POSITIVE.check("voxel_size", voxel_size, error=HullError)
    if priors is not None and len(priors) != len(cameras):
        raise HullError(f"{len(priors)} priors for {len(cameras)} cameras")
    if tolerance < 0:
        raise HullError(f"tolerance must be >= 0, got {tolerance}")
    seen = []
    for i, (cam, m) in enumerate(zip(cameras, masks)):
        m = np.asarray(m)
        if m.shape != (cam.height, cam.width):
            raise HullError(f"camera {cam.name!r}: mask of shape {m.shape}, the camera's images are "
                            f"{cam.width}×{cam.height}: a mask is a ({cam.height}, {cam.width}) array")
        if not m.any():
            report.skipped[cam.name] = "empty mask"
            continue
        prior = None if priors is None else np.asarray(priors[i])
        if prior is not None and prior.shape != m.shape:
            raise HullError(f"camera {cam.name!r}: prior of shape {prior.shape}, the mask's {m.shape}")
        seen.append((cam, m, prior))
    views = over_views(lambda view: _carving_view(*view), seen)
    if not views:
        raise HullError("every mask is empty: nothing to carve")
    if report.skipped:
        warnings.warn(f"visual hull: views left out: {report.skipped}", stacklevel=2)
    lo, hi = check_bounds(volume) if volume is not None else capture_volume(cameras)
    side = float(np.max(hi - lo)) / voxel_size
    if side > MAX_VOXELS_A_SIDE:
        raise HullError(f"voxel_size {voxel_size} m gives {side:.3g} voxels along the capture volume "
                        f"{format_bounds((lo, hi))}, more than {MAX_VOXELS_A_SIDE} (a size in metres?)")
    t0 = time.perf_counter()
    tolerance = min(tolerance, max(0, len(views) - 4))
    if priors is None:
        # A view left out no longer carves what it alone shared with one other view, so
        # without priors to bound it each view missing already overrules one.
        tolerance = max(0, tolerance - (len(cameras) - len(views)))
    origin, occupancy = _carve(views, lo, hi, voxel_size, report, min_views, tolerance)
    report.carve_seconds = time.perf_counter() - t0
    if not occupancy.any():
        raise HullError(f"the visual hull is empty: the silhouettes agree on no point of the capture volume "
                        f"{format_bounds((lo, hi))} (is the person inside it? give volume= / --volume)")
    t0 = time.perf_counter()
    surface = _mesh(occupancy, origin, voxel_size, smooth)
    report.mesh_seconds = time.perf_counter() - t0
    return surface


def doubtful_vertices(surface: Surface, masks, unsure, cameras: Cameras, reach: float = 0.02,
                      views: int = 3) -> np.ndarray:
    """(V,) bool: the vertices of a hull whose place the silhouettes do not vouch for. The
    point `reach` metres outside a vertex along its normal is what cut the hull there;
    the vertex is doubtful when at least `views` views leave that point out and none of
    them was sure it saw the background there (`unsure`: one (H, W) bool image per
    camera, true where its mask's verdict of background was not sure, or None for a view
    sure everywhere). Clothes the colour of the floor that several views miss together
    carve the hull inside the body where no tolerance can keep it (design.md §7); a view
    that sees the room beside a limb is sure of it, and the limb's surface stays. Views
    with an empty mask (left out of the hull) and points outside a view's image count
    for nothing."""
    if not len(masks) == len(unsure) == len(cameras):
        raise HullError(f"{len(masks)} masks, {len(unsure)} unsure images for {len(cameras)} cameras")
    outside = np.asarray(surface.vertices) + reach * np.asarray(surface.normals)
    cutting = [(cam.K, cam.dist, cam.R, cam.t, mask, doubt)
               for cam, mask, doubt in zip(cameras, masks, unsure) if np.any(mask)]
    return doubtful_points(outside, cutting, views)


MAX_VOXELS_A_SIDE = 4096
"""The most voxels along the capture volume's longest side (1 mm over 4 m): the carving's
coarsest cells and the kept box's finest voxels grow with it, a billion voxels before it."""


def _carve(views, lo, hi, h, report, min_views, tolerance):
    """``(origin, occupancy)`` carved from `views` (`_carving_view`s): a boolean grid of
    the finest voxels holding the hull, with at least two empty voxels all round, and
    the world position of its voxel (0, 0, 0)'s corner. Up to `tolerance` views may
    leave a voxel out (inside every view's prior, where the views have priors). The
    coarsest cells are 2^levels voxels on a side, about 24 of them across the volume's
    longest side, at most 32 voxels (5 levels)."""
    n_fine = np.maximum(np.ceil((hi - lo) / h).astype(int), 1)
    levels = min(5, max(0, int(np.ceil(np.log2(max(n_fine.max() / 24, 1))))))
    first, occupancy, tested = carve(lo, h, n_fine.tolist(), levels, views, tolerance, min(min_views, len(views)))
    report.voxels_tested += tested
    return lo + np.asarray(first) * h, occupancy


def _mesh(occupancy, origin, h, smooth) -> Surface:
    field = gaussian_blur(occupancy, smooth) if smooth > 0 else occupancy.astype(np.float32)
    # The field is high inside: the engine winds the triangles counter-clockwise seen
    # from outside and its normals point outwards.
    vertices, faces, normals = isosurface(field, 0.5)
    return Surface(vertices * h + (origin + 0.5 * h), faces, normals)
