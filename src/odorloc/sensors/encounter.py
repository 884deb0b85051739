"""Particle-encounter counter: Poisson hits at the plume's local encounter rate.

The Vergassola rate model (muc-osl paper, eqs. 1-3) gives an expected encounter rate
``R(r)`` (1/s); a sensor exposed for ``dt`` seconds counts ``h ~ Poisson(gain R(r) dt)`` hits.
"""

from __future__ import annotations

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

    @property
    def info(self) -> SensorInfo:
        """Threshold in hits per call period."""
        return SensorInfo(self.kind, float(self.params.threshold), "hits", False)

    def expected(self, plume: PlumeModel, position: ArrayLike, dt: float) -> float:
        """Expected hits in ``dt`` seconds at ``position``."""
        dt = check_dt(dt)
        rate = float(plume.encounter_rate(position_point(position, plume.dim))[0])
        if not (np.isfinite(rate) and rate >= 0):
            raise ConfigError("encounter_rate", f"plume returned an invalid rate {rate}")
        return self.params.gain * rate * dt

    def measure(
        self, plume: PlumeModel, position: ArrayLike, dt: float, rng: np.random.Generator
    ) -> GasReading:
        """Count hits at ``position`` over the period ``dt`` (seconds).

        Returns
        -------
        GasReading
        """
        mu = self.expected(plume, position, dt)
        hits = int(rng.poisson(mu))
        return GasReading(value=float(hits), raw=mu, detection=hits >= self.params.threshold)
