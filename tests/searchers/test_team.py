"""Decentralised teams: per-agent searchers, message delivery within the radius, byte accounting."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import filament_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.types import Action, Command, Declaration
from odorloc.engine.episode import Episode, run_episode
from odorloc.scenarios import Scenario
from odorloc.scenarios.build import build, search_context
from odorloc.searchers.base import Searcher


class Talker(Searcher):
    """Holds still and broadcasts 8 float64 (64 bytes) every step; remembers what it heard."""

    Params = Params
    max_agents = 1

    def __init__(self, params=None) -> None:
        super().__init__(params or Params())
        self.heard: list[int] = []

    def act(self, observations, rng):
        o = observations[0]
        self.heard.extend(m.sender for m in o.messages)
        return Action([Command.hold()], messages={o.agent: {"x": np.zeros(8)}})


class Dice(Searcher):
    """Holds still; remembers the first draw of the stream it was reset with and of each
    stream it acts with."""

    Params = Params
    max_agents = 1

    def reset(self, ctx, rng) -> None:
        super().reset(ctx, rng)
        self.first = float(rng.random())
        self.draws: list[float] = []

    def act(self, observations, rng):
        self.draws.append(float(rng.random()))
        return Action([Command.hold()])


def _team_scenario(starts, radius: float, member: str = "zigzag") -> Scenario:
    d = filament_scenario_dict("per-agent", member={"type": member})
    d["agents"] = {"starts": starts, "comm_radius": radius}
    d["limits"]["time"] = 5.0
    return Scenario.from_dict(d)


def test_messages_reach_only_neighbours_and_bytes_are_counted() -> None:
    # Agents at x = 2, 3 and 6 m: with a 1.5 m radius only agents 0 and 1 are neighbours.
    # A member named by import path ("module:Class"): no registration needed.
    sc = _team_scenario([[2.0, 1.0], [3.0, 1.0], [6.0, 1.0]], 1.5, member="test_team:Talker")
    b = build(sc)
    res = run_episode(sc, 1, 2, built=b)
    talkers = b.searcher.members
    n_steps = res.metrics["steps"]  # messages are sent after each of the steps 0..n-1
    assert set(talkers[0].heard) == {1} and set(talkers[1].heard) == {0}
    assert talkers[2].heard == []
    # 2 deliveries of 64 bytes per step (0 -> 1 and 1 -> 0).
    assert res.metrics["bytes"] == n_steps * 2 * 64


def test_per_agent_zigzag_team_runs_and_says_nothing() -> None:
    sc = _team_scenario([[8.0, 1.0], [8.0, 4.0]], float("inf"))
    res = run_episode(sc, 3, 4)
    assert res.recording.positions.shape[1:] == (2, 2)
    assert res.metrics["bytes"] == 0  # zigzag members say nothing


def test_members_draw_from_separate_streams() -> None:
    # one generator shared by the members (or two seeded alike) would give equal draws
    sc = _team_scenario([[8.0, 1.0], [8.0, 4.0], [5.0, 3.0]], float("inf"), member="test_team:Dice")
    b = build(sc)
    team = b.searcher
    team.reset(search_context(sc, b), np.random.default_rng(7))
    obs = Episode(sc, built=b).reset(1, 2)
    team.act(obs, np.random.default_rng(8))
    team.act(obs, np.random.default_rng(9))
    # each member was reset with a stream of its own and acts with another of its own, which
    # goes on from step to step (the generator passed to the team's act is not the members')
    firsts = [m.first for m in team.members]
    acts = [tuple(m.draws) for m in team.members]
    assert len(set(firsts)) == 3 and len(set(acts)) == 3
    assert not set(firsts) & {d for a in acts for d in a}
    assert all(a[0] != a[1] for a in acts)
    again = build(sc).searcher
    again.reset(search_context(sc, b), np.random.default_rng(7))
    again.act(obs, np.random.default_rng(123))
    assert [m.draws[0] for m in again.members] == [a[0] for a in acts]


def test_an_agents_path_does_not_depend_on_where_the_others_are() -> None:
    # random-walk members draw every step: moving agent 1 elsewhere must leave agent 0's path as
    # it was, to the bit (nothing passes between members that say nothing, and the bodies stay
    # apart), while agent 1's own path changes
    starts = [[8.0, 1.0], [8.0, 4.0]]
    pos = run_episode(_team_scenario(starts, float("inf"), "random-walk"), 3, 4).recording.positions
    moved = [[8.0, 1.0], [5.0, 3.0]]
    other = run_episode(
        _team_scenario(moved, float("inf"), "random-walk"), 3, 4
    ).recording.positions
    assert not np.array_equal(pos[1:, 0], pos[:-1, 0])  # agent 0 does move
    np.testing.assert_array_equal(other[:, 0], pos[:, 0])
    assert not np.array_equal(other[:, 1], pos[:, 1])


def test_unknown_member_is_a_field_error_when_the_scenario_loads() -> None:
    d = filament_scenario_dict("per-agent", member={"type": "nope"})
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(d)
    assert ei.value.field == "searcher.member.type"
    d = filament_scenario_dict("per-agent", member={"type": "zigzag", "angle_deg": -5})
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(d)
    assert ei.value.field == "searcher.member.angle_deg"


def test_members_keep_global_agent_ids_and_every_belief_is_recorded() -> None:
    d = filament_scenario_dict("per-agent", member={"type": "pf-entropy"})
    d["agents"] = {"starts": [[8.0, 2.0], [8.0, 3.0], [8.0, 2.5]]}
    d["limits"]["time"] = 30.0
    d["recording"] = {"belief_stride": 1}
    sc = Scenario.from_dict(d)
    b = build(sc)
    res = run_episode(sc, 5, 6, built=b)
    assert [m.ctx.agent_ids for m in b.searcher.members] == [(0,), (1,), (2,)]
    owners = {int(snap["agent"]) for _, snap in res.recording.beliefs}
    detected = {
        k for k in range(3) if res.recording.detection[:, k].any()
    }  # a PF exists once its agent detected
    assert owners == detected and len(owners) >= 2


def test_a_members_declaration_is_tagged_and_the_end_rule_decides() -> None:
    class Declarer(Searcher):
        def act(self, observations, rng):
            o = observations[0]
            decl = Declaration([[1.0, 2.5]]) if o.agent == 1 and o.t >= 1.0 else None
            return Action([Command.hold()], declaration=decl)

    d = filament_scenario_dict("per-agent", member={"type": "passive"})
    d["agents"] = {"starts": [[8.0, 2.0], [8.0, 3.0]]}
    d["task"] = {"end": "limits"}
    d["limits"]["time"] = 5.0
    sc = Scenario.from_dict(d)
    from odorloc.searchers.team import PerAgentTeam, TeamParams

    team = PerAgentTeam(TeamParams.model_validate({"member": {"type": "passive"}}))
    team.reset(_ctx(sc), np.random.default_rng(0))
    team.members[1] = Declarer(team.members[1].params)
    team.members[1].reset(team.ctx.subset((1,)), np.random.default_rng(1))
    res = run_episode(sc, 1, 2, searcher=_Fixed(team))
    assert res.metrics["termination"] == "time_limit" and res.metrics["declared"]
    decl = [e for e in res.events if e.kind == "declaration"]
    assert len(decl) == 1 and decl[0].agent == 1
    assert res.metrics["found_time_0"] == pytest.approx(1.0)


class _Fixed(Searcher):
    """Wraps an already reset searcher (reset is a no-op)."""

    def __init__(self, inner: Searcher) -> None:
        self.inner = inner

    def reset(self, ctx, rng) -> None:
        self.ctx = ctx

    def act(self, observations, rng):
        return self.inner.act(observations, rng)


def _ctx(sc):
    from odorloc.scenarios.build import search_context

    return search_context(sc, build(sc))


class GroupProbe(Searcher):
    """Holds still; remembers which agents it saw and declares its group's centroid once."""

    Params = Params

    def reset(self, ctx, rng) -> None:
        super().reset(ctx, rng)
        self.seen: set[int] = set()

    def act(self, observations, rng):
        self.seen |= {o.agent for o in observations}
        pos = np.mean([o.position for o in observations], axis=0)
        decl = Declaration(pos[None, :]) if observations[0].t >= 1.0 else None
        return Action([Command.hold() for _ in observations], declaration=decl)


def test_per_group_controllers_see_their_group_only_and_declare_per_group() -> None:
    d = filament_scenario_dict("per-group", member={"type": "test_team:GroupProbe"})
    d["agents"] = {
        "starts": [[8.0, 1.0], [8.5, 1.0], [8.0, 4.0], [8.5, 4.0], [6.0, 2.5]],
        "groups": [{"name": "A", "agents": [0, 1]}, {"name": "B", "agents": [2, 3]}],
    }
    d["task"] = {"end": "all_groups"}
    d["limits"]["time"] = 5.0
    sc = Scenario.from_dict(d)
    b = build(sc)
    res = run_episode(sc, 1, 2, built=b)
    seen = [m.seen for m in b.searcher.members]
    assert seen == [{0, 1}, {2, 3}, {4}]  # the ungrouped agent gets a controller of its own
    decl = [e for e in res.events if e.kind == "declaration"]
    assert [e.group for e in decl] == [0, 1, None]
    assert res.metrics["termination"] == "declared" and res.metrics["search_time"] == 1.0
