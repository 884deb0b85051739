"""Source-term search: a source-term posterior, a planner over it, and a declaration rule.

Recipe (``ste-search``), every control period:

1. the reading updates the source-term posterior (``estimator``, default ``ste-pf``:
   :mod:`odorloc.inference.source_terms`) under the searcher's measurement model (``model``,
   default ``ste-gaussian``);
2. **declaration** (``declare``): ``credible-region`` declares the posterior mean once the
   95 % credible region of the position lies within ``declare_radius`` of it
   (:meth:`~odorloc.inference.source_terms.belief.SourceTermBelief.credible_region`; with
   several source slots, once the estimator's convergence test holds for every source read);
   ``converged`` once ``sqrt(trace Cov(position)) < convergence_radius`` (the estimator's
   test); ``never`` leaves it to the scenario. No rule fires before ``min_readings`` readings.
   A searcher whose planner has run out of moves (the end of a lawn-mower) declares its
   estimate then;
3. **motion**, when the last move is done: the ``planner``'s target (``ste-infotaxis``,
   ``ste-entrotaxis`` or ``ste-lawnmower``: :mod:`odorloc.planning.source_term`) with the
   conditions of the next reading (the measured wind, the exposure).

The searcher drives one agent; teams run one per agent (``per-agent``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.inference.source_terms import SourceTermBelief, SourceTermEstimator
from odorloc.models.source_term import SourceTermModel
from odorloc.planning.base import Planner, Pose
from odorloc.searchers.base import Searcher

__all__ = ["SourceTermSearchParams", "SourceTermSearcher"]


class SourceTermSearchParams(Params):
    """Parameters of :class:`SourceTermSearcher` (see the module docstring).

    Attributes
    ----------
    model : dict
        The measurement model, ``{type: ste-gaussian | ste-vergassola | ste-adapter, ...}``.
        Default: ``ste-gaussian`` with a reading law for a plume that is not the model's own,
        ``relative_noise: 1.0`` and ``miss: 0.5`` (:mod:`odorloc.models.source_term`): an
        instantaneous reading of a turbulent plume fluctuates about its mean by about the
        mean itself and is clean air for much of the time. A scenario that knows its plume
        (the source-term papers' worlds) gives its own law.
    estimator : dict
        The source-term estimator, ``{type: ste-pf, ...}``.
    planner : dict
        ``{type: ste-infotaxis | ste-entrotaxis | ste-lawnmower, ...}``.
    declare : {"credible-region", "converged", "never"}
        Declaration rule: the credible region within ``declare_radius``, the estimator's
        convergence test, or none (the scenario ends the episode).
    declare_radius : float, metres
        The credible region must lie within this distance of the posterior mean.
    min_readings : int
        Readings before any declaration.
    """

    # Without the fluctuation and the intermittency in the law, one reading of a filament
    # plume separates hypotheses by thousands of nats: every reading then collapses the
    # particle set and costs the maximum of tempered steps, each moving every particle
    # against the whole history.
    model: Ref("model") = ComponentRef(type="ste-gaussian", relative_noise=1.0, miss=0.5)
    estimator: Ref("estimator") = ComponentRef(type="ste-pf", n_particles=2000)
    planner: Ref("planner") = ComponentRef(type="ste-entrotaxis")
    declare: Literal["credible-region", "converged", "never"] = "credible-region"
    declare_radius: Positive = 1.0
    min_readings: int = Field(10, ge=1, le=1_000_000)


@register("searcher", "ste-search", SourceTermSearchParams, "source-term posterior + planner")
class SourceTermSearcher(Searcher):
    """Source-term estimation with an information planner (see the module docstring)."""

    params: SourceTermSearchParams
    max_agents = 1

    def __init__(self, params: SourceTermSearchParams | None = None) -> None:
        super().__init__(params or SourceTermSearchParams())
        p = self.params
        model = p.model.build("model", field="searcher.model")
        if not isinstance(model, SourceTermModel):
            raise ConfigError(
                "searcher.model", "must be a source-term model (ste-gaussian, ste-vergassola, ...)"
            )
        est = p.estimator.build("estimator", field="searcher.estimator")
        if not isinstance(est, SourceTermEstimator):
            raise ConfigError("searcher.estimator", "must be a source-term estimator (ste-pf)")
        planner = p.planner.build("planner", field="searcher.planner")
        assert isinstance(planner, Planner)
        self.model: SourceTermModel = model
        self.estimator: SourceTermEstimator = est
        self.planner: Planner = planner

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """New posterior and planner."""
        super().reset(ctx, rng)
        self.estimator.reset(ctx, self.model, rng)
        self.planner.reset(ctx, self.estimator.model)
        self.declared = False
        self.by_rule = False
        self.last_score = math.nan
        self.declared_at = math.nan

    def _rule(self) -> bool:
        p, est = self.params, self.estimator
        if p.declare == "never" or est.n_read < p.min_readings:
            return False
        if p.declare == "converged" or est.layout.slots > 1:
            return est.converged()
        # a cheap bound first: the 95 % region of a cloud this wide cannot fit the radius
        if est.spread() >= p.declare_radius:
            return False
        b = est.belief()
        assert b is not None
        return b.credible_region(est.params.credible_level, n=400).radius <= p.declare_radius

    def _declare(self, t: float, confidence: float) -> Declaration | None:
        est = self.estimator.estimate()
        if self.declared or len(est) == 0:
            return None
        self.declared = True
        self.declared_at = t
        return Declaration(est, confidence=confidence)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Update, maybe declare, and move when the last move is done."""
        o = observations[0]
        self.estimator.update(o)
        if not self.declared and self._rule():
            self.by_rule = True
            decl = self._declare(o.t, self.estimator.params.credible_level)
            return Action([Command.hold()], declaration=decl)
        if not o.ready:
            return Action([None])
        pose = Pose(
            np.asarray(o.position, float),
            float(o.heading),
            np.asarray(o.wind, float),
            self.estimator.conditions(),
        )
        plan = self.planner.plan(self.estimator.belief(), pose, rng)
        if plan.index is None:
            # nothing left to do (a finished route) or nowhere to go: say what is known
            return Action([Command.hold()], declaration=self._declare(o.t, 0.0))
        self.last_score = plan.score
        return Action([Command.waypoint(plan.candidates[plan.index])])

    def belief(self) -> SourceTermBelief | None:
        """The source-term posterior."""
        return self.estimator.belief()

    def estimation(self) -> tuple[SourceTermEstimator, SourceTermModel]:
        """The posterior and its model (an offline replay drives them alone)."""
        return self.estimator, self.model

    def diagnostics(self) -> dict[str, float | str]:
        """The estimator's scalars and the chosen move's score."""
        return {**self.estimator.diagnostics(), "score": self.last_score}

    def final_metrics(self) -> dict[str, Any]:
        """The posterior summary and how the search ended."""
        return {
            **self.estimator.final_metrics(),
            "declared_by_rule": float(self.by_rule),
            "declared_at": self.declared_at,
        }
