"""Odor-path (air-mass path) probability maps by the dynamic-window method.

Implements the estimator of the odor-path paper (Li, Meng, Li & Zhang, "Mobile robot based odor
path estimation via dynamic window approach"): given the wind recorded at the robot over the last
``t_thr`` seconds, where was the air (and the odor patch) now at the robot at earlier times?

For every earlier record time ``t_r`` the patch position is Gaussian around the robot cell moved
back by the recorded wind (eq. 10); ``S`` is that Gaussian integrated over a cell (eq. 11); the
sub-dynamic window ``DW(t_r, t_c)`` keeps the cells with ``S >= eta`` -- an axis-aligned ellipse
(eqs. 12-15); ``S`` is normalised inside each window and the map is the maximum over ``t_r``
(eqs. 16-17). Only the cells inside each window's bounding box are evaluated, so the cost follows
``sum |DW|`` rather than the map size ``M``; :meth:`OdorPathEstimator.path_map_full` evaluates the
same maths on every cell as a reference. With numba (``backend="auto"``) the point kernel's map
is one compiled call; otherwise all windows are evaluated in one batched NumPy pass, the
reference. The compiled map equals it within a few units in the last place on every cell, with
the same cells (tested; a cell within rounding of a window's edge could fall either side).
:meth:`OdorPathEstimator.windows` and :meth:`OdorPathEstimator.window_arrays` are the batch's to
the bit on both backends. Dense maps are drawn into an array the estimator reuses
(:class:`DenseCanvas`) and are read-only.

Readings of the paper's flattened or ambiguous formulas (each one configurable):

* Displacement (eq. 10). The paper writes ``v(t_r, t_c) = sum_{i=r}^{c} U(t_i) dt``, which has one
  term more than the span ``t_c - t_r`` holds. Because a record ``U(t_i)`` is the mean of the
  readings in ``(t_{i-1}, t_i]`` (eq. 1), the integral over ``[t_r, t_c]`` is
  ``sum_{i=r+1}^{c} U(t_i) (t_i - t_{i-1})`` -- ``advection="interval"`` (default).
  ``advection="inclusive"`` uses the literal ``i = r .. c`` sum.
* Variance (eqs. 10-11). The paper gives the position variance as ``(t_c - t_r) sigma^2`` with
  ``sigma^2`` the variance of the recorded wind *velocity*, which is not a length squared. We use
  ``Sigma_r = (t_c - t_r) * tau * sigma_u^2`` per axis, with ``tau = noise_time_scale`` (s):
  ``tau = 1 s`` reproduces the paper's numbers, ``tau = dt`` is the random walk of independent
  per-record wind errors. ``sigma_u^2`` is the sample variance (ddof=1) of the wind records that
  enter the displacement sums (the last ``t_thr`` seconds), per axis, floored at ``min_variance``
  so that a perfectly steady wind still gives a finite kernel; ``variance="fixed"`` uses
  ``fixed_variance`` instead.
* Kernel (eq. 11). ``kernel="point"`` is the paper's approximation ``a^2 N(centre; Sigma)``;
  ``kernel="cell"`` integrates the Gaussian over the cell exactly (separable error functions).
  In both cases the window is the ellipse of eq. (12) with ``k`` from eq. (13).
* Cell coordinates. The paper's ``(i, j)`` is (row = y, column = x) with 1-based linear index
  ``k`` (eq. 9); arrays here are indexed ``[ix, iy]`` (x first, like every grid in odorloc) and
  :func:`paper_k` / :func:`from_paper_k` convert. The cell count per axis is
  ``int(extent / a)`` (eq. 7): a strip narrower than one cell at the upper edges is not mapped.
* Normalisation. Each sub-window is normalised over its cells *inside the grid* (the paper's
  window is a set of map cells); ``normalise=False`` keeps the raw ``S``.
* The map is the air-mass path whatever the reading; eq. (17) zeroes it unless the current signal
  intensity is positive, which ``require_detection=True`` applies.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import model_validator
from scipy.special import ndtr

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.geometry.grid import CellGrid
from odorloc.inference.odor_path.kernel import (
    HAVE_NUMBA,
    axis_kernel_fast,
    dw_kernel_fast,
    paint_fast,
    path_kernel_fast,
    path_meta,
    path_workspace,
    window_kernel_fast,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

_TIME_TOL = 1e-9


# ---------------------------------------------------------------------------------------- grid
def paper_k(grid: CellGrid, ix: ArrayLike, iy: ArrayLike) -> IntArray:
    """The paper's 1-based linear cell index ``k = (i - 1) n + j`` (eq. 9-a).

    Row ``i = iy + 1`` counts along y and column ``j = ix + 1`` along x.
    """
    return (np.asarray(iy, np.intp) * grid.nx + np.asarray(ix, np.intp) + 1).astype(np.intp)


def from_paper_k(grid: CellGrid, k: ArrayLike) -> tuple[IntArray, IntArray]:
    """``(ix, iy)`` of the paper's linear index ``k`` (eq. 9-b)."""
    k = np.asarray(k, np.intp)
    if np.any((k < 1) | (k > grid.n_cells)):
        raise ConfigError("k", f"must lie in [1, {grid.n_cells}]")
    i = (k - 1) // grid.nx + 1
    j = k - (i - 1) * grid.nx
    return (j - 1).astype(np.intp), (i - 1).astype(np.intp)


def _pair(value: ArrayLike, name: str) -> tuple[float, float]:
    """The two finite components of a record's ``position`` or ``wind``, or its error."""
    if type(value) is np.ndarray and value.dtype is _F64 and value.shape == (2,):
        x, y = value.tolist()
    else:
        v = np.asarray(value, float).reshape(-1)
        if v.shape != (2,):
            raise ConfigError(name, f"needs 2 finite components, got {value!r}")
        x, y = float(v[0]), float(v[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ConfigError(name, f"needs 2 finite components, got {value!r}")
    return x, y


_F64 = np.dtype(np.float64)


# ---------------------------------------------------------------------------------- parameters
class OdorPathParams(Params):
    """Parameters of :class:`OdorPathEstimator`.

    Attributes
    ----------
    cell_size : float, metres
        Cell side ``a`` (5 cm in the paper's experiments).
    t_thr : float, seconds
        Only records with ``t_c - t_r <= t_thr`` open a sub-window (10 s: 20 records at 0.5 s).
    dt : float, seconds
        Nominal record period; weights the first record's wind under ``advection="inclusive"``.
    history : float, seconds
        Extra record history kept beyond ``t_thr`` so maps can be computed at earlier record
        times (e.g. to attribute a delayed sensor reading, eq. 2); a map whose windows would
        need trimmed records is refused.
    eta : float, optional
        Window threshold on ``S`` (eq. 14); ``None`` means ``1 / M`` (eq. 15).
    variance : {"online", "fixed"}
        Wind-velocity variance from the records (eq. 10) or ``fixed_variance``.
    fixed_variance : (2,) tuple of float, m^2/s^2
        ``(sigma_x^2, sigma_y^2)`` used when ``variance="fixed"``.
    min_variance : float, m^2/s^2
        Floor on each axis' online velocity variance (``fixed_variance`` is used as given).
    noise_time_scale : float, seconds
        ``tau`` in ``Sigma = (t_c - t_r) tau sigma_u^2`` (see the module notes).
    advection : {"interval", "inclusive"}
        Which records enter the displacement sum (see the module notes).
    kernel : {"point", "cell"}
        Point approximation of eq. (11) or the exact cell integral.
    normalise : bool
        Normalise ``S`` within each sub-window (section IV).
    snap_to_cell : bool
        Use the centre of the robot's cell as ``(x_j, y_j)`` (eq. 11) rather than the exact
        position.
    backend : {"auto", "numpy", "numba"}
        Window kernel: the compiled loop when numba is installed ("auto"), or the batched NumPy
        form. Both give the same map within a few units in the last place.
    """

    cell_size: Positive = 0.05
    t_thr: Positive = 10.0
    dt: Positive = 0.5
    history: NonNegative = 0.0
    eta: float | None = None
    variance: Literal["online", "fixed"] = "online"
    fixed_variance: tuple[Positive, Positive] = (1e-3, 1e-3)
    min_variance: Positive = 1e-4
    noise_time_scale: Positive = 1.0
    advection: Literal["interval", "inclusive"] = "interval"
    kernel: Literal["point", "cell"] = "point"
    normalise: bool = True
    snap_to_cell: bool = True
    backend: Literal["auto", "numpy", "numba"] = "auto"

    @model_validator(mode="after")
    def _check(self) -> OdorPathParams:
        if self.eta is not None and not (math.isfinite(self.eta) and 0.0 < self.eta < 1.0):
            raise ValueError("eta must lie in (0, 1) or be None (1/M)")
        return self


# ------------------------------------------------------------------------------- result types
@dataclass(frozen=True, eq=False)
class SubWindow:
    """One sub-dynamic window ``DW(t_r, t_c)`` (eq. 12).

    Attributes
    ----------
    t_r : float, seconds
        Record time the window refers to.
    center : (2,) ndarray, metres
        Where the air now at the robot was at ``t_r``: robot cell minus the displacement (eq. 10).
    semi_axes : (2,) ndarray, metres
        Semi-axes of the window ellipse along x and y, ``sqrt(2 k Sigma)``; zeros if ``k <= 0``.
    angle : float, rad
        Ellipse orientation (0: the covariance is diagonal, eq. 11).
    k : float
        ``k`` of eq. (13) (already multiplied into ``Sigma = (t_c - t_r) tau sigma^2``).
    variance : (2,) ndarray, m^2
        Position variance ``Sigma`` along x and y.
    box : (4,) tuple of int
        ``(ix0, ix1, iy0, iy1)``: index bounds (end exclusive) of the window's cells in the grid.
    n_cells : int
        Number of grid cells in the window.
    """

    t_r: float
    center: FloatArray
    semi_axes: FloatArray
    angle: float
    k: float
    variance: FloatArray
    box: tuple[int, int, int, int]
    n_cells: int


@dataclass(frozen=True, eq=False)
class PathPatch:
    """A path map stored as its non-zero bounding box.

    Attributes
    ----------
    ix0, iy0 : int
        Grid index of ``values[0, 0]``.
    values : (bx, by) ndarray
        Map values in the box; the map is zero outside it.
    grid : CellGrid
    ref_cell : (2,) int ndarray
        Cell of the robot the map was computed for (used to shift it, eq. 7 of the D-S paper).
    canvas : DenseCanvas, optional
        Where :meth:`to_dense` writes the full map (the estimator's own, reused between maps);
        ``None``: a fresh array each time.
    """

    ix0: int
    iy0: int
    values: FloatArray
    grid: CellGrid
    ref_cell: IntArray
    canvas: DenseCanvas | None = field(default=None, repr=False)

    @property
    def slices(self) -> tuple[slice, slice]:
        """Slices of the box in a full ``(nx, ny)`` array."""
        bx, by = self.values.shape
        return slice(self.ix0, self.ix0 + bx), slice(self.iy0, self.iy0 + by)

    @property
    def empty(self) -> bool:
        """``True`` when the map is zero everywhere."""
        return self.values.size == 0 or not np.any(self.values > 0)

    def to_dense(self) -> FloatArray:
        """The full ``(nx, ny)`` map.

        A fresh writable array, or, for a patch with a :attr:`canvas` (the estimator's), a
        read-only one whose memory the canvas reuses once nothing refers to it any more: copy
        it to modify it.
        """
        if self.canvas is not None:
            return self.canvas.draw(self)
        out = np.zeros(self.grid.shape)
        if self.values.size:
            out[self.slices] = self.values
        return out


def _patch(
    ix0: int,
    iy0: int,
    values: FloatArray,
    grid: CellGrid,
    ref_cell: IntArray,
    canvas: DenseCanvas | None,
) -> PathPatch:
    """``PathPatch(ix0, iy0, values, grid, ref_cell, canvas)`` without the frozen dataclass's
    ``__init__`` (one ``object.__setattr__`` per field: a third of the Python around the
    compiled map); the same object."""
    p = object.__new__(PathPatch)
    d = p.__dict__
    d["ix0"] = ix0
    d["iy0"] = iy0
    d["values"] = values
    d["grid"] = grid
    d["ref_cell"] = ref_cell
    d["canvas"] = canvas
    return p


class DenseCanvas:
    """A full ``(nx, ny)`` map reused for the dense form of successive patches.

    Making a 40 000-cell map dense costs more than computing the patch when the map is a fresh
    array each time (the whole array is zeroed); a canvas instead clears only the previous
    patch's box and writes the new one. It hands its array out read-only and reuses it only
    when nothing else refers to it (CPython's reference count: any view of it counts), so a map
    once returned never changes; otherwise it starts a new array.

    Parameters
    ----------
    shape : (2,) tuple of int
        ``(nx, ny)``.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        # the map is written in _base and handed out as _view, a read-only view of it: no
        # flag to set and reset around every drawing
        self._base: FloatArray | None = None
        self._view: FloatArray | None = None
        self._last = np.zeros(4, np.intp)  # box of the patch the map holds
        self._free = (0, 0)  # reference counts of view and base when nothing outside refers

    def __getstate__(self) -> dict[str, tuple[int, int]]:
        # a copy or a pickle starts its own map: the array is memory handed out, not state
        return {"shape": self.shape}

    def __setstate__(self, state: dict[str, tuple[int, int]]) -> None:
        self.__init__(state["shape"])  # type: ignore[misc]

    def draw(self, patch: PathPatch) -> FloatArray:
        """``patch`` as a full read-only map (see the class notes)."""
        m, v = self._base, self._view
        # a view of the map handed out refers to the base, not to the view it was cut from
        if m is None or (sys.getrefcount(v), sys.getrefcount(m)) != self._free:
            m = np.zeros(self.shape)
            v = m.view()
            v.flags.writeable = False
            self._base, self._view = m, v
            self._last[:] = 0
            # the same expressions as the test above, so the counts are the same on any CPython
            self._free = (sys.getrefcount(v), sys.getrefcount(m))
        if HAVE_NUMBA:
            paint_fast(m, self._last, patch.values, patch.ix0, patch.iy0)
        else:
            a, b, c, d = self._last.tolist()
            m[a:b, c:d] = 0.0
            m[patch.slices] = patch.values
            bx, by = patch.values.shape
            self._last[:] = (patch.ix0, patch.ix0 + bx, patch.iy0, patch.iy0 + by)
        return v  # type: ignore[return-value]


# -------------------------------------------------------------------------------- estimator
@dataclass(frozen=True, eq=False)
class WindowArrays:
    """The sub-windows of one map as arrays: record times, centres ``(R, 2)`` m, variances
    ``(R, 2)`` m^2, ``k`` ``(R,)`` of eq. 13, and the robot cell ``(2,)``."""

    t_c: float
    t_r: FloatArray  # (R,)
    center: FloatArray  # (R, 2) metres
    var: FloatArray  # (R, 2) m^2
    k: FloatArray  # (R,)
    ref_cell: IntArray  # (2,)


@dataclass(frozen=True)
class AxisTerms:
    """Per sub-window: ``boxes`` ``(R, 4)`` (``(ix0, ix1, iy0, iy1)``, empty when
    ``ix1 == ix0`` or ``iy1 == iy0``), the ellipse terms ``qx`` ``(R, Bx)`` and ``qy``
    ``(R, By)`` of eq. (12), the kernel factors ``fx``, ``fy`` of eq. (11) on the same cells,
    and ``lim = 2 k`` ``(R,)``."""

    boxes: IntArray
    qx: FloatArray
    qy: FloatArray
    fx: FloatArray
    fy: FloatArray
    lim: FloatArray


class OdorPathEstimator:
    """Odor-path probability maps from the robot's wind record (odor-path paper, section IV).

    Parameters
    ----------
    params : OdorPathParams
    lower, upper : (2,) sequence of float, metres
        Extent of the mapped area.

    Notes
    -----
    Feed one record per control period with :meth:`update`; the wind must be the air velocity in
    the world frame at the robot (for an anemometer on a moving robot, the reading corrected by
    the robot's own velocity, as in the paper's experiments).
    """

    def __init__(
        self, params: OdorPathParams, lower: Sequence[float], upper: Sequence[float]
    ) -> None:
        self.params = params
        if len(lower) != 2 or len(upper) != 2:
            # the map is over the horizontal plane (eqs. 6-9); a 3D box would fail later
            raise ConfigError("lower", "the odor-path map needs 2D bounds (x, y)")
        self.grid = CellGrid.from_extent(lower, upper, params.cell_size)
        self.eta = params.eta if params.eta is not None else 1.0 / self.grid.n_cells
        self._canvas = DenseCanvas(self.grid.shape)
        g, p = self.grid, params
        # the compiled map's fixed settings, packed once: every argument adds to a call's
        # dispatch (path_kernel's layout)
        fixed = (g.lower[0], g.lower[1], g.cell_size, *p.fixed_variance, p.min_variance)
        readings = (p.advection == "interval", p.snap_to_cell, p.variance == "fixed")
        self._par = np.array(
            [p.dt, *fixed, p.noise_time_scale, self.eta, p.t_thr, _TIME_TOL, *readings,
             p.normalise, *g.shape],
            float,
        )  # fmt: skip
        self._ws: FloatArray | None = None  # its scratch (path_workspace)
        self._ws_capacity = 0
        self._meta: IntArray | None = None  # path_meta of the scratch
        # path_patch by the fused kernel (a missing numba is reported by _use_numba)
        self._fused = p.kernel == "point" and p.backend != "numpy" and HAVE_NUMBA
        self.reset()

    def __getstate__(self) -> dict[str, object]:
        # the compiled map's scratch is not state, and a copy of its integer view would not
        # view the copy's scratch: a copy or a pickle allocates its own on first use
        state = self.__dict__.copy()
        state.update(_ws=None, _ws_capacity=0, _meta=None)
        return state

    # ------------------------------------------------------------------------ records
    def reset(self) -> None:
        """Forget all records."""
        cap = 64
        self._tt = np.zeros(cap)
        self._pp = np.zeros((cap, 2))
        self._ww = np.zeros((cap, 2))
        self._ss = np.zeros(cap)
        self._lo = 0
        self._hi = 0
        self._dropped_t = -math.inf  # newest record trimmed away, seconds

    def update(
        self, t: float, position: ArrayLike, wind: ArrayLike, signal: float | bool = 0.0
    ) -> None:
        """Store the record of one period.

        Parameters
        ----------
        t : float, seconds
            Record time, strictly after the previous one.
        position : (2,) array_like, metres
            Robot (sensor) position at ``t``.
        wind : (2,) array_like, m/s
            Air velocity at the robot, mean over the period ending at ``t`` (eq. 1).
        signal : float or bool
            Signal intensity ``s(t)`` (eq. 5) or a binary detection; ``> 0`` is a detection.
        """
        t = float(t)
        if not math.isfinite(t):
            raise ConfigError("t", "must be finite")
        if self._hi > self._lo and t <= self._tt[self._hi - 1]:
            raise ConfigError("t", f"must increase (got {t} after {self._tt[self._hi - 1]})")
        # this runs at every record: scalar tests, not np.all(np.isfinite(.)), and no array
        # made from a float array of the right shape (either would cost more than the store)
        px, py = _pair(position, "position")
        wx, wy = _pair(wind, "wind")
        s = float(signal)
        if not math.isfinite(s):
            raise ConfigError("signal", "must be finite")
        keep_from = t - self.params.t_thr - self.params.history - _TIME_TOL
        lo, hi = self._lo, self._hi
        if hi > lo and self._tt[lo] < keep_from:
            # at a steady period one record leaves per record stored: two scalar tests
            if hi > lo + 1 and self._tt[lo + 1] >= keep_from:
                n_drop = 1
            else:
                n_drop = int(np.searchsorted(self._tt[lo:hi], keep_from, side="left"))
            self._dropped_t = float(self._tt[lo + n_drop - 1])
            self._lo = lo + n_drop
        if self._hi == len(self._tt):
            n = self._hi - self._lo
            cap = max(len(self._tt), 2 * (n + 1))
            for name in ("_tt", "_pp", "_ww", "_ss"):
                old = getattr(self, name)
                new = np.zeros((cap, *old.shape[1:]))
                new[:n] = old[self._lo : self._hi]
                setattr(self, name, new)
            self._lo, self._hi = 0, n
        i = self._hi
        self._tt[i] = t
        pp, ww = self._pp, self._ww
        pp[i, 0] = px
        pp[i, 1] = py
        ww[i, 0] = wx
        ww[i, 1] = wy
        self._ss[i] = s
        self._hi += 1

    @property
    def n_records(self) -> int:
        """Number of stored records."""
        return self._hi - self._lo

    @property
    def times(self) -> FloatArray:
        """``(n,)`` stored record times, seconds."""
        return self._tt[self._lo : self._hi].copy()

    def detected(self, t_c: float | None = None) -> bool:
        """``True`` when the signal of the record at ``t_c`` (default newest) is positive."""
        return bool(self._ss[self._record_index(t_c)] > 0.0)

    def _record_index(self, t_c: float | None) -> int:
        """Absolute buffer index of the record at ``t_c`` (default newest)."""
        if self._hi == self._lo:
            raise ConfigError("t_c", "no records yet")
        if t_c is None:
            return self._hi - 1
        if not math.isfinite(t_c):
            # NaN would pass the tolerance test below and pick the oldest record
            raise ConfigError("t_c", f"must be a finite record time, got {t_c}")
        times = self._tt[self._lo : self._hi]
        c = int(np.argmin(np.abs(times - t_c)))
        if abs(times[c] - t_c) > 1e-6:
            raise ConfigError("t_c", f"{t_c} s is not a stored record time")
        return self._lo + c

    def wind_variance(self, t_c: float | None = None) -> FloatArray:
        """``(2,)`` wind-velocity variance ``(sigma_x^2, sigma_y^2)`` used at ``t_c``, m^2/s^2."""
        c = self._record_index(t_c)
        first = self._first_window(c)
        return self._velocity_variance(c, first)

    def _first_window(self, c: int) -> int:
        """Buffer index of the oldest record with ``t_c - t_r <= t_thr``."""
        limit = self._tt[c] - self.params.t_thr - _TIME_TOL
        if self._dropped_t >= limit:
            # a map from fewer windows than at the time would differ without notice
            raise ConfigError(
                "t_c",
                f"the map at {self._tt[c]} s needs records trimmed away already (keep more "
                "with history)",
            )
        return self._lo + int(np.searchsorted(self._tt[self._lo : c + 1], limit, side="left"))

    def _velocity_variance(self, c: int, first: int) -> FloatArray:
        p = self.params
        if p.variance == "fixed":
            # as given: the floor only keeps a steady wind's online estimate finite
            return np.asarray(p.fixed_variance, float)
        lo = first + 1 if p.advection == "interval" else first
        n = c + 1 - lo
        if n < 2:
            return np.full(2, p.min_variance)
        var = self._ww[lo : c + 1].var(axis=0, ddof=1)  # sample variance
        return np.maximum(var, p.min_variance)

    def window_arrays(self, t_c: float | None = None) -> WindowArrays:
        """The sub-windows at ``t_c`` as arrays (centres, variances, ``k``): the kernels' input."""
        p = self.params
        c = self._record_index(t_c)
        if self._use_numba():
            limit = self._tt[c] - p.t_thr - _TIME_TOL
            if self._dropped_t >= limit:
                self._first_window(c)  # its error: the records needed are gone
            g = self.grid
            t_r, center, var, k_arg, ref = window_kernel_fast(
                self._tt,
                self._ww,
                self._pp,
                limit,
                c,
                self._lo,
                float(p.dt),
                p.advection == "interval",
                p.snap_to_cell,
                float(g.lower[0]),
                float(g.lower[1]),
                float(g.cell_size),
                p.variance == "fixed",
                np.asarray(p.fixed_variance, float),
                float(p.min_variance),
                float(p.noise_time_scale),
                float(self.eta),
            )
            # NumPy's logarithm on both paths: the same k to the bit
            return WindowArrays(float(self._tt[c]), t_r, center, var, np.log(k_arg), ref)
        first = self._first_window(c)
        times = self._tt[first : c + 1]
        wind = self._ww[first : c + 1]
        dts = np.empty(len(times))
        if first > self._lo:
            dts[:] = times - self._tt[first - 1 : c]
        else:
            dts[0] = p.dt
            dts[1:] = times[1:] - times[:-1]
        # suffix[i] = sum_{l >= i} U_l dt_l over the kept records (eq. 10, discretised)
        suffix = np.cumsum((wind * dts[:, None])[::-1], axis=0)[::-1]
        n_win = len(times) - 1
        disp = suffix[1:] if p.advection == "interval" else suffix[:n_win]
        px, py = float(self._pp[c, 0]), float(self._pp[c, 1])
        a = self.grid.cell_size
        x0, y0 = self.grid.lower
        ix, iy = math.floor((px - x0) / a), math.floor((py - y0) / a)
        if p.snap_to_cell:
            px, py = x0 + (ix + 0.5) * a, y0 + (iy + 0.5) * a
        sig2 = self._velocity_variance(c, first) * p.noise_time_scale
        age = times[-1] - times[:n_win]
        var = age[:, None] * sig2[None, :]
        # eq. (13) with (t_c - t_r) sigma_x sigma_y generalised to sqrt(det Sigma)
        k = np.log((a * a / (2.0 * np.pi * self.eta * math.sqrt(sig2[0] * sig2[1]))) / age)
        center = np.empty((n_win, 2))
        center[:, 0] = px - disp[:, 0]
        center[:, 1] = py - disp[:, 1]
        return WindowArrays(
            t_c=float(times[-1]),
            t_r=times[:n_win].copy(),
            center=center,
            var=var,
            k=k,
            ref_cell=np.array([ix, iy], np.intp),
        )

    # --------------------------------------------------------------------------- kernels
    def axis_terms(self, w: WindowArrays) -> AxisTerms:
        """What both paths start from: each sub-window's box and, along each axis of it, the
        ellipse term of eq. (12) and the kernel factor of eq. (11) (padded to a common size).

        The exponentials (and the cell kernel's ``ndtr``) are NumPy's on both paths, so that
        :meth:`windows` gives the same cells to the bit on both (the map itself, with numba and
        the point kernel, is :meth:`path_patch`'s single compiled call); with numba the rest of
        the point kernel's prelude runs as
        :func:`~odorloc.inference.odor_path.kernel.axis_kernel`, operation for operation as the
        NumPy code below.

        Parameters
        ----------
        w : WindowArrays
            From :meth:`window_arrays`.

        Returns
        -------
        AxisTerms
            The input of :func:`~odorloc.inference.odor_path.kernel.dw_kernel`.
        """
        if self.params.kernel == "point" and self._use_numba():
            g = self.grid
            boxes, qa_x, qa_y, coef = axis_kernel_fast(
                w.center, w.var, w.k, g.lower[0], g.lower[1], g.cell_size, g.nx, g.ny
            )
            qx, qy = qa_x[0], qa_y[0]
            # in place: coef * exp(arg), the NumPy branch's product (one rounding either way)
            fx = np.exp(qa_x[1], out=qa_x[1])
            fx *= coef[:, 0:1]
            fy = np.exp(qa_y[1], out=qa_y[1])
            fy *= coef[:, 1:2]
            return AxisTerms(boxes=boxes, qx=qx, qy=qy, fx=fx, fy=fy, lim=2.0 * w.k)
        a = self.grid.cell_size
        lo = np.asarray(self.grid.lower)
        shape = np.asarray(self.grid.shape)
        k = w.k
        valid = k > 0
        half = np.sqrt(2.0 * np.where(valid, k, 0.0)[:, None] * w.var)
        # One spare cell per side: membership is decided by the exact ellipse test.
        i0 = np.ceil((w.center - half - lo) / a - 0.5).astype(np.intp) - 1
        i1 = np.floor((w.center + half - lo) / a - 0.5).astype(np.intp) + 2
        i0 = np.clip(i0, 0, shape)
        i1 = np.clip(i1, 0, shape)
        size = np.where(valid[:, None], np.maximum(i1 - i0, 0), 0)
        boxes = np.column_stack([i0[:, 0], i0[:, 0] + size[:, 0], i0[:, 1], i0[:, 1] + size[:, 1]])
        n_r = len(k)
        bx, by = (int(size[:, 0].max()), int(size[:, 1].max())) if n_r else (0, 0)
        ax, ay = np.arange(bx), np.arange(by)
        ix = np.minimum(i0[:, 0, None] + ax, shape[0] - 1)
        iy = np.minimum(i0[:, 1, None] + ay, shape[1] - 1)
        dx = self.grid.x_centers()[ix] - w.center[:, 0, None]  # (R, Bx)
        dy = self.grid.y_centers()[iy] - w.center[:, 1, None]  # (R, By)
        vx = w.var[:, 0, None]
        vy = w.var[:, 1, None]
        if self.params.kernel == "point":
            # eq. (11), separable: a^2 / (2 pi sqrt(det Sigma)) exp(-q / 2)
            fx = a / np.sqrt(2.0 * np.pi * vx) * np.exp(-0.5 * dx * dx / vx)
            fy = a / np.sqrt(2.0 * np.pi * vy) * np.exp(-0.5 * dy * dy / vy)
        else:
            sx, sy = np.sqrt(vx), np.sqrt(vy)
            fx = ndtr((dx + 0.5 * a) / sx) - ndtr((dx - 0.5 * a) / sx)
            fy = ndtr((dy + 0.5 * a) / sy) - ndtr((dy - 0.5 * a) / sy)
        return AxisTerms(
            boxes=boxes,
            qx=dx * dx / vx,
            qy=dy * dy / vy,
            fx=fx,
            fy=fy,
            lim=2.0 * k,
        )

    def _batch(self, w: WindowArrays) -> tuple[IntArray, FloatArray, IntArray]:
        """Every sub-window at once, each in its own bounding box padded to a common size.

        Returns
        -------
        boxes : (R, 4) int ndarray
            ``(ix0, ix1, iy0, iy1)`` per window (end exclusive, clipped to the grid).
        values : (R, Bx, By) ndarray
            Normalised ``S`` of window ``r`` in ``values[r, :ix1-ix0, :iy1-iy0]``, zero elsewhere
            and outside the window ellipse.
        n_cells : (R,) int ndarray
            Cells of each window inside the grid (0: empty window).
        """
        t = self.axis_terms(w)
        n_r = len(t.lim)
        bx, by = t.qx.shape[1], t.qy.shape[1]
        if bx == 0 or by == 0:
            return t.boxes, np.zeros((n_r, 0, 0)), np.zeros(n_r, np.intp)
        # eq. (12): ellipse membership, written exactly as in the full-grid reference
        q = t.qx[:, :, None] + t.qy[:, None, :]
        inside = q <= t.lim[:, None, None]
        size = t.boxes[:, 1::2] - t.boxes[:, ::2]  # cells per axis
        inside &= (np.arange(bx)[None, :] < size[:, 0, None])[:, :, None]
        inside &= (np.arange(by)[None, :] < size[:, 1, None])[:, None, :]
        vals = t.fx[:, :, None] * t.fy[:, None, :]
        vals *= inside
        n_cells = np.count_nonzero(inside.reshape(n_r, -1), axis=1)
        # cell by cell in row order (a running sum, as the compiled loop adds them; the zeros
        # outside the ellipse change nothing)
        total = np.cumsum(vals.reshape(n_r, -1), axis=1)[:, -1]
        ok = total > 0
        n_cells = np.where(ok, n_cells, 0)
        if self.params.normalise:
            vals /= np.where(ok, total, 1.0)[:, None, None]
        return t.boxes, vals, n_cells

    def _use_numba(self) -> bool:
        b = self.params.backend
        if b == "numba" and not HAVE_NUMBA:
            raise ConfigError("backend", "numba is not installed (install the 'fast' extra)")
        return b == "numba" or (b == "auto" and HAVE_NUMBA)

    def _patch_compiled(self, c: int, require_detection: bool) -> PathPatch:
        """:meth:`path_patch` of record ``c`` in one compiled call (point kernel).

        The same maths as :meth:`window_arrays`, :meth:`axis_terms` and the NumPy batch, within
        a few units in the last place of the batch's values
        (:func:`~odorloc.inference.odor_path.kernel.path_kernel`).
        """
        tt = self._tt
        limit = tt[c] - self.params.t_thr - _TIME_TOL
        if self._dropped_t >= limit:
            self._first_window(c)  # its error: the records needed are gone
        if require_detection and not self._ss[c] > 0.0:
            # the robot's cell as the kernel finds it
            g = self.grid
            ix = math.floor((self._pp[c, 0] - g.lower[0]) / g.cell_size)
            iy = math.floor((self._pp[c, 1] - g.lower[1]) / g.cell_size)
            ref = np.array([ix, iy], np.intp)
            return PathPatch(0, 0, np.zeros((0, 0)), g, ref, self._canvas)
        ws = self._ws
        if ws is None or self._ws_capacity < len(tt):
            ws = self._ws = path_workspace(len(tt), *self.grid.shape)
            self._ws_capacity = len(tt)
            self._meta = path_meta(ws)
        values = path_kernel_fast(tt, self._ww, self._pp, c, self._lo, self._par, ws)
        ix0, iy0, rx, ry = self._meta.tolist()  # type: ignore[union-attr]
        return _patch(ix0, iy0, values, self.grid, np.array((rx, ry), np.intp), self._canvas)

    def _compiled(self, w: WindowArrays) -> tuple[IntArray, IntArray, FloatArray, int, int]:
        t = self.axis_terms(w)
        n_cells, patch, ix0, iy0 = dw_kernel_fast(
            t.boxes, t.qx, t.qy, t.fx, t.fy, t.lim, self.params.normalise
        )
        return t.boxes, n_cells, patch, ix0, iy0

    # --------------------------------------------------------------------------- outputs
    def windows(self, t_c: float | None = None) -> list[SubWindow]:
        """The sub-dynamic windows ``DW(t_r, t_c)`` at ``t_c`` (default: newest record).

        Returns
        -------
        list of SubWindow
            Oldest ``t_r`` first; empty windows are included with ``n_cells == 0``.
        """
        w = self.window_arrays(t_c)
        if self._use_numba():
            boxes, n_cells, _, _, _ = self._compiled(w)
        else:
            boxes, _, n_cells = self._batch(w)
        out = []
        for r in range(len(w.t_r)):
            k = float(w.k[r])
            n = int(n_cells[r])
            half = np.sqrt(2.0 * k * w.var[r]) if k > 0 else np.zeros(2)
            box = tuple(int(b) for b in boxes[r]) if n else (0, 0, 0, 0)
            out.append(
                SubWindow(
                    t_r=float(w.t_r[r]),
                    center=w.center[r].copy(),
                    semi_axes=half,
                    angle=0.0,
                    k=k,
                    variance=w.var[r].copy(),
                    box=box,  # type: ignore[arg-type]
                    n_cells=n,
                )
            )
        return out

    def path_patch(self, t_c: float | None = None, require_detection: bool = False) -> PathPatch:
        """The odor-path map at ``t_c`` as its bounding box (eqs. 12-17).

        Parameters
        ----------
        t_c : float, optional
            A stored record time (default: the newest).
        require_detection : bool
            Apply eq. (17) literally: the map is zero unless ``s(t_c) > 0``.

        Returns
        -------
        PathPatch
            Cost is proportional to the number of cells in the windows, not to ``M``.
        """
        if self._fused:
            return self._patch_compiled(self._record_index(t_c), require_detection)
        w = self.window_arrays(t_c)
        if require_detection and not self._ss[self._record_index(t_c)] > 0.0:
            return PathPatch(0, 0, np.zeros((0, 0)), self.grid, w.ref_cell, self._canvas)
        if self._use_numba():
            # no window with a cell: the kernel's patch is (0, 0) at (0, 0), the empty patch
            _, _, patch, ix0, iy0 = self._compiled(w)
            return PathPatch(int(ix0), int(iy0), patch, self.grid, w.ref_cell, self._canvas)
        boxes, vals, n_cells = self._batch(w)
        used = np.flatnonzero(n_cells > 0)
        if used.size == 0:
            return PathPatch(0, 0, np.zeros((0, 0)), self.grid, w.ref_cell, self._canvas)
        b = boxes[used]
        ix0, iy0 = int(b[:, 0].min()), int(b[:, 2].min())
        ix1, iy1 = int(b[:, 1].max()), int(b[:, 3].max())
        out = np.zeros((ix1 - ix0, iy1 - iy0))
        box_list = boxes.tolist()
        for r in used.tolist():
            bx0, bx1, by0, by1 = box_list[r]
            view = out[bx0 - ix0 : bx1 - ix0, by0 - iy0 : by1 - iy0]
            np.maximum(view, vals[r, : bx1 - bx0, : by1 - by0], out=view)  # eq. (17)
        return PathPatch(ix0, iy0, out, self.grid, w.ref_cell, self._canvas)

    def path_map(self, t_c: float | None = None, require_detection: bool = False) -> FloatArray:
        """The odor-path probability map ``pi`` at ``t_c``, ``(nx, ny)`` (eq. 17).

        See :meth:`path_patch` for the parameters. The array is read-only: its memory serves a
        later map once nothing refers to it any more (:meth:`PathPatch.to_dense`).
        """
        return self.path_patch(t_c, require_detection).to_dense()

    def path_map_full(
        self, t_c: float | None = None, require_detection: bool = False
    ) -> FloatArray:
        """Reference: the same map evaluating ``S`` on every cell for every window.

        Cost ``O(R M)`` for ``R`` windows; used to test and time :meth:`path_map`.

        Returns
        -------
        (nx, ny) ndarray
        """
        w = self.window_arrays(t_c)
        c = self._record_index(t_c)
        out = np.zeros(self.grid.shape)
        if require_detection and not self._ss[c] > 0.0:
            return out
        a = self.grid.cell_size
        xc, yc = self.grid.x_centers(), self.grid.y_centers()
        # work arrays for every window (no full-size temporaries per window)
        q = np.empty(self.grid.shape)
        s = np.empty(self.grid.shape)
        outside = np.empty(self.grid.shape, bool)
        for r in range(len(w.t_r)):
            var, k = w.var[r], w.k[r]
            if k < 0.0:
                continue  # eq. (12) keeps no cell (q >= 0)
            dx = xc - w.center[r, 0]
            dy = yc - w.center[r, 1]
            qx, qy = dx * dx / var[0], dy * dy / var[1]
            np.add.outer(qx, qy, out=q)
            if self.params.kernel == "point":
                # eq. 11; the Gaussian is separable, so nx + ny exponentials instead of nx ny
                cf = a * a / (2.0 * np.pi * np.sqrt(var[0] * var[1]))
                np.multiply.outer(cf * np.exp(-0.5 * qx), np.exp(-0.5 * qy), out=s)
            else:
                sx, sy = np.sqrt(var)
                fx = ndtr((dx + 0.5 * a) / sx) - ndtr((dx - 0.5 * a) / sx)
                fy = ndtr((dy + 0.5 * a) / sy) - ndtr((dy - 0.5 * a) / sy)
                np.multiply.outer(fx, fy, out=s)
            np.greater(q, 2.0 * k, out=outside)
            np.putmask(s, outside, 0.0)  # eq. (12)
            if self.params.normalise:
                total = s.sum()
                if not total > 0:
                    continue
                s /= total
            np.maximum(out, s, out=out)
        return out
