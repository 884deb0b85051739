"""Candidate sets of a planner: where the agent could go next.

- :func:`move_directions`: forward/backward/left/right in the robot, wind or world frame
  (indoor PF paper, eq. 18);
- :func:`lattice_targets`: the ``2d`` axis moves of a lattice, optionally "stay" (infotaxis);
- :func:`direction_step_targets`: directions times step lengths (e.g. the 26 grid directions x
  ``1..l_max`` of the multi-UAV paper);
- :func:`reachable`: which straight motions walls and obstacles allow.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import lattice_moves

__all__ = [
    "MOVE_NAMES",
    "direction_step_targets",
    "lattice_targets",
    "move_directions",
    "reachable",
]

MOVE_NAMES = ("forward", "backward", "left", "right")


def move_directions(
    frame: Literal["robot", "wind", "world"],
    dim: int,
    heading: float = 0.0,
    wind: np.ndarray | None = None,
) -> np.ndarray:
    """Unit vectors of the moves forward, backward, left, right, ``(4, dim)``.

    ``"robot"``: forward along ``heading`` (rad), left at +90 deg (indoor PF paper, eq. 18:
    moves in the robot coordinate system). ``"wind"``: forward = upwind (against the horizontal
    ``wind``), falling back to ``heading`` in calm air. ``"world"``: forward = +x, left = +y.
    Moves are horizontal in 3D.
    """
    if frame == "robot":
        ang = heading
    elif frame == "wind":
        if wind is None:
            raise ConfigError("wind", "frame 'wind' needs the wind vector")
        u = np.asarray(wind, float)
        ang = math.atan2(-u[1], -u[0]) if math.hypot(u[0], u[1]) > 1e-9 else heading
    elif frame == "world":
        ang = 0.0
    else:
        raise ConfigError("frame", f"unknown frame {frame!r}")
    c, s = math.cos(ang), math.sin(ang)
    out = np.zeros((4, dim))
    out[:, :2] = [[c, s], [-c, -s], [-s, c], [s, -c]]
    return out


def lattice_targets(position: ArrayLike, step: float, stay: bool = False) -> np.ndarray:
    """Targets of the ``2d`` lattice moves of length ``step`` (plus "stay"), ``(2d[+1], d)``.

    Move ``a`` goes along axis ``a // 2``, towards lower coordinates when ``a`` is even.
    """
    p = np.asarray(position, float)
    return p + step * lattice_moves(p.size, stay)


def direction_step_targets(
    position: ArrayLike, directions: ArrayLike, lengths: ArrayLike
) -> np.ndarray:
    """Targets ``position + l u`` for every direction ``u`` and length ``l``, ``(K * L, d)``.

    Rows are direction-major: all lengths of direction 0 first.
    """
    p = np.asarray(position, float)
    u = np.atleast_2d(np.asarray(directions, float))
    ls = np.asarray(lengths, float).reshape(-1)
    return (p[None, None, :] + u[:, None, :] * ls[None, :, None]).reshape(-1, p.size)


def reachable(arena: Arena | None, position: ArrayLike, targets: ArrayLike) -> np.ndarray:
    """``(M,)`` bool: straight motions from ``position`` to each target that stay free."""
    t = np.atleast_2d(np.asarray(targets, float))
    if arena is None:
        return np.ones(len(t), bool)
    return arena.segment_free(np.asarray(position, float), t)
