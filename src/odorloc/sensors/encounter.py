"""Particle-encounter counter: Poisson hits at the plume's local encounter rate.

The Vergassola rate model (muc-osl paper, eqs. 1-3) gives an expected encounter rate
``R(r)`` (1/s); a sensor exposed for ``dt`` seconds counts ``h ~ Poisson(gain R(r) dt)`` hits.
The first reading after :meth:`EncounterSensor.start` is the plume's
:meth:`~odorloc.plume.base.PlumeModel.initial_hits` when it has one (a search that starts from a
first hit, as in the lattice problem of infotaxis).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.core.timestep import check_dt
from odorloc.core.types import SensorInfo
from odorloc.sensors.base import GasReading, GasSensor, position_point

if TYPE_CHECKING:
    from odorloc.plume.base import PlumeModel


class EncounterSensorParams(Params):
    """Parameters of :class:`EncounterSensor`.

    gain : float
        Multiplier of the plume's encounter rate (relative sensor cross-section).
    threshold : int
        Hits needed for a detection (1: any hit is a detection).
    """

    gain: Positive = 1.0
    threshold: int = Field(1, ge=1, le=1_000_000)


@register("gas_sensor", "encounter", EncounterSensorParams, "Poisson particle-encounter counter")
class EncounterSensor(GasSensor):
    """Counts odor-particle encounters during each call period.

    ``measure`` returns a :class:`~odorloc.sensors.gas.GasReading` with ``value`` = hits (float),
    ``raw`` = expected hits ``gain R dt`` and ``detection`` = ``hits >= threshold``.
    """

    kind = "encounter"

    def __init__(self, params: EncounterSensorParams) -> None:
        self.params = params
        self._first_hits: int | None = None

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget the pending initial hits of a previous episode."""
        self._first_hits = None

    def start(self, plume: PlumeModel, position: ArrayLike) -> None:
        """The next reading is the plume's initial hits at the start ``position``, if it has any."""
        self._first_hits = plume.initial_hits(position_point(position, plume.dim)[0])

    @property
    def info(self) -> SensorInfo:
        """Threshold in hits per call period."""
        return SensorInfo(self.kind, float(self.params.threshold), "hits", False)

    def sample(self, plume: PlumeModel, points: np.ndarray) -> np.ndarray:
        """The plume's encounter rate at ``(Q, d)`` points, ``(Q,)`` 1/s."""
        return plume.encounter_rate(points)

    def expected(self, plume: PlumeModel, position: ArrayLike, dt: float) -> float:
        """Expected hits in ``dt`` seconds at ``position``."""
        rate = float(self.sample(plume, position_point(position, plume.dim))[0])
        return self._mean(rate, dt)

    def _mean(self, rate: float, dt: float) -> float:
        dt = check_dt(dt)
        if not (math.isfinite(rate) and rate >= 0):
            raise ConfigError("encounter_rate", f"plume returned an invalid rate {rate}")
        return self.params.gain * rate * dt

    def respond(self, value: float, dt: float, rng: np.random.Generator) -> GasReading:
        """Count hits over the period ``dt`` (seconds) at the encounter rate ``value`` (1/s).

        Returns
        -------
        GasReading
            ``value`` = hits, ``raw`` = expected hits ``gain R dt``.
        """
        mu = self._mean(float(value), dt)
        # The episode's first reading may be fixed by the plume (a search that starts from a hit).
        first, self._first_hits = self._first_hits, None
        hits = int(rng.poisson(mu)) if first is None else int(first)
        return GasReading(value=float(hits), raw=mu, detection=hits >= self.params.threshold)
