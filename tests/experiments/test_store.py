"""The SQLite results store: durability settings, uniqueness, round trips, exports, refusal."""

from __future__ import annotations

import math
import sqlite3

import numpy as np
import pandas as pd
import pytest

from _stub_episode import stub_episode
from odorloc.core.errors import ConfigError
from odorloc.experiments.store import ResultStore, open_results
from odorloc.experiments.sweep import config_hash, expand_tasks, load_sweep

SPEC = {
    "seed": 3,
    "episodes": 4,
    "scenarios": [{"name": "toy", "grid": {"scale": [1.0, 2.0]}}],
    "searchers": [{"name": "a", "params": {"trajectory": True}}, {"name": "b"}],
}


@pytest.fixture
def filled(tmp_path):
    spec = load_sweep(SPEC)
    tasks = expand_tasks(spec)
    st = ResultStore(tmp_path / "r.sqlite")
    st.bind(config_hash(spec), spec)
    for t in tasks:
        st.add(t, {**stub_episode(t), "wall_time": 0.01})
    yield st, tasks
    st.close()


def test_wal_mode_and_unique_episode(filled):
    st, tasks = filled
    con = sqlite3.connect(st.path)
    mode = con.execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"
    assert len(st) == 16
    row = stub_episode(tasks[0])
    # a second write of the same (cell, episode) is ignored: the first result stays
    assert st.add(tasks[0], {**row, "search_time": -1.0}) is False
    assert len(st) == 16
    assert st.frame()["search_time"].iloc[0] == row["search_time"]
    with pytest.raises(sqlite3.IntegrityError):
        con.execute("INSERT INTO episodes SELECT * FROM episodes LIMIT 1")
    con.close()
    assert st.done_keys() == {(t.cell_id, t.episode) for t in tasks}


def test_row_round_trip(filled):
    st, tasks = filled
    df = st.frame()
    t = tasks[5]
    r = stub_episode(t)
    got = df[(df["cell_id"] == t.cell_id) & (df["episode"] == t.episode)].iloc[0]
    for k in ("search_time", "path_length", "energy", "start_distance", "difficulty"):
        assert got[k] == pytest.approx(r[k], rel=0, abs=0)
    assert bool(got["success"]) == r["success"]
    assert int(got["bytes"]) == r["bytes"] and int(got["steps"]) == r["steps"]
    if math.isnan(r["loc_error"]):
        assert math.isnan(got["loc_error"])
    assert got["world_seed"] == t.world_seed and got["agent_seed"] == t.agent_seed
    assert got["config_hash"] == t.config_hash and got["status"] == "ok" and got["error"] == ""
    assert got["scenario.scale"] == t.cell["scenario_params"]["scale"]
    assert got["wall_time"] == 0.01
    # arrays kept per episode as npz blobs
    arr = st.arrays("toy[scale=1.0]/a", 2)
    ref = stub_episode(next(x for x in tasks if x.cell_id == "toy[scale=1.0]/a" and x.episode == 2))
    np.testing.assert_array_equal(arr["positions"], ref["arrays"]["positions"])
    assert st.arrays("toy[scale=1.0]/b", 2) is None
    assert st.episodes_with_arrays()[0] == ("toy[scale=1.0]/a", 0)


def test_exports_equal_the_table(filled, tmp_path):
    st, _ = filled
    df = st.frame()
    csv = open_results(st.to_csv(tmp_path / "r.csv"))
    pq = open_results(st.to_parquet(tmp_path / "r.parquet"))
    for other in (csv, pq):
        assert list(other["cell_id"]) == list(df["cell_id"])
        np.testing.assert_allclose(other["search_time"], df["search_time"])
        np.testing.assert_array_equal(other["success"].astype(bool), df["success"].astype(bool))
        np.testing.assert_array_equal(other["world_seed"], df["world_seed"])


def test_duckdb_query(filled):
    duckdb = pytest.importorskip("duckdb", reason="duckdb not installed (extra odorloc[duckdb])")
    st, _ = filled
    con = st.duckdb()
    res = con.sql(
        "select searcher, count(*) n, avg(success::int) rate from episodes group by 1 order by 1"
    ).df()
    df = st.frame()
    assert list(res["n"]) == [8, 8]
    exp = df.groupby("searcher")["success"].mean().astype(float).to_numpy()
    np.testing.assert_allclose(res["rate"].to_numpy(float), exp)
    assert duckdb.__version__


def test_refuses_foreign_files_untouched(tmp_path):
    junk = tmp_path / "notes.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    before = junk.read_bytes()
    with pytest.raises(ConfigError, match="not an odorloc results store"):
        ResultStore(junk)
    assert junk.read_bytes() == before
    other = tmp_path / "other.sqlite"
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE t (x)")
    con.commit()
    con.close()
    before = other.read_bytes()
    with pytest.raises(ConfigError, match="not an odorloc results store"):
        ResultStore(other)
    assert other.read_bytes() == before
    with pytest.raises(ConfigError, match="no results store"):
        ResultStore(tmp_path / "missing.sqlite", readonly=True)


def test_bind_refuses_other_hash(filled):
    st, _ = filled
    with pytest.raises(ConfigError) as ei:
        st.bind("0123456789abcdef")
    assert ei.value.field == "store"
    assert len(st) == 16


def test_retry_errors_deletes_only_errors(tmp_path):
    spec = load_sweep(SPEC)
    tasks = expand_tasks(spec)
    with ResultStore(tmp_path / "e.sqlite") as st:
        st.bind(config_hash(spec), spec)
        for i, t in enumerate(tasks):
            row = {"status": "error", "error": "boom"} if i % 5 == 0 else stub_episode(t)
            if i == 5:  # a separate traceback is kept under the error line
                row["traceback"] = "Traceback...\n  line 3"
            st.add(t, row)
        t0 = tasks[0]
        err = st.frame().set_index(["cell_id", "episode"]).loc[(t0.cell_id, t0.episode), "error"]
        assert err == "boom"
        t5 = tasks[5]
        err = st.frame().set_index(["cell_id", "episode"]).loc[(t5.cell_id, t5.episode), "error"]
        assert err.split("\n")[0] == "boom" and "line 3" in err
        assert st.delete_errors() == 4
        assert len(st) == 12
        assert (st.frame()["status"] == "ok").all()
        counts = st.cell_counts()
        assert sum(v[0] for v in counts.values()) == 12


def test_reader_sees_committed_rows_while_writer_open(filled):
    st, tasks = filled
    df = pd.read_sql_query("select count(*) n from episodes", sqlite3.connect(st.path))
    assert int(df["n"].iloc[0]) == len(tasks)


def test_cell_counts_count_a_named_success_column(tmp_path):
    """Progress counts (and so the live bars) can count a reproduction's own success column,
    kept among the extra metrics, and agree with the stored rows."""
    spec = load_sweep(SPEC)
    tasks = expand_tasks(spec)
    with ResultStore(tmp_path / "m.sqlite") as st:
        st.bind(config_hash(spec), spec)
        for i, t in enumerate(tasks):
            st.add(t, {**stub_episode(t), "map_ok": i % 3 == 0})
        df = st.frame()
        counts = st.cell_counts("map_ok")
        for cid, g in df.groupby("cell_id"):
            assert counts[cid][:2] == (len(g), int(g["map_ok"].sum()))
        assert st.cell_counts()[cid][1] == int(g["success"].fillna(False).astype(bool).sum())
        with pytest.raises(ConfigError):
            st.cell_counts("x'); DROP TABLE episodes; --")


# ----------------------------------------------------------------------------- per-agent values
def _team_rows(tasks):
    """Rows of a 3-UAV team: episode columns plus each agent's own values."""
    out = []
    for t in tasks:
        row = {**stub_episode(t), "wall_time": 0.01, "found_time_0": 5.0}
        row["agent_metrics"] = {a: {"cues": float(a + t.episode), "sent": 2.0} for a in range(3)}
        out.append(row)
    return out


def test_per_agent_values_go_to_their_own_table(tmp_path):
    spec = load_sweep(SPEC)
    tasks = expand_tasks(spec)[:4]
    with ResultStore(tmp_path / "r.sqlite") as st:
        st.bind(config_hash(spec), spec)
        for t, row in zip(tasks, _team_rows(tasks), strict=True):
            st.add(t, row)
        long = st.agent_frame()
        assert list(long.columns) == ["cell_id", "episode", "agent", "key", "value"]
        assert len(long) == 4 * 3 * 2
        t = tasks[1]
        mine = long[(long.cell_id == t.cell_id) & (long.episode == t.episode)]
        assert mine[mine.key == "cues"].value.tolist() == [t.episode + a for a in range(3)]
        df = st.frame(agents=True)
        # the episode table holds the episode's own columns, nothing folded per agent
        assert "found_time_0" in df.columns
        assert not [c for c in df.columns if c.startswith(("cues", "sent"))]
        assert df["agents"].iloc[1] == {a: {"cues": t.episode + a, "sent": 2.0} for a in range(3)}
        from odorloc.experiments.store import agent_values

        cues = agent_values(df, "cues")
        assert list(cues.columns) == [0, 1, 2]
        assert cues.sum(axis=1).tolist() == [3.0 * t.episode + 3 for t in tasks]
        # exports: the episode table as today, the long table beside it
        csv = st.to_csv(tmp_path / "results.csv")
        pq = st.to_parquet(tmp_path / "results.parquet")
        assert not [c for c in pd.read_csv(csv).columns if c.startswith("cues")]
        back = pd.read_csv(tmp_path / "results_agents.csv")
        pd.testing.assert_frame_equal(back, long, check_dtype=False)
        back = pd.read_parquet(tmp_path / "results_agents.parquet")
        pd.testing.assert_frame_equal(back, long, check_dtype=False)
        assert pq.is_file()
        con = st.duckdb()
        n = con.sql("select count(*) n from agent_metrics where key = 'cues'").df()["n"]
        assert n.tolist() == [12]


def _legacy_store(path, tasks, spec):
    """A store as schema 1 wrote it: a team's values as ``key`` / ``key_<agent>`` extras."""
    with ResultStore(path) as st:
        st.bind(config_hash(spec), spec)
        for t in tasks:
            row = {**stub_episode(t), "wall_time": 0.01, "found_time_0": 5.0, "mapped_x_0": 1.0}
            row.update(cues=1.0, cues_1=2.0, cues_2=3.0 + t.episode, sent=4.0, sent_2=5.0)
            st.add(t, row)
    con = sqlite3.connect(path)
    con.execute("DROP TABLE agent_metrics")
    con.execute("UPDATE meta SET value = '1' WHERE key = 'schema'")
    con.commit()
    con.close()


def test_a_schema_1_store_reads_per_agent_and_migrates_when_resumed(tmp_path):
    spec = load_sweep(SPEC)
    tasks = expand_tasks(spec)[:3]
    path = tmp_path / "old.sqlite"
    _legacy_store(path, tasks, spec)
    expected = {
        0: {"cues": 1.0, "sent": 4.0},
        1: {"cues": 2.0},
        2: {"cues": 3.0 + tasks[2].episode, "sent": 5.0},
    }
    with ResultStore(path, readonly=True) as st:
        assert st.legacy
        df = st.frame(agents=True)
        # indexed columns without a base column are the episode's (found times, per-peak values)
        assert {"found_time_0", "mapped_x_0"} <= set(df.columns)
        assert not [c for c in df.columns if c.startswith(("cues", "sent"))]
        assert df["agents"].iloc[2] == expected
        before = st.agent_frame()
    assert len(before) == 3 * 5
    with ResultStore(path) as st:  # opened to write (a resumed sweep): migrated once
        assert not st.legacy and st.schema == "2"
        pd.testing.assert_frame_equal(st.agent_frame(), before)
        assert st.frame(agents=True)["agents"].iloc[2] == expected
    con = sqlite3.connect(path)
    extra = con.execute("SELECT extra FROM episodes LIMIT 1").fetchone()[0]
    con.close()
    assert "cues" not in extra and "found_time_0" in extra
