"""Square-spiral search with a proximity index (as in MAPIRlab's GSL package, "spiral").

The agent drives a square spiral: each leg turns 90 degrees to the left of the previous one and
the leg length grows by ``step_increment`` every second leg, starting at ``initial_step`` (the
first leg is the diagonal of one step forward and one to the left). After every leg it stops and
measures for ``measure_periods`` control periods. The *proximity index* of such a measurement
window is ``kmu * mean(c) + kp * dt * sum of the window's local maxima``: it grows with both the
level and the intermittent peaks of the signal, so it rises as the agent nears a source. When it
beats the best index so far, the spiral restarts small around the current position; after
``patience`` windows in a row without a better index the best is halved (``decay``), so a
fluctuation cannot hold the spiral off for ever.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from odorloc.core.params import NonNegative, Params, Positive
from odorloc.geometry.arena import Arena

__all__ = ["Spiral", "SpiralLegParams", "SpiralParams", "proximity_index"]


class SpiralLegParams(Params):
    """The spiral's legs: the first leg's step and its growth every second leg (metres)."""

    initial_step: Positive = 0.6
    step_increment: NonNegative = 0.3


class SpiralParams(SpiralLegParams):
    """Settings of the spiral search with a proximity index (see the module docstring)."""

    measure_periods: int = Field(2, ge=1, le=10_000)
    kmu: NonNegative = 0.5
    kp: NonNegative = 1.0
    patience: int = Field(3, ge=0, le=10_000)
    decay: float = Field(0.5, gt=0.0, le=1.0)


def proximity_index(readings: np.ndarray, dt: float, kmu: float, kp: float) -> float:
    """``kmu * mean + kp * dt * sum(local maxima)`` of a window of readings ``(K,)``.

    A local maximum is a reading above both neighbours (the window's ends count against their
    one neighbour).
    """
    c = np.asarray(readings, float)
    if c.size == 0:
        return 0.0
    padded = np.concatenate([[-np.inf], c, [-np.inf]])
    peak = (c > padded[:-2]) & (c > padded[2:])
    return float(kmu * c.mean() + kp * dt * c[peak].sum())


class Spiral:
    """One agent's spiral state: the legs, the best proximity index and its patience.

    Parameters
    ----------
    params : SpiralLegParams
        The legs (a :class:`SpiralParams` also gives :meth:`judge` its patience and decay).
    """

    def __init__(self, params: SpiralLegParams) -> None:
        self.params = params
        self.best = 0.0
        self.misses = 0
        self.restarts = 0
        self.restart(0.0)

    def restart(self, heading: float) -> None:
        """Start a new spiral facing ``heading`` rad."""
        self.step = self.params.initial_step
        self.leg = 0
        self.heading = float(heading)

    def judge(self, index: float, heading: float, patience: int, decay: float) -> bool:
        """Feed a window's proximity index; ``True`` when it restarts the spiral.

        After ``patience`` windows in a row without a better index the best is multiplied by
        ``decay``.
        """
        if index > self.best:
            self.best = index
            self.misses = 0
            self.restarts += 1
            self.restart(heading)
            return True
        self.misses += 1
        if self.misses > patience:
            self.best *= decay
            self.misses = 0
        return False

    def next_offset(self) -> np.ndarray:
        """Horizontal displacement ``(2,)`` of the next leg, metres; advances the spiral."""
        h = self.heading
        if self.leg == 0:
            # the first leg: one step forward and one to the left, then face along it
            d = self.step * np.array([math.cos(h) - math.sin(h), math.sin(h) + math.cos(h)])
            self.heading = h + math.pi / 4
        else:
            if self.leg % 2 == 0:
                self.step += self.params.step_increment
            self.heading = h + math.pi / 2
            d = self.step * np.array([math.cos(self.heading), math.sin(self.heading)])
        self.leg += 1
        return d

    def free_leg(
        self, arena: Arena, pos: np.ndarray, max_skips: int, heading: float | None = None
    ) -> np.ndarray | None:
        """Target ``(d,)`` of the next leg that walls and obstacles leave free, or ``None``.

        Up to ``max_skips`` blocked legs are skipped; then the spiral restarts facing
        ``heading`` (default: where it faces then) and tries as many legs again.
        """
        for attempt in range(2):
            for _ in range(max_skips + 1):
                target = np.array(pos, dtype=float)
                target[:2] += self.next_offset()
                if arena.segment_free(pos, target)[0]:
                    return target
            if attempt == 0:
                self.restart(self.heading if heading is None else heading)
        return None
