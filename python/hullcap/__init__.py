"""hullcap: markerless human motion capture from calibrated multi-view video.

The public API is what this module exports (``__all__``), with :mod:`hullcap.errors` and
:mod:`hullcap.export`; modules whose names start with an underscore are the implementation
and may change. The heavy lifting happens in the Rust engine, ``hullcap._engine``;
everything exported here validates its input and raises an error of :mod:`hullcap.errors`
(each a ``ValueError`` when the input is at fault) naming the file, camera, frame or
argument at fault.
"""

from hullcap import errors
from hullcap._body import BodyModel, Pose
from hullcap._cameras import Camera, Cameras, ring
from hullcap._compare import Comparison, compare_run
from hullcap._engine import NormalKDTree, __version__, skin_weights
from hullcap._evaluate import Accuracy, accuracy
from hullcap._fitting import FitOptions, FitResult, PoseParameters, fit
from hullcap._guided import GuidedOptions
from hullcap._hull import HullReport, visual_hull
from hullcap._links import LinkModel
from hullcap._mesh import Surface, read_mesh, write_mesh
from hullcap._reacquire import SearchOptions
from hullcap._results import TrackingResult, smooth_joints
from hullcap.export import load_result
from hullcap._sequence import Sequence
from hullcap._shape import ShapeBasis
from hullcap._silhouette import background_model
from hullcap._subject import SubjectFit, SubjectOptions, build_subject
from hullcap._synth import synthesize
from hullcap._tracking import Tracker, TrackerOptions
from hullcap.errors import HullcapError

__all__ = [
    "Accuracy",
    "BodyModel",
    "Camera",
    "Cameras",
    "Comparison",
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
    "accuracy",
    "background_model",
    "build_subject",
    "compare_run",
    "errors",
    "fit",
    "load_result",
    "read_mesh",
    "ring",
    "skin_weights",
    "smooth_joints",
    "synthesize",
    "visual_hull",
    "write_mesh",
]
