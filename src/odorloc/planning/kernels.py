"""Compiled kernels of the lattice step planners (numba).

Each decision of a UAV's planner scores 26 directions against every particle and every count
class: the expected value ``E[W']`` of Adap-PP (eqs. 21-25 of the multi-UAV paper) or the
expected posterior entropy of fixed-step infotaxis, both after cutting the classes where the
predicted count has ended (``d_max``, eq. 24). These loops run that in one pass over the
``(M, Z, N)`` outcome array, compiled with numba (:data:`~odorloc.models.kernels.HAVE_NUMBA`).

:func:`poisson_direction_rewards` is Adap-PP's whole decision for Poisson count outcomes: from
the ``(M, N)`` means, in two passes, with the entropy terms taken from the classes'
log-probabilities (one logarithm per candidate and particle, not per class); it equals the
NumPy planner within round-off (1e-9 relative). The others reproduce the NumPy functions they
replace
(:func:`~odorloc.planning.adaptive.merge_tail_classes`,
:func:`~odorloc.planning.adaptive.direction_rewards`,
:func:`~odorloc.planning.fixed_step.with_found_outcome` with
:func:`~odorloc.planning.rewards.expected_entropy`, and
:func:`~odorloc.planning.adaptive.step_rewards`) bit for bit: sums over a contiguous axis use
NumPy's pairwise summation (:func:`pairwise_sum`), other sums run in index order, and the
matrix products (BLAS) and NumPy's own ``log`` are left to NumPy between two kernels.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.jit import jit as _cached_jit
from odorloc.models.kernels import inside_box, jit, rate_means_direct

__all__ = [
    "adap_pp_choose",
    "adap_pp_means",
    "direction_finish",
    "direction_terms",
    "found_entropy",
    "pairwise_sum",
    "poisson_direction_rewards",
    "step_rewards",
    "tail_cut",
]


@jit
def _block_sum(a: np.ndarray, lo: int, n: int) -> float:
    """NumPy's pairwise sum of ``a[lo:lo + n]`` for ``n <= 128``."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0 = a[lo]
    r1 = a[lo + 1]
    r2 = a[lo + 2]
    r3 = a[lo + 3]
    r4 = a[lo + 4]
    r5 = a[lo + 5]
    r6 = a[lo + 6]
    r7 = a[lo + 7]
    i = 8
    end = n - n % 8
    while i < end:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@jit
def _half(n: int) -> int:
    h = n // 2
    return h - h % 8


@jit
def _stack() -> tuple[np.ndarray, np.ndarray]:
    """Workspace of :func:`_pairwise`: segment bounds and states, and left-half sums."""
    return np.zeros((64, 3), np.int64), np.empty(64)


@jit
def _pairwise(a: np.ndarray, lo: int, n: int, seg: np.ndarray, left: np.ndarray) -> float:
    """:func:`pairwise_sum` with a workspace from :func:`_stack` (allocated once per kernel)."""
    if n <= 128:
        return _block_sum(a, lo, n)
    # seg[depth] = (start, length, stage); stage 1: left half running, 2: right half running
    depth = 0
    seg[0, 0] = lo
    seg[0, 1] = n
    while True:
        m = seg[depth, 1]
        if m > 128:
            seg[depth, 2] = 1
            depth += 1
            seg[depth, 0] = seg[depth - 1, 0]
            seg[depth, 1] = _half(m)
            continue
        val = _block_sum(a, seg[depth, 0], m)
        depth -= 1
        while depth >= 0 and seg[depth, 2] == 2:
            val = left[depth] + val
            depth -= 1
        if depth < 0:
            return val
        # the left half of segment `depth` is done: run its right half
        left[depth] = val
        seg[depth, 2] = 2
        h = _half(seg[depth, 1])
        depth += 1
        seg[depth, 0] = seg[depth - 1, 0] + h
        seg[depth, 1] = seg[depth - 1, 1] - h


@jit
def pairwise_sum(a: np.ndarray, lo: int, n: int) -> float:
    """``a[lo:lo + n].sum()`` as NumPy sums a contiguous float64 array.

    NumPy's pairwise summation: below 8 numbers in order, up to 128 in eight interleaved
    partial sums, beyond that the two halves (split at a multiple of 8) summed apart and then
    added. The recursion runs on a small explicit stack (cached numba code must not recurse).
    """
    seg, left = _stack()
    return _pairwise(a, lo, n, seg, left)


@jit
def _xlogx(v: float) -> float:
    """``scipy.special.xlogy(v, v)``: 0 at 0, else ``v log v`` (the C library's ``log``)."""
    if v == 0.0:
        return 0.0
    return v * math.log(v)


@jit
def tail_cut(pz: np.ndarray, tail_mass: float) -> int:
    """Where :func:`~odorloc.planning.adaptive.merge_tail_classes` cuts the classes.

    Parameters
    ----------
    pz : (M, Z) ndarray
        Predicted count distribution at each candidate (``q @ w``, computed by NumPy).
    tail_mass : float

    Returns
    -------
    int
        ``keep``: classes ``0 .. keep-1`` stay, ``keep .. Z-1`` are merged into one; ``Z`` when
        nothing is merged.
    """
    m, z = pz.shape
    if z <= 2:
        return z
    worst = np.full(z, -np.inf)
    for i in range(m):
        acc = 0.0
        # P(d >= c) summed from the last class down, as numpy.cumsum of the reversed row
        for c in range(z - 1, 0, -1):
            acc = pz[i, c] if c == z - 1 else acc + pz[i, c]
            if acc > worst[c]:
                worst[c] = acc
    for c in range(1, z):
        if worst[c] < tail_mass:
            keep = c
            if keep + 1 >= z:
                return z
            return keep
    return z


@jit
def _merged_row(q: np.ndarray, i: int, c: int, keep: int, out: np.ndarray) -> None:
    """Row ``(i, c)`` of the merged outcome array into ``out`` ``(N,)``: class ``c``, or from
    ``c = keep`` on the classes summed in order (``q[:, keep:].sum(axis=1)``)."""
    n = q.shape[2]
    if c < keep:
        for j in range(n):
            out[j] = q[i, c, j]
        return
    for j in range(n):
        out[j] = q[i, keep, j]
    for cc in range(keep + 1, q.shape[1]):
        for j in range(n):
            out[j] += q[i, cc, j]


@jit
def direction_terms(
    q: np.ndarray, w: np.ndarray, keep: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The joint ``p(d, o_n)`` and its sums per class (eq. 24), classes merged at ``keep``.

    Parameters
    ----------
    q : (M, Z, N) ndarray
        ``p(d | o_n)`` at each candidate.
    w : (N,) ndarray
        Particle weights.
    keep : int
        From :func:`tail_cut`.

    Returns
    -------
    joint : (M, Z', N) ndarray
        ``w_n p(d | o_n)``, ``Z' = min(keep + 1, Z)``.
    pz : (M, Z') ndarray
        ``p(d) = sum_n w_n p(d | o_n)``.
    xl : (M, Z') ndarray
        ``sum_n joint log joint``.
    safe : (M, Z') ndarray
        ``p(d)`` where above ``1e-300``, else 1.
    """
    m, z, n = q.shape
    zz = keep + 1 if keep < z else z
    joint = np.empty((m, zz, n))
    pz = np.empty((m, zz))
    xl = np.empty((m, zz))
    safe = np.empty((m, zz))
    buf = np.empty(n)
    seg, left = _stack()
    for i in range(m):
        for c in range(zz):
            row = joint[i, c]
            _merged_row(q, i, c, keep, row)
            for j in range(n):
                row[j] *= w[j]
            s = _pairwise(row, 0, n, seg, left)
            for j in range(n):
                buf[j] = _xlogx(row[j])
            pz[i, c] = s
            xl[i, c] = _pairwise(buf, 0, n, seg, left)
            safe[i, c] = s if s > 1e-300 else 1.0
    return joint, pz, xl, safe


@jit
def direction_finish(
    mean_sum: np.ndarray,
    pz: np.ndarray,
    xl: np.ndarray,
    safe: np.ndarray,
    log_safe: np.ndarray,
    targets: np.ndarray,
    h1: float,
    w_now: float,
) -> np.ndarray:
    """``W_k - E[W_{k+1}]`` of each candidate (eqs. 21-25), ``(M,)`` metres.

    Parameters
    ----------
    mean_sum : (M * Z', d) ndarray
        ``joint @ x`` (computed by NumPy): the posterior means times ``p(d)``.
    pz, xl, safe : (M, Z') ndarray
        From :func:`direction_terms`.
    log_safe : (M, Z') ndarray
        ``log(safe)`` (computed by NumPy).
    targets : (M, d) ndarray, metres
    h1 : float
    w_now : float
        ``W_k`` at the UAV's position.
    """
    m, zz = pz.shape
    d = targets.shape[1]
    out = np.empty(m)
    vals = np.empty(zz)
    seg, left = _stack()
    for i in range(m):
        for c in range(zz):
            s = safe[i, c]
            acc = 0.0
            for k in range(d):
                diff = targets[i, k] - mean_sum[i * zz + c, k] / s
                acc += diff * diff
            dist = math.sqrt(acc)
            ent = log_safe[i, c] - xl[i, c] / s
            p = pz[i, c]
            vals[c] = p * (dist + h1 * ent) if p > 1e-300 else 0.0
        out[i] = w_now - _pairwise(vals, 0, zz, seg, left)
    return out


@jit
def found_entropy(
    q: np.ndarray,
    w: np.ndarray,
    keep: int,
    targets: np.ndarray,
    x: np.ndarray,
    radius2: float,
) -> tuple[np.ndarray, int]:
    """Expected posterior entropy with a *found* outcome at each candidate, ``(M,)`` nats.

    The classes merged at ``keep`` (:func:`tail_cut`), then a last class *found* for the
    particles within ``sqrt(radius2)`` of the target (the count classes conditioned on *not
    found*), then ``sum_z P(z) log P(z) - sum_{z,n} p(z, o_n) log p(z, o_n)``; also returns the
    number of classes ``Z' + 1``.
    """
    m, z, n = q.shape
    d = x.shape[1]
    zz = keep + 1 if keep < z else z
    buf = np.empty((zz + 1) * n)
    row = np.empty(n)
    found = np.empty(n)
    pl = np.empty(zz + 1)
    out = np.empty(m)
    seg, left = _stack()
    for i in range(m):
        for j in range(n):
            acc = 0.0
            for k in range(d):
                diff = targets[i, k] - x[j, k]
                acc += diff * diff
            found[j] = 1.0 if acc <= radius2 else 0.0
        for c in range(zz):
            _merged_row(q, i, c, keep, row)
            for j in range(n):
                v = (row[j] * (1.0 - found[j])) * w[j]
                buf[c * n + j] = v
                row[j] = v
            pl[c] = _xlogx(_pairwise(row, 0, n, seg, left))
        for j in range(n):
            v = found[j] * w[j]
            buf[zz * n + j] = v
            row[j] = v
        pl[zz] = _xlogx(_pairwise(row, 0, n, seg, left))
        for t in range(buf.size):
            buf[t] = _xlogx(buf[t])
        out[i] = _pairwise(pl, 0, zz + 1, seg, left) - _pairwise(buf, 0, buf.size, seg, left)
    return out, zz + 1


@jit
def step_rewards(
    position: np.ndarray,
    step: np.ndarray,
    step_norm: float,
    l_max: int,
    estimate: np.ndarray,
    history: np.ndarray,
    h2: float,
) -> np.ndarray:
    """``R(l) = D(l) + h2 Z(l)`` for ``l = 1..l_max`` (eq. 27), ``(l_max,)``; as
    :func:`~odorloc.planning.adaptive.step_rewards` with ``step_norm = |step|`` (NumPy)."""
    d = position.shape[0]
    k = history.shape[0]
    out = np.empty(l_max)
    keep = np.empty(k, np.bool_)
    for p in range(k):
        acc = 0.0
        for a in range(d):
            diff = history[p, a] - position[a]
            acc += diff * diff
        keep[p] = math.sqrt(acc) > 1e-9
    prev = 0
    for li in range(l_max):
        ell = float(li + 1)
        acc = 0.0
        for a in range(d):
            diff = (position[a] + ell * step[a]) - estimate[a]
            acc += diff * diff
        dist = math.sqrt(acc)
        half = 0.5 * ell
        radius = half * step_norm + 1e-9
        inside = 0
        for p in range(k):
            if keep[p]:
                acc = 0.0
                for a in range(d):
                    diff = history[p, a] - (position[a] + half * step[a])
                    acc += diff * diff
                if math.sqrt(acc) <= radius:
                    inside += 1
        out[li] = dist + h2 * (inside - prev)
        prev = inside
    return out


@jit
def _poisson_tail(lam: float, k: int, pk_1: float, head_sum: float, recip: np.ndarray) -> float:
    """``P(d >= k)`` of Poisson(``lam``) from ``p(k-1)`` and the head sum ``p(0) + .. + p(k-1)``.

    The series ``p(k) (1 + lam/(k+1) + lam^2/((k+1)(k+2)) + ...)`` where it converges fast
    (``lam < k / 4``) or where ``1 - head`` would lose digits (below 1e-4); ``1 - head``
    elsewhere. Relative error about 1e-15 (the NumPy classes use the incomplete gamma function
    in the second case; the two agree within round-off). ``recip[c] = 1 / c`` (``recip[0]``
    unused): the series' ratios as products, not divisions, as far as the table goes.
    """
    if k == 0:
        return 1.0
    rest = 1.0 - head_sum
    if lam >= 0.25 * k and rest >= 1e-4:
        return rest
    size = recip.shape[0]
    t = pk_1 * lam * recip[k] if k < size else pk_1 * lam / k
    total = t
    j = 1
    while j < 2000:
        c = k + j
        t *= lam * recip[c] if c < size else lam / c
        if not t > 1e-17 * total:
            break
        total += t
        j += 1
    return total


#: Terms of the tail series :func:`_poisson_direction_rewards` sums for a small mean
_TAIL_TERMS = 6

#: numba's fast-math flags of the kernels whose sums may be reassociated (vectorised)
_REASSOC = {"reassoc", "contract", "nsz"}


def _class_sums(
    p: np.ndarray, w: np.ndarray, u: np.ndarray, v: np.ndarray, wx: np.ndarray, ma: np.ndarray
) -> tuple[float, float, float]:
    """One class's sums over the particles in one pass: ``p(d) = sum_n w_n p_n``,
    ``sum_n p_n u_n``, ``sum_n p_n v_n`` and, into ``ma`` ``(d,)``, ``sum_n p_n wx[:, n]`` (the
    posterior mean times ``p(d)``)."""
    n = p.shape[0]
    pc = 0.0
    su = 0.0
    sv = 0.0
    if wx.shape[0] == 3:
        # the 3-D case in one loop (a loop over the axes would re-read ``p`` for each)
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        for j in range(n):
            pj = p[j]
            pc += w[j] * pj
            su += u[j] * pj
            sv += v[j] * pj
            m0 += wx[0, j] * pj
            m1 += wx[1, j] * pj
            m2 += wx[2, j] * pj
        ma[0] = m0
        ma[1] = m1
        ma[2] = m2
        return pc, su, sv
    for j in range(n):
        pj = p[j]
        pc += w[j] * pj
        su += u[j] * pj
        sv += v[j] * pj
    for a in range(wx.shape[0]):
        acc = 0.0
        for j in range(n):
            acc += wx[a, j] * p[j]
        ma[a] = acc
    return pc, su, sv


#: inlined into the rewards (numba's IR inlining, under the same flags): a call per candidate
#: and class, with a view of its row, would cost more than a short row's sums
_class_sums = _cached_jit(_class_sums, nogil=True, fastmath=_REASSOC, inline="always")


def _poisson_direction_rewards(
    mu: np.ndarray,
    w: np.ndarray,
    log_w: np.ndarray,
    x: np.ndarray,
    targets: np.ndarray,
    n_classes: int,
    tail_mass: float,
    h1: float,
    w_now: float,
) -> tuple[np.ndarray, int]:
    """Adap-PP's direction rewards ``W_k - E[W_{k+1}]`` (eqs. 21-25) for Poisson count
    outcomes, in two passes over the ``(M, N)`` means: the whole of
    :func:`~odorloc.planning.adaptive.merge_tail_classes` and
    :func:`~odorloc.planning.adaptive.direction_rewards` on the classes of
    :func:`~odorloc.models.poisson.censored_poisson`, with the entropy terms taken from the
    classes' log-probabilities ``c log mu - mu - log c!`` (one logarithm per candidate and
    particle instead of one per class).

    Parameters
    ----------
    mu : (M, N) ndarray
        Poisson means of the next measurement at each candidate under each hypothesis.
    w, log_w : (N,) ndarray
        Normalised weights and their logarithms.
    x : (N, d) ndarray, metres
        Particle positions.
    targets : (M, d) ndarray, metres
    n_classes : int
        ``Z``: classes ``0 .. Z-2`` and ``>= Z-1`` (the model's).
    tail_mass : float
        ``d_max`` of eq. 24 (see :func:`~odorloc.planning.adaptive.merge_tail_classes`).
    h1 : float, metres per nat
    w_now : float
        ``W_k`` at the UAV's position.

    Returns
    -------
    rewards : (M,) ndarray, metres
    kept : int
        Classes after the tail cut.

    Notes
    -----
    Equal to the NumPy planner within round-off (1e-9 relative), not to the bit.
    """
    m, n = mu.shape
    d = x.shape[1]
    z = n_classes
    k = z - 1
    lf = np.empty(z)
    for c in range(z):
        lf[c] = math.lgamma(c + 1.0)
    # 1 / c for the tail series: its terms fall by lam / c < 1/4, 64 of them reach 1e-17
    recip = np.empty(z + 64)
    recip[0] = 0.0
    for c in range(1, recip.shape[0]):
        recip[c] = 1.0 / c
    # means this small take the tail's short series (see pass 1)
    small = 1e-3 * (k + 1)
    # the weighted positions, transposed: the mean sums of pass 2 run on contiguous rows
    wx = np.empty((d, n))
    for a in range(d):
        for j in range(n):
            wx[a, j] = w[j] * x[j, a]
    probs = np.empty((m, z, n))
    pz = np.empty((m, z))
    head = np.empty(n)
    # pass 1: the classes of every (candidate, particle) and the predicted distribution, each
    # class's row summed as it is written
    for i in range(m):
        lam = mu[i]
        row = probs[i, 0]
        acc = 0.0
        for j in range(n):
            v = math.exp(-lam[j])
            row[j] = v
            head[j] = v
            acc += w[j] * v
        pz[i, 0] = acc
        for c in range(1, k):
            f = 1.0 / c
            row, prev = probs[i, c], probs[i, c - 1]
            acc = 0.0
            for j in range(n):
                v = prev[j] * lam[j] * f
                row[j] = v
                head[j] += v
                acc += w[j] * v
            pz[i, c] = acc
        big = False
        for j in range(n):
            if lam[j] > 600.0:
                # exp(-lam) underflows: the head in log space, the tail the rest
                big = True
                ll = math.log(lam[j])
                acc = 0.0
                for c in range(k):
                    v = math.exp(c * ll - lam[j] - lf[c])
                    probs[i, c, j] = v
                    acc += v
                tail = 1.0 - acc
                probs[i, k, j] = tail if tail > 0.0 else 0.0
            elif k > 0 and lam[j] <= small:
                # the series of _poisson_tail with its ratios lam / (k + t) <= 1e-3: its first
                # _TAIL_TERMS terms in Horner form (the rest below 1e-20 relative), no branches
                lj = lam[j]
                acc = 1.0
                for t in range(_TAIL_TERMS, 0, -1):
                    acc = 1.0 + lj * recip[k + t] * acc
                probs[i, k, j] = probs[i, k - 1, j] * lj * recip[k] * acc
            else:
                pk_1 = probs[i, k - 1, j] if k > 0 else 1.0
                probs[i, k, j] = _poisson_tail(lam[j], k, pk_1, head[j], recip)
        if big:
            # rare: head classes rewritten above, their sums too
            for c in range(k):
                row = probs[i, c]
                acc = 0.0
                for j in range(n):
                    acc += w[j] * row[j]
                pz[i, c] = acc
        row = probs[i, k]
        acc = 0.0
        for j in range(n):
            acc += w[j] * row[j]
        pz[i, k] = acc
    # d_max: the first class from which the predicted tail is below tail_mass at every candidate
    keep = z
    if z > 2:
        worst = np.full(z, -np.inf)
        for i in range(m):
            acc = 0.0
            for c in range(z - 1, 0, -1):
                acc += pz[i, c]
                if acc > worst[c]:
                    worst[c] = acc
        for c in range(1, z):
            if worst[c] < tail_mass:
                keep = c if c + 1 < z else z
                break
    zz = keep + 1 if keep < z else z
    out = np.empty(m)
    # per candidate: w (log w - mu) and w log mu, so that a count class's entropy sum
    # sum_n w_n p_n (log w_n + c log mu_n - mu_n - log c!) needs no array of its own
    wb = np.empty(n)
    wl = np.empty(n)
    lnl = np.empty(n)
    p = np.empty(n)
    wq = np.empty(n)
    ma = np.empty(d)
    for i in range(m):
        lam = mu[i]
        for j in range(n):
            # a zero mean gives classes c > 0 probability 0: any finite log does for them
            ll = math.log(lam[j]) if lam[j] > 0.0 else -1e300
            lnl[j] = ll
            wb[j] = w[j] * (log_w[j] - lam[j])
            wl[j] = w[j] * ll
        expected = 0.0
        for c in range(zz):
            if (c == keep and keep < z) or c == k:
                # the merged tail (or the last class): its probability, and w times log (w p)
                # where p is not 0
                head = probs[i, c]
                for j in range(n):
                    p[j] = head[j]
                for cc in range(c + 1, z):
                    row = probs[i, cc]
                    for j in range(n):
                        p[j] += row[j]
                merged = c < k
                for j in range(n):
                    pj = p[j]
                    if pj > 0.0:
                        q = head[j]
                        r = pj / q - 1.0 if merged and q > 0.0 else 1.0
                        if r < 1e-4:
                            # P(d >= c) = p(c) (1 + r), r small where the mean is: the log of
                            # p(c) from log mu (as the count classes') and log(1 + r) by its
                            # series (to r^5 / 5 < 2e-21), no logarithm per particle
                            lp = (
                                c * lnl[j]
                                - lam[j]
                                - lf[c]
                                + r * (1.0 - r * (0.5 - r * (1.0 / 3.0 - 0.25 * r)))
                            )
                        else:
                            lp = math.log(pj)
                        wq[j] = w[j] * (log_w[j] + lp)
                    else:
                        wq[j] = w[j] * log_w[j]
                pc, xc, _ = _class_sums(p, w, wq, wq, wx, ma)
            else:
                pc, sb, sl = _class_sums(probs[i, c], w, wb, wl, wx, ma)
                xc = sb + c * sl - lf[c] * pc
            if pc > 1e-300:
                acc = 0.0
                for a in range(d):
                    diff = targets[i, a] - ma[a] / pc
                    acc += diff * diff
                ent = math.log(pc) - xc / pc
                expected += pc * (math.sqrt(acc) + h1 * ent)
        out[i] = w_now - expected
    return out, zz


#: The Poisson rewards with sums reassociated (vectorised): round-off differs from the NumPy
#: reference's order, within its 1e-9 relative tolerance.
poisson_direction_rewards = _cached_jit(_poisson_direction_rewards, nogil=True, fastmath=_REASSOC)


@jit
def adap_pp_means(
    x: np.ndarray,
    position: np.ndarray,
    steps: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    e: np.ndarray,
    aq: float,
    dt: float,
    adv: float,
    inv_lam: float,
    a2: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The first half of an Adap-PP decision in an obstacle-free box: the feasible candidates
    one step away and the expected counts of a measurement there (eqs. 1, 3).

    Parameters
    ----------
    x : (N, 3) ndarray, metres
        Particles (source hypotheses).
    position : (3,) ndarray, metres
        The UAV.
    steps : (M, 3) ndarray, metres
        The lattice steps.
    lo, hi : (3,) ndarray, metres
        The arena's bounds (a box is convex: a target inside, from a position inside, is
        reachable).
    e : (3,) ndarray
        Unit vector the wind blows towards.
    aq, dt, adv, inv_lam, a2 : float
        ``a Q``, the exposure (s), ``V / (2 D)``, ``1 / lambda`` and ``a^2`` of eq. 1.

    Returns
    -------
    feasible : (M,) bool ndarray
    targets : (M', 3) ndarray, metres
        The feasible candidates' hover points.
    mu : (M', N) ndarray
        Expected counts (:func:`~odorloc.models.kernels.rate_means_direct`).
    top : float
        Their maximum (``-inf`` when none).
    """
    m, d = steps.shape
    n = x.shape[0]
    ok = np.zeros(m, np.bool_)
    here = inside_box(position, lo, hi)
    t = np.empty(d)
    count = 0
    for i in range(m):
        for a in range(d):
            t[a] = position[a] + steps[i, a]
        if here and inside_box(t, lo, hi):
            ok[i] = True
            count += 1
    targets = np.empty((count, d))
    c = 0
    for i in range(m):
        if ok[i]:
            for a in range(d):
                targets[c, a] = position[a] + steps[i, a]
            c += 1
    mu, top = rate_means_direct(targets, x, e, np.full(n, aq), dt, adv, inv_lam, a2)
    return ok, targets, mu, top


@jit
def adap_pp_choose(
    mu: np.ndarray,
    n_classes: int,
    x: np.ndarray,
    log_w: np.ndarray,
    position: np.ndarray,
    steps: np.ndarray,
    feasible: np.ndarray,
    targets: np.ndarray,
    tail_mass: float,
    h1_scale: float,
    h1_variance: bool,
    l_max: int,
    lo: np.ndarray,
    hi: np.ndarray,
    history: np.ndarray,
    h2_scale: float,
) -> tuple[np.ndarray, int, int, np.ndarray, int]:
    """The second half of an Adap-PP decision: the direction (eqs. 21-25) and the step length
    (eqs. 26-28), as :class:`~odorloc.planning.adaptive.AdaptivePathPlanner` chooses them.

    Parameters
    ----------
    mu : (M', N) ndarray
        From :func:`adap_pp_means`.
    n_classes : int
        The model's count classes ``Z`` for these means.
    x : (N, 3) ndarray, metres
    log_w : (N,) ndarray
        Normalised log-weights.
    position : (3,) ndarray, metres
    steps : (M, 3) ndarray, metres
    feasible : (M,) bool ndarray
    targets : (M', 3) ndarray, metres
    tail_mass : float
        ``d_max`` of eq. 24.
    h1_scale : float
    h1_variance : bool
        ``h1 = h1_scale tr(Sigma)`` (else ``h1_scale sqrt(tr Sigma)``).
    l_max : int
    lo, hi : (3,) ndarray, metres
        The arena's bounds.
    history : (K, 3) ndarray, metres
        Past measurement points.
    h2_scale : float

    Returns
    -------
    rewards : (M',) ndarray, metres
        ``W_k - E[W_{k+1}]`` of the feasible candidates.
    kept : int
        Count classes after the tail cut.
    k : int
        The chosen direction (an index into ``steps``).
    step_scores : (l_max,) ndarray
        ``R(l)`` (eq. 27).
    length : int
        The chosen number of cells.
    """
    n, d = x.shape
    w = np.empty(n)
    est = np.zeros(d)
    h_now = 0.0
    for j in range(n):
        w[j] = math.exp(log_w[j])
        h_now -= _xlogx(w[j])
        for a in range(d):
            est[a] += w[j] * x[j, a]
    var = 0.0
    for j in range(n):
        for a in range(d):
            diff = x[j, a] - est[a]
            var += w[j] * diff * diff
    if var < 0.0:
        var = 0.0
    h1 = h1_scale * (var if h1_variance else math.sqrt(var))
    gap = 0.0
    for a in range(d):
        diff = position[a] - est[a]
        gap += diff * diff
    d_now = math.sqrt(gap)
    rewards, kept = poisson_direction_rewards(
        mu, w, log_w, x, targets, n_classes, tail_mass, h1, d_now + h1 * h_now
    )
    # the feasible candidate of the largest reward, the first of equals
    k = -1
    best = -np.inf
    c = 0
    for i in range(feasible.shape[0]):
        if feasible[i]:
            if math.isfinite(rewards[c]) and (k < 0 or rewards[c] > best):
                k = i
                best = rewards[c]
            c += 1
    if k < 0:
        return rewards, kept, k, np.empty(0), 1
    step = steps[k]
    s2 = 0.0
    for a in range(d):
        s2 += step[a] * step[a]
    scores = step_rewards(position, step, math.sqrt(s2), l_max, est, history, h2_scale * d_now)
    # a move is feasible only up to its first blocked length
    length = 1
    best = np.inf
    p = np.empty(d)
    for li in range(l_max):
        for a in range(d):
            p[a] = position[a] + (li + 1) * step[a]
        if not inside_box(p, lo, hi):
            break
        if math.isfinite(scores[li]) and scores[li] < best:
            best = scores[li]
            length = li + 1
    return rewards, kept, k, scores, length
