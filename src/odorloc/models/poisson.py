"""Poisson encounter counts: the log-pmf, and censored count classes for planning.

Encounters of odor particles in ``dt`` seconds at a mean rate ``R`` are Poisson with mean
``lambda = R dt`` (Vergassola et al. 2007; eq. 3 of the multi-UAV paper):
``log P(d | lambda) = d log(lambda) - lambda - log(d!)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gammainc, gammaln, xlogy

from odorloc.core.errors import ConfigError

__all__ = ["censored_poisson", "poisson_log_pmf"]


def poisson_log_pmf(counts: ArrayLike, mean: ArrayLike) -> np.ndarray:
    """``log Poisson(counts | mean)``, broadcast over both arguments.

    Parameters
    ----------
    counts : array_like of int >= 0
    mean : array_like of float >= 0
        Expected counts ``lambda``.

    Returns
    -------
    ndarray
        ``0`` for ``d = 0, lambda = 0`` and ``-inf`` for ``d > 0, lambda = 0``.
    """
    d = np.asarray(counts, float)
    lam = np.asarray(mean, float)
    if np.any(d < 0) or np.any(d != np.floor(d)):
        raise ConfigError("counts", "must be non-negative integers")
    if np.any(lam < 0) or not np.all(np.isfinite(lam)):
        raise ConfigError("expected_counts", "must be finite and >= 0")
    return xlogy(d, lam) - lam - gammaln(d + 1.0)


def censored_poisson(mean: ArrayLike, n_classes: int) -> np.ndarray:
    """Probabilities of the count classes ``0, 1, ..., n_classes - 2`` and ``>= n_classes - 1``.

    Parameters
    ----------
    mean : array_like, shape S
        Poisson means ``lambda >= 0``.
    n_classes : int
        Number of classes (>= 2); the last one holds the whole upper tail.

    Returns
    -------
    ndarray, shape S + (n_classes,)
        Rows sum to one.
    """
    if n_classes < 2:
        raise ConfigError("n_classes", "must be >= 2")
    lam = np.asarray(mean, float)[..., None]
    k = np.arange(n_classes - 1, dtype=float)
    head = np.exp(xlogy(k, lam) - lam - gammaln(k + 1.0))
    # P(d >= n - 1) is the regularised lower incomplete gamma P(n - 1, lambda)
    tail = gammainc(n_classes - 1, lam)
    return np.concatenate([head, tail], axis=-1)
