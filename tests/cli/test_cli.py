"""Command line: help everywhere, scenario listing, bad input exits 2 with one line."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from helpers import filament_scenario_dict, small_scenario_dict
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


def _cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "odorloc.cli", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
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


@pytest.mark.parametrize(
    ("edit", "field", "problem"),
    [
        # a fixed source at the start where reaching ends the episode: a success at time 0
        (
            {"world.sources.0.position": [26.0, 7.5]},
            "task.reach_radius",
            "agents.starts[0] (26, 7.5) is 0 m from world.sources[0], within this radius",
        ),
        # the world's wind against the plume's own (the plume's would silently win)
        ({"world.wind.velocity": [-1.0, 0.0]}, "world.plume.wind", "blows along +x"),
    ],
)
def test_scenarios_that_contradict_themselves_are_refused(tmp_path, edit, field, problem) -> None:
    """One line naming the field, exit 2, nothing written."""
    name = "open-field-filament" if "sources" in next(iter(edit)) else "lattice-windy-medium"
    r = runner.invoke(app, ["scenarios", name])
    data = yaml.safe_load(r.output)
    for path, value in edit.items():
        node = data
        *parents, last = path.split(".")
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        node[last] = value
    f = tmp_path / "x.yaml"
    f.write_text(yaml.safe_dump(data))
    out = tmp_path / "o"
    r = _cli("run", str(f), "--out", str(out), "--no-animation")
    assert r.returncode == 2, r.stdout + r.stderr
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {field}:") and problem in lines[0]
    assert not out.exists()


def test_malformed_yaml_exit_2(tmp_path) -> None:
    f = tmp_path / "broken.yaml"
    f.write_text("world: [unclosed\n")
    r = _cli("run", str(f))
    assert r.returncode == 2 and "not valid YAML" in r.stderr


def test_unknown_scenario_exit_2() -> None:
    r = _cli("run", "does-not-exist")
    assert r.returncode == 2 and "unknown scenario" in r.stderr


_FAILING_SEARCHER = """
import numpy as np
from odorloc.core.params import Params
from odorloc.core.types import Action, Command
from odorloc.searchers.base import Searcher


class FailLaterParams(Params):
    after: int = 3


class FailLater(Searcher):
    Params = FailLaterParams

    def reset(self, ctx, rng):
        super().reset(ctx, rng)
        self.k = 0

    def act(self, observations, rng):
        self.k += 1
        if self.k > self.params.after:
            raise RuntimeError("this searcher fails on purpose")
        return Action([Command.hold() for _ in observations])


class FailConfig(FailLater):
    def act(self, observations, rng):
        from odorloc.core.errors import ConfigError

        if self.k >= self.params.after:
            raise ConfigError("searcher.after", "refused while running")
        return super().act(observations, rng)
"""


def _failed_summary(stderr: str, failed: int, total: int, first: str, out) -> None:
    """stderr is exactly one summary line of the failed episodes, no traceback."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    summary = " ".join(stderr.split())
    assert summary.startswith(f"batch: {failed} of {total} episodes failed (first: {first}")
    assert summary.endswith(f"; see {out / 'errors.log'}")


def _failing_sweep(tmp_path, episodes: int, searchers: list[str]):
    """A short sweep file over the given searchers (``failmod`` importable), its output folder
    and the environment that finds ``failmod``."""
    (tmp_path / "failmod.py").write_text(_FAILING_SEARCHER)
    room = small_scenario_dict("zigzag")
    room["limits"]["time"] = 5.0
    (tmp_path / "room.yaml").write_text(yaml.safe_dump(room))
    sweep = {
        "name": "t",
        "seed": 1,
        "episodes": episodes,
        "scenarios": [{"name": "room.yaml"}],
        "searchers": [{"name": n} for n in searchers],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    return f, tmp_path / "out", {**os.environ, "PYTHONPATH": str(tmp_path)}


def test_batch_records_failing_episode_and_goes_on(tmp_path) -> None:
    """An episode that fails while running is stored as an error; the other cells complete,
    every result is written, stderr holds one summary line (tracebacks go to errors.log) and
    the exit status is 1."""
    f, out, env = _failing_sweep(tmp_path, 2, ["zigzag", "failmod:FailLater"])
    r = _cli("batch", str(f), "--out", str(out), "--workers", "1", "--no-progress", env=env)
    assert r.returncode == 1, r.stderr
    import pandas as pd

    df = pd.read_csv(out / "results.csv")
    assert len(df) == 4
    bad = df[df["status"] == "error"]
    assert len(bad) == 2 and bad["error"].str.contains("fails on purpose").all()
    assert (df[df["status"] == "ok"]["searcher"] == "zigzag").all()
    assert (out / "results.parquet").exists()
    assert "Traceback" in (out / "errors.log").read_text()
    _failed_summary(r.stderr, 2, 4, "RuntimeError: this searcher fails on purpose", out)
    # resuming runs nothing new; the stored failures still set the exit status
    r = _cli("batch", str(f), "--out", str(out), "--workers", "1", "--no-progress", env=env)
    assert r.returncode == 1, r.stderr
    _failed_summary(r.stderr, 2, 4, "RuntimeError: this searcher fails on purpose", out)


def test_batch_episode_refused_at_run_time_is_one_summary_line(tmp_path) -> None:
    """A setting refused only while an episode runs (a ConfigError) is stored as an error row;
    the summary names its field, the pool's workers print no traceback, exit status 1."""
    f, out, env = _failing_sweep(tmp_path, 3, ["failmod:FailConfig"])
    r = _cli("batch", str(f), "--out", str(out), "--workers", "2", "--no-progress", env=env)
    assert r.returncode == 1, r.stderr
    _failed_summary(r.stderr, 3, 3, "searcher.after: refused while running)", out)
    log = (out / "errors.log").read_text()
    assert log.count("Traceback") == 3 and "refused while running" in log
    for name in ("results.sqlite", "results.csv", "results.parquet"):
        assert (out / name).stat().st_size > 0


def test_batch_refuses_options_the_sweep_file_sets(tmp_path) -> None:
    f = tmp_path / "sweep.yaml"
    f.write_text(
        yaml.safe_dump(
            {
                "seed": 1,
                "episodes": 2,
                "scenarios": [{"name": "indoor-ventilated", "params": {"task.end": "limits"}}],
                "searchers": [{"name": "zigzag"}],
            }
        )
    )
    for opt in (["--episodes", "1"], ["--seed", "99"]):
        r = runner.invoke(app, ["batch", str(f), *opt, "--out", str(tmp_path / "o")])
        assert r.exit_code == 2
        assert r.stderr.strip() == f"error: {opt[0]}: the sweep file sets it; edit the file instead"
    assert not (tmp_path / "o").exists()


def test_batch_with_an_invalid_searcher_parameter_runs_nothing(tmp_path) -> None:
    """A parameter that stops a cell from running (a wave margin that leaves no area) is found
    by the validation pass: exit 2 naming the sweep field, no store written."""
    sweep = {
        "name": "t",
        "seed": 1,
        "episodes": 2,
        "scenarios": [
            {"name": "indoor-ventilated", "params": {"limits.time": 5.0, "task.end": "limits"}}
        ],
        "searchers": [{"name": "zigzag"}, {"name": "rectangular-wave", "params": {"margin": 10.0}}],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    r = runner.invoke(app, ["batch", str(f), "--out", str(tmp_path / "out"), "--no-progress"])
    assert r.exit_code == 2
    assert r.stderr.strip() == "error: searchers[1].params.margin: leaves no area to cover"
    assert not (tmp_path / "out").exists()


def test_run_repeats_an_episode_from_its_saved_scenario(tmp_path) -> None:
    r = runner.invoke(
        app,
        [
            "run",
            "lattice-isotropic-2d",
            "--out",
            str(tmp_path / "a"),
            "--no-animation",
            "--episode",
            "2",
        ],
    )
    assert r.exit_code == 0, r.output
    saved = tmp_path / "a" / "scenario.yaml"
    first = saved.read_text().splitlines()[0]
    assert first.startswith("# odorloc run ") and "--world-key" not in first
    args = first.removeprefix("# odorloc run ").split()
    args[0] = str(saved)  # the saved file, wherever the test runs
    r = runner.invoke(app, ["run", *args, "--out", str(tmp_path / "b"), "--no-animation"])
    assert r.exit_code == 0, r.output
    a = np.load(tmp_path / "a" / "recording.npz")
    b = np.load(tmp_path / "b" / "recording.npz")
    np.testing.assert_array_equal(a["positions"], b["positions"])
    np.testing.assert_array_equal(a["gas"], b["gas"])
    for bad, field in (
        ([""], "scenario"),
        (["lattice-isotropic-2d", "--world-key", " "], "--world-key"),
    ):
        r = runner.invoke(app, ["run", *bad, "--out", str(tmp_path / "c")])
        assert r.exit_code == 2 and r.stderr.startswith(f"error: {field}: "), r.stderr


def test_batch_names_a_malformed_scheduler_as_its_option(tmp_path) -> None:
    r = runner.invoke(
        app,
        [
            "batch",
            "-s",
            "lattice-isotropic-2d",
            "--backend",
            "dask",
            "--scheduler",
            "tcp://127.0.0.1:notaport",
            "--out",
            str(tmp_path / "o"),
            "--no-progress",
        ],
    )
    assert r.exit_code == 2
    assert r.stderr.startswith("error: --scheduler: expected an address like tcp://host:8786")
    assert len(r.stderr.strip().splitlines()) == 1


def test_batch_with_an_unreachable_scheduler_writes_nothing(tmp_path) -> None:
    pytest.importorskip("distributed")
    out = tmp_path / "o"
    r = runner.invoke(
        app,
        [
            "batch",
            "-s",
            "lattice-isotropic-2d",
            "--episodes",
            "1",
            "--scheduler",
            "tcp://127.0.0.1:1",
            "--out",
            str(out),
            "--no-progress",
        ],
    )
    assert r.exit_code == 2, r.output
    assert r.stderr.startswith("error: --scheduler: cannot reach Dask scheduler"), r.stderr
    assert not out.exists()  # no empty results.sqlite left behind


def test_reproduce_list_with_a_name(tmp_path) -> None:
    """``--list`` with a name describes that reproduction; an unknown name is refused."""
    for args in (["nosuch", "--list"], ["--list", "nosuch"]):
        r = runner.invoke(app, ["reproduce", *args])
        assert r.exit_code == 2, r.output
        assert r.stderr.startswith("error: paper: unknown reproduction 'nosuch'"), r.stderr
        assert len(r.stderr.strip().splitlines()) == 1
    r = runner.invoke(app, ["reproduce", "single-agent", "--list"])
    assert r.exit_code == 0, r.output
    assert "single-agent" in r.stdout and "muc-osl" not in r.stdout
    r = runner.invoke(app, ["reproduce", "--list"])
    assert r.exit_code == 0 and "single-agent" in r.stdout and "muc-osl" in r.stdout


def test_reproduce_with_failed_episodes_exits_1_after_writing_everything(
    tmp_path, monkeypatch
) -> None:
    import odorloc.experiments.sweep as sweep_mod
    from helpers import fake_run_sweep

    monkeypatch.setattr(sweep_mod, "run_sweep", fake_run_sweep("all-errors"))
    out = tmp_path / "o"
    r = runner.invoke(
        app, ["reproduce", "single-agent", "--out", str(out), "--episodes", "1", "--workers", "1"]
    )
    assert r.exit_code == 1, (r.output, r.exception)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    summary = " ".join(r.stderr.split())
    assert summary.startswith("reproduce: ") and "episodes failed (first: RuntimeError: boom)" in (
        summary
    )
    assert summary.endswith(f"see {out / 'errors.log'}")
    assert (out / "errors.log").read_text().count("RuntimeError: boom") >= 1
    assert (out / "results.csv").is_file() and (out / "report.html").is_file()


def _sweep_file(tmp_path, **kw):
    f = tmp_path / "sweep.yaml"
    d = {
        "seed": 1,
        "episodes": 1,
        "scenarios": [{"name": "lattice-isotropic-2d"}],
        "searchers": [{"name": "zigzag"}],
        **kw,
    }
    f.write_text(yaml.safe_dump(d))
    return f


def test_errors_name_the_option_the_user_typed(tmp_path) -> None:
    from odorloc.experiments.store import ResultStore

    other = tmp_path / "other"
    other.mkdir()
    with ResultStore(other / "results.sqlite") as st:
        st.bind("0" * 16)
    (tmp_path / "bad.sqlite").write_text("not a database at all")
    for args, expect in (
        (
            ["batch", str(_sweep_file(tmp_path)), "--out", str(other), "--no-progress"],
            f"error: --out: {other / 'results.sqlite'} holds results of a different sweep",
        ),
        (
            ["run", "--from-batch", str(tmp_path / "bad.sqlite"), "--out", str(tmp_path / "r")],
            "error: --from-batch: ",
        ),
        (["batch", "--scenario", "nosuch", "--out", str(tmp_path / "b")], "error: --scenario: "),
        (
            ["run", "muc-osl-3d", "--searcher", "ds-mapping", "--out", str(tmp_path / "m")],
            "error: --searcher: ",
        ),
    ):
        r = runner.invoke(app, args)
        assert r.exit_code == 2, (args, r.output)
        assert r.stderr.startswith(expect), (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_a_file_of_the_other_kind_is_named_as_such(tmp_path) -> None:
    """A scenario file given as a sweep (or the reverse) says so, not that a dozen fields are
    missing."""
    d = filament_scenario_dict("zigzag")
    scen = tmp_path / "scen.yaml"
    scen.write_text(yaml.safe_dump(d))
    sweep = _sweep_file(tmp_path)
    r = runner.invoke(app, ["batch", str(scen), "--out", str(tmp_path / "o"), "--no-progress"])
    assert r.exit_code == 2
    assert r.stderr.startswith("error: sweep: scen.yaml looks like a scenario file (it has world")
    assert r.stderr.strip().endswith("give it with --scenario"), r.stderr
    r = runner.invoke(app, ["run", str(sweep), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert r.stderr.startswith("error: scenario: sweep.yaml looks like a sweep file (it has "), (
        r.stderr
    )
    assert "odorloc batch" in r.stderr
    r = runner.invoke(app, ["batch", "--scenario", str(sweep), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert r.stderr.startswith("error: --scenario: sweep.yaml looks like a sweep file"), r.stderr
    assert not (tmp_path / "o").exists()
