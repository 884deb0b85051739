"""Moth-inspired surge and cast (e.g. Kennedy & Marsh 1974; Li, Farrell & Cardé 2001).

After the odor is lost the agent *surges* straight upwind for ``surge_steps`` steps, then
*casts*: legs across the wind at ``cast_angle_deg`` from upwind, alternating sides, whose length
starts at ``cast_amplitude`` metres and grows by the factor ``cast_growth`` each leg up to
``cast_max``. A wall ends a leg early. Casting from the start is a plume-finding behaviour.

In 3-D, ``cast_elevation_deg`` tilts the cast legs out of the horizontal plane, up for two legs
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

__all__ = ["SurgeCast", "SurgeCastParams"]


class SurgeCastParams(Params):
    """Surge and cast settings (see the module docstring)."""

    surge_steps: int = Field(4, ge=0, le=1_000_000)
    cast_angle_deg: float = Field(80.0, ge=0.0, le=90.0)
    cast_amplitude: Positive = 0.4
    cast_growth: Finite = Field(1.5, ge=1.0)
    cast_max: Positive = 3.0
    cast_elevation_deg: float = Field(0.0, ge=0.0, lt=90.0)


class SurgeCast:
    """One agent's surge/cast state."""

    def __init__(self, params: SurgeCastParams) -> None:
        self.params = params
        self.surge_left = 0
        self.side = 1.0
        self.leg = params.cast_amplitude
        self.done = 0.0
        self.legs = 0

    @property
    def surging(self) -> bool:
        """``True`` while surge steps remain."""
        return self.surge_left > 0

    def start_surge(self) -> None:
        """The odor was lost: surge upwind next, then cast afresh from ``cast_amplitude``."""
        self.surge_left = self.params.surge_steps
        # reset here, not when the surge runs out: with no surge steps the next cast must not
        # carry on with the widened legs of an earlier one
        self.leg, self.done = self.params.cast_amplitude, 0.0

    def direction(self, arena: Arena, pos: np.ndarray, up: np.ndarray, step: float) -> np.ndarray:
        """Unit direction ``(d,)`` of this step (``up`` while surging, else the cast leg's)."""
        p = self.params
        if self.surge_left > 0:
            self.surge_left -= 1
            return up
        if self.done >= self.leg:
            self.side = -self.side
            self.done = 0.0
            self.leg = min(self.leg * p.cast_growth, p.cast_max)
            self.legs += 1
        d = rotate2(up, math.radians(p.cast_angle_deg) * self.side)
        if p.cast_elevation_deg > 0 and d.size == 3:
            e = math.radians(p.cast_elevation_deg)
            d = math.cos(e) * d
            d[2] = math.sin(e) * (1.0 if (self.legs // 2) % 2 == 0 else -1.0)
        if not arena.segment_free(pos, pos + d * step)[0]:
            # A wall ends the leg early: turn to the other side next.
            self.done = self.leg
        self.done += step
        return d
