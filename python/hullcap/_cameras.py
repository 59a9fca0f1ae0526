"""Calibrated cameras: OpenCV's pinhole model with distortion (docs/formats.md, cameras.json).

A world point X (metres, z up) maps to camera coordinates x = R·X + t, then to pixels by
K after the distortion dist = [k1, k2, p1, p2, k3]. Pixel (0, 0) is the centre of the
top-left pixel. Besides our own ``cameras.json``, the calibrations of EasyMocap
(OpenCV FileStorage ``intri.yml`` + ``extri.yml``) and Pose2Sim (``Calib.toml``) import.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from hullcap._files import atomic_write, read_document
from hullcap._options import FRACTION
from hullcap.errors import CalibrationError, HullError

__all__ = ["Camera", "Cameras", "ring", "parse_size", "check_principal_point", "capture_volume", "axes_meeting_point",
           "check_bounds", "format_bounds"]

ROTATION_TOLERANCE = 1e-3
"""Largest |RRᵀ − I| accepted for a camera's rotation: calibration files round (5 decimals
give about 1e-5), and the nearest rotation is used; a real non-rotation is far beyond."""

PRINCIPAL_POINT_TOLERANCE = 0.25
"""An imported camera whose principal point lies further than this fraction of the image's
width or height from its centre is refused: the image size is most likely swapped."""

UNDISTORT_ITERATIONS = 50
UNDISTORT_TOLERANCE = 1e-12
"""Newton's iterations, at most, and the residual (normalised image coordinates) at which
:meth:`Camera.rays` stops removing the distortion: a lens of k1 within ±0.3 converges in a
handful."""

Y_UP_TO_Z_UP = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
"""Maps a y-up world (x right, y up, z towards the viewer) to ours (z up)."""


@dataclass(frozen=True)
class Camera:
    """One calibrated camera.

    Attributes:
        name: unique name; the sequence's folders are named after it.
        width, height: image size in pixels.
        K: (3, 3) intrinsics, upper-triangular, positive focal lengths.
        dist: (5,) distortion [k1, k2, p1, p2, k3].
        R: (3, 3) world → camera rotation; t: (3,) world → camera translation (metres).
    """

    name: str
    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray

    def __post_init__(self):
        where = f"camera {self.name!r}"
        for attr, shape in (("K", (3, 3)), ("dist", (5,)), ("R", (3, 3)), ("t", (3,))):
            try:
                value = np.array(getattr(self, attr), dtype=np.float64)
            except (TypeError, ValueError):
                raise CalibrationError(f"{where}: {attr} is not numeric") from None
            if attr == "dist" and value.ndim <= 1 and value.size < 5:  # [k1 k2 p1 p2]: k3 = 0
                value = np.concatenate([value.ravel(), np.zeros(5 - value.size)])
            if value.shape != shape:
                raise CalibrationError(f"{where}: {attr} must be {shape} numbers, got shape {value.shape}")
            if not np.isfinite(value).all():
                raise CalibrationError(f"{where}: {attr} must be finite numbers, got {value.tolist()}")
            value.setflags(write=False)
            object.__setattr__(self, attr, value)
        if not isinstance(self.name, str) or not self.name or "/" in self.name:
            raise CalibrationError(f"{where}: name must be a non-empty string without '/'")
        for attr in ("width", "height"):
            value = getattr(self, attr)
            whole = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool) \
                and math.isfinite(value) and value == int(value) > 0
            if not whole:
                raise CalibrationError(f"{where}: {attr} must be a positive whole number of pixels, got {value!r}"
                                       + (f" (a {type(value).__name__})" if isinstance(value, str | bool) else ""))
            object.__setattr__(self, attr, int(value))
        K = self.K
        if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
            raise CalibrationError(f"{where}: K must be upper-triangular with K[2,2] = 1, got {K.tolist()}")
        if not (K[0, 0] > 0 and K[1, 1] > 0):
            raise CalibrationError(f"{where}: K's focal lengths must be positive, got {K[0, 0]}, {K[1, 1]}")
        R = self.R
        error = np.abs(R @ R.T - np.eye(3)).max()
        if error > ROTATION_TOLERANCE or not np.linalg.det(R) > 0:
            raise CalibrationError(f"{where}: R is not a rotation (det = {np.linalg.det(R):.4g}, "
                                   f"|RRᵀ − I| = {error:.2g}, more than {ROTATION_TOLERANCE:g})")
        if error > 1e-9:  # written with few decimals: the nearest rotation (rounding noise kept as is)
            u, _, vt = np.linalg.svd(R)
            R = u @ vt
            R.setflags(write=False)
            object.__setattr__(self, "R", R)

    @property
    def centre(self) -> np.ndarray:
        """(3,) the camera's optical centre in the world, −Rᵀt."""
        return -self.R.T @ self.t

    def to_camera(self, points) -> np.ndarray:
        """(N, 3) world points in this camera's frame."""
        return np.asarray(points, dtype=np.float64) @ self.R.T + self.t

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """World points (N, 3) → ``(pixels (N, 2), depth (N,))``, with distortion.
        Points behind the camera get a negative depth (their pixels are meaningless)."""
        x = self.to_camera(points)
        z = x[:, 2]
        safe = np.where(np.abs(z) > 1e-12, z, 1e-12)
        a, b = self._distorted(x[:, 0] / safe, x[:, 1] / safe)
        K = self.K
        u = K[0, 0] * a + K[0, 1] * b + K[0, 2]
        v = K[1, 1] * b + K[1, 2]
        return np.stack([u, v], 1), z

    def _distorted(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised image coordinates (x/z, y/z) → the same after the lens distortion
        (Brown–Conrady: radial k1, k2, k3 and tangential p1, p2, as OpenCV has it)."""
        if not self.dist.any():
            return a, b
        k1, k2, p1, p2, k3 = self.dist
        r2 = a * a + b * b
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return (a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a),
                b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b)

    def _undistorted(self, a_d: np.ndarray, b_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The inverse of :meth:`_distorted`, by Newton's method from the distorted point
        (the map has no closed-form inverse). Written here rather than taken from OpenCV,
        whose ``undistortPoints`` changed its signature between 4.x and 5.x."""
        if not self.dist.any():
            return a_d, b_d
        k1, k2, p1, p2, k3 = self.dist
        a, b = a_d.copy(), b_d.copy()
        for _ in range(UNDISTORT_ITERATIONS):
            fa, fb = self._distorted(a, b)
            ra, rb = fa - a_d, fb - b_d
            if max(np.abs(ra).max(initial=0), np.abs(rb).max(initial=0)) < UNDISTORT_TOLERANCE:
                break
            r2 = a * a + b * b
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            d_radial = k1 + r2 * (2 * k2 + 3 * r2 * k3)  # d radial / d r2
            # The Jacobian of the distortion, d(fa, fb) / d(a, b).
            jaa = radial + 2 * a * a * d_radial + 2 * p1 * b + 6 * p2 * a
            jab = 2 * a * b * d_radial + 2 * p1 * a + 2 * p2 * b
            jba = 2 * a * b * d_radial + 2 * p1 * a + 2 * p2 * b
            jbb = radial + 2 * b * b * d_radial + 6 * p1 * b + 2 * p2 * a
            det = jaa * jbb - jab * jba
            det = np.where(np.abs(det) > 1e-12, det, 1e-12)
            a = a - (jbb * ra - jab * rb) / det
            b = b - (jaa * rb - jba * ra) / det
        return a, b

    def rays(self, pixels) -> tuple[np.ndarray, np.ndarray]:
        """Back-projection: pixels (N, 2) → ``(origin (3,), unit directions (N, 3))`` in
        the world, distortion removed."""
        pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        K = self.K
        b_d = (pixels[:, 1] - K[1, 2]) / K[1, 1]
        a_d = (pixels[:, 0] - K[0, 2] - K[0, 1] * b_d) / K[0, 0]
        a, b = self._undistorted(a_d, b_d)
        d = np.stack([a, b, np.ones_like(a)], 1) @ self.R
        return self.centre, d / np.linalg.norm(d, axis=1, keepdims=True)

    def scaled(self, factor: float) -> Camera:
        """The same camera seeing its images resized by `factor` (``cv2.resize`` to
        round(width · factor) × round(height · factor)): the focal lengths and skew scaled by
        each axis's own ratio of sizes, the principal point mapped as a pixel centre is,
        (c + ½) · ratio − ½. The distortion acts on normalised coordinates and stays."""
        FRACTION.check("image scale", factor, where=f"camera {self.name!r}", error=CalibrationError)
        width, height = max(1, round(self.width * factor)), max(1, round(self.height * factor))
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        K[0, :2] *= sx
        K[1, 1] *= sy
        K[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
        K[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
        return Camera(self.name, width, height, K, self.dist, self.R, self.t)

    def to_dict(self) -> dict:
        return {"name": self.name, "width": self.width, "height": self.height,
                "K": self.K.tolist(), "dist": self.dist.tolist(), "R": self.R.tolist(),
                "t": self.t.tolist()}


class Cameras(Sequence[Camera]):
    """An ordered set of cameras with unique names."""

    def __init__(self, cameras: Sequence[Camera]):
        if isinstance(cameras, str | os.PathLike):
            raise TypeError(f"Cameras takes Camera objects; for the file {str(cameras)!r} use Cameras.load")
        self._cameras = tuple(cameras)
        wrong = [type(c).__name__ for c in self._cameras if not isinstance(c, Camera)]
        if wrong:
            raise TypeError(f"Cameras takes Camera objects, got a {wrong[0]}")
        names = [c.name for c in self._cameras]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise CalibrationError(f"camera names must be unique; repeated: {sorted(dup)}")
        if not self._cameras:
            raise CalibrationError("no cameras")
        self._derived: dict = {}

    def __len__(self) -> int:
        return len(self._cameras)

    def __getitem__(self, i):
        if isinstance(i, str):
            for c in self._cameras:
                if c.name == i:
                    return c
            raise KeyError(f"no camera named {i!r}; cameras are {self.names}")
        if isinstance(i, slice):
            return Cameras(self._cameras[i])
        return self._cameras[i]

    def __iter__(self) -> Iterator[Camera]:
        return iter(self._cameras)

    def __repr__(self) -> str:
        return f"Cameras({', '.join(self.names)})"

    def derived(self, key, compute):
        """What is derived from the calibration alone (the capture volume), computed by
        ``compute()`` the first time `key` is asked for and kept (the cameras never change)."""
        if key not in self._derived:
            self._derived[key] = compute()
        return self._derived[key]

    @property
    def names(self) -> list[str]:
        return [c.name for c in self._cameras]

    def scaled(self, factor: float) -> Cameras:
        """Every camera :meth:`Camera.scaled`; `factor` 1 gives these cameras."""
        return self if factor == 1 else Cameras([c.scaled(factor) for c in self._cameras])

    def subset(self, keep=None, leave_out=()) -> Cameras:
        """The cameras named in `keep` (every one when ``None``) less those named in
        `leave_out`, in this set's order. A name that is not a camera of the set, or one
        given twice, is a :class:`CalibrationError` naming it and the set's cameras; so is
        a subset without a camera."""
        names = self.names
        if isinstance(keep, str) or isinstance(leave_out, str):
            raise TypeError(f"camera names come as a list, e.g. [{(keep or leave_out)!r}]")
        asked = [*([] if keep is None else keep), *leave_out]
        for name in asked:
            if not isinstance(name, str):
                raise TypeError(f"camera names are strings, got {name!r}")
        unknown = [name for name in asked if name not in names]
        if unknown:
            raise CalibrationError(f"no camera named {', '.join(map(repr, unknown))}; the cameras are "
                                   f"{', '.join(names)}")
        repeated = sorted({name for name in asked if asked.count(name) > 1})
        if repeated:
            raise CalibrationError(f"camera {', '.join(map(repr, repeated))} named twice")
        chosen = [c for c in self._cameras if (keep is None or c.name in keep) and c.name not in leave_out]
        if not chosen:
            raise CalibrationError(f"no camera left of {', '.join(names)}")
        return self if len(chosen) == len(self._cameras) else Cameras(chosen)

    # -- our format -----------------------------------------------------------------------

    @classmethod
    def load(cls, path) -> Cameras:
        """Read ``cameras.json`` (docs/formats.md); errors name the file, camera and field."""
        path = Path(path)
        spec = read_document(path, CalibrationError)
        if spec.get("units", "m") != "m":
            raise CalibrationError(f"{path}: units must be 'm', got {spec.get('units')!r}")
        if not isinstance(spec.get("cameras"), list):
            raise CalibrationError(f"{path}: needs a 'cameras' list")
        cams = []
        for i, c in enumerate(spec["cameras"]):
            if not isinstance(c, dict):
                raise CalibrationError(f"{path}: camera #{i} is not an object")
            try:
                missing = [k for k in ("name", "width", "height", "K", "R", "t") if k not in c]
                if missing:
                    raise CalibrationError(f"camera {c.get('name', f'#{i}')!r}: missing {missing}")
                cams.append(Camera(c["name"], c["width"], c["height"], c["K"],
                                   c.get("dist", np.zeros(5)), c["R"], c["t"]))
            except CalibrationError as e:
                raise CalibrationError(f"{path}: {e}") from None
            except (TypeError, ValueError, OverflowError) as e:
                raise CalibrationError(f"{path}: camera #{i}: {e}") from None
        try:
            return cls(cams)
        except ValueError as e:
            raise CalibrationError(f"{path}: {e}") from None

    def save(self, path) -> None:
        """Write ``cameras.json`` (atomically)."""
        doc = {"units": "m", "cameras": [c.to_dict() for c in self._cameras]}
        atomic_write(Path(path), (json.dumps(doc, indent=1) + "\n").encode())

    # -- other tools' formats -------------------------------------------------------------

    @classmethod
    def from_easymocap(cls, intri, extri, image_size=None, up: str = "z") -> Cameras:
        """Import EasyMocap's OpenCV FileStorage pair ``intri.yml`` (``names``, ``K_<cam>``,
        ``dist_<cam>``, optional ``H_<cam>``/``W_<cam>``) and ``extri.yml`` (``Rot_<cam>``
        or the Rodrigues ``R_<cam>``, ``T_<cam>``), metres.

        Args:
            image_size: for files that do not store it: ``(width, height)``, ``"WxH"``, or
                a dict of either per camera name.
            up: the world's up axis in the files, ``"z"`` (ours) or ``"y"``.

        Raises:
            CalibrationError: naming the file and camera; also when a camera's principal
                point is far from its image's centre (a swapped width and height).
        """
        with _storage(intri) as fi, _storage(extri) as fe, _malformed(f"{intri}, {extri}"):
            return cls(_easymocap_cameras(fi, fe, intri, extri, image_size, up))

    @classmethod
    def from_opencv(cls, paths, image_size=None, up: str = "z") -> Cameras:
        """Import one OpenCV FileStorage file (YAML or XML) per camera, named after the file:
        ``camera_matrix`` (or ``K``), ``distortion_coefficients`` (or ``dist``), the
        world → camera rotation as ``R`` (3×3, or a Rodrigues vector) or ``rvec``, the
        translation ``T`` or ``tvec`` (metres), and ``image_width``/``image_height`` when the
        file has them (as ``cv2.calibrateCamera``'s samples write). `image_size` and `up`
        as in :meth:`from_easymocap`."""
        cams = []
        for path in map(Path, paths):
            with _storage(path) as fs, _malformed(path):
                K = _yml_first(fs, ("camera_matrix", "K"), path)
                dist = _yml_first(fs, ("distortion_coefficients", "dist", "D"), path, required=False)
                rot = _yml_first(fs, ("R", "rvec", "Rot"), path)
                if rot.size == 3:
                    rot = cv2.Rodrigues(rot.reshape(3, 1))[0]
                T = _yml_first(fs, ("T", "tvec", "t"), path).reshape(-1)
                if T.size != 3:
                    raise CalibrationError(f"{path}: the translation must have 3 values, got {T.size}")
                size = _stored_size(fs, "image_width", "image_height", image_size, path.stem, path)
            cams.append(_with_up(path, path.stem, *size, K, dist, rot.reshape(3, 3), T, up))
        return cls(cams)

    @classmethod
    def from_pose2sim(cls, path, up: str = "z") -> Cameras:
        """Import a Pose2Sim ``Calib.toml``: a table per camera with ``name``, ``size``
        (width, height), ``matrix``, ``distortions`` [k1, k2, p1, p2], ``rotation``
        (Rodrigues, world → camera) and ``translation`` (metres). `up` as in
        :meth:`from_easymocap`."""
        path = Path(path)
        doc = read_document(path, CalibrationError)
        cams = []
        for key, c in doc.items():
            if key == "metadata" or not isinstance(c, dict):
                continue
            if c.get("fisheye"):
                raise CalibrationError(f"{path}: camera [{key}]: fisheye cameras are not supported")
            with _malformed(f"{path}: camera [{key}]"):
                R = cv2.Rodrigues(np.asarray(c["rotation"], float).reshape(3, 1))[0]
                w, h = c["size"]
                cams.append(_with_up(path, str(c.get("name", key)), int(w), int(h), c["matrix"],
                                     c.get("distortions", []), R, c["translation"], up))
        return cls(cams)


def parse_size(size, where="image size") -> tuple[int, int]:
    """``(width, height)`` from a pair or a ``"WxH"`` string."""
    if isinstance(size, str):
        parts = size.lower().replace("×", "x").split("x")
    else:
        parts = list(size) if isinstance(size, (tuple, list, np.ndarray)) else [size]
    try:
        w, h = (int(p) for p in parts)
    except (TypeError, ValueError):
        raise CalibrationError(f"{where}: expected (width, height) or 'WIDTHxHEIGHT', got {size!r}") from None
    if w <= 0 or h <= 0:
        raise CalibrationError(f"{where}: width and height must be positive, got {w}×{h}")
    return w, h


def _size_for(image_size, name, path) -> tuple[int, int]:
    """Camera `name`'s size from the `image_size` argument of an import."""
    if isinstance(image_size, dict):
        image_size = image_size.get(name)
    if image_size is None:
        raise CalibrationError(f"{path}: no image size for camera {name!r}; pass image_size=(width, height)")
    return parse_size(image_size, f"{path}: camera {name!r}")


def check_principal_point(camera: Camera) -> None:
    """Refuse a camera whose principal point is far from its image's centre: the mark of
    a width and height given the wrong way round (1080×1920 for a 1920×1080 camera)."""
    cx, cy = camera.K[0, 2], camera.K[1, 2]
    w, h = camera.width, camera.height
    if abs(cx - (w - 1) / 2) > PRINCIPAL_POINT_TOLERANCE * w or abs(cy - (h - 1) / 2) > PRINCIPAL_POINT_TOLERANCE * h:
        hint = " (width and height swapped?)" if abs(cx - (h - 1) / 2) <= PRINCIPAL_POINT_TOLERANCE * h and \
            abs(cy - (w - 1) / 2) <= PRINCIPAL_POINT_TOLERANCE * w else ""
        raise CalibrationError(f"camera {camera.name!r}: principal point ({cx:.0f}, {cy:.0f}) is far from the centre "
                               f"of a {w}×{h} image{hint}")


def _with_up(source, name, w, h, K, dist, R, t, up) -> Camera:
    """A camera imported from the file `source` of another tool: axes converted, size
    checked; errors name the file."""
    if up not in ("z", "y"):
        raise CalibrationError(f"up must be 'z' or 'y', got {up!r}")
    R = np.asarray(R, float)
    if up == "y":
        R = R @ Y_UP_TO_Z_UP.T  # x_cam = R·X_file = R·Mᵀ·X_ours
    dist = np.ravel(np.asarray(dist if dist is not None else [], float))
    try:
        if dist.size > 5:
            raise CalibrationError(f"camera {name!r}: {dist.size} distortion coefficients; only [k1 k2 p1 p2 k3] "
                                   f"are supported")
        camera = Camera(name, w, h, K, dist, R, t)  # Camera pads [k1 k2 p1 p2] with k3 = 0
        check_principal_point(camera)
    except CalibrationError as e:
        raise CalibrationError(f"{source}: {e}") from None
    return camera


def _easymocap_cameras(fi, fe, intri, extri, image_size, up) -> list[Camera]:
    cams = []
    for n in _yml_names(fi, intri):
        K = _yml_mat(fi, f"K_{n}", intri)
        dist = _yml_mat(fi, f"dist_{n}", intri, required=False)
        rot = _yml_mat(fe, f"Rot_{n}", extri, required=False)
        if rot is None:
            rot = cv2.Rodrigues(_yml_mat(fe, f"R_{n}", extri).reshape(3, 1))[0]
        T = _yml_mat(fe, f"T_{n}", extri).reshape(3)
        w, h = _stored_size(fi, f"W_{n}", f"H_{n}", image_size, n, intri)
        cams.append(_with_up(intri, n, w, h, K, dist, rot, T, up))
    return cams


@contextmanager
def _malformed(where):
    """Errors of a file's contents that no check names one by one (OpenCV's parser, a
    value of the wrong kind) as a CalibrationError naming `where`."""
    try:
        yield
    except CalibrationError:
        raise
    except (cv2.error, SystemError, KeyError, TypeError, ValueError, OverflowError) as e:
        raise CalibrationError(f"{where}: malformed ({type(e).__name__}: {e})") from None


@contextmanager
def _storage(path):
    """An OpenCV FileStorage opened for reading (released at the end of the block)."""
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"{path}: no such file")
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as e:
        raise CalibrationError(f"{path}: not an OpenCV FileStorage file ({str(e).strip()[-80:]})") from None
    if not fs.isOpened():
        raise CalibrationError(f"{path}: not an OpenCV FileStorage file")
    try:
        yield fs
    finally:
        fs.release()


def _yml_names(fs, path) -> list[str]:
    node = fs.getNode("names")
    if node.empty():
        raise CalibrationError(f"{path}: no 'names' list")
    return [node.at(i).string() for i in range(node.size())]


def _yml_mat(fs, key, path, required=True):
    node = fs.getNode(key)
    if node.empty():
        if required:
            raise CalibrationError(f"{path}: no '{key}'")
        return None
    m = node.mat()
    if m is None:
        raise CalibrationError(f"{path}: '{key}' is not a matrix")
    return np.asarray(m, float)


def _yml_first(fs, keys, path, required=True):
    """The first of `keys` the file has, as a matrix."""
    for key in keys:
        m = _yml_mat(fs, key, path, required=False)
        if m is not None:
            return m
    if required:
        raise CalibrationError(f"{path}: none of {list(keys)}")
    return None


def _stored_size(fs, width_key, height_key, image_size, name, path) -> tuple[int, int]:
    """Camera `name`'s image size from the file's two keys when it has both, else from the
    `image_size` argument of the import."""
    w, h = fs.getNode(width_key), fs.getNode(height_key)
    if not w.empty() and not h.empty():
        return int(w.real()), int(h.real())
    return _size_for(image_size, name, path)


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)`` of a camera at `eye` looking at `target`, image up towards `up`."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, float))
    if np.linalg.norm(x) < 1e-9:
        raise CalibrationError("look_at: the view direction is parallel to up")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


def ring(n: int, radius: float = 4.0, height: float = 1.6, target=(0.0, 0.0, 1.0),
         width: int = 640, height_px: int = 480, fov_deg: float = 50.0, prefix: str = "cam",
         phase_deg: float = 0.0, height_jitter: float = 0.25) -> Cameras:
    """N cameras evenly spaced on a ring around the capture volume, looking at `target`.

    Camera heights alternate ±`height_jitter` about `height` so that views differ in
    elevation too. Horizontal field of view `fov_deg`; no distortion.
    """
    if n < 1:
        raise CalibrationError(f"a ring needs at least one camera, got {n}")
    f = 0.5 * width / np.tan(np.radians(fov_deg) / 2)
    K = [[f, 0, (width - 1) / 2], [0, f, (height_px - 1) / 2], [0, 0, 1]]
    cams = []
    for i in range(n):
        a = np.radians(phase_deg) + 2 * np.pi * i / n
        z = height + (height_jitter if i % 2 else -height_jitter) * (n > 1)
        R, t = look_at((radius * np.sin(a), -radius * np.cos(a), z), target)
        cams.append(Camera(f"{prefix}{i}", width, height_px, K, np.zeros(5), R, t))
    return Cameras(cams)


# -- the rig's geometry: where the cameras look, the volume every one of them sees ----------

def check_bounds(bounds) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` as float arrays from ``((x0, y0, z0), (x1, y1, z1))`` or six numbers,
    checked: finite, lo < hi on every axis."""
    try:
        b = np.asarray(bounds, float).reshape(2, 3)
    except (TypeError, ValueError):
        raise HullError(f"bounds must be (x0, y0, z0), (x1, y1, z1) in metres, got {bounds!r}") from None
    if not np.isfinite(b).all() or not (b[0] < b[1]).all():
        raise HullError(f"bounds must be finite with x0 < x1, y0 < y1, z0 < z1, got {b.tolist()}")
    return b[0].copy(), b[1].copy()


def format_bounds(bounds) -> str:
    """``(x0, y0, z0)–(x1, y1, z1) m`` to the centimetre."""
    lo, hi = bounds
    return "({:.2f}, {:.2f}, {:.2f})–({:.2f}, {:.2f}, {:.2f}) m".format(*lo, *hi)


def capture_volume(cameras: Cameras, floor: float = 0.0, ceiling: float = 2.4, step: float = 0.05):
    """``(lo, hi)``: the bounding box of the points between `floor` and `ceiling` that
    every camera sees, to within `step` metres; computed once per set of cameras.

    The search starts where the cameras' optical axes pass closest to each other (the
    least-squares meeting point, where a rig is aimed), over a square reaching the
    furthest camera, first every 4 `step` and then every `step` around what that found:
    a rig on one side of a room sees a volume its camera centres do not surround."""
    lo, hi = cameras.derived(("capture_volume", floor, ceiling, step),
                             lambda: _capture_volume(cameras, floor, ceiling, step))
    return lo.copy(), hi.copy()


def axes_meeting_point(cameras: Cameras) -> np.ndarray:
    """(3,) the point nearest to every camera's optical axis (least squares)."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    for cam in cameras:
        d = cam.R[2]  # the optical axis in the world
        P = np.eye(3) - np.outer(d, d)
        A += P
        b += P @ cam.centre
    return np.linalg.lstsq(A, b, rcond=None)[0]


def _capture_volume(cameras, floor, ceiling, step):
    centres = np.array([c.centre for c in cameras])
    mid = axes_meeting_point(cameras)[:2]
    if len(cameras) < 2 or not np.isfinite(mid).all():
        mid = centres[:, :2].mean(0)
    span = np.linalg.norm(centres[:, :2] - mid, axis=1).max() + step
    lo, hi = np.array([*(mid - span), floor]), np.array([*(mid + span), ceiling])
    for s in (4 * step, step):
        lo[2], hi[2] = max(lo[2], floor), min(hi[2], ceiling)
        axes = [np.arange(lo[k], hi[k] + s / 2, s) for k in range(3)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        seen = np.ones(len(pts), bool)
        for cam in cameras:
            px, z = cam.project(pts[seen])
            inside = (z > 0) & (px[:, 0] >= 0) & (px[:, 0] <= cam.width - 1) & (px[:, 1] >= 0) & \
                (px[:, 1] <= cam.height - 1)
            seen[np.flatnonzero(seen)[~inside]] = False
        if not seen.any():
            raise CalibrationError(f"the cameras see no common volume between the floor (z = {floor} m) and "
                                   f"z = {ceiling} m; give the capture volume (bounds)")
        p = pts[seen]
        lo, hi = p.min(0) - s, p.max(0) + s
    return lo, hi
