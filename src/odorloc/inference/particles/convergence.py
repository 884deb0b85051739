"""The dual convergence test of the indoor PF paper, as a stopping rule for particle filters.

- Particle convergence (eq. 15): ``sigma_k^2 = sum_i w_i |L^i - P_k|^2 <= R_conv``. The paper
  defines the "weighted variance" as the sum of squared weighted distances, i.e. the trace of
  the weighted covariance (m^2), and compares it with the "convergence radius" R_conv = 0.5
  (given in m). ``variance="trace"`` follows the text literally: trace (m^2) <= R_conv read as a
  number. ``variance="radius"`` compares the RMS distance ``sqrt(trace)`` (m) with R_conv;
  ``variance="max_axis"`` compares the largest per-axis variance (m^2).
- Estimate convergence (eq. 16): the history holds the last ``K = 20`` estimates ``{P_j}`` (one
  per filter update; the flattened ``P_j | z_j = 1`` is read as ``j = 1..20``); it must be full
  and every element within ``R_err`` of the history mean.
- The current estimate must be admissible (not inside an obstacle nor outside the arena).

Stopping rules form the registry family ``stopping_rule``: ``dual-convergence``
(:class:`DualConvergence`) and ``never`` (:class:`NeverStop`, for searches that end otherwise,
e.g. when the source is reached).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, Params, Positive
from odorloc.core.registry import register


class ParticleFilter(Protocol):
    """What a stopping rule reads of :class:`~odorloc.inference.particles.filter.ParticleFilter`
    (named by its shape: the filter module imports this one)."""

    @property
    def history(self) -> np.ndarray: ...

    @property
    def history_capacity(self) -> int: ...

    @property
    def constraint(self) -> Any: ...

    def spread(self, variance: Literal["trace", "radius", "max_axis"] = "trace") -> float: ...

    def estimate(self) -> np.ndarray: ...


__all__ = [
    "ConvergenceParams",
    "ConvergenceStatus",
    "DualConvergence",
    "NeverStop",
    "StoppingRule",
    "spread",
]


def spread(
    positions: np.ndarray, weights: np.ndarray, variance: Literal["trace", "radius", "max_axis"]
) -> float:
    """Particle spread: trace of the weighted covariance (m^2, eq. 15), its square root
    (``"radius"``, m) or the largest per-axis variance (``"max_axis"``, m^2)."""
    dx = positions - weights @ positions
    per_axis = weights @ (dx * dx)
    if variance == "trace":
        return float(per_axis.sum())
    if variance == "radius":
        return float(math.sqrt(per_axis.sum()))
    return float(per_axis.max())


class ConvergenceParams(Params):
    """Dual convergence test of the indoor PF paper (eqs. 15-16).

    Parameters
    ----------
    r_conv : float
        Threshold on the particle spread (0.5; m^2 for ``"trace"``/``"max_axis"``, m for
        ``"radius"``).
    r_err : float, metres
        Radius around the history mean that every stored estimate must lie within.
    history : int
        Number of estimates that must be stored (and agree) before declaring.
    variance : {"trace", "radius", "max_axis"}
        How the particle spread is measured, see the module docstring.
    """

    r_conv: Positive = 0.5
    r_err: Positive = 0.5
    history: int = Field(20, ge=1, le=100_000)
    variance: Literal["trace", "radius", "max_axis"] = "trace"


@dataclass(frozen=True)
class ConvergenceStatus:
    """Outcome of :meth:`ParticleFilter.convergence` with each criterion separately."""

    spread: float
    """Particle spread in the chosen measure (m^2 or m)."""
    particles_converged: bool
    history_full: bool
    max_history_deviation: float
    """Largest distance of a stored estimate from the history mean, metres (inf if empty)."""
    estimates_converged: bool
    estimate_free: bool

    @property
    def converged(self) -> bool:
        """All criteria hold."""
        return (
            self.particles_converged
            and self.history_full
            and self.estimates_converged
            and self.estimate_free
        )


class StoppingRule(Configured, ABC):
    """Base class of the ``stopping_rule`` family: when a filter's estimate may be declared."""

    @property
    def history(self) -> int:
        """Estimates the rule needs the filter to keep (default 1)."""
        return 1

    @abstractmethod
    def converged(self, pf: ParticleFilter) -> bool:
        """Whether ``pf``'s estimate may be declared."""

    def diagnostics(self, pf: ParticleFilter) -> dict[str, float]:
        """Scalars of the rule worth recording (default none)."""
        return {}


class NeverParams(Params):
    """The ``never`` rule has no settings."""


@register("stopping_rule", "never", NeverParams, "never declare (the search ends otherwise)")
class NeverStop(StoppingRule):
    """A rule that never holds: for searches that end when the source is reached."""

    params: NeverParams
    Params = NeverParams

    def converged(self, pf: ParticleFilter) -> bool:
        return False


@register(
    "stopping_rule", "dual-convergence", ConvergenceParams, "particle and estimate convergence"
)
class DualConvergence(StoppingRule):
    """The stopping rule of eqs. 15-16: ``converged(filter)`` when every criterion holds."""

    params: ConvergenceParams
    Params = ConvergenceParams

    def __init__(self, params: ConvergenceParams | None = None) -> None:
        super().__init__(params or ConvergenceParams())

    @property
    def history(self) -> int:
        """The ``history`` of the test."""
        return self.params.history

    def status(self, pf: ParticleFilter) -> ConvergenceStatus:
        """Each criterion of the test, evaluated on ``pf``.

        Raises :class:`~odorloc.core.errors.ConfigError` when ``pf`` keeps fewer estimates than
        the test needs: its history could never fill and the test never hold.
        """
        c = self.params
        if pf.history_capacity < c.history:
            raise ConfigError(
                "history",
                f"the filter keeps {pf.history_capacity} estimates but the convergence test "
                f"needs {c.history}",
            )
        sp = pf.spread(c.variance)
        hist = pf.history[-c.history :]
        full = len(hist) >= c.history
        if len(hist):
            dev = float(np.linalg.norm(hist - hist.mean(axis=0), axis=1).max())
        else:
            dev = math.inf
        est = pf.estimate()
        free = True if pf.constraint is None else bool(pf.constraint.admissible(est[None, :])[0])
        return ConvergenceStatus(
            spread=sp,
            particles_converged=sp <= c.r_conv,
            history_full=full,
            max_history_deviation=dev,
            estimates_converged=full and dev <= c.r_err,
            estimate_free=free,
        )

    def converged(self, pf: ParticleFilter) -> bool:
        """``True`` when the filter has converged."""
        return self.status(pf).converged

    def diagnostics(self, pf: ParticleFilter) -> dict[str, float]:
        """``spread``: the particle spread in the test's measure (m^2 or m)."""
        return {"spread": pf.spread(self.params.variance)}
