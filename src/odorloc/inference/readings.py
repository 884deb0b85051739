"""How an estimator reads an observation (registry family ``reading``).

A measurement model says how likely a reading is under given *conditions* (a recorded wind
window, an exposure time, a mean wind); which reading an observation holds and under which
conditions it is read is a choice of the estimator, made by one of these parts:

- ``wind-window`` (:class:`WindWindowReading`): the detection (0/1) under the wind recorded over
  the last ``window`` control periods and its variance over the last ``wind_var_window``
  seconds, as the Pang & Farrell likelihood of the indoor PF paper needs (eqs. 8-11);
- ``outcome-class`` (:class:`OutcomeClassReading`): the reading's outcome class (a hit count,
  capped at the model's last class, or the detection) under the mean of the last
  ``wind_average`` anemometer readings (its direction and velocity) and an exposure time, as
  the Poisson encounter models of infotaxis need (Vergassola et al. 2007).

Each part keeps the wind record it needs. :meth:`Reading.update` records an observation and
returns the conditions of its reading; :meth:`Reading.next_conditions` gives those a reading
taken one control period later would be read under, for a planner that anticipates it.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections import deque
from typing import Any, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Observation, SearchContext
from odorloc.models.base import MeasurementModel
from odorloc.models.pang_farrell import wind_variance
from odorloc.sensors.preprocessing import WindAverage

__all__ = [
    "OutcomeClassParams",
    "OutcomeClassReading",
    "Reading",
    "WindWindowParams",
    "WindWindowReading",
    "reading_class",
]


def reading_class(o: Observation, kind: str, n_classes: int) -> int:
    """The outcome class of a reading: ``min(hits, Z - 1)`` (``kind="hits"``) or the
    detection, 0 or 1."""
    if kind == "hits":
        h = float(o.gas)
        if not (math.isfinite(h) and h >= 0):
            raise ConfigError("reading", f"a hit count must be finite and >= 0, got {o.gas}")
        return min(round(h), n_classes - 1)
    return int(bool(o.detection))


class Reading(Configured, ABC):
    """Base class of the ``reading`` family (see the module docstring)."""

    @abstractmethod
    def reset(self, ctx: SearchContext) -> None:
        """Forget the record: a new episode."""

    @abstractmethod
    def update(self, o: Observation) -> dict[str, Any]:
        """Record ``o``; return the model conditions its reading is read under."""

    @abstractmethod
    def log_likelihood(
        self,
        o: Observation,
        model: MeasurementModel,
        hypotheses: np.ndarray,
        conditions: dict[str, Any],
    ) -> np.ndarray:
        """``log p(reading of o | hypothesis)`` ``(N,)`` over ``(N, d)`` source hypotheses."""

    @abstractmethod
    def next_conditions(self) -> dict[str, Any]:
        """Conditions of a reading taken one control period after the last update."""


# ---------------------------------------------------------------------- wind window
class WindWindowParams(Params):
    """Settings of :class:`WindWindowReading`.

    Attributes
    ----------
    window : int
        Wind records in the likelihood window (indoor PF paper: 20 at 0.5 s = 10 s).
    wind_var_window : float, seconds
        Time span of the readings whose variance is the wind variance (paper: 10 s).
    pad_window : bool
        Pad a window shorter than ``window`` records (start of an episode) with its oldest
        reading, so odor released before recording started is accounted for.
    """

    window: int = Field(20, ge=1, le=100_000)
    wind_var_window: Positive = 10.0
    pad_window: bool = True


@register("reading", "wind-window", WindWindowParams, "detection under the recorded wind window")
class WindWindowReading(Reading):
    """The detection under the recorded wind window and its variance (indoor PF paper, eq. 10).

    Conditions: ``wind_window`` ``(window, d)`` m/s (the records *before* the reading, oldest
    first), ``dt`` (the control period, s) and ``wind_var`` ``(d,)`` m^2/s^2 (the population
    variance of the readings of the last ``wind_var_window`` seconds, this one included; the
    model applies its own floor). Early in an episode fewer than ``window`` records exist
    although odor released before the robot started recording can already arrive; the window
    is then padded at its old end with the oldest available reading (the current one if none),
    i.e. the wind before the first record is assumed equal to it (``pad_window``).
    """

    params: WindWindowParams
    Params = WindWindowParams

    def reset(self, ctx: SearchContext) -> None:
        self.dt = ctx.dt
        self.n_var = max(2, round(self.params.wind_var_window / ctx.dt))
        self._winds: deque[np.ndarray] = deque(maxlen=max(self.params.window, self.n_var))
        self._wind_var: np.ndarray | None = None

    def _window(self, current: np.ndarray) -> np.ndarray:
        """The last ``window`` records, oldest first, padded (see the class)."""
        p = self.params
        w = list(self._winds)[-p.window :]
        if not w:
            w = [current]
        if p.pad_window and len(w) < p.window:
            w = [w[0]] * (p.window - len(w)) + w
        return np.array(w)

    def update(self, o: Observation) -> dict[str, Any]:
        wind = np.asarray(o.wind, float)
        window = self._window(wind)
        recent = [*list(self._winds)[-(self.n_var - 1) :], wind]
        self._wind_var = wind_variance(np.array(recent))
        self._winds.append(wind)
        return {"wind_window": window, "dt": self.dt, "wind_var": self._wind_var}

    def log_likelihood(
        self,
        o: Observation,
        model: MeasurementModel,
        hypotheses: np.ndarray,
        conditions: dict[str, Any],
    ) -> np.ndarray:
        pos = np.asarray(o.position, float)
        return model.log_likelihood(bool(o.detection), pos, hypotheses, **conditions)

    def next_conditions(self) -> dict[str, Any]:
        # one record later the window holds the last reading too; the variance is the last one
        if self._wind_var is None:
            raise ConfigError("reading", "no reading recorded yet")
        window = self._window(self._winds[-1])
        return {"wind_window": window, "dt": self.dt, "wind_var": self._wind_var}


# ---------------------------------------------------------------------- outcome classes
class OutcomeClassParams(Params):
    """Settings of :class:`OutcomeClassReading`.

    Attributes
    ----------
    reading : {"auto", "hits", "detection"}
        What a reading is: a hit count (class ``min(hits, Z - 1)``) or a detection (class 0/1);
        ``auto``: hits when the sensor counts hits, else detections.
    n_classes : int, optional
        Outcome classes of the model (default: 2 for detections, else the model's own choice).
    exposure : float, seconds, optional
        Exposure of one reading (the model's ``dt``; default the control period).
    wind_average : int
        Anemometer readings averaged for the model's wind.
    """

    reading: Literal["auto", "hits", "detection"] = "auto"
    n_classes: int | None = Field(None, ge=2, le=64)
    exposure: Positive | None = None
    wind_average: int = Field(10, ge=1, le=10_000)


@register(
    "reading", "outcome-class", OutcomeClassParams, "hit count or detection as an outcome class"
)
class OutcomeClassReading(Reading):
    """The reading's outcome class under the mean wind (see the module docstring).

    Conditions: ``dt`` (the exposure, s), ``wind`` ``(d,)`` m/s (the mean of the last
    ``wind_average`` readings), ``direction`` (its unit vector, when the air moves) and
    ``n_classes`` (when fixed). The likelihood of a reading is the model's probability of its
    class (:meth:`~odorloc.models.base.MeasurementModel.outcome_probabilities`).
    """

    params: OutcomeClassParams
    Params = OutcomeClassParams

    def reset(self, ctx: SearchContext) -> None:
        p = self.params
        kind = p.reading
        if kind == "auto":
            kind = "hits" if ctx.sensor.unit == "hits" else "detection"
        self.kind = kind
        if p.n_classes is not None:
            self.n_classes: int | None = p.n_classes
        else:
            self.n_classes = 2 if kind == "detection" else None
        self.exposure = p.exposure if p.exposure is not None else ctx.dt
        self.wind = WindAverage(p.wind_average)
        self._last: dict[str, Any] | None = None

    def conditions_for(self, wind: np.ndarray) -> dict[str, Any]:
        """The model conditions under the wind ``(d,)`` m/s."""
        cond: dict[str, Any] = {"dt": self.exposure, "wind": wind}
        speed = float(np.linalg.norm(wind))
        if speed > 1e-9:
            cond["direction"] = wind / speed
        if self.n_classes is not None:
            cond["n_classes"] = self.n_classes
        return cond

    def update(self, o: Observation) -> dict[str, Any]:
        self._last = self.conditions_for(self.wind.add(o.wind))
        return self._last

    def class_of(self, o: Observation, n_classes: int) -> int:
        """The outcome class of ``o`` among ``n_classes`` (:func:`reading_class`)."""
        return reading_class(o, self.kind, n_classes)

    def log_likelihood(
        self,
        o: Observation,
        model: MeasurementModel,
        hypotheses: np.ndarray,
        conditions: dict[str, Any],
    ) -> np.ndarray:
        pos = np.asarray(o.position, float)
        q = model.outcome_probabilities(pos[None, :], hypotheses, **conditions)
        z = self.class_of(o, q.shape[1])
        with np.errstate(divide="ignore"):
            return np.log(q[0, z])

    def next_conditions(self) -> dict[str, Any]:
        # the mean wind is the best guess of the next period's: the same conditions
        if self._last is None:
            raise ConfigError("reading", "no reading recorded yet")
        return self._last
