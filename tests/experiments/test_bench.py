"""The benchmark (``odorloc bench``): suite, methods, board, ranks, results JSON and its diff.

The runs here use the shipped suite's ``otto-19x19`` task with 24 episodes in one process
(a few seconds); the full agreement with OTTO's numbers is the standard tier's (1000 episodes).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from odorloc.cli import app
from odorloc.core.errors import ConfigError
from odorloc.experiments.bench import (
    compare_results,
    load_results,
    load_suite,
    method_from_option,
    run_bench,
)
from odorloc.experiments.bench.results import overall_board, rank_rows
from odorloc.experiments.bench.suite import task_methods

EPISODES = 24
USER = "bench_methods:BlunderInfotaxis"
TIMING = ("cpu_ms_per_decision",)


def _mini_suite(episodes: int = EPISODES) -> dict[str, Any]:
    """The shipped suite reduced to its 19 x 19 lattice task with ``episodes`` episodes."""
    data = load_suite().model_dump(mode="json")
    task = next(t for t in data["tasks"] if t["name"] == "otto-19x19")
    task["episodes"] = {"quick": episodes, "standard": episodes}
    data["tasks"] = [task]
    return data


def _run(out: Path, methods: list[str], extra: tuple[str, ...] = ()) -> dict[str, Any]:
    return run_bench(
        out,
        suite=_mini_suite(),  # type: ignore[arg-type]
        tier="quick",
        methods=methods,
        extra=extra,
        workers=1,
        progress=False,
        html=False,
    )


def _steady(row: dict[str, Any]) -> dict[str, Any]:
    """A row without its timing columns (machine-dependent)."""
    return {k: v for k, v in row.items() if not k.startswith(TIMING)}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    base = tmp_path_factory.mktemp("bench")
    a = _run(base / "board", ["infotaxis", "greedy"])
    a_json = json.loads((base / "board" / "results.json").read_text())
    # the same folder again, with a user method by import path: the stored rows carry over
    b = _run(base / "board", ["infotaxis", "greedy"], (USER,))
    weak = _run(base / "weak", [f"infotaxis={USER}"])
    return {"a": a, "a_json": a_json, "b": b, "weak": weak, "base": base}


def test_results_json_schema(runs: dict[str, Any]) -> None:
    doc = runs["a_json"]
    assert doc["schema"] == "odorloc-bench/1"
    assert doc["suite"] == "2027.1" and doc["tier"] == "quick"
    for key in ("odorloc_version", "machine", "seed", "wall_time_s", "started"):
        assert key in doc
    (task,) = doc["tasks"]
    assert len(task["seeds"]) == EPISODES
    assert {r["method"] for r in doc["rows"]} == {"infotaxis", "greedy"}
    for r in doc["rows"]:
        assert r["episodes"] == EPISODES and r["errors"] == 0
        assert 0 <= r["success_lo"] <= r["success"] <= r["success_hi"] <= 1
        assert r["search_time_lo"] <= r["search_time"] <= r["search_time_hi"]
        # path over start distance: a lattice walker never beats the straight line by more
        # than the Manhattan factor sqrt(2)
        assert r["path_ratio"] >= 1 / math.sqrt(2)
        assert sum(r["failures"].values()) == r["episodes"] - r["successes"]


def test_user_method_adds_its_row_and_changes_nothing_else(runs: dict[str, Any]) -> None:
    a, b = runs["a"], runs["b"]
    rows_a = {r["method"]: _steady(r) for r in a["rows"]}
    rows_b = {r["method"]: _steady(r) for r in b["rows"]}
    assert set(rows_b) == set(rows_a) | {"BlunderInfotaxis"}
    for name, row in rows_a.items():
        assert rows_b[name] == row, name
    new = rows_b["BlunderInfotaxis"]
    assert new["source"] == "import" and new["searcher"] == USER
    assert a["tasks"][0]["seeds"] == b["tasks"][0]["seeds"]


def test_compare_flags_a_weakened_method(runs: dict[str, Any]) -> None:
    diff = compare_results(runs["a"], runs["weak"])
    worse = [c for c in diff["changes"] if c["method"] == "infotaxis"]
    assert any(c["metric"] == "search_time" and c["verdict"] == "worse" for c in worse)
    assert not [c for c in diff["changes"] if c["verdict"] == "better"]
    assert diff["removed"] == ["otto-19x19/greedy"]
    # a run compared with itself changes nothing
    assert compare_results(runs["a"], runs["a"])["changes"] == []


def test_cli_compare_exit_status(runs: dict[str, Any]) -> None:
    base = runs["base"]
    a, w = base / "board" / "results.json", base / "weak" / "results.json"
    res = CliRunner().invoke(app, ["bench", "compare", str(a), str(w), "--fail-on-worse"])
    assert res.exit_code == 1, res.output
    assert "worse" in res.output and "search_time" in res.output
    res = CliRunner().invoke(app, ["bench", "compare", str(a), str(a), "--fail-on-worse"])
    assert res.exit_code == 0 and "no change" in res.output


def test_lattice_rows_agree_with_otto(runs: dict[str, Any]) -> None:
    """Mean moves of the found episodes against OTTO's (otto-pomdp.md): within 1.96 combined
    standard errors (ours from 24 episodes: a loose check; the standard tier's 1000 episodes
    make it tight)."""
    for r in runs["a"]["rows"]:
        ref = r["reference"]
        assert ref["agrees"], (r["method"], r["search_time"], ref)
        assert ref["tolerance"] == pytest.approx(
            1.96 * math.hypot(r["search_time_sem"], ref["sem"])
        )


def test_ranks_share_overlapping_intervals() -> None:
    def row(name: str, s: float, lo: float, hi: float, t: float | None = None) -> dict:
        tt = (
            {}
            if t is None
            else {"search_time": t, "search_time_lo": t - 1, "search_time_hi": t + 1}
        )
        return {"task": "x", "method": name, "success": s, "success_lo": lo, "success_hi": hi, **tt}

    rows = rank_rows(
        [row("a", 0.9, 0.7, 1.0), row("b", 0.8, 0.6, 0.95), row("c", 0.1, 0.0, 0.3)], "success"
    )
    assert [(r["method"], r["rank"]) for r in rows] == [("a", 1), ("b", 1), ("c", 3)]
    rows = rank_rows(
        [row("a", 1, 0.9, 1, 10.0), row("b", 1, 0.9, 1, 11.5), row("c", 1, 0.9, 1, 20.0)],
        "search_time",
    )
    assert [(r["method"], r["rank"]) for r in rows] == [("a", 1), ("b", 1), ("c", 3)]
    board = overall_board(rows)
    assert [a["method"] for a in board] == ["a", "b", "c"]
    assert board[-1]["mean_rank"] == 1.0


def test_every_task_has_methods_and_skips_say_why() -> None:
    suite = load_suite()
    for task in suite.tasks:
        app_ = task_methods(suite, task)
        assert app_.methods, task.name
        assert all(why for why in app_.skipped.values())
    lattice = task_methods(suite, suite.task("otto-19x19"))
    assert "infotaxis" in [m.name for m in lattice.methods]
    assert "policy" in lattice.skipped
    teams = task_methods(suite, suite.task("muc-osl-3d"))
    assert "infotaxis" in teams.skipped and "agent" in teams.skipped["infotaxis"]


def test_preset_file_is_a_method(tmp_path: Path) -> None:
    f = tmp_path / "my.yaml"
    f.write_text("name: my-greedy\nbase: infotaxis\nparams: {planner: {reward: {type: greedy}}}\n")
    m = method_from_option(str(f))
    assert (m.name, m.searcher, m.source) == ("my-greedy", "infotaxis", "preset")
    assert m.params == {"planner": {"reward": {"type": "greedy"}}}


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"tier": "fast"}, "--tier"),
        ({"tasks": ["nope"]}, "--tasks"),
        ({"methods": ["nope"]}, "--method"),
        ({"extra": ["nope.module:Nothing"]}, "--method"),
        ({"suite": "1999.9"}, "--suite"),
    ],
)
def test_bad_input_is_refused_before_work(
    tmp_path: Path, kwargs: dict[str, Any], field: str
) -> None:
    with pytest.raises(ConfigError) as err:
        run_bench(tmp_path / "out", progress=False, **kwargs)
    assert err.value.field == field
    assert not (tmp_path / "out").exists()


def test_bad_suite_and_results_files(tmp_path: Path) -> None:
    data = _mini_suite()
    data["tasks"][0]["rank_by"] = "speed"
    with pytest.raises(ConfigError) as err:
        load_suite(data)
    assert "rank_by" in err.value.field
    bad = tmp_path / "x.json"
    bad.write_text(json.dumps({"schema": "other"}))
    with pytest.raises(ConfigError, match="not a benchmark results file"):
        load_results(bad)
    with pytest.raises(ConfigError) as err:
        compare_results({"suite": "1", "rows": []}, {"suite": "2", "rows": []})
    assert err.value.field == "suite"


def test_cli_bad_tier_is_one_line(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["bench", "run", "--tier", "fast", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "--tier" in res.output and "Traceback" not in res.output


def test_cli_board_redraws_a_results_file(runs: dict[str, Any], tmp_path: Path) -> None:
    src = runs["base"] / "board" / "results.json"
    md = tmp_path / "board.md"
    res = CliRunner().invoke(
        app, ["bench", "board", str(src), "--out", str(tmp_path / "html"), "--markdown", str(md)]
    )
    assert res.exit_code == 0, res.output
    text = md.read_text()
    assert "| rank | method |" in text and "BlunderInfotaxis" in text and "agrees" in text
    page = (tmp_path / "html" / "leaderboard.html").read_text()
    assert "otto-19x19-success.png" in page
    assert (tmp_path / "html" / "figures" / "otto-19x19-success.png").exists()
