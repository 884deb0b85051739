"""Decentralised teams: per-agent searchers, message delivery within the radius, byte accounting."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import filament_scenario_dict
from odorloc.engine.episode import run_episode
from odorloc.errors import ConfigError
from odorloc.registry import Entry
from odorloc.scenarios import Scenario
from odorloc.scenarios.build import build
from odorloc.searchers.base import Action, Command, Searcher


class _Talker(Searcher):
    """Holds still and broadcasts 8 float64 (64 bytes) every step; remembers what it heard."""

    def __init__(self, params=None) -> None:
        self.heard: list[int] = []

    def act(self, observations, rng):
        self.heard.extend(m.sender for m in observations[0].messages)
        return Action([Command.hold()], messages={0: {"x": np.zeros(8)}})


def _team_scenario(starts, radius: float) -> Scenario:
    d = filament_scenario_dict("per-agent", member={"type": "zigzag"})
    d["agents"] = {"starts": starts, "comm_radius": radius}
    d["limits"]["time"] = 5.0
    return Scenario.from_dict(d)


def test_messages_reach_only_neighbours_and_bytes_are_counted() -> None:
    # Agents at x = 2, 3 and 6 m: with a 1.5 m radius only agents 0 and 1 are neighbours.
    sc = _team_scenario([[2.0, 1.0], [3.0, 1.0], [6.0, 1.0]], 1.5)
    b = build(sc)
    b.searcher._entry = Entry("searcher", "talker", type(None), _Talker, "")
    res = run_episode(sc, 1, 2, built=b)
    talkers = b.searcher.members
    n_steps = res.metrics["steps"]  # messages are sent after each of the steps 0..n-1
    assert set(talkers[0].heard) == {1} and set(talkers[1].heard) == {0}
    assert talkers[2].heard == []
    # 2 deliveries of 64 bytes per step (0 -> 1 and 1 -> 0).
    assert res.metrics["bytes"] == n_steps * 2 * 64


def test_per_agent_zigzag_team_runs_and_members_are_independent() -> None:
    sc = _team_scenario([[8.0, 1.0], [8.0, 4.0]], float("inf"))
    res = run_episode(sc, 3, 4)
    pos = res.recording.positions
    assert pos.shape[1] == 2
    assert not np.allclose(pos[:, 0], pos[:, 1])
    assert res.metrics["bytes"] == 0  # zigzag members say nothing


def test_unknown_member_is_a_field_error() -> None:
    d = filament_scenario_dict("per-agent", member={"type": "nope"})
    with pytest.raises(ConfigError) as ei:
        build(Scenario.from_dict(d))
    assert ei.value.field == "searcher.member.type"
