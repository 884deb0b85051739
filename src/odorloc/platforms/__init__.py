"""Platforms: how agents move and what it costs (wheeled robots, UAVs) and how teams talk.

Each platform is registered in the ``"platform"`` family: ``holonomic``, ``unicycle``, ``uav``,
``lattice`` (one cell per step).
"""

from __future__ import annotations

from odorloc.platforms.base import Platform, free_fraction
from odorloc.platforms.team import CommGraph, message_nbytes, neighbour_matrix
from odorloc.platforms.uav import UAV, UAVParams, movement_energy
from odorloc.platforms.wheeled import (
    HolonomicParams,
    HolonomicRobot,
    UnicycleParams,
    UnicycleRobot,
    WheeledRobot,
)

__all__ = [
    "UAV",
    "CommGraph",
    "HolonomicParams",
    "HolonomicRobot",
    "Platform",
    "UAVParams",
    "UnicycleParams",
    "UnicycleRobot",
    "WheeledRobot",
    "free_fraction",
    "message_nbytes",
    "movement_energy",
    "neighbour_matrix",
]
