"""Closed meshes of implicit surfaces: unions of capsules, by marching cubes.

The seed of the template body (DESIGN.md §8: a smooth closed mesh around the link model);
tests and benchmarks use it to make bodies with known geometry.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from skimage.measure import marching_cubes

Capsule = tuple[Sequence[float], Sequence[float], float]
"""A capsule: segment start, segment end (metres) and radius."""


def capsule_union_mesh(capsules: Sequence[Capsule], voxel: float = 0.006, pad: float = 0.03):
    """A closed triangle mesh of the union of `capsules`, sampled on a `voxel` grid.

    Returns:
        ``(vertices, faces)``: (V, 3) float64 metres and (T, 3) int64 indices, outward
        oriented as scikit-image's marching cubes makes them for a signed distance field.
    """
    if not capsules:
        raise ValueError("capsule_union_mesh needs at least one capsule")
    if not voxel > 0:
        raise ValueError(f"voxel must be positive, got {voxel}")
    ends = np.array([c[0] for c in capsules] + [c[1] for c in capsules], float)
    reach = max(c[2] for c in capsules) + pad
    lo, hi = ends.min(0) - reach, ends.max(0) + reach
    axes = [np.arange(lo[d], hi[d], voxel) for d in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    field = np.full(grid.shape[:3], np.inf)
    for a, b, radius in capsules:
        a, b = np.asarray(a, float), np.asarray(b, float)
        t = np.clip(((grid - a) @ (b - a)) / max((b - a) @ (b - a), 1e-300), 0, 1)
        field = np.minimum(field, np.linalg.norm(grid - (a + t[..., None] * (b - a)), axis=-1) - radius)
    vertices, faces, _, _ = marching_cubes(field, 0.0, spacing=(voxel,) * 3)
    return vertices + lo, faces.astype(np.int64)
