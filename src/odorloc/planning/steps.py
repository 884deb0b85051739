"""Step planners on a lattice of flight directions (registry family ``step_planner``).

A step planner chooses a UAV's next hover point from its particle belief: one of the
``3^d - 1`` lattice directions (26 in 3-D, 8 in 2-D: the neighbouring cells of a gridded space,
multi-UAV paper V.1) times a number of cells. Its parts are the candidate set
(:func:`lattice_offsets` x :func:`~odorloc.planning.candidates.direction_step_targets`), a reward
over the belief and the measurement model's outcome probabilities, and
:func:`~odorloc.planning.selection.select`.

- :class:`~odorloc.planning.adaptive.AdaptivePathPlanner` (``adap-pp``): direction by
  ``W - E[W']``, then the step length (eqs. 21-28);
- :class:`~odorloc.planning.fixed_step.FixedStepInfotaxis` (``fixed-step-infotaxis``): one cell
  in the direction of least expected entropy (infotaxis).

A move of ``l`` cells along lattice direction ``o`` (components in ``{-1, 0, 1}``) is the
displacement ``l * cell * o`` (``moves: lattice``, the UAV stays on the lattice; a diagonal move
is ``sqrt(2)`` or ``sqrt(3)`` cells long) or ``l * cell * o / |o|`` (``moves: unit``, every
direction ``cell`` metres per step).
"""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar, Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.types import SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.models.base import BoundModel
from odorloc.models.kernels import Backend, compiled
from odorloc.planning.candidates import reachable

__all__ = ["LatticeParams", "StepPlan", "StepPlanner", "lattice_offsets"]


@lru_cache(maxsize=4)
def _offsets(dim: int) -> np.ndarray:
    v = np.array([p for p in itertools.product((-1, 0, 1), repeat=dim) if any(p)], float)
    v.setflags(write=False)
    return v


def lattice_offsets(dim: int) -> np.ndarray:
    """The ``3^d - 1`` lattice directions with components in ``{-1, 0, 1}``, ``(3^d - 1, d)``.

    Their unit vectors are :func:`~odorloc.geometry.vectors.directions_26` in 3-D (same order).
    """
    if dim not in (2, 3):
        raise ConfigError("dim", f"must be 2 or 3, got {dim}")
    return _offsets(dim)


class LatticeParams(Params):
    """Settings every step planner shares.

    Parameters
    ----------
    cell : float, metres
        Lattice spacing: the length of one step along an axis.
    moves : {"lattice", "unit"}
        Displacement of a step along a diagonal direction (see the module docstring).
    backend : {"auto", "numpy", "numba"}
        The rewards as NumPy arrays or as the compiled loops of :mod:`odorloc.planning.kernels`
        (the ``fast`` extra; the same numbers bit for bit). ``auto`` compiles when numba is
        installed.
    """

    cell: Positive = 2.0
    moves: Literal["lattice", "unit"] = "lattice"
    backend: Backend = "auto"


@dataclass(frozen=True)
class StepPlan:
    """A step planner's decision.

    Attributes
    ----------
    target : (d,) ndarray or None, metres
        The next hover point (``None`` when every direction is blocked).
    direction : int or None
        Index of the chosen direction in :attr:`steps`.
    length : int
        Number of cells.
    steps : (M, d) ndarray, metres
        One-cell displacement of every direction.
    scores : (M,) ndarray
        The direction score (``inf``/``-inf`` for blocked directions).
    feasible : (M,) bool ndarray
    """

    target: np.ndarray | None
    direction: int | None
    length: int
    steps: np.ndarray
    scores: np.ndarray
    feasible: np.ndarray


class StepPlanner(ABC):
    """Base class of the step planners.

    After :meth:`reset`, :attr:`steps` are the one-cell displacements ``(M, d)``; :attr:`processed`
    counts the numbers the last :meth:`plan` processed (the computation measure of eq. 7);
    :attr:`compiled` says whether the rewards run as compiled kernels (``backend``).
    """

    params: LatticeParams
    Params: ClassVar[type[Params]]

    def __init__(self, params: LatticeParams | None = None) -> None:
        self.params = params if params is not None else type(self).Params()  # type: ignore[assignment]
        self.compiled = compiled(self.params.backend)

    def reset(self, ctx: SearchContext) -> None:
        """Prepare for an episode in ``ctx``."""
        self.ctx = ctx
        o = lattice_offsets(ctx.dim)
        if self.params.moves == "unit":
            o = o / np.linalg.norm(o, axis=1)[:, None]
        self.steps = self.params.cell * o
        self.processed = 0.0

    def feasible(self, position: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """``(M,)`` bool: targets inside the free arena reachable in a straight line."""
        arena = self.ctx.arena
        if arena.occ is None:
            # a box is convex: free and reachable is both ends inside (what the general test
            # finds, with one bounds test instead of three; Arena.contains without its input
            # checks, the planner's arrays being (M, d) floats already)
            lo, hi = arena.lo, arena.hi
            inside = ((targets >= lo) & (targets <= hi)).all(axis=1)
            here = np.asarray(position, float).tolist()
            if not all(a <= v <= b for a, v, b in zip(lo.tolist(), here, hi.tolist(), strict=True)):
                inside[:] = False
            return inside
        return arena.is_free(targets) & reachable(arena, position, targets)

    @abstractmethod
    def plan(
        self,
        belief: ParticleBelief,
        position: np.ndarray,
        model: BoundModel,
        history: np.ndarray,
        rng: np.random.Generator,
    ) -> StepPlan:
        """The next hover point.

        Parameters
        ----------
        belief : ParticleBelief
            The UAV's particles.
        position : (d,) ndarray, metres
        model : BoundModel
            The measurement model with the next measurement's conditions bound (exposure,
            wind direction).
        history : (K, d) ndarray, metres
            The UAV's past measurement points (the current one included).
        rng : numpy.random.Generator
            For random tie-breaking.
        """
