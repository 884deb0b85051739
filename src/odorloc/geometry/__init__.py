"""Geometry: arenas with obstacles, the one cell-grid type, vectors and regions."""

from __future__ import annotations

from odorloc.geometry.arena import Arena, as_points
from odorloc.geometry.grid import CellGrid, multilinear
from odorloc.geometry.regions import check_region, narrow_box, resolve_region, task_region
from odorloc.geometry.vectors import (
    directions_26,
    fan,
    heading_vector,
    lattice_moves,
    ring,
    rotate2,
    upwind_unit,
    wrap_angle,
)

__all__ = [
    "Arena",
    "CellGrid",
    "as_points",
    "check_region",
    "directions_26",
    "fan",
    "heading_vector",
    "lattice_moves",
    "multilinear",
    "narrow_box",
    "resolve_region",
    "ring",
    "rotate2",
    "task_region",
    "upwind_unit",
    "wrap_angle",
]
