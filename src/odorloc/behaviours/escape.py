"""Escaping to a free direction: the first candidate motion that walls and obstacles allow.

- :func:`first_free`: the first of candidate displacements whose straight motion stays free;
- :func:`free_move`: a step along a direction or its nearest free rotation (0, +-45, +-90,
  +-135, 180 degrees), optionally escaping at random when all of those are blocked;
- :func:`escape_move`: a step in a random one of 16 horizontal directions (the first free one
  of a random order), for an agent boxed in by obstacles.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import fan, ring

__all__ = ["TURNS", "escape_move", "first_free", "free_move", "free_step"]

#: Rotations (degrees) tried in order by :func:`free_move`: the nearest first.
TURNS = (0, 45, -45, 90, -90, 135, -135, 180)


def first_free(arena: Arena, start: ArrayLike, displacements: ArrayLike) -> int | None:
    """Index of the first displacement whose straight motion from ``start`` stays free.

    Parameters
    ----------
    arena : Arena
    start : (d,) array_like, metres
    displacements : (K, d) array_like, metres
        Candidate motions in order of preference.

    Returns
    -------
    int or None
        ``None`` when every candidate is blocked.
    """
    p = np.asarray(start, float)
    disp = np.atleast_2d(np.asarray(displacements, float))
    if len(disp) == 0:
        return None
    ok = arena.segment_free(p, p + disp)
    hit = np.flatnonzero(ok)
    return int(hit[0]) if hit.size else None


def free_step(arena: Arena, pos: ArrayLike, direction: ArrayLike, length: float) -> bool:
    """``True`` when moving ``length`` metres from ``pos`` along ``direction`` stays free."""
    d = np.asarray(direction, float)
    n = float(np.linalg.norm(d))
    if n == 0:
        return True
    return first_free(arena, pos, d / n * length) is not None


def escape_move(
    arena: Arena, pos: ArrayLike, length: float, rng: np.random.Generator
) -> np.ndarray | None:
    """A free displacement ``(d,)`` of ``length`` metres in one of 16 horizontal directions,
    tried in a random order (one permutation drawn from ``rng``); ``None`` when boxed in."""
    moves = ring(16, arena.dim)[rng.permutation(16)] * length
    k = first_free(arena, pos, moves)
    return None if k is None else moves[k]


def free_move(
    arena: Arena,
    pos: ArrayLike,
    direction: ArrayLike,
    length: float,
    rng: np.random.Generator | None = None,
) -> np.ndarray | None:
    """A free displacement ``(d,)`` of ``length`` metres along ``direction`` or its nearest free
    rotation (:data:`TURNS`); when all of those are blocked, :func:`escape_move` with ``rng``
    (``None``: no escape). ``None`` when nothing is free."""
    cand = np.array(
        [d / max(float(np.linalg.norm(d)), 1e-12) * length for d in fan(direction, TURNS)]
    )
    k = first_free(arena, pos, cand)
    if k is not None:
        return cand[k]
    return None if rng is None else escape_move(arena, pos, length, rng)
