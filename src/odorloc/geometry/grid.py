"""One uniform cell grid type for every gridded thing in odorloc, and multilinear interpolation.

:class:`CellGrid` is a box of equal cells in 2D or 3D: the arena's occupancy grid, the Eulerian
plume's finite volumes, the odor-path and Dempster-Shafer maps and the grid beliefs all use it.
Cell ``[i, j(, k)]`` (x index first) spans ``lower + idx * cell`` to ``lower + (idx + 1) * cell``
and its centre is ``lower + (idx + 0.5) * cell``. A cell may have a different side per axis.

:func:`multilinear` interpolates values given on the nodes of a rectilinear lattice (a grid's
cell centres, or a recorded wind's node lattice), holding the edge values outside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit

__all__ = ["MAX_GRID_CELLS", "CellGrid", "check_cell_count", "multilinear"]

MAX_GRID_CELLS = 20_000_000
"""Most cells of one grid (a float64 field of this size takes 160 MB): a cell size too small
for its extent is refused instead of exhausting memory."""

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def check_cell_count(
    counts: ArrayLike, cell_size: float | Sequence[float], field: str = "cell_size"
) -> None:
    """Refuse a grid of more than :data:`MAX_GRID_CELLS` cells before it is sized in integers.

    ``counts`` are the (float) cells per axis, e.g. ``extent / cell_size``.
    """
    c = np.maximum(np.asarray(counts, float), 1.0)
    # in logarithms: the product of absurd counts must not overflow (and warn) before it is
    # refused
    log_total = float(np.sum(np.log(c))) if np.all(np.isfinite(c)) else math.inf
    if not log_total <= math.log(MAX_GRID_CELLS):
        shown = f"{math.exp(log_total):.3g}" if log_total < 700 else "too many"
        raise ConfigError(
            field,
            f"{cell_size} m cells make a grid of {shown} cells; at most {MAX_GRID_CELLS} "
            "(use larger cells)",
        )


@dataclass(frozen=True, eq=False)
class CellGrid:
    """A uniform grid of cells over an axis-aligned box.

    Parameters
    ----------
    lower : (d,) tuple of float, metres
        Corner of cell ``[0, ..., 0]``; ``d`` in {2, 3}.
    cell_size : float or (d,) tuple of float, metres
        Side of a cell (one value for square/cubic cells, or one per axis).
    shape : (d,) tuple of int
        Number of cells along each axis.
    """

    lower: tuple[float, ...]
    cell_size: float | tuple[float, ...]
    shape: tuple[int, ...]

    def __post_init__(self) -> None:
        lo = tuple(float(v) for v in self.lower)
        if len(lo) not in (2, 3) or not all(math.isfinite(v) for v in lo):
            raise ConfigError("grid.lower", "needs 2 or 3 finite components")
        cs = self.cell_size
        if isinstance(cs, int | float | np.floating | np.integer):
            cs = float(cs)
            ok = math.isfinite(cs) and cs > 0
        else:
            cs = tuple(float(v) for v in cs)
            ok = len(cs) == len(lo) and all(math.isfinite(v) and v > 0 for v in cs)
            if ok and len(set(cs)) == 1:
                cs = cs[0]
        if not ok:
            raise ConfigError("grid.cell_size", "must be finite and > 0 (one per axis or one)")
        shape = tuple(int(n) for n in self.shape)
        if len(shape) != len(lo) or min(shape) < 1:
            raise ConfigError("grid.shape", f"needs {len(lo)} positive cell counts, got {shape}")
        check_cell_count(shape, cs)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "cell_size", cs)
        object.__setattr__(self, "shape", shape)

    @classmethod
    def from_extent(
        cls,
        lower: Sequence[float],
        upper: Sequence[float],
        cell_size: float,
        rounding: Literal["floor", "ceil"] = "floor",
    ) -> CellGrid:
        """A grid of ``cell_size`` cells starting at ``lower`` and covering ``[lower, upper]``.

        ``rounding="floor"`` keeps ``int(extent / a)`` cells per axis (a strip narrower than a
        cell at the upper edge is left out, odor-path paper eq. 7); ``"ceil"`` covers the whole
        box (at least one cell per axis; the last cell may reach past ``upper``).
        """
        lo = np.asarray(lower, float)
        hi = np.asarray(upper, float)
        if lo.ndim != 1 or lo.shape != hi.shape or lo.size not in (2, 3):
            raise ConfigError("grid.lower", "lower and upper need 2 or 3 components each")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ConfigError("grid.upper", "bounds must be finite")
        if np.any(hi <= lo):
            raise ConfigError("grid.upper", f"must exceed lower in every axis ({hi} vs {lo})")
        if not (math.isfinite(cell_size) and cell_size > 0):
            raise ConfigError("grid.cell_size", "must be a finite number > 0")
        check_cell_count((hi - lo) / cell_size, cell_size)
        if rounding == "floor":
            # The small tolerance keeps 10 m / 0.05 m at 200 cells despite rounding.
            n = np.floor((hi - lo) / cell_size + 1e-9).astype(int)
            if np.any(n < 1):
                raise ConfigError("grid.cell_size", f"{cell_size} m is larger than the extent")
        else:
            n = np.maximum(1, np.ceil((hi - lo) / cell_size - 1e-9)).astype(int)
        return cls(tuple(float(v) for v in lo), float(cell_size), tuple(int(k) for k in n))

    # ------------------------------------------------------------------ geometry
    @property
    def dim(self) -> int:
        """Number of axes (2 or 3)."""
        return len(self.shape)

    @property
    def cells(self) -> FloatArray:
        """``(d,)`` cell side per axis, metres."""
        return np.broadcast_to(np.asarray(self.cell_size, float), (self.dim,)).copy()

    @property
    def nx(self) -> int:
        """Number of cells along x."""
        return self.shape[0]

    @property
    def ny(self) -> int:
        """Number of cells along y."""
        return self.shape[1]

    @property
    def n_cells(self) -> int:
        """Total number of cells."""
        return int(np.prod(self.shape))

    @property
    def upper(self) -> tuple[float, ...]:
        """Far corner of the last cell, metres."""
        c = self.cells
        return tuple(float(self.lower[a] + self.shape[a] * c[a]) for a in range(self.dim))

    @property
    def cell_volume(self) -> float:
        """Area (2D) or volume (3D) of one cell, m^d."""
        return float(np.prod(self.cells))

    def axis_centers(self, axis: int) -> FloatArray:
        """``(n_axis,)`` cell-centre coordinates along ``axis``, metres."""
        c = self.cell_size if isinstance(self.cell_size, float) else self.cell_size[axis]
        return self.lower[axis] + (np.arange(self.shape[axis]) + 0.5) * c

    def x_centers(self) -> FloatArray:
        """``(nx,)`` x coordinates of the cell centres, metres."""
        return self.axis_centers(0)

    def y_centers(self) -> FloatArray:
        """``(ny,)`` y coordinates of the cell centres, metres."""
        return self.axis_centers(1)

    def centers(self) -> FloatArray:
        """``(n1, ..., nd, d)`` cell centres, metres."""
        axes = [self.axis_centers(a) for a in range(self.dim)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def flat_centers(self) -> FloatArray:
        """``(n_cells, d)`` cell centres in C order, metres."""
        return self.centers().reshape(-1, self.dim)

    def index(self, points: ArrayLike, clip: bool = True) -> IntArray:
        """Index of the cell containing each point.

        Parameters
        ----------
        points : (Q, d) or (d,) array_like, metres
        clip : bool
            Clip into the grid (else points outside get indices outside ``[0, n)``).

        Returns
        -------
        (Q, d) int ndarray
        """
        p = np.atleast_2d(np.asarray(points, float))
        if p.ndim != 2 or p.shape[1] != self.dim:
            raise ConfigError("points", f"expected shape (Q, {self.dim}), got {np.shape(points)}")
        if not np.isfinite(p).all():
            # NaN would be cast to an arbitrary index (cell 0 after clipping) without a word
            raise ConfigError("points", "must be finite")
        idx = np.floor((p - np.asarray(self.lower)) / np.asarray(self.cell_size)).astype(np.intp)
        if clip:
            idx = np.clip(idx, 0, np.asarray(self.shape) - 1)
        return idx

    def center(self, idx: ArrayLike) -> FloatArray:
        """Centre of cell(s) ``idx``: ``(Q, d)`` metres."""
        i = np.atleast_2d(np.asarray(idx, float))
        return np.asarray(self.lower) + (i + 0.5) * np.asarray(self.cell_size)

    def contains(self, points: ArrayLike) -> NDArray[np.bool_]:
        """``True`` where a point lies inside the gridded box (upper faces excluded), ``(Q,)``."""
        p = np.atleast_2d(np.asarray(points, float))
        return np.all((p >= np.asarray(self.lower)) & (p < np.asarray(self.upper)), axis=1)

    def region_mask(self, region: Sequence[Sequence[float]] | None) -> NDArray[np.bool_]:
        """Mask of the cells whose centre lies in ``region = (lower, upper)`` (closed box).

        ``region`` may give only the first two axes (a horizontal region of a 3D grid); ``None``
        means the whole grid.
        """
        if region is None:
            return np.ones(self.shape, bool)
        lo = np.asarray(region[0], float)
        hi = np.asarray(region[1], float)
        k = lo.size
        if lo.shape != hi.shape or not 2 <= k <= self.dim or np.any(hi <= lo):
            raise ConfigError(
                "region", "needs (lower, upper) with 2 or 3 components, upper > lower"
            )
        mask = np.ones(self.shape, bool)
        for a in range(k):
            c = self.axis_centers(a)
            m = (c >= lo[a]) & (c <= hi[a])
            shape = [1] * self.dim
            shape[a] = len(c)
            mask &= m.reshape(shape)
        return mask

    def same_as(self, other: CellGrid) -> bool:
        """``True`` when both grids have the same corner, cell sizes and shape."""
        return (
            self.shape == other.shape
            and np.allclose(self.cells, other.cells, rtol=1e-12, atol=0.0)
            and np.allclose(self.lower, other.lower, rtol=0.0, atol=1e-9)
        )

    def interpolate(self, values: np.ndarray, points: ArrayLike) -> FloatArray:
        """Multilinear interpolation of cell-centre ``values`` ``(n1, ..., nd)`` at points.

        Returns
        -------
        (Q,) ndarray
            Edge values are held outside the lattice of cell centres.
        """
        v = np.asarray(values, float)
        if v.shape != self.shape:
            raise ConfigError("values", f"shape {v.shape} != grid {self.shape}")
        axes = [self.axis_centers(a) for a in range(self.dim)]
        pts = np.atleast_2d(np.asarray(points, float))
        return multilinear(v[..., None], axes, pts)[:, 0]


def multilinear(values: np.ndarray, axes: Sequence[np.ndarray], points: np.ndarray) -> FloatArray:
    """Multilinear interpolation of node values on a rectilinear lattice (held at the edges).

    Parameters
    ----------
    values : (n1, ..., nd, m) ndarray
        ``m`` components at each node.
    axes : sequence of d increasing (n_a,) ndarrays, metres
        Node coordinates per axis (an axis with one node is constant along it).
    points : (Q, d) ndarray, metres

    Returns
    -------
    (Q, m) ndarray
    """
    dim = len(axes)
    q = len(points)
    m = values.shape[-1]
    if HAVE_NUMBA and q >= _COMPILED_FROM and any(len(ax) > 1 for ax in axes):
        return _multilinear_compiled(values, axes, points)
    # One contiguous 1D array per component: 1D gathers are far cheaper than row gathers.
    comps = [np.ascontiguousarray(values[..., c]).ravel() for c in range(m)]
    strides = np.cumprod([1] + [len(ax) for ax in axes[:0:-1]])[::-1]
    base = np.zeros(q, np.intp)
    fs: list[np.ndarray | None] = []
    steps = []
    for a, ax in enumerate(axes):
        n = len(ax)
        if n == 1:
            fs.append(None)
            steps.append(0)
            continue
        h = (ax[-1] - ax[0]) / (n - 1)
        if float(np.abs(ax[1:] - ax[:-1] - h).max()) <= 1e-12 * abs(h):
            # Uniform axis: the cell index is arithmetic (no search).
            g = (points[:, a] - ax[0]) * (1.0 / h)
            i0 = np.clip(g, 0.0, n - 2).astype(np.intp)  # truncation == floor for g >= 0
        else:
            i0 = np.clip(np.searchsorted(ax, points[:, a], side="right") - 1, 0, n - 2)
        # From the node coordinates, so that a point on a node gets exactly that node's value.
        f = (points[:, a] - ax[i0]) / (ax[i0 + 1] - ax[i0])
        np.clip(f, 0.0, 1.0, out=f)
        base += i0 * int(strides[a])
        fs.append(f)
        steps.append(int(strides[a]))
    out = np.zeros((q, m))
    for corner in range(2**dim):
        w = None
        off = 0
        skip = False
        for a in range(dim):
            hi = (corner >> a) & 1
            fa = fs[a]
            if fa is None:
                skip = skip or bool(hi)
                continue
            wa = fa if hi else 1.0 - fa
            w = wa if w is None else w * wa
            off += hi * steps[a]
        if skip:
            continue
        idx = base + off if off else base
        for c in range(m):
            vals = comps[c][idx]
            out[:, c] += vals if w is None else w * vals
    return out


#: Points from which :func:`multilinear` runs compiled (below, NumPy's call overhead is small).
_COMPILED_FROM = 16


def _multilinear_compiled(
    values: np.ndarray, axes: Sequence[np.ndarray], points: np.ndarray
) -> FloatArray:
    """:func:`multilinear` in one compiled pass, equal to the NumPy code to the bit (the same
    operations in the same order per point). The axes' arrays are prepared once per axes
    objects (a wind field is interpolated at every step on the same axes)."""
    key = tuple(id(ax) for ax in axes)
    hit = _PREPARED.get(key)
    if hit is not None and all(a is b for a, b in zip(hit[0], axes, strict=True)):
        prepared = hit[1]
    else:
        prepared = _prepare(axes)
        if len(_PREPARED) >= 16:
            _PREPARED.clear()
        _PREPARED[key] = (tuple(axes), prepared)
    m = values.shape[-1]
    flat = np.ascontiguousarray(values, dtype=float).reshape(-1, m)
    pts = np.ascontiguousarray(points, dtype=float)
    if not pts.flags.writeable:
        pts = pts.copy()  # one compiled variant for the points (they are few)
    out = np.empty((len(pts), m))
    _multilinear_kernel(flat, *prepared, pts, out)
    return out


_PREPARED: dict[tuple[int, ...], tuple[tuple[np.ndarray, ...], tuple]] = {}


def _prepare(axes: Sequence[np.ndarray]) -> tuple:
    """The kernel's lattice arrays: padded axes, lengths, uniform flags, inverse steps and
    strides (as :func:`multilinear` computes them)."""
    dim = len(axes)
    nmax = max(len(ax) for ax in axes)
    ax2 = np.zeros((dim, nmax))
    lens = np.empty(dim, np.int64)
    uniform = np.zeros(dim, np.bool_)
    inv_h = np.ones(dim)
    for a, ax in enumerate(axes):
        n = len(ax)
        ax2[a, :n] = ax
        lens[a] = n
        if n > 1:
            h = (ax[-1] - ax[0]) / (n - 1)
            if float(np.abs(ax[1:] - ax[:-1] - h).max()) <= 1e-12 * abs(h):
                uniform[a] = True
                inv_h[a] = 1.0 / h
    strides = np.cumprod([1] + [len(ax) for ax in axes[:0:-1]])[::-1].astype(np.int64)
    return ax2, lens, uniform, inv_h, strides


def _multilinear_kernel(vals, ax, lens, uniform, inv_h, strides, pts, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    q, dim = pts.shape
    m = vals.shape[1]
    f = np.empty(dim)
    for i in range(q):
        base = 0
        for a in range(dim):
            n = lens[a]
            if n == 1:
                continue
            p = pts[i, a]
            if uniform[a]:
                g = (p - ax[a, 0]) * inv_h[a]
                g = min(max(g, 0.0), float(n - 2))
                i0 = int(g)
            else:
                i0 = np.searchsorted(ax[a, :n], p, side="right") - 1
                i0 = min(max(i0, 0), n - 2)
            fa = (p - ax[a, i0]) / (ax[a, i0 + 1] - ax[a, i0])
            f[a] = min(max(fa, 0.0), 1.0)
            base += i0 * strides[a]
        for c in range(m):
            out[i, c] = 0.0
        for corner in range(2**dim):
            w = 1.0
            first = True
            off = 0
            skip = False
            for a in range(dim):
                hi = (corner >> a) & 1
                if lens[a] == 1:
                    if hi:
                        skip = True
                    continue
                wa = f[a] if hi else 1.0 - f[a]
                if first:
                    w = wa
                    first = False
                else:
                    w = w * wa
                off += hi * strides[a]
            if skip:
                continue
            for c in range(m):
                out[i, c] += w * vals[base + off, c]


def _warm_multilinear(kernel: Any) -> None:
    """One call with the argument types :func:`_multilinear_compiled` uses (the values
    writable or read-only, as a wind field may be)."""
    prepared = _prepare([np.array([0.0, 1.0]), np.array([0.0, 1.0])])
    vals = np.zeros((4, 1))
    kernel(vals, *prepared, np.zeros((1, 2)), np.zeros((1, 1)))
    vals.setflags(write=False)
    kernel(vals, *prepared, np.zeros((1, 2)), np.zeros((1, 1)))


if HAVE_NUMBA:
    _multilinear_kernel = jit(_multilinear_kernel, warmup=_warm_multilinear)
