"""The searcher interface every published algorithm implements.

Each control period the episode hands the searcher one
:class:`~odorloc.core.types.Observation` per controlled agent (in the order of
:attr:`~odorloc.core.types.SearchContext.agent_ids`) and expects an
:class:`~odorloc.core.types.Action`. Single robots, centrally controlled groups and teams whose
members each run their own estimator and talk to neighbours all fit this shape: a central
searcher sees all observations at once; a team (:mod:`odorloc.searchers.team`) gives each member
only its own agents' observations and the messages they received.

A searcher is a *recipe*: its parameters name the parts it composes (behaviours, estimators,
planners, measurement models) and :meth:`Searcher.act` wires them together.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from odorloc.core.params import Params
from odorloc.core.types import Action, Observation, SearchContext
from odorloc.inference.belief import Belief
from odorloc.inference.estimator import Estimator
from odorloc.models.base import MeasurementModel

__all__ = ["Belief", "Searcher"]


class Searcher(ABC):
    """Base class of search strategies.

    Subclasses keep their parameters immutable (a :class:`~odorloc.core.params.Params` in
    ``self.params``) and all evolving state in attributes set by :meth:`reset`.

    Class attributes
    ----------------
    dims : tuple of int
        Spatial dimensions the searcher works in.
    max_agents : int or None
        Most agents one instance can drive (``None``: any number). A single-agent searcher in a
        team scenario runs inside a ``per-agent`` team.
    min_agents : int
        Fewest agents one instance needs (a formation that must surround a point needs three).
    """

    params: Params
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    max_agents: ClassVar[int | None] = None
    min_agents: ClassVar[int] = 1

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else Params()

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Prepare for a new episode (subclasses call this first)."""
        self.ctx = ctx

    @abstractmethod
    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Choose the next commands from this step's observations (one per controlled agent)."""

    def belief(self) -> Belief | None:
        """The current belief (particles, grid, evidence map, ...) for recording, or ``None``."""
        return None

    def estimation(self) -> tuple[Estimator, MeasurementModel | None] | None:
        """The single-agent estimator this recipe composes and the measurement model it feeds
        it (``None``: none), not yet reset. An offline replay of a log drives them without the
        searcher, whose motion the log's robot did not follow."""
        return None

    def beliefs(self) -> Mapping[int, Belief]:
        """Every belief to record, keyed by the agent that holds it (``-1``: a central one)."""
        b = self.belief()
        return {} if b is None else {-1: b}

    def diagnostics(self) -> dict[str, float | str]:
        """Scalars worth recording each step: numbers (entropy, ESS, ...) or text (the phase's
        name, never a numeric code). Default none."""
        return {}

    def final_metrics(self) -> dict[str, Any]:
        """Extra columns for the episode's result row (default none). A name of a core column
        of the episode (``success``, ``search_time``, ...) is refused."""
        return {}

    def agent_metrics(self) -> dict[int, dict[str, Any]]:
        """Values that belong to one agent each, ``{agent id: {key: value}}`` (default none):
        stored per agent beside the episode row, never as ``key_<agent>`` columns. Teams give
        each member's :meth:`final_metrics` under the member's (first) agent."""
        return {}
