"""Compiled kernels of one Col-PF iteration (multi-UAV paper, Algorithm 1) for the 3-D
Vergassola model (numba).

A UAV's Col-PF update weighs ``N`` particles by a few readings (eqs. 10-14) and then moves
``N_s`` of them by Metropolis-Hastings moves judged against the whole measurement history
(eqs. 15-17, :mod:`~odorloc.inference.particles.pugl`). In NumPy each of those steps is a dozen
array calls on small arrays, checked one by one; here each is one compiled pass over raw arrays:

- :func:`readings_log_likelihood`: ``sum_k e_k log Poisson(d_k | R(s_k; x_n) dt_k)`` (eqs. 1, 3,
  11, 13) of readings stored as the history stores them (wind directions not yet made unit, NaN
  rows for the model's own direction, ``log d!`` taken here);
- :func:`kl_divergences`: the divergences of eq. 10 between the UAV's fit and its neighbours'
  (through Cholesky factors);
- :func:`resample_systematic`: low-variance resampling to the count eq. 18 chose, with the
  resampler's Gaussian roughening clipped into the arena;
- :func:`reversible_moves`: PUGL's two reversible moves of the selected particles, env-pu
  (eq. 16, upwind or downwind along the wind axis) then col-pu (eq. 17, an independence
  proposal around ``gbest``), each accepted with the Metropolis-Hastings probability against
  the history, a proposal outside the prior's support rejected unevaluated;
- :func:`weighted_fit`: the Gaussian fit of eqs. 19-20.

An update is these passes in order (:meth:`~odorloc.inference.particles.team_estimators.
ColPFEstimator.update` with a model that has compiled kernels), with Python between them only
to draw the random numbers and to read the messages.

Random numbers are drawn by the caller from the episode's :class:`numpy.random.Generator`
with the same calls, in the same order, as the NumPy path draws them, and passed in: the same
seed gives the same episode on either path (within round-off) and on any number of workers.

The readings are those already checked by
:class:`~odorloc.inference.particles.history.MeasurementHistory` when they were appended; the
kernels do not check them again. Each equals its NumPy reference (the model's
:meth:`~odorloc.models.vergassola.VergassolaModel.weighted_log_likelihood`,
:func:`~odorloc.inference.weights.kl_gaussians`, the low-variance resampler,
:func:`~odorloc.inference.particles.pugl.reversible_env_move` /
:func:`~odorloc.inference.particles.pugl.reversible_col_move` and
:func:`~odorloc.inference.weights.gaussian_fit`) within round-off (1e-9 relative), not to the
bit: the C library's ``exp``, ``log`` and ``lgamma``, sums in reading order, Cholesky factors
instead of LU.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.jit import jit
from odorloc.models.kernels import history_term3, inside_box

__all__ = [
    "kl_divergences",
    "readings_log_likelihood",
    "resample_systematic",
    "reversible_moves",
    "reversible_moves_of_set",
    "unit_rows",
    "weighted_fit",
]


@jit
def unit_rows(raw: np.ndarray, default: np.ndarray) -> np.ndarray:
    """Unit rows of ``raw`` ``(K, 3)``; an all-NaN row takes ``default`` (a unit vector)."""
    k, d = raw.shape
    out = np.empty((k, d))
    for j in range(k):
        if math.isnan(raw[j, 0]):
            for a in range(d):
                out[j, a] = default[a]
            continue
        s = 0.0
        for a in range(d):
            s += raw[j, a] * raw[j, a]
        s = math.sqrt(s)
        for a in range(d):
            out[j, a] = raw[j, a] / s
    return out


@jit
def _log_factorials(counts: np.ndarray) -> np.ndarray:
    out = np.empty(counts.shape[0])
    for j in range(counts.shape[0]):
        out[j] = math.lgamma(counts[j] + 1.0)
    return out


@jit
def readings_log_likelihood(
    x: np.ndarray,
    s: np.ndarray,
    directions: np.ndarray,
    counts: np.ndarray,
    dts: np.ndarray,
    exponents: np.ndarray,
    default: np.ndarray,
    aq: float,
    adv: float,
    inv_lam: float,
    a2: float,
) -> np.ndarray:
    """``sum_k e_k log Poisson(d_k | R(s_k; x_n) dt_k)`` of every hypothesis, ``(N,)``.

    Parameters
    ----------
    x : (N, 3) ndarray, metres
        Source hypotheses.
    s : (K, 3) ndarray, metres
        Where each reading was taken.
    directions : (K, 3) ndarray
        Wind direction of each reading (made unit here; an all-NaN row: ``default``).
    counts, dts, exponents : (K,) ndarray
        Counts, exposures (s) and the exponents ``e_k`` (1 for an own reading, ``beta`` for a
        neighbour's).
    default : (3,) ndarray
        The model's unit wind direction.
    aq, adv, inv_lam, a2 : float
        ``a Q``, ``V / (2 D)`` (1/m), ``1 / lambda`` (1/m) and ``a^2`` (m^2) of eq. 1.
    """
    e = unit_rows(directions, default)
    lf = _log_factorials(counts)
    n = x.shape[0]
    out = np.empty(n)
    dist = np.empty(s.shape[0])
    expo = np.empty(s.shape[0])
    ee = np.empty(s.shape[0])
    for i in range(n):
        out[i] = history_term3(
            x[i, 0],
            x[i, 1],
            x[i, 2],
            s,
            e,
            counts,
            lf,
            dts,
            exponents,
            aq,
            adv,
            inv_lam,
            a2,
            dist,
            expo,
            ee,
        )
    return out


@jit
def reversible_moves(
    xs: np.ndarray,
    ll_in: np.ndarray,
    s: np.ndarray,
    directions: np.ndarray,
    counts: np.ndarray,
    dts: np.ndarray,
    exponents: np.ndarray,
    default: np.ndarray,
    aq: float,
    adv: float,
    inv_lam: float,
    a2: float,
    lo: np.ndarray,
    hi: np.ndarray,
    env: bool,
    upwind: np.ndarray,
    step: float,
    env_draws: np.ndarray,
    col: bool,
    centre: np.ndarray,
    chol: np.ndarray,
    normals: np.ndarray,
    col_uniforms: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """PUGL's reversible moves of the selected particles (eqs. 16-17) against the history.

    Parameters
    ----------
    xs : (S, 3) ndarray, metres
        The selected particles (not modified).
    ll_in : (S,) ndarray
        The history's log-likelihood at ``xs`` (:func:`readings_log_likelihood`, or kept from
        the last iteration plus this iteration's readings).
    s, directions, counts, dts, exponents, default, aq, adv, inv_lam, a2
        The measurement history and the model, as :func:`readings_log_likelihood`.
    lo, hi : (3,) ndarray, metres
        The prior's support: a box (its bounds included).
    env : bool
        Propose env-pu.
    upwind : (3,) ndarray
        Unit horizontal direction against the wind.
    step : float, metres
        Largest env-pu step.
    env_draws : (S, 3) ndarray
        Uniforms: the step fraction, the side (upwind below 0.5), the acceptance.
    col : bool
        Propose col-pu.
    centre : (3,) ndarray, metres
        ``gbest``.
    chol : (3, 3) ndarray
        Lower Cholesky factor of the proposal's covariance.
    normals : (S, 3) ndarray
        Standard normals of the col-pu proposals.
    col_uniforms : (S,) ndarray
        Uniforms of the col-pu acceptance.

    Returns
    -------
    positions : (S, 3) ndarray, metres
    log_likelihood : (S,) ndarray
        The history's log-likelihood at the new positions.
    env_accepted, col_accepted : int
    evaluated : int
        History evaluations of proposals (those in the support).
    """
    m, d = xs.shape
    e = unit_rows(directions, default)
    lf = _log_factorials(counts)
    dist = np.empty(s.shape[0])
    expo = np.empty(s.shape[0])
    ee = np.empty(s.shape[0])
    out = xs.copy()
    ll = ll_in.copy()
    evaluated = 0
    env_acc = 0
    col_acc = 0
    prop = np.empty(d)
    if env:
        for i in range(m):
            side = 1.0 if env_draws[i, 1] < 0.5 else -1.0
            f = side * step * env_draws[i, 0]
            for a in range(d):
                prop[a] = out[i, a] + f * upwind[a]
            if not inside_box(prop, lo, hi):
                continue
            evaluated += 1
            new = history_term3(
                prop[0],
                prop[1],
                prop[2],
                s,
                e,
                counts,
                lf,
                dts,
                exponents,
                aq,
                adv,
                inv_lam,
                a2,
                dist,
                expo,
                ee,
            )
            u = env_draws[i, 2]
            log_u = math.log(u) if u > 0.0 else -math.inf
            if log_u < new - ll[i]:
                for a in range(d):
                    out[i, a] = prop[a]
                ll[i] = new
                env_acc += 1
    if col:
        back = np.empty(d)
        for i in range(m):
            zz = 0.0
            for a in range(d):
                v = centre[a]
                for b in range(a + 1):
                    v += chol[a, b] * normals[i, b]
                prop[a] = v
                zz += normals[i, a] * normals[i, a]
            if not inside_box(prop, lo, hi):
                continue
            # log q(x) - log q(x'): chol^-1 (x - g) by forward substitution
            bb = 0.0
            for a in range(d):
                v = out[i, a] - centre[a]
                for b in range(a):
                    v -= chol[a, b] * back[b]
                back[a] = v / chol[a, a]
                bb += back[a] * back[a]
            evaluated += 1
            new = history_term3(
                prop[0],
                prop[1],
                prop[2],
                s,
                e,
                counts,
                lf,
                dts,
                exponents,
                aq,
                adv,
                inv_lam,
                a2,
                dist,
                expo,
                ee,
            )
            u = col_uniforms[i]
            log_u = math.log(u) if u > 0.0 else -math.inf
            if log_u < new - ll[i] + (-0.5 * bb + 0.5 * zz):
                for a in range(d):
                    out[i, a] = prop[a]
                ll[i] = new
                col_acc += 1
    return out, ll, env_acc, col_acc, evaluated


@jit
def reversible_moves_of_set(
    x: np.ndarray,
    sel: np.ndarray,
    ll_known: np.ndarray,
    known: bool,
    s: np.ndarray,
    directions: np.ndarray,
    counts: np.ndarray,
    dts: np.ndarray,
    exponents: np.ndarray,
    default: np.ndarray,
    aq: float,
    adv: float,
    inv_lam: float,
    a2: float,
    lo: np.ndarray,
    hi: np.ndarray,
    env: bool,
    upwind: np.ndarray,
    step: float,
    env_draws: np.ndarray,
    col: bool,
    centre: np.ndarray,
    chol: np.ndarray,
    normals: np.ndarray,
    col_uniforms: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """:func:`reversible_moves` of the rows ``sel`` of a whole particle set, in one pass.

    Parameters
    ----------
    x : (N, 3) ndarray, metres
        The particles (not modified).
    sel : (S,) int ndarray
        The selected rows (distinct).
    ll_known : (N,) ndarray
        The history's log-likelihood at ``x`` if ``known``; otherwise ignored and computed here
        (:func:`readings_log_likelihood`, every particle's: kept for the next iterations).
    known : bool
    s, directions, counts, dts, exponents, default, aq, adv, inv_lam, a2, lo, hi, env, upwind,
    step, env_draws, col, centre, chol, normals, col_uniforms
        As :func:`reversible_moves`.

    Returns
    -------
    positions : (N, 3) ndarray, metres
        ``x`` with the selected rows moved (a new array).
    log_likelihood : (N,) ndarray
        The history's log-likelihood at ``positions`` (a new array).
    env_accepted, col_accepted, evaluated : int
        As :func:`reversible_moves`.
    """
    if known:
        ll = ll_known.copy()
    else:
        ll = readings_log_likelihood(
            x, s, directions, counts, dts, exponents, default, aq, adv, inv_lam, a2
        )
    m = sel.shape[0]
    d = x.shape[1]
    xs = np.empty((m, d))
    ll_sel = np.empty(m)
    for j in range(m):
        for a in range(d):
            xs[j, a] = x[sel[j], a]
        ll_sel[j] = ll[sel[j]]
    moved, ll_moved, env_acc, col_acc, evaluated = reversible_moves(
        xs,
        ll_sel,
        s,
        directions,
        counts,
        dts,
        exponents,
        default,
        aq,
        adv,
        inv_lam,
        a2,
        lo,
        hi,
        env,
        upwind,
        step,
        env_draws,
        col,
        centre,
        chol,
        normals,
        col_uniforms,
    )
    out = x.copy()
    for j in range(m):
        for a in range(d):
            out[sel[j], a] = moved[j, a]
        ll[sel[j]] = ll_moved[j]
    return out, ll, env_acc, col_acc, evaluated


@jit
def _cholesky(a: np.ndarray, out: np.ndarray) -> bool:
    """Lower Cholesky factor of ``a`` ``(d, d)`` into ``out``; ``False`` if not positive
    definite."""
    d = a.shape[0]
    for i in range(d):
        for j in range(i + 1):
            s = a[i, j]
            for k in range(j):
                s -= out[i, k] * out[j, k]
            if i == j:
                if not s > 0.0:
                    return False
                out[i, i] = math.sqrt(s)
            else:
                out[i, j] = s / out[j, j]
        for j in range(i + 1, d):
            out[i, j] = 0.0
    return True


@jit
def _forward(chol: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``chol^-1 b`` of a vector ``b`` into ``out`` (forward substitution)."""
    d = chol.shape[0]
    for a in range(d):
        v = b[a]
        for c in range(a):
            v -= chol[a, c] * out[c]
        out[a] = v / chol[a, a]


@jit
def kl_divergences(
    mean0: np.ndarray, cov0: np.ndarray, means1: np.ndarray, covs1: np.ndarray, jitter: float
) -> tuple[np.ndarray, bool]:
    """``KL(N0 || N1_h)`` to each of ``H`` Gaussians, nats (eq. 10's divergence), and whether
    every covariance (``jitter`` m^2 added to its diagonal) was positive definite.

    ``0.5 [tr(S1^-1 S0) + dm^T S1^-1 dm - d + ln det S1 - ln det S0]`` through Cholesky
    factors; equal to :func:`~odorloc.inference.weights.kl_gaussians` within round-off.
    """
    d = mean0.shape[0]
    h = means1.shape[0]
    out = np.zeros(h)
    s0 = cov0.copy()
    for a in range(d):
        s0[a, a] += jitter
    l0 = np.empty((d, d))
    if not _cholesky(s0, l0):
        return out, False
    logdet0 = 0.0
    for a in range(d):
        logdet0 += 2.0 * math.log(l0[a, a])
    s1 = np.empty((d, d))
    l1 = np.empty((d, d))
    col = np.empty(d)
    sol = np.empty(d)
    for j in range(h):
        for a in range(d):
            for b in range(d):
                s1[a, b] = covs1[j, a, b]
            s1[a, a] += jitter
        if not _cholesky(s1, l1):
            return out, False
        logdet1 = 0.0
        for a in range(d):
            logdet1 += 2.0 * math.log(l1[a, a])
        # tr(S1^-1 S0) = ||L1^-1 L0||_F^2
        tr = 0.0
        for b in range(d):
            for a in range(d):
                col[a] = l0[a, b]
            _forward(l1, col, sol)
            for a in range(d):
                tr += sol[a] * sol[a]
        for a in range(d):
            col[a] = means1[j, a] - mean0[a]
        _forward(l1, col, sol)
        quad = 0.0
        for a in range(d):
            quad += sol[a] * sol[a]
        out[j] = 0.5 * (tr + quad - d + logdet1 - logdet0)
    return out, True


@jit
def resample_systematic(
    x: np.ndarray,
    w: np.ndarray,
    m: int,
    u0: float,
    noise: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> np.ndarray:
    """Low-variance (systematic) resampling to ``m`` particles with Gaussian roughening, as
    :class:`~odorloc.inference.particles.resampling.SystematicResampler` with the arena's
    box constraint does it: pointers ``(u0 + k) / m`` into the cumulative weights (its last
    entry taken as 1), each copy moved by its row of ``noise`` (``(m, d)`` metres; an empty
    array: exact copies) and clipped into ``[lo, hi]``."""
    n, d = x.shape
    cdf = np.empty(n)
    acc = 0.0
    for i in range(n):
        acc += w[i]
        cdf[i] = acc
    cdf[n - 1] = 1.0
    out = np.empty((m, d))
    rough = noise.shape[0] > 0
    i = 0
    for k in range(m):
        ptr = (u0 + k) / m
        # the first index whose cumulative weight exceeds the pointer (numpy.searchsorted,
        # side "right"); the pointers increase, so the search continues where it stopped
        while i < n - 1 and not cdf[i] > ptr:
            i += 1
        for a in range(d):
            v = x[i, a]
            if rough:
                v += noise[k, a]
                v = min(max(v, lo[a]), hi[a])
            out[k, a] = v
    return out


@jit
def weighted_fit(x: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``(d,)`` and covariance ``(d, d)`` of weighted particles (eqs. 19-20; weights
    summing to one), as :func:`~odorloc.inference.weights.gaussian_fit`."""
    n, d = x.shape
    mean = np.zeros(d)
    for j in range(n):
        for a in range(d):
            mean[a] += w[j] * x[j, a]
    cov = np.zeros((d, d))
    for j in range(n):
        for a in range(d):
            da = w[j] * (x[j, a] - mean[a])
            for b in range(d):
                cov[a, b] += da * (x[j, b] - mean[b])
    return mean, cov
