"""Triangle meshes: the `Surface` type, normals, topology checks, and PLY / OBJ files.

A mesh is (V, 3) float vertices (metres) and (T, 3) integer faces, wound counter-clockwise
seen from outside. Files are written atomically (see :mod:`hullcap._files`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hullcap._files import atomic_write
from hullcap.errors import ArrayError, ModelError

__all__ = ["Surface", "face_normals", "vertex_normals", "check_closed", "is_closed", "smoothed_over_mesh", "read_mesh",
           "write_mesh"]


@dataclass(frozen=True)
class Surface:
    """A triangle mesh with unit vertex normals.

    Attributes:
        vertices: (V, 3) float64, metres.
        faces: (T, 3) int64 vertex indices, counter-clockwise seen from outside.
        normals: (V, 3) float64 unit outward normals.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray

    @classmethod
    def from_mesh(cls, vertices, faces) -> Surface:
        """A surface whose normals are the area-weighted normals of `faces`."""
        vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        return cls(vertices, faces, vertex_normals(vertices, faces))

    def subset(self, keep) -> Surface:
        """The surface of the vertices where `keep` (V,) bool is true, in their order, and
        of the faces whose three corners are all kept; the normals stay as they are."""
        keep = np.asarray(keep, bool)
        if keep.shape != (len(self.vertices),):
            raise ArrayError(f"keep has shape {keep.shape}, the surface {len(self.vertices)} vertices")
        number = np.cumsum(keep) - 1
        corners = keep[self.faces]
        # Three columns and-ed, and rows taken with `take`: NumPy's reduction over a short
        # last axis and its indexing of rows cost several times as much (every tracked
        # frame's hull is trimmed so, on the tracking thread).
        faces = self.faces.take(np.flatnonzero(corners[:, 0] & corners[:, 1] & corners[:, 2]), axis=0)
        rows = np.flatnonzero(keep)
        return Surface(self.vertices.take(rows, axis=0), number[faces], self.normals.take(rows, axis=0))


def face_normals(vertices: np.ndarray, faces: np.ndarray, unit: bool = True) -> np.ndarray:
    """(T, 3) triangle normals (right-handed in the winding): unit, or with length twice
    the triangle's area when ``unit=False``."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    if unit:
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return n


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V, 3) unit vertex normals, each the area-weighted mean of its triangles' normals
    (an unreferenced vertex gets +z)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    face_n = face_normals(v, f, unit=False)
    n = np.zeros_like(v)
    for corner in range(3):
        np.add.at(n, f[:, corner], face_n)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    n[length[:, 0] == 0] = (0.0, 0.0, 1.0)
    return n


def check_closed(vertices: np.ndarray, faces: np.ndarray) -> dict:
    """Topology of a mesh that should bound a solid.

    Returns a dict with ``closed`` (every edge in exactly two triangles, once in each
    direction: closed, manifold along edges and consistently oriented), ``euler``
    (V − E + T, 2 for a sphere-like surface), ``components`` and ``volume`` (signed,
    positive when the triangles face outwards).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    undirected = _undirected_edges(f)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
    return {
        "closed": is_closed(f),
        "euler": int(len(np.unique(f)) - len(undirected) + len(f)),
        "components": _components(len(v), undirected),
        "volume": volume,
    }


def is_closed(faces) -> bool:
    """Whether every edge of the triangles `faces` is in exactly two of them, once in each
    direction: the mesh is closed, manifold along its edges and consistently wound."""
    directed = _directed_edges(np.asarray(faces, dtype=np.int64))
    n = int(directed.max()) + 1 if directed.size else 0
    keys = directed[:, 0] * n + directed[:, 1]
    return bool(np.unique(keys).size == keys.size and np.isin(directed[:, 1] * n + directed[:, 0], keys).all())


def smoothed_over_mesh(values, faces, passes: int) -> np.ndarray:
    """(V,) `values` of the vertices smoothed `passes` times: each pass keeps half of a
    vertex's value and takes half the mean of its neighbours' (those it shares an edge
    with; a vertex without any keeps its value)."""
    values = np.asarray(values, float).copy()
    edges = _undirected_edges(np.asarray(faces, dtype=np.int64))
    if not passes or not len(edges):
        return values
    rows, cols = np.concatenate([edges[:, 0], edges[:, 1]]), np.concatenate([edges[:, 1], edges[:, 0]])
    degree = np.bincount(rows, minlength=len(values))
    lonely = degree == 0
    for _ in range(passes):
        mean = np.bincount(rows, weights=values[cols], minlength=len(values)) / np.maximum(degree, 1)
        values = np.where(lonely, values, 0.5 * values + 0.5 * mean)
    return values


def _directed_edges(f: np.ndarray) -> np.ndarray:
    """(3T, 2) the edges of the triangles `f`, each in its triangle's direction."""
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])


def _undirected_edges(f: np.ndarray) -> np.ndarray:
    """(E, 2) the edges of the triangles `f`, each once, its lower vertex first."""
    return np.unique(np.sort(_directed_edges(f), axis=1), axis=0)


def _components(n: int, edges: np.ndarray) -> int:
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in edges:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    used = np.unique(edges)
    return len({find(i) for i in used})


def write_mesh(path, vertices, faces, normals=None) -> None:
    """Write a mesh as PLY (binary little-endian) or OBJ, chosen by the file's suffix.

    Args:
        path: ``*.ply`` or ``*.obj``.
        vertices: (V, 3) metres.
        faces: (T, 3) vertex indices.
        normals: optional (V, 3) vertex normals, written with the vertices.
    """
    path = Path(path)
    vertices = _rows(vertices, "vertices", float)
    faces = _rows(faces, "faces", np.int64)
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ModelError(f"{path}: faces refer to vertices outside 0..{len(vertices) - 1}")
    if normals is not None:
        normals = _rows(normals, "normals", float)
        if len(normals) != len(vertices):
            raise ModelError(f"{path}: {len(normals)} normals for {len(vertices)} vertices")
    suffix = path.suffix.lower()
    if suffix == ".ply":
        data = _ply_bytes(vertices, faces, normals)
    elif suffix == ".obj":
        data = _obj_text(vertices, faces, normals).encode()
    else:
        raise ModelError(f"{path}: unknown mesh format {suffix!r} (use .ply or .obj)")
    atomic_write(path, data)


def read_mesh(path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a PLY (ASCII or binary, as :func:`write_mesh` and most tools write them) or an
    OBJ file: ``(vertices (V, 3) float64, faces (T, 3) int64, normals or None)``.
    Polygons with more than three corners are split into fans."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise ModelError(f"{path}: cannot read ({e.strerror})") from e
    suffix = path.suffix.lower()
    try:
        if suffix == ".ply":
            return _parse_ply(raw)
        if suffix == ".obj":
            return _parse_obj(raw.decode())
    except (ValueError, IndexError, struct.error, UnicodeDecodeError) as e:
        raise ModelError(f"{path}: not a readable {suffix[1:].upper()} mesh ({e})") from e
    raise ModelError(f"{path}: unknown mesh format {suffix!r} (use .ply or .obj)")


def _rows(a, name, dtype):
    a = np.asarray(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ModelError(f"{name} must have shape (N, 3), got {a.shape}")
    a = a.astype(dtype)
    if dtype is float and not np.isfinite(a).all():
        raise ModelError(f"{name} holds NaN or inf")
    return a


def _ply_bytes(vertices, faces, normals) -> bytes:
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals is not None else [])
    header = ["ply", "format binary_little_endian 1.0", "comment written by hullcap",
              f"element vertex {len(vertices)}"]
    header += [f"property float {p}" for p in props]
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    cols = vertices if normals is None else np.hstack([vertices, normals])
    vdata = np.ascontiguousarray(cols, dtype="<f4").tobytes()
    fdata = np.empty(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    fdata["n"] = 3
    fdata["i"] = faces
    return ("\n".join(header) + "\n").encode() + vdata + fdata.tobytes()


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}


def _parse_ply(raw: bytes):
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise ModelError("no PLY header")
    body_start = raw.index(b"\n", end) + 1
    lines = raw[:end].decode("ascii").splitlines()
    fmt = next(line.split()[1] for line in lines if line.startswith("format"))
    elements: list[tuple[str, int, list]] = []
    for line in lines:
        parts = line.split()
        if parts and parts[0] == "element":
            elements.append((parts[1], int(parts[2]), []))
        elif parts and parts[0] == "property":
            elements[-1][2].append(parts[1:])
    if fmt == "ascii":
        tokens = raw[body_start:].split()
        return _ply_elements(elements, ascii_tokens=iter(tokens))
    endian = "<" if fmt == "binary_little_endian" else ">"
    return _ply_elements(elements, binary=(raw, body_start, endian))


def _ply_elements(elements, ascii_tokens=None, binary=None):
    vertices = faces = normals = None
    offset = binary[1] if binary else 0
    for name, count, props in elements:
        if all(p[0] != "list" for p in props):
            if binary:
                dt = np.dtype([(p[1], binary[2] + _PLY_TYPES[p[0]]) for p in props])
                table = np.frombuffer(binary[0], dt, count, offset)
                offset += dt.itemsize * count
                cols = {p[1]: table[p[1]].astype(float) for p in props}
            else:
                flat = np.array([float(next(ascii_tokens)) for _ in range(count * len(props))])
                table = flat.reshape(count, len(props))
                cols = {p[1]: table[:, i] for i, p in enumerate(props)}
            if name == "vertex":
                vertices = np.stack([cols["x"], cols["y"], cols["z"]], 1)
                if {"nx", "ny", "nz"} <= cols.keys():
                    normals = np.stack([cols["nx"], cols["ny"], cols["nz"]], 1)
        else:
            if len(props) != 1:
                raise ModelError(f"element {name!r}: only a lone list property is supported")
            _, count_type, index_type, _ = props[0]
            polygons = []
            for _ in range(count):
                if binary:
                    ct = np.dtype(binary[2] + _PLY_TYPES[count_type])
                    n = int(np.frombuffer(binary[0], ct, 1, offset)[0])
                    offset += ct.itemsize
                    it = np.dtype(binary[2] + _PLY_TYPES[index_type])
                    polygons.append(np.frombuffer(binary[0], it, n, offset))
                    offset += it.itemsize * n
                else:
                    n = int(next(ascii_tokens))
                    polygons.append([int(next(ascii_tokens)) for _ in range(n)])
            if name == "face":
                faces = _fans(polygons)
    if vertices is None or faces is None:
        raise ModelError("no vertex or face element")
    return vertices, faces, normals


def _fans(polygons) -> np.ndarray:
    tris = [(p[0], p[i], p[i + 1]) for p in polygons for i in range(1, len(p) - 1)]
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


def _obj_text(vertices, faces, normals) -> str:
    out = ["# written by hullcap"]
    out += [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in vertices]
    if normals is not None:
        out += [f"vn {x:.6g} {y:.6g} {z:.6g}" for x, y, z in normals]
        out += [f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in faces + 1]
    else:
        out += [f"f {a} {b} {c}" for a, b, c in faces + 1]
    return "\n".join(out) + "\n"


def _parse_obj(text: str):
    vertices, normals, polygons = [], [], []
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            vertices.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vn":
            normals.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            polygons.append([i - 1 if i > 0 else len(vertices) + i for i in idx])
    if not vertices or not polygons:
        raise ModelError("no vertices or faces")
    v = np.array(vertices, dtype=np.float64)
    n = np.array(normals, dtype=np.float64) if len(normals) == len(vertices) else None
    return v, _fans(polygons), n
