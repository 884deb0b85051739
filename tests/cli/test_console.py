"""What the console says: units on every metric, fixed-point numbers, the columns that explain
a failure, what a batch added, and ``--no-progress`` hiding only the live bar."""

from __future__ import annotations

import re

import pytest
import yaml
from typer.testing import CliRunner

from helpers import small_scenario_dict
from odorloc.cli import app
from odorloc.experiments.display import (
    explain_failure,
    explain_reach,
    format_metric,
    metric_label,
)

runner = CliRunner()


def test_metrics_are_fixed_point_with_their_units() -> None:
    assert format_metric("search_time", 1200.0) == "1200.0"
    assert format_metric("search_time", 1200.0, unit=True) == "1200.0 s"
    assert format_metric("search_time", 12345.67, unit=True) == "12,345.7 s"
    assert format_metric("energy", 3412594.4, unit=True) == "3,412,594 J"
    assert format_metric("loc_error", 0.7912, unit=True) == "0.79 m"
    assert format_metric("success", True) == "yes"
    assert format_metric("loc_error", float("nan")) == "-"
    assert format_metric("steps", 1200) == "1200"
    assert format_metric("bytes", 111792, unit=True) == "111,792 B"
    assert metric_label("wall_per_step_ms") == "wall_per_step_ms (ms)"
    assert metric_label("termination") == "termination"
    for v in (1e-7, 12345678.9, 3.0e15):
        assert "e" not in format_metric("search_time", v)


def test_a_failure_is_explained_by_its_own_columns() -> None:
    row = {"success": False, "declared": True, "sources_found": 1, "false_sources": 1}
    row.update(loc_error=0.79, termination="declared")
    why = explain_failure(row, n_sources=2)
    assert why == (
        "1 of 2 source(s) found; 1 false source(s) declared; a source's nearest declaration "
        "0.79 m away on average (declared)"
    )
    assert explain_failure({"success": False, "termination": "time_limit"}) == (
        "no declaration (time_limit)"
    )
    assert "within reach" in explain_failure({"success": False, "termination": "x"}, end="reach")
    assert explain_failure({"success": True}) is None


def test_a_success_by_reaching_says_when_its_declarations_missed() -> None:
    row = {"success": True, "declarations": 1, "sources_found": 0, "false_sources": 1}
    note = explain_reach(row, 1, "reach", 2.0, 1.5)
    assert note is not None
    assert "within task.reach_radius (2 m)" in note and "0 of 1 source(s) found, 1 false" in note
    # declarations that found every source, no declaration, a failure, another end: nothing
    good = {**row, "sources_found": 1, "false_sources": 0}
    assert explain_reach(good, 1, "reach", 2.0, 1.5) is None
    assert explain_reach({**row, "declarations": 0}, 1, "reach", 2.0, 1.5) is None
    assert explain_reach({**row, "success": False}, 1, "reach", 2.0, 1.5) is None
    assert explain_reach(row, 1, "first_declaration", None, 1.5) is None


def _scenario(tmp_path, time: float = 10.0) -> str:
    d = small_scenario_dict("zigzag")
    d["limits"]["time"] = time
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(d))
    return str(f)


def test_run_prints_units_fixed_point_and_why_it_failed(tmp_path) -> None:
    r = runner.invoke(
        app, ["run", _scenario(tmp_path), "--out", str(tmp_path / "o"), "--no-animation"]
    )
    assert r.exit_code == 0, r.output
    out = r.stdout
    for label in ("search_time (s)", "loc_error (m)", "energy (J)", "path_length (m)"):
        assert label in out
    for label in ("sources_found", "false_sources"):
        assert label in out
    assert not re.search(r"\d\.?\d*e[+-]\d", out), out  # no scientific notation
    # 10 s of zigzag never declares: said in one line
    assert "failure: no declaration (time_limit)" in out


def _sweep(tmp_path, episodes: int) -> str:
    scen = _scenario(tmp_path, time=5.0)
    f = tmp_path / "sweep.yaml"
    spec = {
        "name": "c",
        "seed": 3,
        "episodes": episodes,
        "scenarios": [{"name": scen}],
        "searchers": [{"name": "zigzag"}],
    }
    f.write_text(yaml.safe_dump(spec))
    return str(f)


def test_batch_says_what_it_added_and_always_prints_the_summary(tmp_path) -> None:
    out = str(tmp_path / "o")
    r = runner.invoke(
        app, ["batch", _sweep(tmp_path, 2), "--out", out, "--workers", "1", "--no-progress"]
    )
    assert r.exit_code == 0, r.output
    assert "added 2 episodes (2 in the store)" in r.stdout
    # the summary table with --no-progress, readable at 80 columns
    assert "Sweep summary" in r.stdout and "found/" in r.stdout
    assert max(len(ln) for ln in r.stdout.splitlines()) <= 80
    # resuming with one more episode per cell adds one, and says the store's total apart
    r = runner.invoke(
        app, ["batch", _sweep(tmp_path, 3), "--out", out, "--workers", "1", "--no-progress"]
    )
    assert r.exit_code == 0, r.output
    assert "added 1 episode (3 in the store)" in r.stdout


def test_reproduce_no_progress_keeps_the_tables(tmp_path, monkeypatch) -> None:
    import odorloc.experiments.sweep as sweep_mod
    from helpers import fake_run_sweep

    seen: list[bool] = []
    fake = fake_run_sweep("one-each")

    def spy(spec, store_path, **kw):
        seen.append(kw["progress"])
        return fake(spec, store_path, **kw)

    monkeypatch.setattr(sweep_mod, "run_sweep", spy)
    out = tmp_path / "o"
    r = runner.invoke(
        app,
        ["reproduce", "single-agent", "--out", str(out), "--episodes", "1", "--no-progress"],
    )
    assert r.exit_code == 0, (r.output, r.exception)
    assert seen and not any(seen)
    assert "wall time" in r.stdout and (out / "report.html").is_file()


@pytest.mark.parametrize("command", ["batch", "reproduce"])
def test_no_progress_is_an_option_of(command: str) -> None:
    r = runner.invoke(app, [command, "--help"])
    assert "--no-progress" in r.stdout
