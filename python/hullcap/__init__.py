"""hullcap: markerless human motion capture from calibrated multi-view video.

The public API is what this module exports (``__all__``). The heavy lifting happens in the
Rust engine, ``hullcap._engine``; everything exported here validates its input and raises
``ValueError`` naming the argument at fault.
"""

from hullcap._engine import NormalKDTree, __version__, skin_weights
from hullcap.body import BodyModel, Pose
from hullcap.cameras import Camera, Cameras
from hullcap.links import LinkModel
from hullcap.mesh import Surface, read_mesh, write_mesh

__all__ = [
    "BodyModel",
    "Camera",
    "Cameras",
    "LinkModel",
    "NormalKDTree",
    "Pose",
    "Surface",
    "__version__",
    "read_mesh",
    "skin_weights",
    "write_mesh",
]
