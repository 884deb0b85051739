"""The planner interface: candidates x reward x selection, one :class:`Plan` out.

Every information-driven planner (the entropy moves of the indoor PF paper, the infotaxis
family on grids and particles, the UAV step planners, the uncertainty route of the D-S paper,
the searches over a source-term posterior) answers the same call::

    planner.reset(ctx, model)              # new episode: arena, control period, model
    plan = planner.plan(belief, pose, rng) # one decision
    plan.target                            # the chosen position (or None: nothing feasible)

A planner is a composition of three parts, each a ``Ref`` in its parameters: the *candidates*
(which positions could be next), the *reward* (what a reading there is worth under the belief
and the model's outcome probabilities) and the *selection* (how ties are broken). The work a
decision did is counted in :attr:`Plan.work` so that the episode can charge computation energy
without timing anything.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from odorloc.core.params import Params

if TYPE_CHECKING:
    from odorloc.core.types import SearchContext

__all__ = ["OutcomeModel", "Plan", "Planner", "Pose"]


class OutcomeModel(Protocol):
    """A measurement model with its conditions bound (:class:`~odorloc.models.base.BoundModel`):
    outcome-class probabilities ``(M, Z, N)`` of ``M`` sensor positions over ``N`` hypotheses."""

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray
    ) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class Pose:
    """Where the agent is when it plans.

    Attributes
    ----------
    position : (d,) ndarray, metres
    heading : float, rad
        Heading (x axis = 0, counter-clockwise); frames such as "forward" use it.
    wind : (d,) ndarray or None, m/s
        The measured wind, for wind-frame candidates.
    conditions : dict
        Measurement conditions of the reading the plan anticipates (a wind window, an exposure
        time), bound into the planner's model for this decision
        (:meth:`~odorloc.models.base.MeasurementModel.bind`).
    """

    position: np.ndarray
    heading: float = 0.0
    wind: np.ndarray | None = None
    conditions: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Plan:
    """One decision of a :class:`Planner`.

    Attributes
    ----------
    index : int or None
        The chosen candidate (``None``: no candidate was feasible).
    candidates : (M, d) ndarray
        Candidate targets, metres (lattice planners: cell centres).
    scores : (M,) ndarray
        The minimised score of each candidate (``inf`` where infeasible); its unit is the
        reward's (nats, bits, metres).
    feasible : (M,) bool ndarray
    work : int
        Elementary operations the decision took (e.g. candidates x outcomes x hypotheses), for
        computation accounting.
    extra : dict
        Planner-specific results worth keeping (e.g. the chosen step length).
    """

    index: int | None
    candidates: np.ndarray
    scores: np.ndarray
    feasible: np.ndarray
    work: int = 0
    extra: dict[str, Any] | None = None

    @property
    def target(self) -> np.ndarray | None:
        """The chosen candidate, ``(d,)``, or ``None``."""
        return None if self.index is None else self.candidates[self.index]

    @property
    def score(self) -> float:
        """The chosen candidate's score (``inf`` when nothing was feasible)."""
        return float("inf") if self.index is None else float(self.scores[self.index])


class Planner(ABC):
    """Base class of planners (see the module docstring)."""

    params: Params

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else Params()

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        """Prepare for a new episode (default: keep the context)."""
        self.ctx = ctx
        self.model = model

    @abstractmethod
    def plan(self, belief: Any, pose: Pose, rng: np.random.Generator) -> Plan:
        """Choose the next target for ``belief`` from ``pose``."""
