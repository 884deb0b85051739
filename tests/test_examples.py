"""The examples the README points to keep working: scripts run, sweep and scenario files load."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from odorloc.experiments.runner import cell_scenario
from odorloc.experiments.sweep import expand_cells, load_sweep
from odorloc.scenarios import get_scenario

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SWEEPS = sorted(EXAMPLES.glob("sweep-*.yaml"))


def _run(*args: str, cwd: Path) -> str:
    r = subprocess.run(
        [sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout


def test_there_are_example_sweeps() -> None:
    assert len(SWEEPS) >= 3


@pytest.mark.parametrize("path", SWEEPS, ids=lambda p: p.name)
def test_example_sweeps_load_and_build_every_cell(path: Path) -> None:
    spec = load_sweep(path)
    cells = expand_cells(spec)
    assert cells
    for cell in cells:
        cell_scenario(cell.spec)  # the scenario validates (searcher, overrides, knobs)


def test_policy_search_scenario_loads() -> None:
    sc = get_scenario(EXAMPLES / "policy-search.yaml")
    assert sc.name == "policy-search"


def test_plumes_example_writes_a_picture_of_every_continuous_family(tmp_path: Path) -> None:
    out = _run(str(EXAMPLES / "plumes.py"), str(tmp_path / "out"), cwd=tmp_path)
    assert "wrote 5 PNGs" in out
    names = sorted(p.name for p in (tmp_path / "out").glob("plume_*.png"))
    assert names == [
        f"plume_{n}.png" for n in ("eulerian", "filament", "gaussian", "replay", "vergassola")
    ]


def test_train_policy_example_trains_and_evaluates(tmp_path: Path) -> None:
    out = _run(
        str(EXAMPLES / "train_policy.py"),
        *("--iterations", "1", "--population", "2", "--train-episodes", "1"),
        *("--episodes", "2", "--workers", "1", "--out", str(tmp_path / "tp")),
        cwd=tmp_path,
    )
    assert (tmp_path / "tp" / "linear.npz").is_file()
    for name in ("linear-policy", "infotaxis", "zigzag"):
        assert name in out


def test_train_lattice_batched_example_trains_and_says_how_long(tmp_path: Path) -> None:
    out = _run(str(EXAMPLES / "train_lattice_batched.py"), "--quick", cwd=tmp_path)
    assert "trained in" in out and "agent-steps" in out
    for name in ("trained", "random", "greedy"):
        assert name in out
