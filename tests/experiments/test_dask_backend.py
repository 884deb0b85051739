"""The Dask backend gives the local pool's table bit for bit; a dead scheduler is one clear line."""

from __future__ import annotations

import os
import signal
import socket
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

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


@pytest.mark.parametrize(
    "addr",
    [
        "tcp://127.0.0.1:notaport",
        "tcp://127.0.0.1",
        "tcp://",
        "foo://127.0.0.1:8786",
        "tcp://127.0.0.1:99999",
        "inproc://x",
    ],
)
def test_malformed_scheduler_address_is_one_line_naming_the_field(tmp_path, addr):
    with pytest.raises(ConfigError) as ei:
        run_sweep(
            SPEC,
            tmp_path / "m.sqlite",
            scheduler=addr,
            timeout=1.0,
            episode_fn=stub_episode,
            progress=False,
        )
    msg = str(ei.value)
    assert ei.value.field == "scheduler" and addr in msg and "\n" not in msg


def test_worker_crash_is_isolated_and_recorded_like_the_local_pool(tmp_path):
    spec = {**SPEC, "episodes": 6, "scenarios": [{"name": "toy"}]}
    spec["searchers"] = [{"name": "a", "params": {"crash_on": [2]}}]
    df = run_sweep(
        spec,
        tmp_path / "c.sqlite",
        backend="dask",
        workers=2,
        episode_fn=stub_episode,
        progress=False,
    )
    # the episode that kills its worker is recorded, the sweep goes on with the others
    assert df["episode"].tolist() == list(range(6))
    assert df.loc[df["status"] == "error", "episode"].tolist() == [2]
    assert "WorkerDied" in df.loc[df["episode"] == 2, "error"].iloc[0]
    assert df.loc[df["episode"] != 2, "search_time"].notna().all()


_CHILD = """
import signal
import sys
sys.path.insert(0, {tests!r})
from _stub_episode import stub_episode
from odorloc.experiments.sweep import run_sweep

SPEC = {spec!r}

if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        run_sweep(SPEC, sys.argv[1], backend="dask", workers=2, episode_fn=stub_episode,
                  progress=False)
    except KeyboardInterrupt:
        print("interrupted")
"""


def _stored(path: Path) -> int:
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            return int(con.execute("SELECT COUNT(*) FROM episodes").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return 0


def test_ctrl_c_stops_the_local_cluster_quietly_and_keeps_what_finished(tmp_path):
    spec = {**SPEC, "episodes": 200, "scenarios": [{"name": "toy"}]}
    spec["searchers"] = [{"name": "a", "params": {"sleep": 0.2}}]
    script = tmp_path / "child.py"
    tests = str(Path(__file__).resolve().parents[1])
    script.write_text(textwrap.dedent(_CHILD.format(tests=tests, spec=spec)))
    store = tmp_path / "i.sqlite"
    proc = subprocess.Popen(
        [sys.executable, str(script), str(store)],
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        while _stored(store) < 4:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.05)
        # Ctrl-C in a terminal signals the whole process group, workers included
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert "interrupted" in out
    assert "Traceback" not in err, err[-2000:]
    assert 4 <= _stored(store) < 200


def _worker_state() -> tuple[bool, bool]:
    """(SIGINT ignored, compiled kernels loaded) in the worker process running this."""
    import signal as sig

    from odorloc.core.jit import HAVE_NUMBA

    ignored = sig.getsignal(sig.SIGINT) == sig.SIG_IGN
    if not HAVE_NUMBA:
        return ignored, True
    from odorloc.inference.odor_path.kernel import dw_kernel_fast

    return ignored, bool(dw_kernel_fast.signatures)


def test_restarted_workers_get_the_same_set_up_as_the_first():
    from odorloc.experiments.backends import DaskBackend

    with DaskBackend(workers=1) as backend:
        client = backend.client
        assert list(client.run(_worker_state).values()) == [(True, True)]
        # a worker that died is replaced by its nanny the same way
        client.restart()
        assert list(client.run(_worker_state).values()) == [(True, True)]


def test_joined_cluster_is_left_without_the_set_up_plugin():
    import logging

    from distributed import Client, LocalCluster

    from odorloc.experiments.backends import WORKER_SETUP, DaskBackend

    with LocalCluster(
        n_workers=1, processes=False, dashboard_address=None, silence_logs=logging.ERROR
    ) as cluster:
        with DaskBackend(scheduler=cluster.scheduler_address) as backend:
            plugins = backend.client.run_on_scheduler(
                lambda dask_scheduler: list(dask_scheduler.worker_plugins)
            )
            assert WORKER_SETUP in plugins
        with Client(cluster, set_as_default=False) as client:
            plugins = client.run_on_scheduler(
                lambda dask_scheduler: list(dask_scheduler.worker_plugins)
            )
            assert WORKER_SETUP not in plugins


def test_a_failure_while_entering_shuts_the_local_cluster_down(monkeypatch):
    import odorloc.experiments.backends as backends

    def broken(ignore_sigint: bool):
        raise RuntimeError("plugin could not be built")

    monkeypatch.setattr(backends, "dask_worker_setup", broken)
    backend = backends.DaskBackend(workers=1)
    with pytest.raises(RuntimeError, match="plugin could not be built"):
        backend.__enter__()
    assert backend.client is None and backend.cluster is None
