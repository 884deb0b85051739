"""A PID-like concentration sensor whose reading is turned into an encounter count.

Rate-model estimators (the Vergassola Poisson model, eqs. 1-3 of the multi-UAV paper) expect a
count of odor encounters per exposure, while a photo-ionisation detector (PID) reports a
concentration. :class:`PIDCountSensor` is both: the PID part is a
:class:`~odorloc.sensors.gas.ConcentrationSensor` (delay, first-order lag, additive noise,
saturation; ppm), and its reading ``c`` at the end of each call period becomes a count

    hits = min(floor(c / ppm_per_hit), max_hits),

the number of whole "fresh filaments" of gas the reading holds: with ``ppm_per_hit`` the
concentration at the centre of a newly released filament (GADEN's ``Fc``, 100 ppm in Table 1 of
the multi-UAV paper), one hit is the gas of one filament seen at its centre, a reading below it
is no encounter, and overlapping filaments near the source give several. Aged filaments have
spread (their centre concentration falls as ``sigma^-3``), so far downwind a hit needs several
of them at once. ``max_hits`` optionally caps the count (``None``: no cap).

The sensor states the unit ``hits``, so a searcher that reads counts (the UAV members of
:mod:`odorloc.searchers.uav_team`) uses ``hits`` directly as its measurement; ``raw`` is the
true concentration (ppm) at the sensor and ``detection`` is ``hits >= threshold``.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import SensorInfo
from odorloc.sensors.base import GasReading, GasSensor
from odorloc.sensors.gas import ConcentrationSensor, ConcentrationSensorParams

__all__ = ["PIDCountParams", "PIDCountSensor", "hits_from_concentration"]


def hits_from_concentration(
    concentration: ArrayLike, ppm_per_hit: float, max_hits: int | None = None
) -> np.ndarray:
    """Encounter counts ``min(floor(c / ppm_per_hit), max_hits)`` of PID readings.

    Parameters
    ----------
    concentration : array_like, ppm
        Readings (negative values count as 0).
    ppm_per_hit : float, ppm
        Concentration of one encounter (> 0).
    max_hits : int, optional
        Cap on the count.

    Returns
    -------
    ndarray of int64, same shape
    """
    c = np.asarray(concentration, float)
    # a NaN or an infinite reading would cast to a huge negative count
    if not np.all(np.isfinite(c)):
        raise ConfigError("concentration", "every reading must be finite")
    if not (math.isfinite(ppm_per_hit) and ppm_per_hit > 0):
        raise ConfigError("ppm_per_hit", f"must be a finite number > 0, got {ppm_per_hit}")
    c = np.maximum(c, 0.0)
    # the small relative tolerance keeps exact multiples (200 ppm / 100 ppm) from flooring short
    hits = np.floor(c / float(ppm_per_hit) * (1.0 + 1e-12)).astype(np.int64)
    if max_hits is not None:
        hits = np.minimum(hits, int(max_hits))
    return hits


class PIDCountParams(Params):
    """Parameters of :class:`PIDCountSensor`.

    ppm_per_hit : float, ppm
        Concentration of one encounter (default 100 ppm: GADEN's filament centre concentration
        ``Fc`` in the multi-UAV paper's Table 1).
    max_hits : int, optional
        Cap on the count of one period; ``None``: none.
    threshold : int
        Hits needed for a detection.
    delay : float, seconds
        PID transport delay (rounded to whole call periods).
    tau : float, seconds
        PID first-order response time constant; 0 = instantaneous.
    noise_std : float, ppm
        Standard deviation of the PID's additive Gaussian noise.
    max_value : float, ppm, optional
        PID saturation; ``None``: none.
    start : {"steady", "zero"}
        PID state at the first call (see :class:`~odorloc.sensors.gas.ConcentrationSensor`).
    """

    ppm_per_hit: Positive = 100.0
    max_hits: int | None = Field(None, ge=1, le=1_000_000)
    threshold: int = Field(1, ge=1, le=1_000_000)
    delay: NonNegative = 0.0
    tau: NonNegative = 0.0
    noise_std: NonNegative = 0.0
    max_value: Positive | None = None
    start: Literal["steady", "zero"] = "steady"


@register("gas_sensor", "pid-count", PIDCountParams, "PID reading turned into encounter counts")
class PIDCountSensor(GasSensor):
    """A PID (ppm) whose reading at the end of each period is a count of encounters.

    Parameters
    ----------
    params : PIDCountParams
    """

    kind = "pid-count"

    def __init__(self, params: PIDCountParams) -> None:
        self.params = params
        self.pid = ConcentrationSensor(
            ConcentrationSensorParams(
                delay=params.delay,
                tau=params.tau,
                noise_std=params.noise_std,
                max_value=params.max_value,
                threshold=params.ppm_per_hit,
                start=params.start,
            )
        )

    @property
    def info(self) -> SensorInfo:
        """Threshold in hits per call period."""
        return SensorInfo(self.kind, float(self.params.threshold), "hits", False)

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget the PID's delay buffer and lag state."""
        self.pid.reset(rng)

    def respond(self, value: float, dt: float, rng: np.random.Generator) -> GasReading:
        """One period's reading from the true concentration ``value`` (ppm) at the sensor.

        The PID chain runs on ``value`` (:meth:`GasSensor.sample` gives the concentration) and
        its output is counted in encounters.

        Returns
        -------
        GasReading
            ``value``: hits (a whole number); ``raw``: true concentration, ppm;
            ``detection``: ``hits >= threshold``.
        """
        r = self.pid.respond(value, dt, rng)
        p = self.params
        hits = int(hits_from_concentration(r.value, p.ppm_per_hit, p.max_hits))
        return GasReading(value=float(hits), raw=r.raw, detection=hits >= p.threshold)
