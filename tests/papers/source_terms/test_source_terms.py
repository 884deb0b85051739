"""The source-term reproduction's pieces: scoring a posterior against the truth, its settings."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from odorloc.experiments import reproduction as rp
from odorloc.inference.source_terms import SourceTermBelief
from odorloc.models.source_term import ThetaLayout
from odorloc.papers.source_terms.reproduction import SEARCHERS, score_posterior, truth_columns
from odorloc.scenarios import get_scenario


def _snapshot(n: int = 1500) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    th = np.column_stack(
        [rng.normal(20.0, 1.0, n), rng.normal(30.0, 0.5, n), rng.normal(math.log(0.2), 0.2, n)]
    )
    return SourceTermBelief.of(th, np.zeros(n), ThetaLayout(2)).snapshot()


def test_a_posterior_is_scored_against_the_truth() -> None:
    snap = _snapshot()
    near = score_posterior(snap, np.array([20.3, 29.9]), 0.21)
    assert near["covered_position"] and near["covered_rate"]
    assert near["pos_error"] == pytest.approx(math.hypot(0.3, 0.1), abs=0.1)
    assert near["rate_factor"] == pytest.approx(1.05, abs=0.03)
    far = score_posterior(snap, np.array([25.0, 30.0]), 0.6)
    assert not far["covered_position"] and not far["covered_rate"]
    assert far["pit_x"] == pytest.approx(1.0) and far["pit_rate"] == pytest.approx(1.0)
    assert 0.5 < near["pit_x"] < 0.7 and 0.35 < near["pit_y"] < 0.65


def test_without_stores_the_rows_are_left_as_they_are() -> None:
    df = pd.DataFrame({"sweep": ["search"], "status": ["ok"]})
    assert truth_columns(df, None) is df


def test_the_benchmark_setting_is_the_documented_one() -> None:
    """ste-gaussian keeps gym_ste's court, start, success rule and wind."""
    sc = get_scenario("ste-gaussian")
    assert sc.world.arena.upper == (55.0, 55.0)
    assert sc.agents.starts == [(5.0, 10.0)] or np.allclose(sc.agents.starts, [[5.0, 10.0]])
    assert sc.task.success_radius == pytest.approx(0.05 * 55)
    draw = sc.world.source_draw.values
    assert draw["min_start_distance"] == pytest.approx(0.3 * 55)
    assert np.allclose(draw["region"], [[0.2 * 55, 0.2 * 55], [0.8 * 55, 0.8 * 55]])
    w = np.asarray(sc.world.wind.values["velocity"])
    assert np.hypot(*w) == pytest.approx(2.0, abs=1e-3)
    assert math.degrees(math.atan2(w[1], w[0])) % 360 == pytest.approx(220.0, abs=0.1)


def test_the_sweeps_cover_every_method_and_the_episode_counts() -> None:
    r = rp.get("source-terms")
    default = r.sweeps(None, 1)
    assert set(default) == {"search", "calibration", "multi"}
    assert default["calibration"]["episodes"] == 200
    labels = [s["label"] for s in default["search"]["searchers"]]
    assert labels == list(SEARCHERS) and len(labels) == 7
    assert {s["name"] for s in default["search"]["scenarios"]} == {
        "ste-gaussian",
        "ste-vergassola-3d",
    }
    assert all(s["episodes"] == 3 for s in r.sweeps(3, 1).values())


def test_only_the_sweeps_that_ran_get_tables_and_figures(tmp_path) -> None:
    """`--only multi` shows the several-sources table and figure, no empty ones of the
    sweeps that did not run; all three sweeps give all three."""
    r = rp.get("source-terms")
    multi = pd.DataFrame(
        {"sweep": ["multi"], "status": ["ok"], "scenario": ["two-sources-farrell"]}
    )
    names = [f.name for f in r.figures(multi, None, tmp_path, 1)]
    assert names == ["several_sources.png"]
    everything = pd.DataFrame(
        {
            "sweep": ["search", "calibration", "multi"],
            "status": ["ok"] * 3,
            "scenario": ["ste-gaussian", "ste-calibration", "ste-three-sources-farrell"],
        }
    )
    names = [f.name for f in r.figures(everything, None, tmp_path, 1)]
    assert names == ["posterior_marginals.png", "calibration_pit.png", "several_sources.png"]


def test_three_sources_get_time_to_declare() -> None:
    """The mapping route declares between 5 200 and 7 300 s in this flow (six seeds): the
    limit leaves it room, unlike the two-source file's 5 000 s."""
    three = get_scenario("ste-three-sources-farrell")
    assert three.limits.time >= 10_000.0
    assert get_scenario("two-sources-farrell").limits.time < three.limits.time
