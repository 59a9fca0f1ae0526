"""Synthetic multi-view sequences rendered by the project itself (docs/design.md §11).

:func:`render_sequence` renders any triangle-mesh sequence in a set of cameras into a
sequence folder (docs/formats.md): colour frames of the subject over a textured scene (a
checkered floor, a panelled backdrop) with a soft floor shadow and sensor noise, the empty
scene as background images, and ``truth/`` with the exact silhouettes and whatever ground
truth it is given. :func:`synthesize` drives the template body through a scripted motion
(:mod:`hullcap._motions`) with chosen proportions and renders it.
"""

from __future__ import annotations

import math
import json
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

from hullcap._body import BodyModel
from hullcap._cameras import Cameras, ring
from hullcap._files import atomic_write
from hullcap._mesh import face_normals
from hullcap._motions import motion_poses
from hullcap._progress import progress
from hullcap._options import AT_LEAST_ONE, or_none
from hullcap._render import render_depth, render_silhouette
from hullcap.errors import OptionsError, SequenceError

__all__ = ["render_sequence", "render_motion", "synthesize", "SUBJECTS"]

SUBJECTS = {
    "template": ({}, {}),
    "tall": ({"torso": 1.05, "l_thigh": 1.08, "r_thigh": 1.08, "l_shin": 1.08, "r_shin": 1.08,
              "l_upper_arm": 1.06, "r_upper_arm": 1.06, "l_forearm": 1.05, "r_forearm": 1.05},
             {"torso": 0.92, "pelvis": 0.95, "l_thigh": 0.9, "r_thigh": 0.9, "l_upper_arm": 0.9, "r_upper_arm": 0.9}),
    "short": ({"torso": 0.95, "l_thigh": 0.92, "r_thigh": 0.92, "l_shin": 0.93, "r_shin": 0.93,
               "l_upper_arm": 0.94, "r_upper_arm": 0.94, "l_forearm": 0.95, "r_forearm": 0.95},
              {"torso": 1.12, "pelvis": 1.08, "l_thigh": 1.12, "r_thigh": 1.12, "l_shin": 1.1, "r_shin": 1.1,
               "l_upper_arm": 1.1, "r_upper_arm": 1.1, "l_forearm": 1.08, "r_forearm": 1.08}),
}
"""Body proportions (per-segment length and girth scales) of the synthetic subjects."""

LIGHT = np.array([0.35, 0.25, 1.0]) / np.linalg.norm([0.35, 0.25, 1.0])
"""Direction towards the light (world): casts the floor shadow."""

CLOTHES = {"shirt": (0.20, 0.45, 0.75), "trousers": (0.55, 0.22, 0.20), "skin": (0.85, 0.65, 0.52),
           "shoes": (0.85, 0.55, 0.15)}
_LINK_CLOTHES = {"torso": "shirt", "l_clavicle": "shirt", "r_clavicle": "shirt", "l_upper_arm": "shirt",
                 "r_upper_arm": "shirt", "pelvis": "trousers", "l_thigh": "trousers", "r_thigh": "trousers",
                 "l_shin": "trousers", "r_shin": "trousers", "l_foot": "shoes", "r_foot": "shoes"}


def body_colours(model: BodyModel) -> np.ndarray:
    """(V, 3) clothing colours in [0, 1] by each vertex's strongest link."""
    names = model.link_model.names
    palette = np.array([CLOTHES[_LINK_CLOTHES.get(n, "skin")] for n in names])
    return palette[model.skin[0][:, 0]]


def scene_image(camera, seed: int = 0) -> np.ndarray:
    """The empty scene as `camera` sees it, (H, W, 3) float RGB in [0, 1]: a checkered
    floor (0.5 m tiles) and a backdrop of coloured panels 7 m from the centre."""
    h, w = camera.height, camera.width
    vv, uu = np.mgrid[0:h, 0:w]
    origin, d = camera.rays(np.stack([uu.ravel(), vv.ravel()], 1).astype(float))
    rng = np.random.default_rng(seed)
    img = np.empty((h * w, 3))
    # Backdrop: a vertical cylinder of radius 7 m around the origin.
    ox, oy = origin[0], origin[1]
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2 * (ox * d[:, 0] + oy * d[:, 1])
    c = ox**2 + oy**2 - 49.0
    s_wall = (-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0))) / np.maximum(2 * a, 1e-12)
    s_floor = np.where(d[:, 2] < -1e-9, -origin[2] / np.where(d[:, 2] < -1e-9, d[:, 2], -1), np.inf)
    floor = s_floor < s_wall
    p = origin + d * np.where(floor, s_floor, s_wall)[:, None]
    tiles = (np.floor(p[:, 0] / 0.5) + np.floor(p[:, 1] / 0.5)) % 2
    floor_rgb = np.where(tiles[:, None] > 0, (0.62, 0.60, 0.56), (0.42, 0.41, 0.40))
    panel_colours = rng.uniform(0.25, 0.85, size=(24, 3))
    angle = (np.arctan2(p[:, 1], p[:, 0]) + np.pi) / (2 * np.pi)
    panel = panel_colours[(angle * 24).astype(int) % 24]
    band = 0.85 + 0.15 * np.sin(p[:, 2] * 9.0)
    img[:] = np.where(floor[:, None], floor_rgb, panel * band[:, None])
    img = img.reshape(h, w, 3)
    texture = cv2.GaussianBlur(rng.normal(0, 0.04, (h, w, 1)).astype(np.float32), (0, 0), 2.0)
    return np.clip(img * (1 + texture.reshape(h, w, 1)), 0, 1)


def _draw(camera, vertices, faces, colours, scene, noise, rng):
    """(colour uint8 BGR, exact mask uint8) of one view."""
    _, face = render_depth(camera, vertices, faces)
    # The shadow: the mesh flattened onto the floor along the light, seen by the camera.
    flat = vertices - np.outer(np.maximum(vertices[:, 2], 0) / LIGHT[2], LIGHT)
    shadow = cv2.GaussianBlur(render_silhouette(camera, flat, faces).astype(np.float32), (0, 0), 3.0)
    img = scene * (1 - 0.45 * shadow[..., None])
    seen = face >= 0
    if seen.any():
        n = face_normals(vertices, faces)
        light = 0.45 + 0.45 * np.clip(n @ LIGHT, 0, 1) + 0.1 * np.clip(n[:, 2], 0, 1)
        shaded = light[:, None] * colours[faces].mean(1)  # per triangle, then looked up
        img[seen] = shaded[face[seen]]
    out = img * 255 + rng.normal(0, noise, img.shape)
    return np.clip(out, 0, 255).astype(np.uint8)[..., ::-1], (seen * 255).astype(np.uint8)


def render_sequence(out, cameras: Cameras, frames: Iterable[np.ndarray], faces, n_frames: int,
                    colours=None, fps: float = 30.0, noise: float = 2.0, seed: int = 0,
                    silhouettes: bool = False, truth: dict | None = None,
                    show_progress: bool = True) -> Path:
    """Render a mesh sequence into a sequence folder.

    Args:
        out: the folder to write (created; existing frames are overwritten).
        cameras: the calibration, written as ``cameras.json``.
        frames: an iterable of (V, 3) world vertices, one per time step (streamed).
        faces: (T, 3) triangles shared by all frames.
        n_frames: how many frames `frames` yields (for meta.json and the progress bar).
        colours: (V, 3) vertex colours in [0, 1] (default: a light grey).
        fps: frame rate written to meta.json.
        noise: standard deviation of the sensor noise, grey levels.
        silhouettes: also write the exact masks to ``silhouettes/`` (the tracker then uses
            them instead of background subtraction); they always go to
            ``truth/silhouettes/``.
        truth: arrays for ``truth/``: ``joints`` (F, J, 3) with ``joint_names``, and
            ``pose`` (a dict written as ``truth/pose.npz``).

    Returns:
        The sequence folder.
    """
    out = Path(out)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    rng = np.random.default_rng(seed)
    (out / "truth").mkdir(parents=True, exist_ok=True)
    cameras.save(out / "cameras.json")
    atomic_write(out / "meta.json", json.dumps({"fps": fps, "frames": int(n_frames)}).encode())
    scenes = [scene_image(cam, seed + i) for i, cam in enumerate(cameras)]
    for cam, scene in zip(cameras, scenes):
        bg = np.clip(scene * 255 + rng.normal(0, noise, scene.shape), 0, 255).astype(np.uint8)
        _imwrite(out / "background" / f"{cam.name}.png", bg[..., ::-1])
    vertices_out = None
    count = 0
    for i, vertices in enumerate(progress(frames, total=n_frames, desc=f"render {out.name}", enable=show_progress)):
        vertices = np.asarray(vertices, dtype=np.float64)
        if colours is None:
            colours = np.full((len(vertices), 3), 0.7)
        if vertices_out is None:
            vertices_out = np.lib.format.open_memmap(out / "truth" / "vertices.npy", mode="w+",
                                                     dtype=np.float32, shape=(n_frames, len(vertices), 3))
        vertices_out[i] = vertices
        for cam, scene in zip(cameras, scenes):
            colour, mask = _draw(cam, vertices, faces, np.asarray(colours), scene, noise, rng)
            name = f"{i:06d}.png"
            _imwrite(out / "frames" / cam.name / name, colour)
            _imwrite(out / "truth" / "silhouettes" / cam.name / name, mask)
            if silhouettes:
                _imwrite(out / "silhouettes" / cam.name / name, mask)
        count += 1
    if count != n_frames:
        raise SequenceError(f"frames yielded {count} meshes, n_frames says {n_frames}")
    if vertices_out is not None:
        vertices_out.flush()
    np.save(out / "truth" / "faces.npy", faces.astype(np.int32))
    truth = truth or {}
    if "joints" in truth:
        np.savez(out / "truth" / "joints.npz", names=np.array(truth["joint_names"]),
                 positions=np.asarray(truth["joints"]))
    if "pose" in truth:
        np.savez(out / "truth" / "pose.npz", **truth["pose"])
    return out


def synthesize(out, motion: str = "demo", cameras: int | Cameras = 8, subject: str = "tall",
               fps: float = 30.0, noise: float = 2.0, seed: int = 0, silhouettes: bool = False,
               width: int = 640, height: int = 480, frames: int | None = None,
               show_progress: bool = True) -> Path:
    """Render the template body with `subject`'s proportions through a scripted `motion`.

    Args:
        out: the sequence folder to write.
        motion: a name from :data:`hullcap._motions.MOTIONS`.
        cameras: a calibration, or the number of cameras on a ring (:func:`~hullcap._cameras.ring`).
        subject: a name from :data:`SUBJECTS` (proportions unlike the template's own).
        frames: keep only the first this many frames (default: the whole motion).

    Returns:
        The sequence folder, with ``truth/`` holding the true joints, pose and vertices.
    """
    if subject not in SUBJECTS:
        raise OptionsError(f"unknown subject {subject!r}; subjects: {sorted(SUBJECTS)}")
    if not (0 < fps < math.inf and 0 <= noise < math.inf):
        raise OptionsError(f"fps must be a positive number and noise (grey levels) a number >= 0, "
                           f"got {fps} and {noise}")
    or_none(AT_LEAST_ONE).check("frames", frames)
    if isinstance(cameras, int):
        cameras = ring(cameras, width=width, height_px=height)
    model = BodyModel.template()
    lengths, girths = SUBJECTS[subject]
    model = model.scaled(lengths, girths)
    theta, rot, trans = motion_poses(motion, model.dof_names, fps, model.rest_root_height)
    if frames is not None:
        theta, rot, trans = theta[:frames], rot[:frames], trans[:frames]
    seq = render_motion(out, cameras, model, theta, rot, trans, fps, noise, seed, silhouettes, show_progress)
    (seq / "truth" / "subject.json").write_text(json.dumps({"subject": subject, "motion": motion,
                                                            "lengths": lengths, "girths": girths}))
    return seq


def render_motion(out, cameras: Cameras, model: BodyModel, theta, root_rotation, root_translation,
                  fps: float = 30.0, noise: float = 2.0, seed: int = 0, silhouettes: bool = False,
                  show_progress: bool = True) -> Path:
    """Render `model` through the poses (theta (F, D), root_rotation (F, 3, 3),
    root_translation (F, 3)) into the sequence folder `out`, with ``truth/`` (the true
    joints in ``joints.npz``, the pose and the model); returns the folder."""
    joints = []

    def meshes():
        for th, r, t in zip(theta, root_rotation, root_translation):
            pose = model.pose(th, r, t)
            joints.append(pose.joints)
            yield pose.vertices

    seq = render_sequence(out, cameras, meshes(), model.faces, len(theta), body_colours(model), fps,
                          noise, seed, silhouettes, show_progress=show_progress)
    truth = {"root_translation": root_translation, "root_rotation": root_rotation, "theta": theta,
             "dof_names": np.array(model.dof_names), "joint_names": np.array(model.joint_names),
             "failed": np.zeros(len(theta), bool)}
    np.savez(seq / "truth" / "pose.npz", **truth)
    np.savez(seq / "truth" / "joints.npz", names=np.array(model.joint_names), positions=np.array(joints))
    model.save(seq / "truth" / "model")
    return seq


def _imwrite(path: Path, image: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), image):
        raise OSError(f"{path}: could not write the image")
