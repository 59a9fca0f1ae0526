"""Type stubs of the Rust extension module ``hullcap._engine``."""

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike3 = npt.ArrayLike
"""Anything NumPy turns into an (N, 3) array of real numbers."""

class NormalKDTree:
    """Exact nearest neighbours among target points with normals (the paper's §3.2).

    Each target point ``r`` with unit normal ``n`` is the 6-D key
    ``(x, y, z, λ·nx, λ·ny, λ·nz)``; a query (a point with its normal) finds the key
    nearest in that space, so a point whose surface faces another way counts as far even
    when it is close. The pair is then rejected (index -1) when the points are more than
    ``max_distance`` apart in space or their normals more than ``max_angle`` apart; a
    rejected nearest key is never replaced by a farther one.

    Args:
        points: (N, 3) target points, metres. Any real dtype; copied once if not
            C-contiguous float64.
        normals: (N, 3) target normals, any non-zero length (they are normalised).
        normal_weight: λ, metres per unit of normal difference. Default: the paper's
            balance, λ·π = the diagonal of the points' bounding box.
        leaf_size: most points per leaf bucket.

    Raises:
        ValueError: wrong shape or dtype, NaN/inf, a zero-length normal, no points,
            ``normal_weight <= 0``, ``leaf_size < 1``.
    """

    def __init__(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        normal_weight: float | None = None,
        leaf_size: int = 16,
    ) -> None: ...
    def query(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        max_distance: float = ...,
        max_angle: float = ...,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """The nearest key of each query.

        Args:
            points: (M, 3) query points, metres.
            normals: (M, 3) query normals, any non-zero length.
            max_distance: largest distance in space (metres) of an accepted pair.
            max_angle: largest angle between normals (radians) of an accepted pair.
            threads: worker threads; ``None`` = all cores.

        Returns:
            ``(indices, distances)``: (M,) int64 indices into the tree's points (-1 where
            gated out) and (M,) float64 6-D distances ``sqrt(|Δp|² + λ²|Δn|²)`` (inf
            where gated out).
        """
    def query_k(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        k: int,
        max_distance: float = ...,
        max_angle: float = ...,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """The ``k`` nearest keys of each query, nearest first: (M, k) indices and
        distances; gated pairs, and slots past the tree's size, are -1 / inf in place."""
    @property
    def normal_weight(self) -> float:
        """λ, metres per unit of normal difference."""
    @property
    def leaf_size(self) -> int:
        """Most points per leaf bucket."""
    def __len__(self) -> int: ...
