"""Seeds come from the scenario's own name, never from the way its file path is typed.

The built-in name, ``x.yaml``, ``./x.yaml``, ``/abs/x.yaml`` (the file ``odorloc scenarios NAME``
prints) give the same episode in ``odorloc run``, ``odorloc batch``, ``run --from-batch`` and the
Gymnasium environment; a store written with other seeds keeps re-running its own episodes,
because each row carries its seeds.
"""

from __future__ import annotations

import shlex
import sqlite3

import numpy as np
import pytest
from typer.testing import CliRunner

from odorloc.cli import app
from odorloc.core.seeds import episode_seeds
from odorloc.experiments.store import ResultStore
from odorloc.scenarios import builtin_names, get_scenario

runner = CliRunner()


def _invoke(line: str, *more: str):
    """The command ``odorloc LINE MORE...`` in this process."""
    return runner.invoke(app, [*shlex.split(line), *more])


NAME = "lattice-isotropic-2d"  # cheap, and its source is drawn from the world seed
EPISODE = 2


@pytest.fixture
def printed(tmp_path, monkeypatch):
    """The scenario file ``odorloc scenarios NAME`` prints, in the current folder."""
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["scenarios", NAME])
    assert r.exit_code == 0, r.output
    (tmp_path / "x.yaml").write_text(r.stdout)
    return tmp_path / "x.yaml"


def _run(ref: str, out: str) -> dict[str, np.ndarray]:
    args = ["run", ref, "--episode", str(EPISODE), "--out", out, "--no-animation"]
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    with np.load(f"{out}/recording.npz") as z:
        return {k: z[k] for k in ("positions", "gas", "t")}


def test_four_spellings_of_one_scenario_give_one_episode(printed) -> None:
    spellings = [NAME, "x.yaml", "./x.yaml", str(printed.resolve())]
    runs = [_run(ref, f"out{i}") for i, ref in enumerate(spellings)]
    for ref, rec in zip(spellings[1:], runs[1:], strict=True):
        for key, ref_array in runs[0].items():
            np.testing.assert_array_equal(rec[key], ref_array, err_msg=f"{ref}: {key}")
    # and the saved scenario repeats it without a world key
    first = (printed.parent / "out2" / "scenario.yaml").read_text().splitlines()[0]
    assert "--world-key" not in first
    # a different world really is different: episode 3 is not episode 2
    r = runner.invoke(app, ["run", "x.yaml", "--episode", "3", "--out", "o3", "--no-animation"])
    assert r.exit_code == 0, r.output
    with np.load("o3/recording.npz") as z:
        other = z["positions"]
    assert other.shape != runs[0]["positions"].shape or not np.array_equal(
        other, runs[0]["positions"]
    )


def test_batch_run_and_from_batch_agree_on_the_seeds(printed) -> None:
    want = episode_seeds(0, NAME, 0)
    cells = []
    for i, ref in enumerate(["./x.yaml", NAME]):
        r = _invoke(f"batch -s {ref} --episodes 1 --workers 1 --out b{i} --no-progress")
        assert r.exit_code == 0, r.output
        with ResultStore(f"b{i}/results.sqlite", readonly=True) as store:
            row = store.frame().iloc[0]
        assert (int(row.world_seed), int(row.agent_seed)) == want, ref
        cells.append(str(row.cell_id))
    r = runner.invoke(app, ["run", NAME, "--out", "single", "--no-animation"])
    assert r.exit_code == 0, r.output
    r = _invoke("run --from-batch b0 --out rb --no-animation --cell", cells[0])
    assert r.exit_code == 0, r.output
    with np.load("rb/recording.npz") as z, np.load("single/recording.npz") as y:
        np.testing.assert_array_equal(z["positions"], y["positions"])


def test_a_store_keeps_its_own_seeds(printed) -> None:
    """Rows written under another derivation (the path as typed, before 0.2.0) re-run with the
    seeds they carry."""
    r = _invoke("batch -s ./x.yaml --episodes 1 --workers 1 --out b --no-progress")
    assert r.exit_code == 0, r.output
    old = episode_seeds(0, "./x.yaml", 0)
    assert old != episode_seeds(0, NAME, 0)
    with sqlite3.connect("b/results.sqlite") as con:
        con.execute("UPDATE episodes SET world_seed = ?, agent_seed = ?", old)
    with ResultStore("b/results.sqlite", readonly=True) as store:
        cell = str(store.frame().cell_id.iloc[0])
    r = _invoke("run --from-batch b --out rb --no-animation --cell", cell)
    assert r.exit_code == 0, r.output
    assert f"world seed {old[0]}" in " ".join(r.output.split())

    from odorloc.engine.episode import run_episode

    res = run_episode(get_scenario("x.yaml"), *old, record=True)
    with np.load("rb/recording.npz") as z:
        np.testing.assert_array_equal(z["positions"], res.recording.positions)


def test_the_gymnasium_environment_keys_by_the_name(printed) -> None:
    pytest.importorskip("gymnasium", reason="the rl extra is not installed")
    from odorloc.envs.core import EnvCore

    for ref in (NAME, "x.yaml", str(printed.resolve())):
        core = EnvCore(ref, action={"kind": "discrete", "moves": "axis", "declare": "none"})
        assert core.world_key == NAME, ref


def test_every_builtin_scenario_is_named_as_it_is_listed() -> None:
    """The printed file of a built-in scenario keys its seeds by the same name."""
    for name in builtin_names():
        assert get_scenario(name).name == name


def test_two_entries_of_one_name_are_refused(printed) -> None:
    r = runner.invoke(
        app,
        ["batch", "-s", "x.yaml", "-s", NAME, "--episodes", "1", "--out", "b", "--no-progress"],
    )
    assert r.exit_code == 2
    assert r.stderr.startswith("error: scenarios[1].label: "), r.stderr
