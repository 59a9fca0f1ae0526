"""The link model (docs/design.md §1): joint links with revolute DOF, structure links, joint
sites and the hierarchy of joint groups, read from a JSON file and validated.

The standard model is ``data/body/links.json``; its ``about`` field states the frame and
the sign conventions. All positions are in the body frame at rest.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hullcap._engine import link_tree_problem
from hullcap._files import atomic_write, read_document
from hullcap.errors import ModelError

__all__ = ["LinkModel", "STANDARD_LINKS"]

DATA = Path(__file__).resolve().parent / "data" / "body"
STANDARD_LINKS = DATA / "links.json"


@dataclass(frozen=True)
class LinkModel:
    """A validated link model. Arrays are float64 in the body frame at rest (metres).

    Attributes:
        names: the L joint links, parents before children; link 0 is the root.
        parents: (L,) int, −1 for the root.
        origins: (L, 3) joint centres.
        segments: (L, 2, 3) each joint link's segment (for skin weights).
        joints: the joint at each link's origin (``pelvis``, ``waist``, …).
        dof_names: the joint DOF (``waist_flexion``, …), grouped by link in link order.
        dof_links: (D,) int, the link each DOF turns.
        dof_axes: (D, 3) unit axes in the parent's frame at rest.
        dof_limits: (D, 2) lower and upper limits, radians.
        structure_names, structure_links (S,) int, structure_segments (S, 2, 3): segments
            fixed to a joint link that pull skin towards it.
        joint_names: the output joints, in output order; each is a link's origin or a site.
        joint_links: (J,) int link of each output joint; joint_points (J, 3) its position.
        hierarchy: the DOF indices of each joint group, fitted in this order after the
            root (docs/design.md §5).
        source: where it was read from (for error messages).
    """

    names: tuple[str, ...]
    parents: np.ndarray
    origins: np.ndarray
    segments: np.ndarray
    joints: tuple[str, ...]
    dof_names: tuple[str, ...]
    dof_links: np.ndarray
    dof_axes: np.ndarray
    dof_limits: np.ndarray
    structure_names: tuple[str, ...]
    structure_links: np.ndarray
    structure_segments: np.ndarray
    joint_names: tuple[str, ...]
    joint_links: np.ndarray
    joint_points: np.ndarray
    hierarchy: tuple[tuple[int, ...], ...]
    source: str = field(default="<memory>", compare=False)

    @classmethod
    def standard(cls) -> LinkModel:
        """hullcap's standard 29-DOF link model (``data/body/links.json``)."""
        return cls.load(STANDARD_LINKS)

    @classmethod
    def load(cls, path) -> LinkModel:
        """Read and validate a link model file; `ValueError` names the file and the entry."""
        return cls.from_dict(read_document(path, ModelError), source=str(path))

    @classmethod
    def from_dict(cls, spec: dict, source: str = "<memory>") -> LinkModel:
        """Validate a link model given as the parsed JSON of ``links.json``."""
        try:
            return _parse(spec, source)
        except ModelError:
            raise
        except (TypeError, AttributeError, KeyError, IndexError, ValueError) as e:
            # An entry of the wrong kind (a list where an object belongs…) that the checks
            # above do not name one by one.
            raise ModelError(f"{source}: malformed link model ({type(e).__name__}: {e})") from None

    def to_dict(self) -> dict:
        """The JSON form (``LinkModel.from_dict(m.to_dict()) == m``)."""
        links = []
        for j, name in enumerate(self.names):
            dofs = [
                {"name": self.dof_names[d], "axis": self.dof_axes[d].tolist(),
                 "limits": np.degrees(self.dof_limits[d]).tolist()}
                for d in np.flatnonzero(self.dof_links == j)
            ]
            parent = None if self.parents[j] < 0 else self.names[self.parents[j]]
            links.append({"name": name, "parent": parent, "joint": self.joints[j],
                          "origin": self.origins[j].tolist(),
                          "segment": self.segments[j].tolist(), "dofs": dofs})
        structure = [
            {"name": n, "parent": self.names[p], "segment": s.tolist()}
            for n, p, s in zip(self.structure_names, self.structure_links, self.structure_segments)
        ]
        link_joint = dict(zip(self.joints, range(len(self.joints))))
        sites = [
            {"name": n, "link": self.names[link], "position": p.tolist()}
            for n, link, p in zip(self.joint_names, self.joint_links, self.joint_points)
            if n not in link_joint
        ]
        hierarchy = [sorted({self.joints[self.dof_links[d]] for d in g}, key=self.joints.index)
                     for g in self.hierarchy]
        return {"units": "m", "links": links, "structure_links": structure, "sites": sites,
                "joint_names": list(self.joint_names), "hierarchy": hierarchy}

    def save(self, path) -> None:
        """Write the model as JSON (atomically)."""
        atomic_write(Path(path), (json.dumps(self.to_dict(), indent=1) + "\n").encode())

    @property
    def n_dofs(self) -> int:
        return len(self.dof_names)

    def all_segments(self) -> tuple[np.ndarray, list[int]]:
        """Joint and structure segments together, ``((L + S, 2, 3), bone of each)``: what
        :func:`hullcap.skin_weights` takes as ``links`` and ``groups``."""
        segs = np.concatenate([self.segments, self.structure_segments.reshape(-1, 2, 3)])
        return segs, list(range(len(self.names))) + [int(p) for p in self.structure_links]

    def dof_indices(self, name: str) -> list[int]:
        """The DOF called `name`, or, for a name without a side (``"knee_flexion"``), the
        DOF of that name on both sides (``l_knee_flexion``, ``r_knee_flexion``) or on
        the midline (``waist_flexion``). `ModelError` when none has that name."""
        names = [name] if name[:2] in ("l_", "r_") else [f"l_{name}", f"r_{name}", name]
        hits = [self.dof_names.index(n) for n in names if n in self.dof_names]
        if not hits:
            raise ModelError(f"{self.source}: no DOF named {name!r}")
        return hits

    def clamp(self, theta) -> np.ndarray:
        """`theta` (…, D) clamped into the joint limits."""
        return np.clip(theta, self.dof_limits[:, 0], self.dof_limits[:, 1])

    def with_wrists(self) -> LinkModel:
        """This model with each hand a joint link of its own (``l_hand``, ``r_hand``) that
        turns at the wrist by :data:`WRIST_DOFS`; the same model when no side has a
        forearm link with a ``wrist`` site (a model that has its hands already).

        The paper's 29 DOF have no wrist: a hand turns rigidly with its forearm, and a
        bent hand in the hull pulls the whole forearm toward it. The hand's joint is the
        wrist site; the forearm's segment now ends short of it and the hand's runs from
        beyond it to past the forearm's old end (by :data:`WRIST_GAP` and
        :data:`HAND_REACH` of the forearm's length), so that the skin weights give the
        hand's vertices to the hand's link and blend the wrist's between the two. The
        wrists join the elbows' group of the hierarchy."""
        spec = self.to_dict()
        links, added = [], []
        for link in spec["links"]:
            links.append(link)
            side = link["name"][:2]
            wrist = f"{side}wrist"
            if link["name"] not in ("l_forearm", "r_forearm") or wrist not in self.joint_names or wrist in self.joints:
                continue
            j = self.names.index(link["name"])
            centre = self.joint_points[self.joint_names.index(wrist)]
            start, end = self.segments[j]
            along = (end - start) / np.linalg.norm(end - start)
            length = np.linalg.norm(centre - self.origins[j])
            link["segment"] = [start.tolist(), (centre - WRIST_GAP * length * along).tolist()]
            mirror = np.array([1.0, -1.0, -1.0]) if side == "r_" else np.ones(3)  # an axis is a pseudovector
            links.append({"name": f"{side}hand", "parent": link["name"], "joint": wrist, "origin": centre.tolist(),
                          "segment": [(centre + WRIST_GAP * length * along).tolist(),
                                      (end + HAND_REACH * length * along).tolist()],
                          "dofs": [{"name": f"{side}{name}", "axis": (mirror * axis + 0.0).tolist(),
                                    "limits": list(limits)} for name, axis, limits in WRIST_DOFS]})
            added.append((wrist, f"{side}elbow"))
        if not added:
            return self
        spec["links"] = links
        wrists = {w for w, _ in added}
        spec["sites"] = [site for site in spec["sites"] if site["name"] not in wrists]
        for wrist, elbow in added:
            group = next((g for g in spec["hierarchy"] if elbow in g), spec["hierarchy"][-1])
            group.append(wrist)
        return LinkModel.from_dict(spec, source=f"{self.source} with wrists")


WRIST_DOFS = (("wrist_flexion", (0.0, 1.0, 0.0), (-70.0, 80.0)),
              ("wrist_deviation", (0.0, 0.0, -1.0), (-30.0, 20.0)))
"""The DOF of a hand turning at its wrist (:meth:`LinkModel.with_wrists`): name, the left
side's axis at rest (the right side's is mirrored) and limits in degrees. At rest the
template's arms lie along x with the palms down and the thumbs forward (−y): flexion
turns the hand toward the palm, deviation toward the thumb (radial; negative: ulnar). The
limits are the wrist's usual ranges of motion: 70° extension, 80° flexion, 20° radial and
30° ulnar deviation (the American Academy of Orthopaedic Surgeons' normal values)."""

WRIST_GAP = 0.08
"""The forearm's segment ends, and the hand's begins, this fraction of the forearm's length
(elbow to wrist) short of and beyond the wrist: 2 cm on the template."""

HAND_REACH = 0.04
"""The hand's segment ends this fraction of the forearm's length beyond the forearm's old
segment end: 1 cm on the template, 4 cm short of its fingertips."""


def _parse(spec: dict, source: str) -> LinkModel:
    def fail(msg):
        raise ModelError(f"{source}: {msg}")

    def vec(value, where, shape=(3,)):
        try:
            a = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            fail(f"{where} must be numbers, got {value!r}")
        if a.shape != shape or not np.isfinite(a).all():
            wanted = f"{shape[0]} finite numbers" if len(shape) == 1 else f"shape {shape}"
            fail(f"{where} must be {wanted}, got {value!r}")
        return a

    if not isinstance(spec, dict) or not isinstance(spec.get("links"), list) or not spec["links"]:
        fail("needs a non-empty 'links' list")
    names, parents, origins, segments, joints = [], [], [], [], []
    dof_names, dof_links, axes, limits = [], [], [], []
    index: dict[str, int] = {}
    every_link = {link.get("name"): j for j, link in reversed(list(enumerate(spec["links"])))}
    for j, link in enumerate(spec["links"]):
        name = link.get("name")
        where = f"link {name!r}" if name else f"link #{j}"
        if not isinstance(name, str) or not name:
            fail(f"{where} has no name")
        if name in index:
            fail(f"{where} is defined twice")
        parent = link.get("parent")
        if j == 0:
            if parent is not None:
                fail(f"{where}: the first link is the root and must have parent null")
            parents.append(-1)
        elif parent is None:
            fail(f"{where}: only the first link may be the root (parent null)")
        elif parent not in every_link:
            fail(f"{where}: parent {parent!r} is not a link")
        else:
            parents.append(every_link[parent])  # the engine checks the order below
        index[name] = j
        names.append(name)
        joints.append(link.get("joint", name))
        origins.append(vec(link.get("origin"), f"{where}: origin"))
        segments.append(vec(link.get("segment"), f"{where}: segment", (2, 3)))
        if np.linalg.norm(segments[-1][1] - segments[-1][0]) < 1e-6:
            fail(f"{where}: segment has zero length")
        for d in link.get("dofs", []):
            dwhere = f"{where}: DOF {d.get('name')!r}"
            axis = vec(d.get("axis"), f"{dwhere}: axis")
            lim = vec(d.get("limits"), f"{dwhere}: limits (degrees)", (2,))
            if not (-360 <= lim.min() and lim.max() <= 360):
                fail(f"{dwhere}: limits must lie within ±360 degrees")
            if not isinstance(d.get("name"), str) or d["name"] in dof_names:
                fail(f"{dwhere}: DOF names must be unique strings")
            dof_names.append(d["name"])
            dof_links.append(j)
            axes.append(axis)
            limits.append(np.radians(lim))
    dof_links = np.array(dof_links, dtype=np.int64)
    axes, limits = np.array(axes).reshape(-1, 3), np.array(limits).reshape(-1, 2)
    problem = link_tree_problem(parents, np.array(origins), dof_links.tolist(), axes, limits)
    if problem is not None:
        link, what = problem
        fail(what if link is None else f"link {names[link]!r}: {what}")
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    if len(set(joints)) != len(joints):
        fail("two links name the same joint")
    s_names, s_links, s_segs = [], [], []
    for s in spec.get("structure_links", []):
        where = f"structure link {s.get('name')!r}"
        if s.get("parent") not in index:
            fail(f"{where}: parent {s.get('parent')!r} is not a link")
        s_names.append(str(s.get("name")))
        s_links.append(index[s["parent"]])
        s_segs.append(vec(s.get("segment"), f"{where}: segment", (2, 3)))
    points = {jn: (j, origins[j]) for j, jn in enumerate(joints)}
    for site in spec.get("sites", []):
        where = f"site {site.get('name')!r}"
        if site.get("link") not in index:
            fail(f"{where}: link {site.get('link')!r} is not a link")
        if site.get("name") in points:
            fail(f"{where}: name already used by a joint or site")
        points[site["name"]] = (index[site["link"]], vec(site.get("position"), f"{where}: position"))
    joint_names = spec.get("joint_names", list(points))
    for jn in joint_names:
        if jn not in points:
            fail(f"joint_names: {jn!r} is neither a link's joint nor a site")
    hierarchy = []
    grouped: set[str] = set()
    for g, group in enumerate(spec.get("hierarchy", [])):
        dofs = []
        for jn in group:
            if jn not in joints:
                fail(f"hierarchy group {g}: {jn!r} is not a joint")
            if jn in grouped:
                fail(f"hierarchy: joint {jn!r} is in two groups")
            grouped.add(jn)
            dofs += np.flatnonzero(dof_links == joints.index(jn)).tolist()
        hierarchy.append(tuple(sorted(dofs)))
    moving = {joints[link] for link in dof_links}
    if spec.get("hierarchy") and moving - grouped:
        fail(f"hierarchy leaves joints out: {sorted(moving - grouped)}")
    return LinkModel(
        names=tuple(names), parents=np.array(parents), origins=np.array(origins),
        segments=np.array(segments), joints=tuple(joints), dof_names=tuple(dof_names),
        dof_links=dof_links, dof_axes=axes, dof_limits=limits, structure_names=tuple(s_names),
        structure_links=np.array(s_links, dtype=np.int64),
        structure_segments=np.array(s_segs).reshape(-1, 2, 3),
        joint_names=tuple(joint_names),
        joint_links=np.array([points[n][0] for n in joint_names], dtype=np.int64),
        joint_points=np.array([points[n][1] for n in joint_names]).reshape(-1, 3),
        hierarchy=tuple(hierarchy) if hierarchy else (tuple(range(len(dof_names))),),
        source=source,
    )
