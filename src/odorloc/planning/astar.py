"""A* shortest paths on an arena's occupancy grid (2D or 3D), with line-of-sight smoothing.

Used by searchers when a move or waypoint target is not in line of sight: the path goes through
the centres of free cells (8-connected in 2D, 26-connected in 3D, no corner cutting past
obstacle cells) and is then shortened by dropping waypoints that the previous kept waypoint
sees directly (:meth:`Arena.segment_free`), so every leg of the returned path is free.
"""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena

__all__ = ["astar_path", "free_grid", "path_length", "smooth_path"]


def free_grid(arena: Arena, clearance: float = 0.0) -> np.ndarray:
    """Free-cell mask of the arena, obstacles grown by ``clearance`` metres, ``grid_shape`` bool."""
    occ = np.zeros(arena.grid_shape, bool) if arena.occ is None else arena.occ.copy()
    r = math.ceil(clearance / arena.resolution - 1e-9) if clearance > 0 else 0
    if r and occ.any():
        grown = occ.copy()
        for off in itertools.product(range(-r, r + 1), repeat=arena.dim):
            if sum(o * o for o in off) > r * r or not any(off):
                continue
            src = tuple(
                slice(max(0, -o), n - max(0, o)) for o, n in zip(off, occ.shape, strict=True)
            )
            dst = tuple(
                slice(max(0, o), n - max(0, -o)) for o, n in zip(off, occ.shape, strict=True)
            )
            grown[dst] |= occ[src]
        occ = grown
    return ~occ


def path_length(path: np.ndarray) -> float:
    """Length of a polyline ``(K, d)``, metres."""
    p = np.asarray(path, float)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def smooth_path(arena: Arena, path: np.ndarray) -> np.ndarray:
    """Drop intermediate waypoints visible from the last kept one, ``(K', d)`` metres."""
    p = np.asarray(path, float)
    if len(p) <= 2:
        return p
    keep = [0]
    i = 0
    while i < len(p) - 1:
        # The farthest later waypoint still in line of sight of p[i].
        vis = arena.segment_free(p[i], p[i + 1 :])
        j = i + 1
        if vis.any():
            j = i + 1 + int(np.flatnonzero(vis)[-1])
        keep.append(j)
        i = j
    return p[keep]


def astar_path(
    arena: Arena,
    start: np.ndarray,
    goal: np.ndarray,
    *,
    clearance: float = 0.0,
    smooth: bool = True,
) -> np.ndarray | None:
    """Shortest free path from ``start`` to ``goal`` on the occupancy grid.

    Parameters
    ----------
    arena : Arena
    start, goal : (d,) ndarray, metres
    clearance : float, metres
        Obstacles are grown by this much for planning (the start/goal cells stay allowed): the
        direct segment, the A* cells and the smoothed legs all keep out of the grown obstacles.
        When no path keeps that clearance, a free direct segment is still returned.
    smooth : bool
        Shorten with :func:`smooth_path`.

    Returns
    -------
    (K, d) ndarray or None
        Waypoints from ``start`` to ``goal`` inclusive; ``None`` when the goal is outside the
        arena, in an obstacle, or unreachable.
    """
    s = np.asarray(start, float)
    g = np.asarray(goal, float)
    if s.shape != (arena.dim,) or g.shape != (arena.dim,):
        raise ConfigError("start", f"start and goal need {arena.dim} components")
    if not arena.is_free(g)[0]:
        return None
    direct = bool(arena.segment_free(s, g)[0])
    if direct and clearance <= 0:
        return np.stack([s, g])
    free = free_grid(arena, clearance)
    si = tuple(int(v) for v in arena.cell_index(s)[0])
    gi = tuple(int(v) for v in arena.cell_index(g)[0])
    free[si] = True
    free[gi] = True
    # line-of-sight tests (direct segment, smoothing) must respect the grown obstacles too,
    # or the shortcuts would cut back to the raw obstacle edges
    plan_arena = (
        arena if clearance <= 0 else Arena(arena.lower, arena.upper, arena.resolution, ~free)
    )
    if direct and plan_arena.segment_free(s, g)[0]:
        return np.stack([s, g])
    shape = free.shape
    offsets = [o for o in itertools.product((-1, 0, 1), repeat=arena.dim) if any(o)]
    costs = [math.sqrt(sum(v * v for v in o)) for o in offsets]

    def h(c: tuple[int, ...]) -> float:
        return math.sqrt(sum((a - b) ** 2 for a, b in zip(c, gi, strict=True)))

    best = {si: 0.0}
    parent: dict[tuple[int, ...], tuple[int, ...]] = {}
    heap = [(h(si), 0.0, si)]
    closed: set[tuple[int, ...]] = set()
    found = False
    while heap:
        _, cost, cell = heapq.heappop(heap)
        if cell in closed:
            continue
        if cell == gi:
            found = True
            break
        closed.add(cell)
        for off, step in zip(offsets, costs, strict=True):
            nb = tuple(c + o for c, o in zip(cell, off, strict=True))
            if any(v < 0 or v >= n for v, n in zip(nb, shape, strict=True)) or not free[nb]:
                continue
            # No corner cutting: every axis-aligned neighbour spanned by a diagonal must be free.
            if sum(1 for o in off if o) > 1 and not all(
                free[
                    tuple(
                        c + (o if a == b else 0)
                        for b, (c, o) in enumerate(zip(cell, off, strict=True))
                    )
                ]
                for a in range(len(off))
                if off[a]
            ):
                continue
            nc = cost + step
            if nc < best.get(nb, math.inf):
                best[nb] = nc
                parent[nb] = cell
                heapq.heappush(heap, (nc + h(nb), nc, nb))
    if not found:
        # the clearance is a preference: a goal in plain sight is still reached
        return np.stack([s, g]) if direct else None
    cells = [gi]
    while cells[-1] != si:
        cells.append(parent[cells[-1]])
    cells.reverse()
    centres = arena.lo + (np.asarray(cells, float) + 0.5) * arena.resolution
    path = np.concatenate([s[None], centres[1:-1], g[None]], axis=0)
    return smooth_path(plan_arena, path) if smooth else path
