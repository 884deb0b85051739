"""Belief containers shared by estimators, planners, the recorder and the plots.

Beliefs are arrays, not lists of objects; normalisation happens in log space.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.geometry.grid import CellGrid
from odorloc.inference.weights import gaussian_fit, weight_entropy


class Belief(Protocol):
    """What every belief offers the recorder: its arrays (particles and weights, grid
    masses, map layers, ...)."""

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays describing the belief."""
        ...


@dataclass(frozen=True, eq=False)
class ParticleBelief:
    """A weighted particle set over source positions.

    Parameters
    ----------
    positions : (N, d) ndarray, metres
    log_weights : (N,) ndarray
        Normalised log-weights (``logsumexp == 0``).
    found_radius : float, metres
        A source within this distance of where the agent stands is found there (a search that
        ends when the source is reached; a planner predicts that outcome too). 0: the search
        does not end by reaching.
    """

    positions: np.ndarray
    log_weights: np.ndarray
    found_radius: float = 0.0

    @property
    def weights(self) -> np.ndarray:
        """``(N,)`` weights summing to one."""
        return np.exp(self.log_weights)

    @property
    def mean(self) -> np.ndarray:
        """Weighted mean position, ``(d,)`` metres."""
        return self.weights @ self.positions

    @property
    def cov(self) -> np.ndarray:
        """Weighted covariance, ``(d, d)`` m^2."""
        return gaussian_fit(self.positions, self.weights)[1]

    @property
    def ess(self) -> float:
        """Effective sample size ``1 / sum w^2``."""
        w = self.weights
        return float(1.0 / np.sum(w * w))

    @property
    def entropy(self) -> float:
        """Shannon entropy of the weights ``-sum w log w`` (nats)."""
        return weight_entropy(self.weights)

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording."""
        return {"positions": self.positions.copy(), "weights": self.weights}


@dataclass(frozen=True, eq=False)
class GridBelief:
    """A probability grid over source positions.

    Parameters
    ----------
    grid : CellGrid
        The cells.
    prob : (nx, ny[, nz]) ndarray
        Cell probabilities summing to one; index ``[i, j]`` is x then y.
    extra : dict of str to ndarray
        Further per-cell arrays to record (e.g. the Dempster-Shafer masses).
    """

    grid: CellGrid
    prob: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def lower(self) -> tuple[float, ...]:
        """Corner of the grid, metres."""
        return self.grid.lower

    @property
    def upper(self) -> tuple[float, ...]:
        """Far corner of the grid, metres."""
        return self.grid.upper

    def centers(self) -> np.ndarray:
        """Cell centres, ``(M, d)`` metres, in C order of :attr:`prob`."""
        return self.grid.flat_centers()

    @property
    def mean(self) -> np.ndarray:
        """Expected source position, ``(d,)`` metres."""
        return self.prob.ravel() @ self.centers()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the position, ``(d, d)`` m^2."""
        return gaussian_fit(self.centers(), self.prob.ravel())[1]

    @property
    def entropy(self) -> float:
        """Shannon entropy (nats)."""
        return weight_entropy(self.prob.ravel())

    @property
    def ess(self) -> float:
        """``1 / sum p^2`` (the effective number of cells)."""
        return float(1.0 / np.sum(self.prob**2))

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording: ``prob``, the extra arrays, and the grid's extent (``lower``,
        ``upper``, metres) so that a figure can place it."""
        return {
            "prob": self.prob.copy(),
            **{k: v.copy() for k, v in self.extra.items()},
            "lower": np.asarray(self.lower, float),
            "upper": np.asarray(self.upper, float),
        }


def histogram_entropy(
    belief: ParticleBelief, lower: Sequence[float], upper: Sequence[float], cell: float
) -> float:
    """Shannon entropy (nats) of the weighted particle histogram on ``cell``-sized bins.

    Unlike the weight entropy it keeps falling through resampling as the cloud contracts.

    Parameters
    ----------
    belief : ParticleBelief
    lower, upper : (d,) sequence of float, metres
        Extent binned (e.g. the arena's).
    cell : float, metres

    Raises
    ------
    ConfigError
        When ``cell`` is not a finite number > 0 or no particle weight lies inside the extent
        (particles outside it are left out of the histogram).
    """
    if not (math.isfinite(cell) and cell > 0):
        raise ConfigError("cell", f"must be a finite number > 0, got {cell}")
    lo = np.asarray(lower, float)
    hi = np.asarray(upper, float)
    bins = [max(1, math.ceil(s / cell)) for s in hi - lo]
    rng_ = list(zip(lo, hi, strict=True))
    h, _ = np.histogramdd(belief.positions, bins=bins, range=rng_, weights=belief.weights)
    q = h.ravel()
    if not q.sum() > 0:
        # an empty histogram would otherwise report entropy 0, i.e. a certain belief
        raise ConfigError("upper", "no particle weight lies inside the binned extent")
    q = q[q > 0] / q.sum()
    return float(-np.sum(q * np.log(q)))
