"""Bounded 2D/3D arenas with obstacles stored as an occupancy grid.

All queries are vectorised over points: ``points`` is a ``(Q, d)`` array in metres.
The occupancy grid ``occ`` has shape ``(nx, ny)`` or ``(nx, ny, nz)``: it lives on
:attr:`Arena.grid`, a :class:`~odorloc.geometry.grid.CellGrid` whose cell ``[i, j(, k)]`` covers
``lower + (i, j, k) * resolution`` to ``lower + (i+1, j+1, k+1) * resolution``.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.geometry.grid import MAX_GRID_CELLS, CellGrid, check_cell_count

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@lru_cache(maxsize=2)
def _corners(dim: int) -> NDArray[np.intp]:
    """``(dim, 2**dim)`` 0/1 choices per axis of the cells meeting at a cell corner."""
    c = np.array(list(itertools.product((0, 1), repeat=dim)), np.intp).T
    c.setflags(write=False)
    return c


def as_points(points: ArrayLike, dim: int, name: str = "points") -> FloatArray:
    """Return ``points`` as a float ``(Q, dim)`` array (a single point becomes ``(1, dim)``)."""
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != dim:
        raise ConfigError(name, f"expected shape (Q, {dim}), got {np.shape(points)}")
    return p


@dataclass(frozen=True, eq=False)
class Arena:
    """A rectangular (box) arena with an optional occupancy grid of obstacles.

    Parameters
    ----------
    lower, upper : (d,) sequence of float, metres
        Opposite corners of the arena, ``d`` in {2, 3}.
    resolution : float, metres
        Edge length of an occupancy cell.
    occ : (nx, ny[, nz]) bool ndarray, optional
        ``True`` where a cell is an obstacle. ``None`` means no obstacles.
    """

    lower: tuple[float, ...]
    upper: tuple[float, ...]
    resolution: float = 0.1
    occ: BoolArray | None = field(default=None, repr=False)
    grid: CellGrid = field(init=False, repr=False, compare=False)
    # the corners as read-only arrays (lo, hi), made once: point queries run every step
    _lo: FloatArray = field(init=False, repr=False, compare=False)
    _hi: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, float)
        hi = np.asarray(self.upper, float)
        if lo.ndim != 1 or lo.shape != hi.shape or lo.size not in (2, 3):
            raise ConfigError("arena.lower", "lower and upper must both have 2 or 3 components")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ConfigError("arena.upper", "bounds must be finite")
        if np.any(hi <= lo):
            raise ConfigError(
                "arena.upper",
                f"must exceed lower in every axis ({tuple(hi.tolist())} vs {tuple(lo.tolist())})",
            )
        if not (np.isfinite(self.resolution) and self.resolution > 0):
            raise ConfigError("arena.resolution", "must be a finite number > 0")
        object.__setattr__(self, "lower", tuple(float(x) for x in lo))
        object.__setattr__(self, "upper", tuple(float(x) for x in hi))
        check_cell_count((hi - lo) / self.resolution, self.resolution, "arena.resolution")
        shape = tuple(int(n) for n in np.maximum(1, np.ceil((hi - lo) / self.resolution - 1e-9)))
        object.__setattr__(self, "grid", CellGrid(self.lower, float(self.resolution), shape))
        for name, corner in (("_lo", self.lower), ("_hi", self.upper)):
            a = np.array(corner, float)
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.occ is not None:
            occ = np.asarray(self.occ, dtype=bool)
            if occ.shape != self.grid_shape:
                raise ConfigError(
                    "arena.occupancy", f"grid shape {occ.shape} != expected {self.grid_shape}"
                )
            occ = occ.copy()
            occ.setflags(write=False)
            object.__setattr__(self, "occ", occ if occ.any() else None)

    # ------------------------------------------------------------------ geometry
    @property
    def dim(self) -> int:
        """Number of spatial dimensions (2 or 3)."""
        return len(self.lower)

    @property
    def lo(self) -> FloatArray:
        """Lower corner as a read-only array, metres."""
        return self._lo

    @property
    def hi(self) -> FloatArray:
        """Upper corner as a read-only array, metres."""
        return self._hi

    @property
    def size(self) -> FloatArray:
        """Edge lengths ``upper - lower``, metres."""
        return self.hi - self.lo

    @property
    def grid_shape(self) -> tuple[int, ...]:
        """Shape of the occupancy grid: ``ceil(size / resolution)`` per axis."""
        return self.grid.shape

    def cell_centers(self) -> list[FloatArray]:
        """Per-axis coordinates of the occupancy cell centres, metres."""
        return [self.grid.axis_centers(a) for a in range(self.dim)]

    def cell_index(self, points: ArrayLike) -> NDArray[np.intp]:
        """Occupancy cell index of each point, clipped into the grid: ``(Q, d)`` int."""
        return self.grid.index(as_points(points, self.dim))

    # ------------------------------------------------------------------ queries
    def contains(self, points: ArrayLike) -> BoolArray:
        """``True`` where a point lies inside the bounds (closed box): ``(Q,)``."""
        p = as_points(points, self.dim)
        return ((p >= self.lo) & (p <= self.hi)).all(axis=1)

    def in_obstacle(self, points: ArrayLike) -> BoolArray:
        """``True`` where a point lies inside the bounds and in an occupied cell: ``(Q,)``."""
        p = as_points(points, self.dim)
        if self.occ is None:
            return np.zeros(len(p), dtype=bool)
        inside = self.contains(p)
        idx = self.cell_index(p)
        return inside & self.occ[tuple(idx.T)]

    def is_free(self, points: ArrayLike) -> BoolArray:
        """``True`` where a point is inside the bounds and not in an obstacle: ``(Q,)``."""
        p = as_points(points, self.dim)
        ok = self.contains(p)
        if self.occ is not None:
            ok &= ~self.occ[tuple(self.cell_index(p).T)]
        return ok

    def body_free(self, points: ArrayLike, radius: float) -> BoolArray:
        """``True`` where a body of ``radius`` centred on a point overlaps no obstacle cell.

        The body is a disc (2D) or ball (3D), as for platform collisions; it may touch an
        obstacle cell (to within a billionth of a cell, so that decimal coordinates exactly
        ``radius`` from a wall count as touching) but not reach into it. Bounds are not checked
        (see :meth:`distance_to_bounds`); a point outside them is not free.

        Parameters
        ----------
        points : (Q, d) array_like, metres
        radius : float, metres
            Body radius, >= 0 (0: the point itself, as :meth:`is_free`).

        Returns
        -------
        (Q,) bool ndarray
        """
        p = as_points(points, self.dim)
        ok = self.is_free(p)
        if self.occ is None or radius <= 0:
            return ok
        res = float(self.resolution)
        top = np.asarray(self.grid_shape) - 1
        reach = max(radius - 1e-9 * res, 0.0)
        for q in np.flatnonzero(ok):
            lo = np.clip(np.floor((p[q] - radius - self.lo) / res), 0, top).astype(np.intp)
            hi = np.clip(np.floor((p[q] + radius - self.lo) / res), 0, top).astype(np.intp)
            near = tuple(slice(int(i), int(j) + 1) for i, j in zip(lo, hi, strict=True))
            cells = np.argwhere(self.occ[near]) + lo
            if len(cells) == 0:
                continue
            # distance from the centre to the nearest point of each occupied cell
            c_lo = self.lo + cells * res
            gap = np.maximum(np.maximum(c_lo - p[q], p[q] - (c_lo + res)), 0.0)
            ok[q] = bool(np.all(np.einsum("ij,ij->i", gap, gap) >= reach * reach))
        return ok

    def segment_free(self, start: ArrayLike, end: ArrayLike) -> BoolArray:
        """``True`` where the straight segment from ``start`` to ``end`` stays in free space.

        Exact on the occupancy grid: every cell the segment passes through is checked (not
        samples along it), so no obstacle cell is skipped, however little of it the segment
        clips. A segment through the corner (or, in 3D, along the edge) where cells meet counts
        as touching all of them, so it cannot slip between two obstacle cells that share only
        a corner (a diagonal wall). ``start`` and ``end`` broadcast: ``(Q, d)`` or ``(d,)``.

        Returns
        -------
        (Q,) bool ndarray
        """
        a = as_points(start, self.dim, "start")
        b = as_points(end, self.dim, "end")
        if self.occ is None:
            # an empty box is convex: a segment stays inside when both its ends do
            return self.contains(a) & self.contains(b)
        a, b = np.broadcast_arrays(a, b)
        # the box is convex: a segment with both ends inside stays inside
        ok = self.contains(a) & self.contains(b)
        # segments already refused need no traversal (and a far-off end must not size it)
        b = np.where(ok[:, None], b, a)
        a = np.where(ok[:, None], a, self.lo)
        b = np.where(ok[:, None], b, self.lo)
        return ok & np.isinf(self._first_contact(a, b))

    def line_of_sight(self, start: ArrayLike, end: ArrayLike) -> BoolArray:
        """Alias of :meth:`segment_free`: nothing blocks the straight line between the points."""
        return self.segment_free(start, end)

    def first_hit(self, start: ArrayLike, end: ArrayLike) -> FloatArray:
        """Fraction ``s`` in [0, 1] of each segment that can be travelled before leaving free space.

        ``1.0`` means the whole segment is free; used by platforms to stop at walls. Otherwise
        ``s`` is the last of samples a tenth of a cell apart that lies before the segment first
        touches an obstacle cell (found exactly, as in :meth:`segment_free`) or leaves the
        bounds, so the stopping point is free and at most a tenth of a cell short of the wall.
        """
        a = as_points(start, self.dim, "start")
        b = as_points(end, self.dim, "end")
        a, b = np.broadcast_arrays(a, b)
        length = np.linalg.norm(b - a, axis=1)
        n = int(np.ceil(length.max(initial=0.0) / (0.1 * self.resolution))) + 1
        s = np.linspace(0.0, 1.0, max(n, 2))
        pts = a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]
        ok = self.is_free(pts.reshape(-1, self.dim)).reshape(len(a), -1)
        bad = ~ok
        first_bad = np.where(bad.any(axis=1), bad.argmax(axis=1), len(s))
        if self.occ is not None:
            # samples can straddle an obstacle corner: the first sample at or past the exact
            # first contact counts as blocked too
            finite = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
            t = self._first_contact(
                np.where(finite[:, None], a, self.lo), np.where(finite[:, None], b, self.lo)
            )
            first_bad = np.minimum(first_bad, np.searchsorted(s, t, side="left"))
        frac = np.where(first_bad >= len(s), 1.0, s[np.maximum(first_bad - 1, 0)])
        return np.where(first_bad == 0, 0.0, frac)

    def _first_contact(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """Parameter in [0, 1] where each segment ``a -> b`` first touches an occupied cell.

        Parameters
        ----------
        a, b : (Q, d) float ndarray, metres
            Finite segment ends; parts outside the grid are read from its edge cells.

        Returns
        -------
        (Q,) float ndarray
            ``inf`` for a segment that touches no occupied cell.
        """
        assert self.occ is not None
        res = float(self.resolution)
        top = np.asarray(self.grid_shape) - 1
        q, dim = a.shape
        ga = (a - self.lo) / res
        gb = (b - self.lo) / res
        fa, fb = np.floor(ga), np.floor(gb)
        # most calls are short moves far from any obstacle: look at the cells around them first
        near_lo = np.clip(np.minimum(fa, fb).min(axis=0, initial=np.inf) - 1, 0, top)
        near_hi = np.clip(np.maximum(fa, fb).max(axis=0, initial=-np.inf) + 1, 0, top)
        near = tuple(slice(int(i), int(j) + 1) for i, j in zip(near_lo, near_hi, strict=True))
        if q == 0 or not self.occ[near].any():
            return np.full(q, np.inf)
        # parameters where the segment crosses the cell faces of each axis; unused slots are 1
        ts = [np.zeros((q, 1)), np.ones((q, 1))]
        for ax in range(dim):
            cnt = np.abs(fb[:, ax] - fa[:, ax]).astype(np.intp)
            k = int(cnt.max(initial=0))
            if k == 0:
                continue
            m = np.arange(1, k + 1)
            up = (fb[:, ax] >= fa[:, ax])[:, None]
            plane = fa[:, ax, None] + np.where(up, m, 1 - m)
            span = np.where(cnt > 0, gb[:, ax] - ga[:, ax], 1.0)[:, None]
            ts.append(np.where(m <= cnt[:, None], (plane - ga[:, ax, None]) / span, 1.0))
        t = np.sort(np.concatenate(ts, axis=1), axis=1)
        # crossings closer than a billionth of a cell are one: the segment passes a corner
        length = np.linalg.norm(b - a, axis=1)
        tol = 1e-9 * res / np.maximum(length, 1e-300)
        valid = np.diff(t, axis=1) > tol[:, None]
        mid = 0.5 * (t[:, :-1] + t[:, 1:])
        pts = a[:, None, :] + mid[..., None] * (b - a)[:, None, :]
        cells = np.concatenate([ga[:, None, :], (pts - self.lo) / res, gb[:, None, :]], axis=1)
        cells = np.clip(np.floor(cells), 0, top).astype(np.intp)
        keep = np.concatenate([np.ones((q, 1), bool), valid, np.ones((q, 1), bool)], axis=1)
        # where each element of the sequence (start cell, intervals, end cell) is left
        leave = np.concatenate([np.zeros((q, 1)), t[:, 1:], np.ones((q, 1))], axis=1)
        # an interval too short to count takes the cell before it
        pos = np.maximum.accumulate(np.where(keep, np.arange(keep.shape[1]), 0), axis=1)
        cells = np.take_along_axis(cells, pos[..., None], axis=1)
        flat = self.occ.ravel()
        strides = np.cumprod((1, *self.grid_shape[:0:-1]))[::-1]
        lin = cells @ strides
        # consecutive cells differ in several axes only at a shared corner or edge: every
        # cell meeting there is touched
        step = (cells[:, 1:] - cells[:, :-1]) * strides
        touched = lin[:, :-1, None] + step @ _corners(dim)
        hit = np.concatenate([flat[lin[:, :1]], flat[touched].any(axis=2)], axis=1)
        # contact is made where the last cell kept before the touched one is left: the first
        # of crossings merged at a corner
        first = hit.argmax(axis=1)
        rows = np.arange(q)
        before = pos[rows, np.maximum(first - 1, 0)]
        contact = np.where(first == 0, 0.0, leave[rows, before])
        return np.where(hit.any(axis=1), contact, np.inf)

    def horizontal_slice(self, z: float) -> Arena:
        """The 2D arena of the layer of cells holding height ``z`` (metres, clipped into the
        grid); a 2D arena is its own slice."""
        if self.dim == 2:
            return self
        k = int(self.grid.index([[self.lower[0], self.lower[1], float(z)]])[0, 2])
        occ = None if self.occ is None else self.occ[:, :, k]
        return Arena(self.lower[:2], self.upper[:2], self.resolution, occ)

    def clip(self, points: ArrayLike) -> FloatArray:
        """Points clipped into the bounds (not out of obstacles), ``(Q, d)``."""
        return np.clip(as_points(points, self.dim), self.lo, self.hi)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def box(cls, lower: Sequence[float], upper: Sequence[float], resolution: float = 0.1) -> Arena:
        """An empty box arena."""
        return cls(tuple(lower), tuple(upper), resolution)

    def with_boxes(self, boxes: Sequence[tuple[Sequence[float], Sequence[float]]]) -> Arena:
        """A copy with axis-aligned box obstacles ``[(lower, upper), ...]`` marked occupied.

        A cell is occupied when its centre lies inside a box. Along an axis where a box inside
        the bounds is too thin to hold a cell centre, the cells whose centres are nearest its
        middle are marked instead, so a wall thinner than a cell is kept one cell thick rather
        than dropped.
        """
        occ = np.zeros(self.grid_shape, bool) if self.occ is None else self.occ.copy()
        centers = self.cell_centers()
        for k, (blo, bhi) in enumerate(boxes):
            blo_a, bhi_a = np.asarray(blo, float), np.asarray(bhi, float)
            if blo_a.shape != (self.dim,) or bhi_a.shape != (self.dim,):
                raise ConfigError(
                    f"obstacles.boxes[{k}]", f"box corners need {self.dim} components"
                )
            if not (np.all(np.isfinite(blo_a)) and np.all(np.isfinite(bhi_a))):
                raise ConfigError(f"obstacles.boxes[{k}]", "box corners must be finite")
            if np.any(bhi_a <= blo_a):
                raise ConfigError(f"obstacles.boxes[{k}]", "box upper corner must exceed lower")
            inside = np.ones(self.grid_shape, bool)
            for a in range(self.dim):
                rows = (centers[a] >= blo_a[a]) & (centers[a] <= bhi_a[a])
                if not rows.any() and blo_a[a] < self.upper[a] and bhi_a[a] > self.lower[a]:
                    mid = 0.5 * (max(blo_a[a], self.lower[a]) + min(bhi_a[a], self.upper[a]))
                    rows[int(np.argmin(np.abs(centers[a] - mid)))] = True
                shape = [1] * self.dim
                shape[a] = len(rows)
                inside &= rows.reshape(shape)
            occ |= inside
        return Arena(self.lower, self.upper, self.resolution, occ)

    def with_polygons(self, polygons: Sequence[Sequence[Sequence[float]]]) -> Arena:
        """A copy with 2D polygon obstacles (vertex lists, metres); in 3D they span all heights.

        A cell is occupied when its centre lies inside a polygon. As for boxes, a polygon (or a
        part of one) too thin to hold a cell centre is not dropped: every chord the polygon cuts
        from a row or column of cell centres marks at least the cell holding its middle (a
        polygon crossing no such line marks the cell holding the middle of its extent). A thin
        wall at any angle thus stays a chain of cells meeting at least at their corners, which
        neither :meth:`segment_free` nor the A* planner passes.
        """
        from matplotlib.path import Path as MplPath

        occ = np.zeros(self.grid_shape, bool) if self.occ is None else self.occ.copy()
        cx, cy = self.cell_centers()[:2]
        gx, gy = np.meshgrid(cx, cy, indexing="ij")
        xy = np.column_stack([gx.ravel(), gy.ravel()])
        for k, poly in enumerate(polygons):
            v = np.asarray(poly, float)
            if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
                raise ConfigError(f"obstacles.polygons[{k}]", "need at least 3 (x, y) vertices")
            if not np.all(np.isfinite(v)):
                raise ConfigError(f"obstacles.polygons[{k}]", "vertices must be finite")
            inside = MplPath(v).contains_points(xy).reshape(gx.shape)
            inside |= self._chord_cells(v)
            occ |= inside[..., None] if self.dim == 3 else inside
        return Arena(self.lower, self.upper, self.resolution, occ)

    def _chord_cells(self, v: FloatArray) -> BoolArray:
        """Horizontal cells holding the middle of each chord of polygon ``v`` along a line of
        cell centres.

        Parameters
        ----------
        v : (V, 2) float ndarray, metres
            Polygon vertices (closed implicitly; even-odd rule).

        Returns
        -------
        (nx, ny) bool ndarray
        """
        shape = self.grid_shape[:2]
        marked = np.zeros(shape, bool)
        lo, hi = self.lo[:2], self.hi[:2]
        res = float(self.resolution)
        p, q = v, np.roll(v, -1, axis=0)
        crossed = False
        for a in (0, 1):
            b = 1 - a
            c = self.grid.axis_centers(b)[:, None]  # (L, 1): the lines b = c
            # half-open crossing rule: a vertex on a line is counted once, edges along it never
            crosses = ((p[:, b] <= c) & (c < q[:, b])) | ((q[:, b] <= c) & (c < p[:, b]))
            if not crosses.any():
                continue
            crossed = True
            span = np.where(crosses, q[:, b] - p[:, b], 1.0)
            at = np.where(crosses, p[:, a] + (c - p[:, b]) * (q[:, a] - p[:, a]) / span, np.inf)
            at = np.sort(at, axis=1)[:, : int(crosses.sum(axis=1).max())]
            # consecutive crossings pair up into the chords inside the polygon
            c0, c1 = at[:, 0::2], at[:, 1::2]
            ok = np.isfinite(c1) & (c1 > lo[a]) & (c0 < hi[a])
            mid = 0.5 * (np.maximum(c0, lo[a]) + np.minimum(c1, hi[a]))
            line, _ = np.nonzero(ok)
            cell = np.clip(np.floor((mid[ok] - lo[a]) / res), 0, shape[a] - 1).astype(np.intp)
            idx = [line, line]
            idx[a] = cell
            marked[tuple(idx)] = True
        vlo, vhi = np.maximum(v.min(axis=0), lo), np.minimum(v.max(axis=0), hi)
        if not crossed and np.all(vlo < vhi):
            # smaller than a cell on both axes, between lines of centres: the cell of a vertex
            # in the arena (on the polygon, so the cell touches it), else of its extent's middle
            held = np.all((v >= lo) & (v <= hi), axis=1)
            point = v[int(np.argmax(held))] if held.any() else 0.5 * (vlo + vhi)
            cell = np.clip(np.floor((point - lo) / res), 0, np.array(shape) - 1)
            marked[tuple(cell.astype(np.intp))] = True
        return marked

    @classmethod
    def from_grid(
        cls,
        grid: ArrayLike,
        resolution: float,
        origin: Sequence[float] = (0.0, 0.0),
    ) -> Arena:
        """An arena whose bounds are those of an occupancy grid ``grid[i, j]`` (x index first)."""
        g = np.asarray(grid).astype(bool)
        if g.ndim not in (2, 3):
            raise ConfigError("occupancy", f"grid must be 2D or 3D, got {g.ndim}D")
        lo = np.asarray(origin, float)[: g.ndim]
        if lo.size != g.ndim:
            raise ConfigError("origin", f"needs {g.ndim} components")
        hi = lo + np.asarray(g.shape) * resolution
        return cls(tuple(lo), tuple(hi), resolution, g)

    @classmethod
    def from_csv(
        cls, path: str | Path, resolution: float, origin: Sequence[float] = (0.0, 0.0)
    ) -> Arena:
        """Load a 2D occupancy grid from CSV.

        Rows are y (the top row is the largest y), columns x; non-zero cells are obstacles.

        Raises
        ------
        ConfigError
            ``occupancy_file``: unreadable, not UTF-8 text, more than
            :data:`~odorloc.geometry.grid.MAX_GRID_CELLS` cells, ragged rows or a cell that is
            not a finite number (named by row and column).
        """
        from odorloc.core.loading import read_text

        text = read_text(path, "occupancy_file")
        rows: list[list[float]] = []
        n_cells = 0
        for i, r in enumerate(csv.reader(text.splitlines())):
            if not r:
                continue
            n_cells += len(r)
            if n_cells > MAX_GRID_CELLS:
                raise ConfigError("occupancy_file", f"{path} has more than {MAX_GRID_CELLS} cells")
            row = []
            for j, c in enumerate(r):
                try:
                    v = float(c)
                except ValueError:
                    v = math.nan
                if not math.isfinite(v):
                    raise ConfigError(
                        "occupancy_file",
                        f"{path} row {i + 1}, column {j + 1}: {c.strip()[:20]!r} is not a "
                        "finite number",
                    ) from None
                row.append(v)
            rows.append(row)
        if not rows or len({len(r) for r in rows}) != 1:
            raise ConfigError("occupancy_file", f"{path}: rows must be non-empty and equal length")
        img = np.asarray(rows) != 0
        return cls.from_grid(img[::-1].T, resolution, origin)

    @classmethod
    def from_image(
        cls,
        path: str | Path,
        resolution: float,
        origin: Sequence[float] = (0.0, 0.0),
        threshold: float = 0.5,
    ) -> Arena:
        """Load a 2D occupancy grid from an image (ROS map style: dark pixels are obstacles).

        Raises
        ------
        ConfigError
            ``occupancy_file``: not an image, unreadable, or more than
            :data:`~odorloc.geometry.grid.MAX_GRID_CELLS` pixels.
        """
        import warnings

        from PIL import Image

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                with Image.open(path) as im:
                    w, h = im.size
                    if w * h > MAX_GRID_CELLS:
                        raise ConfigError(
                            "occupancy_file",
                            f"{path} has {w} x {h} pixels; at most {MAX_GRID_CELLS}",
                        )
                    img = np.asarray(im.convert("L"), float) / 255.0
        except (OSError, ValueError, SyntaxError, Image.DecompressionBombWarning) as exc:
            if isinstance(exc, ConfigError):
                raise
            reason = " ".join(str(exc).split())[:120] or type(exc).__name__
            raise ConfigError("occupancy_file", f"cannot read image {path}: {reason}") from None
        return cls.from_grid((img < threshold)[::-1].T, resolution, origin)

    def distance_to_bounds(self, points: ArrayLike) -> FloatArray:
        """Distance of each point to the nearest arena face (negative outside), ``(Q,)``."""
        p = as_points(points, self.dim)
        return np.minimum(p - self.lo, self.hi - p).min(axis=1)
