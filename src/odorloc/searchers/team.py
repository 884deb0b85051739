"""Teams: one searcher per agent, or one controller per group, coordinating through messages.

:class:`PerAgentTeam` (``per-agent``) wraps one searcher per agent. Each member controls only its
own agent: it sees only that agent's observation (with the messages neighbours sent within the
communication radius, delivered by the episode) and broadcasts what its own action says; the
episode accounts the bytes. :class:`PerGroupTeam` (``per-group``) runs one controller per group of
the scenario (``agents.groups``), which sees the observations of its group's agents only; groups
know of each other only what they tell each other in messages.

Members keep the global agent ids (observations, messages, declarations), their own random
streams, and their beliefs are all recorded. A member's first stream (its :meth:`reset`) depends
only on its place in the team; its second (its actions) is spawned after every member's first,
so it depends on the team's size too: a member of a team of three draws other numbers than the
same member of a team of two (seeds give the same episode for the same team, as everywhere).

A member's declaration is forwarded tagged with its agent and group, so the scenario's end rule
(``task.end``) decides whether it ends the episode; with ``declare: all`` the team instead
declares once, when every member has declared.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.searchers.base import Belief, Searcher

__all__ = ["PerAgentTeam", "PerGroupTeam", "TeamParams"]


class TeamParams(Params):
    """Parameters of the teams.

    Attributes
    ----------
    member : dict
        The members' searcher, ``{"type": name, **params}``; every agent (or group) gets its
        own instance. Checked against the searcher registry when the scenario loads.
    declare : {"each", "all"}
        ``each``: every member's first declaration is passed on as it is made; ``all``: the
        team declares once every member has, all members' positions stacked.
    """

    member: Ref("searcher") = ComponentRef(type="random-walk")
    declare: Literal["each", "all"] = "each"


@register("searcher", "per-agent", TeamParams, "one searcher per agent")
class PerAgentTeam(Searcher):
    """One independent searcher per agent; coordination only through messages."""

    params: TeamParams
    unit: ClassVar[str] = "agent"

    def _units(self, ctx: SearchContext) -> list[tuple[tuple[int, ...], int | None]]:
        """``(agent ids, group index)`` of each member."""
        out = []
        for a in ctx.agent_ids:
            g = ctx.group_of(a)
            out.append(((a,), None if g is None else g.index))
        return out

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        ref = self.params.member
        entry_cls = None
        self.units = self._units(ctx)
        self.members: list[Searcher] = []
        # Each member draws from streams of its own, so no member's draws depend on what the
        # others do (the streams of its actions, spawned below, do depend on the team size).
        for (agents, g), child in zip(self.units, rng.spawn(len(self.units)), strict=True):
            m = ref.build("searcher", field="searcher.member")
            entry_cls = type(m)
            if entry_cls.max_agents is not None and len(agents) > entry_cls.max_agents:
                raise ConfigError(
                    "searcher.member.type",
                    f"{ref.type!r} drives at most {entry_cls.max_agents} agent(s), a member "
                    f"controls {len(agents)}",
                )
            if len(agents) < entry_cls.min_agents:
                names = {grp.index: grp.name for grp in ctx.groups or ()}
                what = "the agents outside any group" if g is None else f"group {names[g]!r}"
                raise ConfigError(
                    "agents.groups",
                    f"{ref.type!r} needs at least {entry_cls.min_agents} agents, "
                    f"{what} has {len(agents)}",
                )
            m.reset(ctx.subset(agents), child)
            self.members.append(m)
        self._rngs = rng.spawn(len(self.units))
        self._rows = [[ctx.index(a) for a in agents] for agents, _ in self.units]
        self._declared: list[Declaration | None] = [None] * len(self.units)
        self._team_declared = False

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        ctx = self.ctx
        commands: list[Command | None] = [None] * ctx.n_agents
        messages: dict[int, Mapping[str, np.ndarray]] = {}
        compute: dict[int, float] = {}
        new: list[Declaration] = []
        for k, (m, (agents, group)) in enumerate(zip(self.members, self.units, strict=True)):
            rows = self._rows[k]
            a = m.act([observations[r] for r in rows], self._rngs[k])
            if len(a.commands) != len(agents):
                raise RuntimeError(
                    f"member {k} returned {len(a.commands)} commands for {len(agents)} agents"
                )
            for r, c in zip(rows, a.commands, strict=True):
                commands[r] = c
            for sender, payload in a.messages.items():
                if sender not in agents:
                    raise RuntimeError(f"member {k} sent a message as agent {sender}")
                messages[int(sender)] = payload
            compute.update(a.compute_bits)
            if a.declarations and self._declared[k] is None:
                d = a.declarations[0]
                tagged = Declaration(
                    d.positions,
                    d.confidence,
                    agent=d.agent if d.agent is not None else agents[0],
                    group=d.group if d.group is not None else group,
                )
                self._declared[k] = tagged
                new.append(tagged)
        decls: tuple[Declaration, ...] = ()
        if self.params.declare == "each":
            decls = tuple(new)
        elif not self._team_declared and all(d is not None for d in self._declared):
            done = [d for d in self._declared if d is not None]
            self._team_declared = True
            decls = (
                Declaration(
                    np.vstack([d.positions for d in done]),
                    confidence=float(np.mean([d.confidence for d in done])),
                ),
            )
        return Action(commands, messages=messages, declarations=decls, compute_bits=compute)

    def beliefs(self) -> Mapping[int, Belief]:
        """Every member's belief, keyed by the (first) agent it belongs to."""
        out: dict[int, Belief] = {}
        for m, (agents, _) in zip(self.members, self.units, strict=True):
            b = m.belief()
            if b is not None:
                out[agents[0]] = b
        return out

    def belief(self) -> Belief | None:
        """The first member's belief."""
        return self.members[0].belief() if self.members else None

    def diagnostics(self) -> dict[str, float]:
        """The first member's diagnostics as they are, the others' suffixed ``_<agent>``."""
        out: dict[str, float] = {}
        for k, (m, (agents, _)) in enumerate(zip(self.members, self.units, strict=True)):
            for key, v in m.diagnostics().items():
                out[key if k == 0 else f"{key}_{agents[0]}"] = v
        return out

    def agent_metrics(self) -> dict[int, dict[str, Any]]:
        """Each member's :meth:`final_metrics` (and its own per-agent values) under the
        member's first agent."""
        out: dict[int, dict[str, Any]] = {}
        for m, (agents, _) in zip(self.members, self.units, strict=True):
            for a, values in m.agent_metrics().items():
                out.setdefault(int(a), {}).update(values)
            own = m.final_metrics()
            if own:
                out.setdefault(int(agents[0]), {}).update(own)
        return out


@register("searcher", "per-group", TeamParams, "one controller per group of agents")
class PerGroupTeam(PerAgentTeam):
    """One controller per group (``agents.groups``); without groups, one for the whole team."""

    unit = "group"

    def _units(self, ctx: SearchContext) -> list[tuple[tuple[int, ...], int | None]]:
        if not ctx.groups:
            return [(ctx.agent_ids, None)]
        grouped = {a for g in ctx.groups for a in g.agents}
        units: list[tuple[tuple[int, ...], int | None]] = [
            (tuple(a for a in g.agents if a in ctx.agent_ids), g.index) for g in ctx.groups
        ]
        loose = tuple(a for a in ctx.agent_ids if a not in grouped)
        if loose:
            units.append((loose, None))
        return [u for u in units if u[0]]
