"""Surge-cast that declares the estimate of a particle filter once its stopping rule holds.

The moth-inspired surge and casts of ``surge-cast`` (:class:`~odorloc.behaviours.surge_cast.
SurgeCast`: an upwind surge of ``surge_steps`` periods after every detection, widening crosswind
casts when the odor is lost) move the robot; a single-agent estimator (``estimator``, default
the indoor PF paper's ``particle-filter``: back-tracking at the first detection, the Pang &
Farrell likelihood, roulette resampling, the dual convergence test) reads every period under
the searcher's ``model``, and its estimate is declared as soon as its stopping rule holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import free_move
from odorloc.behaviours.surge_cast import CastParams, SurgeCast
from odorloc.core.params import Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.searchers.base import Belief, Searcher
from odorloc.sensors.preprocessing import WindAverage


class SurgeCastPFParams(Params):
    """``surge_steps``, ``cast`` and ``wind_average`` of the motion; the ``model`` and the
    ``estimator`` whose converged estimate is declared."""

    surge_steps: int = Field(4, ge=1, le=1_000_000)
    cast: CastParams = CastParams()
    wind_average: int = Field(4, ge=1, le=10_000)
    model: Ref("model") = ComponentRef(type="pang-farrell", sensor_area=0.1, min_wind_variance=0.05)
    estimator: Ref("estimator") = ComponentRef(type="particle-filter")


@register("searcher", "surge-cast-pf", SurgeCastPFParams, "surge-cast declaring a PF estimate")
class SurgeCastPFSearcher(Searcher):
    """Surge and casts; declares the estimator's estimate when its stopping rule holds."""

    params: SurgeCastPFParams
    max_agents = 1

    def __init__(self, params: SurgeCastPFParams | None = None) -> None:
        super().__init__(params or SurgeCastPFParams())
        self.model = self.params.model.build("model", field="searcher.model")
        self.estimator = self.params.estimator.build("estimator", field="searcher.estimator")

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.estimator.reset(ctx, self.model, rng)
        self.wind = WindAverage(self.params.wind_average)
        self.caster = SurgeCast(self.params.cast, self.params.surge_steps)
        self.step = ctx.max_speed * ctx.dt

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        self.estimator.use_stream(rng)
        self.estimator.update(o)
        self.wind.add(o.wind)
        if o.detection:
            self.caster.start_surge()
        if self.estimator.converged():
            decl = Declaration(self.estimator.estimate(), agent=o.agent)
            return Action([Command.hold()], declaration=decl)
        if not o.ready:
            return Action([None])
        pos = np.asarray(o.position, float)
        d = self.caster.direction(self.ctx.arena, pos, self.wind.upwind(o.heading), self.step)
        move = free_move(self.ctx.arena, pos, d, self.step, rng)
        return Action([Command.hold() if move is None else Command.move(move)])

    def belief(self) -> Belief | None:
        return self.estimator.belief()

    def final_metrics(self) -> dict[str, Any]:
        return self.estimator.final_metrics()
