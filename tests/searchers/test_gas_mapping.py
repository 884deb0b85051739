"""A searcher carrying a gas map (``gas-mapping``): the same path, the map recorded."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import filament_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.engine.episode import run_episode
from odorloc.scenarios import Scenario
from odorloc.scenarios.build import build


def _scenario(searcher: dict, time: float = 20.0) -> Scenario:
    d = filament_scenario_dict()
    d["searcher"] = searcher
    d["limits"]["time"] = time
    d["recording"]["belief_stride"] = 10
    return Scenario.from_dict(d)


@pytest.mark.parametrize(
    "inner", [{"type": "random-walk"}, {"type": "rectangular-wave", "lane_spacing": 1.0}]
)
def test_the_wrapped_searcher_takes_the_same_path(inner):
    alone = run_episode(_scenario(inner), 3, 4, record=True)
    wrapped = {"type": "gas-mapping", "searcher": inner, "gas_map": {"type": "kernel-dmv"}}
    mapped = run_episode(_scenario(wrapped), 3, 4, record=True)
    assert np.array_equal(alone.recording.positions, mapped.recording.positions)
    assert mapped.metrics["gas_map_readings"] == len(mapped.recording.t)
    assert np.isfinite(mapped.metrics["gas_map_peak_x"])
    snap = mapped.recording.beliefs[-1][1]
    assert int(snap["agent"]) == -1
    assert snap["gas_mean"].shape == snap["gas_confidence"].shape == (40, 20)
    np.testing.assert_allclose(snap["gas_lower"], [0.0, 0.0])


def test_the_map_is_recorded_beside_a_central_belief():
    # ds-mapping records its D-S map as the central belief: one snapshot holds both
    wrapped = {
        "type": "gas-mapping",
        "searcher": {"type": "ds-mapping", "cell_size": 0.5},
        "gas_map": {"type": "gmrf", "cell_size": 0.5},
    }
    res = run_episode(_scenario(wrapped, time=10.0), 1, 2, record=True)
    snap = res.recording.beliefs[-1][1]
    assert {"prob", "m_s", "gas_mean", "gas_variance", "agent"} <= set(snap)
    assert "residual_uncertainty" in res.metrics and "gas_map_readings" in res.metrics


def test_team_members_each_carry_their_own_map():
    member = {"type": "gas-mapping", "searcher": {"type": "random-walk"}}
    d = filament_scenario_dict()
    d["searcher"] = {"type": "per-agent", "member": member}
    d["agents"]["starts"] = [[8.0, 2.0], [8.0, 3.0]]
    d["limits"]["time"] = 10.0
    d["recording"]["belief_stride"] = 10
    res = run_episode(Scenario.from_dict(d), 1, 2, record=True)
    last = [snap for t, snap in res.recording.beliefs if t == res.recording.beliefs[-1][0]]
    assert sorted(int(s["agent"]) for s in last) == [0, 1]
    assert all("gas_mean" in s for s in last)


def test_the_wrapped_searchers_limits_are_checked_when_the_scenario_is_built():
    ds = {"type": "gas-mapping", "searcher": {"type": "ds-mapping"}}
    d = filament_scenario_dict()
    d["searcher"] = ds
    d["agents"]["starts"] = [[8.0, 2.0], [8.0, 3.0]]
    with pytest.raises(ConfigError, match=r"^searcher.type: 'gas-mapping' drives at most 1"):
        build(Scenario.from_dict(d))
    with pytest.raises(ConfigError) as err:
        _scenario({"type": "gas-mapping", "gas_map": {"type": "kernel-dmv", "kernel_width": 0}})
    assert err.value.field == "searcher.gas_map.kernel_width"
    with pytest.raises(ConfigError) as err:
        _scenario({"type": "gas-mapping", "gas_map": {"type": "no-such-map"}})
    assert err.value.field == "searcher.gas_map.type"
