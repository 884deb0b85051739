"""Step planners on a lattice of flight directions (registry family ``step_planner``).

A step planner chooses a UAV's next hover point from its particle belief: one of the
``3^d - 1`` lattice directions (26 in 3-D, 8 in 2-D: the neighbouring cells of a gridded space,
multi-UAV paper V.1) times a number of cells. Its parts are the candidate set
(:func:`lattice_offsets` x :func:`~odorloc.planning.candidates.direction_step_targets`), a reward
over the belief and the measurement model's outcome probabilities, and
:func:`~odorloc.planning.selection.select`.

Step planners implement :class:`~odorloc.planning.base.Planner`::

    planner.reset(ctx, model)                 # the arena, and the UAV's measurement model
    planner.record(position)                  # each measurement point, as it is taken
    plan = planner.plan(belief, pose, rng)    # pose.conditions: the next reading's (dt, wind)
    plan.target, plan.extra["length"]         # the next hover point, cells along the direction

The :class:`~odorloc.planning.base.Plan` of a step planner has one candidate per direction, at
the step length the planner chose (``extra["length"]``; 1 for a fixed step): ``scores`` are the
directions' (minimised) scores and ``feasible`` says whether a direction's first cell is free
and reachable. The chosen target is free and reachable at its length. ``work`` counts the
numbers the decision processed (the computation measure of eq. 7).

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
from abc import abstractmethod
from functools import lru_cache
from typing import Any, ClassVar, Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.types import SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.models.base import BoundModel, MeasurementModel
from odorloc.models.kernels import Backend, compiled
from odorloc.planning.base import Plan, Planner, Pose
from odorloc.planning.candidates import reachable

__all__ = ["LatticeParams", "StepPlanner", "lattice_offsets"]


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
        (numba; equal to the NumPy reference within round-off, fixed-step infotaxis to the
        bit). ``auto`` compiles when numba is importable.
    """

    cell: Positive = 2.0
    moves: Literal["lattice", "unit"] = "lattice"
    backend: Backend = "auto"


class StepPlanner(Planner):
    """Base class of the step planners (see the module docstring).

    After :meth:`reset`, :attr:`steps` are the one-cell displacements ``(M, d)`` and
    :attr:`compiled` says whether the rewards run as compiled kernels (``backend``).
    """

    params: LatticeParams
    Params: ClassVar[type[Params]]

    def __init__(self, params: LatticeParams | None = None) -> None:
        super().__init__(params if params is not None else type(self).Params())
        self.compiled = compiled(self.params.backend)

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        """Prepare for an episode in ``ctx`` with the UAV's measurement ``model``."""
        if not isinstance(model, MeasurementModel):
            raise ConfigError("model", "a step planner needs the UAV's measurement model")
        super().reset(ctx, model)
        o = lattice_offsets(ctx.dim)
        if self.params.moves == "unit":
            o = o / np.linalg.norm(o, axis=1)[:, None]
        self.steps = self.params.cell * o
        # measurement points, (K, d) in a buffer that doubles when full
        self._points = np.empty((64, ctx.dim))
        self._n_points = 0

    def record(self, position: np.ndarray) -> None:
        """Note a measurement point of the UAV (Adap-PP's step reward counts them, eq. 27)."""
        if self._n_points == len(self._points):
            self._points = np.concatenate([self._points, np.empty_like(self._points)])
        self._points[self._n_points] = np.asarray(position, float)
        self._n_points += 1

    @property
    def history(self) -> np.ndarray:
        """The measurement points recorded so far, ``(K, d)`` metres (a view)."""
        return self._points[: self._n_points]

    def bound_model(self, pose: Pose) -> BoundModel:
        """The model with the conditions of the reading the plan anticipates bound."""
        return self.model.bind(**pose.conditions)

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
    def plan(self, belief: ParticleBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        """The next hover point.

        Parameters
        ----------
        belief : ParticleBelief
            The UAV's particles.
        pose : Pose
            Its position and the conditions of the next reading (exposure, wind direction),
            bound into the model for this decision.
        rng : numpy.random.Generator
            For random tie-breaking.
        """
