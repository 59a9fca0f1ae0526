"""The subject's own body model, built automatically from the first frame (DESIGN.md §8).

The first frame shows the calibration pose. The template body is placed in the hull
(height from the hull, heading from the spread arms, both facing directions tried),
then pose and per-segment proportions are fitted in turn: each pass fits the pose by
ICP and re-estimates every segment's length and girth scale from where the hull
points matched to that segment's vertices lie in the segment's own frame (least squares
along and across the bone; left and right sides averaged). The subject's rest mesh is
the scaled template (clean topology, default) or the hull itself brought back to the
rest pose (the paper's way); its skin weights are computed afresh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hullcap._engine import NormalKDTree
from hullcap.body import BodyModel
from hullcap.fitting import FitResult, PoseParameters, fit, make_target
from hullcap.mesh import Surface

__all__ = ["SubjectFit", "build_subject", "place_model"]

SCALE_RANGE = (0.6, 1.6)
CHAINS = (("l_upper_arm", "l_forearm"), ("r_upper_arm", "r_forearm"), ("l_thigh", "l_shin"),
          ("r_thigh", "r_shin"))
"""Limbs whose segments share one length scale."""
LEGS = ("l_thigh", "l_shin", "r_thigh", "r_shin")
UNMEASURED_LENGTHS = ("pelvis", "head", "l_clavicle", "r_clavicle", "l_foot", "r_foot")
"""Links whose length keeps the overall scale."""


@dataclass(frozen=True)
class SubjectFit:
    """The subject's model and its pose in the first frame.

    Attributes:
        model: the subject's body model (rest mesh in the calibration rest pose).
        pose: its fitted pose in the frame it was built from.
        lengths, girths: per-link scales relative to the template.
        fit: the final fit's statistics.
    """

    model: BodyModel
    pose: PoseParameters
    lengths: dict
    girths: dict
    fit: FitResult


def build_subject(hull: Surface, template: BodyModel | None = None, passes: int = 4,
                  rest_mesh: str = "template", threads: int | None = None) -> SubjectFit:
    """Fit the template to the first frame's hull and return the subject's model.

    Args:
        hull: the visual hull of a frame showing the calibration pose (z up, floor z = 0).
        template: the body to start from (default: :meth:`BodyModel.template`).
        passes: pose/proportion alternations.
        rest_mesh: ``"template"`` (the scaled template) or ``"hull"`` (the hull mesh
            brought to the rest pose by inverse skinning, as in the paper).
    """
    if rest_mesh not in ("template", "hull"):
        raise ValueError(f"rest_mesh must be 'template' or 'hull', got {rest_mesh!r}")
    template = template or BodyModel.template()
    v = hull.vertices
    s = float(np.clip(np.ptp(v[:, 2]) / np.ptp(template.vertices[:, 2]), *SCALE_RANGE))
    names = template.link_model.names
    lengths = dict.fromkeys(names, s)
    girths = dict.fromkeys(names, s)
    model = template.scaled(lengths, girths)
    target = make_target(hull)
    best = place_model(model, hull, target, threads)
    tree = NormalKDTree(hull.vertices, hull.normals)
    leg = _leg_scale(template, best.pose, hull)
    for _ in range(passes):
        rel_len, rel_girth = _segment_scales(model, best.pose, tree, hull)
        if leg is not None:
            for name in LEGS:
                rel_len[name] = leg / lengths[name]
        for name in names:
            lengths[name] = float(np.clip(lengths[name] * rel_len.get(name, 1.0), *SCALE_RANGE))
            girths[name] = float(np.clip(girths[name] * rel_girth.get(name, 1.0), *SCALE_RANGE))
        model = template.scaled(lengths, girths)
        best = fit(model, target, best.pose, threads=threads)
    if rest_mesh == "hull":
        model = _hull_at_rest(model, best.pose, hull)
    else:
        model = model.reskinned()
    final = fit(model, target, best.pose, threads=threads)
    return SubjectFit(model, final.pose, lengths, girths, final)


def place_model(model: BodyModel, hull: Surface, target=None, threads: int | None = None) -> FitResult:
    """Fit `model` to a hull of the calibration pose with no pose to start from: the rest
    pose stood on the hull's floor at its centre, turned so the arms lie along the hull's
    arm axis, facing either way along it; the better of the two fits."""
    v = hull.vertices
    floor, height = v[:, 2].min(), np.ptp(v[:, 2])
    target = target if target is not None else make_target(hull)
    centre = np.median(v[:, :2], 0)
    yaw = _arm_axis_yaw(v, floor, height)
    best = None
    for heading in (yaw, yaw + np.pi):
        start = PoseParameters.rest(model, (centre[0], centre[1], floor + model.rest_root_height), heading)
        result = fit(model, target, start, threads=threads)
        if best is None or result.energy < best.energy:
            best = result
    return best


def _crotch_height(points, floor) -> float | None:
    """Height above `floor` of the top of the gap between the legs: the lowest surface
    point within 1.5 cm of the body's mid-plane (x = 0 in body coordinates) above knee
    height; None when the legs touch (no gap)."""
    mid = points[(np.abs(points[:, 0]) < 0.015) & (points[:, 2] > floor + 0.3)]
    if len(mid) == 0:
        return None
    lowest = mid[:, 2].min() - floor
    return float(lowest) if lowest < 0.65 * (points[:, 2].max() - floor) else None


def _leg_scale(template: BodyModel, pose: PoseParameters, hull: Surface) -> float | None:
    """Leg length scale from the crotch height, the one place in a calibration pose that
    shows how long the legs are (the hips themselves are hidden in the pelvis)."""
    body = (hull.vertices - pose.root_translation) @ pose.root_rotation  # body frame
    floor_body = float(((np.array([0, 0, hull.vertices[:, 2].min()]) - pose.root_translation) @ pose.root_rotation)[2])
    ours = _crotch_height(body, floor_body)
    rest = template.vertices
    theirs = _crotch_height(rest, rest[:, 2].min())
    if ours is None or theirs is None:
        return None
    return float(np.clip(ours / theirs, *SCALE_RANGE))


def _arm_axis_yaw(v, floor, height) -> float:
    """Heading (yaw of the body's x axis) from the principal horizontal direction of the
    hull at shoulder height, where the spread arms reach furthest."""
    band = v[(v[:, 2] > floor + 0.75 * height) & (v[:, 2] < floor + 0.88 * height)]
    if len(band) < 10:
        return 0.0
    xy = band[:, :2] - band[:, :2].mean(0)
    _, _, vt = np.linalg.svd(xy, full_matrices=False)
    return float(np.arctan2(vt[0, 1], vt[0, 0]))


def _segment_scales(model: BodyModel, pose: PoseParameters, tree: NormalKDTree, hull: Surface):
    """Relative length and girth scale per link from the hull points matched to the
    vertices each link carries most."""
    posed = model.pose(pose.theta, pose.root_rotation, pose.root_translation)
    idx, _ = tree.query(posed.vertices, posed.normals, max_distance=0.08, max_angle=np.radians(45))
    index, weight = model.skin
    links = model.link_model
    rest = model.vertices
    rel_len, rel_girth = {}, {}
    for j, name in enumerate(links.names):
        sel = (index[:, 0] == j) & (weight[:, 0] > 0.8) & (idx >= 0)
        if sel.sum() < 30:
            continue
        seg = links.segments[j]
        u = (seg[1] - seg[0]) / np.linalg.norm(seg[1] - seg[0])
        a = rest[sel] - links.origins[j]
        # Matched hull points in the link's rest frame (undo its world rotation).
        q = hull.vertices[idx[sel]]
        b = (q - posed.link_positions[j]) @ posed.link_rotations[j]
        a_par, b_par = a @ u, b @ u
        a_perp, b_perp = a - np.outer(a_par, u), b - np.outer(b_par, u)
        if np.ptp(a_par) > 0.05:  # the segment is long enough to measure along
            rel_len[name] = float(np.clip((a_par @ b_par) / (a_par @ a_par), 0.8, 1.25))
        rel_girth[name] = float(np.clip(np.sum(a_perp * b_perp) / np.sum(a_perp * a_perp), 0.8, 1.25))
    for table in (rel_len, rel_girth):
        for name in list(table):
            if name.startswith("l_") and "r_" + name[2:] in table:
                mean = 0.5 * (table[name] + table["r_" + name[2:]])
                table[name] = table["r_" + name[2:]] = mean
    # In a static pose with straight limbs, where the elbow or knee sits along the limb,
    # and where the hips sit in the pelvis, cannot be seen: limbs get one length scale
    # (their segments keep the template's ratio) and unobservable lengths none.
    for chain in CHAINS:
        found = [rel_len[n] for n in chain if n in rel_len]
        for n in chain:
            if found:
                rel_len[n] = float(np.mean(found))
    for n in UNMEASURED_LENGTHS:
        rel_len.pop(n, None)
    return rel_len, rel_girth


def _hull_at_rest(model: BodyModel, pose: PoseParameters, hull: Surface) -> BodyModel:
    """The hull mesh as the rest mesh: each vertex moved back to the rest pose by the
    inverse of its blended link transform (weights from the fitted model's nearest
    vertex), expressed in the body frame."""
    posed = model.pose(pose.theta, pose.root_rotation, pose.root_translation)
    near, _ = NormalKDTree(posed.vertices, posed.normals).query(hull.vertices, hull.normals)  # ungated
    index, weight = model.skin
    k_idx, k_w = index[near], weight[near]  # (H, K) each
    links = model.link_model
    # Link j moves a rest point x to A_j (x − o_j) + c_j; blended: M x + off.
    A, c = posed.link_rotations, posed.link_positions
    M = np.einsum("hk,hkab->hab", k_w, A[k_idx])
    off = np.einsum("hk,hka->ha", k_w, c[k_idx] - np.einsum("hkab,hkb->hka", A[k_idx], links.origins[k_idx]))
    rest = np.linalg.solve(M, (hull.vertices - off)[..., None])[..., 0]
    return BodyModel(links, rest, hull.faces, b=model.skin_parameters[0], k=model.skin_parameters[1])
