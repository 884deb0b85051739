"""A lattice walker: one cell along one axis per step (the agent of the lattice problem).

The walker lives on the lattice of nodes ``start + k * cell`` (``k`` integer per axis; anchored at
its start position, so starting on a cell centre keeps it on cell centres). It makes one move of
one ``cell`` along one axis every ``step_time`` seconds, and only to a node that is free and
reached by a free straight segment; a move that would leave the arena or enter an obstacle is
impossible: the walker stays (a blocked move), and a ``move`` or ``waypoint`` ends there.

Commands (see :mod:`odorloc.platforms.base`):

- ``move``: go to the node nearest to ``position + value``; a one-cell displacement along an axis
  is exactly one step (the moves of the lattice problem);
- ``waypoint``: go to the node nearest to the target;
- both walk one axis at a time, the axis with the largest remaining offset first (ties: the
  lowest axis);
- ``velocity``: one step per ``step_time`` along the axis of the largest velocity component, in
  its direction;
- ``hold``: stay.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Command
from odorloc.geometry.arena import Arena
from odorloc.platforms.base import Platform

__all__ = ["LatticeWalker", "LatticeWalkerParams"]


class LatticeWalkerParams(Params):
    """Parameters of :class:`LatticeWalker`.

    Attributes
    ----------
    cell : float, metres
        Lattice step (one move).
    step_time : float, seconds
        Time one move takes (the lattice problem: one move per control period).
    """

    cell: Positive = 1.0
    step_time: Positive = 1.0


@register("platform", "lattice", LatticeWalkerParams, "one cell per step on a lattice")
class LatticeWalker(Platform):
    """One cell along one axis per ``step_time`` (see the module docstring)."""

    params: LatticeWalkerParams

    def __init__(self, params: LatticeWalkerParams | None = None) -> None:
        super().__init__(params if params is not None else LatticeWalkerParams())

    def _reset_state(self) -> None:
        self._anchor = self.position
        self._clock = 0.0
        self._done = True

    @property
    def speed_limit(self) -> float:
        """``cell / step_time``, m/s."""
        return self.params.cell / self.params.step_time

    @property
    def ready(self) -> bool:
        """``True`` unless a move or waypoint is still under way."""
        return self._done

    def _node(self, point: np.ndarray) -> np.ndarray:
        """The lattice node nearest to ``point``."""
        k = np.round((point - self._anchor) / self.params.cell)
        return self._anchor + k * self.params.cell

    def _start(self, command: Command) -> None:
        if command.kind in ("waypoint", "move"):
            assert self._target is not None
            self._target = self._node(self._target)
        self._done = command.kind not in ("waypoint", "move")

    def _step_towards(self, offset: np.ndarray, arena: Arena) -> bool:
        """One move along the axis of the largest ``|offset|``; ``False`` if blocked."""
        pos = self._require_reset()
        axis = int(np.argmax(np.abs(offset)))
        end = pos.copy()
        end[axis] += math.copysign(self.params.cell, offset[axis])
        end = self._node(end)  # no drift from repeated additions
        # an empty box is convex: a node inside it is reached by a free segment
        free = (
            arena.contains(end)[0]
            if arena.occ is None
            else (arena.is_free(end)[0] and arena.segment_free(pos, end)[0])
        )
        if not free:
            self._collided += 1
            self._blocked = True
            return False
        self._translate(end, arena)
        if axis < 2:
            self._heading = math.atan2(end[1] - pos[1], end[0] - pos[0])
        return True

    def _advance(self, dt: float, arena: Arena) -> None:
        cmd = self._command
        self._clock += dt
        n = math.floor(self._clock / self.params.step_time + 1e-9)
        self._clock = max(self._clock - n * self.params.step_time, 0.0)
        if cmd is None or cmd.kind == "hold":
            return
        half = 0.5 * self.params.cell
        for _ in range(n):
            pos = self._require_reset()
            if cmd.kind == "velocity":
                if float(np.max(np.abs(cmd.value))) <= 0.0:
                    return
                if not self._step_towards(cmd.value, arena):
                    return
                continue
            assert self._target is not None
            off = self._target - pos
            if float(np.max(np.abs(off))) < half:
                self._done = True
                return
            if not self._step_towards(off, arena):
                self._done = True  # an impossible move ends the command
                return
        target = self._target
        if cmd.kind in ("waypoint", "move") and target is not None:
            self._done = float(np.max(np.abs(target - self._require_reset()))) < half
