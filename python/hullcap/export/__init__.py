"""Outputs people load into other tools (DESIGN.md §10)."""

from hullcap.export.bvh import write_bvh

__all__ = ["write_bvh"]
