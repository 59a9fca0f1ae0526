"""hullcap: markerless human motion capture from calibrated multi-view video.

The public API is what this module exports (``__all__``). The heavy lifting happens in the
Rust engine, ``hullcap._engine``; everything exported here validates its input and raises
``ValueError`` naming the argument at fault.
"""

from hullcap._engine import NormalKDTree, __version__, skin_weights

__all__ = ["NormalKDTree", "__version__", "skin_weights"]
