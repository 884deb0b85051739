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


def test_default_law_stays_honest_when_readings_fluctuate_and_drop_out() -> None:
    """Readings of a turbulent plume: clean air 60 % of the time, else the Gaussian plume's
    mean times an exponential fluctuation. The strict law (Gaussian noise of the sensor only)
    ends confidently wrong, the source many posterior spreads from its estimate; the searcher's
    default law (relative noise 1, miss 0.5) keeps the source within 1.5 spreads."""
    import numpy as np

    from odorloc.core.types import Observation, SearchContext, SensorInfo
    from odorloc.geometry.arena import Arena
    from odorloc.inference.source_terms import SourceTermEstimator, SourceTermParams
    from odorloc.models.source_term import (
        GaussianSourceTermModel,
        GaussianSourceTermParams,
        SourceTerms,
    )
    from odorloc.searchers.source_term import SourceTermSearchParams

    ctx = SearchContext(
        arena=Arena.box([0.0, 0.0], [30.0, 30.0], 0.5),
        dt=1.0,
        agent_ids=(0,),
        start=np.ones((1, 2)),
        speed_limits=np.array([1.0]),
        sensor=SensorInfo(threshold=0.2),
    )
    src, wind = np.array([[8.0, 15.0]]), np.array([1.0, 0.0])
    strict = GaussianSourceTermModel(GaussianSourceTermParams(threshold=0.2))
    default = SourceTermSearchParams().model.build("model")
    for seed in range(4):
        rng = np.random.default_rng(seed)
        pts = np.column_stack([rng.uniform(10, 28, 60), rng.uniform(10, 20, 60)])
        mean = strict.signal(pts, SourceTerms.single(src, 10.0), np.tile(wind, (60, 1)))[:, 0]
        z = np.where(rng.random(60) < 0.6, 0.0, mean * rng.exponential(1.0, 60))
        ratio = {}
        for name, model in (("strict", strict), ("default", default)):
            est = SourceTermEstimator(SourceTermParams(n_particles=300, wind_average=1))
            est.reset(ctx, model, np.random.default_rng(seed))
            for t in range(60):
                est.update(
                    Observation(
                        agent=0,
                        t=float(t),
                        position=pts[t],
                        heading=0.0,
                        gas=float(z[t]),
                        detection=bool(z[t] > 0.2),
                        wind=wind,
                    )
                )
            error = float(np.hypot(*(est.estimate()[0] - src[0])))
            ratio[name] = error / est.spread()
        assert ratio["strict"] > 5.0, (seed, ratio)
        assert ratio["default"] < 1.5, (seed, ratio)
