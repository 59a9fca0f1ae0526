"""Closed meshes of implicit surfaces: smooth unions of tapered capsules and ellipsoids.

The template body (``data/body/make_template.py``) is such a surface around the link model,
and tests and benchmarks use plain capsule unions to make bodies with known geometry. Each
primitive is a signed distance (or a close stand-in: negative inside, zero on the surface,
about the true distance near it) evaluated on a voxel grid; the engine's marching cubes
(`isosurface`) turns the zero set of their union into a closed triangle mesh.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hullcap._engine import isosurface
from hullcap.errors import ModelError

Capsule = tuple[Sequence[float], Sequence[float], float]
"""A capsule: segment start, segment end (metres) and radius."""


def round_cone(points: np.ndarray, a, b, radius_a: float, radius_b: float) -> np.ndarray:
    """Distance-like field of a capsule whose radius tapers linearly from `a` to `b`."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    t = np.clip(((points - a) @ ab) / max(ab @ ab, 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[..., None] * ab), axis=-1) - (radius_a + t * (radius_b - radius_a))


def ellipsoid(points: np.ndarray, centre, radii) -> np.ndarray:
    """Distance-like field of an axis-aligned ellipsoid (exact on the surface, scaled by
    the smallest radius elsewhere)."""
    radii = np.asarray(radii, float)
    scaled = np.linalg.norm((points - np.asarray(centre, float)) / radii, axis=-1)
    return (scaled - 1.0) * radii.min()


def smooth_union(d1: np.ndarray, d2: np.ndarray, blend: float) -> np.ndarray:
    """The polynomial smooth minimum: the union of two shapes with a fillet about `blend`
    metres wide where they meet (plain minimum for ``blend = 0``)."""
    if blend <= 0:
        return np.minimum(d1, d2)
    h = np.clip(0.5 + 0.5 * (d2 - d1) / blend, 0.0, 1.0)
    return d2 + (d1 - d2) * h - blend * h * (1.0 - h)


def field_mesh(field, lo, hi, voxel: float):
    """A closed mesh of the zero set of ``field(points)`` over the box [lo, hi].

    `field` maps a (..., 3) array of points to their (...) field values, negative inside.
    The box is padded by two voxels so the surface never touches its faces.

    Returns:
        ``(vertices, faces)``: (V, 3) float64 metres and (T, 3) int64 indices, outward
        oriented (counter-clockwise seen from outside).
    """
    if not voxel > 0:
        raise ModelError(f"voxel must be positive, got {voxel}")
    lo, hi = np.asarray(lo, float) - 2 * voxel, np.asarray(hi, float) + 2 * voxel
    axes = [np.arange(lo[d], hi[d] + voxel, voxel) for d in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    values = field(grid)
    # The engine winds triangles counter-clockwise seen from the lower values: with the
    # field negated (high inside), from outside.
    vertices, faces, _ = isosurface(-values, 0.0)
    return vertices * voxel + lo, faces


def capsule_union_mesh(capsules: Sequence[Capsule], voxel: float = 0.006, pad: float = 0.03):
    """A closed triangle mesh of the union of `capsules`, sampled on a `voxel` grid.

    Returns:
        ``(vertices, faces)`` as :func:`field_mesh` gives them.
    """
    if not capsules:
        raise ModelError("capsule_union_mesh needs at least one capsule")
    ends = np.array([c[0] for c in capsules] + [c[1] for c in capsules], float)
    reach = max(c[2] for c in capsules) + pad

    def field(points):
        values = np.full(points.shape[:-1], np.inf)
        for a, b, radius in capsules:
            values = np.minimum(values, round_cone(points, a, b, radius, radius))
        return values

    return field_mesh(field, ends.min(0) - reach, ends.max(0) + reach, voxel)
