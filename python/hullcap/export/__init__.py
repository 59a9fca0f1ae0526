"""Outputs people load into other tools (docs/design.md §10)."""

from hullcap.export._angles import angle_table, read_mot, write_angles_csv, write_mot
from hullcap.export._bvh import write_bvh
from hullcap.export._c3d import read_c3d, write_c3d
from hullcap.export._gltf import write_glb
from hullcap.export._outputs import load_result, write_joints_csv, write_outputs
from hullcap.export._overlay import write_overlays, write_report
from hullcap.export._trc import read_trc, write_trc

__all__ = ["angle_table", "load_result", "read_c3d", "read_mot", "read_trc", "write_angles_csv", "write_bvh",
           "write_c3d", "write_glb", "write_joints_csv", "write_mot", "write_outputs", "write_overlays", "write_report",
           "write_trc"]
