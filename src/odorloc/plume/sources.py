"""Odor sources: position, release rate and release modulation."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import model_validator

from odorloc.core.params import Finite, NonNegative, Params, Positive, Vector


class Modulation(Params):
    """Time modulation of a source's release rate.

    ``kind="constant"``: factor 1. ``kind="onoff"``: 1 during the first ``duty`` fraction of each
    period (shifted by ``phase`` seconds), else 0. ``kind="sine"``:
    ``1 + depth * sin(2 pi (t + phase) / period)``, clipped at 0. The period in force is
    ``period / frequency_factor`` (:attr:`effective_period`): ``frequency_factor`` 1, 2, 3 are the
    virtual-physics paper's standard, twice and treble release frequency.
    """

    kind: Literal["constant", "onoff", "sine"] = "constant"
    period: Positive = 10.0
    duty: float = 0.5
    depth: NonNegative = 0.5
    phase: Finite = 0.0
    frequency_factor: Positive = 1.0

    @model_validator(mode="after")
    def _check(self) -> Modulation:
        if not 0.0 < self.duty <= 1.0:
            raise ValueError("duty must be in (0, 1]")
        return self

    @property
    def effective_period(self) -> float:
        """The period in force, ``period / frequency_factor`` (seconds)."""
        return self.period / self.frequency_factor

    @property
    def peak_factor(self) -> float:
        """The largest :meth:`factor` over time."""
        return 1.0 + self.depth if self.kind == "sine" else 1.0

    def factor(self, t: float) -> float:
        """Release-rate factor at time ``t`` (seconds), dimensionless >= 0."""
        if self.kind == "constant":
            return 1.0
        T = self.effective_period
        if self.kind == "onoff":
            return 1.0 if ((t + self.phase) % T) < self.duty * T else 0.0
        return max(0.0, 1.0 + self.depth * math.sin(2.0 * math.pi * (t + self.phase) / T))


class Source(Params):
    """A point odor source.

    Parameters
    ----------
    position : (d,) tuple of float, metres
    rate : float
        Release rate; units follow the plume model (filaments/s for filament plumes, mass/s or
        the dimensionless ``Q`` of the rate model otherwise).
    modulation : Modulation
        Release modulation in time.
    """

    position: Vector
    rate: NonNegative = 1.0
    modulation: Modulation = Modulation()

    @model_validator(mode="after")
    def _check(self) -> Source:
        if len(self.position) not in (2, 3):
            raise ValueError("position must have 2 or 3 components")
        return self

    def rate_at(self, t: float) -> float:
        """Instantaneous release rate at ``t`` seconds."""
        return self.rate * self.modulation.factor(t)

    @property
    def peak_rate(self) -> float:
        """The largest release rate over time."""
        return self.rate * self.modulation.peak_factor

    @property
    def pos(self) -> np.ndarray:
        """Position as a ``(d,)`` float array, metres."""
        return np.asarray(self.position, float)
