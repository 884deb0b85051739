"""Any stored batch episode re-runs alone (``odorloc run --from-batch``), bit for bit."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from helpers import filament_scenario_dict
from odorloc.cli import app
from odorloc.experiments.rerun import differences, stored_episode
from odorloc.experiments.store import ResultStore

runner = CliRunner()
CELL = "room[limits.time=12.0]/zigzag[angle_deg=45.0]"


def _batch(tmp_path, replay: bool) -> tuple[str, str]:
    """A sweep with scenario and searcher overrides; episode 1 keeps its arrays."""
    d = filament_scenario_dict("zigzag")
    room = tmp_path / "room.yaml"
    room.write_text(yaml.safe_dump(d))
    sweep = {
        "name": "rerun",
        "seed": 11,
        "episodes": 2,
        "keep_episodes": [1],
        "replay": replay,
        "scenarios": [{"name": "room.yaml", "label": "room", "grid": {"limits.time": [12.0]}}],
        "searchers": [
            {"name": "zigzag", "grid": {"angle_deg": [45.0, 70.0]}},
        ],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    out = tmp_path / "out"
    r = runner.invoke(app, ["batch", str(f), "--out", str(out), "--workers", "1", "--no-progress"])
    assert r.exit_code == 0, r.output
    return str(out), str(out / "results.sqlite")


@pytest.mark.parametrize("replay", [False, True])
def test_a_stored_episode_with_overrides_reruns_bit_for_bit(tmp_path, replay: bool) -> None:
    out, store = _batch(tmp_path, replay)
    with ResultStore(store, readonly=True) as s:
        kept = s.arrays(CELL, 1)
    assert kept is not None
    r = runner.invoke(
        app,
        [
            "run",
            "--from-batch",
            out,
            "--cell",
            CELL,
            "--episode",
            "1",
            "--out",
            str(tmp_path / "again"),
            "--no-animation",
        ],
    )
    assert r.exit_code == 0, r.output
    assert "the same episode as stored" in r.output
    rec = np.load(tmp_path / "again" / "recording.npz")
    np.testing.assert_array_equal(rec["positions"], kept["positions"])
    np.testing.assert_array_equal(rec["gas"], kept["gas"])
    # the saved scenario names the command that repeats it
    first = (tmp_path / "again" / "scenario.yaml").read_text().splitlines()[0]
    assert first.startswith("# odorloc run --from-batch ") and "--episode 1" in first
    # the cell's overrides are in the scenario it ran
    saved = yaml.safe_load((tmp_path / "again" / "scenario.yaml").read_text())
    assert saved["limits"]["time"] == 12.0 and saved["searcher"]["angle_deg"] == 45.0


def test_a_changed_episode_is_reported_not_hidden(tmp_path) -> None:
    _, store = _batch(tmp_path, False)
    con = sqlite3.connect(store)
    with con:
        con.execute(
            "UPDATE episodes SET path_length = path_length + 1 WHERE cell_id = ? AND episode = 0",
            (CELL,),
        )
    con.close()
    ep = stored_episode(store, CELL, 0)
    assert ep.row["status"] == "ok" and not ep.replay
    r = runner.invoke(
        app,
        [
            "run",
            "--from-batch",
            store,
            "--cell",
            CELL,
            "--out",
            str(tmp_path / "x"),
            "--no-animation",
        ],
    )
    assert r.exit_code == 0, r.output
    assert "differs from the stored episode" in r.output and "path_length" in r.output
    assert differences(ep, dict(ep.row)) == []
    assert differences(ep, {**ep.row, "success": not ep.row["success"]}) == ["success"]


@pytest.fixture(scope="module")
def stored_batch(tmp_path_factory) -> tuple[str, str]:
    return _batch(tmp_path_factory.mktemp("batch"), False)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cell", CELL], "error: --cell: needs --from-batch"),
        (
            ["room", "--from-batch", "{out}"],
            "error: scenario: cannot be combined with --from-batch",
        ),
        (["--from-batch", "{out}", "--seed", "3"], "error: --seed: cannot be combined"),
        (["--from-batch", "{out}"], "error: --cell: {store} holds 2 cells: "),
        (["--from-batch", "{out}", "--cell", "nope"], "error: --cell: no cell 'nope' in "),
        (["--from-batch", "{out}", "--cell", " "], "error: --cell: is empty"),
        (
            ["--from-batch", "{out}", "--cell", CELL, "--episode", "7"],
            f"error: --episode: cell '{CELL}' has no stored episode 7 (stored: 0-1)",
        ),
        (["--from-batch", "{out}/missing"], "error: --from-batch: {out}/missing does not exist"),
        (["--from-batch", "{tmp}"], "error: --from-batch: {tmp} holds no results store"),
    ],
)
def test_bad_rerun_requests_get_one_line(
    tmp_path, stored_batch: tuple[str, str], args: list[str], message: str
) -> None:
    out, store = stored_batch
    fill = {"out": out, "store": store, "tmp": str(tmp_path)}
    args = [a.format(**fill) for a in args]
    r = runner.invoke(app, ["run", *args, "--out", str(tmp_path / "o")])
    assert r.exit_code == 2, r.output
    assert r.stderr.startswith(message.format(**fill)), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_rerun_may_keep_more_without_changing_the_episode(stored_batch) -> None:
    from odorloc.experiments.rerun import rerun

    _, store = stored_batch
    ep = stored_episode(store, CELL, 1)
    with ResultStore(store, readonly=True) as s:
        kept = s.arrays(CELL, 1)
    _, plain = rerun(ep)
    _, dense = rerun(ep, recording={"plume_stride": 1})
    assert len(dense.recording.plume_t) > len(plain.recording.plume_t)
    np.testing.assert_array_equal(dense.recording.positions, kept["positions"])
    assert differences(ep, dense.metrics) == []
