"""Particle-belief infotaxis: a particle filter with infotaxis over direction x step moves.

Recipe (the single-agent base of the multi-UAV paper's Col-Inf baseline: "traditional particle
filter + POMDP with fixed moving step", i.e. infotaxis), the loop of
:class:`~odorloc.searchers.infotaxis.PlanningSearcher` with these parts as defaults:

1. **Belief** (``estimator``): the ``particle-filter`` with ``n_particles`` source hypotheses
   uniform over the free part of the search region, resampled (systematic, 0.2 m jitter) when
   ``N_eff < 0.5 N``; every control period the particles within ``found_radius`` of the agent
   (default half a step) are ruled out (the episode would have ended) and the reading updates
   the weights with the outcome law of the searcher's model at the agent's position (its class:
   the hit count, capped at the last class, or the detection).
2. **Motion** (``planner``), when the last move is done: the ``particle`` planner scores the
   candidates ``position + step u`` (``directions``: ``neighbours``, 8 horizontal directions in
   2-D and the 26 of :func:`~odorloc.geometry.vectors.directions_26` in 3-D, or ``lattice``)
   that walls and obstacles allow by the expected entropy of the weights after the move, the
   found outcome included (``reward``; ``predictive-entropy`` is entrotaxis), with the model
   bound to the exposure and the measured mean wind.

A team recipe (collaborative infotaxis) reuses the same parts with its own candidate sets and
joint outcome models.
"""

from __future__ import annotations

from typing import Any

from odorloc.core.params import Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.inference.belief import ParticleBelief
from odorloc.searchers.infotaxis import PlanningSearcher

__all__ = ["ParticleInfotaxisParams", "ParticleInfotaxisSearcher"]


class ParticleInfotaxisParams(Params):
    """Parameters of :class:`ParticleInfotaxisSearcher` (see the module docstring).

    Attributes
    ----------
    model : dict
        The searcher's measurement model, ``{type: name, **params}``.
    estimator : dict
        The ``particle-filter`` (:class:`~odorloc.inference.particles.estimator.
        ParticleFilterParams`): ``n_particles``, ``init: {type: uniform, region}``, ``reading:
        {type: outcome-class, reading, n_classes, exposure, wind_average}``, ``resampler``,
        ``resampling``, ``stopping: {type: never}``, ``found_radius`` (``half-step``: half a
        control period's travel at the speed limit; set it to the task's reach radius).
    planner : dict
        ``{type: particle, candidates: {type: directions, moves, step}, reward: {type:
        expected-entropy | predictive-entropy | ...}, selection: {ties, tolerance}}``.
    """

    model: Ref("model") = ComponentRef(type="vergassola")
    estimator: Ref("estimator") = ComponentRef(
        type="particle-filter",
        n_particles=500,
        reading={"type": "outcome-class"},
        init={"type": "uniform"},
        resampler={"type": "systematic", "jitter_std": 0.2},
        stopping={"type": "never"},
        found_radius="half-step",
    )
    planner: Ref("planner") = ComponentRef(type="particle")


@register(
    "searcher", "particle-infotaxis", ParticleInfotaxisParams, "particle filter + infotaxis moves"
)
class ParticleInfotaxisSearcher(PlanningSearcher):
    """Infotaxis on a particle belief over direction x step candidates. Single agent."""

    params: ParticleInfotaxisParams

    def __init__(self, params: ParticleInfotaxisParams | None = None) -> None:
        super().__init__(params or ParticleInfotaxisParams())

    def diagnostics(self) -> dict[str, float]:
        """``ess``, ``entropy`` (of the weights, nats) and the chosen move's ``score``."""
        b = self.estimator.belief()
        plan = self.last_plan
        score = plan.score if plan is not None and plan.index is not None else float("nan")
        if not isinstance(b, ParticleBelief):
            return {"score": score}
        return {"ess": b.ess, "entropy": b.entropy, "score": score}

    def final_metrics(self) -> dict[str, Any]:
        """The estimator's (resamplings and redraws of the particle set)."""
        return self.estimator.final_metrics()
