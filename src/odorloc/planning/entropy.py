"""Expected-entropy move selection: candidates x reward x selection (indoor PF paper, 2.2).

The robot evaluates a small set of moves ``M_k`` (forward, backward, left, right in its own
frame, :func:`~odorloc.planning.candidates.move_directions`) and picks
``m_k* = argmin_{m in M_k} H(m_k)`` (eq. 18), ``H`` being the Shannon entropy of the source
posterior expected after the reading the robot would take at the end of the move. The flattened
eq. 17 mixes the likelihood into the entropy; it is read here, as in infotaxis / entrotaxis (the
works it cites), as the expected posterior entropy
(:func:`~odorloc.planning.rewards.expected_entropy`). Moves blocked by walls or obstacles are
excluded; ties go to the first move in :data:`MOVE_NAMES` order.

The planner is model-agnostic: it takes a bound measurement model (:mod:`odorloc.models`) whose
``outcome_probabilities(targets, hypotheses)`` gives ``(M, Z, N)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.geometry.arena import Arena
from odorloc.inference.belief import ParticleBelief
from odorloc.planning.candidates import MOVE_NAMES, move_directions, reachable
from odorloc.planning.rewards import expected_entropy
from odorloc.planning.selection import select

__all__ = [
    "MOVE_NAMES",
    "EntropyPlan",
    "EntropyPlanner",
    "EntropyPlannerParams",
    "OutcomeModel",
]


class OutcomeModel(Protocol):
    """A measurement model with its conditions bound (:class:`~odorloc.models.base.BoundModel`)."""

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray
    ) -> np.ndarray: ...


class EntropyPlannerParams(Params):
    """Settings of :class:`EntropyPlanner`.

    Parameters
    ----------
    step_length : float, metres
        Length of a move (the searcher may override per call, e.g. max speed x control period).
    frame : {"robot", "wind", "world"}
        Reference of forward/backward/left/right (paper: the robot frame).
    """

    step_length: Positive = 0.25
    frame: Literal["robot", "wind", "world"] = "robot"


@dataclass(frozen=True)
class EntropyPlan:
    """Outcome of :meth:`EntropyPlanner.plan`.

    Attributes
    ----------
    index : int or None
        Chosen move (index into :data:`MOVE_NAMES`), ``None`` when every move is blocked.
    targets : (M, d) ndarray, metres
    expected_entropy : (M,) ndarray, nats
        ``inf`` for blocked moves.
    feasible : (M,) bool ndarray
    """

    index: int | None
    targets: np.ndarray
    expected_entropy: np.ndarray
    feasible: np.ndarray

    @property
    def target(self) -> np.ndarray | None:
        """Chosen target position, ``(d,)`` metres, or ``None``."""
        return None if self.index is None else self.targets[self.index]

    @property
    def name(self) -> str | None:
        """Name of the chosen move."""
        return None if self.index is None else MOVE_NAMES[self.index]


class EntropyPlanner:
    """Pick the move whose reading minimises the expected posterior entropy (eq. 18)."""

    def __init__(self, params: EntropyPlannerParams | None = None) -> None:
        self.params = params or EntropyPlannerParams()

    def candidates(
        self,
        position: np.ndarray,
        heading: float = 0.0,
        wind: np.ndarray | None = None,
        step_length: float | None = None,
    ) -> np.ndarray:
        """Target positions of the four moves, ``(4, d)`` metres."""
        pos = np.asarray(position, float)
        step = self.params.step_length if step_length is None else float(step_length)
        if not (math.isfinite(step) and step > 0):
            raise ConfigError("step_length", "must be a finite number > 0")
        return pos + step * move_directions(self.params.frame, pos.size, heading, wind)

    def plan(
        self,
        belief: ParticleBelief,
        position: np.ndarray,
        model: OutcomeModel,
        *,
        heading: float = 0.0,
        wind: np.ndarray | None = None,
        arena: Arena | None = None,
        step_length: float | None = None,
    ) -> EntropyPlan:
        """Choose ``argmin`` expected entropy among the moves not blocked in ``arena``."""
        targets = self.candidates(position, heading, wind, step_length)
        feasible = reachable(arena, position, targets)
        eh = np.full(len(targets), np.inf)
        if feasible.any():
            q = model.outcome_probabilities(targets[feasible], belief.positions)
            eh[feasible] = expected_entropy(belief.log_weights, q)
        index = select(eh, mode="min", feasible=feasible, ties="first")
        return EntropyPlan(index, targets, eh, feasible)
