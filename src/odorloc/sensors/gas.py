"""Gas concentration sensor: delay, first-order lag, gain/offset, noise, saturation, threshold.

The processing chain, applied once per call of :meth:`ConcentrationSensor.measure`:

1. true concentration ``c`` at the sensor position (``plume.concentration``);
2. pure transport delay: the value ``n = round(delay / dt)`` calls ago, from a ring buffer of
   past true values (the delay is rounded to whole call periods; ``dt`` must stay constant);
3. first-order response lag with time constant ``tau``, discretised exactly for an input held
   constant over the call period, ``y += (1 - exp(-dt / tau)) (x - y)``; a step of size 1 seen
   at call 0 gives ``y_k = 1 - exp(-(k + 1) dt / tau)``;
4. ``gain * y + offset`` (offset = baseline reading in clean air);
5. additive Gaussian noise of standard deviation ``noise_std``;
6. saturation: clip to ``[0, max_value]``;
7. detection ``value >= threshold``; with ``binarize`` the value itself becomes 1.0 / 0.0.

A PMS5003-style particle counter binarised at a threshold (indoor-pf-entropy paper: "200 ppm")
is this class with ``threshold`` set and ``binarize=True``.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.timestep import check_dt
from odorloc.core.types import SensorInfo
from odorloc.sensors.base import GasReading, GasSensor


class ConcentrationSensorParams(Params):
    """Parameters of :class:`ConcentrationSensor`.

    delay : float, seconds
        Pure delay (rounded to whole call periods).
    tau : float, seconds
        First-order response time constant; 0 = instantaneous.
    gain : float
        Reading units per concentration unit.
    offset : float
        Baseline reading in clean air (reading units).
    noise_std : float
        Standard deviation of the additive Gaussian noise (reading units).
    max_value : float, optional
        Saturation level; ``None`` = no upper limit (the reading is always clipped at 0).
    threshold : float
        Detection threshold (reading units): detection is ``value >= threshold``.
    binarize : bool
        Output 1.0 on detection and 0.0 otherwise instead of the analogue value.
    start : {"steady", "zero"}
        State at the first call after :meth:`reset`: ``"steady"`` assumes the sensor has been
        sitting at its first position (delay buffer and lag filled with the first true value);
        ``"zero"`` assumes clean air before.
    """

    delay: NonNegative = 0.0
    tau: NonNegative = 0.0
    gain: Finite = 1.0
    offset: Finite = 0.0
    noise_std: NonNegative = 0.0
    max_value: Positive | None = None
    threshold: Finite = 1.0
    binarize: bool = False
    start: Literal["steady", "zero"] = "steady"


@register("gas_sensor", "concentration", ConcentrationSensorParams, "gas concentration sensor")
class ConcentrationSensor(GasSensor):
    """A concentration sensor with delay, lag, gain, noise, saturation and threshold.

    Parameters
    ----------
    params : ConcentrationSensorParams
    """

    kind = "concentration"

    def __init__(self, params: ConcentrationSensorParams) -> None:
        self.params = params
        self._buf: np.ndarray | None = None
        self._head = 0
        self._y = 0.0
        self._dt: float | None = None

    @property
    def info(self) -> SensorInfo:
        """Threshold in the sensor's output units (``"reading"``)."""
        p = self.params
        return SensorInfo(self.kind, float(p.threshold), "reading", bool(p.binarize))

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget the delay buffer and the lag state (``rng`` unused: no random initial state)."""
        self._buf = None
        self._head = 0
        self._y = 0.0
        self._dt = None

    def delay_steps(self, dt: float) -> int:
        """Delay in whole call periods, ``round(delay / dt)``."""
        return round(self.params.delay / dt)

    def _process(self, c: float, dt: float) -> float:
        """Delay then lag of the true value ``c``: the noiseless sensor response."""
        p = self.params
        if self._dt is None:
            self._dt = dt
            n = self.delay_steps(dt)
            fill = c if p.start == "steady" else 0.0
            self._buf = np.full(n + 1, fill)
            self._head = 0
            self._y = fill
        elif abs(dt - self._dt) > 1e-9 * self._dt:
            raise ConfigError("dt", f"must stay constant ({self._dt:g} s), got {dt:g} s")
        buf = self._buf
        assert buf is not None
        # Ring buffer of the last n + 1 true values: write now, read the oldest.
        buf[self._head] = c
        self._head = (self._head + 1) % len(buf)
        x = float(buf[self._head])
        if p.tau > 0:
            self._y += (1.0 - math.exp(-dt / p.tau)) * (x - self._y)
        else:
            self._y = x
        return self._y

    def respond(self, value: float, dt: float, rng: np.random.Generator) -> GasReading:
        """Feed one true concentration ``value`` through the chain (no plume needed)."""
        dt = check_dt(dt)
        c = float(value)
        if not math.isfinite(c):
            raise ConfigError("concentration", f"must be finite, got {c}")
        p = self.params
        y = p.gain * self._process(c, dt) + p.offset
        if p.noise_std > 0:
            y += p.noise_std * float(rng.standard_normal())
        y = max(0.0, y)
        if p.max_value is not None:
            y = min(y, p.max_value)
        det = y >= p.threshold
        value = (1.0 if det else 0.0) if p.binarize else y
        return GasReading(value=value, raw=c, detection=bool(det))
