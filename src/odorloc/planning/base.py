"""The planner interface: candidates x reward x selection, one :class:`Plan` out.

Every information-driven planner (the entropy moves of the indoor PF paper, the infotaxis
family on grids and particles, the UAV step planners, the uncertainty route of the D-S paper,
the searches over a source-term posterior) answers the same call::

    planner.reset(ctx, model)              # new episode: arena, control period, model
    plan = planner.plan(belief, pose, rng) # one decision
    plan.target                            # the chosen position (or None: nothing feasible)

A planner is a composition of three parts, each a ``Ref`` in its parameters: the *candidates*
(which positions could be next; registry family ``candidates``), the *reward* (what a reading
there is worth under the belief and the model's outcome probabilities; family ``reward``,
:class:`Reward`) and the *selection* (how ties are broken; family ``selection``). The work a
decision did is counted in :attr:`Plan.work` so that the episode can charge computation energy
without timing anything.

Planners form the registry family ``planner``. Each names, as the class attribute
``belief_estimator``, the estimator (``{type: name, **params}``) whose belief it plans on, so
that a contract check can give it one.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from odorloc.core.params import Configured, Params

if TYPE_CHECKING:
    from odorloc.core.types import SearchContext
    from odorloc.models.lattice import OffsetTable

__all__ = ["OutcomeModel", "Plan", "Planner", "Pose", "Reward"]


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
    """Base class of planners (see the module docstring).

    Class attributes
    ----------------
    dims : tuple of int
        Spatial dimensions the planner works in.
    needs_model : bool
        ``True`` when :meth:`reset` requires a measurement model.
    belief_estimator : dict
        The estimator whose belief the planner plans on, ``{type: name, **params}``.
    belief_model : dict or None
        The measurement model of that estimator and of the planner (``None``: the estimator's
        ``default_model``).
    """

    params: Params
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    needs_model: ClassVar[bool] = True
    belief_estimator: ClassVar[Mapping[str, Any]] = {"type": "particle-filter"}
    belief_model: ClassVar[Mapping[str, Any] | None] = None

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else Params()

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        """Prepare for a new episode (default: keep the context)."""
        self.ctx = ctx
        self.model = model

    @abstractmethod
    def plan(self, belief: Any, pose: Pose, rng: np.random.Generator) -> Plan:
        """Choose the next target for ``belief`` from ``pose``."""


class Reward(Configured, ABC):
    """Base class of the ``reward`` family: a score per candidate, to be minimised.

    A reward is evaluated on weighted particles (:meth:`particle`) or on a lattice belief
    with tabulated outcomes (:meth:`lattice`); a member that has no form for one kind of belief
    says so (``particles = False`` / ``lattices = False``) and the planner refuses it.
    """

    particles: ClassVar[bool] = True
    lattices: ClassVar[bool] = True
    #: Whether the particle form needs the model's outcome probabilities.
    needs_outcomes: ClassVar[bool] = True
    #: Whether the particle form needs the candidate-particle distances.
    needs_distances: ClassVar[bool] = False

    def particle(
        self,
        log_weights: np.ndarray,
        outcome_probs: np.ndarray | None,
        found: np.ndarray | None,
        distances: np.ndarray | None,
    ) -> np.ndarray:
        """Scores ``(M,)`` over ``N`` weighted particles.

        Parameters
        ----------
        log_weights : (N,) ndarray
        outcome_probs : (M, Z, N) ndarray or None
            ``None`` when :attr:`needs_outcomes` is false.
        found : (M, N) bool ndarray or None
            Particles found at each candidate (``None``: the search does not end by reaching).
        distances : (M, N) ndarray or None, metres
            From each candidate to each particle (given when :attr:`needs_distances` or a
            found radius needs them).
        """
        raise NotImplementedError

    def lattice(
        self,
        joint: np.ndarray,
        tables: Sequence[OffsetTable],
        cells: np.ndarray,
        found_radius: float,
        floor: float,
        tolerance: float,
    ) -> tuple[np.ndarray, int]:
        """Scores ``(M,)`` of candidate ``cells`` on a ``(K, *shape)`` lattice belief and the
        number of candidates scored again with the ``floor`` conventions
        (:mod:`odorloc.planning.infotaxis`); ``tolerance`` is the selection's tie tolerance."""
        raise NotImplementedError
