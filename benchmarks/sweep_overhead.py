"""Harness overhead, parallel efficiency and parent memory of the sweep runner.

Runs ``N`` short episodes (the test stub doing a fixed amount of NumPy work, calibrated to
~20 ms on an idle core) three ways:

1. a bare loop calling the episode function (the reference: no harness at all);
2. the harness in this process (``workers=1``: task creation, seeding, error wrapper, one SQLite
   commit per episode) -> harness overhead per episode = (harness - bare) / N, measured on empty
   episodes so that other jobs slowing the episode's own work do not count as overhead;
3. the local process pool and a Dask ``LocalCluster`` with ``W`` workers, results written to a
   store as they arrive -> parallel efficiency = bare / (W * wall), start-up reported apart.

Then a child process runs a 2 000-episode sweep of empty episodes and reports how much the
parent's peak resident memory (``ru_maxrss``) grew beyond a 200-episode warm-up: nothing may
accumulate per episode.

Targets: overhead <= 5 ms per episode, local efficiency >= 80 % on 2 free cores, RSS growth
<= 50 MB. On a machine shared with other jobs the efficiency is lower; the numbers are what was
measured.

Usage::

    python benchmarks/sweep_overhead.py [--episodes 500] [--workers 2] [--work-ms 20] [--real]

``--real`` uses the package's own episode function on its shortest built-in scenario (when
``odorloc.experiments.runner`` exists) instead of the stub.

The last line reads
``RESULT overhead_ms=<x> efficiency_local=<y> efficiency_dask=<z> rss_growth_mb=<w>``.
"""

from __future__ import annotations

import os

# one BLAS thread per process, otherwise the "bare" loop would already use several cores
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from odorloc.experiments.backends import DaskBackend, LocalBackend  # noqa: E402
from odorloc.experiments.store import ResultStore  # noqa: E402
from odorloc.experiments.sweep import (  # noqa: E402
    config_hash,
    expand_tasks,
    load_sweep,
    run_sweep,
)


def _spec(episodes: int, work_iters: int, real: bool) -> dict:
    if real:
        # short real episodes: 10 s of the indoor room with the zigzag searcher
        return {
            "seed": 1,
            "episodes": episodes,
            "scenarios": [
                {"name": "indoor-ventilated", "params": {"limits.time": 10.0, "world.warmup": 5.0}}
            ],
            "searchers": [{"name": "zigzag"}],
        }
    return {
        "seed": 1,
        "episodes": episodes,
        "scenarios": [{"name": "toy"}],
        "searchers": [{"name": "bench", "params": {"work_iters": work_iters}}],
    }


def _episode_fn(real: bool):
    if real:
        from odorloc.experiments.runner import run_task  # type: ignore[import-not-found]

        return run_task
    from _stub_episode import stub_episode

    return stub_episode


def bare_loop(tasks, fn) -> float:
    t0 = time.perf_counter()
    for t in tasks:
        fn(t)
    return time.perf_counter() - t0


def harness_in_process(spec: dict, fn, tmp: Path) -> float:
    tmp.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    run_sweep(spec, tmp / "inproc.sqlite", workers=1, episode_fn=fn, progress=False)
    return time.perf_counter() - t0


def backend_run(backend, spec: dict, fn, store_path: Path) -> tuple[float, float]:
    """(start-up s, run s) of a backend writing every row to a store as it arrives."""
    sp = load_sweep(spec)
    tasks = expand_tasks(sp)
    with ResultStore(store_path) as store:
        store.bind(config_hash(sp), sp)
        t0 = time.perf_counter()
        with backend:
            if isinstance(backend, LocalBackend):
                # the pool starts its workers lazily: count that as start-up
                list(backend.run(tasks[: 2 * backend.workers], fn, chunk_size=1))
            t1 = time.perf_counter()
            n = 0
            for task, row in backend.run(tasks, fn):
                store.add(task, row)
                n += 1
            t2 = time.perf_counter()
        assert n == len(tasks) and len(store) == len(tasks)
    return t1 - t0, t2 - t1


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def _current_rss_mb() -> float:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def rss_child(n: int, workers: int) -> None:
    """Child mode: peak RSS growth of the parent between a warm-up and an ``n``-episode sweep."""
    from _stub_episode import stub_episode

    with tempfile.TemporaryDirectory() as d:
        warm = _spec(200, 0, False)
        run_sweep(
            warm, Path(d) / "warm.sqlite", workers=workers, episode_fn=stub_episode, progress=False
        )
        before = _rss_mb()
        cur_before = _current_rss_mb()
        big = _spec(n, 0, False)
        big["seed"] = 2
        t0 = time.perf_counter()
        run_sweep(
            big, Path(d) / "big.sqlite", workers=workers, episode_fn=stub_episode, progress=False
        )
        wall = time.perf_counter() - t0
        after = _rss_mb()
        cur_after = _current_rss_mb()
    print(
        json.dumps(
            {
                "before_mb": before,
                "after_mb": after,
                "wall": wall,
                "n": n,
                "cur_before_mb": cur_before,
                "cur_after_mb": cur_after,
            }
        )
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=500)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--work-ms", type=float, default=20.0)
    ap.add_argument("--rss-episodes", type=int, default=2000)
    ap.add_argument("--real", action="store_true", help="use the package's run_task")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--rss-child", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.rss_child:
        rss_child(args.rss_child, args.workers)
        return

    n, w = args.episodes, args.workers
    from _stub_episode import calibrate

    iters = calibrate(args.work_ms)
    spec = _spec(n, iters, args.real)
    fn = _episode_fn(args.real)
    tasks = expand_tasks(load_sweep(spec))
    rows = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        bare_loop(tasks[:20], fn)  # warm caches and imports
        warm = {**spec, "episodes": 5, "seed": 99}
        run_sweep(warm, tmp / "warm.sqlite", workers=1, episode_fn=fn, progress=False)
        bare = bare_loop(tasks, fn)
        rows.append(("bare loop", 1, 0.0, bare, 1.0))
        inproc = harness_in_process(spec, fn, tmp)
        rows.append(("harness, in process", 1, 0.0, inproc, bare / inproc))
        # overhead measured on empty episodes, so the load of other jobs on the episode's own
        # work does not masquerade as harness cost
        empty = {**_spec(n, 0, False), "seed": 5}
        empty_fn = _episode_fn(False)
        empty_tasks = expand_tasks(load_sweep(empty))
        bare_empty = min(bare_loop(empty_tasks, empty_fn) for _ in range(3))
        harness_empty = min(
            harness_in_process({**empty, "seed": 5 + i}, empty_fn, tmp / f"e{i}") for i in range(3)
        )
        overhead_ms = 1000.0 * (harness_empty - bare_empty) / n
        _, run_e = backend_run(LocalBackend(workers=w), empty, empty_fn, tmp / "local_empty.sqlite")
        su, run = backend_run(LocalBackend(workers=w), spec, fn, tmp / "local.sqlite")
        eff_local = bare / (w * run)
        rows.append(("local pool", w, su, run, eff_local))
        eff_dask = float("nan")
        if not args.no_dask:
            try:
                import distributed  # noqa: F401

                su, run = backend_run(DaskBackend(workers=w), spec, fn, tmp / "dask.sqlite")
                eff_dask = bare / (w * run)
                rows.append(("dask LocalCluster", w, su, run, eff_dask))
            except ImportError:
                print("dask not installed: skipped (pip install 'odorloc[dask]')")

    out = subprocess.run(
        [sys.executable, __file__, "--rss-child", str(args.rss_episodes), "--workers", str(w)],
        capture_output=True,
        text=True,
        check=True,
    )
    rss = json.loads(out.stdout.strip().splitlines()[-1])
    growth = rss["after_mb"] - rss["before_mb"]

    print(
        f"\n{n} episodes of ~{args.work_ms:g} ms ({iters} matrix products, "
        f"{'run_task' if args.real else 'stub'}), "
        f"{os.cpu_count()} CPUs visible, load average {os.getloadavg()[0]:.2f}"
    )
    print(
        f"{'mode':<22}{'workers':>8}{'start-up s':>12}{'run s':>9}"
        f"{'ms/episode':>12}{'efficiency':>12}"
    )
    for name, ww, su, run, eff in rows:
        print(f"{name:<22}{ww:>8}{su:>12.2f}{run:>9.2f}{1000 * run / n:>12.2f}{100 * eff:>11.1f}%")
    print(
        f"harness overhead per episode (empty episodes, in process: task, seeds, error "
        f"wrapper, SQLite commit, final table): {overhead_ms:.3f} ms  [target <= 5 ms]"
    )
    print(
        f"local pool on empty episodes ({w} workers, rows written as they arrive): "
        f"{1000 * run_e / n:.3f} ms per episode (parent throughput limit)"
    )
    print(
        f"local-pool parallel efficiency: {100 * eff_local:.1f} %  "
        f"[target >= 80 % on {w} free cores]"
    )
    print(
        f"parent peak RSS: {rss['before_mb']:.1f} MB after 200-episode warm-up, "
        f"{rss['after_mb']:.1f} MB after a {rss['n']}-episode sweep ({rss['wall']:.1f} s) -> "
        f"growth {growth:.1f} MB  [target <= 50 MB]; current RSS {rss['cur_before_mb']:.1f} -> "
        f"{rss['cur_after_mb']:.1f} MB"
    )
    print(
        f"RESULT overhead_ms={overhead_ms:.3f} efficiency_local={eff_local:.3f} "
        f"efficiency_dask={eff_dask:.3f} rss_growth_mb={growth:.1f}"
    )


if __name__ == "__main__":
    main()
