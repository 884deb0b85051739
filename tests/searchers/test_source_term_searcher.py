"""The source-term search recipe: it declares from the credible region, and refuses parts it
cannot use."""

from __future__ import annotations

import pytest

from odorloc.core.errors import ConfigError
from odorloc.engine.episode import run_episode
from odorloc.scenarios import Scenario, get_scenario


def _fixed_source(planner: dict, time: float = 120.0) -> Scenario:
    """ste-gaussian with its source fixed 15 m upwind of the start."""
    data = get_scenario("ste-gaussian").to_dict()
    data["world"].pop("source_draw")
    data["world"]["sources"] = [{"position": [16.0, 20.0], "rate": 0.3}]
    data["agents"]["starts"] = [[5.0, 11.0]]
    data["searcher"]["planner"] = planner
    data["searcher"]["estimator"]["n_particles"] = 1000
    data["limits"]["time"] = time
    return Scenario.from_dict(data)


def test_entrotaxis_declares_the_source_from_its_credible_region() -> None:
    res = run_episode(_fixed_source({"type": "ste-entrotaxis", "directions": 8}), 3, 4)
    m = res.metrics
    assert m["termination"] == "declared" and m["declared_by_rule"] == 1.0
    assert m["success"] and m["loc_error"] < 2.75
    assert m["region_radius"] <= 2.0 + 1e-9
    assert 0.3 / 3 < m["est_rate"] < 0.3 * 3
    assert m["rate_lo"] <= m["est_rate"] <= m["rate_hi"]
    # the wind is in the posterior: its direction within 20 deg of the true 220 deg
    assert abs(((m["est_wind_dir_deg"] - 220.0) + 180.0) % 360.0 - 180.0) < 20.0


def test_a_finished_route_declares_its_estimate() -> None:
    sc = _fixed_source({"type": "ste-lawnmower", "spacing": 20.0}, time=300.0)
    data = sc.to_dict()
    data["searcher"]["declare"] = "never"
    res = run_episode(Scenario.from_dict(data), 3, 4)
    assert res.metrics["termination"] == "declared"
    assert res.metrics["declared_by_rule"] == 0.0
    assert res.declarations[0].confidence == 0.0


def test_parts_that_are_not_source_term_parts_are_refused() -> None:
    from odorloc.scenarios.build import build

    data = get_scenario("ste-gaussian").to_dict()
    data["searcher"]["model"] = {"type": "gaussian"}
    with pytest.raises(ConfigError) as ei:
        build(Scenario.from_dict(data))
    assert ei.value.field == "searcher.model"
    data["searcher"]["model"] = {"type": "ste-gaussian"}
    data["searcher"]["estimator"] = {"type": "ste-pf", "n_particles": 5}
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(data)
    assert ei.value.field.startswith("searcher.estimator.n_particles")
