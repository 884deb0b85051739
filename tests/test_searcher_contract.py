"""Contract tests run over every registered searcher: a short episode through the engine gives a
valid row, commands respect the interface, and the same seeds give the same episode."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import filament_scenario_dict
from odorloc import registry
from odorloc.engine.episode import run_episode
from odorloc.scenarios import Scenario

SEARCHERS = registry.names("searcher")


def _scenario(name: str) -> Scenario:
    d = filament_scenario_dict(name)
    d["limits"]["time"] = 20.0
    d["info"] = {"search_region": [[0.5, 0.5], [9.5, 4.5]]}
    return Scenario.from_dict(d)


@pytest.mark.parametrize("name", SEARCHERS)
def test_every_searcher_runs_a_valid_episode(name: str) -> None:
    sc = _scenario(name)
    res = run_episode(sc, 101, 202)
    m = res.metrics
    assert m["termination"] in ("declared", "time_limit")
    assert 0.0 <= m["search_time"] <= 20.0
    assert math.isfinite(m["path_length"]) and m["path_length"] >= 0.0
    if m["declared"]:
        assert res.declaration is not None
        assert res.declaration.positions.shape[1] == 2
        assert np.all(np.isfinite(res.declaration.positions))
    rec = res.recording
    assert rec is not None
    # The robot stays inside the arena whatever the searcher commands.
    assert np.all(rec.positions >= np.asarray(sc.world.arena.lower) - 1e-9)
    assert np.all(rec.positions <= np.asarray(sc.world.arena.upper) + 1e-9)


@pytest.mark.parametrize("name", SEARCHERS)
def test_every_searcher_is_deterministic_per_seed(name: str) -> None:
    sc = _scenario(name)
    a = run_episode(sc, 7, 8)
    b = run_episode(sc, 7, 8)
    assert np.array_equal(a.recording.positions, b.recording.positions)
    assert a.metrics["search_time"] == b.metrics["search_time"]


@pytest.mark.parametrize("name", SEARCHERS)
def test_every_searcher_rejects_unknown_parameters(name: str) -> None:
    from odorloc.errors import ConfigError

    d = filament_scenario_dict(name, not_a_parameter=1)
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(d)
    assert ei.value.field == "searcher.not_a_parameter"
