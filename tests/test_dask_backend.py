"""The Dask backend gives the local pool's table bit for bit; a dead scheduler is one clear line."""

from __future__ import annotations

import socket

import pandas as pd
import pytest

from _stub_episode import stub_episode
from odorloc.core.errors import ConfigError
from odorloc.experiments.store import ResultStore
from odorloc.experiments.sweep import run_sweep

pytest.importorskip("distributed", reason="dask.distributed not installed (extra odorloc[dask])")

SPEC = {
    "seed": 11,
    "episodes": 15,
    "scenarios": [{"name": "toy", "grid": {"scale": [1.0, 1.5]}}],
    "searchers": [
        {"name": "a", "params": {"skill": 0.7, "fail_on": [4]}},
        {"name": "b", "params": {"skill": 1.4}},
    ],
}


def _table(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["wall_time", "finished_at"]).reset_index(drop=True)


def test_local_cluster_matches_local_pool(tmp_path):
    local = run_sweep(
        SPEC, tmp_path / "l.sqlite", workers=2, episode_fn=stub_episode, progress=False
    )
    dask = run_sweep(
        SPEC,
        tmp_path / "d.sqlite",
        backend="dask",
        workers=2,
        episode_fn=stub_episode,
        progress=False,
    )
    assert len(dask) == 60
    pd.testing.assert_frame_equal(_table(local), _table(dask))
    assert dask.loc[dask["status"] == "error", "episode"].tolist() == [4, 4]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_one_line_and_store_untouched(tmp_path):
    store = tmp_path / "s.sqlite"
    run_sweep({**SPEC, "episodes": 3}, store, workers=1, episode_fn=stub_episode, progress=False)
    with ResultStore(store) as st:
        before = st.frame()
    addr = f"tcp://127.0.0.1:{_free_port()}"
    with pytest.raises(ConfigError) as ei:
        run_sweep(SPEC, store, scheduler=addr, timeout=1.0, episode_fn=stub_episode, progress=False)
    msg = str(ei.value)
    assert ei.value.field == "scheduler" and addr in msg and "\n" not in msg
    with ResultStore(store) as st:
        pd.testing.assert_frame_equal(st.frame(), before)


def test_scheduler_address_joins_existing_cluster(tmp_path):
    import logging

    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, processes=False, dashboard_address=None, silence_logs=logging.ERROR
    ) as cluster:
        spec = {**SPEC, "episodes": 4}
        joined = run_sweep(
            spec,
            tmp_path / "j.sqlite",
            scheduler=cluster.scheduler_address,
            episode_fn=stub_episode,
            progress=False,
        )
    local = run_sweep(
        spec, tmp_path / "l.sqlite", workers=1, episode_fn=stub_episode, progress=False
    )
    pd.testing.assert_frame_equal(_table(local), _table(joined))
