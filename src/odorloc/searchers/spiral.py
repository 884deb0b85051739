"""Spiral search (as in MAPIRlab's GSL package): square spirals restarted where the proximity
index improves (:mod:`odorloc.behaviours.spiral`).

Each agent alternates two phases: it *measures* standing still for ``measure_periods`` control
periods, then *drives* the next spiral leg (a waypoint). Legs blocked by walls or obstacles are
skipped; after ``max_skips`` blocked legs in a row the spiral restarts, and if it is still boxed
in the agent takes a free direction among 16. The searcher never declares: it suits tasks that
end when an agent reaches the source (``task.end: reach``); its row reports the best proximity
index and the number of restarts.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import escape_move
from odorloc.behaviours.spiral import Spiral, SpiralParams, proximity_index
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Observation, SearchContext
from odorloc.searchers.base import Searcher

__all__ = ["SpiralSearchParams", "SpiralSearcher"]


class SpiralSearchParams(SpiralParams):
    """The spiral's settings (:class:`~odorloc.behaviours.spiral.SpiralParams`) and
    ``max_skips``: blocked legs skipped before the spiral restarts."""

    max_skips: int = Field(3, ge=0, le=10_000)


@register("searcher", "spiral", SpiralSearchParams, "square spiral restarted on a better signal")
class SpiralSearcher(Searcher):
    """Square-spiral search with a proximity index, one spiral per agent."""

    params: SpiralSearchParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.spirals = [Spiral(self.params) for _ in range(ctx.n_agents)]
        self.window: list[list[float]] = [[] for _ in range(ctx.n_agents)]
        self.moving = [False] * ctx.n_agents

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        cmds: list[Command | None] = []
        for i, o in enumerate(observations):
            if self.moving[i]:
                if not o.ready:
                    cmds.append(None)
                    continue
                self.moving[i] = False
            self.window[i].append(float(o.gas))
            if len(self.window[i]) < self.params.measure_periods:
                cmds.append(Command.hold())
                continue
            p = self.params
            index = proximity_index(np.array(self.window[i]), self.ctx.dt, p.kmu, p.kp)
            self.window[i] = []
            self.spirals[i].judge(index, o.heading, p.patience, p.decay)
            cmds.append(self._leg(i, o, rng))
            self.moving[i] = cmds[-1].kind == "waypoint"
        return Action(cmds)

    def _leg(self, i: int, o: Observation, rng: np.random.Generator) -> Command:
        arena = self.ctx.arena
        pos = np.asarray(o.position, float)
        target = self.spirals[i].free_leg(arena, pos, self.params.max_skips, o.heading)
        if target is not None:
            return Command.waypoint(target)
        d = escape_move(arena, pos, self.params.initial_step, rng)
        return Command.hold() if d is None else Command.waypoint(pos + d)

    def diagnostics(self) -> dict[str, float]:
        return {"proximity_best": self.spirals[0].best, "spiral_step": self.spirals[0].step}

    def final_metrics(self) -> dict[str, Any]:
        return {
            "spiral_restarts": float(sum(s.restarts for s in self.spirals)),
            "proximity_best": float(max(s.best for s in self.spirals)),
        }
