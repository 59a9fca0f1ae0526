"""Regenerate hullcap's template body, ``data/body/template.npz``.

A standard adult (1.75 m) in the calibration T-pose, in the body frame of ``links.json``
(metres; x = the subject's left, y = back, z = up; origin 0.97 m above the floor on the
body's axis, 3.9 cm above the hip joints). Its proportions follow the segment lengths of
Drillis and Contini (1966) as fractions of the body height H, tabulated by Winter,
"Biomechanics and Motor Control of Human Movement" (4th ed., 2009, Fig. 4.1): hip joints
at 0.530 H, knees at 0.285 H, ankles at 0.039 H, hand 0.108 H and foot 0.152 H long
(``links.json`` places the joints).
The surface is a smooth union of tapered capsules and ellipsoids laid around the link
model, meshed by marching cubes on a 16 mm grid: closed, manifold, outward oriented, one
piece. Run from the repository root:

    .venv/bin/python data/body/make_template.py   (data/body -> python/hullcap/data/body)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hullcap._implicit import ellipsoid, field_mesh, round_cone, smooth_union
from hullcap._mesh import check_closed

VOXEL = 0.016
BLEND = 0.035  # fillet width where parts meet (m)


def _mirror(x):
    return np.asarray(x, float) * (-1.0, 1.0, 1.0)


def _parts():
    """(kind, parameters) of every primitive; the left limbs are mirrored to the right."""
    trunk = [
        ("ellipsoid", (0.0, 0.005, 0.33), (0.165, 0.105, 0.17)),  # chest
        ("ellipsoid", (0.0, 0.0, 0.14), (0.135, 0.095, 0.16)),  # abdomen
        ("ellipsoid", (0.0, 0.012, -0.03), (0.165, 0.105, 0.12)),  # hips and buttocks
        ("cone", (0.0, 0.0, 0.44), (0.0, 0.0, 0.60), 0.055, 0.05),  # neck
        ("ellipsoid", (0.0, -0.012, 0.675), (0.078, 0.098, 0.112)),  # head
        ("ellipsoid", (0.0, -0.085, 0.625), (0.012, 0.02, 0.028)),  # nose
    ]
    left = [
        ("cone", (0.06, 0.0, 0.45), (0.19, 0.0, 0.445), 0.065, 0.055),  # shoulder
        ("cone", (0.19, 0.0, 0.45), (0.46, 0.0, 0.45), 0.05, 0.038),  # upper arm
        ("cone", (0.46, 0.0, 0.45), (0.71, 0.0, 0.45), 0.039, 0.027),  # forearm
        ("ellipsoid", (0.815, -0.005, 0.45), (0.095, 0.048, 0.02)),  # hand, palm down
        ("ellipsoid", (0.76, -0.05, 0.45), (0.045, 0.014, 0.014)),  # thumb
        ("cone", (0.085, 0.0, -0.06), (0.125, 0.0, -0.47), 0.088, 0.055),  # thigh
        ("cone", (0.125, 0.0, -0.47), (0.15, 0.0, -0.88), 0.054, 0.034),  # shin
        ("ellipsoid", (0.128, 0.012, -0.62), (0.042, 0.05, 0.11)),  # calf
        ("ellipsoid", (0.155, -0.055, -0.935), (0.048, 0.135, 0.035)),  # foot
    ]
    right = []
    for kind, *p in left:
        if kind == "cone":
            right.append((kind, _mirror(p[0]), _mirror(p[1]), p[2], p[3]))
        else:
            right.append((kind, _mirror(p[0]), p[1]))
    return trunk + left + right


def body_field(points: np.ndarray) -> np.ndarray:
    """The template's signed distance stand-in at `points` (negative inside)."""
    values = None
    for kind, *p in _parts():
        d = round_cone(points, *p) if kind == "cone" else ellipsoid(points, *p)
        values = d if values is None else smooth_union(values, d, BLEND)
    return values


def make_template():
    """``(vertices, faces)`` of the template body, checked closed and sphere-like."""
    vertices, faces = field_mesh(body_field, (-0.95, -0.2, -0.99), (0.95, 0.15, 0.80), VOXEL)
    topo = check_closed(vertices, faces)
    if not (topo["closed"] and topo["euler"] == 2 and topo["components"] == 1 and topo["volume"] > 0):
        raise RuntimeError(f"template mesh is not a closed sphere-like surface: {topo}")
    return vertices, faces


if __name__ == "__main__":
    v, f = make_template()
    out = Path(__file__).with_name("template.npz")
    np.savez_compressed(out, vertices=v.astype(np.float64), faces=f.astype(np.int32))
    print(f"{out}: {len(v)} vertices, {len(f)} triangles, height {np.ptp(v[:, 2]):.3f} m, "
          f"{check_closed(v, f)}")
