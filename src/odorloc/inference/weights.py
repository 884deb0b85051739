"""Weights of a belief: log-space normalisation, effective sample size, moments, KL divergence.

Every estimator normalises its log-weights here: subtract the maximum *first*, then the log of the
sum of the shifted weights, so that huge log-likelihoods (``-1e17``) keep full precision.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError

__all__ = [
    "effective_sample_size",
    "gaussian_fit",
    "kl_gaussian",
    "kl_gaussians",
    "normalise_checked_log_weights",
    "normalise_log_weights",
    "weight_entropy",
    "weighted_mean",
]

FloatArray = NDArray[np.float64]


def normalise_log_weights(log_w: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Normalised log-weights and weights of ``(N,)`` log-weights.

    NaN counts as ``-inf``. If every entry is ``-inf`` (all weights underflowed) the weights are
    read as uniform: the data then carried no usable information. A ``+inf`` entry (a hypothesis
    infinitely more likely than all others: a broken likelihood) raises :class:`ConfigError`.

    Returns
    -------
    log_w : (N,) ndarray
        ``logsumexp(log_w) == 0``.
    w : (N,) ndarray
        ``exp(log_w)``, summing to one.
    """
    lw = np.asarray(log_w, float)
    if lw.size == 0:
        raise ConfigError("log_weights", "cannot normalise an empty set")
    m = lw.max()
    if m != m:
        # a NaN (the maximum propagates it; filters call this several times per update, so
        # the replacing pass runs only when needed)
        lw = np.where(np.isnan(lw), -np.inf, lw)
        m = lw.max()
    if m == math.inf:
        raise ConfigError("log_weights", "a log-weight of +inf (a likelihood gave +inf)")
    if not math.isfinite(m):
        lw = np.full(lw.shape, -math.log(lw.size))
        return lw, np.exp(lw)
    return _normalise_from(lw, m)


def normalise_checked_log_weights(log_w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`normalise_log_weights` of log-weights already known to be valid: a float64
    ``(N,)`` array (``N >= 1``) without NaN or ``+inf`` and with a finite maximum (e.g. the
    normalised log-weights a filter holds). The same arithmetic, bit for bit, without the
    checks and conversions (filters renormalise several times per update).
    """
    return _normalise_from(log_w, log_w.max())


def _normalise_from(lw: FloatArray, m: float) -> tuple[FloatArray, FloatArray]:
    """Normalised log-weights and weights of ``lw`` whose (finite) maximum is ``m``."""
    shifted = lw - m
    w = np.exp(shifted)
    total = w.sum()
    return shifted - math.log(total), w / total


def effective_sample_size(log_weights: ArrayLike) -> float:
    """Effective sample size ``1 / sum w^2`` of (possibly unnormalised) log-weights, in [1, N]."""
    _, w = normalise_log_weights(log_weights)
    return float(1.0 / np.dot(w, w))


def weight_entropy(weights: ArrayLike) -> float:
    """Shannon entropy ``-sum w log w`` of normalised weights, nats."""
    w = np.asarray(weights, float)
    nz = w > 0
    return float(-np.sum(w[nz] * np.log(w[nz])))


def weighted_mean(points: ArrayLike, weights: ArrayLike) -> FloatArray:
    """``sum_i w_i x_i`` of ``(N, d)`` points, ``(d,)``."""
    return np.asarray(weights, float) @ np.asarray(points, float)


def gaussian_fit(points: ArrayLike, weights: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Mean ``(d,)`` and covariance ``(d, d)`` of weighted points (weights summing to one)."""
    x = np.asarray(points, float)
    w = np.asarray(weights, float)
    mean = w @ x
    dx = x - mean
    return mean, (dx * w[:, None]).T @ dx


def kl_gaussian(
    mean0: ArrayLike, cov0: ArrayLike, mean1: ArrayLike, cov1: ArrayLike, jitter: float = 1e-9
) -> float:
    """``KL(N0 || N1)`` between two Gaussians, nats (closed form).

    ``0.5 [tr(S1^-1 S0) + (m1 - m0)^T S1^-1 (m1 - m0) - d + ln(det S1 / det S0)]``; ``jitter``
    (m^2) is added to both diagonals so that degenerate fits stay finite.
    """
    m1 = np.asarray(mean1, float)
    return kl_gaussians(mean0, cov0, m1[None, :], np.asarray(cov1, float)[None], jitter)[0]


def kl_gaussians(
    mean0: ArrayLike,
    cov0: ArrayLike,
    means1: ArrayLike,
    covs1: ArrayLike,
    jitter: float = 1e-9,
) -> list[float]:
    """``KL(N0 || N1_h)`` from one Gaussian to each of ``H`` others, nats (closed form).

    Parameters
    ----------
    mean0 : (d,) array_like
    cov0 : (d, d) array_like
    means1 : (H, d) array_like
    covs1 : (H, d, d) array_like
    jitter : float, m^2
        Added to every diagonal (see :func:`kl_gaussian`).

    Returns
    -------
    list of float
        One divergence per ``h``; each equals :func:`kl_gaussian` of the pair to the bit (the
        determinants and solves run per matrix in one batched call).
    """
    m0 = np.asarray(mean0, float)
    m1 = np.asarray(means1, float).reshape(-1, len(m0))
    d, h = len(m0), len(m1)
    covs = np.concatenate(
        [np.asarray(cov0, float)[None], np.asarray(covs1, float).reshape(h, d, d)]
    )
    covs += jitter * _eye(d)
    sign, logdet = np.linalg.slogdet(covs)
    if not (sign > 0).all():
        raise ConfigError("cov", "covariances must be positive definite")
    dm = m1 - m0
    # one solve for S1^-1 S0 and S1^-1 dm together (small matrices: the call dominates)
    rhs = np.concatenate([np.broadcast_to(covs[0], (h, d, d)), dm[:, :, None]], axis=2)
    sol = np.linalg.solve(covs[1:], rhs)
    out = []
    for j in range(h):
        quad = float(dm[j] @ sol[j, :, d])
        tr = np.trace(sol[j, :, :d])
        out.append(float(0.5 * (tr + quad - d + logdet[j + 1] - logdet[0])))
    return out


@lru_cache(maxsize=4)
def _eye(d: int) -> np.ndarray:
    e = np.eye(d)
    e.setflags(write=False)
    return e
