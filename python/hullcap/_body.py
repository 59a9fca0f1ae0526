"""The articulated deformable body model (docs/design.md §1–2): link model, rest mesh, skin
weights, posing and its derivatives.

``BodyModel.template()`` is the standard adult of ``data/body/`` (made by
``data/body/make_template.py``). The model is immutable: scaling, re-skinning and the
rigid variant return new models.
"""

from __future__ import annotations

import functools
import io
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from hullcap._engine import Rig, skin_weights
from hullcap._files import atomic_write, read_npz
from hullcap._links import DATA, LinkModel
from hullcap._mesh import is_closed, vertex_normals
from hullcap._shape import ShapeBasis
from hullcap.errors import ModelError

__all__ = ["BodyModel", "Pose", "ROOT_DOF_NAMES"]

ROOT_DOF_NAMES = ("root_tx", "root_ty", "root_tz", "root_rx", "root_ry", "root_rz")
"""The root's six DOF as the Jacobian orders them: translation, then rotation
(R ← exp([ω]×)·R, ω in the world frame)."""

DEFAULT_B = 40.0
"""Skin-weight decay per metre of geodesic distance: weights fall by e every 2.5 cm, so
bends blend over a few centimetres around each joint."""
DEFAULT_K = 4


@dataclass(frozen=True)
class Pose:
    """A posed body, world frame (metres).

    Attributes:
        vertices: (V, 3) deformed mesh vertices.
        normals: (V, 3) their unit normals.
        joints: (J, 3) joint positions, in ``model.joint_names`` order.
        link_rotations: (L, 3, 3) rotation of each link's frame.
        link_positions: (L, 3) each link's joint centre.
    """

    vertices: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    link_rotations: np.ndarray
    link_positions: np.ndarray


class BodyModel:
    """A link model with a rest mesh around it and its skin weights.

    Args:
        links: the link model.
        vertices: (V, 3) rest mesh, body frame (metres), in the link model's rest pose.
        faces: (T, 3) triangles, counter-clockwise seen from outside.
        skin: ``(index (V, K) int, weight (V, K) float)`` precomputed weights; computed by
            :func:`hullcap.skin_weights` when omitted.
        b: skin-weight decay per metre (see ``DEFAULT_B``); k: weights kept per vertex
            (1 = the rigid segment model).
    """

    def __init__(self, links: LinkModel, vertices, faces, skin=None, b: float = DEFAULT_B,
                 k: int = DEFAULT_K):
        self._links = links
        self._vertices = _array(vertices, "vertices", np.float64, (-1, 3))
        self._faces = _array(faces, "faces", np.int64, (-1, 3))
        if self._faces.size and (self._faces.min() < 0 or self._faces.max() >= len(self._vertices)):
            raise ModelError(f"faces refer to vertices outside 0..{len(self._vertices) - 1}")
        self._normals = vertex_normals(self._vertices, self._faces)
        self._b, self._k = float(b), int(k)
        if skin is None:
            segments, groups = links.all_segments()
            skin = skin_weights(self._vertices, self._faces, segments, b=b, k=k, groups=groups)
        index = _array(skin[0], "skin index", np.int64, (len(self._vertices), -1))
        weight = _array(skin[1], "skin weight", np.float64, index.shape)
        self._skin = (index, weight)
        self._rig = Rig(links.parents.tolist(), links.origins, links.dof_links.tolist(),
                        links.dof_axes, links.dof_limits, self._vertices, self._normals,
                        index, weight)

    # -- construction -------------------------------------------------------------------

    @classmethod
    def template(cls, b: float = DEFAULT_B, k: int = DEFAULT_K) -> BodyModel:
        """The standard adult (1.75 m, T-pose) with the standard 29-DOF link model."""
        return _template(float(b), int(k))

    def rigid(self) -> BodyModel:
        """The rigid segment model: each vertex bound wholly to one link (the paper's
        comparison)."""
        return BodyModel(self._links, self._vertices, self._faces, b=self._b, k=1)

    def reskinned(self, b: float | None = None, k: int | None = None) -> BodyModel:
        """The same mesh with its skin weights computed afresh."""
        return BodyModel(self._links, self._vertices, self._faces,
                         b=self._b if b is None else b, k=self._k if k is None else k)

    def with_dof_limits(self, limits) -> BodyModel:
        """The same mesh and skin weights with the joint limits `limits` ((D, 2) radians,
        in ``dof_names`` order)."""
        limits = _array(limits, "limits", np.float64, (self.n_dofs, 2))
        return BodyModel(replace(self._links, dof_limits=limits), self._vertices, self._faces, skin=self._skin,
                         b=self._b, k=self._k)

    def with_wrists(self) -> BodyModel:
        """The same mesh with hands that turn at the wrists (:meth:`LinkModel.with_wrists`),
        skinned afresh; this model when its link model has no wrist to add."""
        links = self._links.with_wrists()
        return self if links is self._links else BodyModel(links, self._vertices, self._faces, b=self._b, k=self._k)

    def scaled(self, lengths: dict | None = None, girths: dict | None = None) -> BodyModel:
        """The body with per-segment proportions: link j stretched by ``lengths[name]``
        along its segment and ``girths[name]`` across it, about its joint centre; the
        joints below it move with it. Vertices follow their links by their skin weights;
        the weights are kept (call :meth:`reskinned` to recompute them)."""
        return self.shaped(*ShapeBasis.scales(self._links, lengths, girths))

    def shaped(self, basis: ShapeBasis, shape) -> BodyModel:
        """The body at shape vector `shape` of `basis` (:mod:`hullcap._shape`): joint
        centres, link segments, sites and vertices moved by the engine's linear shape
        model. The skin weights are kept (call :meth:`reskinned` to recompute them)."""
        shape = _array(shape, "shape", np.float64, (len(basis),)).tolist()
        engine = basis.engine(self)
        links = self._links
        origins, vertices = engine.rest(shape)
        origins = _root_kept_between_hips(links, origins)

        def move(points, owners):
            flat = np.asarray(points, float).reshape(-1, 3)
            return engine.map_points(shape, np.broadcast_to(owners, points.shape[:-1]).ravel().tolist(),
                                     flat).reshape(points.shape)

        # A link's joint is the centre it turns about; a site moves with its link's surface.
        joint_points = move(links.joint_points, links.joint_links)
        for i, name in enumerate(links.joint_names):
            if name in links.joints:
                joint_points[i] = origins[links.joints.index(name)]
        moved = replace(links, origins=origins, joint_points=joint_points,
                        segments=move(links.segments, np.arange(len(links.names))[:, None]),
                        structure_segments=move(links.structure_segments, links.structure_links[:, None]))
        return BodyModel(moved, vertices, self._faces, skin=self._skin, b=self._b, k=self._k)

    # -- what it is ---------------------------------------------------------------------

    @property
    def link_model(self) -> LinkModel:
        return self._links

    @property
    def vertices(self) -> np.ndarray:
        """(V, 3) rest vertices, body frame (a copy)."""
        return self._vertices.copy()

    @property
    def normals(self) -> np.ndarray:
        """(V, 3) rest unit normals (a copy)."""
        return self._normals.copy()

    @property
    def faces(self) -> np.ndarray:
        """(T, 3) int64 triangles (a copy)."""
        return self._faces.copy()

    @functools.cached_property
    def closed(self) -> bool:
        """Whether the mesh bounds a solid (:func:`~hullcap._mesh.is_closed`), as the
        template's does: its silhouettes are then drawn from half its triangles."""
        return is_closed(self._faces)

    @property
    def links(self) -> np.ndarray:
        """(L + S, 2, 3) joint and structure link segments: what `skin_weights` takes."""
        return self._links.all_segments()[0]

    @property
    def link_groups(self) -> list[int]:
        """For each entry of :attr:`links`, the joint link (bone) it moves with."""
        return self._links.all_segments()[1]

    @property
    def skin(self) -> tuple[np.ndarray, np.ndarray]:
        """``(index (V, K) int64, weight (V, K) float64)``: the K largest weights of each
        vertex and the bones they belong to (copies)."""
        return self._skin[0].copy(), self._skin[1].copy()

    @property
    def skin_parameters(self) -> tuple[float, int]:
        """``(b, k)`` the weights were computed with."""
        return self._b, self._k

    @property
    def dof_names(self) -> tuple[str, ...]:
        """The joint DOF, in the order of ``theta``."""
        return self._links.dof_names

    @property
    def all_dof_names(self) -> tuple[str, ...]:
        """The root's 6 DOF then the joint DOF: the Jacobian's parameter order."""
        return ROOT_DOF_NAMES + self._links.dof_names

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._links.joint_names

    @property
    def n_dofs(self) -> int:
        return self._links.n_dofs

    @property
    def rest_root_height(self) -> float:
        """Height of the body frame's origin (the point the root turns about) above the
        floor when the rest body stands on it: the root translation that puts the rest
        mesh's lowest point at z = 0."""
        return float(-self._vertices[:, 2].min())

    def __repr__(self) -> str:
        return (f"BodyModel({len(self._vertices)} vertices, {len(self._links.names)} links, "
                f"{self.n_dofs} DOF, K={self._k}, b={self._b:g})")

    # -- posing -------------------------------------------------------------------------

    def clamp(self, theta) -> np.ndarray:
        """`theta` clamped into the joint limits."""
        return self._links.clamp(self._theta(theta))

    def pose(self, theta=None, root_rotation=None, root_translation=None, clamp: bool = True,
             threads: int | None = None) -> Pose:
        """Deform the mesh (paper eq. 2) and place it in the world.

        Args:
            theta: (D,) joint angles, radians (default: the rest pose).
            root_rotation: (3, 3) world rotation of the body frame (default identity).
            root_translation: (3,) world position of the body frame's origin (default 0).
            clamp: clamp `theta` into the joint limits first.
        """
        root = _root(root_rotation, root_translation)
        v, n, centres, rotations = self._rig.pose(self._posable(theta, clamp), *root, threads)
        return Pose(v, n, self._joints(centres, rotations), rotations, centres)

    def joints(self, theta=None, root_rotation=None, root_translation=None, clamp: bool = True) -> np.ndarray:
        """The (J, 3) world positions of :attr:`joint_names` at a pose, as :meth:`pose`
        gives them, without posing the mesh."""
        return self._joints(*self._rig.frames(self._posable(theta, clamp), *_root(root_rotation, root_translation)))

    def _posable(self, theta, clamp: bool) -> np.ndarray:
        """`theta` checked (the rest pose for ``None``), and clamped into the joint limits
        when `clamp` says so."""
        theta = self._theta(theta)
        return self._links.clamp(theta) if clamp else theta

    def _joints(self, centres: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """The joints of links at world `centres` (L, 3) turned by `rotations` (L, 3, 3)."""
        rest = self._links.joint_points - self._links.origins[self._links.joint_links]
        return centres[self._links.joint_links] + np.einsum("jab,jb->ja", rotations[self._links.joint_links], rest)

    def jacobian(self, theta=None, root_rotation=None, root_translation=None,
                 threads: int | None = None) -> np.ndarray:
        """(V, 6 + D, 3) derivatives of the posed world vertices with respect to
        :attr:`all_dof_names` (analytic; no clamping)."""
        return self._rig.jacobian(self._theta(theta), *_root(root_rotation, root_translation), threads)

    def _theta(self, theta) -> np.ndarray:
        if theta is None:
            return np.zeros(self.n_dofs)
        theta = np.asarray(theta, dtype=np.float64)
        if theta.shape != (self.n_dofs,):
            raise ModelError(f"theta must have {self.n_dofs} joint angles, got shape {theta.shape}")
        if not np.isfinite(theta).all():
            raise ModelError(f"theta holds NaN or inf at {np.flatnonzero(~np.isfinite(theta)).tolist()}")
        return theta

    # -- files --------------------------------------------------------------------------

    def save(self, path) -> None:
        """Save to a folder: ``links.json`` (the link model) and ``mesh.npz`` (rest mesh and
        skin weights). Each file is written atomically."""
        path = Path(path)
        path.mkdir(parents=True, exist_ok=True)
        self._links.save(path / "links.json")
        buf = io.BytesIO()
        np.savez_compressed(buf, vertices=self._vertices, faces=self._faces.astype(np.int32),
                            skin_index=self._skin[0].astype(np.int32), skin_weight=self._skin[1],
                            skin_b=self._b, skin_k=self._k)
        atomic_write(path / "mesh.npz", buf.getvalue())

    @classmethod
    def load(cls, path) -> BodyModel:
        """Load a model saved by :meth:`save`; errors name the file at fault."""
        path = Path(path)
        if not path.is_dir():
            raise ModelError(f"{path}: not a body model folder (expected links.json and mesh.npz)")
        links = LinkModel.load(path / "links.json")
        mesh = path / "mesh.npz"
        arrays = read_npz(mesh, ModelError, "hullcap body mesh")
        missing = {"vertices", "faces", "skin_index", "skin_weight", "skin_b", "skin_k"} - arrays.keys()
        if missing:
            raise ModelError(f"{mesh}: not a hullcap body mesh (missing {sorted(missing)})")
        try:
            return cls(links, arrays["vertices"], arrays["faces"],
                       skin=(arrays["skin_index"], arrays["skin_weight"]),
                       b=float(arrays["skin_b"]), k=int(arrays["skin_k"]))
        except (ValueError, TypeError) as e:  # TypeError: skin_b or skin_k not one number
            raise ModelError(f"{mesh}: {e}") from e


@functools.lru_cache(maxsize=4)
def _template(b: float, k: int) -> BodyModel:
    path = DATA / "template.npz"
    with np.load(path) as z:
        vertices, faces = z["vertices"], z["faces"]
    return BodyModel(LinkModel.standard(), vertices, faces, b=b, k=k)


def _root_kept_between_hips(links: LinkModel, origins: np.ndarray) -> np.ndarray:
    """`origins` with the root's joint centre midway between the hip joints again, where
    the link model put it there (the standard one does: docs/design.md §1). The root has
    no joint DOF, so its centre moves no vertex; it is the pelvis point the outputs report."""
    hips = [links.joints.index(n) for n in ("l_hip", "r_hip") if n in links.joints]
    if len(hips) != 2 or np.abs(links.origins[0] - links.origins[hips].mean(0)).max() > 1e-9:
        return origins
    origins = np.array(origins, float)
    origins[0] = origins[hips].mean(0)
    return origins


def _root(rotation, translation):
    if rotation is not None:
        rotation = _array(rotation, "root_rotation", np.float64, (3, 3))
    if translation is not None:
        translation = _array(translation, "root_translation", np.float64, (3,))
    return rotation, translation


def _array(value, name, dtype, shape) -> np.ndarray:
    try:
        a = np.asarray(value)
        if a.dtype.kind == "f" and not np.isfinite(a).all():  # asked before a cast to integers
            raise ModelError(f"{name} holds NaN or inf")
        if a.dtype.kind == "f" and np.dtype(dtype).kind in "iu":
            limits = np.iinfo(dtype)
            if not ((a == np.round(a)) & (a >= limits.min) & (a <= limits.max)).all():
                raise ModelError(f"{name} must hold whole numbers within {limits.min}..{limits.max}")
        a = np.ascontiguousarray(a, dtype=dtype)
    except ModelError:
        raise
    except (TypeError, ValueError) as e:
        raise ModelError(f"{name}: not an array of numbers ({e})") from e
    if a.dtype.kind == "f" and not np.isfinite(a).all():
        raise ModelError(f"{name} holds NaN or inf")
    if a.ndim != len(shape) or any(s not in (-1, d) for s, d in zip(shape, a.shape)):
        raise ModelError(f"{name} must have shape {tuple('N' if s < 0 else s for s in shape)}, got {a.shape}")
    return a
