"""Infotaxis and its successors on a grid belief: an estimator x a planner, moved on each plan.

Recipe (:class:`InfotaxisSearcher`, ``infotaxis``; the parts are named in
:class:`InfotaxisParams`):

1. **Model** (``model``): the searcher's measurement model (any of :mod:`odorloc.models`; its
   parameters are the searcher's knowledge, not the world's).
2. **Belief** (``estimator``, default ``grid-filter``,
   :class:`~odorloc.inference.grid_estimator.GridFilterEstimator`): a grid Bayes filter over the
   free cells of the search region with the model tabulated over lattice offsets at the measured
   mean wind; every control period it rules out the cells within ``found_radius`` of the agent
   (the episode would have ended) and takes the reading (its outcome class).
3. **Motion** (``planner``, default ``lattice``,
   :class:`~odorloc.planning.infotaxis.LatticePlanner`), when the last move is done: the
   neighbour cells that are free and reachable (``candidates``) scored by the ``reward`` and
   chosen by the ``selection``; the agent moves to the centre of the chosen one.

The policies of the infotaxis family are this recipe with another reward, registered as
presets (:mod:`odorloc.searchers.presets`): ``space-aware-infotaxis`` (Loisy & Eloy 2022),
``entrotaxis`` (Hutchinson et al. 2018), ``greedy`` and ``mean-distance`` (Loisy & Eloy 2022).

The searchers never declare: they suit tasks that end when the source is reached
(``task.end: reach``). On the lattice problem of infotaxis (the built-in scenarios
``lattice-isotropic-*``) this is the problem of Loisy & Eloy (2022) exactly, and the choices are
those of their reference implementation (OTTO) on the same beliefs.

:class:`PlanningSearcher` is the loop shared with the particle recipe
(:mod:`odorloc.searchers.particle_infotaxis`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from odorloc.core.params import Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Observation, SearchContext
from odorloc.inference.estimator import Estimator
from odorloc.models.base import MeasurementModel
from odorloc.planning.base import Plan, Planner, Pose
from odorloc.searchers.base import Belief, Searcher

__all__ = ["InfotaxisParams", "InfotaxisSearcher", "PlanningSearcher"]


class PlanningSearcher(Searcher):
    """An estimator and a planner over one measurement model (the parameters' ``model``,
    ``estimator`` and ``planner``): every control period the estimator takes the reading; when
    the last move is done the planner picks the next target, and the agent moves there (holds
    when nothing is feasible). Single agent; never declares."""

    max_agents = 1

    def __init__(self, params: Params | None = None) -> None:
        super().__init__(params)
        p: Any = self.params
        self.model: MeasurementModel = p.model.build("model", field="searcher.model")
        self.estimator: Estimator = p.estimator.build("estimator", field="searcher.estimator")
        self.planner: Planner = p.planner.build("planner", field="searcher.planner")

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """A fresh belief (drawn from ``rng`` where the estimator draws one)."""
        super().reset(ctx, rng)
        self.estimator.reset(ctx, self.model, rng)
        self.planner.reset(ctx, self.model)
        self.last_plan: Plan | None = None
        self.decisions = 0

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Update the belief with the reading; plan when ready."""
        o = observations[0]
        est = self.estimator
        est.use_stream(rng)
        est.update(o)
        if not o.ready:
            return Action([None])
        pos = np.asarray(o.position, float)
        pose = Pose(pos, o.heading, np.asarray(o.wind, float), est.conditions())
        plan = self.planner.plan(est.belief(), pose, rng)
        self.last_plan = plan
        self.decisions += 1
        if plan.target is None:
            return Action([Command.hold()])
        return Action([Command.move(plan.target - pos)])

    def belief(self) -> Belief | None:
        """The estimator's belief."""
        return self.estimator.belief()

    def estimation(self) -> tuple[Estimator, MeasurementModel | None]:
        """The estimator and the model."""
        return self.estimator, self.model


class InfotaxisParams(Params):
    """Parameters of :class:`InfotaxisSearcher` (see the module docstring).

    Attributes
    ----------
    model : dict
        The searcher's measurement model, ``{type: name, **params}``.
    estimator : dict
        ``{type: grid-filter, cell_size, region, found_radius, releases, reading: {reading,
        n_classes, exposure, wind_average}, retabulate_deg}``
        (:class:`~odorloc.inference.grid_estimator.GridFilterParams`).
    planner : dict
        ``{type: lattice, candidates: {moves}, reward: {type: ...}, selection: {ties,
        tolerance}, floor}`` (:class:`~odorloc.planning.infotaxis.LatticePlannerParams`).
    """

    model: Ref("model") = ComponentRef(type="vergassola")
    estimator: Ref("estimator") = ComponentRef(type="grid-filter")
    planner: Ref("planner") = ComponentRef(type="lattice")


@register("searcher", "infotaxis", InfotaxisParams, "infotaxis on a grid belief")
class InfotaxisSearcher(PlanningSearcher):
    """Infotaxis (Vergassola, Villermaux & Shraiman 2007): the move that minimises the expected
    entropy of the source belief, the found outcome included; with another reward, the other
    policies of the family (module docstring)."""

    params: InfotaxisParams

    def __init__(self, params: InfotaxisParams | None = None) -> None:
        super().__init__(params or InfotaxisParams())

    def diagnostics(self) -> dict[str, float]:
        """The estimator's (``entropy`` in bits, ``p_max``) and the candidates the last plan
        ``rescored``."""
        extra = self.last_plan.extra if self.last_plan is not None else None
        rescored = float(extra.get("rescored", 0)) if extra else 0.0
        return {**self.estimator.diagnostics(), "rescored": rescored}

    def final_metrics(self) -> dict[str, Any]:
        """The estimator's (entropy after the first reading and at the end, belief restarts) and
        the number of decisions."""
        return {**self.estimator.final_metrics(), "decisions": float(self.decisions)}
