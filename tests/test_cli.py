"""Command line: help everywhere, scenario listing, bad input exits 2 with one line."""

from __future__ import annotations

import subprocess
import sys

import pytest
import yaml
from typer.testing import CliRunner

from conftest import filament_scenario_dict
from odorloc.cli import app

runner = CliRunner()


@pytest.mark.parametrize("cmd", [[], ["run"], ["scenarios"], ["components"]])
def test_help_everywhere(cmd: list[str]) -> None:
    r = runner.invoke(app, [*cmd, "--help"])
    assert r.exit_code == 0 and "Usage" in r.output


def test_scenarios_lists_builtins() -> None:
    r = runner.invoke(app, ["scenarios"])
    assert r.exit_code == 0
    assert "indoor-ventilated" in r.output


def test_run_small_scenario_writes_figures(tmp_path) -> None:
    d = filament_scenario_dict("zigzag")
    d["limits"]["time"] = 10.0
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(d))
    out = tmp_path / "out"
    r = runner.invoke(app, ["run", str(f), "--out", str(out), "--frames", "10"])
    assert r.exit_code == 0, r.output
    for name in ("trajectory.png", "traces.png", "episode.gif", "recording.npz", "scenario.yaml"):
        assert (out / name).stat().st_size > 0


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "odorloc.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_invalid_scenario_file_one_line_exit_2(tmp_path) -> None:
    d = filament_scenario_dict("zigzag")
    d["world"]["plume"]["sigma0"] = -1.0
    f = tmp_path / "bad.yaml"
    f.write_text(yaml.safe_dump(d))
    r = _cli("run", str(f), "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "world.plume.sigma0" in lines[0]
    assert "Traceback" not in r.stderr


def test_malformed_yaml_exit_2(tmp_path) -> None:
    f = tmp_path / "broken.yaml"
    f.write_text("world: [unclosed\n")
    r = _cli("run", str(f))
    assert r.returncode == 2 and "not valid YAML" in r.stderr


def test_unknown_scenario_exit_2() -> None:
    r = _cli("run", "does-not-exist")
    assert r.returncode == 2 and "unknown scenario" in r.stderr


def test_batch_records_failing_episode_and_goes_on(tmp_path) -> None:
    """A searcher parameter that makes one cell fail is stored as an error; others complete."""
    sweep = {
        "name": "t",
        "seed": 1,
        "episodes": 2,
        "scenarios": [
            {"name": "indoor-ventilated", "params": {"limits.time": 5.0, "world.warmup": 1.0}}
        ],
        "searchers": [
            {"name": "zigzag"},
            # A rectangular wave whose margin leaves no area raises inside the episode.
            {"name": "rectangular-wave", "params": {"margin": 10.0}},
        ],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    out = tmp_path / "out"
    r = _cli("batch", str(f), "--out", str(out), "--workers", "1", "--no-progress")
    assert r.returncode == 0, r.stderr
    import pandas as pd

    df = pd.read_csv(out / "results.csv")
    assert len(df) == 4
    bad = df[df["status"] == "error"]
    assert len(bad) == 2 and bad["error"].str.contains("margin").all()
    assert (df[df["status"] == "ok"]["searcher"] == "zigzag").all()
    assert (out / "results.parquet").exists()
    assert "Traceback" in (out / "errors.log").read_text()
