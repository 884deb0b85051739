"""Belief containers shared by estimators, planners, the recorder and the plots.

Beliefs are arrays, not lists of objects; normalisation happens in log space.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp


def normalize_log_weights(log_w: np.ndarray) -> np.ndarray:
    """Log-weights shifted so that ``logsumexp == 0``.

    If every weight underflowed (all ``-inf``) or is NaN, the weights are reset to uniform
    rather than propagating NaN: the data then carried no usable information.
    """
    log_w = np.asarray(log_w, float)
    finite = np.isfinite(log_w)
    if not finite.any():
        return np.full(log_w.shape, -np.log(log_w.size))
    log_w = np.where(np.isnan(log_w), -np.inf, log_w)
    return log_w - logsumexp(log_w)


@dataclass(frozen=True, eq=False)
class ParticleBelief:
    """A weighted particle set over source positions.

    Parameters
    ----------
    positions : (N, d) ndarray, metres
    log_weights : (N,) ndarray
        Normalised log-weights (``logsumexp == 0``).
    """

    positions: np.ndarray
    log_weights: np.ndarray

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
        w = self.weights
        dx = self.positions - w @ self.positions
        return (dx * w[:, None]).T @ dx

    @property
    def ess(self) -> float:
        """Effective sample size ``1 / sum w^2``."""
        w = self.weights
        return float(1.0 / np.sum(w * w))

    @property
    def entropy(self) -> float:
        """Shannon entropy of the weights ``-sum w log w`` (nats)."""
        w = self.weights
        nz = w > 0
        return float(-np.sum(w[nz] * np.log(w[nz])))

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording."""
        return {"positions": self.positions.copy(), "weights": self.weights}


@dataclass(frozen=True, eq=False)
class GridBelief:
    """A probability grid over source positions.

    Parameters
    ----------
    prob : (nx, ny[, nz]) ndarray
        Cell probabilities summing to one; index ``[i, j]`` is x then y.
    lower, upper : (d,) tuple
        Extent covered by the grid, metres.
    """

    prob: np.ndarray
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def centers(self) -> np.ndarray:
        """Cell centres, ``(M, d)`` metres, in C order of :attr:`prob`."""
        axes = [
            lo + (np.arange(n) + 0.5) * (hi - lo) / n
            for lo, hi, n in zip(self.lower, self.upper, self.prob.shape, strict=True)
        ]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))

    @property
    def mean(self) -> np.ndarray:
        """Expected source position, ``(d,)`` metres."""
        return self.prob.ravel() @ self.centers()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the position, ``(d, d)`` m^2."""
        c = self.centers()
        p = self.prob.ravel()
        dx = c - p @ c
        return (dx * p[:, None]).T @ dx

    @property
    def entropy(self) -> float:
        """Shannon entropy (nats)."""
        p = self.prob.ravel()
        p = p[p > 0]
        return float(-np.sum(p * np.log(p)))

    @property
    def ess(self) -> float:
        """``1 / sum p^2`` (the effective number of cells)."""
        return float(1.0 / np.sum(self.prob**2))

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording."""
        return {"prob": self.prob.copy(), **{k: v.copy() for k, v in self.extra.items()}}
