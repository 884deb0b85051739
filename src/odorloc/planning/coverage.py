"""Coverage patterns: the rectangular wave (boustrophedon lanes) and its repeated rounds.

In an arena with obstacles the straight legs of the pattern are routed around them
(:func:`route_around_obstacles`): every free stretch of a lane is still swept, the stretches
joined by A* paths.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.core.types import Region
from odorloc.geometry.arena import Arena
from odorloc.planning.astar import astar_path

__all__ = ["free_stretches", "rectangular_wave", "route_around_obstacles", "wave_waypoints"]

FloatArray = NDArray[np.float64]


def rectangular_wave(
    lower: Sequence[float],
    upper: Sequence[float],
    spacing: float,
    along: str,
    start: Sequence[float] | None = None,
) -> np.ndarray:
    """Waypoints of one boustrophedon pass, ``(W, 2)`` metres.

    Lanes are ``spacing`` apart across the region; the pass starts at the corner nearest to
    ``start`` when given.
    """
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    across = 0 if along == "y" else 1
    long = 1 - across
    n_lanes = math.floor((hi[across] - lo[across]) / spacing + 1e-9) + 1
    lanes = lo[across] + spacing * np.arange(n_lanes)
    if start is not None and abs(start[across] - hi[across]) < abs(start[across] - lo[across]):
        lanes = lanes[::-1]
    first_at_hi = start is not None and abs(start[long] - hi[long]) < abs(start[long] - lo[long])
    pts = []
    for i, c in enumerate(lanes):
        ends = [lo[long], hi[long]]
        if (i % 2 == 1) != first_at_hi:
            ends = ends[::-1]
        for e in ends:
            p = np.zeros(2)
            p[across], p[long] = c, e
            pts.append(p)
    return np.array(pts)


def wave_waypoints(
    region: Region,
    lane_spacing: float,
    lanes_along: str,
    rounds: int,
    start: ArrayLike,
    margin: float = 0.0,
    round_order: str = "restart",
    arena: Arena | None = None,
) -> FloatArray:
    """Corners of the rectangular-wave path over all rounds, ``(W, 2)`` metres.

    Parameters
    ----------
    region : ((x0, y0), (x1, y1)), metres
    lane_spacing : float, metres
    lanes_along : {"x", "y"}
    rounds : int
    start : (2,) array_like, metres
        The first round starts at the region corner nearest to it.
    margin : float, metres
        Distance kept from the region's edges.
    round_order : {"restart", "alternate"}
        ``"restart"``: every round ends at the corner diagonally opposite its first corner and
        goes straight back to it (D-S paper, section 4.2: "when the robot arrives at the
        left-top corner (called 1 round) ... the robot comes back to the right-bottom corner,
        and starts a new round"; the last lane is extended to that corner if needed);
        ``"alternate"``: every other round is run backwards.
    arena : Arena, optional
        A 2D arena (the horizontal slice the path is flown in): legs its obstacles block are
        routed around them from ``start`` (:func:`route_around_obstacles`). Without it, or
        without obstacles in the way, the corners are returned as they are.
    """
    lo = np.asarray(region[0], float) + margin
    hi = np.asarray(region[1], float) - margin
    if np.any(hi <= lo):
        raise ConfigError("searcher.margin", "leaves no area to cover")
    start2 = np.asarray(start, float)[:2]
    one = rectangular_wave(lo, hi, lane_spacing, lanes_along, start2)
    if round_order == "alternate":
        path = np.concatenate([one if r % 2 == 0 else one[::-1] for r in range(rounds)])
    else:
        # "arrives at the left-top corner (called 1 round) ... comes back to the right-bottom
        # corner, and starts a new round" (section 4.2)
        opposite = lo + hi - one[0]
        if not np.allclose(one[-1], opposite):
            one = np.vstack([one, opposite])
        path = np.concatenate([one] * rounds)
    return path if arena is None else route_around_obstacles(arena, path, start2)


def free_stretches(arena: Arena, a: ArrayLike, b: ArrayLike) -> list[tuple[FloatArray, FloatArray]]:
    """The free stretches of the straight leg ``a -> b``, in order from ``a``.

    Parameters
    ----------
    arena : Arena
        2D arena.
    a, b : (2,) array_like, metres

    Returns
    -------
    list of ((2,) ndarray, (2,) ndarray)
        First and last point of each stretch, metres: the leg itself when it is free, else
        the runs of free points sampled a quarter of a cell apart (ends included), so a stretch
        ends at most a quarter of a cell before an obstacle or the arena's edge.
    """
    p, q = np.asarray(a, float), np.asarray(b, float)
    if bool(arena.segment_free(p, q)[0]):
        return [(p, q)]
    n = math.ceil(float(np.linalg.norm(q - p)) / (0.25 * arena.resolution)) + 1
    pts = p + np.linspace(0.0, 1.0, max(n, 2))[:, None] * (q - p)
    free = arena.is_free(pts)
    # run starts and ends: where the free flag switches on and off
    edges = np.diff(np.concatenate([[False], free, [False]]).astype(np.int8))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(pts[i], pts[j]) for i, j in zip(first, last, strict=True)]


def route_around_obstacles(arena: Arena, waypoints: ArrayLike, start: ArrayLike) -> FloatArray:
    """A corner path with its legs routed around the obstacles of a 2D arena.

    Every leg is cut into its :func:`free_stretches`; the stretches are travelled in order,
    each reached from where the previous one ended (at first: from ``start``) straight when
    that is free, else along an A* path (:func:`~odorloc.planning.astar.astar_path`). A lane
    that an obstacle cuts is thus swept on both sides of it, and a stretch that cannot be
    reached at all is left out. When every leg (and the way from ``start`` to the first
    corner) is free, the corners are returned unchanged.

    Parameters
    ----------
    arena : Arena
        2D arena.
    waypoints : (W, 2) array_like, metres
        Corners of the path.
    start : (2,) array_like, metres
        Where the path is entered from (not part of the result).

    Returns
    -------
    (W', 2) ndarray, metres
        Waypoints whose consecutive legs (and the first, from ``start``) are free.
    """
    w = np.asarray(waypoints, float)
    s = np.asarray(start, float)[:2]
    if arena.dim != 2:
        raise ConfigError("arena", "routing a coverage path needs a 2D arena (a slice)")
    if arena.occ is None or len(w) == 0:
        return w
    legs = np.vstack([s, w])
    if arena.is_free(w).all() and arena.segment_free(legs[:-1], legs[1:]).all():
        return w
    out: list[FloatArray] = []
    cur = s
    # rounds repeat the same legs: each detour is planned once
    detours: dict[tuple[float, ...], FloatArray | None] = {}

    def go(target: FloatArray) -> None:
        nonlocal cur
        if np.array_equal(cur, target):
            return
        if bool(arena.segment_free(cur, target)[0]):
            out.append(target)
        else:
            key = (*cur.tolist(), *target.tolist())
            if key not in detours:
                detours[key] = astar_path(arena, cur, target)
            path = detours[key]
            if path is None:
                return  # unreachable from here: left out
            out.extend(path[1:])
        cur = target

    for p, q in itertools.pairwise(w):
        for a, b in free_stretches(arena, p, q):
            go(a)
            go(b)
    if len(w) == 1 and arena.is_free(w)[0]:
        go(w[0])
    return np.array(out, float).reshape(-1, 2)
