"""Hits on a lattice in a mean wind: the windy source-tracking problem of otto-benchmark.

The windy POMDP of Loisy & Eloy (Eur. Phys. J. E 46, 2023; the otto-benchmark package) is
dimensionless: lengths in cells, time in steps. A source of emission ``R`` in a wind ``V``
along the first axis, with turbulent coherence time ``tau``, gives an agent at distance ``d``
(cells, Euclidean) and downwind offset ``x = x_agent - x_source`` (cells) a Poisson number of
hits per step of mean

    ``mu = R / d * exp(V x / 2 - d / lambda)``,  ``lambda = sqrt((tau / V^2) / (1 + tau / 4))``

(the advected form of the Vergassola rate, read on a 2-D lattice; ``d`` is taken as 1 on the
source's cell, whose hypothesis the search excludes anyway). Hits are censored to ``n_hits``
classes (``0, ..., Z - 2`` and ``Z - 1 or more``); the benchmark's cases use two (detection or
not). Their settings: an 81 x 41 grid, the agent starting at cell (65, 20), ``V = 2``,
``tau = 150``, and ``R = 2.5`` ("medium detections") or ``R = 0.25`` ("low detections").

The model is translation invariant (the law depends on the sensor-minus-source offset only), so
grid filters and lattice planners read it through offset tables
(:func:`odorloc.models.lattice.tabulate`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.models.lattice import IsotropicHitModel

__all__ = ["WindyHitModel", "WindyHitParams", "windy_length", "windy_mean_hits"]

FloatArray = NDArray[np.float64]


def windy_length(wind: float, tau: float) -> float:
    """Dispersion length ``lambda = sqrt((tau / V^2) / (1 + tau / 4))``, cells."""
    if not (wind > 0 and tau > 0):
        raise ConfigError("wind", "the windy lattice needs a positive wind and coherence time")
    return math.sqrt((tau / wind**2) / (1.0 + tau / 4.0))


def windy_mean_hits(
    offset: ArrayLike, rate: ArrayLike, wind: float, tau: float, cell: float = 1.0
) -> FloatArray:
    """Mean hits per step at sensor-minus-source offsets (module docstring).

    Parameters
    ----------
    offset : (..., d) array_like, metres
        Sensor position minus source position; the wind blows along the first axis.
    rate : float or array_like
        ``R``, broadcast against ``offset[..., 0]``.
    wind, tau : float
        ``V`` and ``tau`` (dimensionless).
    cell : float, metres
        Lattice step (lengths are counted in cells).
    """
    o = np.asarray(offset, float) / cell
    d = np.sqrt((o * o).sum(axis=-1))
    d = np.where(d > 0, d, 1.0)
    lam = windy_length(wind, tau)
    return np.asarray(rate, float) / d * np.exp(0.5 * wind * o[..., 0] - d / lam)


class WindyHitParams(Params):
    """Parameters of :class:`WindyHitModel`.

    Attributes
    ----------
    rate : float
        ``R``: dimensionless emission (hits per step scale).
    wind : float
        ``V``: dimensionless mean wind, along the first axis.
    tau : float
        Dimensionless turbulent coherence time.
    cell : float, metres
        Lattice step.
    n_hits : int
        Hit classes (the last holds ``n_hits - 1`` or more).
    background : float
        Mean hits per step without the source (false alarms; 0 in otto-benchmark).
    """

    rate: Positive = 2.5
    wind: Positive = 2.0
    tau: Positive = 150.0
    cell: Positive = 1.0
    n_hits: int = Field(2, ge=2, le=64)
    background: NonNegative = 0.0


@register("model", "lattice-windy", WindyHitParams, "censored Poisson hits, mean wind (OTTO)")
class WindyHitModel(IsotropicHitModel):
    """Censored Poisson hits of the windy lattice problem (module docstring): the isotropic
    model's censored classes and likelihoods over the windy mean.

    Conditions: ``release`` (``R`` per hypothesis, default the parameter ``rate``).
    """

    Params = WindyHitParams
    params: WindyHitParams  # type: ignore[assignment]

    def __init__(self, params: WindyHitParams | None = None) -> None:
        self.params = params or WindyHitParams()  # type: ignore[assignment]
        windy_length(self.params.wind, self.params.tau)

    def n_classes(self, dim: int) -> int:
        """``Z``: the parameter ``n_hits``."""
        return self.params.n_hits

    def default_release(self) -> float:
        """``R`` of a hypothesis without its own ``release``: the parameter ``rate``."""
        return self.params.rate

    def offset_mean_hits(self, offsets: np.ndarray, release: np.ndarray) -> FloatArray:
        """``mu`` at sensor-minus-source ``offsets`` ``(M, N, d)``, ``(M, N)``."""
        p = self.params
        return windy_mean_hits(offsets, release, p.wind, p.tau, p.cell) + p.background
