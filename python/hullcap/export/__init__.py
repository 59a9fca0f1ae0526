"""Outputs people load into other tools (DESIGN.md §10)."""

from hullcap.export.bvh import write_bvh
from hullcap.export.overlay import write_overlays, write_report

__all__ = ["write_bvh", "write_overlays", "write_report"]
