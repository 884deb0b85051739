"""A clock shared by everything that advances in time (wind fields, plumes)."""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.errors import ConfigError


def check_dt(dt: float, field: str = "dt") -> float:
    """``dt`` as a float; :class:`ConfigError` unless it is finite and > 0 (seconds)."""
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError(field, f"must be a finite number > 0, got {dt}")
    return float(dt)


class TimeStepped:
    """Keeps ``t`` (seconds); :meth:`step` validates ``dt``, calls :meth:`_advance`, then ticks."""

    t: float = 0.0

    def reset(self, rng: np.random.Generator) -> None:
        """Restart at ``t = 0`` (subclasses also reset their state, drawing from ``rng``)."""
        self.t = 0.0

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Advance by ``dt`` seconds."""
        dt = check_dt(dt)
        self._advance(dt, rng)
        self.t += dt

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        """Evolve the state by ``dt``; steady models do nothing."""
