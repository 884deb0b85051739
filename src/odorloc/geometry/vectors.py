"""Small vector helpers shared by behaviours, planners and platforms.

Angles are in radians, measured in the horizontal plane from the x axis, counter-clockwise.
Vectors are 2D or 3D; horizontal operations act on the first two components only.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError

__all__ = [
    "directions_26",
    "fan",
    "heading_vector",
    "lattice_moves",
    "ring",
    "rotate2",
    "upwind_unit",
    "wrap_angle",
]

FloatArray = NDArray[np.float64]


def wrap_angle(a: float) -> float:
    """Angle ``a`` (rad) wrapped into ``(-pi, pi]``."""
    w = math.remainder(a, 2.0 * math.pi)
    return math.pi if w == -math.pi else w


def rotate2(v: ArrayLike, angle: float) -> FloatArray:
    """A copy of ``v`` with its first two components rotated by ``angle`` rad (anticlockwise)."""
    src = np.asarray(v, float)
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(src, float)
    out[0], out[1] = c * src[0] - s * src[1], s * src[0] + c * src[1]
    return out


def heading_vector(heading: float, dim: int) -> FloatArray:
    """Horizontal unit vector along ``heading`` rad, ``(dim,)``."""
    u = np.zeros(dim)
    u[0], u[1] = math.cos(heading), math.sin(heading)
    return u


def upwind_unit(wind: ArrayLike, fallback_heading: float) -> FloatArray:
    """Horizontal unit vector pointing against ``wind`` (``(d,)`` m/s), ``(d,)``.

    In calm air (horizontal speed below 1e-9 m/s) the direction of ``fallback_heading`` rad is
    returned instead.

    Raises
    ------
    ConfigError
        If the horizontal wind is not finite (a NaN would otherwise read as calm air).
    """
    w = np.asarray(wind, float)
    u = np.zeros(len(w))
    n = math.hypot(w[0], w[1])
    if not math.isfinite(n):
        raise ConfigError("wind", f"must be finite, got {w.tolist()}")
    if n > 1e-9:
        u[:2] = -w[:2] / n
    else:
        u[:2] = [math.cos(fallback_heading), math.sin(fallback_heading)]
    return u


def ring(n: int, dim: int, offset: float = 0.0) -> FloatArray:
    """``n`` horizontal unit vectors at angles ``offset + 2 pi k / n``, ``(n, dim)``."""
    if n < 1:
        raise ConfigError("n", "must be >= 1")
    a = offset + np.arange(n) * (2.0 * math.pi / n)
    out = np.zeros((n, dim))
    out[:, 0], out[:, 1] = np.cos(a), np.sin(a)
    return out


def fan(base: ArrayLike, turns_deg: Sequence[float]) -> FloatArray:
    """``base`` rotated by each angle of ``turns_deg`` (degrees, in order), ``(K, d)``."""
    return np.array([rotate2(base, math.radians(t)) for t in turns_deg])


@lru_cache(maxsize=8)
def _lattice(dim: int, stay: bool) -> FloatArray:
    moves = np.zeros((2 * dim + int(stay), dim))
    for a in range(2 * dim):
        moves[a, a // 2] = -1.0 if a % 2 == 0 else 1.0
    moves.setflags(write=False)
    return moves


def lattice_moves(dim: int, stay: bool = False) -> FloatArray:
    """The ``2 dim`` unit lattice moves, ``(2 dim [+1], dim)``.

    Move ``a`` goes along axis ``a // 2``, towards lower coordinates when ``a`` is even
    (``-x, +x, -y, +y[, -z, +z]``); with ``stay`` a zero move is appended.
    """
    if dim not in (2, 3):
        raise ConfigError("dim", f"must be 2 or 3, got {dim}")
    return _lattice(dim, stay)


@lru_cache(maxsize=1)
def _dirs26() -> FloatArray:
    v = np.array([p for p in itertools.product((-1, 0, 1), repeat=3) if any(p)], float)
    v /= np.linalg.norm(v, axis=1)[:, None]
    v.setflags(write=False)
    return v


def directions_26() -> FloatArray:
    """The 26 unit vectors towards the neighbours of a cubic lattice cell, ``(26, 3)``."""
    return _dirs26()
