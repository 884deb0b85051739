"""Poisson encounter counts: the log-pmf, and censored count classes for planning.

Encounters of odor particles in ``dt`` seconds at a mean rate ``R`` are Poisson with mean
``lambda = R dt`` (Vergassola et al. 2007; eq. 3 of the multi-UAV paper):
``log P(d | lambda) = d log(lambda) - lambda - log(d!)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gammainc, gammaln, xlogy

from odorloc.core.errors import ConfigError

__all__ = ["MAX_CLASSES", "censored_poisson", "check_counts", "check_n_classes", "poisson_log_pmf"]

MAX_CLASSES = 256
"""Most count classes a model gives (the last holds the tail). Planners hold ``(M, Z, N)``
arrays, and the classes are built one after another: a larger ``Z`` costs memory and time
without a meaningful gain (the models' own ``max_classes`` and ``n_hits`` stop here too)."""


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
    check_counts(d)
    if np.any(lam < 0) or not np.all(np.isfinite(lam)):
        raise ConfigError("expected_counts", "must be finite and >= 0")
    return xlogy(d, lam) - lam - gammaln(d + 1.0)


def check_counts(counts: np.ndarray) -> None:
    """:class:`ConfigError` unless every count is a non-negative integer."""
    if np.any(counts < 0) or np.any(counts != np.floor(counts)):
        raise ConfigError("counts", "must be non-negative integers")


def check_n_classes(n_classes: Any, field: str = "n_classes") -> int:
    """``n_classes`` as an ``int`` in ``[2, MAX_CLASSES]``.

    Raises
    ------
    ConfigError
        Naming ``field`` for anything else: a bool, a fraction (which ``int`` would truncate),
        fewer than two classes or more than :data:`MAX_CLASSES`.
    """
    whole = not isinstance(n_classes, (bool, np.bool_)) and (
        isinstance(n_classes, (int, np.integer))
        or (isinstance(n_classes, (float, np.floating)) and float(n_classes).is_integer())
    )
    z = int(n_classes) if whole else 0
    if not 2 <= z <= MAX_CLASSES:
        raise ConfigError(field, f"must be an integer in [2, {MAX_CLASSES}], got {n_classes!r}")
    return z


def censored_poisson(mean: ArrayLike, n_classes: int) -> np.ndarray:
    """Probabilities of the count classes ``0, 1, ..., n_classes - 2`` and ``>= n_classes - 1``.

    Parameters
    ----------
    mean : array_like, shape S
        Poisson means ``lambda >= 0``.
    n_classes : int
        Number of classes, 2 to :data:`MAX_CLASSES`; the last one holds the whole upper tail.

    Returns
    -------
    ndarray, shape S + (n_classes,)
        Rows sum to one.
    """
    n_classes = check_n_classes(n_classes)
    lam = np.asarray(mean, float)
    if lam.size:
        hi, lo = float(lam.max()), float(lam.min())
        # a negative mean gives "probabilities" outside [0, 1], a NaN one a row of NaN
        if not (math.isfinite(hi) and lo >= 0):
            raise ConfigError("expected_counts", "must be finite and >= 0")
    if lam.size and hi > 600.0:
        # exp(-lambda) would underflow: evaluate every class in log space
        k = np.arange(n_classes - 1, dtype=float)
        ll = lam[..., None]
        head = np.exp(xlogy(k, ll) - ll - gammaln(k + 1.0))
        return np.concatenate([head, gammainc(n_classes - 1, ll)], axis=-1)
    # classes first: every recurrence step then works on contiguous memory
    out = np.empty((n_classes, *lam.shape))
    # p(0) = exp(-lambda), p(k) = p(k-1) lambda / k: one exponential instead of one per class
    np.exp(-lam, out=out[0, ...])
    for k in range(1, n_classes - 1):
        np.multiply(out[k - 1, ...], lam, out=out[k, ...])
        out[k, ...] *= 1.0 / k
    out[-1, ...] = _upper_tail(lam, n_classes - 1, out[:-1])
    return np.moveaxis(out, 0, -1)


def _upper_tail(lam: np.ndarray, k: int, head: np.ndarray) -> np.ndarray:
    """``P(d >= k)`` of Poisson(``lam``) from the head ``p(0..k-1)`` (classes first), ~1e-12 rel.

    Below ``lam = k / 4`` the series ``p(k) (1 + lam/(k+1) + lam^2/((k+1)(k+2)) + ...)``
    gains a factor 4 per term; elsewhere ``1 - sum(head)`` is used where it is at least 1e-4
    (no cancellation), and the incomplete gamma function only for the rest, where it is needed:
    it costs ~50 exponentials.
    """
    tail = np.atleast_1d(1.0 - head.sum(axis=0))
    lam = np.atleast_1d(lam)
    head = head.reshape(head.shape[0], *tail.shape)
    small = lam < 0.25 * k
    if np.any(small):
        x = lam[small]
        term = head[-1][small] * x / k  # p(k)
        total = term.copy()
        for j in range(1, 26):
            term *= x / (k + j)
            total += term
            # the terms fall geometrically: stop once the largest relative term is negligible
            if j % 4 == 0 and not np.any(term > 1e-17 * total):
                break
        tail[small] = total
    rest = ~small & (tail < 1e-4)
    if np.any(rest):
        tail[rest] = gammainc(k, lam[rest])
    return np.maximum(tail, 0.0)
