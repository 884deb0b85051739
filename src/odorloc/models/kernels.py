"""Compiled kernels of the 3-D Vergassola rate and its Poisson counts (numba).

The estimators and planners of a UAV team evaluate eq. 1 (rate) and eq. 3 (Poisson counts) of
the multi-UAV paper for every particle at up to 26 points, hundreds of times per episode. In
NumPy that is some thirty array calls per evaluation on arrays of a few thousand numbers, where
the call overhead dominates. These loops do the element-wise work in one pass each, compiled
with numba (:data:`HAVE_NUMBA`).

The kernels behind :meth:`~odorloc.models.vergassola.VergassolaModel.log_likelihood` and
:meth:`~odorloc.models.vergassola.VergassolaModel.outcome_probabilities` reproduce the NumPy code
of :mod:`odorloc.models.vergassola` and :mod:`odorloc.models.poisson` *bit for bit*, so that the
backend does not change a single episode of the models' other users:

- every operation is the same IEEE operation in the same order (sums of squares and of classes
  in index order, as NumPy's reductions over a short or a non-contiguous axis do);
- what NumPy computes with BLAS (the Gram matrix ``x s^T`` and the projections ``x . e``) or
  with its own SIMD functions (``exp``) is left to NumPy: the callers compute those arrays and
  pass them in. A compiled ``exp`` is the C library's, which differs from NumPy's in the last
  bit for a few per cent of arguments;
- logarithms are the C library's on both sides (``scipy.special.xlogy`` calls it).

The kernels of a whole measurement history (:func:`weighted_poisson_log_likelihood`) and of the
expected counts for planning (:func:`rate_means_direct`) compute everything in one pass, with
the C library's ``exp`` and ``log``: they equal their NumPy references within round-off (1e-9
relative), not to the bit.

The NumPy functions remain the reference (and the path without numba); the test suite checks
the equality on random inputs.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import AfterValidator

__all__ = [
    "HAVE_NUMBA",
    "Backend",
    "censored_classes",
    "compiled",
    "history_term",
    "history_term3",
    "history_work",
    "inside_box",
    "jit",
    "poisson_log_rows",
    "rate_exponent_direct",
    "rate_exponent_gram",
    "rate_means",
    "rate_means_direct",
    "weighted_poisson_log_likelihood",
]

from odorloc.core.jit import HAVE_NUMBA
from odorloc.core.jit import jit as _cached_jit


def _available(backend: str) -> str:
    if backend == "numba" and not HAVE_NUMBA:
        raise ValueError("numba cannot be imported (a dependency of odorloc), use auto or numpy")
    return backend


#: A component's choice of kernels: ``numpy`` arrays, compiled ``numba`` loops (refused at load
#: without numba), or ``auto`` (numba when installed).
Backend = Annotated[Literal["auto", "numpy", "numba"], AfterValidator(_available)]


def compiled(backend: str) -> bool:
    """Whether a component with this :data:`Backend` runs the compiled kernels."""
    return backend == "numba" or (backend == "auto" and HAVE_NUMBA)


def jit(fn):  # type: ignore[no-untyped-def]
    """``fn`` compiled with ``numba.njit(cache=True, nogil=True)`` into the shared kernel cache
    (:mod:`odorloc.core.jit`), or ``fn`` without numba."""
    return _cached_jit(fn, nogil=True)


@jit
def _sum_squares_rows(x: np.ndarray) -> np.ndarray:
    """``(x * x).sum(axis=1)`` of a ``(Q, d)`` array, summed in index order from 0."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        acc = 0.0
        for k in range(x.shape[1]):
            acc += x[i, k] * x[i, k]
        out[i] = acc
    return out


@jit
def rate_exponent_gram(
    gram: np.ndarray,
    x: np.ndarray,
    s: np.ndarray,
    xe: np.ndarray,
    se: np.ndarray,
    adv: float,
    inv_lam: float,
    a2: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Exponent and floored distance of the 3-D rate from the Gram matrix, ``(Q, N)`` each.

    Parameters
    ----------
    gram : (Q, N) ndarray
        ``x @ s.T`` (computed by NumPy).
    x, s : (Q, 3), (N, 3) ndarray, metres
        Points and sources.
    xe, se : (Q,), (N,) ndarray, metres
        ``x @ e`` and ``s @ e`` (computed by NumPy).
    adv, inv_lam, a2 : float
        ``V / (2 D)`` (1/m), ``1 / lambda`` (1/m) and the squared sensor radius (m^2).

    Returns
    -------
    expo, r : (Q, N) ndarray
        ``(x.e - s.e) V / (2 D) - r / lambda`` and ``r = max(|x - s|, a)``, as
        :func:`~odorloc.models.vergassola.rate_exponent` computes them on its Gram path.
    """
    q, n = gram.shape
    xx = _sum_squares_rows(x)
    ss = _sum_squares_rows(s)
    expo = np.empty((q, n))
    r = np.empty((q, n))
    for i in range(q):
        for j in range(n):
            v = gram[i, j] * -2.0
            v += xx[i]
            v += ss[j]
            if v < a2:  # numpy.maximum(v, a2), NaN kept
                v = a2
            rr = math.sqrt(v)
            r[i, j] = rr
            ex = (xe[i] - se[j]) * adv
            ex -= rr * inv_lam
            expo[i, j] = ex
    return expo, r


@jit
def rate_exponent_direct(
    x: np.ndarray,
    s: np.ndarray,
    xe: np.ndarray,
    se: np.ndarray,
    adv: float,
    inv_lam: float,
    a2: float,
) -> tuple[np.ndarray, np.ndarray]:
    """As :func:`rate_exponent_gram`, with the distances from the differences (the path of
    :func:`~odorloc.models.vergassola.rate_exponent` for at most 64 pairs)."""
    q = x.shape[0]
    n = s.shape[0]
    d = x.shape[1]
    expo = np.empty((q, n))
    r = np.empty((q, n))
    for i in range(q):
        for j in range(n):
            v = 0.0
            for k in range(d):
                diff = x[i, k] - s[j, k]
                v += diff * diff
            if v < a2:
                v = a2
            rr = math.sqrt(v)
            r[i, j] = rr
            ex = (xe[i] - se[j]) * adv
            ex -= rr * inv_lam
            expo[i, j] = ex
    return expo, r


@jit
def poisson_log_rows(
    e: np.ndarray,
    r: np.ndarray,
    aq: np.ndarray,
    dt: float,
    counts: np.ndarray,
    log_fact: np.ndarray,
) -> tuple[np.ndarray, bool]:
    """``log Poisson(d_q | R dt)`` of each count at its row's point, ``(Q, N)`` (eqs. 1, 3).

    Parameters
    ----------
    e : (Q, N) ndarray
        ``exp`` of the exponent (computed by NumPy).
    r : (Q, N) ndarray, metres
        Floored distances.
    aq : (N,) ndarray
        ``a Q`` of each source hypothesis.
    dt : float, s
        Exposure.
    counts, log_fact : (Q,) ndarray
        The counts ``d_q`` and ``log(d_q!)`` (``scipy.special.gammaln(d_q + 1)``).

    Returns
    -------
    log_p : (Q, N) ndarray
        ``xlogy(d, mu) - mu - log d!`` with ``mu = (a Q e / r) dt``, as
        :func:`~odorloc.models.poisson.poisson_log_pmf` computes it.
    valid : bool
        ``False`` if a mean is negative or not finite (the caller raises).
    """
    q, n = e.shape
    out = np.empty((q, n))
    valid = True
    for i in range(q):
        d = counts[i]
        for j in range(n):
            mu = (aq[j] * e[i, j]) / r[i, j] * dt
            if not (mu >= 0.0 and mu < np.inf):
                valid = False
            # scipy.special.xlogy: 0 for d = 0 (mu not NaN), else d log(mu)
            xl = 0.0 if d == 0.0 and mu == mu else d * math.log(mu)
            out[i, j] = (xl - mu) - log_fact[i]
    return out, valid


@jit
def rate_means(
    e: np.ndarray, r: np.ndarray, aq: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Expected counts ``dt (a Q e / r)`` ``(M, N)``, their negatives and their maximum."""
    m, n = e.shape
    mu = np.empty((m, n))
    neg = np.empty((m, n))
    top = -np.inf
    for i in range(m):
        for j in range(n):
            v = dt * ((aq[j] * e[i, j]) / r[i, j])
            mu[i, j] = v
            neg[i, j] = -v
            if v > top:
                top = v
    return mu, neg, top


@jit
def censored_classes(
    lam: np.ndarray, p0: np.ndarray, n_classes: int
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Poisson count classes ``0 .. Z-2`` and ``>= Z-1`` in the planners' layout ``(M, Z, N)``.

    Parameters
    ----------
    lam : (M, N) ndarray
        Poisson means (at most 600: larger ones take the log-space path of
        :func:`~odorloc.models.poisson.censored_poisson`).
    p0 : (M, N) ndarray
        ``exp(-lam)`` (computed by NumPy).
    n_classes : int
        ``Z >= 2``.

    Returns
    -------
    classes : (M, Z, N) ndarray
        As ``censored_poisson(lam, Z)`` moved to ``(M, Z, N)``, except the tail class of the
        entries flagged in ``rest``.
    rest : (M, N) bool ndarray
        Entries whose tail ``P(d >= Z-1)`` needs the incomplete gamma function (the caller
        fills them in with ``scipy.special.gammainc``).
    any_rest : bool

    Notes
    -----
    :func:`~odorloc.models.poisson.censored_poisson` sums the tail series of every mean below
    ``k / 4`` (``k = Z - 1``) in lockstep and stops all of them at the first fourth term where
    none of them still matters (``term <= 1e-17 * sum``). Here each mean stops at its own
    first such term, before adding it. The result is the same to the bit: the terms only
    shrink, and a term below ``1e-17`` of the sum is below half a unit in the sum's last place,
    so adding it, or any later term, leaves the rounded sum unchanged. (Stopping early also
    spares the subnormal terms of the small means, which cost a hundred cycles each.)
    """
    m, n = lam.shape
    k = n_classes - 1
    out = np.empty((m, n_classes, n))
    rest = np.zeros((m, n), np.bool_)
    any_rest = False
    total = np.empty(n)
    small = np.empty(n, np.bool_)
    acc = np.empty(n)
    quarter = 0.25 * k
    fk = float(k)
    # row by row, each loop over the N means of a row (independent: they vectorise)
    for i in range(m):
        for j in range(n):
            out[i, 0, j] = p0[i, j]
            total[j] = p0[i, j]
        # p(c) = p(c-1) lambda / c, and the head summed class by class
        for c in range(1, k):
            f = 1.0 / c
            for j in range(n):
                v = (out[i, c - 1, j] * lam[i, j]) * f
                out[i, c, j] = v
                total[j] += v
        for j in range(n):
            x = lam[i, j]
            small[j] = x < quarter
            if small[j]:
                # the tail as the series p(k) (1 + lam/(k+1) + lam^2/((k+1)(k+2)) + ...)
                t = (out[i, k - 1, j] * x) / fk
                a = t
                for r in range(1, 26):
                    t *= x / float(k + r)
                    if not t > 1e-17 * a:
                        break
                    a += t
                acc[j] = a
        for j in range(n):
            t = acc[j] if small[j] else 1.0 - total[j]
            if not small[j] and t < 1e-4:
                rest[i, j] = True
                any_rest = True
            out[i, k, j] = 0.0 if t < 0.0 else t  # numpy.maximum(t, 0.0)
    return out, rest, any_rest


@jit
def weighted_poisson_log_likelihood(
    x: np.ndarray,
    s: np.ndarray,
    e: np.ndarray,
    counts: np.ndarray,
    log_fact: np.ndarray,
    scale: np.ndarray,
    exponents: np.ndarray,
    aq: np.ndarray,
    adv: float,
    inv_lam: float,
    a2: float,
) -> np.ndarray:
    """``sum_k e_k log Poisson(d_k | R(s_k; x_n) dt_k)`` for every hypothesis, ``(N,)``
    (eqs. 1, 3 and 11 of the multi-UAV paper: a measurement history, each reading at its own
    sensor position with its own exposure and wind direction).

    Parameters
    ----------
    x : (N, 3) ndarray, metres
        Source hypotheses.
    s : (K, 3) ndarray, metres
        Where each reading was taken.
    e : (K, 3) ndarray
        Unit vector the wind blew towards at each reading.
    counts, log_fact : (K,) ndarray
        The counts ``d_k`` and ``log(d_k!)``.
    scale : (K,) ndarray, seconds
        The exposure ``dt_k`` of each reading.
    exponents : (K,) ndarray
        ``e_k`` (1 for the UAV's own reading, the confidence factor for a neighbour's).
    aq : (N,) ndarray
        ``a Q`` of each hypothesis.
    adv, inv_lam, a2 : float
        ``V / (2 D)`` (1/m), ``1 / lambda`` (1/m) and the squared sensor radius (m^2).

    Notes
    -----
    The same maths as the NumPy evaluation of
    :meth:`~odorloc.models.vergassola.VergassolaModel.weighted_log_likelihood` (its reference),
    equal to it within round-off (1e-9 relative): the C library's ``exp`` and ``log``, sums in
    reading order. ``log mu`` is taken from the exponent directly for a non-zero count, so an
    expected count that underflows never gives ``-inf`` where the rate is merely tiny.
    """
    n = x.shape[0]
    out = np.empty(n)
    work = history_work(s.shape[0])
    if x.shape[1] == 3:
        dist, expo, ee = work[0], work[1], work[2]
        for i in range(n):
            out[i] = history_term3(
                x[i, 0],
                x[i, 1],
                x[i, 2],
                s,
                e,
                counts,
                log_fact,
                scale,
                exponents,
                aq[i],
                adv,
                inv_lam,
                a2,
                dist,
                expo,
                ee,
            )
        return out
    for i in range(n):
        out[i] = history_term(
            x[i], s, e, counts, log_fact, scale, exponents, aq[i], adv, inv_lam, a2, work
        )
    return out


@jit
def history_term(
    p: np.ndarray,
    s: np.ndarray,
    e: np.ndarray,
    counts: np.ndarray,
    log_fact: np.ndarray,
    scale: np.ndarray,
    exponents: np.ndarray,
    aq: float,
    adv: float,
    inv_lam: float,
    a2: float,
    work: np.ndarray,
) -> float:
    """:func:`weighted_poisson_log_likelihood` of one hypothesis ``p`` ``(d,)`` with ``a Q =
    aq``: the weighted log-likelihood of the readings, summed in reading order.

    ``work`` ``(3, K)`` is scratch space (:func:`history_work`): the geometry of every reading
    (floored distance and exponent of eq. 1) is taken first in a loop without branches, which
    the compiler vectorises, then the logarithms in reading order, the same arithmetic as one
    loop (bit for bit). A 3-D hypothesis is :func:`history_term3`'s (which hot loops call
    directly: it takes the point as three numbers and the scratch as three vectors, no array
    views made per call).
    """
    d = p.shape[0]
    k = s.shape[0]
    dist = work[0]
    expo = work[1]
    ee = work[2]
    if d == 3:
        return history_term3(
            p[0],
            p[1],
            p[2],
            s,
            e,
            counts,
            log_fact,
            scale,
            exponents,
            aq,
            adv,
            inv_lam,
            a2,
            dist,
            expo,
            ee,
        )
    for j in range(k):
        r2 = 0.0
        along = 0.0
        for a in range(d):
            diff = s[j, a] - p[a]
            r2 += diff * diff
            along += diff * e[j, a]
        r = math.sqrt(a2 if r2 < a2 else r2)
        dist[j] = r
        expo[j] = along * adv - r * inv_lam
    return _history_sum(counts, log_fact, scale, exponents, aq, dist, expo, ee)


@jit
def history_term3(
    p0: float,
    p1: float,
    p2: float,
    s: np.ndarray,
    e: np.ndarray,
    counts: np.ndarray,
    log_fact: np.ndarray,
    scale: np.ndarray,
    exponents: np.ndarray,
    aq: float,
    adv: float,
    inv_lam: float,
    a2: float,
    dist: np.ndarray,
    expo: np.ndarray,
    ee: np.ndarray,
) -> float:
    """:func:`history_term` of the 3-D hypothesis ``(p0, p1, p2)`` (metres), with the scratch
    vectors ``dist``, ``expo`` and ``ee`` ``(K,)``: the same arithmetic, bit for bit."""
    k = s.shape[0]
    for j in range(k):
        d0 = s[j, 0] - p0
        d1 = s[j, 1] - p1
        d2 = s[j, 2] - p2
        r2 = d0 * d0 + d1 * d1 + d2 * d2
        along = ((0.0 + d0 * e[j, 0]) + d1 * e[j, 1]) + d2 * e[j, 2]
        r = math.sqrt(a2 if r2 < a2 else r2)
        dist[j] = r
        expo[j] = along * adv - r * inv_lam
    return _history_sum(counts, log_fact, scale, exponents, aq, dist, expo, ee)


def _history_sum_py(
    counts: np.ndarray,
    log_fact: np.ndarray,
    scale: np.ndarray,
    exponents: np.ndarray,
    aq: float,
    dist: np.ndarray,
    expo: np.ndarray,
    ee: np.ndarray,
) -> float:
    """``sum_k e_k log Poisson(d_k | mu_k)`` in reading order from each reading's floored
    distance and exponent of eq. 1 (``mu_k = dt_k a Q exp(expo_k) / r_k``); ``ee`` ``(K,)``
    is scratch for the exponentials."""
    k = dist.shape[0]
    # the exponentials first, in a loop of their own without branches: the calls overlap
    # (about twice as fast as inside the branching sum), the same values bit for bit
    for j in range(k):
        ee[j] = math.exp(expo[j])
    acc = 0.0
    for j in range(k):
        if exponents[j] == 0.0:
            continue
        r = dist[j]
        mu = scale[j] * aq * ee[j] / r
        v = -mu - log_fact[j]
        if counts[j] != 0.0:
            v += counts[j] * (math.log(scale[j] * aq) + expo[j] - math.log(r))
        acc += exponents[j] * v
    return acc


#: inlined into its callers (numba's IR inlining): a call per hypothesis would cost more than
#: a short history's arithmetic
_history_sum = _cached_jit(_history_sum_py, nogil=True, inline="always")


@jit
def history_work(k: int) -> np.ndarray:
    """Scratch space of :func:`history_term` for ``k`` readings, ``(3, k)``."""
    return np.empty((3, k))


def _inside_box(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether the point ``p`` lies in the box ``[lo, hi]`` (bounds included)."""
    # a loop, not all() over a generator: numba compiles no generator expressions
    for a in range(p.shape[0]):  # noqa: SIM110
        if not (lo[a] <= p[a] <= hi[a]):
            return False
    return True


#: inlined into its callers (comparisons only): kernels test every proposal and candidate
inside_box = _cached_jit(_inside_box, nogil=True, inline="always")


@jit
def rate_means_direct(
    x: np.ndarray,
    s: np.ndarray,
    e: np.ndarray,
    aq: np.ndarray,
    dt: float,
    adv: float,
    inv_lam: float,
    a2: float,
) -> tuple[np.ndarray, float]:
    """Expected counts ``R(x_m; s_n) dt`` ``(M, N)`` of the 3-D rate (eqs. 1, 3) and their
    maximum, in one pass (the C library's ``exp``; equal to
    :func:`~odorloc.models.vergassola.vergassola_rate` times ``dt`` within round-off).

    Parameters
    ----------
    x : (M, 3) ndarray, metres
        Sensor positions.
    s : (N, 3) ndarray, metres
        Source hypotheses.
    e : (3,) ndarray
        Unit vector the wind blows towards.
    aq : (N,) ndarray
        ``a Q`` of each hypothesis.
    dt : float, seconds
    adv, inv_lam, a2 : float
        ``V / (2 D)``, ``1 / lambda`` and ``a^2``.
    """
    m = x.shape[0]
    n = s.shape[0]
    d = x.shape[1]
    mu = np.empty((m, n))
    expo = np.empty(n)
    top = -np.inf
    for i in range(m):
        # the geometry of every hypothesis first, in a loop without branches (vectorised), then
        # the exponentials in a loop of their own (the calls overlap), then the means: the
        # same arithmetic as one loop, bit for bit
        row = mu[i]
        if d == 3:
            x0 = x[i, 0]
            x1 = x[i, 1]
            x2 = x[i, 2]
            for j in range(n):
                d0 = x0 - s[j, 0]
                d1 = x1 - s[j, 1]
                d2 = x2 - s[j, 2]
                r2 = d0 * d0 + d1 * d1 + d2 * d2
                along = ((0.0 + d0 * e[0]) + d1 * e[1]) + d2 * e[2]
                r = math.sqrt(a2 if r2 < a2 else r2)
                row[j] = r
                expo[j] = along * adv - r * inv_lam
        else:
            for j in range(n):
                r2 = 0.0
                along = 0.0
                for k in range(d):
                    diff = x[i, k] - s[j, k]
                    r2 += diff * diff
                    along += diff * e[k]
                r = math.sqrt(a2 if r2 < a2 else r2)
                row[j] = r
                expo[j] = along * adv - r * inv_lam
        for j in range(n):
            expo[j] = math.exp(expo[j])
        for j in range(n):
            v = dt * (aq[j] * expo[j] / row[j])
            row[j] = v
            if v > top:
                top = v
    return mu, top
