"""Running the suite: one sweep per task on the sweep harness (durable store, resume, local
pool or Dask), with the benchmark's own episode columns.

Each task's sweep crosses the task's scenario with its methods under the suite's root seed, so
episode ``i`` of every method faces the same world (common random numbers, keyed by the task's
name) on any backend and worker count; its store is ``<out>/stores/<task>-<tier>.sqlite``, and
running the same command again resumes it. A method added later only adds its own cells: the
other cells keep their rows (the sweep's config hash changes, so the store is rebuilt from the
rows it holds; see :func:`run_task`).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.experiments.bench.suite import (
    Applicability,
    Method,
    Suite,
    Task,
    method_cell,
    task_methods,
)

__all__ = ["bench_episode", "bench_sweep", "run_task"]


def _extra_columns(cell: dict[str, Any], res: Any, built: Any) -> dict[str, Any]:
    """Columns of the task's extra metrics that the episode's own row lacks."""
    from odorloc.geometry.point_sets import earth_movers_distance

    out: dict[str, Any] = {}
    declared = res.declaration
    if declared is not None:
        out["emd"] = earth_movers_distance(np.atleast_2d(declared.positions), res.sources)
    else:
        out["emd"] = math.nan
    rates = [float(s.rate) for s in built.world.plume.sources]
    out["true_rate"] = rates[0] if len(rates) == 1 else math.nan
    return out


def bench_episode(task: Any) -> dict[str, Any]:
    """The benchmark's episode function: the harness's row of the episode
    (:func:`odorloc.experiments.runner.run_cell_episode`'s columns) plus ``cpu_time`` (s, the
    process's CPU time for the episode after its parts are built, world included), ``emd``
    (m, Earth Mover's Distance of the declared set to the true sources; NaN without
    declarations) and ``true_rate`` (the release rate of a single source, for the rate
    error). Never raises for a failing episode.
    """
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario, error_row, result_row
    from odorloc.scenarios.build import build

    t0 = time.perf_counter()
    c0 = time.process_time()
    try:
        sc = cell_scenario(task.cell)
        built = build(sc)
        # the episode's CPU time, not the build's (tables a model computes once per process)
        c0 = time.process_time()
        res = run_episode(sc, task.world_seed, task.agent_seed, built=built, record=False)
        row = result_row(res)
        row.update(_extra_columns(task.cell, res, built))
    except Exception as exc:  # one bad episode must not stop the board
        row = error_row(task.cell, exc, t0)
    row["cpu_time"] = time.process_time() - c0
    return row


def bench_sweep(suite: Suite, task: Task, tier: str, methods: Sequence[Method]) -> dict[str, Any]:
    """The sweep of one task and tier (a mapping :func:`odorloc.experiments.sweep.load_sweep`
    reads)."""
    from odorloc.scenarios import get_scenario

    own = get_scenario(task.scenario).searcher.type
    entry: dict[str, Any] = {"name": task.scenario, "label": task.name}
    overrides = task.overrides(tier)
    if overrides:
        entry["params"] = overrides
    return {
        "name": f"bench {suite.suite} {task.name} ({tier})",
        "seed": suite.seed,
        "episodes": task.episodes[tier],  # type: ignore[index]
        "scenarios": [entry],
        "searchers": [method_cell(task, m, own) for m in methods],
    }


def run_task(
    suite: Suite,
    task: Task,
    tier: str,
    out: Path,
    *,
    methods: Sequence[Method] | None = None,
    extra: Sequence[Method] = (),
    backend: str = "local",
    workers: int = 2,
    scheduler: str | None = None,
    progress: bool = True,
    episode_fn: Callable[[Any], dict[str, Any]] = bench_episode,
) -> tuple[Any, Applicability, float]:
    """Run (or resume) one task: ``(rows, the methods run and skipped, wall time in s)``.

    The store of a task keeps the rows of every method it ran; when the methods change (one
    added by import path, one dropped by ``--methods``) the sweep's config hash changes, so the
    store's rows are carried into a new store of the new sweep, for the cells the new sweep
    still has (their cell ids and seeds are the same: they depend on the task and the method,
    not on the other methods).
    """
    from odorloc.experiments.sweep import config_hash, load_sweep, run_sweep

    app = task_methods(suite, task, methods, extra)
    t0 = time.perf_counter()
    if not app.methods:
        import pandas as pd

        return pd.DataFrame(), app, 0.0
    spec = load_sweep(bench_sweep(suite, task, tier, app.methods))
    store = out / "stores" / f"{task.name}-{tier}.sqlite"
    store.parent.mkdir(parents=True, exist_ok=True)
    _carry_over(store, config_hash(spec), spec)
    df = run_sweep(
        spec,
        store,
        backend=backend,
        workers=workers,
        scheduler=scheduler,
        episode_fn=episode_fn,
        progress=progress,
        summary=False,
        validate=False,
    )
    # a store filled by a run of more episodes holds them all: the board is this tier's count
    df = df[df["episode"] < spec.episodes].reset_index(drop=True)
    return df, app, time.perf_counter() - t0


def _carry_over(store: Path, chash: str, spec: Any) -> None:
    """Move the rows of an older sweep of this task into a fresh store of ``spec`` (only the
    cells ``spec`` still has), so that adding or dropping a method never re-runs the others."""
    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import expand_cells, make_task

    if not store.exists():
        return
    with ResultStore(store, readonly=True) as old:
        if old.config_hash in (None, chash):
            return
        rows = old.frame(expand=False)
    keep = {c.cell_id: c for c in expand_cells(spec)}
    old_path = store.with_suffix(".previous.sqlite")
    store.replace(old_path)
    with ResultStore(store) as new:
        new.bind(chash, spec)
        for rec in rows.to_dict("records"):
            cell = keep.get(rec.get("cell_id"))
            if cell is None or rec.get("status") != "ok":
                continue
            task = make_task(spec, cell, int(rec["episode"]), chash)
            if (task.world_seed, task.agent_seed) != (rec.get("world_seed"), rec.get("agent_seed")):
                continue
            row = {k: v for k, v in rec.items() if k not in _STORE_KEYS and k != "extra"}
            row.update(json.loads(rec["extra"]) if rec.get("extra") else {})
            new.add(task, row)
    old_path.unlink()


#: Columns the store writes itself from the task (not from the row).
_STORE_KEYS = ("cell_id", "episode", "world_seed", "agent_seed", "cell", "config_hash")
