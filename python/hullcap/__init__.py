"""hullcap: markerless human motion capture from calibrated multi-view video.

The public API is what this module exports (``__all__``). The heavy lifting happens in the
Rust engine, ``hullcap._engine``; everything exported here validates its input and raises
an error of :mod:`hullcap.errors` (each a ``ValueError`` when the input is at fault) naming
the file, camera, frame or argument at fault.
"""

from hullcap import errors
from hullcap._engine import NormalKDTree, __version__, skin_weights
from hullcap.body import BodyModel, Pose
from hullcap.cameras import Camera, Cameras
from hullcap.errors import HullcapError
from hullcap.fitting import FitOptions, FitResult, PoseParameters, fit
from hullcap.guided import GuidedOptions
from hullcap.hull import HullReport, visual_hull
from hullcap.links import LinkModel
from hullcap.mesh import Surface, read_mesh, write_mesh
from hullcap.reacquire import SearchOptions
from hullcap.results import TrackingResult, load_result, smooth_joints
from hullcap.sequence import Sequence
from hullcap.shape import ShapeBasis
from hullcap.subject import SubjectFit, SubjectOptions, build_subject
from hullcap.tracking import Tracker, TrackerOptions

__all__ = [
    "BodyModel",
    "Camera",
    "Cameras",
    "FitOptions",
    "FitResult",
    "GuidedOptions",
    "HullReport",
    "HullcapError",
    "LinkModel",
    "NormalKDTree",
    "Pose",
    "PoseParameters",
    "SearchOptions",
    "Sequence",
    "ShapeBasis",
    "SubjectFit",
    "SubjectOptions",
    "Surface",
    "Tracker",
    "TrackerOptions",
    "TrackingResult",
    "__version__",
    "build_subject",
    "errors",
    "fit",
    "load_result",
    "read_mesh",
    "skin_weights",
    "smooth_joints",
    "visual_hull",
    "write_mesh",
]
