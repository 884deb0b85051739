"""Stop-and-go motion towards a goal: a move of at most one period's reach, then standing still.

Robots that read at discrete points (a reading at rest needs no correction for the robot's own
motion) move one control period at up to full speed, then hold for ``dwell`` periods.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.types import Command

__all__ = ["REACHED", "StopAndGo"]

REACHED = 1e-6
"""Metres: a goal this close counts as reached."""


class StopAndGo:
    """Stop-and-go motion towards a goal.

    Parameters
    ----------
    step : float, metres
        Longest move per control period (speed limit times period).
    dwell : int
        Periods held after each move.
    """

    def __init__(self, step: float, dwell: int) -> None:
        self.step = float(step)
        self.dwell = int(dwell)
        self.goal: NDArray[np.float64] | None = None
        self.hold_left = 0
        self._last_dist = math.inf

    def set_goal(self, goal: ArrayLike) -> None:
        """Head for ``goal`` (its first two components, metres)."""
        self.goal = np.asarray(goal, float)[:2].copy()
        self._last_dist = math.inf

    def arrived(self, position: ArrayLike) -> bool:
        """``True`` when there is no goal, it was reached, or the last move made no progress
        (e.g. blocked), once the dwell after the last move is over."""
        if self.hold_left > 0:
            return False
        if self.goal is None:
            return True
        dist = float(np.hypot(*(np.asarray(position, float)[:2] - self.goal)))
        if dist <= REACHED or dist >= self._last_dist - REACHED:
            self.goal = None
            return True
        return False

    def command(self, position: ArrayLike) -> Command:
        """The command of this period: hold while dwelling, else one move towards the goal."""
        if self.hold_left > 0 or self.goal is None:
            self.hold_left = max(self.hold_left - 1, 0)
            return Command.hold()
        pos = np.asarray(position, float)
        d = self.goal - pos[:2]
        dist = float(np.hypot(*d))
        self._last_dist = dist
        target = pos.copy()
        target[:2] = pos[:2] + d * min(1.0, self.step / dist) if dist > 0 else self.goal
        self.hold_left = self.dwell
        return Command.waypoint(target)
