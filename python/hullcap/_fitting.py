"""Fitting the body model to a target surface: robust hierarchical articulated ICP
(docs/design.md §4–5), run by the engine (``crates/hullcap-icp``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hullcap import _engine
from hullcap._body import BodyModel
from hullcap._engine import FitOptions
from hullcap._mesh import Surface
from hullcap.errors import FitError

__all__ = ["FitOptions", "FitResult", "PoseParameters", "PosePrior", "angles_by_name", "fit", "make_target", "quality",
           "yaw_rotation"]


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
        root_translation: (3,) world position of the body frame's origin, metres.
    """

    theta: np.ndarray
    root_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    root_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def rest(cls, model: BodyModel, root_translation=None, yaw: float = 0.0) -> PoseParameters:
        """The rest pose, standing on the floor (or at `root_translation`), turned by
        `yaw` radians about z (0 = facing −y)."""
        R = yaw_rotation(yaw)
        t = np.array([0.0, 0.0, model.rest_root_height]) if root_translation is None \
            else np.asarray(root_translation, float)
        return cls(np.zeros(model.n_dofs), R, t)

    def carried(self, source: BodyModel, model: BodyModel) -> PoseParameters:
        """This pose of `source` as a pose of `model` (:func:`angles_by_name`)."""
        theta = angles_by_name(self.theta, source.dof_names, model.dof_names)
        return PoseParameters(theta, self.root_rotation, self.root_translation)


def angles_by_name(theta, names, to_names) -> np.ndarray:
    """Joint angles (…, D) in the DOF order `names`, in the order `to_names` instead, DOF
    by DOF name; a DOF `names` lacks (a wrist, :meth:`BodyModel.with_wrists`) is 0."""
    theta = np.asarray(theta, float)
    index = {name: i for i, name in enumerate(names)}
    out = np.zeros(theta.shape[:-1] + (len(to_names),))
    for j, name in enumerate(to_names):
        if name in index:
            out[..., j] = theta[..., index[name]]
    return out


@dataclass(frozen=True)
class FitResult:
    """A fitted pose with the fit's statistics (see :func:`fit`).

    Attributes:
        pose: the fitted pose.
        iterations, rounds: ICP iterations (correspondence updates) and hierarchical passes.
        energy: the final robust energy.
        inlier_fraction: model points with a hull partner within ``inlier_distance``.
        mean_residual: mean model→hull pair distance (metres).
        coverage: hull samples with a model partner within ``inlier_distance``: how much
            of the hull the model explains.
        mean_reverse_residual: mean hull→model pair distance (metres).
        sigma: the final robust scale σ (metres).
        link_counts: (L, 4) int per link: its model points, those that are inliers, the
            hull samples nearest to its vertices, those the model covers.
    """

    pose: PoseParameters
    iterations: int
    rounds: int
    energy: float
    inlier_fraction: float
    mean_residual: float
    coverage: float
    mean_reverse_residual: float
    sigma: float
    link_counts: np.ndarray


@dataclass(frozen=True)
class PosePrior:
    """A Gaussian prior on a fit's joint angles, added to its energy (the engine's
    ``PosePrior``): ½·κ·Σ_d ((θ_d − mean_d) / sigma_d)² with κ = N·prior_distance² for N
    pairs, so that one `sigma` costs as much as every pair lying `prior_distance` further
    off.

    Attributes:
        mean: (D,) joint angles, radians.
        sigma: (D,) radians, positive; ``inf`` leaves that DOF free.
        prior_distance: metres.
    """

    mean: np.ndarray
    sigma: np.ndarray
    prior_distance: float

    def engine(self) -> tuple[list[float], list[float], float]:
        return (np.asarray(self.mean, float).tolist(), np.asarray(self.sigma, float).tolist(),
                float(self.prior_distance))


def quality(stats) -> float:
    """How much of the hull a fit explains both ways, ½(inlier fraction + coverage), of a
    :class:`FitResult` or of the engine's statistics (a dict); 1 = every model point and
    every hull sample within the inlier distance of a partner."""
    get = (lambda k: stats[k]) if isinstance(stats, dict) else (lambda k: getattr(stats, k))
    return 0.5 * (get("inlier_fraction") + get("coverage"))


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


def fit(model: BodyModel, target, initial: PoseParameters, options: FitOptions | None = None,
        model_points=None, prior: PosePrior | None = None, threads: int | None = None) -> FitResult:
    """Fit `model` to `target` from `initial` by robust articulated ICP.

    Args:
        model: the body model.
        target: a :class:`~hullcap._mesh.Surface` (its vertices and outward normals) or a
            target made by :func:`make_target`.
        initial: the starting pose (e.g. the previous frame's, or a prediction).
        options: a :class:`FitOptions` (residual, solver, gates, robust scale, two-sided
            weight, schedule); default ``FitOptions()``.
        model_points: indices of the model vertices that seek partners (default: about
            ``options.model_points`` spread over the mesh).
        prior: a :class:`PosePrior` on the joint angles (default: none, the paper's
            energy).
        threads: the engine's threads for this fit when `options` leaves them open (its
            ``threads`` is ``None``), as :func:`hullcap._threads.over_fits` shares them
            out; the result is the same on any number.

    Returns:
        A :class:`FitResult`.
    """
    if isinstance(target, Surface):
        target = make_target(target)
    options = FitOptions() if options is None else options
    if threads is not None and options.threads is None:
        options = options.replace(threads=threads)
    theta = np.asarray(initial.theta, float)
    if theta.shape != (model.n_dofs,):
        raise FitError(f"initial.theta must have {model.n_dofs} angles, got shape {theta.shape}")
    points = None if model_points is None else np.asarray(model_points, np.int64).tolist()
    groups = [list(g) for g in model.link_model.hierarchy]
    (th, R, t), stats = _engine.fit(model._rig, target, theta.tolist(), np.asarray(initial.root_rotation, float),
                                    np.asarray(initial.root_translation, float), groups, options, points,
                                    None if prior is None else prior.engine())
    return FitResult(PoseParameters(th, R, t), **stats)
