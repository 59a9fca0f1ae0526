"""Shared fixtures: seeded random clouds."""

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


def random_cloud(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) points in [-1, 1)^3 and (n, 3) random non-unit normals."""
    points = rng.uniform(-1.0, 1.0, (n, 3))
    normals = rng.normal(size=(n, 3))
    return points, normals
