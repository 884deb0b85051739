"""An estimator of one's own and a searcher that composes it (the how-to guide "Write an
estimator")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import Field

from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Declaration, Observation, SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.estimator import Estimator
from odorloc.searchers.base import Searcher
from odorloc.searchers.simple import ZigzagParams, ZigzagSearcher


class UpwindCloudParams(Params):
    """Parameters of :class:`UpwindCloud`.

    Attributes
    ----------
    reach : float, metres
        How far upwind of a detection the source may lie.
    points : int
        Hypotheses added per detection, spread evenly along that reach.
    spread : float, metres
        Most distance between the last estimates for :meth:`UpwindCloud.converged`.
    history : int
        Estimates compared by the stopping rule.
    """

    reach: Positive = 2.0
    points: int = Field(20, ge=1, le=1000)
    spread: Positive = 0.3
    history: int = Field(10, ge=2, le=1000)


@register("estimator", "upwind-cloud", UpwindCloudParams, "hypotheses upwind of detections")
class UpwindCloud(Estimator):
    """Every detection adds hypotheses on the segment upwind of the agent, weighted by the
    reading; the estimate is their weighted mean. No measurement model (``needs_model``)."""

    Params = UpwindCloudParams
    params: UpwindCloudParams
    needs_model = False

    def reset(self, ctx: SearchContext, model: object, rng: np.random.Generator) -> None:
        self.ctx = ctx
        self.points: list[np.ndarray] = []
        self.weights: list[np.ndarray] = []
        self.estimates: list[np.ndarray] = []

    def update(self, observation: Observation) -> None:
        o = observation
        speed = float(np.linalg.norm(o.wind))
        if not o.detection or speed == 0.0:
            return
        along = np.linspace(0.0, self.params.reach, self.params.points)[:, None]
        line = o.position - along * (o.wind / speed)  # upwind of the agent
        inside = self.ctx.arena.is_free(line)
        self.points.append(line[inside])
        self.weights.append(np.full(int(inside.sum()), max(float(o.gas), 1e-9)))
        self.estimates.append(self.estimate()[0])

    def belief(self) -> ParticleBelief | None:
        if not self.points:
            return None
        w = np.concatenate(self.weights)
        return ParticleBelief(np.vstack(self.points), np.log(w / w.sum()))

    def estimate(self) -> np.ndarray:
        b = self.belief()
        return np.zeros((0, self.ctx.arena.dim)) if b is None else b.mean[None, :]

    def converged(self) -> bool:
        last = self.estimates[-self.params.history :]
        if len(last) < self.params.history:
            return False
        return bool(np.ptp(np.array(last), axis=0).max() <= self.params.spread)


class ZigzagThenDeclareParams(Params):
    """Parameters of :class:`ZigzagThenDeclare`.

    Attributes
    ----------
    estimator : component (estimator)
        The estimator whose converged estimate is declared.
    zigzag : mapping
        The exploration (:class:`~odorloc.searchers.simple.ZigzagParams`).
    """

    estimator: Ref("estimator") = ComponentRef(type="upwind-cloud")
    zigzag: ZigzagParams = ZigzagParams()


@register("searcher", "zigzag-then-declare", ZigzagThenDeclareParams, "zigzag, then declare")
class ZigzagThenDeclare(Searcher):
    """Explores with the zigzag and declares the estimator's estimate once it has converged."""

    Params = ZigzagThenDeclareParams
    params: ZigzagThenDeclareParams
    max_agents = 1

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.explore = ZigzagSearcher(self.params.zigzag)
        self.explore.reset(ctx, rng)
        self.estimator = self.params.estimator.build("estimator", field="searcher.estimator")
        self.estimator.reset(ctx, None, rng.spawn(1)[0])

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        self.estimator.update(observations[0])
        action = self.explore.act(observations, rng)
        if self.estimator.converged():
            found = Declaration(self.estimator.estimate(), agent=observations[0].agent)
            return Action(action.commands, declaration=found)
        return action

    def belief(self) -> ParticleBelief | None:
        return self.estimator.belief()
