"""Moth-inspired surge and cast (e.g. Kennedy & Marsh 1974; Li, Farrell & Cardé 2001).

After the odor is lost the agent *surges* straight upwind for ``surge_steps`` steps, then
*casts* (:class:`CastParams`): legs across the wind at ``angle_deg`` from upwind, alternating
sides, whose length starts at ``amplitude`` metres and grows by the factor ``growth`` each leg
up to ``max_amplitude``. A wall ends a leg early. Casting from the start is a plume-finding
behaviour.

In 3-D, ``elevation_deg`` tilts the cast legs out of the horizontal plane, up for two legs
and down for the next two, so the casts also sweep heights (a 3-D plume is missed at the wrong
height); the default 0 keeps them horizontal.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from odorloc.core.params import Finite, Params, Positive
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import rotate2

__all__ = ["CastParams", "SurgeCast"]


class CastParams(Params):
    """The casting legs (see the module docstring).

    Attributes
    ----------
    angle_deg : float, degrees
        Angle of a leg from upwind (90: straight across the wind).
    amplitude : float, metres
        Length of the first leg.
    growth : float
        Factor by which each leg is longer than the one before (>= 1).
    max_amplitude : float, metres
        Longest leg.
    elevation_deg : float, degrees
        Tilt of the legs out of the horizontal plane in 3-D (0: horizontal).
    """

    angle_deg: float = Field(80.0, ge=0.0, le=90.0)
    amplitude: Positive = 0.4
    growth: Finite = Field(1.5, ge=1.0)
    max_amplitude: Positive = 3.0
    elevation_deg: float = Field(0.0, ge=0.0, lt=90.0)


class SurgeCast:
    """One agent's surge/cast state.

    Parameters
    ----------
    cast : CastParams
        The casting legs.
    surge_steps : int
        Steps of upwind surge after :meth:`start_surge` (0: cast at once).
    """

    def __init__(self, cast: CastParams, surge_steps: int = 0) -> None:
        self.params = cast
        self.surge_steps = int(surge_steps)
        self.surge_left = 0
        self.side = 1.0
        self.leg = cast.amplitude
        self.done = 0.0
        self.legs = 0

    @property
    def surging(self) -> bool:
        """``True`` while surge steps remain."""
        return self.surge_left > 0

    def start_surge(self) -> None:
        """The odor was lost: surge upwind next, then cast afresh from ``amplitude``."""
        self.surge_left = self.surge_steps
        # reset here, not when the surge runs out: with no surge steps the next cast must not
        # carry on with the widened legs of an earlier one
        self.leg, self.done = self.params.amplitude, 0.0

    def direction(self, arena: Arena, pos: np.ndarray, up: np.ndarray, step: float) -> np.ndarray:
        """Unit direction ``(d,)`` of this step (``up`` while surging, else the cast leg's)."""
        p = self.params
        if self.surge_left > 0:
            self.surge_left -= 1
            return up
        if self.done >= self.leg:
            self.side = -self.side
            self.done = 0.0
            self.leg = min(self.leg * p.growth, p.max_amplitude)
            self.legs += 1
        d = rotate2(up, math.radians(p.angle_deg) * self.side)
        if p.elevation_deg > 0 and d.size == 3:
            e = math.radians(p.elevation_deg)
            d = math.cos(e) * d
            d[2] = math.sin(e) * (1.0 if (self.legs // 2) % 2 == 0 else -1.0)
        if not arena.segment_free(pos, pos + d * step)[0]:
            # A wall ends the leg early: turn to the other side next.
            self.done = self.leg
        self.done += step
        return d
