"""Processes: a killed batch leaves no process behind; compiled kernels hit their cache across
processes and never write into the package."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

import odorloc
from odorloc.core.jit import HAVE_NUMBA

pytestmark = pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs Linux /proc")

PACKAGE = Path(odorloc.__file__).parent


def _children() -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_bytes()
        except OSError:
            continue
        ppid = int(stat.rsplit(b")", 1)[1].split()[1])
        kids.setdefault(ppid, []).append(int(d.name))
    return kids


def _descendants(pid: int) -> set[int]:
    kids = _children()
    out: set[int] = set()
    todo = [pid]
    while todo:
        p = todo.pop()
        for c in kids.get(p, []):
            if c not in out:
                out.add(c)
                todo.append(c)
    return out


def _alive(pid: int) -> bool:
    """Running (a zombie waiting to be reaped by whoever adopted it counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_bytes()
    except OSError:
        return False
    return stat.rsplit(b")", 1)[1].split()[0] not in (b"Z", b"X")


def _slow_sweep(tmp_path: Path) -> Path:
    sweep = {
        "name": "kill-me",
        "seed": 3,
        "episodes": 40,
        "scenarios": [{"name": "indoor-ventilated", "params": {"limits.time": 300.0}}],
        "searchers": [{"name": "zigzag"}],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    return f


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["local", "dask"])
def test_sigkill_of_a_batch_leaves_no_process_alive(tmp_path, backend) -> None:
    """SIGKILL the batch while its workers run episodes: every process it started
    (pool workers, forkserver, resource tracker; Dask nanny workers) has exited (they are told
    at once; the generous bound only keeps a hang from going unnoticed)."""
    if backend == "dask":
        pytest.importorskip("distributed")
    f = _slow_sweep(tmp_path)
    cmd = [sys.executable, "-m", "odorloc.cli", "batch", str(f), "--out", str(tmp_path / "o")]
    cmd += ["--workers", "2", "--no-progress", "--backend", backend]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    family: set[int] = set()
    try:
        deadline = time.monotonic() + 120
        store = tmp_path / "o" / "results.sqlite"
        # wait until the workers exist and have started episodes
        while time.monotonic() < deadline:
            family |= _descendants(proc.pid)
            if len(family) >= 2 and store.exists() and proc.poll() is None:
                time.sleep(1.0)
                family |= _descendants(proc.pid)
                break
            assert proc.poll() is None, "the batch ended before it could be killed"
            time.sleep(0.2)
        assert len(family) >= 2, "no worker processes seen"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        t_kill = time.monotonic()
        while time.monotonic() - t_kill < 60.0 and any(_alive(p) for p in family):
            time.sleep(0.1)
        left = sorted(p for p in family if _alive(p))
        assert not left, f"still alive {time.monotonic() - t_kill:.1f} s after the kill: {left}"
    finally:
        # whatever happened, leave nothing running
        if proc.poll() is None:
            proc.kill()
        for p in family | _descendants(proc.pid):
            if _alive(p):
                with contextlib.suppress(OSError):
                    os.kill(p, signal.SIGKILL)


_KERNEL_STATS = """
import json, sys
from odorloc.plume import filament
from odorloc.inference.odor_path import kernel
from odorloc.planning import infotaxis
if sys.argv[1] == "warm":
    from odorloc.core.jit import warm
    warm()
else:
    sys.path.insert(0, sys.argv[2])
    from helpers import filament_scenario_dict
    from odorloc.engine.episode import run_episode
    from odorloc.inference.odor_path.estimator import OdorPathEstimator, OdorPathParams
    from odorloc.scenarios import Scenario
    import numpy as np
    d = filament_scenario_dict("zigzag")
    d["limits"]["time"] = 5.0
    run_episode(Scenario.from_dict(d), 1, 2, record=True)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.5, dt=0.5), (0.0, 0.0), (10.0, 10.0))
    for i in range(30):
        est.update(0.5 * i, np.array([8.0, 5.0]), np.array([1.0, 0.1]), 1.0)
    est.path_patch()
    cells = np.zeros((1, 2), np.int64)
    infotaxis.correlate(np.ones((2, 3, 3)), np.ones((1, 1)), cells, (1, 1), backend="numba")
from odorloc.core import jit
stats = {}
for name, k in jit.kernels().items():
    stats[name] = [sum(k.stats.cache_hits.values()), sum(k.stats.cache_misses.values())]
print(json.dumps(stats))
"""


def _kernel_files(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*") if p.suffix in (".nbi", ".nbc"))


@pytest.mark.skipif(not HAVE_NUMBA, reason="needs the 'fast' extra")
def test_compiled_kernels_hit_the_cache_in_a_new_process(tmp_path) -> None:
    """The first process compiles into the user cache folder; a second one running a filament
    episode, an odor-path update and an infotaxis correlation loads every kernel from it (no
    cache miss), and nothing is ever written under the package's source tree."""
    before = _kernel_files(PACKAGE)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["ODORLOC_CACHE_DIR"] = str(tmp_path / "cache")
    script = tmp_path / "stats.py"
    script.write_text(_KERNEL_STATS)
    tests = str(Path(__file__).resolve().parents[1])

    def run(mode: str) -> dict[str, list[int]]:
        r = subprocess.run(
            [sys.executable, str(script), mode, tests],
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout.strip().splitlines()[-1])

    def used(stats: dict[str, list[int]], module: str) -> list[list[int]]:
        return [v for k, v in stats.items() if k.startswith(module + ".") and sum(v)]

    first = run("warm")
    for module in ("odorloc.plume.filament", "odorloc.inference.odor_path.kernel"):
        # compiled (cold cache)
        assert any(v[1] >= 1 for v in used(first, module)), (module, first)
    assert _kernel_files(tmp_path / "cache"), "nothing cached in the user cache folder"
    second = run("episode")
    # the episode, the odor-path update and the correlation load their kernels from the cache
    for module in (
        "odorloc.plume.filament",
        "odorloc.inference.odor_path.kernel",
        "odorloc.planning.infotaxis",
    ):
        assert used(second, module), (module, second)
    assert all(v[1] == 0 for v in second.values() if sum(v)), second
    assert _kernel_files(PACKAGE) == before == []


def test_cache_folder_is_outside_the_package(tmp_path, monkeypatch) -> None:
    from odorloc.core import jit

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("ODORLOC_CACHE_DIR", str(tmp_path / "c"))
    assert jit.cache_dir() == tmp_path / "c" / "numba"
    monkeypatch.delenv("ODORLOC_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert jit.cache_dir() == tmp_path / "x" / "odorloc" / "numba"
    assert PACKAGE not in jit.cache_dir().parents


def test_runtime_start_runs_once_and_loads_from_the_cache(tmp_path) -> None:
    """``jit.start`` brings numba up once per process (a second call does nothing); in a new
    process its own tiny kernel loads from the cache instead of compiling."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["ODORLOC_CACHE_DIR"] = str(tmp_path / "cache")
    code = (
        "import json; from odorloc.core import jit; jit.start(); jit.start(); "
        "k = [v for n, v in jit.kernels().items() if n == 'runtime']; print(json.dumps("
        "[len(k), [sum(k[0].stats.cache_misses.values()) if k else 0]]))"
    )

    def run() -> list:
        r = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
        )
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout.strip().splitlines()[-1])

    first, second = run(), run()
    if not HAVE_NUMBA:
        assert first == second == [0, [0]]
        return
    assert first[0] == second[0] == 1
    assert second[1] == [0]  # the second process compiled nothing
