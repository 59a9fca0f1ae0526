"""Fitting the body model to a target surface: robust hierarchical articulated ICP
(DESIGN.md §4–5), run by the engine (``crates/hullcap-icp``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hullcap import _engine
from hullcap.body import BodyModel
from hullcap.mesh import Surface

__all__ = ["PoseParameters", "FitResult", "fit", "make_target", "yaw_rotation"]


def yaw_rotation(angle: float) -> np.ndarray:
    """The (3, 3) rotation by `angle` radians about the vertical (z) axis."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class PoseParameters:
    """A pose of the body model: joint angles and the root's world placement.

    Attributes:
        theta: (D,) joint angles, radians, in ``model.dof_names`` order.
        root_rotation: (3, 3) world rotation of the body frame.
        root_translation: (3,) world position of the root joint (pelvis), metres.
    """

    theta: np.ndarray
    root_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    root_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def rest(cls, model: BodyModel, root_translation=None, yaw: float = 0.0) -> PoseParameters:
        """The rest pose, standing on the floor (or at `root_translation`), turned by
        `yaw` radians about z (0 = facing −y)."""
        R = yaw_rotation(yaw)
        t = np.array([0.0, 0.0, model.rest_root_height]) if root_translation is None else np.asarray(root_translation, float)
        return cls(np.zeros(model.n_dofs), R, t)


@dataclass(frozen=True)
class FitResult:
    """A fitted pose with the fit's statistics (see :func:`fit`)."""

    pose: PoseParameters
    iterations: int
    rounds: int
    energy: float
    inlier_fraction: float
    mean_residual: float
    sigma: float


DEFAULT_NORMAL_WEIGHT = 0.05
"""λ of the 6-D keys for fitting (metres per unit of normal difference). The paper's
balance (bounding-box diagonal / π ≈ 0.6 m for a person) lets normal differences of a
few degrees outweigh centimetres, and a visual hull's normals are that noisy: pairs then
lie several centimetres apart. With 5 cm, an arm still never pairs with the torso beside
it (opposite normals differ by 2, i.e. 10 cm) while pairs stay close in space."""


def make_target(surface: Surface, normal_weight: float | None = DEFAULT_NORMAL_WEIGHT) -> _engine.Target:
    """The target surface indexed for correspondences (reuse it for several fits);
    ``normal_weight=None`` is the paper's balance."""
    return _engine.Target(surface.vertices, surface.normals, normal_weight)


def default_model_points(model: BodyModel, count: int = 1500) -> np.ndarray:
    """About `count` model vertices spread over the mesh (every n-th vertex)."""
    n = len(model.vertices)
    return np.arange(0, n, max(1, n // count), dtype=np.int64)


def fit(model: BodyModel, target, initial: PoseParameters, *, model_points=None,
        residual: str = "point_to_point", solver: str = "lm", hierarchical: bool = True,
        polish: bool = True, max_distance: float = 0.15, max_angle_deg: float = 60.0,
        sigma_min: float = 0.004, iterations: int = 10, tolerance: float = 1e-3, rounds: int = 4,
        inlier_distance: float = 0.02, threads: int | None = None) -> FitResult:
    """Fit `model` to `target` from `initial` by robust articulated ICP.

    Args:
        model: the body model.
        target: a :class:`~hullcap.mesh.Surface` (its vertices and outward normals) or a
            target made by :func:`make_target`.
        initial: the starting pose (e.g. the previous frame's, or a prediction).
        model_points: indices of the model vertices that seek partners (default: about
            1 500 spread over the mesh).
        residual: ``"point_to_point"`` (the paper) or ``"point_to_plane"``.
        solver: ``"lm"`` (Levenberg–Marquardt) or ``"cg"`` (the paper's conjugate gradients).
        hierarchical: root, then the joint groups of the link model from the torso
            outwards, repeated until the energy settles (the paper); else all at once.
        polish: finish a hierarchical fit with one stage on all parameters.
        max_distance, max_angle_deg: correspondence gates (metres, degrees).
        sigma_min: lower bound of the robust scale σ (metres).
        iterations: most ICP iterations per stage; tolerance: relative energy change at
            which a stage (and the schedule) stops; rounds: most hierarchical passes.
        inlier_distance: a matched model point within this distance is an inlier.

    Returns:
        A :class:`FitResult`: the pose, iterations, rounds, final energy, inlier fraction,
        mean residual (metres) and σ.
    """
    if isinstance(target, Surface):
        target = make_target(target)
    pts = default_model_points(model) if model_points is None else np.asarray(model_points, np.int64)
    theta = np.asarray(initial.theta, float)
    if theta.shape != (model.n_dofs,):
        raise ValueError(f"initial.theta must have {model.n_dofs} angles, got shape {theta.shape}")
    groups = [list(g) for g in model.link_model.hierarchy]
    th, R, t, stats = _engine.fit(
        model._rig, target, pts.tolist(), theta.tolist(), np.asarray(initial.root_rotation, float),
        np.asarray(initial.root_translation, float), groups, residual=residual, solver=solver,
        max_distance=max_distance, max_angle=np.radians(max_angle_deg), sigma_min=sigma_min,
        iterations=iterations, tolerance=tolerance, rounds=rounds, hierarchical=hierarchical,
        polish=polish, inlier_distance=inlier_distance, threads=threads)
    return FitResult(PoseParameters(th, R, t), **stats)
