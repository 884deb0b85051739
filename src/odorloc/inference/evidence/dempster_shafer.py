"""Dempster-Shafer evidence grid of odor-source occupancy (D-S multi-source paper, section 2).

Each cell ``C_i`` has the frame of discernment ``{S, notS}`` (occupied / not occupied by a source)
and three masses ``m(S)``, ``m(notS)``, ``m(U)`` with ``U = {S, notS}`` the unknown (eq. 3). Every
reading is a piece of evidence spread over the cells through the air-mass path map ``pi``
(:mod:`odorloc.inference.odor_path`): a detection supports ``S`` (eq. 4-a), a non-detection
supports ``notS`` (eq. 4-b), both in proportion to ``pi_i``. Evidence is fused cell by cell with
Dempster's rule (eqs. 1-2), recursively, as the rule is associative.

Choices where the paper is silent:

* Total conflict (``K = 1``, e.g. a certain ``S`` meeting a certain ``notS``) leaves Dempster's
  rule undefined. ``on_total_conflict="keep"`` (default) keeps the cell's previous masses,
  ``"reset"`` returns the cell to ``m(U) = 1``; either way :attr:`DSGrid.n_total_conflict` counts
  the events. With the paper's parameters it cannot happen: a single reading carries at most
  ``max(mu_D zeta, mu_notD zeta rho) = 0.54`` on one focal set, so ``K <= 0.54``.
* The entropy term of eq. (5) is ``-[m(S) log2 m(S) + m(notS) log2 m(notS)]`` of the masses
  themselves (``0 log 0 = 0``), read literally; ``entropy="pignistic"`` uses instead the binary
  entropy of the pignistic probability ``BetP(S) = m(S) + m(U) / 2``.
* ``pi`` enters the basic belief assignments as the cell value of the (window-normalised) map, so
  evidence is strongest near the robot, where the map is concentrated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import AfterValidator
from scipy import ndimage

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params
from odorloc.geometry.grid import CellGrid
from odorloc.inference.belief import GridBelief
from odorloc.inference.odor_path.estimator import PathPatch

FloatArray = NDArray[np.float64]

#: Cell states of :meth:`DSGrid.state_map`.
UNKNOWN, FREE, OCCUPIED = 0, 1, 2

_CONFLICT_TOL = 1e-12
_SUM_TOL = 1e-9  # rounding left by many fusions is far below this


def _probability(v: float) -> float:
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ValueError("must be a number in [0, 1]")
    return v


Probability = Annotated[float, AfterValidator(_probability)]


class DSParams(Params):
    """Parameters of :class:`DSGrid` (D-S paper, section 2.2 and eq. 5).

    Attributes
    ----------
    mu_d : float
        ``mu_D``: probability of a detection given detectable odor at the robot (0.9).
    mu_nd : float
        ``mu_notD``: probability of a non-detection given no detectable odor (1.0).
    zeta : float
        Reliability of the air-mass transport model (0.6).
    rho : float
        Reliability loss of non-detections from plume intermittency (0.5).
    q : float
        Weight of ``m(U)`` in the cell uncertainty (eq. 5; 3.0).
    on_total_conflict : {"keep", "reset"}
        What a cell does when ``K = 1`` (see the module notes).
    entropy : {"masses", "pignistic"}
        Which entropy eq. (5) uses (see the module notes).
    """

    mu_d: Probability = 0.9
    mu_nd: Probability = 1.0
    zeta: Probability = 0.6
    rho: Probability = 0.5
    q: NonNegative = 3.0
    on_total_conflict: Literal["keep", "reset"] = "keep"
    entropy: Literal["masses", "pignistic"] = "masses"


# ------------------------------------------------------------------------------ pure functions
def detection_bba(pi: ArrayLike, params: DSParams) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Masses ``(m(S), m(notS), m(U))`` of a detection, cells with path value ``pi`` (eq. 4-a)."""
    p = _check_pi(pi)
    s = params.mu_d * params.zeta * p
    return s, np.zeros_like(p), 1.0 - s


def non_detection_bba(pi: ArrayLike, params: DSParams) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Masses ``(m(S), m(notS), m(U))`` of a non-detection (eq. 4-b)."""
    p = _check_pi(pi)
    n = params.mu_nd * params.zeta * params.rho * p
    return np.zeros_like(p), n, 1.0 - n


def _check_pi(pi: ArrayLike) -> FloatArray:
    p = np.asarray(pi, float)
    if not np.all(np.isfinite(p)) or np.any(p < 0.0) or np.any(p > 1.0 + 1e-12):
        raise ConfigError("pi", "path-map values must lie in [0, 1]")
    return np.minimum(p, 1.0)


def dempster_combine(
    m1: tuple[ArrayLike, ArrayLike, ArrayLike],
    m2: tuple[ArrayLike, ArrayLike, ArrayLike],
    on_total_conflict: Literal["keep", "reset"] = "keep",
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Dempster's rule on the frame ``{S, notS}``, element-wise (eqs. 1-2, D-S paper).

    Parameters
    ----------
    m1, m2 : 3-tuples of array_like
        ``(m(S), m(notS), m(U))`` of the two pieces of evidence, broadcastable shapes.
    on_total_conflict : {"keep", "reset"}
        Result where ``K = 1``: ``m1`` unchanged, or ``m(U) = 1``.

    Returns
    -------
    ms, mn, mu : ndarray
        Combined masses (they sum to one).
    K : ndarray
        Conflict ``m1(S) m2(notS) + m1(notS) m2(S)`` (eq. 2).
    total : bool ndarray
        Where the conflict was total and the rule undefined.

    Raises
    ------
    ConfigError
        If a mass is not in [0, 1] or a mass function does not sum to one (eq. 3; the rule's
        normalisation would otherwise hide the error), or if ``on_total_conflict`` is unknown.
    """
    if on_total_conflict not in ("keep", "reset"):
        raise ConfigError(
            "on_total_conflict", f"must be 'keep' or 'reset', got {on_total_conflict!r}"
        )
    return _combine(_check_masses(m1, "m1"), _check_masses(m2, "m2"), on_total_conflict)


def _check_masses(m: tuple[ArrayLike, ArrayLike, ArrayLike], name: str) -> tuple[FloatArray, ...]:
    if len(m) != 3:
        raise ConfigError(name, "needs the three masses (m(S), m(notS), m(U))")
    s, n, u = (np.asarray(v, float) for v in m)
    if not all(np.all(np.isfinite(v) & (v >= 0.0) & (v <= 1.0)) for v in (s, n, u)):
        raise ConfigError(name, "masses must be numbers in [0, 1]")
    if not np.all(np.abs(s + n + u - 1.0) <= _SUM_TOL):
        raise ConfigError(name, "m(S) + m(notS) + m(U) must equal 1 (eq. 3)")
    return s, n, u


def _combine(
    m1: tuple[ArrayLike, ...],
    m2: tuple[ArrayLike, ...],
    on_total_conflict: Literal["keep", "reset"],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """:func:`dempster_combine` without the checks (the grid's masses are valid by construction)."""
    s1, n1, u1 = (np.asarray(v, float) for v in m1)
    s2, n2, u2 = (np.asarray(v, float) for v in m2)
    conflict = s1 * n2 + n1 * s2  # eq. (2): S and notS are the only disjoint focal pair
    ns = s1 * s2 + s1 * u2 + u1 * s2  # S = S^S = S^U = U^S
    nn = n1 * n2 + n1 * u2 + u1 * n2
    nu = u1 * u2
    # 1 - K equals the sum of the non-conflicting products; dividing by that sum keeps the
    # masses summing to one to rounding.
    norm = ns + nn + nu
    total = norm <= _CONFLICT_TOL
    safe = np.where(total, 1.0, norm)
    ms, mn, mu = ns / safe, nn / safe, nu / safe  # eq. (1)
    if np.any(total):
        if on_total_conflict == "keep":
            ms = np.where(total, s1, ms)
            mn = np.where(total, n1, mn)
            mu = np.where(total, u1, mu)
        else:
            ms = np.where(total, 0.0, ms)
            mn = np.where(total, 0.0, mn)
            mu = np.where(total, 1.0, mu)
    return ms, mn, mu, conflict, total


def cell_uncertainty(
    ms: ArrayLike,
    mn: ArrayLike,
    mu: ArrayLike,
    q: float = 3.0,
    entropy: Literal["masses", "pignistic"] = "masses",
) -> FloatArray:
    """Cell uncertainty ``X_i`` (eq. 5, D-S paper).

    ``X = -[m(S) log2 m(S) + m(notS) log2 m(notS)] + q m(U)`` with ``0 log 0 = 0``; with
    ``entropy="pignistic"`` the first term is the binary entropy of ``m(S) + m(U)/2``.

    Parameters
    ----------
    ms, mn, mu : array_like
        ``m(S)``, ``m(notS)``, ``m(U)`` per cell, broadcastable shapes.
    q : float
        Weight of ``m(U)``, finite and >= 0 (3.0 in the paper).
    entropy : {"masses", "pignistic"}
        Which entropy the first term is (see the module notes).

    Returns
    -------
    ndarray
        ``X`` per cell (bits), the broadcast shape of the masses.
    """
    if not (math.isfinite(q) and q >= 0.0):
        raise ConfigError("q", f"must be a finite number >= 0, got {q!r}")
    if entropy not in ("masses", "pignistic"):
        raise ConfigError("entropy", f"must be 'masses' or 'pignistic', got {entropy!r}")
    ms = np.asarray(ms, float)
    mn = np.asarray(mn, float)
    mu = np.asarray(mu, float)
    if entropy == "masses":
        h = -(_xlog2x(ms) + _xlog2x(mn))
    else:
        p = np.clip(ms + 0.5 * mu, 0.0, 1.0)
        h = -(_xlog2x(p) + _xlog2x(1.0 - p))
    return h + q * mu


def _xlog2x(x: FloatArray) -> FloatArray:
    pos = x > 0
    return np.where(pos, x * np.log2(np.where(pos, x, 1.0)), 0.0)


# ----------------------------------------------------------------------------------- the grid
@dataclass(frozen=True, eq=False)
class EvidenceSource:
    """A connected region of cells with high ``m(S)``.

    Attributes
    ----------
    position : (2,) ndarray, metres
        ``m(S)``-weighted centroid of the region's cell centres.
    total_mass : float
        Sum of ``m(S)`` over the region.
    peak_mass : float
        Largest ``m(S)`` in the region.
    n_cells : int
    """

    position: FloatArray
    total_mass: float
    peak_mass: float
    n_cells: int


class DSGrid:
    """Grid of Dempster-Shafer masses over source occupancy (D-S paper, section 2).

    Parameters
    ----------
    params : DSParams
    grid : CellGrid
        Cell geometry; it must be the grid of the path maps fed to :meth:`update`.

    Attributes
    ----------
    m_s, m_n, m_u : (nx, ny) ndarray
        ``m(S)``, ``m(notS)``, ``m(U)`` per cell.
    n_updates : int
        Pieces of evidence fused so far.
    n_total_conflict : int
        Cell updates met with total conflict (``K = 1``).
    max_conflict : float
        Largest ``K`` seen.
    """

    def __init__(self, params: DSParams, grid: CellGrid) -> None:
        self.params = params
        self.grid = grid
        self.reset()

    @classmethod
    def from_extent(
        cls,
        params: DSParams,
        lower: Sequence[float],
        upper: Sequence[float],
        cell_size: float,
    ) -> DSGrid:
        """A grid over ``[lower, upper]`` with cells of ``cell_size`` metres (eq. 7, odor-path)."""
        return cls(params, CellGrid.from_extent(lower, upper, cell_size))

    def reset(self) -> None:
        """Every cell back to total ignorance, ``m(U) = 1``."""
        shape = self.grid.shape
        self.m_s = np.zeros(shape)
        self.m_n = np.zeros(shape)
        self.m_u = np.ones(shape)
        self.n_updates = 0
        self.n_total_conflict = 0
        self.max_conflict = 0.0

    # ---------------------------------------------------------------------------- update
    def update(self, pi: PathPatch | ArrayLike, detected: bool) -> None:
        """Fuse one reading into the grid (eqs. 1-2 and 4).

        Parameters
        ----------
        pi : PathPatch or (nx, ny) array_like
            Air-mass path map of the reading, values in [0, 1]; a :class:`PathPatch` updates
            only its bounding box (cells with ``pi = 0`` receive vacuous evidence anyway).
        detected : bool
            Detection (eq. 4-a) or non-detection (eq. 4-b).
        """
        if isinstance(pi, PathPatch):
            if not pi.grid.same_as(self.grid):
                raise ConfigError("pi", "path map grid differs from the evidence grid")
            if pi.values.size == 0:
                self.n_updates += 1
                return
            sl = pi.slices
            values = pi.values
        else:
            values = np.asarray(pi, float)
            if values.shape != self.grid.shape:
                raise ConfigError("pi", f"shape {values.shape} != grid {self.grid.shape}")
            sl = (slice(None), slice(None))
        bba = (
            detection_bba(values, self.params)
            if detected
            else non_detection_bba(values, self.params)
        )
        ms, mn, mu, k, total = _combine(
            (self.m_s[sl], self.m_n[sl], self.m_u[sl]), bba, self.params.on_total_conflict
        )
        self.m_s[sl] = ms
        self.m_n[sl] = mn
        self.m_u[sl] = mu
        self.n_updates += 1
        self.n_total_conflict += int(np.count_nonzero(total))
        if k.size:
            self.max_conflict = max(self.max_conflict, float(k.max()))

    # ---------------------------------------------------------------------------- outputs
    def uncertainty(self) -> FloatArray:
        """``(nx, ny)`` cell uncertainty ``X_i`` (eq. 5)."""
        return cell_uncertainty(self.m_s, self.m_n, self.m_u, self.params.q, self.params.entropy)

    def total_uncertainty(self, region: Sequence[Sequence[float]] | None = None) -> float:
        """``sum_i X_i`` over the grid or the cells whose centre is in ``region = (lower, upper)``.

        The paper reports it over the search region (section 4).
        """
        x = self.uncertainty()
        return float(x[self.grid.region_mask(region)].sum())

    def state_map(self, threshold: float = 0.5) -> NDArray[np.int8]:
        """Three-state map like the paper's Figs. 1-2, ``(nx, ny)`` int8.

        A cell is :data:`OCCUPIED` when ``m(S) >= threshold`` and ``m(S) > m(notS)``,
        :data:`FREE` when ``m(notS) >= threshold`` and ``m(notS) > m(S)``, else :data:`UNKNOWN`.
        """
        if not (math.isfinite(threshold) and 0.0 < threshold <= 1.0):
            raise ConfigError("threshold", "must lie in (0, 1]")
        out = np.full(self.grid.shape, UNKNOWN, np.int8)
        out[(self.m_s >= threshold) & (self.m_s > self.m_n)] = OCCUPIED
        out[(self.m_n >= threshold) & (self.m_n > self.m_s)] = FREE
        return out

    def sources(
        self,
        min_mass: float = 0.5,
        min_cells: int = 1,
        region: Sequence[Sequence[float]] | None = None,
        connectivity: int = 8,
    ) -> list[EvidenceSource]:
        """Connected regions of cells with ``m(S) >= min_mass``, heaviest first.

        Parameters
        ----------
        min_mass : float
            Threshold on ``m(S)``, in (0, 1].
        min_cells : int
            Smaller regions are dropped.
        region : (lower, upper), optional
            Only cells whose centre is inside are considered.
        connectivity : {4, 8}
            Neighbourhood of the labelling.

        Returns
        -------
        list of EvidenceSource
            Sorted by ``total_mass``, descending.
        """
        if not (math.isfinite(min_mass) and 0.0 < min_mass <= 1.0):
            raise ConfigError("min_mass", "must lie in (0, 1]")
        if min_cells < 1:
            raise ConfigError("min_cells", "must be >= 1")
        if connectivity not in (4, 8):
            raise ConfigError("connectivity", "must be 4 or 8")
        mask = (self.m_s >= min_mass) & self.grid.region_mask(region)
        structure = np.ones((3, 3), bool) if connectivity == 8 else None
        labels, n = ndimage.label(mask, structure=structure)
        if n == 0:
            return []
        idx = np.arange(1, n + 1)
        w = np.where(mask, self.m_s, 0.0)
        total = ndimage.sum_labels(w, labels, idx)
        count = ndimage.sum_labels(mask, labels, idx)
        peak = ndimage.maximum(w, labels, idx)
        gx, gy = np.meshgrid(self.grid.x_centers(), self.grid.y_centers(), indexing="ij")
        cx = ndimage.sum_labels(w * gx, labels, idx) / total
        cy = ndimage.sum_labels(w * gy, labels, idx) / total
        out = [
            EvidenceSource(
                position=np.array([cx[i], cy[i]]),
                total_mass=float(total[i]),
                peak_mass=float(peak[i]),
                n_cells=int(count[i]),
            )
            for i in range(n)
            if count[i] >= min_cells
        ]
        out.sort(key=lambda s: -s.total_mass)
        return out

    def belief(self) -> GridBelief:
        """The map as a :class:`GridBelief`: ``m(S)`` normalised (uniform if all zero)."""
        total = self.m_s.sum()
        prob = self.m_s / total if total > 0 else np.full(self.grid.shape, 1.0 / self.grid.n_cells)
        return GridBelief(
            grid=self.grid,
            prob=prob,
            extra={"m_s": self.m_s.copy(), "m_n": self.m_n.copy(), "m_u": self.m_u.copy()},
        )

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording: the three masses and the grid's extent (``lower``, ``upper``)."""
        return {
            "m_s": self.m_s.copy(),
            "m_n": self.m_n.copy(),
            "m_u": self.m_u.copy(),
            "lower": np.asarray(self.grid.lower, float),
            "upper": np.asarray(self.grid.upper, float),
        }
