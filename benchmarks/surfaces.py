"""Human-sized test surfaces for the benchmarks, made here (no downloads).

Until the template body exists, a "person" is a union of capsules (legs, torso, arms in a
T-pose, head) about 1.75 m tall; points are sampled uniformly over the union's outer
surface (points buried inside another capsule are dropped) with outward normals.
"""

from __future__ import annotations

import numpy as np

# (start, end, radius) in metres, z up, subject facing -y.
CAPSULES = [
    ((-0.10, 0.0, 0.08), (-0.10, 0.0, 0.88), 0.07),  # legs
    ((0.10, 0.0, 0.08), (0.10, 0.0, 0.88), 0.07),
    ((0.0, 0.0, 0.92), (0.0, 0.0, 1.38), 0.15),  # torso
    ((-0.20, 0.0, 1.40), (-0.85, 0.0, 1.40), 0.045),  # arms, T-pose
    ((0.20, 0.0, 1.40), (0.85, 0.0, 1.40), 0.045),
    ((0.0, 0.0, 1.62), (0.0, 0.0, 1.64), 0.10),  # head
]


def _sample_capsule(a, b, r, n, rng):
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = b - a
    length = np.linalg.norm(axis)
    u = axis / length
    side_area, cap_area = 2 * np.pi * r * length, 4 * np.pi * r**2
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    on_side = rng.random(n) < side_area / (side_area + cap_area)
    # Side: directions perpendicular to the axis at a uniform position along it.
    d_side = d - (d @ u)[:, None] * u
    d_side /= np.linalg.norm(d_side, axis=1, keepdims=True)
    centre_side = a + rng.random(n)[:, None] * axis
    # Caps: a full sphere split between the two ends by hemisphere.
    centre_cap = np.where((d @ u)[:, None] > 0, b, a)
    normals = np.where(on_side[:, None], d_side, d)
    points = np.where(on_side[:, None], centre_side, centre_cap) + r * normals
    return points, normals


def _inside(points, capsule, margin=1e-9):
    a, b, r = (np.asarray(c, float) for c in capsule)
    ab = b - a
    t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1) < r - margin


def human_surface(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) points on a capsule person and their (n, 3) unit outward normals."""
    rng = np.random.default_rng(seed)
    areas = np.array([2 * np.pi * r * np.linalg.norm(np.subtract(b, a)) + 4 * np.pi * r**2 for a, b, r in CAPSULES])
    points, normals = [], []
    have = 0
    while have < n:
        counts = rng.multinomial(2 * (n - have) + 100, areas / areas.sum())
        for i, (capsule, count) in enumerate(zip(CAPSULES, counts)):
            p, nrm = _sample_capsule(*capsule, count, rng)
            keep = np.ones(len(p), bool)
            for j, other in enumerate(CAPSULES):
                if j != i:
                    keep &= ~_inside(p, other)
            points.append(p[keep])
            normals.append(nrm[keep])
        have = sum(len(p) for p in points)
    order = rng.permutation(have)[:n]
    return np.vstack(points)[order], np.vstack(normals)[order]


def noisy_queries(n: int, seed: int, noise: float = 0.01, normal_noise: float = 0.15):
    """Queries as ICP makes them: surface points off by `noise` metres, normals tilted."""
    rng = np.random.default_rng(seed)
    points, normals = human_surface(n, seed)
    points = points + rng.normal(scale=noise, size=points.shape)
    normals = normals + rng.normal(scale=normal_noise, size=normals.shape)
    return points, normals / np.linalg.norm(normals, axis=1, keepdims=True)
