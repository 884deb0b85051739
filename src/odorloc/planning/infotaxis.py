"""Infotaxis and its successors: rewards on grid or particle beliefs, and their planners.

A move to a candidate ends the search if the source is there (probability ``p_found``) and
otherwise yields a reading ``z``. The rewards (registry family ``reward``) score every
candidate, lower is better (:mod:`odorloc.planning.rewards` for the formulas):

- ``expected-entropy`` (infotaxis; Vergassola, Villermaux & Shraiman 2007): the expected change
  of the belief's entropy after the move, i.e. minus the information
  ``I = H(outcome) - H(outcome | source)`` it brings;
- ``space-aware`` (space-aware infotaxis; Loisy & Eloy 2022):
  ``sum_z P(z) g(D_z + 2^(S_z - 1) - 1/2)``;
- ``predictive-entropy`` (entrotaxis; Hutchinson, Oh & Chen 2018): minus the entropy of the
  predicted outcome;
- ``greedy``: the probability of *not* finding the source at the candidate;
- ``mean-distance`` (Loisy & Eloy 2022): the expected posterior mean distance.

A policy is a planner with one of them: :class:`LatticePlanner` (``lattice``) on grid beliefs,
:class:`ParticlePlanner` (``particle``) on weighted particles; the searchers' presets name the
published policies (``infotaxis``, ``entrotaxis``, ``space-aware-infotaxis``, ``greedy``,
``mean-distance``).

Grid beliefs (:class:`LatticePlanner`)
--------------------------------------
With a translation-invariant model tabulated over lattice offsets
(:func:`~odorloc.models.lattice.tabulate`), every per-candidate sum over the cells is a
correlation of the belief with a table window. Infotaxis needs only three of them per candidate:
``p_found``, ``J_z = P(z, not found)`` and ``C = sum_x b(x) H(Z | x)`` (the tables are zeroed on
the found offsets), since

    ``E[S after] - S(b) = -I = C - H2(p_found) - sum_z J_z log(J_z)``  (up to the sign of
    ``J log J``: ``H(outcome) = -p_found log p_found - sum_z J_z log J_z``),

the mutual information of the source and the outcome; entrotaxis and greedy need only
``p_found`` and ``J``. Space-aware infotaxis and mean distance form the posteriors explicitly.

The reference implementation (OTTO) leaves out of every entropy the cells of probability at most
``1e-10`` and normalises only masses above it (``floor``). Those conventions change a score by
at most ``B = n floor log2(1 / floor) + (Z + 1) floor log2(n) + floor`` bits (``n`` hypotheses),
so when another candidate scores within ``2 B`` (plus the tie tolerance) of the best, the
contenders are scored again with the conventions applied (:func:`~odorloc.planning.rewards.
expected_entropy` with ``floor``): the choice is then the reference's, while most decisions cost
only the correlations. Ties go to the lowest candidate index among scores within the selection's
tolerance of the best (the reference's rule), or to a uniformly drawn one (``ties: random``).

Particle beliefs (:class:`ParticlePlanner`)
-------------------------------------------
The same rewards over weighted particles: the candidates (e.g. 26 directions times a step) and
the outcome model (the planner's measurement model bound to the pose's conditions) are parts;
particles within the belief's ``found_radius`` of a candidate count as found there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar, Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit
from odorloc.core.params import NonNegative, Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.grid_estimator import LatticeBelief
from odorloc.models.lattice import OffsetTable
from odorloc.planning import rewards
from odorloc.planning.base import Plan, Planner, Pose, Reward
from odorloc.planning.candidates import Candidates
from odorloc.planning.selection import Selection

__all__ = [
    "ExpectedEntropyReward",
    "GreedyReward",
    "LatticeOutcomes",
    "LatticePlanner",
    "LatticePlannerParams",
    "MeanDistanceReward",
    "ParticlePlanner",
    "ParticlePlannerParams",
    "PredictiveEntropyReward",
    "SpaceAwareReward",
    "correlate",
    "lattice_outcomes",
    "lattice_posteriors",
]

_LN2 = math.log(2.0)
_EXACT_TIE = 1e-12  # bits: scores this close are equal up to rounding


def _xlogx(x: np.ndarray) -> np.ndarray:
    """``x log x`` with ``0 log 0 = 0`` (small arrays: cheaper than ``scipy.special.xlogy``)."""
    return x * np.log(x, where=x > 0, out=np.zeros_like(x))


# ---------------------------------------------------------------------- correlations
class _Kernel:
    """A table's planning channels ``[P(z) ..., H(Z), found, |offset|_1]`` (cells), the found
    offsets zeroed in every channel but ``found``."""

    def __init__(self, table: OffsetTable, radius: float) -> None:
        off = table.offsets()
        found = np.linalg.norm(off, axis=-1) <= radius + 1e-9 * float(np.max(table.cell))
        keep = ~found
        z = table.n_classes
        ch = np.empty((z + 3, *found.shape))
        ch[:z] = table.prob * keep
        ch[z] = table.cond_entropy * keep
        ch[z + 1] = found
        ch[z + 2] = np.abs(off / table.cell).sum(axis=-1) * keep
        ch = np.ascontiguousarray(ch)
        self.single = int(found.sum()) == 1
        self.found_channel = np.ascontiguousarray(found[None].astype(float))
        self.table = table
        self.channels = ch
        self.found = found
        self.n_classes = z


_KERNELS: dict[tuple[int, float], tuple[OffsetTable, _Kernel]] = {}


def _kernel(table: OffsetTable, radius: float) -> _Kernel:
    key = (id(table), float(radius))
    hit = _KERNELS.get(key)
    if hit is not None and hit[0] is table:
        return hit[1]
    if len(_KERNELS) > 32:
        _KERNELS.clear()
    k = _Kernel(table, radius)
    _KERNELS[key] = (table, k)
    return k


@dataclass(frozen=True)
class LatticeOutcomes:
    """Per-candidate sums of a grid belief against table windows.

    Attributes
    ----------
    p_found : (M,) ndarray
        Probability that the source lies within the found radius of the candidate.
    joint : (M, Z) ndarray
        ``P(z, not found)``.
    cond_entropy : (M,) ndarray, nats
        ``sum over not-found hypotheses of b(k, x) H(Z | k, x)``.
    found_entropy : (M,) ndarray, nats
        ``P(found) H(source | found)``: zero when a single hypothesis is found (the
        candidate's own cell, a known release).
    """

    p_found: np.ndarray
    joint: np.ndarray
    cond_entropy: np.ndarray
    found_entropy: np.ndarray

    @property
    def outcome_entropy(self) -> np.ndarray:
        """``H(outcome)`` of each candidate (found, or a reading), nats."""
        return -_xlogx(self.p_found) - _xlogx(self.joint).sum(axis=1)

    @property
    def information(self) -> np.ndarray:
        """Mutual information of the source and the outcome, nats (``>= 0``)."""
        return self.outcome_entropy - self.cond_entropy

    @property
    def entropy_change(self) -> np.ndarray:
        """Expected change of the belief's entropy, nats: ``-I - P(found) H(source | found)``
        (finding the source ends the search, so it leaves no uncertainty)."""
        return -self.information - self.found_entropy


def _correlate_numpy(
    channels: np.ndarray, b: np.ndarray, cells: np.ndarray, half: tuple[int, ...]
) -> np.ndarray:
    """``out[m, c] = sum_x b(x) channels[c, x - cell_m + half]``, ``(M, C)`` (reference)."""
    out = np.empty((len(cells), channels.shape[0]))
    flat = b.reshape(-1)
    for m, cell in enumerate(cells):
        w = tuple(
            slice(h - int(v), h - int(v) + n) for v, h, n in zip(cell, half, b.shape, strict=True)
        )
        out[m] = channels[(slice(None), *w)].reshape(channels.shape[0], -1) @ flat
    return out


# Rows outermost and a contiguous innermost loop: it vectorises, and each belief row is read
# once for every candidate and channel.
def _corr2(ch, b, cells, h0, h1, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    n0, n1 = b.shape
    out[:, :] = 0.0
    for i in range(n0):
        brow = b[i]
        for m in range(cells.shape[0]):
            r = i + h0 - cells[m, 0]
            o1 = h1 - cells[m, 1]
            for c in range(ch.shape[0]):
                row = ch[c, r, o1 : o1 + n1]
                acc = 0.0
                for j in range(n1):
                    acc += row[j] * brow[j]
                out[m, c] += acc


def _corr3(ch, b, cells, h0, h1, h2, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    n0, n1, n2 = b.shape
    out[:, :] = 0.0
    for i in range(n0):
        for j in range(n1):
            brow = b[i, j]
            for m in range(cells.shape[0]):
                r0 = i + h0 - cells[m, 0]
                r1 = j + h1 - cells[m, 1]
                o2 = h2 - cells[m, 2]
                for c in range(ch.shape[0]):
                    row = ch[c, r0, r1, o2 : o2 + n2]
                    acc = 0.0
                    for k in range(n2):
                        acc += row[k] * brow[k]
                    out[m, c] += acc


def _warm_corr2(kernel: Any) -> None:
    """One call on a one-cell belief, with the argument types :func:`_correlate` uses."""
    kernel(np.ones((1, 1, 1)), np.ones((1, 1)), np.zeros((1, 2), np.int64), 0, 0, np.zeros((1, 1)))


def _warm_corr3(kernel: Any) -> None:
    """One call on a one-cell 3-D belief, with the argument types :func:`_correlate` uses."""
    kernel(
        np.ones((1, 1, 1, 1)),
        np.ones((1, 1, 1)),
        np.zeros((1, 3), np.int64),
        0,
        0,
        0,
        np.zeros((1, 1)),
    )


if HAVE_NUMBA:
    # module-level kernels with a cache in the user's cache folder, so that the cache hits in
    # every later process and nothing is written into the package (see odorloc.core.jit)
    _corr2 = jit(_corr2, warmup=_warm_corr2, fastmath=True)
    _corr3 = jit(_corr3, warmup=_warm_corr3, fastmath=True)


def _correlate_kernel():  # type: ignore[no-untyped-def]
    """The compiled correlations ``(2-D, 3-D)``, or ``None`` without numba."""
    return (_corr2, _corr3) if HAVE_NUMBA else None


def correlate(
    channels: np.ndarray,
    b: np.ndarray,
    cells: np.ndarray,
    half: tuple[int, ...],
    backend: Literal["auto", "numpy", "numba"] = "auto",
) -> np.ndarray:
    """Sums of a grid ``b`` against table windows at candidate cells, ``(M, C)``.

    ``out[m, c] = sum_x b(x) channels[c, x - cells[m] + half]``: the table entry of the offset
    from the candidate to each cell. ``numba`` runs a compiled loop (the ``fast`` extra);
    ``numpy`` one matrix-vector product per candidate; ``auto`` uses numba when installed. Both
    agree to rounding.
    """
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    for a, (lo_c, hi_c) in enumerate(zip(cells.min(axis=0), cells.max(axis=0), strict=True)):
        if half[a] - hi_c < 0 or half[a] - lo_c + b.shape[a] > 2 * half[a] + 1:
            raise ConfigError("cells", f"a candidate lies beyond the table on axis {a}")
    return _correlate(channels, b, cells, half, backend)


def _correlate(
    channels: np.ndarray,
    b: np.ndarray,
    cells: np.ndarray,
    half: tuple[int, ...],
    backend: Literal["auto", "numpy", "numba"] = "auto",
) -> np.ndarray:
    """:func:`correlate` without its checks (``cells`` int64, inside the tables' reach)."""
    kernels = _correlate_kernel() if backend != "numpy" else None
    if kernels is None:
        if backend == "numba":
            raise ModuleNotFoundError("numba is not installed (pip install odorloc[fast])")
        return _correlate_numpy(channels, b, cells, half)
    out = np.empty((len(cells), channels.shape[0]))
    if b.ndim == 2:
        kernels[0](channels, b, cells, half[0], half[1], out)
    else:
        kernels[1](channels, b, cells, half[0], half[1], half[2], out)
    return out


def lattice_outcomes(
    joint: np.ndarray,
    tables: Sequence[OffsetTable],
    cells: np.ndarray,
    found_radius: float,
    backend: Literal["auto", "numpy", "numba"] = "auto",
) -> LatticeOutcomes:
    """``p_found``, ``P(z, not found)`` and the conditional entropy of every candidate cell.

    Parameters
    ----------
    joint : (K, n1, ..., nd) ndarray
        Belief over release hypotheses and cells (sums to one).
    tables : sequence of K OffsetTable
        The model tabulated for each release (same classes and cell).
    cells : (M, d) int ndarray
        Candidate cells (inside the tables' reach).
    found_radius : float, metres
        Hypotheses within this distance of a candidate's centre are found there.
    backend : {"auto", "numpy", "numba"}
        See :func:`correlate`.
    """
    b = np.asarray(joint, float)
    if len(tables) != b.shape[0]:
        raise ConfigError("tables", f"need {b.shape[0]} table(s), got {len(tables)}")
    if len({t.n_classes for t in tables}) > 1:
        raise ConfigError("tables", "the release hypotheses' tables need the same classes")
    cells = np.atleast_2d(np.asarray(cells, dtype=np.int64))
    acc = None
    for k, t in enumerate(tables):
        sums = correlate(_kernel(t, found_radius).channels, b[k], cells, t.half, backend)
        acc = sums if acc is None else acc + sums
    assert acc is not None
    z = tables[0].n_classes
    pe = np.clip(acc[:, z + 1], 0.0, 1.0)
    return LatticeOutcomes(
        pe,
        np.maximum(acc[:, :z], 0.0),
        np.maximum(acc[:, z], 0.0),
        _found_entropy(b, tables, cells, found_radius, pe),
    )


def _found_entropy(
    b: np.ndarray,
    tables: Sequence[OffsetTable],
    cells: np.ndarray,
    radius: float,
    pe: np.ndarray,
) -> np.ndarray:
    """``P(found) H(source | found) = pe log pe - sum_found b log b`` per candidate, nats."""
    if len(tables) == 1 and _kernel(tables[0], radius).single:
        return np.zeros(len(cells))  # one hypothesis found: nothing left uncertain
    blogb = _xlogx(b)
    s = np.zeros(len(cells))
    for k, t in enumerate(tables):
        s += _correlate(_kernel(t, radius).found_channel, blogb[k], cells, t.half)[:, 0]
    return np.maximum(_xlogx(pe) - s, 0.0)


def _sums(
    b: np.ndarray, tables: Sequence[OffsetTable], cells: np.ndarray, radius: float
) -> np.ndarray:
    """Planning sums ``(M, Z + 3)`` of a ``(K, *shape)`` belief: ``J_z``, ``C``, ``p_found`` and
    the mean Manhattan distance (cells) over the not-found hypotheses."""
    if len({t.n_classes for t in tables}) > 1:
        raise ConfigError("tables", "the release hypotheses' tables need the same classes")
    acc = _correlate(_kernel(tables[0], radius).channels, b[0], cells, tables[0].half)
    for k in range(1, len(tables)):
        acc += _correlate(_kernel(tables[k], radius).channels, b[k], cells, tables[k].half)
    np.maximum(acc, 0.0, out=acc)  # rounding below zero on empty windows
    return acc


@lru_cache(maxsize=32)
def _outcome_columns(z: int) -> np.ndarray:
    """Columns of the outcomes in the planning sums: the ``z`` readings and "found"."""
    return np.array([*range(z), z + 1])


def lattice_posteriors(
    joint: np.ndarray,
    tables: Sequence[OffsetTable],
    cells: np.ndarray,
    found_radius: float,
    floor: float = 0.0,
    distances: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """The outcome law and posterior statistics of every candidate cell, from table windows.

    Equivalent to :func:`~odorloc.planning.rewards.outcome_posteriors` (with the ``floor``
    conventions) over the hypotheses ``(k, x)``, but the logarithms come from the tables:
    ``log b_z = log b' + log P(z | x - cell) - log p(z)``.

    Returns
    -------
    p_found : (M,) ndarray
    p : (M, Z) ndarray
        Reading law when not found.
    entropy : (M, Z) ndarray, bits
        Posterior entropies (entries above ``floor`` only).
    distance : (M, Z) ndarray or None
        Posterior mean Manhattan distance to the candidate, in cells (with ``distances``).
    """
    b = np.asarray(joint, float)
    shape = b.shape[1:]
    cells = np.atleast_2d(np.asarray(cells, dtype=np.int64))
    flat = b.reshape(b.shape[0], -1)
    with np.errstate(divide="ignore"):
        logb = np.log(flat)
    qs, lqs, fs = [], [], []
    for k, t in enumerate(tables):
        ker = _kernel(t, found_radius)
        idx = _window_index(t, shape, cells)  # (M, n) flat table entries
        z = t.n_classes
        qs.append(np.take(t.prob.reshape(z, -1), idx, axis=1).transpose(1, 0, 2))
        lq = np.take(t.log_prob.reshape(z, -1), idx, axis=1).transpose(1, 0, 2)
        lqs.append(lq + logb[k])
        fs.append(np.take(ker.found.reshape(-1), idx))
    q = np.concatenate(qs, axis=2) if len(qs) > 1 else qs[0]
    lj = np.concatenate(lqs, axis=2) if len(lqs) > 1 else lqs[0]  # log b(x) P(z | x)
    found = np.concatenate(fs, axis=1) if len(fs) > 1 else fs[0]
    w = flat.reshape(-1)
    pe = found.astype(float) @ w
    rest = 1.0 - pe
    norm = np.where(rest > floor, rest, 1.0)
    bp = np.where(found, 0.0, w[None, :]) / norm[:, None]  # b' (M, n)
    joint_z = q * bp[:, None, :]
    p = joint_z.sum(axis=2)
    pz = np.where(p > floor, p, 1.0)
    post = joint_z / pz[:, :, None]
    # log of the posterior from the tables; found hypotheses are zero in ``post``
    lj -= (np.log(norm)[:, None] + np.log(pz))[:, :, None]
    np.copyto(lj, 0.0, where=~(post > floor))
    ent = -np.einsum("mzn,mzn->mz", post, lj) / _LN2
    dist = None
    if distances:
        coords = _grid_coords(shape)
        d = np.abs(coords[None, :, :] - cells[:, None, :]).sum(axis=2).astype(float)
        if len(tables) > 1:
            d = np.tile(d, (1, len(tables)))
        dist = np.einsum("mzn,mn->mz", post, d)
    return pe, p, ent, dist


@lru_cache(maxsize=16)
def _grid_coords(shape: tuple[int, ...]) -> np.ndarray:
    """Cell indices of a grid in C order, ``(n, d)`` int."""
    g = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1)
    g = g.reshape(-1, len(shape)).astype(np.int64)
    g.setflags(write=False)
    return g


def _window_index(table: OffsetTable, shape: tuple[int, ...], cells: np.ndarray) -> np.ndarray:
    """Flat indices ``(M, n)`` of the table entries of each candidate over a grid of ``shape``.

    Entry ``x`` of candidate ``c`` is the offset ``x - c``, at table index ``x - c + half``.
    """
    tshape = tuple(2 * h + 1 for h in table.half)
    strides = np.cumprod((1, *tshape[:0:-1]))[::-1]
    base = _grid_coords(shape) @ strides
    shift = (np.asarray(table.half) - cells) @ strides
    return base[None, :] + shift[:, None]


# ---------------------------------------------------------------------- rewards
def _floor_bound(n: int, z: int, floor: float, tolerance: float) -> float:
    """Largest change of an entropy score (bits) by the ``floor`` conventions, plus the tie
    tolerance (module docstring)."""
    b = n * floor * math.log2(1.0 / floor) + (z + 1) * floor * math.log2(max(n, 2)) + floor
    return b + tolerance


def _rescore(
    s: np.ndarray,
    bound: float,
    direct: Any,
) -> int:
    """Score again, with the ``floor`` conventions, the candidates within ``2 bound`` of the
    best (in place); returns how many. Exact ties (a symmetric belief) are the reference's ties
    too and are left alone."""
    if len(s) < 2:
        return 0
    close = s <= s.min() + 2.0 * bound
    cs = s[close]
    if cs.size > 1 and cs.max() - cs.min() > _EXACT_TIE:
        s[close] = direct(close)
        return int(close.sum())
    return 0


class _NoParams(Params):
    """A reward without settings."""


@register("reward", "expected-entropy", _NoParams, "expected posterior entropy (infotaxis)")
class ExpectedEntropyReward(Reward):
    """Infotaxis (Vergassola, Villermaux & Shraiman 2007): the expected entropy after the move,
    the found outcome included (nats on particles; on a lattice the expected *change* of the
    entropy, bits)."""

    params: _NoParams
    Params = _NoParams

    def particle(self, log_weights, outcome_probs, found, distances):  # type: ignore[no-untyped-def]
        return rewards.expected_entropy(log_weights, outcome_probs, found)

    def lattice(self, joint, tables, cells, found_radius, floor, tolerance):  # type: ignore[no-untyped-def]
        z = tables[0].n_classes
        sums = _sums(joint, tables, cells, found_radius)
        # H(outcome): the found outcome (column z + 1) and the readings (0 .. z - 1)
        h_out = -_xlogx(sums[:, _outcome_columns(z)]).sum(axis=1)
        # minus the information (and the uncertainty a find removes), bits
        s = sums[:, z] - h_out
        s -= _found_entropy(joint, tables, cells, found_radius, sums[:, z + 1])
        s /= _LN2
        if floor <= 0:
            return s, 0

        def direct(close: np.ndarray) -> np.ndarray:
            pe, p, ent, _ = lattice_posteriors(joint, tables, cells[close], found_radius, floor)
            flat = joint.reshape(-1)
            keep = flat > floor
            s0 = float(-np.sum(flat[keep] * np.log2(flat[keep])))
            return rewards.expected_entropy_from(pe, p, ent, floor) - s0

        return s, _rescore(s, _floor_bound(joint.size, z, floor, tolerance), direct)


@register("reward", "predictive-entropy", _NoParams, "entropy of the outcome (entrotaxis)")
class PredictiveEntropyReward(Reward):
    """Entrotaxis (Hutchinson, Oh & Chen 2018): minus the entropy of the predicted outcome
    (found, or the reading), nats on particles, bits on a lattice."""

    params: _NoParams
    Params = _NoParams

    def particle(self, log_weights, outcome_probs, found, distances):  # type: ignore[no-untyped-def]
        return -rewards.predictive_entropy(log_weights, outcome_probs, found)

    def lattice(self, joint, tables, cells, found_radius, floor, tolerance):  # type: ignore[no-untyped-def]
        z = tables[0].n_classes
        sums = _sums(joint, tables, cells, found_radius)
        h_out = -_xlogx(sums[:, _outcome_columns(z)]).sum(axis=1)
        return -h_out / _LN2, 0


@register("reward", "greedy", _NoParams, "probability of not finding the source there")
class GreedyReward(Reward):
    """Greedy: ``1 - p_found``, the candidate most likely to hold the source wins (without a
    found radius every particle candidate ties)."""

    params: _NoParams
    Params = _NoParams
    needs_outcomes = False
    needs_distances = True

    def particle(self, log_weights, outcome_probs, found, distances):  # type: ignore[no-untyped-def]
        if found is None:
            found = np.zeros(distances.shape, bool)
        return rewards.greedy(log_weights, found)

    def lattice(self, joint, tables, cells, found_radius, floor, tolerance):  # type: ignore[no-untyped-def]
        z = tables[0].n_classes
        return 1.0 - _sums(joint, tables, cells, found_radius)[:, z + 1], 0


@register("reward", "mean-distance", _NoParams, "expected posterior mean distance")
class MeanDistanceReward(Reward):
    """Mean distance (Loisy & Eloy 2022): the expected posterior mean distance to the source
    (on a lattice the Manhattan distance in cells, on particles the Euclidean in metres)."""

    params: _NoParams
    Params = _NoParams
    needs_distances = True

    def particle(self, log_weights, outcome_probs, found, distances):  # type: ignore[no-untyped-def]
        return rewards.mean_distance(log_weights, outcome_probs, found, distances)

    def lattice(self, joint, tables, cells, found_radius, floor, tolerance):  # type: ignore[no-untyped-def]
        t0 = tables[0]
        z = t0.n_classes
        # the expected posterior mean distance is the prior mean distance over the not-found
        # hypotheses; the reference conventions move it by < (Z + 1) floor max_distance
        s = _sums(joint, tables, cells, found_radius)[:, z + 2]
        if floor <= 0:
            return s, 0
        dmax = float(sum(2 * h for h in t0.half)) + 1.0
        bound = (z + 1) * floor * dmax + floor + tolerance

        def direct(close: np.ndarray) -> np.ndarray:
            pe, p, _, d = lattice_posteriors(joint, tables, cells[close], found_radius, floor, True)
            assert d is not None
            return rewards.mean_distance_from(pe, p, d, floor)

        return s, _rescore(s, bound, direct)


@register("reward", "space-aware", _NoParams, "space-aware infotaxis (Loisy & Eloy)")
class SpaceAwareReward(Reward):
    """Space-aware infotaxis (Loisy & Eloy 2022): the expected
    ``log2(D + 2^(S - 1) - 1/2)``, distance (in moves) and entropy (bits) together. Lattice
    beliefs only: on particles the distance has no move unit."""

    params: _NoParams
    Params = _NoParams
    particles = False

    def lattice(self, joint, tables, cells, found_radius, floor, tolerance):  # type: ignore[no-untyped-def]
        pe, p, ent, d = lattice_posteriors(joint, tables, cells, found_radius, floor, True)
        assert d is not None
        return rewards.space_aware_from(pe, p, ent, d, floor), 0


# ---------------------------------------------------------------------- planners
def _parts(p: Any) -> tuple[Candidates, Reward, Selection]:
    f = "searcher.planner"
    return (
        p.candidates.build("candidates", field=f"{f}.candidates"),
        p.reward.build("reward", field=f"{f}.reward"),
        p.selection.build("selection", field=f"{f}.selection"),
    )


class LatticePlannerParams(Params):
    """Parameters of :class:`LatticePlanner`.

    Attributes
    ----------
    candidates : dict
        ``{type: lattice-cells, moves: lattice | lattice-stay | neighbours}``.
    reward : dict
        ``{type: expected-entropy | predictive-entropy | space-aware | greedy |
        mean-distance}``.
    selection : dict
        ``{type: best, ties: first | random, tolerance: ...}`` (scores within the tolerance of
        the best tie; bits for the entropy rewards).
    floor : float
        The reference conventions of OTTO (module docstring); 0: exact.
    """

    candidates: Ref("candidates") = ComponentRef(type="lattice-cells")
    reward: Ref("reward") = ComponentRef(type="expected-entropy")
    selection: Ref("selection") = ComponentRef(type="best", tolerance=1e-10)
    floor: NonNegative = 1e-10


@register("planner", "lattice", LatticePlannerParams, "candidate cells x reward on a grid belief")
class LatticePlanner(Planner):
    """Candidate cells x a reward x a selection on a lattice belief (module docstring).

    The belief is a :class:`~odorloc.inference.grid_estimator.LatticeBelief` (its joint
    release-position belief and its tables); a cell within the belief's ``found_radius`` of a
    candidate's centre is found there. :attr:`Plan.extra` holds ``cells`` and ``rescored``.
    """

    params: LatticePlannerParams
    Params = LatticePlannerParams
    belief_estimator: ClassVar[Mapping[str, Any]] = {"type": "grid-filter"}

    def __init__(self, params: LatticePlannerParams | None = None) -> None:
        super().__init__(params or LatticePlannerParams())
        self.candidates, self.reward, self.selection = _parts(self.params)
        if not self.reward.lattices:
            raise ConfigError("searcher.planner.reward", "has no form for grid beliefs")

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        super().reset(ctx, model)
        self.candidates.reset(ctx)

    def plan(self, belief: LatticeBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        """Score the candidate cells of ``pose`` on ``belief``."""
        if belief.joint is None or not belief.tables:
            raise ConfigError("belief", "the lattice planner needs a belief with its tables")
        cs = self.candidates.generate(belief, pose)
        tables = belief.tables
        t0 = tables[0]
        b = belief.joint
        shape = b.shape[1:]
        if len(tables) != b.shape[0]:
            raise ConfigError("tables", f"need {b.shape[0]} table(s), got {len(tables)}")
        if any(h < n - 1 for h, n in zip(t0.half, shape, strict=True)):
            raise ConfigError("tables", f"offsets {t0.half} do not cover a grid of {shape}")
        assert cs.cells is not None
        cells = np.asarray(cs.cells, dtype=np.int64).reshape(-1, t0.dim)
        ok = ((cells >= 0) & (cells < shape)).all(axis=1) & cs.feasible
        scores = np.full(len(cells), np.inf)
        rescored = 0
        sel = cells[ok]
        if len(sel):
            s, rescored = self.reward.lattice(
                b,
                tables,
                sel,
                float(belief.found_radius),
                self.params.floor,
                self.selection.tolerance,
            )
            scores[ok] = s
        index = self.selection.choose(scores, ok, rng)
        work = int(len(sel) * b.size * (t0.n_classes + 3))
        return Plan(index, cs.targets, scores, ok, work, {"cells": cells, "rescored": rescored})


class ParticlePlannerParams(Params):
    """Parameters of :class:`ParticlePlanner`.

    Attributes
    ----------
    candidates : dict
        ``{type: directions | moves, ...}``.
    reward : dict
        ``{type: expected-entropy | predictive-entropy | greedy | mean-distance}``.
    selection : dict
        ``{type: best, ties: first | random, tolerance: ...}`` (nats for the entropy rewards).
    """

    candidates: Ref("candidates") = ComponentRef(type="directions")
    reward: Ref("reward") = ComponentRef(type="expected-entropy")
    selection: Ref("selection") = ComponentRef(type="best", tolerance=1e-12)


@register("planner", "particle", ParticlePlannerParams, "candidates x reward over particles")
class ParticlePlanner(Planner):
    """Candidates x a reward x a selection over weighted particles (module docstring).

    The model's outcome probabilities come from the planner's model bound to the pose's
    conditions (:meth:`~odorloc.models.base.MeasurementModel.bind`).
    """

    params: ParticlePlannerParams
    Params = ParticlePlannerParams
    belief_estimator: ClassVar[Mapping[str, Any]] = {
        "type": "particle-filter",
        "n_particles": 200,
        "reading": {"type": "outcome-class"},
        "init": {"type": "uniform"},
        "resampler": {"type": "systematic", "jitter_std": 0.2},
        "stopping": {"type": "never"},
        "found_radius": "half-step",
    }
    belief_model: ClassVar[Mapping[str, Any] | None] = {"type": "vergassola"}

    def __init__(self, params: ParticlePlannerParams | None = None) -> None:
        super().__init__(params or ParticlePlannerParams())
        self.candidates, self.reward, self.selection = _parts(self.params)
        if not self.reward.particles:
            raise ConfigError("searcher.planner.reward", "has no form for particle beliefs")

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        if model is None:
            raise ConfigError("model", "the particle planner needs a measurement model")
        super().reset(ctx, model)
        self.candidates.reset(ctx)

    def plan(self, belief: ParticleBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        """Score the candidates of ``pose`` over the particles of ``belief``."""
        cs = self.candidates.generate(belief, pose)
        t = np.atleast_2d(np.asarray(cs.targets, float))
        ok = np.asarray(cs.feasible, bool).copy()
        scores = np.full(len(t), np.inf)
        work = 0
        if ok.any():
            x = belief.positions
            q = None
            if self.reward.needs_outcomes:
                q = self.model.bind(**pose.conditions).outcome_probabilities(t[ok], x)
                work = int(q.size)
            dist = None
            if belief.found_radius > 0 or self.reward.needs_distances:
                dist = np.linalg.norm(t[ok][:, None, :] - x[None], axis=2)
            found = None if belief.found_radius <= 0 else dist <= belief.found_radius
            scores[ok] = self.reward.particle(belief.log_weights, q, found, dist)
        index = self.selection.choose(scores, ok, rng)
        return Plan(index, t, scores, ok, work)
