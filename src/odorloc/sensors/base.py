"""The gas-sensor interface: a reading per control period, and the detection threshold.

Every gas sensor turns the plume at its position into a :class:`GasReading` once per call
period and states its detection threshold with the unit its readings are in
(:attr:`GasSensor.info`), which is what a searcher is told in
:attr:`~odorloc.core.types.SearchContext.sensor`.

A reading is two parts: :meth:`GasSensor.sample` reads the plume quantity the sensor responds to
(the concentration, or the encounter rate) at any number of points at once and depends on the
plume only, and :meth:`GasSensor.respond` runs one sensor's own chain (delay, lag, noise,
threshold, counting) on its value. :meth:`GasSensor.measure` is both for one position; the
episode samples the plume once for all its agents and lets each agent's sensor respond.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.types import SensorInfo

if TYPE_CHECKING:
    from odorloc.plume.base import PlumeModel

__all__ = ["GasReading", "GasSensor", "position_point"]


@dataclass(frozen=True)
class GasReading:
    """One gas-sensor reading.

    Attributes
    ----------
    value : float
        Output after the sensor's processing (reading units, or a count).
    raw : float
        True concentration (or expected count) at the sensor position at this call.
    detection : bool
        Binarised reading.
    """

    value: float
    raw: float
    detection: bool


def position_point(position: ArrayLike, dim: int) -> np.ndarray:
    """A sensor position as a ``(1, dim)`` array; :class:`ConfigError` if malformed."""
    p = np.asarray(position, float).reshape(-1)
    if p.shape != (dim,) or not np.all(np.isfinite(p)):
        raise ConfigError("position", f"expected {dim} finite components, got {np.shape(position)}")
    return p[None, :]


class GasSensor(ABC):
    """Base class of gas sensors (one instance per agent)."""

    params: Params
    #: Registry name of the sensor family (set by subclasses).
    kind: str = "gas"

    def reset(self, rng: np.random.Generator | None = None) -> None:  # noqa: B027
        """Forget any state between episodes; default none."""

    def start(self, plume: PlumeModel, position: ArrayLike) -> None:  # noqa: B027
        """The episode starts with the sensor at ``position`` (``(d,)`` metres) in ``plume``.

        Called after :meth:`reset` once the world is prepared; default nothing. A sensor whose
        first reading the plume fixes (an initial hit) takes it here.
        """

    def sample(self, plume: PlumeModel, points: np.ndarray) -> np.ndarray:
        """The plume quantity the sensor responds to at ``(Q, d)`` points, ``(Q,)``.

        Default: the concentration. It must depend on the plume alone (not on the sensor's
        state), so that one call serves the sensors of every agent.
        """
        return plume.concentration(points)

    @abstractmethod
    def respond(self, value: float, dt: float, rng: np.random.Generator) -> GasReading:
        """One call period's reading from the sampled ``value`` (:meth:`sample`) at the sensor,
        ``dt`` seconds after the previous call."""

    def measure(
        self, plume: PlumeModel, position: ArrayLike, dt: float, rng: np.random.Generator
    ) -> GasReading:
        """Read the sensor at ``position`` (``(d,)`` metres) once per call period ``dt`` (s)."""
        value = self.sample(plume, position_point(position, plume.dim))
        return self.respond(float(value[0]), dt, rng)

    @property
    @abstractmethod
    def info(self) -> SensorInfo:
        """The detection threshold with its unit, as searchers are told it."""
