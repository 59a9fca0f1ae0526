"""Outputs people load into other tools (docs/design.md §10)."""

from hullcap.export.bvh import write_bvh
from hullcap.export.c3d import read_c3d, write_c3d
from hullcap.export.gltf import write_glb
from hullcap.export.overlay import write_overlays, write_report
from hullcap.export.trc import write_trc

__all__ = ["read_c3d", "write_bvh", "write_c3d", "write_glb", "write_overlays", "write_report", "write_trc"]
