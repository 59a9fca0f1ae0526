"""Drawing meshes as cameras see them: z-buffer (engine), silhouettes and shaded pictures.

The engine rasterises triangles already projected to pixels (:func:`hullcap._engine.
rasterize`, or :func:`hullcap._engine.coverage` where only the silhouette is wanted);
vertices are projected here with the camera's distortion, so straight edges between
projected vertices stand in for the slightly curved images of triangle edges.
"""

from __future__ import annotations

import numpy as np

from hullcap._cameras import Camera
from hullcap._engine import coverage, rasterize
from hullcap._mesh import face_normals
from hullcap._threads import over_views

__all__ = ["render_depth", "render_silhouette", "model_silhouettes", "shade"]

SKIN = (0.82, 0.66, 0.55)


def model_silhouettes(cameras, model, pose, also=None) -> list[np.ndarray]:
    """`model`'s (H, W) bool silhouette at `pose` (:class:`~hullcap._fitting.PoseParameters`)
    in every one of `cameras`, united with its silhouette at `also` when given; the views
    drawn in parallel."""
    faces, closed = model.faces, model.closed
    posed = [model.pose(p.theta, p.root_rotation, p.root_translation).vertices for p in (pose, also) if p is not None]

    def drawn(cam):
        silhouettes = [render_silhouette(cam, v, faces, closed=closed) for v in posed]
        return silhouettes[0] if len(silhouettes) == 1 else np.logical_or.reduce(silhouettes)
    return over_views(drawn, cameras)


def render_depth(camera: Camera, vertices, faces, threads: int | None = None):
    """``(depth (H, W) float32 metres, inf where empty; face (H, W) int32, −1 where
    empty)`` of the mesh seen by `camera`."""
    return rasterize(*_projected(camera, vertices, faces), 1e-3, threads)


def render_silhouette(camera: Camera, vertices, faces, threads: int | None = None,
                      closed: bool = False) -> np.ndarray:
    """(H, W) bool: where `camera` sees the mesh (``render_depth``'s ``face >= 0``, pixel
    for pixel, without the depths). `closed`: the mesh bounds a solid in front of the
    camera (:func:`~hullcap._mesh.is_closed`), so that the triangles of one winding
    alone cover it and only those are drawn (docs/design.md §6)."""
    return coverage(*_projected(camera, vertices, faces), 1e-3, threads, closed).view(bool)


def _projected(camera: Camera, vertices, faces):
    """``(uvz, faces, width, height)``: the engine's arguments for the mesh in `camera`."""
    pixels, z = camera.project(vertices)
    return np.concatenate([pixels, z[:, None]], 1), faces, camera.width, camera.height


def shade(camera: Camera, vertices, faces, colour=SKIN, background=(1.0, 1.0, 1.0),
          threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A Lambert-shaded picture of the mesh (a light at the camera plus a soft fill), as
    ``(rgb (H, W, 3) float in [0, 1], face (H, W) int32)``."""
    vertices = np.asarray(vertices, float)
    faces = np.asarray(faces)
    _, face = render_depth(camera, vertices, faces, threads)
    n = face_normals(vertices, faces)
    to_camera = camera.centre - vertices[faces].mean(1)
    to_camera /= np.linalg.norm(to_camera, axis=1, keepdims=True)
    key = np.clip(np.einsum("ij,ij->i", n, to_camera), 0, 1)
    fill = np.clip(n[:, 2], 0, 1)
    light = 0.25 + 0.6 * key + 0.15 * fill
    img = np.empty(face.shape + (3,))
    img[:] = background
    seen = face >= 0
    img[seen] = light[face[seen], None] * np.asarray(colour)
    return img, face
