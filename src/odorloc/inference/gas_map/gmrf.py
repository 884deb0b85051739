"""Gaussian Markov random field gas map with obstacles and time-variant readings (registry name
``gmrf``; Monroy, Blanco and Gonzalez-Jimenez, Autonomous Robots 2016).

The map is the vector ``m`` of the cells' concentrations. Its posterior is Gaussian with the
information (precision) matrix and vector of three kinds of factors:

* *prior* factors between every two neighbouring cells (sharing a face: 4 neighbours in 2-D, 6
  in 3-D), ``m_i - m_j ~ N(0, 1/lambda_p)``, which correlate the cells -- but only cells
  *connected* in the environment: no factor joins two cells when either is blocked or the
  segment between their centres crosses an obstacle, so that mass does not leak through a wall
  (the paper's obstacle-aware prior);
* *observation* factors, one per reading ``z_i`` in cell ``k(i)``, ``m_k(i) - z_i ~ N(0,
  1/lambda_i)``, whose information decays with the reading's age: ``lambda_i = lambda_z -
  lambda_loss (t* - t_i)`` at the time ``t*`` of the latest reading, and a reading whose
  information has run out (``lambda_i <= 0``) is dropped (the paper's time-variant observations,
  information lost at a constant rate);
* a weak *anchor* ``m_k ~ N(m_0, 1/lambda_0)`` on every cell (ours): it keeps the system
  regular where a region has no reading (behind a wall, or before the first reading) and sets
  what such cells report. ``m_0`` is the mean of the readings used (as Kernel DM+V's prior
  ``r_0``), so readings that all agree give that value everywhere, or ``prior_mean``.

With ``H`` the sum of the factors' information and ``g`` that of their information-weighted
values, the mean is ``H^-1 g`` (one sparse solve, SciPy's SuperLU) and the variance of cell ``k``
is ``(H^-1)_kk``, taken from a banded Cholesky factor of ``H`` by the Takahashi recursion over
the band (exact; the cells are ordered with the longest axis outermost so that the band is as
narrow as the grid allows). Predictions at a few cells (held-out readings) solve ``H x = e_k``
for those cells only.

Units. As in the paper's implementation, which maps readings normalised to [0, 1], the
information parameters are in units of ``reading_scale^-2``: readings are divided by
``reading_scale`` (default the largest absolute reading so far) before the solve, and the maps
are scaled back. The mean does not depend on the scale (only the ratios of the information
parameters do); the variances do.

Outputs: :meth:`~odorloc.inference.gas_map.base.GasMap.variance` is the posterior variance of
the cell's concentration, the predictive variance of a new reading adds one fresh reading's
noise ``1 / lambda_z``, and the confidence is ``1 - exp(-(1 / (lambda_z (H^-1)_kk))^2)``: the
cell's posterior information counted in fresh readings, mapped to [0, 1] as Kernel DM+V maps
its importance weight (Lilienthal et al. 2009, eq. 4), so that one fresh reading in an
otherwise unconnected cell gives ``1 - 1/e`` in both. Readings outside the grid are not used.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Positive
from odorloc.core.registry import register
from odorloc.geometry.grid import CellGrid
from odorloc.inference.gas_map.base import GasMap, GasMapParams
from odorloc.inference.gas_map.readings import Readings

__all__ = [
    "GMRFGasMap",
    "GMRFParams",
    "band_cholesky",
    "band_inverse_diagonal",
    "neighbour_pairs",
    "precision_system",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

MAX_VARIANCE_WORK = 2e10
"""Most ``cells x band^2`` operations the exact variance may take (minutes at most): a grid
beyond it (a large 3-D grid of small cells) is refused, naming the cell size, rather than left
running for hours."""


class GMRFParams(GasMapParams):
    """Parameters of the GMRF gas map (see the module docstring; information in units of
    ``reading_scale^-2``).

    Attributes
    ----------
    prior_information : float
        ``lambda_p`` of the factor between two connected neighbouring cells.
    observation_information : float
        ``lambda_z``: information of a fresh reading.
    information_loss : float, 1/s
        ``lambda_loss``: information a reading loses per second of age (0: time-invariant).
    anchor_information : float
        ``lambda_0`` of the weak factor that holds every cell to ``prior_mean``.
    prior_mean : float, optional
        ``m_0``, reading units; default the mean of the readings used.
    reading_scale : float, optional
        Readings are divided by it before the solve; default the largest absolute reading.
    """

    prior_information: Positive = 0.5
    observation_information: Positive = 10.0
    information_loss: NonNegative = 0.01
    anchor_information: Positive = 1e-4
    prior_mean: Finite | None = None
    reading_scale: Positive | None = None


def neighbour_pairs(grid: CellGrid, blocked: NDArray[np.bool_], arena: object | None) -> IntArray:
    """``(E, 2)`` flat indices of the face-neighbouring cells a prior factor joins: both free
    and, with an arena, the segment between their centres free of obstacles."""
    idx = np.arange(grid.n_cells).reshape(grid.shape)
    parts = []
    for a in range(grid.dim):
        lo = [slice(None)] * grid.dim
        hi = [slice(None)] * grid.dim
        lo[a] = slice(0, -1)
        hi[a] = slice(1, None)
        parts.append(np.column_stack([idx[tuple(lo)].ravel(), idx[tuple(hi)].ravel()]))
    pairs = np.concatenate(parts) if parts else np.zeros((0, 2), np.intp)
    flat_blocked = blocked.ravel()
    pairs = pairs[~flat_blocked[pairs[:, 0]] & ~flat_blocked[pairs[:, 1]]]
    if arena is not None and len(pairs) and getattr(arena, "occ", None) is not None:
        centres = grid.flat_centers()
        free = arena.segment_free(centres[pairs[:, 0]], centres[pairs[:, 1]])  # type: ignore[attr-defined]
        pairs = pairs[free]
    return pairs.astype(np.intp)


def precision_system(
    n_cells: int,
    pairs: IntArray,
    cells: IntArray,
    information: FloatArray,
    values: FloatArray,
    prior_information: float,
    anchor_information: float,
    anchor_value: float,
) -> tuple[sp.csc_matrix, FloatArray]:
    """The information matrix ``H`` (sparse, ``(n, n)``) and vector ``g`` of the factors.

    Parameters
    ----------
    n_cells : int
    pairs : (E, 2) int ndarray
        Connected neighbour pairs (prior factors of information ``prior_information``).
    cells : (N,) int ndarray
        Cell of each observation.
    information : (N,) ndarray
        Information ``lambda_i`` of each observation.
    values : (N,) ndarray
        The observations ``z_i``.
    prior_information, anchor_information, anchor_value : float
        ``lambda_p``, ``lambda_0``, ``m_0``.
    """
    i, j = pairs[:, 0], pairs[:, 1]
    lam = np.full(len(pairs), prior_information)
    deg = np.bincount(i, lam, n_cells) + np.bincount(j, lam, n_cells)
    diag = deg + np.bincount(cells, information, n_cells) + anchor_information
    rows = np.concatenate([i, j, np.arange(n_cells)])
    cols = np.concatenate([j, i, np.arange(n_cells)])
    vals = np.concatenate([-lam, -lam, diag])
    h = sp.csc_matrix((vals, (rows, cols)), shape=(n_cells, n_cells))
    g = np.bincount(cells, information * values, n_cells) + anchor_information * anchor_value
    return h, g


def band_cholesky(band: FloatArray) -> FloatArray:
    """Lower Cholesky factor of a symmetric positive definite band matrix.

    Parameters
    ----------
    band : (b + 1, n) ndarray
        Lower band storage: ``band[d, j] = A[j + d, j]``.

    Returns
    -------
    (b + 1, n) ndarray
        ``L`` in the same storage (``A = L L^T``).

    A right-looking factorisation over a sliding dense window of the band (``O(n b^2)``),
    single-threaded and the same on every machine.
    """
    b1, n = band.shape
    b = b1 - 1
    out = np.zeros_like(band)
    size = 2 * b1
    buf = np.zeros((size, size))
    # buf[p:p + b1, p:p + b1] holds rows/columns j .. j + b of A as updated by the columns
    # before j; the window slides down the buffer and is copied back to its top at the end
    top = min(b1, n)
    for r in range(top):
        for c in range(r + 1):
            buf[r, c] = buf[c, r] = band[r - c, c]
    p = 0
    ks = np.arange(b)
    for j in range(n):
        m = min(b, n - 1 - j)
        piv = buf[p, p]
        if not piv > 0:
            raise np.linalg.LinAlgError("the matrix is not positive definite")
        ljj = np.sqrt(piv)
        col = buf[p + 1 : p + 1 + m, p] / ljj
        out[0, j] = ljj
        out[1 : m + 1, j] = col
        if m:
            buf[p + 1 : p + 1 + m, p + 1 : p + 1 + m] -= np.outer(col, col)
        if p + 1 + b >= size:
            keep = buf[p + 1 : p + b1, p + 1 : p + b1].copy()
            buf[:] = 0.0
            buf[:b, :b] = keep
            p = -1
        p += 1
        nxt = j + 1 + b
        if nxt < n:
            # the window's new last row holds A's own entries: no column before j + 1 reaches it
            vals = band[b - ks, j + 1 + ks]
            q = p + b
            buf[q, p:q] = vals
            buf[p:q, q] = vals
            buf[q, q] = band[0, nxt]
    return out


def band_inverse_diagonal(factor: FloatArray) -> FloatArray:
    """``diag(A^-1)`` from the lower band Cholesky factor of ``A`` (:func:`band_cholesky`).

    The Takahashi recursion ``S_ij = delta_ij / L_jj^2 - (1 / L_jj) sum_{k > j} L_kj S_ik``
    (``i >= j``) needs only the entries of ``S = A^-1`` inside the band, computed from the last
    column backwards over a sliding dense window; exact, ``O(n b^2)``.

    Returns
    -------
    (n,) ndarray
    """
    b1, n = factor.shape
    b = b1 - 1
    size = 2 * b1
    buf = np.zeros((size, size))
    var = np.empty(n)
    p = size
    for j in range(n - 1, -1, -1):
        m = min(b, n - 1 - j)
        if p == 0:
            keep = buf[:b, :b].copy()
            buf[size - b :, size - b :] = keep
            p = size - b
        p -= 1
        ljj = factor[0, j]
        if m:
            col = factor[1 : m + 1, j]
            s = -(buf[p + 1 : p + 1 + m, p + 1 : p + 1 + m] @ col) / ljj
            sjj = 1.0 / (ljj * ljj) - float(col @ s) / ljj
            buf[p, p + 1 : p + 1 + m] = s
            buf[p + 1 : p + 1 + m, p] = s
        else:
            sjj = 1.0 / (ljj * ljj)
        buf[p, p] = sjj
        var[j] = sjj
    return var


def _band_order(shape: tuple[int, ...]) -> tuple[IntArray, int]:
    """Cell order with the longest axis outermost, and the band width it gives."""
    axes = sorted(range(len(shape)), key=lambda a: -shape[a])
    idx = np.arange(int(np.prod(shape))).reshape(shape)
    order = np.transpose(idx, axes).ravel()
    width = int(np.prod([shape[a] for a in axes[1:]]))
    return order, width


@register("gas_map", "gmrf", GMRFParams, "GMRF gas map with obstacles (Monroy et al. 2016)")
class GMRFGasMap(GasMap):
    """GMRF gas map: obstacle-aware neighbour factors, time-variant observations (Monroy et
    al. 2016)."""

    params: GMRFParams
    needs_time: ClassVar[bool] = False

    def __init__(self, params: GMRFParams | None = None) -> None:
        super().__init__(params if params is not None else GMRFParams())

    def _time_needed(self) -> bool:
        return self.params.information_loss > 0

    def _prepare(self) -> None:
        self._pairs = neighbour_pairs(self.grid, self._blocked, self._arena)

    @property
    def n_prior_factors(self) -> int:
        """Neighbour pairs joined by a prior factor (connected cells)."""
        return len(self._pairs)

    def _scale(self, readings: Readings) -> float:
        p = self.params
        if p.reading_scale is not None:
            return float(p.reading_scale)
        top = float(np.max(np.abs(readings.values))) if len(readings) else 0.0
        return top if top > 0 else 1.0

    def _used(self, readings: Readings) -> tuple[NDArray[np.bool_], FloatArray]:
        """Which readings enter the system (inside the grid, information left), and the
        information of each."""
        p = self.params
        lam = np.full(len(readings), p.observation_information)
        if p.information_loss > 0:
            lam = lam - p.information_loss * (float(readings.t.max()) - readings.t)
        return self.grid.contains(readings.positions) & (lam > 0), lam

    def _prior(self, readings: Readings) -> tuple[float, float]:
        s = self._scale(readings)
        m0 = self.params.prior_mean
        if m0 is None:
            use, _ = self._used(readings)
            m0 = float(readings.values[use].mean()) if use.any() else 0.0
        return float(m0), s * s / self.params.anchor_information

    def _system(self, readings: Readings) -> tuple[sp.csc_matrix, FloatArray, float]:
        p = self.params
        grid = self.grid
        use, lam = self._used(readings)
        m0, _ = self._prior(readings)
        cells_nd = grid.index(readings.positions[use])
        cells = np.ravel_multi_index(tuple(cells_nd.T), grid.shape)
        s = self._scale(readings)
        h, g = precision_system(
            grid.n_cells,
            self._pairs,
            cells,
            lam[use],
            readings.values[use] / s,
            p.prior_information,
            p.anchor_information,
            m0 / s,
        )
        return h, g, s

    def _compute_mean(self, readings: Readings) -> FloatArray:
        h, g, s = self._system(readings)
        self._h = h
        self._lu = spla.splu(h, permc_spec="MMD_AT_PLUS_A")
        x = self._lu.solve(g)
        return (s * np.asarray(x, float)).reshape(self.grid.shape)

    def predict(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Predicted mean and variance of a reading at each point (the cell holding it).

        When the points fall in few cells (held-out readings), only those cells' variances
        ``(H^-1)_kk`` are computed, by solving ``H x = e_k`` with the mean's factorisation;
        otherwise the whole variance map is.
        """
        p = np.atleast_2d(np.asarray(points, float))
        idx = self.grid.index(p)
        flat = np.ravel_multi_index(tuple(idx.T), self.grid.shape)
        cells, inverse = np.unique(flat, return_inverse=True)
        if self._spread is not None or 20 * len(cells) > self.grid.n_cells:
            return super().predict(p)
        mean = self._mean_map().ravel()
        rd = self.readings
        s = self._scale(rd)
        unit = np.zeros((self.grid.n_cells, len(cells)))
        unit[cells, np.arange(len(cells))] = 1.0
        diag = self._lu.solve(unit)[cells, np.arange(len(cells))]
        pvar = s * s * (diag + 1.0 / self.params.observation_information)
        blocked = self._blocked.ravel()[cells]
        if blocked.any():
            _, v0 = self._prior(rd)
            pvar = np.where(blocked, v0, pvar)
        return mean[flat], pvar[inverse]

    def _check_spread(self) -> None:
        _, width = _band_order(self.grid.shape)
        work = float(self.grid.n_cells) * float(width) ** 2
        if work > MAX_VARIANCE_WORK:
            raise ConfigError(
                "cell_size",
                f"the exact variance of {self.grid.n_cells} cells (band {width}) needs about "
                f"{work:.1e} operations; use larger cells or a smaller region",
            )

    def _compute_spread(
        self, readings: Readings, mean: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        p = self.params
        s = self._scale(readings)
        order, width = _band_order(self.grid.shape)
        hp = self._h[order][:, order].tocoo()
        keep = (hp.row >= hp.col) & (hp.row - hp.col <= width)
        band = np.zeros((width + 1, self.grid.n_cells))
        band[hp.row[keep] - hp.col[keep], hp.col[keep]] = hp.data[keep]
        diag = np.empty(self.grid.n_cells)
        diag[order] = band_inverse_diagonal(band_cholesky(band))
        diag = diag.reshape(self.grid.shape)
        var = s * s * diag
        # the cell's posterior information in fresh readings, mapped as eq. 4 of Kernel DM+V
        # maps Omega / sigma_Omega
        conf = 1.0 - np.exp(-((1.0 / (p.observation_information * diag)) ** 2))
        pvar = var + s * s / p.observation_information
        return var, conf, pvar
