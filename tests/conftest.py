"""Shared fixtures and helpers: seeded random clouds, a distorted camera, a small rendered sequence."""

import numpy as np
import pytest
from hullcap import Camera
from hullcap._cameras import ring
from hullcap._synth import synthesize


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


def random_cloud(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) points in [-1, 1)^3 and (n, 3) random non-unit normals."""
    points = rng.uniform(-1.0, 1.0, (n, 3))
    normals = rng.normal(size=(n, 3))
    return points, normals


def distorted_camera():
    base = ring(8)[1]
    return Camera("dist", 640, 480, base.K, [0.08, -0.04, 0.001, -0.002, 0.01], base.R, base.t)


@pytest.fixture(scope="session")
def sequence(tmp_path_factory):
    """A small rendered sequence: 4 cameras at 320×240, the first 42 frames of the demo."""
    out = tmp_path_factory.mktemp("seq") / "demo"
    cams = ring(4, radius=3.2, width=320, height_px=240, fov_deg=55)
    return synthesize(out, "demo", cams, subject="short", frames=42, show_progress=False)
