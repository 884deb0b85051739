"""Escaping to a free direction: the first candidate motion that walls and obstacles allow."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from odorloc.geometry.arena import Arena

__all__ = ["first_free", "free_step"]


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
