"""Infotaxis and its successors: candidates x rewards x selection on grid or particle beliefs.

A move to a candidate ends the search if the source is there (probability ``p_found``) and
otherwise yields a reading ``z``. The policies score every candidate and take the best
(:mod:`odorloc.planning.rewards` for the formulas):

- ``infotaxis`` (Vergassola, Villermaux & Shraiman 2007): minimise the expected entropy after
  the move, i.e. maximise the information ``I = H(outcome) - H(outcome | source)`` it brings;
- ``space-aware`` infotaxis (Loisy & Eloy 2022): minimise
  ``sum_z P(z) g(D_z + 2^(S_z - 1) - 1/2)``;
- ``entrotaxis`` (Hutchinson, Oh & Chen 2018): maximise the entropy of the predicted outcome;
- ``greedy``: go where the source most probably is;
- ``mean-distance`` (Loisy & Eloy 2022): minimise the expected posterior mean distance.

Grid beliefs (:class:`GridPolicyPlanner`)
-----------------------------------------
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
only the correlations. Ties go to the lowest candidate index among scores within ``tie_tol`` of
the best (the reference's rule), or to a uniformly drawn one (``ties="random"``).

Particle beliefs (:class:`ParticleInfotaxisPlanner`)
----------------------------------------------------
The same rewards over weighted particles: candidates (any targets, e.g. 26 directions times a
step) and the outcome model (any bound measurement model) are the caller's; particles within
``found_radius`` of a candidate count as found there.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal, Protocol

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit
from odorloc.geometry.vectors import lattice_moves
from odorloc.inference.belief import ParticleBelief
from odorloc.models.lattice import OffsetTable
from odorloc.planning import rewards
from odorloc.planning.selection import select

__all__ = [
    "POLICIES",
    "GridPlan",
    "GridPolicyPlanner",
    "LatticeOutcomes",
    "ParticleInfotaxisPlanner",
    "ParticlePlan",
    "correlate",
    "lattice_outcomes",
    "lattice_posteriors",
    "neighbour_cells",
]

Policy = Literal["infotaxis", "space-aware", "entrotaxis", "greedy", "mean-distance"]
POLICIES: tuple[str, ...] = ("infotaxis", "space-aware", "entrotaxis", "greedy", "mean-distance")
_LN2 = math.log(2.0)
_EXACT_TIE = 1e-12  # bits: scores this close are equal up to rounding


class OutcomeModel(Protocol):
    """A measurement model with its conditions bound (:class:`~odorloc.models.base.BoundModel`)."""

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray
    ) -> np.ndarray: ...


# ---------------------------------------------------------------------- lattice candidates
def neighbour_cells(
    cell: Sequence[int], moves: Literal["lattice", "lattice-stay", "neighbours"] = "lattice"
) -> np.ndarray:
    """Candidate cells around ``cell``, ``(M, d)`` int.

    ``lattice``: the ``2d`` axis moves in the order ``-axis0, +axis0, -axis1, ...``
    (:func:`~odorloc.geometry.vectors.lattice_moves`); ``lattice-stay`` appends staying;
    ``neighbours``: the ``3^d - 1`` cells sharing a face, edge or corner (e.g. the 26 directions
    of the multi-UAV paper), in lexicographic order of the offsets.
    """
    c = np.asarray(cell, dtype=np.int64).reshape(-1)
    return c[None, :] + _move_offsets(c.size, moves)


@lru_cache(maxsize=16)
def _move_offsets(dim: int, moves: str) -> np.ndarray:
    if moves in ("lattice", "lattice-stay"):
        off = lattice_moves(dim, moves == "lattice-stay").astype(np.int64)
    elif moves == "neighbours":
        grid = np.stack(np.meshgrid(*[[-1, 0, 1]] * dim, indexing="ij"), -1).reshape(-1, dim)
        off = grid[np.any(grid != 0, axis=1)].astype(np.int64)
    else:
        raise ConfigError("moves", f"unknown move set {moves!r}")
    off.setflags(write=False)
    return off


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


# ---------------------------------------------------------------------- grid planner
@dataclass(frozen=True)
class GridPlan:
    """Outcome of :meth:`GridPolicyPlanner.plan`.

    Attributes
    ----------
    index : int or None
        Chosen candidate (``None``: none feasible).
    cells : (M, d) int ndarray
    scores : (M,) ndarray
        Minimised scores (``inf`` where infeasible); infotaxis: the expected entropy change,
        bits; entrotaxis: minus the outcome entropy, bits; greedy: ``1 - p_found``;
        space-aware, mean distance: see :mod:`odorloc.planning.rewards`.
    feasible : (M,) bool ndarray
    rescored : int
        Candidates scored again with the reference conventions.
    """

    index: int | None
    cells: np.ndarray
    scores: np.ndarray
    feasible: np.ndarray
    rescored: int = 0

    @property
    def cell(self) -> tuple[int, ...] | None:
        """Chosen cell, or ``None``."""
        return None if self.index is None else tuple(int(v) for v in self.cells[self.index])


class GridPolicyPlanner:
    """Score lattice candidates on a grid belief with one of :data:`POLICIES`.

    Parameters
    ----------
    policy : str
        One of :data:`POLICIES`.
    floor : float
        The reference conventions (module docstring); 0 for the exact mathematics.
    tie_tol : float
        Scores within this of the best tie (bits for the entropy policies).
    ties : {"first", "random"}
    """

    def __init__(
        self,
        policy: Policy = "infotaxis",
        *,
        floor: float = 1e-10,
        tie_tol: float = 1e-10,
        ties: Literal["first", "random"] = "first",
    ) -> None:
        if policy not in POLICIES:
            raise ConfigError("policy", f"unknown policy {policy!r} (known: {', '.join(POLICIES)})")
        if not (floor >= 0 and tie_tol >= 0):
            raise ConfigError("floor", "floor and tie_tol must be >= 0")
        self.policy = policy
        self.floor = float(floor)
        self.tie_tol = float(tie_tol)
        self.ties = ties

    def _bound(self, n: int, z: int) -> float:
        """Largest change of a score by the reference conventions, plus the tie tolerance."""
        fl = self.floor
        b = n * fl * math.log2(1.0 / fl) + (z + 1) * fl * math.log2(max(n, 2)) + fl
        return b + self.tie_tol

    # ------------------------------------------------------------------ direct scores
    def _direct(
        self,
        joint: np.ndarray,
        tables: Sequence[OffsetTable],
        cells: np.ndarray,
        found_radius: float,
    ) -> np.ndarray:
        """Scores of ``cells`` from explicit posteriors (the reference conventions)."""
        fl = self.floor
        need_d = self.policy in ("space-aware", "mean-distance")
        pe, p, s, d = lattice_posteriors(joint, tables, cells, found_radius, fl, need_d)
        if self.policy == "infotaxis":
            flat = joint.reshape(-1)
            keep = flat > fl
            s0 = float(-np.sum(flat[keep] * np.log2(flat[keep])))
            return rewards.expected_entropy_from(pe, p, s, fl) - s0
        assert d is not None
        if self.policy == "space-aware":
            return rewards.space_aware_from(pe, p, s, d, fl)
        return rewards.mean_distance_from(pe, p, d, fl)

    def plan(
        self,
        joint: np.ndarray,
        tables: Sequence[OffsetTable],
        cells: np.ndarray,
        *,
        feasible: np.ndarray | None = None,
        found_radius: float | None = None,
        rng: np.random.Generator | None = None,
    ) -> GridPlan:
        """Choose among candidate ``cells`` on the belief ``joint`` ``(K, n1, ..., nd)``.

        Parameters
        ----------
        joint : (K, n1, ..., nd) ndarray
            Belief (``K`` release hypotheses; ``(n1, ..., nd)`` is accepted for ``K = 1``).
        tables : sequence of K OffsetTable
        cells : (M, d) int ndarray
        feasible : (M,) bool ndarray, optional
            Reachable candidates (default all; candidates outside the grid are infeasible).
        found_radius : float, metres, optional
            Default: half a cell (the source is found in the cell moved onto).
        rng : numpy.random.Generator, optional
            Needed with ``ties="random"``.
        """
        b = joint if isinstance(joint, np.ndarray) else np.asarray(joint, float)
        t0 = tables[0]
        if b.ndim == t0.dim:
            b = b[None]
        shape = b.shape[1:]
        if len(tables) != b.shape[0]:
            raise ConfigError("tables", f"need {b.shape[0]} table(s), got {len(tables)}")
        if any(h < n - 1 for h, n in zip(t0.half, shape, strict=True)):
            raise ConfigError("tables", f"offsets {t0.half} do not cover a grid of {shape}")
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, t0.dim)
        ok = ((cells >= 0) & (cells < shape)).all(axis=1)
        if feasible is not None:
            ok &= np.asarray(feasible, bool)
        radius = 0.5 * float(t0.cell.min()) if found_radius is None else float(found_radius)
        scores = np.full(len(cells), np.inf)
        rescored = 0
        sel = cells[ok]
        if len(sel):
            if self.policy == "space-aware":
                s = self._direct(b, tables, sel, radius)
            else:
                sums = _sums(b, tables, sel, radius)
                z = t0.n_classes
                if self.policy == "greedy":
                    s = 1.0 - sums[:, z + 1]
                elif self.policy == "mean-distance":
                    # the expected posterior mean distance is the prior mean distance over the
                    # not-found hypotheses; the reference conventions move it by
                    # < (Z + 1) floor max_distance
                    s = sums[:, z + 2]
                    if self.floor > 0 and len(s) > 1:
                        dmax = float(sum(2 * h for h in t0.half)) + 1.0
                        bound = (z + 1) * self.floor * dmax + self.floor + self.tie_tol
                        close = s <= s.min() + 2.0 * bound
                        cs = s[close]
                        if cs.size > 1 and cs.max() - cs.min() > _EXACT_TIE:
                            s[close] = self._direct(b, tables, sel[close], radius)
                            rescored = int(close.sum())
                else:
                    # H(outcome): the found outcome (column z + 1) and the readings (0 .. z - 1)
                    h_out = -_xlogx(sums[:, _outcome_columns(z)]).sum(axis=1)
                    if self.policy == "entrotaxis":
                        s = -h_out / _LN2
                    else:
                        # minus the information (and the uncertainty a find removes), bits
                        s = sums[:, z] - h_out
                        s -= _found_entropy(b, tables, sel, radius, sums[:, z + 1])
                        s /= _LN2
                        if self.floor > 0 and len(s) > 1:
                            close = s <= s.min() + 2.0 * self._bound(b.size, z)
                            cs = s[close]
                            # Exact ties (a symmetric belief) are the reference's ties too.
                            if cs.size > 1 and cs.max() - cs.min() > _EXACT_TIE:
                                s[close] = self._direct(b, tables, sel[close], radius)
                                rescored = int(close.sum())
            scores[ok] = s
        # infeasible candidates already score inf, which select() leaves out
        index = select(scores, mode="min", ties=self.ties, atol=self.tie_tol, rng=rng)
        return GridPlan(index, cells, scores, ok, rescored)


# ---------------------------------------------------------------------- particle planner
@dataclass(frozen=True)
class ParticlePlan:
    """Outcome of :meth:`ParticleInfotaxisPlanner.plan`.

    Attributes
    ----------
    index : int or None
    targets : (M, d) ndarray, metres
    scores : (M,) ndarray, nats (``inf`` where infeasible)
    feasible : (M,) bool ndarray
    """

    index: int | None
    targets: np.ndarray
    scores: np.ndarray
    feasible: np.ndarray

    @property
    def target(self) -> np.ndarray | None:
        """The chosen target, ``(d,)`` metres."""
        return None if self.index is None else self.targets[self.index]


class ParticleInfotaxisPlanner:
    """Infotaxis (or entrotaxis) over weighted particles; candidates and model are pluggable.

    Parameters
    ----------
    policy : {"infotaxis", "entrotaxis"}
    ties : {"first", "random"}
    tie_tol : float, nats
    """

    def __init__(
        self,
        policy: Literal["infotaxis", "entrotaxis"] = "infotaxis",
        *,
        ties: Literal["first", "random"] = "first",
        tie_tol: float = 1e-12,
    ) -> None:
        if policy not in ("infotaxis", "entrotaxis"):
            raise ConfigError("policy", f"particle beliefs support infotaxis, entrotaxis: {policy}")
        self.policy = policy
        self.ties = ties
        self.tie_tol = float(tie_tol)

    def plan(
        self,
        belief: ParticleBelief,
        targets: np.ndarray,
        model: OutcomeModel,
        *,
        feasible: np.ndarray | None = None,
        found_radius: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> ParticlePlan:
        """Score ``targets`` ``(M, d)`` with the outcome law of ``model`` over the particles."""
        t = np.atleast_2d(np.asarray(targets, float))
        ok = np.ones(len(t), bool) if feasible is None else np.asarray(feasible, bool).copy()
        scores = np.full(len(t), np.inf)
        if ok.any():
            x = belief.positions
            q = model.outcome_probabilities(t[ok], x)
            found = None
            if found_radius > 0:
                found = np.linalg.norm(t[ok][:, None, :] - x[None], axis=2) <= found_radius
            if self.policy == "infotaxis":
                scores[ok] = rewards.expected_entropy(belief.log_weights, q, found)
            else:
                scores[ok] = -rewards.predictive_entropy(belief.log_weights, q, found)
        index = select(scores, mode="min", feasible=ok, ties=self.ties, atol=self.tie_tol, rng=rng)
        return ParticlePlan(index, t, scores, ok)
