"""Body proportions as parameters (docs/design.md, "The subject's model").

A shape vector s moves the rest body linearly (the engine's ``Shape``): each parameter
stretches some links about their joint centres (the root about the body frame's origin)
and/or shifts some joints, and the mesh follows by its skin weights. s = 0 is the body
itself. The subject's model is the template at the shape vector that minimises the fit
energy over the calibration frames (:func:`hullcap.build_subject`);
:meth:`hullcap.BodyModel.scaled` is the special case of one length and one girth scale
per link.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hullcap import _engine
from hullcap.errors import ModelError

__all__ = ["ShapeParameter", "ShapeBasis"]

LIMBS = ("clavicle", "upper_arm", "forearm", "thigh", "shin", "foot")
"""Links that come in mirrored pairs (``l_`` and ``r_``); a pair shares its parameters."""
CENTRES = {"hip": "thigh", "knee": "shin", "ankle": "foot", "shoulder": "upper_arm", "elbow": "forearm"}
"""Joints whose centre the subject fit moves (by the link each turns): where a joint sits
inside a limb shows only when the limb bends, so these are decided by frames of motion."""


@dataclass(frozen=True)
class ShapeParameter:
    """One shape parameter.

    Attributes:
        name: e.g. ``length:thigh`` (both thighs), ``girth:torso``, ``shift:hip``,
            ``centre:knee:z``.
        stretches: ``(link index, (3, 3) P)``: one unit adds P to the link's stretch.
        shifts: ``(link index, (3,) c)``: one unit moves the link's joint, and all below
            it, by c metres.
        centres: ``(link index, (3,) e)``: one unit moves the point the link turns about by
            e metres, and nothing else (the surface and the joints below stay).
        sigma: the prior's standard deviation of the parameter (its own unit).
    """

    name: str
    stretches: tuple = ()
    shifts: tuple = ()
    centres: tuple = ()
    sigma: float = 1.0


class ShapeBasis:
    """An ordered set of shape parameters of one link model."""

    def __init__(self, parameters):
        self.parameters = tuple(parameters)
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise ModelError(f"shape parameter names repeat: {names}")

    def __len__(self) -> int:
        return len(self.parameters)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def sigma(self) -> np.ndarray:
        return np.array([p.sigma for p in self.parameters], float)

    def engine(self, model) -> _engine.Shape:
        """The engine's shape of a :class:`~hullcap.BodyModel` (the base body at s = 0).

        A stretch of the root is about the body frame's origin, the point the root turns
        about, not about the root's joint centre, which the link model may put elsewhere
        (the standard one puts it midway between the hips): the engine stretches each link
        about its joint centre, so the root is shifted by what that leaves out."""
        if not hasattr(model, "link_model"):
            raise TypeError(f"ShapeBasis.engine takes a BodyModel, got {type(model).__name__}")
        root = model.link_model.origins[0]

        def shifts(p):
            return [(j, np.asarray(c)) for j, c in p.shifts] + \
                [(0, np.asarray(m) @ root) for j, m in p.stretches if j == 0 and root.any()]

        return _engine.Shape(model._rig,
                             [[(j, np.asarray(m)) for j, m in p.stretches] for p in self.parameters],
                             [shifts(p) for p in self.parameters],
                             [[(j, np.asarray(e)) for j, e in p.centres] for p in self.parameters])

    @classmethod
    def scales(cls, links, lengths: dict | None = None, girths: dict | None = None):
        """``(basis, s)`` for per-link length and girth scale factors (1 = unchanged):
        link j stretched by ``lengths[name]`` along its segment and ``girths[name]`` across
        it, about its joint centre."""
        lengths, girths = dict(lengths or {}), dict(girths or {})
        params, values = [], []
        for kind, table in (("length", lengths), ("girth", girths)):
            for name, scale in table.items():
                if name not in links.names:
                    raise ModelError(f"scaling names unknown link {name!r}; links are {list(links.names)}")
                if not (np.isfinite(scale) and 0.2 <= scale <= 5.0):
                    raise ModelError(f"{kind} scale of {name!r} must be in [0.2, 5], got {scale}")
                j = links.names.index(name)
                along, across = _projectors(links, j)
                params.append(ShapeParameter(f"{kind}:{name}", ((j, along if kind == "length" else across),)))
                values.append(scale - 1.0)
        return cls(params), np.array(values, float)

    @classmethod
    def standard(cls, links, length_sigma: float = 0.15, girth_sigma: float = 0.25,
                 shift_sigma: float = 0.03, centre_sigma: float = 0.03) -> ShapeBasis:
        """The subject model's parameters for hullcap's link model: a length and a girth
        scale per segment (mirrored limbs tied), the torso's and pelvis's girth split into
        width and depth, the hip joints' lateral shift (the hips' place in the pelvis is
        not where the pelvis's width alone would put it), and the centres of the joints of
        :data:`CENTRES` in x, y and z (mirrored: the same anatomical direction both sides).

        Args:
            length_sigma, girth_sigma: prior standard deviations of a length or girth scale
                relative to the template scaled to the subject's height (0.15 = 15 %).
            shift_sigma, centre_sigma: prior standard deviations of a joint shift or of a
                joint centre's move (metres).
        """
        names = links.names
        params = []

        def group(base):
            return [names.index(n) for n in (f"l_{base}", f"r_{base}") if n in names] or \
                ([names.index(base)] if base in names else [])

        for base in ("pelvis", "torso", "head") + LIMBS:
            idx = group(base)
            if not idx:
                continue
            proj = [_projectors(links, j) for j in idx]
            params.append(ShapeParameter(f"length:{base}", tuple((j, a) for j, (a, _) in zip(idx, proj)),
                                         sigma=length_sigma))
            if base in ("pelvis", "torso"):
                for axis, label in ((0, "width"), (1, "depth")):
                    params.append(ShapeParameter(f"{label}:{base}", tuple(
                        (j, _across_axis(links, j, axis)) for j in idx), sigma=girth_sigma))
            else:
                params.append(ShapeParameter(f"girth:{base}", tuple((j, b) for j, (_, b) in zip(idx, proj)),
                                             sigma=girth_sigma))
        hips = [(names.index(n), np.array([s, 0.0, 0.0])) for n, s in (("l_thigh", 1.0), ("r_thigh", -1.0))
                if n in names]
        if hips:
            params.append(ShapeParameter("shift:hip", shifts=tuple(hips), sigma=shift_sigma))
        for joint, base in CENTRES.items():
            idx = group(base)
            for axis, label in enumerate("xyz"):
                moves = tuple((j, _side_axis(names[j], axis)) for j in idx)
                if moves:
                    params.append(ShapeParameter(f"centre:{joint}:{label}", centres=moves, sigma=centre_sigma))
        return cls(params)


def _side_axis(name: str, axis: int) -> np.ndarray:
    """The body axis `axis`, mirrored (x negated) for a right-side link."""
    e = np.eye(3)[axis].copy()
    if name.startswith("r_") and axis == 0:
        e[0] = -1.0
    return e


def _projectors(links, j):
    """(u uᵀ, I − u uᵀ) of link j's segment direction u."""
    u = links.segments[j, 1] - links.segments[j, 0]
    u = u / np.linalg.norm(u)
    along = np.outer(u, u)
    return along, np.eye(3) - along


def _across_axis(links, j, axis):
    """The projector on link j's width (`axis` 0: the body's x made perpendicular to the
    segment) or depth (`axis` 1: perpendicular to both the segment and the width)."""
    _, across = _projectors(links, j)
    width = across @ np.eye(3)[0]
    e = width if axis == 0 else np.cross(links.segments[j, 1] - links.segments[j, 0], width)
    e = e / np.linalg.norm(e)
    return np.outer(e, e)
