"""The single-agent comparison: its settings are valid for every world and strategy, it runs end
to end through the sweep harness, and the detection-model fit recovers a known model."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.registry import make_params
from odorloc.experiments.runner import cell_scenario
from odorloc.experiments.sweep import expand_tasks, load_sweep, run_sweep, validate_names
from odorloc.models.vergassola import vergassola_rate
from odorloc.papers.infotaxis import reproduction as rp
from odorloc.papers.infotaxis.calibration import detection_map, fit_detection_model
from odorloc.scenarios import Scenario


@pytest.mark.parametrize("world", list(rp.WORLDS))
def test_every_strategy_has_valid_settings_in_every_world(world: str) -> None:
    for s in rp.STRATEGIES:
        make_params("searcher", s, rp.SEARCHER_PARAMS[world][s])
    spec = load_sweep(rp.SingleAgentReproduction().sweep(2, 1))
    validate_names(spec)
    task = next(t for t in expand_tasks(spec) if t.cell["scenario_label"] == world)
    sc = rp.prepare(cell_scenario(task.cell), task)
    assert sc.task.end == "reach" and sc.task.reach_radius is not None
    assert sc.searcher.values == {**rp.SEARCHER_PARAMS[world][sc.searcher.type]}


def test_runs_end_to_end_through_the_harness(tmp_path) -> None:
    spec = rp.SingleAgentReproduction().sweep(1, 3)
    # short episodes: every strategy in the rate world (live), two in a replayed filament world
    spec["scenarios"] = [
        {**s, "params": {**s["params"], "limits.time": 20.0}}
        for s in spec["scenarios"]
        if s["label"] in ("uav3d", "indoor")
    ]
    spec["keep_episodes"] = []
    df = run_sweep(
        spec, tmp_path / "s.sqlite", workers=1, progress=False, group_fn=rp.single_agent_group
    )
    assert (df["status"] == "ok").all(), df[df["status"] != "ok"]["error"].tolist()
    assert len(df) == 2 * len(rp.STRATEGIES)
    assert set(df["termination"]) <= {"reached", "time_limit"}
    assert df[df["scenario"] == "indoor"]["replay"].fillna(False).all()
    tables = rp.SingleAgentReproduction().tables(df, 3)
    assert [t.name for t in tables][-1] == "single_agent_families"
    assert all(len(t.rows) for t in tables)


def test_detection_model_fit_recovers_a_known_model() -> None:
    rng = np.random.default_rng(0)
    pts = np.stack(np.meshgrid(np.linspace(1, 19, 19), np.linspace(1, 9, 9), indexing="ij"), -1)
    pts = pts.reshape(-1, 2)
    src = [3.0, 5.0]
    truth = {"Q": 2.0, "D": 0.5, "tau": 20.0}
    wind = np.array([1.0, 0.0])
    r = vergassola_rate(
        pts,
        np.array([src]),
        truth["Q"],
        V=1.0,
        D=truth["D"],
        tau=truth["tau"],
        a=0.1,
        direction=wind,
    )[:, 0]
    periods = 400
    hits = rng.binomial(periods, -np.expm1(-r * 0.5))
    fit = fit_detection_model(
        pts,
        hits,
        periods,
        src,
        wind,
        0.5,
        D=(0.2, 0.5, 1.0),
        tau=(10.0, 20.0, 50.0),
        Q=(1.0, 2.0, 5.0),
    )
    assert (fit["Q"], fit["D"], fit["tau"]) == (2.0, 0.5, 20.0)
    assert fit["V"] == pytest.approx(1.0) and fit["wind_direction"] == (1.0, 0.0)


@pytest.mark.parametrize(("world", "step"), [("indoor", 0.2), ("farrell", 1.0)])
def test_default_fit_gives_the_recorded_detection_models(world: str, step: float) -> None:
    """``fit_detection_model`` with its defaults, on 300 s of flow at seed 99 and probes at the
    cell centres of the documented lattice, gives the models the comparison uses."""
    sc = cell_scenario(
        {"scenario": rp.WORLDS[world]["name"], "scenario_params": rp.WORLDS[world]["params"]}
    )
    lo, hi = np.asarray(sc.world.arena.lower), np.asarray(sc.world.arena.upper)
    axes = [np.arange(a + step / 2, b, step) for a, b in zip(lo, hi, strict=True)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(lo))
    hits, periods, wind = detection_map(sc, pts, 300.0, seed=99)
    rec = rp.FITTED_MODELS[world]
    fit = fit_detection_model(
        pts,
        hits,
        periods,
        sc.world.sources[0].position,
        wind,
        sc.limits.control_dt,
        sensor_radius=rec["sensor_radius"],
    )
    assert {k: fit[k] for k in ("Q", "D", "tau")} == {k: rec[k] for k in ("Q", "D", "tau")}
    assert fit["V"] == pytest.approx(rec["V"], abs=5e-4)


def test_detection_map_reads_the_threshold() -> None:
    sc = Scenario.from_dict(
        {
            "world": {
                "arena": {"lower": [0.0, 0.0], "upper": [10.0, 4.0], "resolution": 0.1},
                "sources": [{"position": [1.0, 2.0], "rate": 1.0}],
                "wind": {"type": "uniform", "velocity": [0.5, 0.0]},
                "plume": {"type": "gaussian"},
            },
            "sensors": {"gas": {"type": "concentration", "threshold": 0.5}},
            "agents": {"starts": [[8.0, 2.0]]},
        }
    )
    pts = np.array([[2.0, 2.0], [2.0, 3.5], [0.5, 2.0]])
    hits, n, wind = detection_map(sc, pts, 5.0)
    assert n == 10
    np.testing.assert_allclose(wind, [0.5, 0.0])
    assert hits.tolist() == [10, 0, 0]  # steady plume: downwind on the axis only, never upwind


def _calibration_world() -> Scenario:
    return Scenario.from_dict(
        {
            "world": {
                "arena": {"lower": [0.0, 0.0], "upper": [10.0, 4.0], "resolution": 0.1},
                "sources": [{"position": [1.0, 2.0], "rate": 1.0}],
                "wind": {"type": "uniform", "velocity": [0.5, 0.0]},
                "plume": {"type": "gaussian"},
            },
            "sensors": {"gas": {"type": "concentration", "threshold": 0.5}},
            "agents": {"starts": [[8.0, 2.0]]},
        }
    )


def test_detection_map_refuses_a_stretch_shorter_than_one_period() -> None:
    sc = _calibration_world()
    pts = np.array([[2.0, 2.0], [2.0, 3.5]])
    for duration in (0.1, 0.0, float("nan")):
        with pytest.raises(ConfigError, match="duration"):
            detection_map(sc, pts, duration)
    with pytest.raises(ConfigError, match="points"):
        detection_map(sc, np.array([2.0, 2.0]), 5.0)


def test_detection_model_fit_refuses_inconsistent_data() -> None:
    pts = np.array([[2.0, 2.0], [2.0, 3.5]])
    src, wind = [1.0, 2.0], np.array([0.5, 0.0])
    good = {"points": pts, "hits": np.array([10, 0]), "periods": 10, "source": src, "wind": wind}
    bad = {
        "hits": [{"hits": np.array([10])}, {"hits": np.array([11, 0])}],
        "periods": [{"periods": 0}, {"periods": 2.5}],
        "wind": [{"wind": np.zeros(2)}, {"wind": np.array([np.nan, 0.0])}],
        "source": [{"source": [1.0, 2.0, 0.0]}],
        "sensor_radius": [{"sensor_radius": 50.0}],
    }
    for field, cases in bad.items():
        for case in cases:
            args = {**good, **case}
            radius = args.pop("sensor_radius", 0.1)
            with pytest.raises(ConfigError, match=field):
                fit_detection_model(**args, dt=0.5, sensor_radius=radius)
    assert fit_detection_model(**good, dt=0.5)["Q"] > 0
