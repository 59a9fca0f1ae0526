"""hullcap: markerless human motion capture from calibrated multi-view video.

The public API is what this module exports (``__all__``). The heavy lifting happens in the
Rust engine, ``hullcap._engine``; everything exported here validates its input and raises
``ValueError`` naming the argument at fault.
"""

from hullcap._engine import NormalKDTree, __version__, skin_weights
from hullcap.body import BodyModel, Pose
from hullcap.cameras import Camera, Cameras
from hullcap.fitting import FitOptions, FitResult, PoseParameters, fit
from hullcap.hull import visual_hull
from hullcap.links import LinkModel
from hullcap.mesh import Surface, read_mesh, write_mesh
from hullcap.sequence import Sequence
from hullcap.subject import build_subject
from hullcap.results import TrackingResult, load_result, smooth_joints
from hullcap.tracking import Tracker, TrackerOptions

__all__ = [
    "BodyModel",
    "Camera",
    "Cameras",
    "FitOptions",
    "FitResult",
    "LinkModel",
    "NormalKDTree",
    "Pose",
    "PoseParameters",
    "Sequence",
    "Surface",
    "Tracker",
    "TrackerOptions",
    "TrackingResult",
    "__version__",
    "build_subject",
    "fit",
    "load_result",
    "read_mesh",
    "skin_weights",
    "smooth_joints",
    "visual_hull",
    "write_mesh",
]
