"""Sweep files, task expansion, common random numbers, the local runner, resume and kill safety."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from _stub_episode import stub_episode
from odorloc.core.errors import ConfigError
from odorloc.experiments import stats
from odorloc.experiments.store import ResultStore
from odorloc.experiments.sweep import (
    config_hash,
    episode_seeds,
    expand_cells,
    expand_tasks,
    load_sweep,
    run_sweep,
)

TESTS = Path(__file__).resolve().parents[1]

EXAMPLE_YAML = """\
name: example
seed: 20240611
episodes: 4
scenarios:
  - name: room
    params: {time_limit: 300}
    grid: {scale: [1.0, 2.0]}
searchers:
  - name: pf
    params: {skill: 1.5}
  - name: gradient
    label: grad
    grid: {skill: [0.5, 1.0]}
"""


def _spec(**kw):
    d = {
        "seed": 7,
        "episodes": 12,
        "scenarios": [{"name": "toy"}],
        "searchers": [
            {"name": "a", "params": {"skill": 0.8}},
            {"name": "b", "params": {"skill": 1.6}},
        ],
    }
    d.update(kw)
    return d


def _table(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["wall_time", "finished_at"]).reset_index(drop=True)


# ----------------------------------------------------------------------------- files


def test_yaml_file_expands_deterministically(tmp_path):
    p = tmp_path / "sweep.yaml"
    p.write_text(EXAMPLE_YAML)
    spec = load_sweep(p)
    cells = expand_cells(spec)
    # 2 scenario points x (1 + 2) searcher points
    assert [c.cell_id for c in cells] == [
        "room[scale=1.0]/pf",
        "room[scale=1.0]/grad[skill=0.5]",
        "room[scale=1.0]/grad[skill=1.0]",
        "room[scale=2.0]/pf",
        "room[scale=2.0]/grad[skill=0.5]",
        "room[scale=2.0]/grad[skill=1.0]",
    ]
    assert cells[2].spec["searcher_params"] == {"skill": 1.0}
    assert cells[3].spec["scenario_params"] == {"time_limit": 300, "scale": 2.0}
    assert cells[1].swept == {"scenario.scale": 1.0, "searcher.skill": 0.5}
    tasks = expand_tasks(spec)
    assert len(tasks) == 6 * 4
    assert tasks == expand_tasks(load_sweep(p))  # same file -> identical tasks


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"seed": None}, "seed"),
        ({"episodes": 0}, "episodes"),
        ({"episode": 3}, "episode"),  # typo of a key
        ({"searchers": []}, "searchers"),
        ({"searchers": [{"name": "a", "grid": {"skill": []}}]}, "searchers[0].grid.skill"),
        ({"searchers": [{"name": "a", "grid": {"skill": [1, 1]}}]}, "searchers[0].grid.skill"),
        (
            {"scenarios": [{"name": "toy", "params": {"x": float("nan")}}]},
            "scenarios[0].params.x",
        ),
        ({"searchers": [{"name": "a"}, {"name": "a"}]}, "searchers[1].label"),
        ({"adaptive": {"target_width": -1}}, "adaptive.target_width"),
        (
            {"searchers": [{"name": "a", "params": {"k": 1}, "grid": {"k": [1, 2]}}]},
            "searchers[0].grid.k",
        ),
        ({"seed": True}, "seed"),
        ({"keep_episodes": [0, True]}, "keep_episodes[1]"),  # not read as episode 1
        (
            {"searchers": [{"name": "a", "agent_grid": {"start_index": [0, 1]}}]},
            "searchers[0].agent_grid",
        ),
        ({"adaptive": {"target_width": 0.1, "max_episodes": 5}}, "adaptive.max_episodes"),
        (  # two cells written out the same way
            {
                "scenarios": [
                    {"name": "toy", "label": "L[scale=2.0]", "params": {"scale": 3.0}},
                    {"name": "toy", "label": "L", "grid": {"scale": [2.0]}},
                ]
            },
            "scenarios[1].label",
        ),
    ],
)
def test_invalid_sweep_names_the_field_in_one_line(patch, field):
    d = _spec()
    for k, v in patch.items():
        if v is None:
            d.pop(k)
        else:
            d[k] = v
    with pytest.raises(ConfigError) as ei:
        load_sweep(d)
    msg = str(ei.value)
    assert "\n" not in msg
    assert ei.value.field == field, msg


def test_bad_files(tmp_path):
    with pytest.raises(ConfigError, match="file not found"):
        load_sweep(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("seed: [1,\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_sweep(bad)
    lst = tmp_path / "list.yaml"
    lst.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="mapping"):
        load_sweep(lst)


# ----------------------------------------------------------------------------- seeds and hash


def test_common_random_numbers_across_searchers():
    spec = load_sweep(_spec(scenarios=[{"name": "toy", "grid": {"scale": [1.0, 2.0]}}]))
    tasks = expand_tasks(spec)
    by = {(t.cell_id, t.episode): t for t in tasks}
    for e in range(spec.episodes):
        for wk in ("toy[scale=1.0]", "toy[scale=2.0]"):
            ta, tb = by[(f"{wk}/a", e)], by[(f"{wk}/b", e)]
            assert (ta.world_seed, ta.agent_seed) == (tb.world_seed, tb.agent_seed)
            # the stub's world (start distance) is therefore identical for both searchers
            assert stub_episode(ta)["start_distance"] == stub_episode(tb)["start_distance"]
    world = [t.world_seed for t in tasks if t.cell_id.endswith("/a")]
    assert len(set(world)) == len(world)  # distinct per episode and per world key
    assert all(0 <= t.world_seed < 2**63 and 0 <= t.agent_seed < 2**63 for t in tasks)
    # seeds are a pure function of (root, world key, episode)
    assert episode_seeds(7, "toy[scale=1.0]", 3) == (
        by[("toy[scale=1.0]/a", 3)].world_seed,
        by[("toy[scale=1.0]/a", 3)].agent_seed,
    )
    assert episode_seeds(8, "toy[scale=1.0]", 3) != episode_seeds(7, "toy[scale=1.0]", 3)


def test_config_hash_stable_and_sensitive(tmp_path):
    base = load_sweep(_spec())
    h = config_hash(base)
    assert h == config_hash(load_sweep(_spec()))
    assert len(h) == 16
    # not part of the results: episode count, name, adaptive settings, keep_arrays
    for same in (
        {"episodes": 99},
        {"name": "renamed"},
        {"keep_arrays": True},
        {"adaptive": {"target_width": 0.1}},
    ):
        assert config_hash(load_sweep(_spec(**same))) == h, same
    for diff in (
        {"seed": 8},
        {"scenarios": [{"name": "toy", "params": {"scale": 2.0}}]},
        {"searchers": [{"name": "a", "params": {"skill": 0.9}}, {"name": "b"}]},
        {"searchers": [{"name": "a", "grid": {"skill": [0.8, 1.0]}}, {"name": "b"}]},
    ):
        assert config_hash(load_sweep(_spec(**diff))) != h, diff
    # a scenario given as a file: editing the file changes the hash
    scen = tmp_path / "room.yaml"
    scen.write_text("wind: 1.0\n")
    sweep = tmp_path / "s.yaml"
    sweep.write_text(
        "seed: 1\nepisodes: 2\nscenarios: [{name: room.yaml}]\nsearchers: [{name: a}]\n"
    )
    h1 = config_hash(load_sweep(sweep))
    scen.write_text("wind: 2.0\n")
    assert config_hash(load_sweep(sweep)) != h1
    # ... whatever the file's name
    bare = tmp_path / "room"
    bare.write_text("wind: 1.0\n")
    sweep.write_text("seed: 1\nepisodes: 2\nscenarios: [{name: ./room}]\nsearchers: [{name: a}]\n")
    h2 = config_hash(load_sweep(sweep))
    bare.write_text("wind: 2.0\n")
    assert config_hash(load_sweep(sweep)) != h2
    # ... and so does editing a file a searcher or a scenario names (weights, a map)
    (tmp_path / "w.npz").write_bytes(b"one")
    (tmp_path / "map.csv").write_text("0 0\n")
    sweep.write_text(
        "seed: 1\nepisodes: 2\n"
        "scenarios: [{name: room.yaml, params: {world.arena.obstacles.file: map.csv}}]\n"
        "searchers: [{name: a, params: {args: {weights: w.npz}}}]\n"
    )
    h3 = config_hash(load_sweep(sweep))
    (tmp_path / "w.npz").write_bytes(b"two")
    h4 = config_hash(load_sweep(sweep))
    (tmp_path / "map.csv").write_text("1 1\n")
    assert len({h3, h4, config_hash(load_sweep(sweep))}) == 3
    # prose that is no path (a long description with dots) is no file
    prose = "A long description. " * 40
    config_hash(load_sweep(_spec(searchers=[{"name": "a", "params": {"note": prose}}])))


# ----------------------------------------------------------------------------- running


def test_pool_equals_in_process_run_and_error_is_recorded(tmp_path):
    spec = _spec(
        searchers=[
            {"name": "a", "params": {"skill": 0.8, "fail_on": [5]}},
            {"name": "b", "params": {"skill": 1.6}},
        ]
    )
    seq = run_sweep(
        spec, tmp_path / "seq.sqlite", workers=1, episode_fn=stub_episode, progress=False
    )
    par = run_sweep(
        spec, tmp_path / "par.sqlite", workers=2, episode_fn=stub_episode, progress=False
    )
    pd.testing.assert_frame_equal(_table(seq), _table(par))
    assert len(par) == 24
    err = par[par["status"] == "error"]
    assert list(zip(err["cell_id"], err["episode"], strict=True)) == [("toy/a", 5)]
    assert err["error"].iloc[0].startswith("RuntimeError: stub failure in episode 5")
    assert err["termination"].iloc[0] == "error"
    ok = par[par["status"] == "ok"]
    assert (ok["error"] == "").all() and ok["search_time"].notna().all()
    # ordered by cell, episode
    assert list(par["episode"][:12]) == list(range(12))


def test_worker_crash_is_isolated_and_recorded(tmp_path):
    spec = _spec(episodes=6, searchers=[{"name": "a", "params": {"crash_on": [2]}}])
    df = run_sweep(spec, tmp_path / "c.sqlite", workers=2, episode_fn=stub_episode, progress=False)
    assert len(df) == 6
    assert list(df.loc[df["status"] == "error", "episode"]) == [2]
    assert "WorkerDied" in df.loc[df["episode"] == 2, "error"].iloc[0]


def test_resume_adds_missing_only(tmp_path):
    store = tmp_path / "r.sqlite"
    first = run_sweep(_spec(episodes=5), store, workers=1, episode_fn=stub_episode, progress=False)
    more = run_sweep(_spec(episodes=9), store, workers=2, episode_fn=stub_episode, progress=False)
    assert len(more) == 18
    assert not more.duplicated(["cell_id", "episode"]).any()
    kept = more[more["episode"] < 5].reset_index(drop=True)
    # the first five episodes were not run again: even their timestamps are unchanged
    pd.testing.assert_frame_equal(kept, first)
    fresh = run_sweep(
        _spec(episodes=9), tmp_path / "f.sqlite", workers=2, episode_fn=stub_episode, progress=False
    )
    pd.testing.assert_frame_equal(_table(more), _table(fresh))


def test_selected_cells_run_alone_and_the_rest_resumes(tmp_path):
    """``select`` runs some cells into the whole sweep's store; the same sweep without it adds
    only the others, and the store ends as one run of everything would leave it."""
    store = tmp_path / "s.sqlite"
    spec = _spec(episodes=4)
    part = run_sweep(spec, store, workers=1, episode_fn=stub_episode, progress=False,
                     select=lambda c: c.spec["searcher_label"] == "b")  # fmt: skip
    assert set(part["searcher"]) == {"b"} and len(part) == 4 and part.attrs["added"] == 4
    rest = run_sweep(spec, store, workers=2, episode_fn=stub_episode, progress=False)
    assert rest.attrs["added"] == 4 and len(rest) == 8
    # b's episodes were not run again
    pd.testing.assert_frame_equal(rest[rest["searcher"] == "b"].reset_index(drop=True), part)
    fresh = run_sweep(spec, tmp_path / "f.sqlite", workers=2, episode_fn=stub_episode,
                      progress=False)  # fmt: skip
    pd.testing.assert_frame_equal(_table(rest), _table(fresh))
    # selecting nothing runs nothing
    none = run_sweep(spec, store, workers=1, episode_fn=stub_episode, progress=False,
                     select=lambda c: False)  # fmt: skip
    assert none.attrs["added"] == 0 and len(none) == 8


def test_store_of_other_sweep_is_refused_untouched(tmp_path):
    store = tmp_path / "o.sqlite"
    run_sweep(_spec(episodes=3), store, workers=1, episode_fn=stub_episode, progress=False)
    with ResultStore(store) as st:
        before = st.frame()
    with pytest.raises(ConfigError) as ei:
        run_sweep(_spec(seed=8), store, workers=1, episode_fn=stub_episode, progress=False)
    assert ei.value.field == "store" and "different sweep" in str(ei.value)
    assert "\n" not in str(ei.value)
    with ResultStore(store) as st:
        pd.testing.assert_frame_equal(st.frame(), before)


def test_unknown_backend_and_bad_scheduler_address(tmp_path):
    with pytest.raises(ConfigError, match="backend"):
        run_sweep(
            _spec(), tmp_path / "x.sqlite", backend="mpi", episode_fn=stub_episode, progress=False
        )
    with pytest.raises(ConfigError, match="scheduler"):
        run_sweep(
            _spec(),
            tmp_path / "x.sqlite",
            scheduler="localhost",
            episode_fn=stub_episode,
            progress=False,
        )


def test_adaptive_stops_at_target_width_or_cap(tmp_path):
    ad = {"metric": "success", "target_width": 0.35, "batch": 6, "max_episodes": 30}
    spec = _spec(
        episodes=6,
        adaptive=ad,
        searchers=[
            {"name": "a", "params": {"skill": 0.3}},
            {"name": "b", "params": {"skill": 3.0}},
        ],
    )
    df = run_sweep(spec, tmp_path / "ad.sqlite", workers=1, episode_fn=stub_episode, progress=False)
    n = df.groupby("cell_id")["episode"].count()
    # extend_together: both searchers of the one world keep the same count (complete pairs)
    assert n["toy/a"] == n["toy/b"]
    final = n.max()
    assert 6 < final <= 30 and final % 6 == 0
    widths = {c: stats.interval_width(g, "success") for c, g in df.groupby("cell_id")}
    assert final == 30 or max(widths.values()) <= 0.35
    # one batch earlier some cell was still too wide (otherwise the loop would have stopped)
    prev = df[df["episode"] < final - 6]
    assert max(stats.interval_width(g, "success") for _, g in prev.groupby("cell_id")) > 0.35
    again = run_sweep(
        spec, tmp_path / "ad2.sqlite", workers=2, episode_fn=stub_episode, progress=False
    )
    pd.testing.assert_frame_equal(_table(df), _table(again))


# ----------------------------------------------------------------------------- kill test

_CHILD = """
import sys
sys.path.insert(0, {tests!r})
from _stub_episode import stub_episode
from odorloc.experiments.sweep import run_sweep

SPEC = {spec!r}

if __name__ == "__main__":
    run_sweep(SPEC, sys.argv[1], workers=2, episode_fn=stub_episode, progress=False)
"""


def _count(path: Path) -> int:
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            return int(con.execute("SELECT COUNT(*) FROM episodes").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return 0


def test_sigkill_then_resume_equals_uninterrupted_run(tmp_path):
    spec = _spec(
        episodes=100,
        scenarios=[{"name": "toy"}],
        searchers=[
            {"name": "a", "params": {"skill": 0.8, "sleep": 0.005}},
            {"name": "b", "params": {"skill": 1.2, "sleep": 0.005}},
            {"name": "c", "params": {"skill": 1.6, "sleep": 0.005, "fail_on": [40]}},
        ],
    )
    script = tmp_path / "child.py"
    script.write_text(textwrap.dedent(_CHILD.format(tests=str(TESTS), spec=spec)))
    store = tmp_path / "killed.sqlite"
    proc = subprocess.Popen([sys.executable, str(script), str(store)], start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while _count(store) < 40:
            assert proc.poll() is None, "child finished before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.01)
    finally:
        # the whole session: the sweep process and its pool workers
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    partial = _count(store)
    assert 40 <= partial < 300
    resumed = run_sweep(spec, store, workers=2, episode_fn=stub_episode, progress=False)
    clean = run_sweep(
        spec, tmp_path / "clean.sqlite", workers=2, episode_fn=stub_episode, progress=False
    )
    assert len(resumed) == 300
    assert not resumed.duplicated(["cell_id", "episode"]).any()
    pd.testing.assert_frame_equal(_table(resumed), _table(clean))
    assert resumed.loc[resumed["status"] == "error", "episode"].tolist() == [40]
    assert np.isfinite(resumed["wall_time"]).all()


def test_task_is_frozen_and_picklable():
    import dataclasses
    import pickle

    t = expand_tasks(load_sweep(_spec()))[3]
    assert pickle.loads(pickle.dumps(t)) == t
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.episode = 4  # type: ignore[misc]


def test_progress_and_summary_table(tmp_path, capsys):

    from odorloc.experiments.progress import summary_table

    spec = _spec(episodes=5, searchers=[{"name": "a", "params": {"fail_on": [1]}}])
    df = run_sweep(spec, tmp_path / "p.sqlite", workers=1, episode_fn=stub_episode, progress=True)
    out = capsys.readouterr().out
    assert "all episodes" in out and "toy/a" in out and "Sweep summary" in out
    table = summary_table(df)
    cells = [str(next(iter(col.cells))) for col in table.columns]
    assert cells[0] == "toy/a"
    # n excludes the failed episode, which is counted in the last column
    assert cells[1] == "4" and cells[-1] == "1"
    k = int(df.loc[df["status"] == "ok", "success"].sum())
    assert cells[2].startswith(f"{100 * k / 4:.0f} [")


def test_name_validation_hook(tmp_path):
    scen = pytest.importorskip("odorloc.scenarios")
    if not hasattr(scen, "get_scenario"):
        pytest.skip("odorloc.scenarios.get_scenario not available")
    from odorloc.core import registry
    from odorloc.experiments.sweep import validate_names

    known = registry.names("searcher")
    if not known:
        pytest.skip("no searcher registered yet")
    with pytest.raises(ConfigError) as ei:
        validate_names(load_sweep(_spec(scenarios=[{"name": "no-such-scenario"}])))
    assert ei.value.field == "scenarios[0].name"
    builtin = scen.builtin_names()[0]
    bad = _spec(scenarios=[{"name": builtin}], searchers=[{"name": known[0]}, {"name": "nope"}])
    with pytest.raises(ConfigError) as ei:
        validate_names(load_sweep(bad))
    assert ei.value.field == "searchers[1].name" and known[0] in str(ei.value)
    # run_sweep validates by default with the real episode function: nothing is stored
    with pytest.raises(ConfigError):
        run_sweep(bad, tmp_path / "v.sqlite", progress=False)
    assert not (tmp_path / "v.sqlite").exists()


def test_tasks_are_generated_lazily() -> None:
    """A sweep of a million episodes per cell yields its first tasks at once and counts its
    pending episodes without building the task list."""
    import odorloc.experiments.sweep as sweep_mod
    from odorloc.experiments.sweep import count_pending, iter_pending

    spec = load_sweep(_spec(episodes=1_000_000))
    cells = expand_cells(spec)
    targets = {c.cell_id: spec.episodes for c in cells}
    made = []
    real = sweep_mod.make_task

    def counted(*args, **kw):
        made.append(1)
        return real(*args, **kw)

    sweep_mod.make_task = counted
    try:
        it = iter_pending(spec, cells, targets, {(cells[0].cell_id, 0)}, config_hash(spec))
        first = [next(it) for _ in range(3)]
    finally:
        sweep_mod.make_task = real
    assert len(made) == 3  # three tasks asked for, three built: nothing ahead of the caller
    assert [t.episode for t in first] == [1, 2, 3]
    assert count_pending(targets, {(cells[0].cell_id, 0)}) == 2 * 1_000_000 - 1


def test_relative_scenario_path_is_relative_to_the_sweep_file(tmp_path, monkeypatch) -> None:
    """A sweep naming its scenario file relative to the sweep's folder runs from any current
    folder: every episode opens that file (no error rows)."""
    import yaml

    from helpers import small_scenario_dict

    d = tmp_path / "study"
    d.mkdir()
    sc = small_scenario_dict("zigzag")
    sc["limits"]["time"] = 5.0
    (d / "room.yaml").write_text(yaml.safe_dump(sc))
    sweep = {
        "name": "rel",
        "seed": 1,
        "episodes": 2,
        "scenarios": [{"name": "room.yaml"}],
        "searchers": [{"name": "zigzag"}],
    }
    (d / "sweep.yaml").write_text(yaml.safe_dump(sweep))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    df = run_sweep(d / "sweep.yaml", tmp_path / "out.sqlite", workers=2, progress=False)
    assert len(df) == 2 and (df["status"] == "ok").all(), df["error"].tolist()
    assert (df["scenario"] == "room.yaml").all()


def test_invalid_grid_cell_runs_nothing_and_leaves_the_store_identical(tmp_path) -> None:
    """One invalid value in a grid is found before the first episode: ConfigError naming the
    sweep field, the store byte-identical (no -wal or -shm file either)."""
    import yaml

    from helpers import small_scenario_dict

    (tmp_path / "room.yaml").write_text(yaml.safe_dump(small_scenario_dict("zigzag")))
    sweep = {
        "name": "grid",
        "seed": 1,
        "episodes": 1,
        "scenarios": [{"name": "room.yaml"}],
        "searchers": [{"name": "zigzag"}],
    }
    (tmp_path / "sweep.yaml").write_text(yaml.safe_dump(sweep))
    store = tmp_path / "out" / "results.sqlite"
    run_sweep(tmp_path / "sweep.yaml", store, workers=1, progress=False)
    files = {p.name: p.read_bytes() for p in store.parent.iterdir()}
    sweep["scenarios"][0]["grid"] = {"limits.time": [10.0, -1.0]}
    (tmp_path / "sweep.yaml").write_text(yaml.safe_dump(sweep))
    calls = []

    def never(task):  # pragma: no cover - must not be called
        calls.append(task)
        return {}

    with pytest.raises(ConfigError) as ei:
        run_sweep(
            tmp_path / "sweep.yaml",
            store,
            workers=1,
            progress=False,
            validate=True,
            episode_fn=never,
        )
    assert ei.value.field == "scenarios[0].grid.limits.time"
    assert {p.name: p.read_bytes() for p in store.parent.iterdir()} == files
    assert calls == []


def test_replay_of_a_flow_with_drawn_sources_is_refused() -> None:
    from odorloc.experiments.sweep_check import check_names

    for scen in ({"name": "lattice-isotropic-2d"},):
        spec = load_sweep(
            {
                "seed": 1,
                "episodes": 2,
                "scenarios": [scen],
                "searchers": [{"name": "infotaxis"}],
                "replay": True,
            }
        )
        with pytest.raises(ConfigError) as ei:
            check_names(spec)
        assert ei.value.field == "replay"
    ok = load_sweep(
        {
            "seed": 1,
            "episodes": 2,
            "scenarios": [{"name": "lattice-isotropic-2d"}],
            "searchers": [{"name": "infotaxis"}],
        }
    )
    check_names(ok)
