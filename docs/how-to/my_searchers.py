"""A searcher of one's own (the how-to guide "Write a searcher")."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import Field

from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Observation, SearchContext
from odorloc.searchers.base import Searcher


class UpwindStepParams(Params):
    """Parameters of :class:`UpwindStepSearcher`.

    Attributes
    ----------
    step : float, metres
        Length of one move.
    cast_angle_deg : float, degrees
        Angle of the crosswind legs to the upwind direction while no odor is sensed.
    legs : int
        Control periods of one crosswind leg.
    """

    step: Positive = 0.3
    cast_angle_deg: float = Field(80.0, ge=0.0, le=90.0)
    legs: int = Field(6, ge=1)


@register("searcher", "upwind-step", UpwindStepParams, "upwind on odor, crosswind legs without")
class UpwindStepSearcher(Searcher):
    """Steps upwind while it detects odor; otherwise sweeps crosswind legs. Never declares."""

    Params = UpwindStepParams  # lets a scenario name the class by its import path
    params: UpwindStepParams
    max_agents = 1  # a team scenario runs one instance per agent (per-agent)
    declares = False  # it never declares: scenarios must end on reaching the source

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.side = 1.0 if rng.random() < 0.5 else -1.0  # every draw from the given stream
        self.count = 0

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        upwind = -o.wind[:2] / max(float(np.linalg.norm(o.wind[:2])), 1e-9)
        heading = math.atan2(upwind[1], upwind[0])
        if not o.detection:
            self.count += 1
            if self.count % self.params.legs == 0:
                self.side = -self.side
            heading += self.side * math.radians(self.params.cast_angle_deg)
        d = np.zeros_like(o.position)
        d[:2] = self.params.step * np.array([math.cos(heading), math.sin(heading)])
        return Action([Command.move(d)])
