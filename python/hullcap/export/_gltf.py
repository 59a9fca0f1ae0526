"""glTF 2.0 binary (``model.glb``): the subject's skinned mesh and its fitted motion.

One glTF node per link of the model, in the link tree, at its rest offset; the mesh is
skinned to them with the model's own 4 weights per vertex and inverse bind matrices
(the rest pose has no rotations, so each is a translation by −(joint centre)). The
animation turns every link node (its rotation relative to its parent) and moves the root
node, one keyframe per frame. glTF's world is y-up: everything hangs under a node that
turns our z-up world into it, so a viewer shows the subject standing.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.export._motion import Z_UP_TO_Y_UP, local_motion

__all__ = ["write_glb"]


_FLOAT, _UINT16, _UINT32 = 5126, 5123, 5125


def quaternion(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations → (..., 4) unit quaternions (x, y, z, w), w ≥ 0."""
    R = np.asarray(R, float)
    w = np.sqrt(np.maximum(0.0, 1 + R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2])) / 2
    x = np.sqrt(np.maximum(0.0, 1 + R[..., 0, 0] - R[..., 1, 1] - R[..., 2, 2])) / 2
    y = np.sqrt(np.maximum(0.0, 1 - R[..., 0, 0] + R[..., 1, 1] - R[..., 2, 2])) / 2
    z = np.sqrt(np.maximum(0.0, 1 - R[..., 0, 0] - R[..., 1, 1] + R[..., 2, 2])) / 2
    x = np.copysign(x, R[..., 2, 1] - R[..., 1, 2])
    y = np.copysign(y, R[..., 0, 2] - R[..., 2, 0])
    z = np.copysign(z, R[..., 1, 0] - R[..., 0, 1])
    q = np.stack([x, y, z, w], -1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


class _Blob:
    """The binary chunk and the accessors that point into it."""

    def __init__(self):
        self.data = bytearray()
        self.views, self.accessors = [], []

    def add(self, array, component, kind, target=None, bounds=False) -> int:
        array = np.ascontiguousarray(array)
        while len(self.data) % 4:
            self.data.append(0)
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": array.nbytes}
        if target:
            view["target"] = target
        self.data += array.tobytes()
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": component,
               "count": int(array.shape[0]), "type": kind}
        if bounds:
            flat = array.reshape(array.shape[0], -1)
            acc["min"] = flat.min(0).tolist()
            acc["max"] = flat.max(0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1


def write_glb(path, model, root_translation, root_rotation, theta, fps: float) -> None:
    """Write the skinned model with its motion (F frames; failed frames, NaN, hold the
    last good pose) as a glTF 2.0 binary, atomically."""
    links = model.link_model
    n_links = len(links.names)
    blob = _Blob()
    # Mesh, in the body frame at rest.
    index, weight = model.skin
    k = index.shape[1]
    joints4 = np.zeros((len(index), 4), np.uint16)
    weights4 = np.zeros((len(index), 4), np.float32)
    keep = min(k, 4)
    joints4[:, :keep] = index[:, :keep]
    weights4[:, :keep] = weight[:, :keep]
    weights4 /= weights4.sum(1, keepdims=True)
    attributes = {
        "POSITION": blob.add(model.vertices.astype(np.float32), _FLOAT, "VEC3", 34962, bounds=True),
        "NORMAL": blob.add(model.normals.astype(np.float32), _FLOAT, "VEC3", 34962),
        "JOINTS_0": blob.add(joints4, _UINT16, "VEC4", 34962),
        "WEIGHTS_0": blob.add(weights4, _FLOAT, "VEC4", 34962),
    }
    indices = blob.add(model.faces.astype(np.uint32).reshape(-1), _UINT32, "SCALAR", 34963, bounds=True)
    ibm = np.tile(np.eye(4, dtype=np.float32), (n_links, 1, 1))
    ibm[:, :3, 3] = -links.origins
    ibm_acc = blob.add(ibm.transpose(0, 2, 1).reshape(n_links, 16), _FLOAT, "MAT4")  # column-major
    # Nodes: 0 = the z-up → y-up frame, 1..L = links, L+1 = the mesh.
    nodes = [{"name": "hullcap_world_z_up", "rotation": quaternion(Z_UP_TO_Y_UP).tolist(), "children": [1]}]
    for j, name in enumerate(links.names):
        p = links.parents[j]
        offset = links.origins[j] - (links.origins[p] if p >= 0 else 0.0)
        node = {"name": links.joints[j], "translation": offset.tolist()}
        kids = [1 + c for c in range(n_links) if links.parents[c] == j]
        if kids:
            node["children"] = kids
        nodes.append(node)
    nodes.append({"name": "body", "mesh": 0, "skin": 0})
    # Animation: local rotations of every link, the root's translation.
    local, root_pos = local_motion(path, model, root_translation, root_rotation, theta)
    frames = len(local)
    times = blob.add((np.arange(frames) / fps).astype(np.float32), _FLOAT, "SCALAR", bounds=True)
    samplers, channels = [], []
    for j in range(n_links):
        q = quaternion(local[:, j]).astype(np.float32)
        samplers.append({"input": times, "output": blob.add(q, _FLOAT, "VEC4"), "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": 1 + j, "path": "rotation"}})
    samplers.append({"input": times, "output": blob.add(root_pos.astype(np.float32), _FLOAT, "VEC3"),
                     "interpolation": "LINEAR"})
    channels.append({"sampler": len(samplers) - 1, "target": {"node": 1, "path": "translation"}})
    doc = {
        "asset": {"version": "2.0", "generator": "hullcap"},
        "scene": 0,
        "scenes": [{"nodes": [0, n_links + 1]}],
        "nodes": nodes,
        "meshes": [{"name": "subject", "primitives": [{"attributes": attributes, "indices": indices, "mode": 4}]}],
        "skins": [{"joints": list(range(1, n_links + 1)), "inverseBindMatrices": ibm_acc, "skeleton": 1}],
        "animations": [{"name": "fitted motion", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": len(blob.data)}],
        "bufferViews": blob.views,
        "accessors": blob.accessors,
    }
    atomic_write(Path(path), _glb(doc, bytes(blob.data)))


def _glb(doc: dict, binary: bytes) -> bytes:
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON") + text
            + struct.pack("<I4s", len(binary), b"BIN\0") + binary)
