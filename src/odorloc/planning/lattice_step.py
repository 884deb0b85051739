"""A whole search step of the lattice problem as one compiled call: decision, move, hit, update.

OTTO's isotropic lattice problem (Loisy & Eloy 2022; ``/docs`` page "infotaxis") spends most of
a step outside its arithmetic when it goes through the general engine (observation objects, the
estimator, the planner's plan, the platform). These kernels keep the whole step in arrays:

1. **decision** of one of the four policies (``infotaxis``, ``space-aware-infotaxis``,
   ``greedy``, ``mean-distance``) on the belief ``b``;
2. **move** along one of the ``2 d`` axis directions (move ``a`` goes along axis ``a // 2``,
   towards lower indices when ``a`` is even);
3. **hit**: the source is found on its cell, else a hit class is drawn from the tabulated law
   ``P(h | source - agent)`` by inverting its cumulative sum at a uniform number ``u``;
4. **Bayes update** ``b(x) <- b(x) P(h | x - agent)``, ``b(agent) = 0``, renormalised (only
   when the mass exceeds ``1e-10``), and the entropy of the new belief.

Decision, with the reference's conventions (OTTO: cells of probability at most ``1e-10`` are
left out of every entropy, and masses are normalised only above ``1e-10``). For a candidate
``x'`` with ``p_end = b(x')`` and ``s = sum_x b - p_end`` (``sn = s`` when above ``1e-10``, else
1), two passes over the grid per candidate give, with ``P_h`` the law at offset ``x - x'`` (zero
at the found cell):

- ``J_h = sum_x b P_h`` and ``M_h = sum_x b P_h |x - x'|_1``; ``p(h) = J_h / sn``, the posterior
  ``b_h = b P_h / c_h`` with ``c_h = sn p(h)`` (``c_h = sn`` when ``p(h) <= 1e-10``);
- over the cells where ``b P_h > 1e-10 c_h`` (posterior above the floor):
  ``A_h = sum b P_h (log b + log P_h)`` and ``T_h = sum b P_h``, so that
  ``S(b_h) = -(A_h - T_h log c_h) / (c_h ln 2)`` bits without a logarithm per cell;
- infotaxis ``(1 - p_end) sum_h p(h) S(b_h) - S(b)`` (``-1e-10 - S(b)`` when
  ``p_end > 1 - 1e-10``); space-aware infotaxis ``(1 - p_end) sum_h p(h) g(D_h + 2^(S(b_h) - 1)
  - 1/2)`` with ``D_h = M_h / c_h`` and ``g = log2`` above 0; mean distance
  ``(1 - p_end) sum_h p(h) D_h``; greedy ``1 - p_end``.

Ties go to the lowest move among scores within ``1e-10`` of the best (the reference's rule).

The 2-D problem runs on the 3-D kernels with a leading axis of one cell. :func:`step_numpy` and
:func:`scores_numpy` are the NumPy reference the compiled kernels are tested against.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.jit import jit

__all__ = [
    "FLOOR",
    "POLICIES",
    "LatticeKernels",
    "draw_hit",
    "log_belief",
    "observe",
    "scores",
    "scores_numpy",
    "search_step",
    "step_numpy",
]

#: Masses at or below this are neither normalised nor counted in entropies (OTTO's ``EPSILON``).
FLOOR = 1e-10
#: Policy name -> kernel code.
POLICIES = {"infotaxis": 0, "space-aware-infotaxis": 1, "greedy": 2, "mean-distance": 3}
_LN2 = math.log(2.0)


class LatticeKernels:
    """The arrays a compiled step reads: the hit law per offset and its correlation channels.

    Parameters
    ----------
    prob : (Z, 2 N_1 - 1, ..., 2 N_d - 1) ndarray
        ``P(h | source - sensor = offset)`` (:attr:`~odorloc.models.lattice.OffsetTable.prob`
        of a table with ``half = N - 1``), ``d`` = 2 or 3.
    policy : str
        One of :data:`POLICIES`.

    Attributes
    ----------
    prob : (Z, W0, W1, W2) ndarray
        The law, 2-D tables given a leading axis of one offset.
    channels : (Z, 3, W0, W1, W2) ndarray
        ``P_h`` and ``P_h |offset|_1`` with the zero offset left out, and ``log P_h``.
    half : (3,) int64 ndarray
        Largest offset per axis (0 on the leading axis in 2-D).
    shape : tuple of int
        The belief's shape in the kernels (``(1, N, N)`` in 2-D).
    """

    def __init__(self, prob: np.ndarray, policy: str = "infotaxis") -> None:
        prob = np.asarray(prob, float)
        dim = prob.ndim - 1
        if dim not in (2, 3) or any(w % 2 == 0 for w in prob.shape[1:]):
            raise ConfigError("prob", f"needs (Z, odd, odd[, odd]) offsets, got {prob.shape}")
        if policy not in POLICIES:
            raise ConfigError("policy", f"must be one of {sorted(POLICIES)}, got {policy!r}")
        p3 = prob if dim == 3 else prob[:, None]
        self.dim = dim
        self.policy = policy
        self.code = POLICIES[policy]
        self.prob = np.ascontiguousarray(p3)
        self.half = np.array([(w - 1) // 2 for w in p3.shape[1:]], np.int64)
        self.shape = tuple(int(h) + 1 for h in self.half)
        z = p3.shape[0]
        axes = [np.abs(np.arange(-h, h + 1)) for h in self.half]
        l1 = axes[0][:, None, None] + axes[1][None, :, None] + axes[2][None, None, :]
        keep = l1 > 0
        ch = np.empty((z, 3, *p3.shape[1:]))
        ch[:, 0] = p3 * keep
        with np.errstate(divide="ignore"):
            ch[:, 1] = np.log(p3)
        ch[:, 2] = p3 * l1 * keep
        self.channels = np.ascontiguousarray(ch)

    @property
    def n_classes(self) -> int:
        """Number of hit classes ``Z``."""
        return int(self.prob.shape[0])

    def as_kernel(self, array: np.ndarray) -> np.ndarray:
        """A belief (``(N, N)`` or ``(N, N, N)``) viewed in the kernels' 3-D shape."""
        return array.reshape(self.shape)

    def agent3(self, cell: np.ndarray) -> np.ndarray:
        """A cell index ``(d,)`` as the kernels' ``(3,)`` int64 index (a ``(3,)`` index is
        returned as it is)."""
        c = np.asarray(cell, np.int64).reshape(-1)
        return c if c.size == 3 else np.concatenate([np.zeros(1, np.int64), c])


# ---------------------------------------------------------------------- compiled kernels
def _move(ag: np.ndarray, a: int, dim: int, shape0: int, shape1: int, shape2: int) -> np.ndarray:
    """The cell after move ``a`` (a copy), or ``[-1, -1, -1]`` when it leaves the grid."""
    out = ag.copy()
    axis = a // 2 + (3 - dim)
    step = 1 if a % 2 == 1 else -1
    out[axis] += step
    n = shape0 if axis == 0 else shape1 if axis == 1 else shape2
    if out[axis] < 0 or out[axis] >= n:
        out[0] = -1
        out[1] = -1
        out[2] = -1
    return out


def _g(v: float) -> float:
    return math.log2(v) if v > 0.0 else v


def _decide(
    b: np.ndarray,
    logb: np.ndarray,
    s_b: float,
    ag: np.ndarray,
    ch: np.ndarray,
    half: np.ndarray,
    dim: int,
    policy: int,
    scores: np.ndarray,
) -> int:
    """Scores of the ``2 d`` moves into ``scores`` (module docstring; ``inf`` for a move that
    leaves the grid) and the choice: the lowest move among the scores within ``1e-10`` of the
    best. Every belief row is read once for all the moves and classes."""
    n0, n1, n2 = b.shape
    nm = 2 * dim
    z = ch.shape[0]
    xs = np.empty((nm, 3), np.int64)
    p_end = np.zeros(nm)
    valid = np.zeros(nm, np.bool_)
    for a in range(nm):
        x = _move(ag, a, dim, n0, n1, n2)
        xs[a] = x
        valid[a] = x[0] >= 0
        if valid[a]:
            p_end[a] = b[x[0], x[1], x[2]]
    if policy == 2:
        for a in range(nm):
            scores[a] = 1.0 - p_end[a] if valid[a] else np.inf
        return _first_best(scores, nm)
    tot = 0.0
    for i0 in range(n0):
        for i1 in range(n1):
            brow = b[i0, i1]
            for i2 in range(n2):
                tot += brow[i2]
    jj = np.zeros((nm, z))
    mm = np.zeros((nm, z))
    # pass 1: J_h and M_h
    for i0 in range(n0):
        for i1 in range(n1):
            brow = b[i0, i1]
            for a in range(nm):
                if not valid[a]:
                    continue
                r0 = i0 - xs[a, 0] + half[0]
                r1 = i1 - xs[a, 1] + half[1]
                o2 = half[2] - xs[a, 2]
                for h in range(z):
                    p = ch[h, 0, r0, r1, o2 : o2 + n2]
                    sj = 0.0
                    for i2 in range(n2):
                        sj += brow[i2] * p[i2]
                    jj[a, h] += sj
                    if policy != 0:
                        pd = ch[h, 2, r0, r1, o2 : o2 + n2]
                        sm = 0.0
                        for i2 in range(n2):
                            sm += brow[i2] * pd[i2]
                        mm[a, h] += sm
    cc = np.ones((nm, z))
    sn = np.ones(nm)
    for a in range(nm):
        s = tot - p_end[a]
        sn[a] = s if s > 1e-10 else 1.0
        for h in range(z):
            ph = jj[a, h] / sn[a]
            cc[a, h] = sn[a] * (ph if ph > 1e-10 else 1.0)
    if policy == 3:
        for a in range(nm):
            if not valid[a]:
                scores[a] = np.inf
                continue
            out = 0.0
            for h in range(z):
                out += jj[a, h] / sn[a] * (mm[a, h] / cc[a, h])
            scores[a] = (1.0 - p_end[a]) * out
        return _first_best(scores, nm)
    # pass 2: over the posterior cells above 1e-10 (b P_h > 1e-10 c_h), A_h and T_h
    aa = np.zeros((nm, z))
    tt = np.zeros((nm, z))
    for i0 in range(n0):
        for i1 in range(n1):
            brow = b[i0, i1]
            lrow = logb[i0, i1]
            for a in range(nm):
                if not valid[a]:
                    continue
                r0 = i0 - xs[a, 0] + half[0]
                r1 = i1 - xs[a, 1] + half[1]
                o2 = half[2] - xs[a, 2]
                for h in range(z):
                    p = ch[h, 0, r0, r1, o2 : o2 + n2]
                    lp = ch[h, 1, r0, r1, o2 : o2 + n2]
                    thr = 1e-10 * cc[a, h]
                    sa = 0.0
                    sk = 0.0
                    for i2 in range(n2):
                        t = brow[i2] * p[i2]
                        if t > thr:
                            sa += t * (lrow[i2] + lp[i2])
                            sk += t
                    aa[a, h] += sa
                    tt[a, h] += sk
    for a in range(nm):
        if not valid[a]:
            scores[a] = np.inf
            continue
        if policy == 0 and p_end[a] > 1.0 - 1e-10:
            scores[a] = -1e-10 - s_b
            continue
        out = 0.0
        for h in range(z):
            j = jj[a, h]
            if j <= 0.0:
                continue
            ph = j / sn[a]
            c = cc[a, h]
            # the cells below the floor are left out of the entropy, not of the mass
            ent = -(aa[a, h] - math.log(c) * tt[a, h]) / (c * math.log(2.0))
            if policy == 0:
                out += ph * ent
            else:
                out += ph * _g(mm[a, h] / c + 2.0 ** (ent - 1.0) - 0.5)
        scores[a] = (1.0 - p_end[a]) * out - (s_b if policy == 0 else 0.0)
    return _first_best(scores, nm)


def _first_best(scores: np.ndarray, nm: int) -> int:
    best = np.inf
    for a in range(nm):
        if scores[a] < best:
            best = scores[a]
    for a in range(nm):
        if abs(scores[a] - best) < 1e-10:
            return a
    return 0  # pragma: no cover - some move stays inside a grid of N >= 2


def _observe(
    b: np.ndarray,
    logb: np.ndarray,
    ag: np.ndarray,
    prob: np.ndarray,
    logp: np.ndarray,
    half: np.ndarray,
    hit: int,
    mom: np.ndarray,
) -> float:
    """Bayes update of ``b`` in place after ``hit`` at ``ag``; ``logb`` follows as
    ``log b + log P_hit - log(mass)`` (no logarithm per cell); returns the entropy (bits,
    cells above ``1e-10``) and puts the belief's first moments ``sum b x`` per axis (cells)
    into ``mom`` ``(3,)``."""
    n0, n1, n2 = b.shape
    b[ag[0], ag[1], ag[2]] = 0.0
    tot = 0.0
    for i0 in range(n0):
        r0 = i0 - ag[0] + half[0]
        for i1 in range(n1):
            r1 = i1 - ag[1] + half[1]
            o2 = half[2] - ag[2]
            p = prob[hit, r0, r1, o2 : o2 + n2]
            row = b[i0, i1]
            # both factors are >= 0, so the reference's clipping of values in (-1e-15, 0)
            # never applies
            for i2 in range(n2):
                v = row[i2] * p[i2]
                row[i2] = v
                tot += v
    scale = 1.0 / tot if tot > 1e-10 else 1.0
    shift = math.log(scale)
    ent = 0.0
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    for i0 in range(n0):
        r0 = i0 - ag[0] + half[0]
        for i1 in range(n1):
            r1 = i1 - ag[1] + half[1]
            o2 = half[2] - ag[2]
            lp = logp[hit, 1, r0, r1, o2 : o2 + n2]
            row = b[i0, i1]
            lrow = logb[i0, i1]
            srow = 0.0
            for i2 in range(n2):
                v = row[i2] * scale
                row[i2] = v
                srow += v
                m2 += v * i2
                lv = lrow[i2] + lp[i2] + shift
                lrow[i2] = lv
                if v > 1e-10:
                    ent -= v * lv
            m0 += srow * i0
            m1 += srow * i1
    mom[0] = m0
    mom[1] = m1
    mom[2] = m2
    logb[ag[0], ag[1], ag[2]] = -np.inf
    return ent / math.log(2.0)


def _log_belief(b: np.ndarray, logb: np.ndarray) -> float:
    """``logb = log b`` (``-inf`` at 0) and the entropy of ``b`` in bits (cells above 1e-10)."""
    n0, n1, n2 = b.shape
    ent = 0.0
    for i0 in range(n0):
        for i1 in range(n1):
            for i2 in range(n2):
                v = b[i0, i1, i2]
                if v > 0.0:
                    lv = math.log(v)
                    logb[i0, i1, i2] = lv
                    if v > 1e-10:
                        ent -= v * lv
                else:
                    logb[i0, i1, i2] = -np.inf
    return ent / math.log(2.0)


def _draw_hit(ag: np.ndarray, src: np.ndarray, prob: np.ndarray, half: np.ndarray, u: float) -> int:
    z = prob.shape[0]
    r0 = src[0] - ag[0] + half[0]
    r1 = src[1] - ag[1] + half[1]
    r2 = src[2] - ag[2] + half[2]
    c = 0.0
    for h in range(z - 1):
        c += prob[h, r0, r1, r2]
        if u < c:
            return h
    return z - 1


def _search_step(
    b: np.ndarray,
    logb: np.ndarray,
    s_b: float,
    ag: np.ndarray,
    src: np.ndarray,
    ch: np.ndarray,
    prob: np.ndarray,
    half: np.ndarray,
    dim: int,
    policy: int,
    u: float,
    given: int,
    scores: np.ndarray,
) -> tuple[int, int, float]:
    """One whole step (module docstring); ``ag`` moves in place. Returns the move, the hit
    (``-1`` when the source is found) and the new entropy (bits)."""
    n0, n1, n2 = b.shape
    a = _decide(b, logb, s_b, ag, ch, half, dim, policy, scores)
    x = _move(ag, a, dim, n0, n1, n2)
    ag[0] = x[0]
    ag[1] = x[1]
    ag[2] = x[2]
    if ag[0] == src[0] and ag[1] == src[1] and ag[2] == src[2]:
        return a, -1, 0.0
    hit = _draw_hit(ag, src, prob, half, u)
    if given >= 0:
        hit = given
    return a, hit, _observe(b, logb, ag, prob, ch, half, hit, np.empty(3))


_move = jit(_move)
_g = jit(_g)
_first_best = jit(_first_best)
# reassociation lets the correlation sums run in SIMD lanes; nothing is assumed about
# infinities (log 0 = -inf is read behind the threshold test)
_decide = jit(_decide, fastmath={"reassoc", "contract", "arcp", "nsz"})
_observe = jit(_observe, fastmath={"reassoc", "contract", "arcp", "nsz"})
_log_belief = jit(_log_belief)
_draw_hit = jit(_draw_hit)
_search_step = jit(_search_step)


# ---------------------------------------------------------------------- public entry points
def log_belief(k: LatticeKernels, b: np.ndarray) -> tuple[np.ndarray, float]:
    """``log b`` (``-inf`` at 0) of a kernel-shaped belief and its entropy (bits)."""
    logb = np.empty_like(b)
    return logb, float(_log_belief(b, logb))


def observe(
    k: LatticeKernels, b: np.ndarray, logb: np.ndarray, agent: np.ndarray, hit: int
) -> float:
    """Bayes update of the kernel-shaped belief ``b`` (and ``logb``) in place after ``hit`` in
    cell ``agent``; returns the new entropy (bits)."""
    if not 0 <= int(hit) < k.n_classes:
        raise ConfigError("hit", f"{hit} is not a class of 0..{k.n_classes - 1}")
    mom = np.empty(3)
    return float(_observe(b, logb, k.agent3(agent), k.prob, k.channels, k.half, int(hit), mom))


def draw_hit(k: LatticeKernels, agent: np.ndarray, source: np.ndarray, u: float) -> int:
    """The hit class at ``agent`` for a source at ``source`` from the uniform number ``u``."""
    return int(_draw_hit(k.agent3(agent), k.agent3(source), k.prob, k.half, float(u)))


def scores(
    k: LatticeKernels, b: np.ndarray, logb: np.ndarray, entropy: float, agent: np.ndarray
) -> tuple[int, np.ndarray]:
    """The compiled decision: the chosen move and the ``(2 d,)`` scores of every move."""
    out = np.empty(2 * k.dim)
    a = _decide(b, logb, float(entropy), k.agent3(agent), k.channels, k.half, k.dim, k.code, out)
    return int(a), out


def search_step(
    k: LatticeKernels,
    b: np.ndarray,
    logb: np.ndarray,
    entropy: float,
    agent: np.ndarray,
    source: np.ndarray,
    u: float,
    hit: int = -1,
    scores: np.ndarray | None = None,
) -> tuple[int, int, float]:
    """One compiled whole step (module docstring) on kernel-shaped arrays.

    Parameters
    ----------
    k : LatticeKernels
    b, logb : ndarray, shape ``k.shape``
        Belief and its logarithm (:func:`log_belief`), both updated in place.
    entropy : float, bits
        Entropy of ``b`` (cells above ``1e-10``).
    agent, source : (3,) int64 ndarray
        Kernel-shaped cells (:meth:`LatticeKernels.agent3`); ``agent`` moves in place.
    u : float
        Uniform number in ``[0, 1)`` for the hit.
    hit : int
        A hit to use instead of the drawn one (``-1``: the drawn one), for replays.
    scores : (2 d,) ndarray, optional
        Receives the scores of the moves.

    Returns
    -------
    move : int
    hit : int
        ``-1`` when the agent stepped onto the source.
    entropy : float, bits
    """
    sc = np.empty(2 * k.dim) if scores is None else scores
    a, h, s = _search_step(
        b,
        logb,
        float(entropy),
        agent,
        source,
        k.channels,
        k.prob,
        k.half,
        k.dim,
        k.code,
        float(u),
        int(hit),
        sc,
    )
    return int(a), int(h), float(s)


# ---------------------------------------------------------------------- NumPy reference
def _window(k: LatticeKernels, cell: np.ndarray) -> tuple[slice, ...]:
    c = k.agent3(cell)
    pairs = zip(k.half, c, k.shape, strict=True)
    return tuple(slice(int(h - x), int(h - x + n)) for h, x, n in pairs)


def scores_numpy(k: LatticeKernels, b: np.ndarray, agent: np.ndarray) -> np.ndarray:
    """The reference's scores of the ``2 d`` moves on the kernel-shaped belief ``b`` (OTTO's
    conventions: entropies over cells above ``1e-10``, masses normalised only above it).

    Returns
    -------
    (2 d,) ndarray
        ``inf`` for a move that leaves the grid.
    """
    ag = k.agent3(agent)
    pos = b[b > FLOOR]
    s_b = float(-(pos * np.log2(pos)).sum())
    grids = np.meshgrid(*[np.arange(n) for n in k.shape], indexing="ij")
    out = np.full(2 * k.dim, np.inf)
    for a in range(2 * k.dim):
        x = ag.copy()
        axis = a // 2 + (3 - k.dim)
        x[axis] += 1 if a % 2 else -1
        if not 0 <= x[axis] < k.shape[axis]:
            continue
        p_end = float(b[tuple(x)])
        if k.code == 2:
            out[a] = 1.0 - p_end
            continue
        if k.code == 0 and p_end > 1.0 - FLOOR:
            out[a] = -FLOOR - s_b
            continue
        bp = b.copy()
        bp[tuple(x)] = 0.0
        if bp.sum() > FLOOR:
            bp /= bp.sum()
        post = bp[None] * k.prob[(slice(None), *_window(k, x))]
        ph = np.maximum(post.sum(axis=(1, 2, 3)), 0.0)
        for h in range(k.n_classes):
            if ph[h] > FLOOR:
                post[h] /= ph[h]
        lg = np.zeros_like(post)
        big = post > FLOOR
        lg[big] = -np.log2(post[big])
        ent = (post * lg).sum(axis=(1, 2, 3))
        dist = sum(np.abs(g - c) for g, c in zip(grids, x, strict=True))
        d_h = (post * dist[None]).sum(axis=(1, 2, 3))
        if k.code == 0:
            out[a] = (1.0 - p_end) * float((ph * ent).sum()) - s_b
        elif k.code == 1:
            v = d_h + 2.0 ** (ent - 1.0) - 0.5
            g = np.where(v > 0, np.log2(np.where(v > 0, v, 1.0)), v)
            out[a] = float(((1.0 - p_end) * ph * g).sum())
        else:
            out[a] = (1.0 - p_end) * float((ph * d_h).sum())
    return out


def step_numpy(
    k: LatticeKernels,
    b: np.ndarray,
    agent: np.ndarray,
    source: np.ndarray,
    u: float,
    hit: int = -1,
) -> tuple[int, int, np.ndarray, np.ndarray]:
    """:func:`search_step` in NumPy (the reference): returns the move, the hit (``-1``: found),
    the new agent cell ``(3,)`` and the new belief (a copy)."""
    sc = scores_numpy(k, b, agent)
    a = int(np.flatnonzero(np.abs(sc - sc.min()) < FLOOR)[0])
    ag = k.agent3(agent).copy()
    ag[a // 2 + (3 - k.dim)] += 1 if a % 2 else -1
    src = k.agent3(source)
    if np.array_equal(ag, src):
        return a, -1, ag, b.copy()
    r = tuple(int(s - x + h) for s, x, h in zip(src, ag, k.half, strict=True))
    cum = np.cumsum(k.prob[(slice(None), *r)])[:-1]
    drawn = int(np.searchsorted(cum, u, side="right"))
    h = drawn if hit < 0 else int(hit)
    nb = b.copy()
    nb[tuple(ag)] = 0.0
    nb *= k.prob[(h, *_window(k, ag))]
    nb[(nb < 0) & (nb > -1e-15)] = 0.0
    if nb.sum() > FLOOR:
        nb /= nb.sum()
    return a, h, ag, nb
