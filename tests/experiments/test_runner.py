"""Group runners every reproduction may use: live groups, a reference task first, and the
outcome table of a comparison."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import yaml

from helpers import small_scenario_dict
from odorloc.experiments.runner import (
    run_cell_episode,
    run_live_group,
    run_replay_group,
    run_with_reference,
)
from odorloc.experiments.stats import bootstrap_ci, mean_sd, outcome_table, wilson_interval
from odorloc.experiments.sweep import expand_tasks, load_sweep


@pytest.fixture(scope="module")
def tasks(tmp_path_factory):
    """One flow (episode 0) seen by three searchers in a 6 s room."""
    d = small_scenario_dict("zigzag")
    d["limits"]["time"] = 6.0
    room = tmp_path_factory.mktemp("room") / "room.yaml"
    room.write_text(yaml.safe_dump(d))
    spec = load_sweep(
        {
            "name": "groups",
            "seed": 5,
            "episodes": 1,
            "scenarios": [{"name": str(room), "label": "room"}],
            "searchers": [{"name": "passive"}, {"name": "zigzag"}, {"name": "random-walk"}],
        }
    )
    return expand_tasks(spec)


def test_a_live_group_gives_each_task_its_own_episode_row(tasks) -> None:
    def slower(sc, task):  # what a reproduction's prepare does: its own settings per task
        return sc.with_overrides({"platform.max_speed": 0.25})

    rows = run_live_group(tasks, prepare=slower)
    for t, row in zip(tasks, rows, strict=True):
        alone = run_cell_episode(
            {**t.cell, "overrides": {"platform.max_speed": 0.25}}, t.world_seed, t.agent_seed
        )
        assert row["status"] == "ok"
        assert row["path_length"] == alone["path_length"]
        assert row["search_time"] == alone["search_time"]
    assert rows[1]["path_length"] <= 0.25 * 6.0 + 1e-9  # the prepared speed was used
    bad = replace(tasks[0], cell={**tasks[0].cell, "scenario": "no-such-scenario"})
    err = run_live_group([bad, tasks[1]])
    assert err[0]["status"] == "error" and "no-such-scenario" in err[0]["error"]
    assert err[1]["status"] == "ok"  # one bad task does not stop the group


def test_the_reference_runs_first_and_a_missing_one_is_run_but_not_returned(tasks) -> None:
    seen: list[list[str]] = []

    def extras(task, res, rows):
        seen[-1].append(task.cell["searcher"])
        ref = next((r for cid, r in rows.items() if cid.endswith("/passive")), None)
        return {"reference_steps": float(ref["steps"]) if ref else math.nan}

    def is_ref(t) -> bool:
        return t.cell["searcher"] == "passive"

    def make_ref(t):
        return next(u for u in tasks if is_ref(u))

    seen.append([])
    rows = run_with_reference(list(reversed(tasks)), is_ref, make_ref, extras=extras)
    assert seen[-1][0] == "passive"  # ran first
    assert [r["status"] for r in rows] == ["ok"] * 3
    # rows in the order of the tasks (the reference last here); the others read its row
    assert math.isnan(rows[-1]["reference_steps"])
    assert all(r["reference_steps"] == rows[-1]["steps"] for r in rows[:-1])
    seen.append([])
    rest = [t for t in tasks if not is_ref(t)]
    rows2 = run_with_reference(rest, is_ref, make_ref, extras=extras)
    assert seen[-1] == ["passive", "zigzag", "random-walk"] and len(rows2) == 2
    direct = run_replay_group([make_ref(tasks[0]), *rest], extras=extras)
    assert [r["path_length"] for r in rows2] == [r["path_length"] for r in direct[1:]]


def test_the_outcome_table_counts_and_bootstraps_as_stated() -> None:
    rng = np.random.default_rng(0)
    rows = []
    for s in ("a", "b"):
        for i in range(9):
            rows.append(
                {
                    "scenario": "w",
                    "searcher": s,
                    "status": "error" if (s == "b" and i == 8) else "ok",
                    "success": bool(i % 3) if s == "a" else i < 2,
                    "search_time": float(rng.uniform(10, 100)),
                    "path_length": float(rng.uniform(1, 10)),
                    "first_detection_time": math.nan if i == 0 else 3.0,
                }
            )
    df = pd.DataFrame(rows)
    t = outcome_table(df, seed=4)
    assert list(t.searcher) == ["a", "b"]
    a, b = t.iloc[0], t.iloc[1]
    assert (a.n, a.successes, a.errors) == (9, 6, 0)
    assert (b.n, b.successes, b.errors) == (8, 2, 1)
    assert (a.success_lo, a.success_hi) == pytest.approx(wilson_interval(6, 9))
    won = df[(df.searcher == "a") & df.success]
    assert a.mean_time == pytest.approx(won.search_time.mean())
    g = np.random.default_rng([4, 0])  # group 0's stream: times first, then paths
    assert (a.time_lo, a.time_hi) == pytest.approx(bootstrap_ci(won.search_time, g))
    assert (a.path_lo, a.path_hi) == pytest.approx(bootstrap_ci(won.path_length, g))
    assert a.detected == pytest.approx(8 / 9)
    empty = outcome_table(df.iloc[:0])
    assert len(empty) == 0 and "success_rate" in empty.columns


def test_mean_and_sd_of_the_finite_values() -> None:
    assert mean_sd([1.0, 3.0, math.nan, math.inf]) == pytest.approx((2.0, math.sqrt(2.0)))
    assert mean_sd([5.0]) == (5.0, 0.0)
    m, s = mean_sd([])
    assert math.isnan(m) and math.isnan(s)
