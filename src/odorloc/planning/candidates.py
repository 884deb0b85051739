"""Candidate sets of a planner: where the agent could go next.

- :func:`move_directions`: forward/backward/left/right in the robot, wind or world frame
  (indoor PF paper, eq. 18);
- :func:`lattice_targets`: the ``2d`` axis moves of a lattice, optionally "stay" (infotaxis);
- :func:`neighbour_cells`: the cells around a lattice cell;
- :func:`direction_step_targets`: directions times step lengths (e.g. the 26 grid directions x
  ``1..l_max`` of the multi-UAV paper);
- :func:`reachable`: which straight motions walls and obstacles allow.

The registry family ``candidates`` composes them for the planners (:class:`Candidates`):
``moves`` (the four moves in a frame), ``directions`` (a direction set times one step) and
``lattice-cells`` (the neighbour cells of a grid belief).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import directions_26, lattice_moves, ring
from odorloc.planning.base import Pose

__all__ = [
    "MOVE_NAMES",
    "CandidateSet",
    "Candidates",
    "DirectionCandidates",
    "LatticeCellCandidates",
    "MoveCandidates",
    "direction_step_targets",
    "lattice_targets",
    "move_directions",
    "move_directions_of",
    "neighbour_cells",
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


# ---------------------------------------------------------------------- the ``candidates`` family
@dataclass(frozen=True, eq=False)
class CandidateSet:
    """Where the agent could go next.

    Attributes
    ----------
    targets : (M, d) ndarray, metres
    feasible : (M,) bool ndarray
        Targets the agent can reach (walls, obstacles, the belief's grid).
    cells : (M, d) int ndarray or None
        The lattice cells of the targets (lattice candidates only).
    """

    targets: np.ndarray
    feasible: np.ndarray
    cells: np.ndarray | None = None


class Candidates(Configured, ABC):
    """Base class of the ``candidates`` family: the candidate targets of one decision."""

    def reset(self, ctx: SearchContext) -> None:
        """A new episode (default: keep the context)."""
        self.ctx = ctx

    @abstractmethod
    def generate(self, belief: Any, pose: Pose) -> CandidateSet:
        """The candidates from ``pose`` (lattice candidates read the belief's grid)."""


def _step(ctx: SearchContext, step: float | None) -> float:
    """``step``, or one control period at the platform's speed limit."""
    return float(step) if step is not None else ctx.max_speed * ctx.dt


class MovesParams(Params):
    """Settings of :class:`MoveCandidates`.

    Attributes
    ----------
    frame : {"robot", "wind", "world"}
        Reference of forward/backward/left/right (indoor PF paper: the robot frame).
    step_length : float, metres, optional
        Length of a move (default: one control period at the platform's speed limit).
    """

    frame: Literal["robot", "wind", "world"] = "robot"
    step_length: Positive | None = None


@register("candidates", "moves", MovesParams, "forward/backward/left/right in a frame")
class MoveCandidates(Candidates):
    """The four moves of :func:`move_directions` (indoor PF paper, eq. 18), those blocked by
    walls or obstacles infeasible."""

    params: MovesParams
    Params = MovesParams

    def reset(self, ctx: SearchContext) -> None:
        super().reset(ctx)
        self.step = _step(ctx, self.params.step_length)

    def generate(self, belief: Any, pose: Pose) -> CandidateSet:
        pos = np.asarray(pose.position, float)
        d = move_directions(self.params.frame, pos.size, pose.heading, pose.wind)
        targets = pos + self.step * d
        return CandidateSet(targets, reachable(self.ctx.arena, pos, targets))


class DirectionsParams(Params):
    """Settings of :class:`DirectionCandidates`.

    Attributes
    ----------
    moves : {"lattice", "neighbours"}
        ``lattice``: the ``2d`` axis directions; ``neighbours``: 8 horizontal directions in 2-D,
        the 26 of :func:`~odorloc.geometry.vectors.directions_26` in 3-D.
    step : float, metres, optional
        Length of one move (default: one control period at the platform's speed limit).
    """

    moves: Literal["lattice", "neighbours"] = "neighbours"
    step: Positive | None = None


def move_directions_of(dim: int, moves: str) -> np.ndarray:
    """Unit directions of a move set, ``(K, dim)``: ``lattice`` (``2 dim`` axis moves) or
    ``neighbours`` (8 horizontal directions in 2-D, the 26 lattice directions in 3-D)."""
    if moves == "lattice":
        return np.asarray(lattice_moves(dim), float)
    if moves == "neighbours":
        return np.asarray(directions_26(), float) if dim == 3 else ring(8, 2)
    raise ConfigError("moves", f"unknown move set {moves!r}")


@register("candidates", "directions", DirectionsParams, "directions x one step length")
class DirectionCandidates(Candidates):
    """``position + step u`` for each direction ``u`` of the move set, those blocked by walls or
    obstacles infeasible."""

    params: DirectionsParams
    Params = DirectionsParams

    def reset(self, ctx: SearchContext) -> None:
        super().reset(ctx)
        self.step = _step(ctx, self.params.step)
        self.directions = move_directions_of(ctx.dim, self.params.moves)

    def generate(self, belief: Any, pose: Pose) -> CandidateSet:
        pos = np.asarray(pose.position, float)
        targets = pos[None, :] + self.step * self.directions
        return CandidateSet(targets, reachable(self.ctx.arena, pos, targets))


class LatticeCellsParams(Params):
    """Settings of :class:`LatticeCellCandidates`.

    Attributes
    ----------
    moves : {"lattice", "lattice-stay", "neighbours"}
        The ``2d`` lattice moves in the order ``-x, +x, -y, +y[, -z, +z]``, the same and
        staying, or all ``3^d - 1`` neighbour cells (:func:`neighbour_cells`).
    """

    moves: Literal["lattice", "lattice-stay", "neighbours"] = "lattice"


def neighbour_cells(
    cell: Sequence[int], moves: Literal["lattice", "lattice-stay", "neighbours"] = "lattice"
) -> np.ndarray:
    """Candidate cells around ``cell``, ``(M, d)`` int.

    ``lattice``: the ``2d`` axis moves in the order ``-axis0, +axis0, -axis1, ...``
    (:func:`~odorloc.geometry.vectors.lattice_moves`); ``lattice-stay`` appends staying;
    ``neighbours``: the ``3^d - 1`` cells sharing a face, edge or corner (e.g. the 26 directions
    of the multi-UAV paper), in lexicographic order of the offsets.
    """
    c = np.asarray(cell, dtype=np.int64).reshape(-1)
    return c[None, :] + _move_offsets(c.size, moves)


@lru_cache(maxsize=16)
def _move_offsets(dim: int, moves: str) -> np.ndarray:
    if moves in ("lattice", "lattice-stay"):
        off = lattice_moves(dim, moves == "lattice-stay").astype(np.int64)
    elif moves == "neighbours":
        grid = np.stack(np.meshgrid(*[[-1, 0, 1]] * dim, indexing="ij"), -1).reshape(-1, dim)
        off = grid[np.any(grid != 0, axis=1)].astype(np.int64)
    else:
        raise ConfigError("moves", f"unknown move set {moves!r}")
    off.setflags(write=False)
    return off


@register("candidates", "lattice-cells", LatticeCellsParams, "neighbour cells of a grid belief")
class LatticeCellCandidates(Candidates):
    """The centres of the cells around the agent's cell of the belief's grid
    (:func:`neighbour_cells`); cells outside the grid, in an obstacle or behind one are
    infeasible."""

    params: LatticeCellsParams
    Params = LatticeCellsParams

    def generate(self, belief: Any, pose: Pose) -> CandidateSet:
        grid = belief.grid
        pos = np.asarray(pose.position, float)
        shape = np.asarray(grid.shape)
        cells = neighbour_cells(grid.index(pos)[0], self.params.moves)
        inside = np.all((cells >= 0) & (cells < shape), axis=1)
        targets = grid.center(np.clip(cells, 0, shape - 1))
        arena = self.ctx.arena
        ok = inside & arena.is_free(targets)
        if arena.occ is not None:
            ok &= arena.segment_free(pos, targets)
        return CandidateSet(targets, ok, cells)
