"""Z-shaped exploration across the wind (indoor PF paper, section 2.1, Fig. 1).

Legs run at ``angle`` either side of the upwind direction. The current leg is kept while the
next ``look`` metres are free; a blocked leg turns into the mirror leg (zig <-> zag), and when
that is blocked too (an upwind or downwind wall) the along-wind progress reverses, so the robot
sweeps the room back and forth. An optional ``max_leg`` turns a leg after that many metres even
without an obstacle.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import free_step
from odorloc.core.params import Params, Positive
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import rotate2

__all__ = ["Zigzag", "ZigzagLegParams", "zigzag_leg"]


class ZigzagLegParams(Params):
    """The legs of a zigzag.

    Attributes
    ----------
    angle_deg : float, degrees
        Angle between a leg and the upwind (or downwind) direction.
    max_leg : float or None, metres
        Leg length after which the leg turns even without an obstacle (``None``: only at
        walls and obstacles, as in the indoor PF paper).
    """

    angle_deg: float = Field(45.0, ge=0.0, le=90.0)
    max_leg: Positive | None = None


def zigzag_leg(
    arena: Arena,
    pos: np.ndarray,
    up: np.ndarray,
    angle: float,
    side: float,
    along: float,
    look: float,
) -> tuple[np.ndarray, float, float] | None:
    """The next free zigzag leg direction.

    Legs run at ``angle`` (rad) either side of the upwind unit vector ``up``; ``side`` (+-1)
    picks the side and ``along`` (+1 upwind, -1 downwind) the along-wind progress. The current
    leg is kept while ``look`` metres ahead are free; otherwise the mirror leg (zig <-> zag),
    then the two legs with reversed along-wind progress are tried.

    Returns
    -------
    (direction (d,) unit ndarray, side, along), or ``None`` when all four legs are blocked.
    """
    for sg, al in ((side, along), (-side, along), (-side, -along), (side, -along)):
        # A downwind leg mirrors the upwind one, so the Z keeps drifting crosswind.
        d = rotate2(up, sg * (angle if al > 0 else math.pi - angle))
        if free_step(arena, pos, d, look):
            return d, sg, al
    return None


class Zigzag:
    """The state of one agent's zigzag: legs at ``angle`` (rad) to the wind, turned after
    ``max_leg`` metres (``None``: only at walls and obstacles), as :class:`ZigzagLegParams`
    describes them (:meth:`from_params`)."""

    def __init__(self, angle: float, max_leg: float | None = None) -> None:
        self.angle = float(angle)
        self.max_leg = max_leg
        self.side = 1.0
        self.along = 1.0  # +1: legs angled upwind, -1: downwind
        self.travelled = 0.0

    @classmethod
    def from_params(cls, params: ZigzagLegParams) -> Zigzag:
        """A zigzag with the legs of ``params``."""
        return cls(math.radians(params.angle_deg), params.max_leg)

    def direction(
        self, arena: Arena, pos: np.ndarray, up: np.ndarray, look: float, advance: float
    ) -> np.ndarray | None:
        """Unit direction ``(d,)`` of the next leg step, ``None`` if boxed in.

        Parameters
        ----------
        up : (d,) unit ndarray
            Upwind direction.
        look : float, metres
            Free distance required ahead.
        advance : float, metres
            Distance this step will travel (counts towards ``max_leg``).
        """
        if self.max_leg is not None and self.travelled >= self.max_leg:
            self.side, self.travelled = -self.side, 0.0
        leg = zigzag_leg(arena, pos, up, self.angle, self.side, self.along, look)
        if leg is None:
            return None
        d, side, along = leg
        if (side, along) != (self.side, self.along):
            self.travelled = 0.0
        self.side, self.along = side, along
        self.travelled += advance
        return d
