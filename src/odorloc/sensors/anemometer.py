"""Anemometer: noisy air velocity, optionally in the platform frame.

A moving platform's instrument feels the *relative* air velocity ``u_air - v_platform``. With
``relative=False`` (default) the reading is compensated back into the world frame by adding the
platform velocity (assumed known exactly from odometry), which is what the searchers expect.

Averaging (eq. 1, odor-path paper): the instrument delivers ``samples`` (``M_f``) readings per call
period and reports their mean. The wind model only exposes its state at the call instant, so the
sub-readings share the same true velocity and averaging only reduces the noise: the reported
noise has standard deviation ``noise_std / sqrt(samples)`` per axis.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params
from odorloc.core.registry import register
from odorloc.core.timestep import check_dt
from odorloc.sensors.base import position_point

if TYPE_CHECKING:
    from odorloc.wind.base import WindModel


class AnemometerParams(Params):
    """Parameters of :class:`Anemometer`.

    noise_std : float, m/s
        Standard deviation of each velocity component of one raw sub-reading.
    samples : int
        Sub-readings averaged per call period (``M_f``).
    relative : bool
        Report the platform-frame air velocity ``u_air - v_platform`` instead of the
        world-frame one.
    """

    noise_std: NonNegative = 0.0
    samples: int = Field(1, ge=1, le=10_000)
    relative: bool = False


@register("anemometer", "anemometer", AnemometerParams, "noisy averaging anemometer")
class Anemometer:
    """Measures the air velocity at the platform."""

    def __init__(self, params: AnemometerParams) -> None:
        self.params = params

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """The anemometer has no state between periods."""

    @property
    def effective_std(self) -> float:
        """Noise standard deviation of the averaged reading, m/s per axis."""
        return self.params.noise_std / math.sqrt(self.params.samples)

    def measure(
        self,
        wind: WindModel,
        position: ArrayLike,
        platform_velocity: ArrayLike | None,
        dt: float,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """One averaged reading.

        Parameters
        ----------
        wind : WindModel
        position : (d,) array_like, metres
        platform_velocity : (d,) array_like, m/s, optional
            Velocity of the platform over the ground (``None`` = at rest).
        dt : float, seconds
            Call period (checked; the reading itself is instantaneous).
        rng : numpy.random.Generator

        Returns
        -------
        (d,) ndarray, m/s
            World-frame air velocity, or platform-frame if ``relative``.
        """
        air = wind.velocity(position_point(position, wind.dim))[0]
        return self.respond(air, platform_velocity, dt, rng)

    def respond(
        self,
        air: ArrayLike,
        platform_velocity: ArrayLike | None,
        dt: float,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """One averaged reading from the true air velocity ``air`` ``(d,)`` m/s at the
        instrument (see :meth:`measure` for the other arguments)."""
        check_dt(dt)
        air = np.asarray(air, float).reshape(-1)
        d = air.size
        if platform_velocity is None:
            vp = np.zeros(d)
        else:
            vp = np.asarray(platform_velocity, float).reshape(-1)
            if vp.shape != (d,) or not all(map(math.isfinite, vp.tolist())):
                raise ConfigError(
                    "platform_velocity", f"expected {d} finite components, got {vp.shape}"
                )
        reading = air - vp
        if self.params.noise_std > 0:
            reading = reading + self.effective_std * rng.standard_normal(d)
        return reading if self.params.relative else reading + vp
