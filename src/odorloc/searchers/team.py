"""Decentralised teams: every agent runs its own searcher and talks only through messages.

:class:`PerAgentTeam` wraps one single-agent searcher per agent. Each member sees only its own
observation (with the messages its neighbours sent within the communication radius, delivered
by the engine) and broadcasts what its own :class:`~odorloc.searchers.base.Action` says; the
engine accounts the bytes. A centralised controller (a formation) instead implements
:class:`~odorloc.searchers.base.Searcher` directly and sees every observation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from pydantic import Field

from odorloc import registry
from odorloc.params import Params
from odorloc.searchers.base import (
    Action,
    Command,
    Declaration,
    Observation,
    SearchContext,
    Searcher,
)


class PerAgentTeamParams(Params):
    """Parameters of :class:`PerAgentTeam`.

    Attributes
    ----------
    member : dict
        The members' searcher: ``{"type": name, **params}`` (each agent gets its own instance).
    declare : "first" | "all"
        The team declares when the first member declares (its positions), or only once every
        member has declared (all members' positions, stacked).
    """

    member: dict[str, Any] = Field(default_factory=lambda: {"type": "random-walk"})
    declare: str = Field("first", pattern="^(first|all)$")


@registry.register("searcher", "per-agent", PerAgentTeamParams, "one searcher per agent")
class PerAgentTeam(Searcher):
    """One independent searcher per agent; coordination only through messages."""

    def __init__(self, params: PerAgentTeamParams) -> None:
        self.params = params
        values = dict(params.member)
        name = values.pop("type", None)
        if not isinstance(name, str):
            from odorloc.errors import ConfigError

            raise ConfigError("searcher.member.type", "a member searcher name is required")
        self._entry = registry.entry("searcher", name, field="searcher.member.type")
        self._member_params = registry.make_params(
            "searcher", name, values, field="searcher.member"
        )

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.members: list[Searcher] = []
        # Each member draws from its own stream, so adding an agent does not change the others.
        for k, child in enumerate(rng.spawn(ctx.n_agents)):
            m = self._entry.build(self._member_params)
            m.reset(replace(ctx, n_agents=1, start=ctx.start[k : k + 1]), child)
            self.members.append(m)
        self._rngs = rng.spawn(ctx.n_agents)
        self._declared: list[Declaration | None] = [None] * ctx.n_agents

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        commands: list[Command | None] = []
        messages: dict[int, dict[str, np.ndarray]] = {}
        for k, (m, o) in enumerate(zip(self.members, observations, strict=True)):
            a = m.act([replace(o, agent=0)], self._rngs[k])
            commands.append(a.commands[0])
            if 0 in a.messages:
                messages[k] = a.messages[0]
            if a.declaration is not None and self._declared[k] is None:
                self._declared[k] = a.declaration
        decl = None
        done = [d for d in self._declared if d is not None]
        if self.params.declare == "first" and done:
            decl = done[0]
        elif self.params.declare == "all" and len(done) == len(self.members):
            decl = Declaration(
                np.vstack([d.positions for d in done]),
                confidence=float(np.mean([d.confidence for d in done])),
            )
        return Action(commands, messages=messages, declaration=decl)

    def belief(self) -> Any | None:
        """The first member's belief (members keep their own)."""
        return self.members[0].belief() if self.members else None

    def member_beliefs(self) -> list[Any | None]:
        """Every member's belief, in agent order."""
        return [m.belief() for m in self.members]
