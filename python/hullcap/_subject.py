"""The subject's own body model, fitted to the calibration frames (docs/design.md, "The
subject's model").

The template is placed in the first hull by a small global search (its centre, headings
all round, the best few refined), then its proportions — a shape vector of
:class:`~hullcap._shape.ShapeBasis`: an overall scale, a length and a girth per segment,
the hips' lateral place — and the pose of every calibration frame are fitted together
as the minimum of the same two-sided robust energy that tracking uses, plus a Gaussian
prior that keeps proportions no frame shows at the template's. The subject's rest mesh is
the template at that shape (clean topology, default) or the hull itself brought back to
the rest pose (the paper's way); its skin weights are computed afresh.

Where a hinge sits along its limb shows only when it bends, and then only in how well
the bent limb fits: :func:`search_centres` moves a joint's centre along the limb, refits
frames where it bends, and keeps the place that explains those hulls best (a functional
joint centre, found by the fit's own measure of quality).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hullcap import _engine
from hullcap._body import BodyModel
from hullcap._engine import FitOptions, NormalKDTree
from hullcap._fitting import FitResult, PoseParameters, fit, make_target, quality
from hullcap._mesh import Surface, smoothed_over_mesh
from hullcap._options import FRACTION
from hullcap._shape import ShapeBasis, ShapeParameter
from hullcap._threads import over_fits
from hullcap.errors import FitError, ModelError, OptionsError

__all__ = ["SubjectOptions", "SubjectFit", "build_subject", "place_model", "bent_frames", "search_centres",
           "centre_profile", "best_move", "fitted_surface", "with_hands"]


@dataclass(frozen=True)
class SubjectOptions:
    """Every number the subject model depends on.

    Why each default is what it is, with the runs behind it: the accuracy notebook
    (docs/notebooks/accuracy.md, "Why the tracker's defaults are what they are").

    Attributes:
        length_sigma: prior standard deviation of a segment's length relative to the
            template at the subject's overall scale (0.15 = 15 %): adult segment-length
            ratios vary by about that much, and a static pose cannot show some of them
            (where the elbow sits along a straight arm).
        girth_sigma: the same for girths (0.25: girth varies more than length).
        shift_sigma: prior standard deviation of a joint shift, metres (the hips' lateral
            place: a few centimetres between people).
        centre_sigma: prior standard deviation of a joint centre's place inside its limb
            against the template's, metres: only frames where the joint bends move it.
        scale_sigma: prior standard deviation of the overall scale against the template
            (0.5: a 1.75 m template covers children of 0.9 m to adults of 2.6 m within 1σ).
        prior_distance: metres of pair distance one prior standard deviation is worth (see
            ``hullcap_icp::ShapePrior``): 3 mm, about a voxel's error, so that what the
            hulls do show wins over the prior.
        stature: the heights (metres) a hull of the calibration pose may have: a small child
            to a very tall adult.
        calibration_limits: joint limits (degrees, by DOF name; without ``l_``/``r_``: both
            sides) of every fit of the first hull, which shows the calibration pose (its
            placement, shape fit and last refit, and the rebuilds from guided silhouettes).
        headings: placements tried in the first hull, evenly spaced about the vertical.
        keep: the best placements (by coverage and inliers after a quick fit) refined.
        iterations: most Levenberg–Marquardt iterations of the shape fit.
        rest_mesh: ``"template"`` (the template at the fitted shape) or ``"hull"`` (the
            first hull brought to the rest pose, the paper's way).
        fit: options of the pose fits and of the shape fit.
        centre_search: ``(joint, axis)`` of each joint centre :func:`search_centres` places
            from frames where the joint bends, by the shape parameter
            ``centre:<joint>:<axis>`` (mirrored sides move together).
        centre_range, centre_step: the moves tried, metres: every `centre_step` within ±
            `centre_range` (a person's knee lies within 4 cm of the template's proportions
            along a limb).
        centre_frames: the frames of most bending refitted for each move.
        centre_min_bend: a frame serves the search only when the joint bends at least this
            much (radians) on one side at least: a straight limb says nothing of where it
            would bend, and a slightly bent one too little.
        centre_min_gain: the least rise of mean quality over keeping the centre where it is
            for a move to be made (a fraction of points).
        centre_samples: the hull samples (``FitOptions.reverse_points``) of the search's
            refits, on which half of their quality, the coverage, is measured.
        surface_reach: the subject's own surface (:func:`fitted_surface`): each rest vertex
            moves along its normal by the median, over frames of the first seconds, of its
            distance to the hull along that normal, where the hull lies within this many
            metres (under a forearm's radius, so that a vertex pairs with its own part of the
            hull).
        surface_angle: the largest angle (radians) between a vertex's normal and its hull
            partner's.
        surface_share: a vertex moves only when at least this share of the frames gave it a
            partner (a part the hull keeps losing, the fingers, stays as it is).
        surface_smoothing: passes of smoothing over the mesh (each vertex half its own
            offset, half its neighbours' mean): a hull's own bumps are a voxel (1 cm) wide,
            and ten passes spread an offset over a few centimetres of the template (its
            edges are 1.6 cm long on average).
        surface_frames: the frames of the first seconds measured, spread evenly over them.
    """

    length_sigma: float = 0.15
    girth_sigma: float = 0.25
    shift_sigma: float = 0.03
    centre_sigma: float = 0.03
    scale_sigma: float = 0.5
    prior_distance: float = 0.003
    stature: tuple = (0.8, 2.5)
    calibration_limits: dict = field(default_factory=lambda: {
        "elbow_flexion": (0, 25), "knee_flexion": (0, 20), "hip_flexion": (-20, 20), "hip_twist": (-20, 20),
        "ankle_flexion": (-20, 20), "ankle_inversion": (-15, 15), "shoulder_flexion": (-30, 30),
        "shoulder_abduction": (-70, 30), "waist_flexion": (-15, 15), "waist_twist": (-20, 20)})
    headings: int = 8
    keep: int = 3
    iterations: int = 40
    rest_mesh: str = "template"
    fit: FitOptions = field(default_factory=lambda: FitOptions(reverse_weight=1.0))
    centre_search: tuple = (("knee", "z"),)
    centre_range: float = 0.04
    centre_step: float = 0.01
    centre_frames: int = 8
    centre_min_bend: float = math.radians(45.0)
    centre_min_gain: float = 0.002
    centre_samples: int = 6000
    surface_reach: float | None = 0.03
    surface_angle: float = math.radians(45.0)
    surface_share: float = 0.3
    surface_smoothing: int = 10
    surface_frames: int = 24

    def __post_init__(self):
        if self.rest_mesh not in ("template", "hull"):
            raise OptionsError(f"rest_mesh must be 'template' or 'hull', got {self.rest_mesh!r}")
        for name in ("length_sigma", "girth_sigma", "shift_sigma", "centre_sigma", "scale_sigma"):
            if not getattr(self, name) > 0:
                raise OptionsError(f"SubjectOptions.{name} must be positive, got {getattr(self, name)}")
        if not (self.prior_distance >= 0 and self.headings >= 1 and self.keep >= 1 and self.iterations >= 1):
            raise OptionsError("SubjectOptions: prior_distance must be >= 0, headings, keep, iterations >= 1")
        if not (0 < self.centre_step <= self.centre_range and self.centre_frames >= 1
                and self.centre_min_bend >= 0 and self.centre_min_gain >= 0 and self.centre_samples >= 1):
            raise OptionsError("SubjectOptions: need 0 < centre_step <= centre_range, centre_frames >= 1, "
                               "centre_samples >= 1, centre_min_bend and centre_min_gain >= 0")
        if not ((self.surface_reach is None or self.surface_reach > 0) and 0 < self.surface_angle <= math.pi
                and 0 <= self.surface_share <= 1 and self.surface_smoothing >= 0 and self.surface_frames >= 1):
            raise OptionsError("SubjectOptions: need surface_reach > 0 (or None), 0 < surface_angle <= pi, "
                               "0 <= surface_share <= 1, surface_smoothing >= 0 and surface_frames >= 1")

    def basis(self, links) -> ShapeBasis:
        """The shape parameters: an overall scale, then :meth:`ShapeBasis.standard`."""
        every = tuple((j, np.eye(3)) for j in range(len(links.names)))
        overall = ShapeParameter("scale:all", every, sigma=self.scale_sigma)
        standard = ShapeBasis.standard(links, self.length_sigma, self.girth_sigma, self.shift_sigma,
                                       self.centre_sigma)
        return ShapeBasis((overall,) + standard.parameters)


@dataclass(frozen=True)
class SubjectFit:
    """The subject's model and its fitted poses.

    Attributes:
        model: the subject's body model.
        pose: its pose in the first calibration frame.
        poses: its pose in every calibration frame given.
        basis, shape: the shape parameters and their fitted values (the model is the
            template at that shape, re-skinned).
        fit: the first frame's fit statistics with the final model.
    """

    model: BodyModel
    pose: PoseParameters
    poses: tuple
    basis: ShapeBasis
    shape: np.ndarray
    fit: FitResult


def build_subject(hulls, poses=None, template: BodyModel | None = None,
                  options: SubjectOptions | None = None, facing=None,
                  calibration: bool | None = None) -> SubjectFit:
    """Fit the template's proportions and poses to the hulls of calibration frames.

    Args:
        hulls: a :class:`~hullcap._mesh.Surface`, or several (frames of the calibration
            pose and of the first motion; the first is where the model is placed).
        poses: a starting pose per hull (e.g. from tracking with an earlier model);
            default: the placement found in the first hull, for every hull, and every
            hull is then taken to show the calibration pose: frames of motion need their
            poses.
        template: the body to start from (default: :meth:`BodyModel.template`).
        options: see :class:`SubjectOptions`.
        facing: with no poses, the way the person faces, as :func:`place_model` takes it.
        calibration: whether the hulls show the calibration pose (default: when no poses
            are given), so that every fit, the last one too, stays within
            ``options.calibration_limits``: where a view loses a limb (a shin the colour
            of the floor), nothing else keeps it straight, and a limb folded onto another
            guides the silhouettes that follow to lose it again.
    """
    options = options or SubjectOptions()
    hulls = [hulls] if isinstance(hulls, Surface) else list(hulls)
    if not hulls:
        raise FitError("build_subject needs at least one hull")
    if poses is not None and len(poses) != len(hulls):
        raise FitError(f"{len(poses)} starting poses for {len(hulls)} hulls")
    template = template or BodyModel.template()
    for i, hull in enumerate(hulls):
        vertices = np.asarray(hull.vertices)
        if len(vertices) == 0 or not np.isfinite(vertices).all():
            raise FitError(f"hull {i} is {'empty' if len(vertices) == 0 else 'not finite'}: no person to fit")
    height = _height(hulls[0].vertices)
    if not options.stature[0] <= height <= options.stature[1]:
        raise FitError(f"the first hull is {height:.2f} m tall: not a person in the calibration pose "
                         f"(SubjectOptions.stature is {options.stature[0]}-{options.stature[1]} m)")
    basis = options.basis(template.link_model)
    shape0 = np.zeros(len(basis))
    shape0[0] = height / _height(template.vertices) - 1.0
    targets = [make_target(h) for h in hulls]
    calibration = poses is None if calibration is None else calibration
    fitted_body = _limited(template, options.calibration_limits) if calibration else template
    if poses is None:
        start = place_model(fitted_body.shaped(basis, shape0), hulls[0], targets[0], options, facing)
        poses = [start.pose] * len(hulls)
    engine = basis.engine(fitted_body)
    rotations = [np.asarray(p.root_rotation, float) for p in poses]
    translations = [np.asarray(p.root_translation, float) for p in poses]
    found, fitted, _, _ = _engine.fit_shape(
        engine, shape0.tolist(), targets, [np.asarray(p.theta, float).tolist() for p in poses],
        rotations, translations, basis.sigma.tolist(), options.prior_distance,
        options.fit.replace(iterations=options.iterations, tolerance=1e-4))
    shaped = template.shaped(basis, found)
    fitted_poses = [PoseParameters(*p) for p in fitted]
    if options.rest_mesh == "hull":
        model = _hull_at_rest(shaped, fitted_poses[0], hulls[0])
    else:
        model = shaped.reskinned()
    fitted_model = _limited(model, options.calibration_limits) if calibration else model
    final = fit(fitted_model, targets[0], fitted_poses[0], options.fit)
    return SubjectFit(model, final.pose, (final.pose, *fitted_poses[1:]), basis, np.asarray(found), final)


AWAY = -0.5
"""A heading whose facing agreement is below this faces away from the person (more than
about 120° off): a start side-on (about 0) is still tried, since it may turn to the front."""


def place_model(model: BodyModel, hull: Surface, target=None, options: SubjectOptions | None = None,
                facing=None) -> FitResult:
    """Fit `model` to a hull with no pose to start from: the rest pose stood on the hull's
    floor at its centre, turned to ``options.headings`` headings; each is fitted briefly,
    the ``options.keep`` that explain most of the hull both ways are fitted fully, and the
    best of those is returned. `facing` (a function of a model and a pose, from -1 facing
    away from the way the person does to 1 facing it; :func:`hullcap._person.facing_agreement`)
    leaves out the headings it scores below :data:`AWAY`, since a hull shows front and back
    alike."""
    options = options or SubjectOptions()
    v = hull.vertices
    target = target if target is not None else make_target(hull)
    centre = np.median(v[:, :2], 0)
    root = (centre[0], centre[1], v[:, 2].min() + model.rest_root_height)
    quick = options.fit.replace(rounds=1, polish=False)
    yaws = np.arange(options.headings) * 2 * np.pi / options.headings
    starts = [PoseParameters.rest(model, root, yaw) for yaw in yaws]
    if facing is not None:
        starts = [s for s in starts if facing(model, s) >= AWAY] or starts
    tried = over_fits(lambda start, threads: fit(model, target, start, quick, threads=threads), starts)
    tried.sort(key=quality, reverse=True)
    refined = over_fits(lambda r, threads: fit(model, target, r.pose, options.fit, threads=threads),
                        tried[: options.keep])
    return max(refined, key=quality)


def bent_frames(model: BodyModel, thetas, joint: str, options: SubjectOptions | None = None) -> list[int]:
    """Indices into `thetas` (F, D) of the frames where the two `joint`s (``l_``/``r_``)
    bend most, at least ``options.centre_min_bend`` on one side, at most
    ``options.centre_frames`` of them, kept apart by three frames (neighbours repeat
    each other)."""
    options = options or SubjectOptions()
    links = model.link_model
    dofs = [d for d in range(model.n_dofs) if links.joints[links.dof_links[d]] in (f"l_{joint}", f"r_{joint}")]
    if not dofs:
        raise OptionsError(f"SubjectOptions.centre_search: the model has no joint l_{joint} or r_{joint}")
    thetas = np.asarray(thetas, float).reshape(-1, model.n_dofs)
    bend = np.abs(thetas[:, dofs]).max(axis=1)
    picked: list[int] = []
    for f in np.argsort(-bend, kind="stable"):
        if bend[f] < options.centre_min_bend or len(picked) == options.centre_frames:
            break
        if all(abs(int(f) - g) >= 3 for g in picked):
            picked.append(int(f))
    return picked


def search_centres(model: BodyModel, joint: str, axis: str, targets, poses,
                   options: SubjectOptions | None = None) -> tuple[BodyModel, float]:
    """``(model, move)``: `model` with the centre of `joint` (both sides, mirrored) moved
    along body `axis` by the move, among those ``options.centre_range`` and
    ``options.centre_step`` give, whose refits of `targets` (frames where the joint
    bends, fitted from `poses`) have the highest mean quality, refined between the grid's
    points by a parabola. The move is 0 (and `model` returned as it is) unless its mean
    gain over keeping the centre is worth having (``options.centre_min_gain``): a flat
    profile, where every move explains the frames about as well, is noise, and noise must
    not move a joint. The gain is not also weighed against its spread over the frames:
    near the peak the profile is flat by nature, so that test decided by a frame or two
    whether a clear peak was taken or ignored."""
    options = options or SubjectOptions()
    if not targets:
        return model, 0.0
    move = best_move(*centre_profile(model, joint, axis, targets, poses, options), options)
    return _centre_moved(model, joint, axis, move), move


def centre_profile(model: BodyModel, joint: str, axis: str, targets, poses,
                   options: SubjectOptions | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(moves, per_frame)`` of :func:`search_centres`: the moves of `joint`'s centre
    along `axis` that ``options.centre_range`` and ``options.centre_step`` give (M,), and
    the quality of each of `targets` refitted from its pose in `poses` with each (M, F)."""
    options = options or SubjectOptions()
    steps = int(round(options.centre_range / options.centre_step))
    moves = options.centre_step * np.arange(-steps, steps + 1)
    refit = options.fit.replace(reverse_points=options.centre_samples)
    moved = [_centre_moved(model, joint, axis, move) for move in moves]
    refits = [(m, t, p) for m in moved for t, p in zip(targets, poses)]
    qualities = over_fits(lambda job, threads: quality(fit(*job, refit, threads=threads)), refits)
    return moves, np.reshape(qualities, (len(moves), len(targets)))


def best_move(moves, per_frame, options: SubjectOptions | None = None) -> float:
    """The move of :func:`search_centres` from its profile: `moves` (M,), spaced by
    ``options.centre_step`` and symmetric about 0, and the quality of each frame's refit
    at each (M, F). The move of best mean quality, refined by a parabola through its
    neighbours, if it gains at least ``options.centre_min_gain`` over the middle move
    (keeping the centre); else 0."""
    options = options or SubjectOptions()
    moves = np.asarray(moves, float)
    scores = np.asarray(per_frame, float).mean(axis=1)
    best, keep = int(np.argmax(scores)), len(moves) // 2
    if scores[best] - scores[keep] < options.centre_min_gain:
        return 0.0
    move = float(moves[best])
    if 0 < best < len(moves) - 1:
        below, at, above = scores[best - 1], scores[best], scores[best + 1]
        curvature = below - 2 * at + above
        if curvature < 0:  # the peak lies between the neighbours of the best move
            move += options.centre_step * 0.5 * (below - above) / curvature
    return move


def _centre_moved(model: BodyModel, joint: str, axis: str, move: float) -> BodyModel:
    """`model` with the centre of `joint` (both sides) moved by `move` metres along body
    `axis` and re-skinned; `model` itself for no move."""
    if not move:
        return model
    name = f"centre:{joint}:{axis}"
    basis = ShapeBasis(p for p in ShapeBasis.standard(model.link_model).parameters if p.name == name)
    if not len(basis):
        raise OptionsError(f"SubjectOptions.centre_search: no shape parameter {name!r} for this model")
    return model.shaped(basis, [move]).reskinned()


def _limited(model: BodyModel, limits: dict) -> BodyModel:
    """`model` with the joint limits of `limits` (degrees by DOF name, both sides for a
    name without a side), the same mesh and skin."""
    links = model.link_model
    new = links.dof_limits.copy()
    for name, (lo, hi) in limits.items():
        try:
            new[links.dof_indices(name)] = np.radians([lo, hi])
        except ModelError as e:
            raise OptionsError(f"SubjectOptions.calibration_limits: {e}") from e
    return model.with_dof_limits(new)


def fitted_surface(model: BodyModel, hulls, poses, options: SubjectOptions = SubjectOptions()) -> BodyModel:
    """`model` with the subject's own surface: the template at the fitted shape is a
    person's proportions, not their shape (a belly, narrow shoulders, the bulk of a
    thigh). Each rest vertex moves along its rest normal by the median, over the
    `hulls` (:class:`~hullcap._mesh.Surface`) with the model at `poses`, of the distance
    along its posed normal to its nearest hull point (6-D, normals within
    ``options.surface_angle``, within ``options.surface_reach``), where at least
    ``options.surface_share`` of the hulls gave it one; the offsets are then smoothed over
    the mesh. The links and skin weights stay: only the surface moves. A hull is larger
    than the body where the views cannot see between parts; the median over frames of
    different poses keeps what most of them agree on."""
    o = options
    if o.surface_reach is None or not len(hulls):
        return model
    n = len(model.vertices)
    offsets = np.full((len(hulls), n), np.nan)
    for i, (hull, pose) in enumerate(zip(hulls, poses)):
        posed = model.pose(pose.theta, pose.root_rotation, pose.root_translation)
        found, _ = NormalKDTree(hull.vertices, hull.normals).query(
            posed.vertices, posed.normals, max_distance=o.surface_reach, max_angle=o.surface_angle)
        paired = found >= 0
        offsets[i, paired] = np.einsum("ij,ij->i", hull.vertices[found[paired]] - posed.vertices[paired],
                                       posed.normals[paired])
    seen = np.isfinite(offsets).sum(0) >= max(1.0, o.surface_share * len(hulls))
    offset = np.zeros(n)
    offset[seen] = np.nanmedian(offsets[:, seen], axis=0)
    offset = smoothed_over_mesh(offset, model.faces, o.surface_smoothing)
    b, k = model.skin_parameters
    return BodyModel(model.link_model, model.vertices + offset[:, None] * model.normals, model.faces,
                     skin=model.skin, b=b, k=k)


def with_hands(model: BodyModel, reach: float) -> BodyModel:
    """`model` with each hand (the vertices its forearm link, or its hand link where the
    hands turn at the wrists, carries most, beyond the wrist along the forearm) pulled
    toward the wrist to `reach` (0 < reach ≤ 1) of its length; the same skin weights and
    joints. `model` itself for a reach of 1 or a model without forearms and wrists. What
    tracking fits (``TrackerOptions.hand_reach``)."""
    FRACTION.check("hand reach", reach)
    links = model.link_model
    sides = [s for s in "lr" if f"{s}_forearm" in links.names and f"{s}_wrist" in links.joint_names]
    if reach == 1 or not sides:
        return model
    vertices = model.vertices
    index, weight = model.skin
    dominant = index[np.arange(len(index)), np.argmax(weight, axis=1)]
    for s in sides:
        forearm = links.names.index(f"{s}_forearm")
        wrist = links.joint_points[links.joint_names.index(f"{s}_wrist")]
        along = wrist - links.segments[forearm, 0]
        along = along / np.linalg.norm(along)
        beyond = (vertices - wrist) @ along
        carriers = [forearm] + ([links.names.index(f"{s}_hand")] if f"{s}_hand" in links.names else [])
        hand = np.isin(dominant, carriers) & (beyond > 0)
        vertices[hand] -= np.outer((1 - reach) * beyond[hand], along)
    b, k = model.skin_parameters
    return BodyModel(links, vertices, model.faces, skin=(index, weight), b=b, k=k)


def _height(vertices) -> float:
    return float(np.ptp(np.asarray(vertices)[:, 2]))


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
