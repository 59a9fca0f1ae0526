"""A camera rig at a glance, and calibrations imported from other tools (``hullcap calib``).

:func:`describe` lists each camera's centre, viewing direction, image size and focal
length and the capture volume every camera sees (:func:`hullcap._cameras.capture_volume`);
:func:`draw_top_view` draws the rig from above with that volume, so that a rig aimed away
from where the person stands shows at once. :func:`import_calibration` reads EasyMocap,
Pose2Sim or plain OpenCV files into :class:`~hullcap._cameras.Cameras`, taking image sizes
from the files, from the caller, or from one frame of each camera's images or video.
"""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np

from hullcap._cameras import Camera, Cameras, axes_meeting_point, capture_volume, format_bounds
from hullcap._files import atomic_write
from hullcap._sequence import VIDEO_SUFFIXES, first_frame
from hullcap.errors import CalibrationError, SequenceError

__all__ = ["describe", "draw_top_view", "import_calibration", "image_sizes", "match_to_images", "normalised_name",
           "surround", "FORMATS", "MIN_SURROUND"]

FORMATS = ("easymocap", "pose2sim", "opencv")


def import_calibration(kind: str, sources, image_size=None, up: str = "z") -> Cameras:
    """Cameras from another tool's files: ``easymocap`` (``intri.yml extri.yml``),
    ``pose2sim`` (one ``Calib*.toml``) or ``opencv`` (one FileStorage file per camera).
    `image_size` and `up` as in :meth:`Cameras.from_easymocap`; a dict of sizes is also
    looked up by :func:`normalised_name`."""
    if isinstance(image_size, dict):
        image_size = _AnyName(image_size)
    sources = [Path(s) for s in sources]
    want = {"easymocap": 2, "pose2sim": 1}.get(kind)
    if kind not in FORMATS:
        raise CalibrationError(f"calibration format must be one of {FORMATS}, got {kind!r}")
    if (want is not None and len(sources) != want) or not sources:
        raise CalibrationError(f"{kind} takes {want or 'one or more'} file(s), got {len(sources)}")
    if kind == "easymocap":
        return Cameras.from_easymocap(*sources, image_size=image_size, up=up)
    if kind == "pose2sim":
        return Cameras.from_pose2sim(sources[0], up=up)
    return Cameras.from_opencv(sources, image_size=image_size, up=up)


class _AnyName(dict):
    """Image sizes by camera name, found under a name that means the same camera too."""

    def get(self, name, default=None):
        if name in self:
            return self[name]
        alike = [k for k in self if normalised_name(k) == normalised_name(name)]
        return self[alike[0]] if len(alike) == 1 else default


RESIZE_TOLERANCE = 0.02
"""A video whose size differs from its camera's calibrated size by at most this fraction on
each side is taken as the calibrated frame resized (uniformly, centred), and adopted."""


def normalised_name(name: str) -> str:
    """A camera name as names that mean the same camera compare: lower case, letters and
    digits only, no leading zeros in a number (``cam_01``, ``Cam01`` and ``cam1`` alike)."""
    parts = re.findall(r"[a-z]+|\d+", name.lower())
    return "".join(str(int(p)) if p.isdigit() else p for p in parts)


def match_to_images(cameras: Cameras, sizes: dict[str, tuple[int, int]],
                    rename: dict[str, str] | None = None) -> tuple[Cameras, list[str]]:
    """``(cameras, notes)``: `cameras` named as their videos or frame folders are (`sizes`:
    :func:`image_sizes`), and each adopted to its images' size where they are the calibrated
    frame resized; `notes` say what changed. `rename` (calibration name → image name) comes
    first; then an exact name, then the same :func:`normalised_name`. A CalibrationError
    lists both sides when a camera has no images, and names a size that is not a resize."""
    rename = dict(rename or {})
    unknown = sorted(set(rename) - set(cameras.names))
    if unknown:
        raise CalibrationError(f"--rename names {', '.join(unknown)}, which the calibration does not have "
                               f"(its cameras: {', '.join(cameras.names)})")
    by_norm: dict[str, list[str]] = {}
    for name in sizes:
        by_norm.setdefault(normalised_name(name), []).append(name)
    notes, kept, missing = [], [], []
    for cam in cameras:
        name = rename.get(cam.name, cam.name)
        if name not in sizes:
            alike = by_norm.get(normalised_name(name), [])
            if len(alike) != 1:
                missing.append(cam.name)
                continue
            name = alike[0]
        if name != cam.name:
            notes.append(f"camera {cam.name!r} is named {name!r}, as its images are")
        cam = Camera(name, cam.width, cam.height, cam.K, cam.dist, cam.R, cam.t)
        adopted = _adopted(cam, sizes[name])
        if adopted is not cam:
            notes.append(f"camera {name!r}: its images are {adopted.width}×{adopted.height}, calibrated "
                         f"{cam.width}×{cam.height}: taken as the calibrated frame resized (by "
                         f"{min(adopted.width / cam.width, adopted.height / cam.height):.4f}, centred), "
                         f"its intrinsics scaled to match")
        kept.append(adopted)
    if missing:
        pairs = ",".join(f"{m}=NAME" for m in missing)
        raise CalibrationError(f"no images for camera{'s' if len(missing) > 1 else ''} {', '.join(missing)} of the "
                               f"calibration; the images are of {', '.join(sorted(sizes))}: name them alike, or "
                               f"give --rename {pairs}")
    return Cameras(kept), notes


def _adopted(cam: Camera, size: tuple[int, int]) -> Camera:
    """`cam` seeing images of `size` ``(width, height)``: itself when it is its size; the
    calibrated frame scaled uniformly and centred in the new size when that is within
    :data:`RESIZE_TOLERANCE` of it; else a CalibrationError."""
    width, height = size
    if (width, height) == (cam.width, cam.height):
        return cam
    scale = min(width / cam.width, height / cam.height)
    off = (width - scale * cam.width, height - scale * cam.height)
    if not (abs(1 - scale) <= RESIZE_TOLERANCE and max(off[0] / width, off[1] / height) <= RESIZE_TOLERANCE):
        raise CalibrationError(f"camera {cam.name!r}: its images are {width}×{height}, calibrated {cam.width}×"
                               f"{cam.height}: not the calibrated frame resized; calibrate at the videos' size")
    K = cam.K.copy()
    K[:2, :2] *= scale
    K[:2, 2] = (K[:2, 2] + 0.5) * scale - 0.5 + np.array(off) / 2  # a pixel's centre maps as a point does

    return Camera(cam.name, width, height, K, cam.dist, cam.R, cam.t)


def image_sizes(folder) -> dict[str, tuple[int, int]]:
    """``{camera: (width, height)}`` from one frame of each camera of a sequence-like
    folder: ``frames/<cam>/`` (first image) or ``videos/<cam>.*``."""
    folder = Path(folder)
    sizes = {}
    for sub in sorted((folder / "frames").glob("*/")) if (folder / "frames").is_dir() else []:
        first = next((p for p in sorted(sub.iterdir()) if p.suffix.lower() in (".png", ".jpg", ".jpeg")), None)
        if first is not None:
            image = cv2.imread(str(first), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise SequenceError(f"{first}: cannot be read as an image")
            sizes[sub.name] = (image.shape[1], image.shape[0])
    videos = sorted((folder / "videos").iterdir()) if (folder / "videos").is_dir() else []
    for video in (v for v in videos if v.suffix.lower() in VIDEO_SUFFIXES):
        image = first_frame(video)
        if image is None:
            raise SequenceError(f"{video}: cannot read its first frame")
        sizes.setdefault(video.stem, (image.shape[1], image.shape[0]))
    if not sizes:
        raise SequenceError(f"{folder}: no frames/<cam>/ images or videos/<cam>.* to take image sizes from")
    return sizes


MIN_SURROUND = 180.0
"""Degrees around the person that the cameras should span (360° less the widest gap
between them, seen from above); below it `describe` warns. With every camera on one side
the hull is a wedge: on a rig spanning 51°, a person 0.5 m deep gave a hull 2.2 m deep."""


def surround(cameras: Cameras, centre) -> float:
    """Degrees that the cameras span around `centre` seen from above: 360° less the widest
    gap between their directions from it."""
    offsets = np.array([c.centre[:2] for c in cameras]) - np.asarray(centre, float)[:2]
    angles = np.sort(np.degrees(np.arctan2(offsets[:, 1], offsets[:, 0])))
    if len(angles) < 2:
        return 0.0
    gaps = np.diff(np.concatenate([angles, angles[:1] + 360.0]))
    return float(360.0 - gaps.max())


def describe(cameras: Cameras) -> str:
    """A table of the cameras and the capture volume, as ``hullcap calib show`` prints."""
    lines = [f"{len(cameras)} cameras", "",
             f"{'camera':<12} {'size':>11} {'focal px':>9} {'centre (m)':>24} {'looks along':>22}"]
    for cam in cameras:
        c, d = cam.centre, cam.R[2]
        lines.append(f"{cam.name:<12} {cam.width:>5}×{cam.height:<5} {cam.K[0, 0]:>9.0f} "
                     f"({c[0]:6.2f}, {c[1]:6.2f}, {c[2]:5.2f}) ({d[0]:6.2f}, {d[1]:6.2f}, {d[2]:5.2f})")
    lines.append("")
    meet = axes_meeting_point(cameras)
    lines.append("axes meet near ({:.2f}, {:.2f}, {:.2f}) m".format(*meet))
    spread = surround(cameras, meet)
    lines.append(f"the cameras surround that point over {spread:.0f}° (the widest angle no camera looks from: "
                 f"{360 - spread:.0f}°)")
    if spread < MIN_SURROUND:
        lines.append(f"warning: less than {MIN_SURROUND:.0f}° around the person: the visual hull will reach far along "
                     f"the viewing direction and tracking will fail or be poor; place cameras around the person")
    try:
        lines.append(f"capture volume (every camera sees it): {format_bounds(capture_volume(cameras))}")
    except CalibrationError as e:
        lines.append(f"capture volume: none ({e})")
    return "\n".join(lines)


def draw_top_view(path, cameras: Cameras, volume=None, size: int = 800) -> None:
    """Write a picture of the rig seen from above: each camera's centre, viewing direction
    and horizontal field of view, the capture volume (`volume`, default every camera's
    common view) and a 1 m grid; the world's x to the right, y up the picture."""
    if volume is None:
        try:
            volume = capture_volume(cameras)
        except CalibrationError:
            volume = None
    centres = np.array([c.centre[:2] for c in cameras])
    pts = centres if volume is None else np.vstack([centres, volume[0][:2], volume[1][:2]])
    lo, hi = pts.min(0) - 1.0, pts.max(0) + 1.0
    scale = (size - 40) / (hi - lo).max()

    def px(p):
        p = np.asarray(p, float)
        return int(round(20 + (p[0] - lo[0]) * scale)), int(round(size - 20 - (p[1] - lo[1]) * scale))

    image = np.full((size, size, 3), 255, np.uint8)
    for x in np.arange(np.ceil(lo[0]), hi[0] + 1e-9):
        cv2.line(image, px((x, lo[1])), px((x, hi[1])), (230, 230, 230), 1)
    for y in np.arange(np.ceil(lo[1]), hi[1] + 1e-9):
        cv2.line(image, px((lo[0], y)), px((hi[0], y)), (230, 230, 230), 1)
    cv2.drawMarker(image, px((0, 0)), (120, 120, 120), cv2.MARKER_CROSS, 14, 1)
    if volume is not None:
        cv2.rectangle(image, px(volume[0][:2]), px(volume[1][:2]), (40, 160, 40), 2)
        cv2.putText(image, "capture volume", (px(volume[0][:2])[0] + 4, px(volume[0][:2])[1] - 6),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.45, (40, 160, 40), 1, cv2.LINE_AA)
    reach = 0.6 * (hi - lo).max()
    for cam in cameras:
        c = cam.centre[:2]
        ends = []
        for u in (0.0, cam.width - 1.0):
            _, d = cam.rays([[u, (cam.height - 1) / 2]])
            d = d[0, :2] / max(np.linalg.norm(d[0, :2]), 1e-9)
            ends.append(px(c + reach * d))
        cv2.line(image, px(c), ends[0], (200, 170, 120), 1, cv2.LINE_AA)
        cv2.line(image, px(c), ends[1], (200, 170, 120), 1, cv2.LINE_AA)
        axis = cam.R[2, :2] / max(np.linalg.norm(cam.R[2, :2]), 1e-9)
        cv2.arrowedLine(image, px(c), px(c + 0.5 * axis), (160, 60, 20), 2, cv2.LINE_AA, tipLength=0.3)
        cv2.circle(image, px(c), 5, (160, 60, 20), -1, cv2.LINE_AA)
        cv2.putText(image, cam.name, (px(c)[0] + 7, px(c)[1] - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (60, 30, 10), 1, cv2.LINE_AA)
    cv2.putText(image, "top view, 1 m grid, + = world origin", (10, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                (80, 80, 80), 1, cv2.LINE_AA)
    ok, png = cv2.imencode(".png", image)
    if not ok:
        raise CalibrationError(f"{path}: could not encode the picture")
    atomic_write(Path(path), png.tobytes())
