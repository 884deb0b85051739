"""Compiled loops of the source-term models: a whole history of readings, summed per hypothesis.

A resample-move step weighs every particle by its likelihood over *all* the readings so far
(``T`` readings x ``N`` particles x ``K`` source slots). In NumPy that is a ``(T, N)`` array
per operation, about thirty of them; here one loop per particle keeps its constants (rate, wind,
widths) in registers, skips the readings upwind of every source, and adds the log-probability
of each reading as it goes, so no ``(T, N)`` array is ever made.

The NumPy reference of each loop is the model's ``log_likelihood_reference``
(:mod:`odorloc.models.source_term`); the two agree to rounding (the tests hold them to a
relative 1e-10). numba is a core dependency, so every installation runs the same loops and
an episode does not depend on the machine's packages.

- :func:`gaussian_history`: the Gaussian plume of :mod:`odorloc.models.gaussian` (widths by
  diffusion, power law or Pasquill-Gifford, 3-D ground reflection) and the reading laws of
  :class:`~odorloc.models.source_term.ReadingLaw` (Gaussian, censored, detection);
- :func:`vergassola_history`: 3-D Vergassola rates (eqs. 1-2, muc-osl-multi-uav paper) and
  Poisson counts (eq. 3).
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.jit import HAVE_NUMBA, jit

__all__ = [
    "HAVE_NUMBA",
    "class_probabilities",
    "gaussian_history",
    "log_ndtr",
    "vergassola_history",
]

_SQRT2 = math.sqrt(2.0)
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_TWO_PI = 2.0 * math.pi
_FAR = 40.0
"""Cross-wind exponents beyond this (``exp(-40) = 4e-18`` of the centre-line value) add
nothing a reading can tell apart: the loop skips them (the reference does not; the two agree
to rounding)."""


def log_ndtr(x: float) -> float:
    """``log Phi(x)`` of the standard normal, accurate in both tails."""
    if x > 0.0:
        return math.log1p(-0.5 * math.erfc(x / _SQRT2))
    if x > -30.0:
        return math.log(0.5 * math.erfc(-x / _SQRT2))
    # asymptotic series of Mills' ratio (erfc underflows past x = -37); at x = -30 the first
    # term left out is 1e-14 of the sum
    r = 1.0 / (x * x)
    series = 1.0 + r * (-1.0 + r * (3.0 + r * (-15.0 + r * (105.0 + r * -945.0))))
    return -0.5 * x * x - math.log(-x) - _LOG_SQRT_2PI + math.log(series)


def _law_logp(
    zt: float,
    sig: float,
    bg: float,
    law: int,
    sa: float,
    sr: float,
    thr: float,
    miss: float,
    fa: float,
) -> float:
    """``log p(z | signal)`` of one reading (:class:`~odorloc.models.source_term.ReadingLaw`)."""
    m = bg + sig
    rel = sr * sig
    sd = math.sqrt(sa * sa + rel * rel)
    if law == 2:
        x = (m - thr) / sd
        live = 1.0 - fa - miss
        if zt > 0.5:
            return math.log(fa + live * 0.5 * math.erfc(-x / _SQRT2))
        return math.log(miss + live * 0.5 * math.erfc(x / _SQRT2))
    r = (zt - m) / sd
    dens = -0.5 * r * r - math.log(sd) - _LOG_SQRT_2PI
    if law == 0:
        return dens
    if zt < thr:
        lc = log_ndtr((thr - m) / sd)
        if miss > 0.0:
            a = math.log(miss)
            b = math.log1p(-miss) + lc
            hi = max(a, b)
            return hi + math.log1p(math.exp(min(a, b) - hi))
        return lc
    if miss > 0.0:
        dens += math.log1p(-miss)
    return dens


def _gaussian_history(theta, rates, n_slots, dim, cols, z, pts, speeds, dirs, spread, law, c):  # type: ignore[no-untyped-def]
    n = theta.shape[0]
    n_read = z.shape[0]
    out = np.empty(n)
    act0, cs, cd, cdisp, cbg = cols[0], cols[1], cols[2], cols[3], cols[4]
    block = dim + 1
    s02, kdiff, a_y, b_y, a_z, b_z = c[0], c[1], c[2], c[3], c[4], c[5]
    pay, pby, paz, pbz, ppz = c[6], c[7], c[8], c[9], c[10]
    umin, gain, ground, reflect = c[11], c[12], c[13], c[14] > 0.5
    sa, sr, thr, bg0, miss, fa = c[15], c[16], c[17], c[18], c[19], c[20]
    # log-probability of each reading without any signal (most readings of most hypotheses)
    zero = np.empty(n_read)
    for t in range(n_read):
        zero[t] = _law_logp(z[t], 0.0, bg0, law, sa, sr, thr, miss, fa)
    for i in range(n):
        u_i = max(theta[i, cs], umin) if cs >= 0 else 0.0
        e0 = math.cos(theta[i, cd]) if cd >= 0 else 0.0
        e1 = math.sin(theta[i, cd]) if cd >= 0 else 0.0
        scale2 = math.exp(2.0 * theta[i, cdisp]) if cdisp >= 0 else 1.0
        bg = theta[i, cbg] if cbg >= 0 else bg0
        acc = 0.0
        for t in range(n_read):
            u = u_i if cs >= 0 else max(speeds[t], umin)
            ex = e0 if cd >= 0 else dirs[t, 0]
            ey = e1 if cd >= 0 else dirs[t, 1]
            sig = 0.0
            for k in range(n_slots):
                if act0 >= 0 and theta[i, act0 + k] <= 0.5:
                    continue
                base = k * block
                dx = pts[t, 0] - theta[i, base]
                dy = pts[t, 1] - theta[i, base + 1]
                x = dx * ex + dy * ey
                if x <= 0.0:
                    continue
                y = -dx * ey + dy * ex
                if spread == 0:
                    sy2 = s02 + 2.0 * kdiff * x / u * scale2
                    sz2 = sy2
                elif spread == 1:
                    gy = a_y * x**b_y
                    gz = a_z * x**b_z
                    sy2 = s02 + gy * gy * scale2
                    sz2 = s02 + gz * gz * scale2
                else:
                    gy = pay * x
                    gz = paz * x
                    sy2 = s02 + gy * gy / (1.0 + pby * x) * scale2
                    # Briggs' vertical exponents are 0, +-1/2 or -1: no general power needed
                    f = 1.0 + pbz * x
                    if ppz == 0.0:
                        fz = 1.0
                    elif ppz == -0.5:
                        fz = 1.0 / f
                    elif ppz == -1.0:
                        fz = 1.0 / (f * f)
                    elif ppz == 0.5:
                        fz = f
                    else:
                        fz = f ** (2.0 * ppz)
                    sz2 = s02 + gz * gz * fz * scale2
                arg = 0.5 * y * y / sy2
                if arg > _FAR:
                    continue
                cval = rates[i, k] / (_TWO_PI * math.sqrt(sy2 * sz2) * u) * math.exp(-arg)
                if dim == 3:
                    zr = pts[t, 2]
                    zs = theta[i, base + 2]
                    zt = math.exp(-0.5 * (zr - zs) ** 2 / sz2)
                    if reflect:
                        zt += math.exp(-0.5 * (zr + zs - 2.0 * ground) ** 2 / sz2)
                    cval *= zt
                sig += cval
            if sig == 0.0 and cbg < 0:
                acc += zero[t]
            else:
                acc += _law_logp(z[t], gain * sig, bg, law, sa, sr, thr, miss, fa)
        out[i] = acc
    return out


def _vergassola_history(theta, n_slots, cols, k, lgk, pts, dirs, dts, c):  # type: ignore[no-untyped-def]
    n = theta.shape[0]
    n_read = k.shape[0]
    out = np.empty(n)
    act0, cs, cd, cdisp, cbg = cols[0], cols[1], cols[2], cols[3], cols[4]
    v0, d0, tau, a, bg0 = c[0], c[1], c[2], c[3], c[4]
    for i in range(n):
        v = theta[i, cs] if cs >= 0 else v0
        dd = d0 * math.exp(theta[i, cdisp]) if cdisp >= 0 else d0
        lam = math.sqrt(dd * tau / (1.0 + v * v * tau / (4.0 * dd)))
        adv = v / (2.0 * dd)
        e0 = math.cos(theta[i, cd]) if cd >= 0 else 0.0
        e1 = math.sin(theta[i, cd]) if cd >= 0 else 0.0
        bg = theta[i, cbg] if cbg >= 0 else bg0
        acc = 0.0
        for t in range(n_read):
            ex = e0 if cd >= 0 else dirs[t, 0]
            ey = e1 if cd >= 0 else dirs[t, 1]
            rate = bg
            for s in range(n_slots):
                if act0 >= 0 and theta[i, act0 + s] <= 0.5:
                    continue
                base = s * 4
                dx = pts[t, 0] - theta[i, base]
                dy = pts[t, 1] - theta[i, base + 1]
                dz = pts[t, 2] - theta[i, base + 2]
                r = max(math.sqrt(dx * dx + dy * dy + dz * dz), a)
                q = math.exp(theta[i, base + 3])
                rate += a * q * math.exp((dx * ex + dy * ey) * adv - r / lam) / r
            mu = rate * dts[t]
            if k[t] > 0.0:
                acc += (k[t] * math.log(mu) if mu > 0.0 else -math.inf) - mu - lgk[t]
            else:
                acc -= mu
        out[i] = acc
    return out


def _class_probabilities(m, sd, quiet, quiet_row, edges, miss, censored):  # type: ignore[no-untyped-def]
    """Reading classes ``(M, B + 1, N)`` of readings of means ``m`` and deviations ``sd``
    (``(M, N)``): below ``edges[0]``, then between edges, the last bin open above; a censored
    law adds the chance ``miss`` of reading nothing to the first class. Entries marked
    ``quiet`` take ``quiet_row`` (the law without signal). Edges more than 9 deviations from a
    mean are 0 or 1 of the normal CDF to double precision and are not evaluated. The NumPy
    reference is :meth:`~odorloc.models.source_term.ReadingLaw.class_row_reference`."""
    n_m, n_n = m.shape
    nb = edges.shape[0] - 1
    out = np.empty((n_m, nb + 1, n_n))
    keep = 1.0 - miss if censored else 1.0
    first = miss if censored else 0.0
    for a in range(n_m):
        for k in range(n_n):
            if quiet[a, k]:
                for j in range(nb + 1):
                    out[a, j, k] = quiet_row[j]
                continue
            mk, sk = m[a, k], sd[a, k]
            prev = 0.0
            for j in range(nb + 1):
                z = (edges[j] - mk) / sk
                if z < -9.0:
                    cdf = 0.0
                elif z > 9.0:
                    cdf = 1.0
                else:
                    cdf = 0.5 * math.erfc(-z / _SQRT2)
                if j == 0:
                    out[a, 0, k] = first + keep * cdf
                else:
                    out[a, j, k] = keep * max(cdf - prev, 0.0)
                prev = cdf
            out[a, nb, k] += keep * (1.0 - prev)
    return out


def _warm_classes(kernel):  # type: ignore[no-untyped-def]
    kernel(
        np.zeros((1, 1)),
        np.ones((1, 1)),
        np.zeros((1, 1), np.bool_),
        np.ones(3),
        np.zeros(3),
        0.0,
        True,
    )


def _warm_gaussian(kernel):  # type: ignore[no-untyped-def]
    for dim in (2, 3):
        kernel(
            np.zeros((1, dim + 1)),
            np.ones((1, 1)),
            1,
            dim,
            np.full(5, -1, np.int64),
            np.zeros(1),
            np.ones((1, dim)),
            np.ones(1),
            np.ones((1, 2)),
            0,
            1,
            np.ones(21),
        )


def _warm_vergassola(kernel):  # type: ignore[no-untyped-def]
    kernel(
        np.zeros((1, 4)),
        1,
        np.full(5, -1, np.int64),
        np.zeros(1),
        np.zeros(1),
        np.ones((1, 3)),
        np.ones((1, 2)),
        np.ones(1),
        np.ones(5),
    )


if HAVE_NUMBA:
    # module-level kernels referenced as globals, so that numba's cache hits in every process
    # (see odorloc.core.jit)
    log_ndtr = jit(log_ndtr)
    _law_logp = jit(_law_logp)
    gaussian_history = jit(_gaussian_history, warmup=_warm_gaussian)
    vergassola_history = jit(_vergassola_history, warmup=_warm_vergassola)
    class_probabilities = jit(_class_probabilities, warmup=_warm_classes)
else:  # pragma: no cover - numba is a core dependency
    gaussian_history = _gaussian_history
    vergassola_history = _vergassola_history
    class_probabilities = _class_probabilities
