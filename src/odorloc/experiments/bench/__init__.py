"""``odorloc bench``: the field's benchmark on the sweep harness.

A versioned suite of tasks (:mod:`.suite`, data in ``suite-<version>.yaml``), every method that
can run each task, one resumable sweep per task (:mod:`.run`), the board with intervals and
ranks, its results JSON and diff (:mod:`.results`), and the HTML leaderboard (:mod:`.board`).

>>> from odorloc.experiments.bench import run_bench          # doctest: +SKIP
>>> doc = run_bench("out", tier="quick", tasks=["otto-19x19"], methods=["infotaxis"])
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from odorloc.core.errors import ConfigError
from odorloc.experiments.bench.results import (
    SCHEMA,
    compare_results,
    load_results,
    reference_check,
    task_rows,
    write_results,
)
from odorloc.experiments.bench.suite import (
    DEFAULT_SUITE,
    TIERS,
    Method,
    Suite,
    load_suite,
    method_from_option,
)

__all__ = [
    "DEFAULT_SUITE",
    "SCHEMA",
    "TIERS",
    "Method",
    "Suite",
    "compare_results",
    "load_results",
    "load_suite",
    "method_from_option",
    "run_bench",
]


def _methods(names: Sequence[str] | None) -> list[Method] | None:
    """``--methods``: registered names (``None``: every registered searcher)."""
    if not names:
        return None
    return [method_from_option(n) for n in names]


def _seeds(df: Any) -> list[list[int]]:
    """``[world_seed, agent_seed]`` per episode index (the same for every method)."""
    if len(df) == 0:
        return []
    first = df.drop_duplicates("episode").sort_values("episode")
    return [[int(w), int(a)] for w, a in zip(first["world_seed"], first["agent_seed"], strict=True)]


def run_bench(
    out: str | Path,
    *,
    suite: str | Path = DEFAULT_SUITE,
    tier: str = "quick",
    tasks: Sequence[str] | None = None,
    methods: Sequence[str] | None = None,
    extra: Sequence[str] = (),
    backend: str = "local",
    workers: int = 2,
    scheduler: str | None = None,
    progress: bool = True,
    html: bool = True,
    episodes: int | None = None,
) -> dict[str, Any]:
    """Run (or resume) the suite's tasks and write ``results.json`` and ``leaderboard.html``.

    Parameters
    ----------
    out : path
        Output folder: ``results.json``, ``leaderboard.html``, ``figures/``, ``stores/`` (one
        SQLite store per task and tier; running again resumes them).
    suite : str or path
        Suite version or file.
    tier : {"quick", "standard"}
    tasks : list of str, optional
        Task names (default: all).
    methods : list of str, optional
        Restrict the board to these methods (registered names, ``module:Class``, preset files).
    extra : list of str
        Methods added to the registered ones (``module:Class`` or preset files).
    backend, workers, scheduler
        As :func:`odorloc.experiments.sweep.run_sweep`.
    progress : bool
        Progress bars.
    html : bool
        Write the leaderboard and its figures.
    episodes : int, optional
        Episodes per method for every task instead of the tier's (a trial run; the results
        say so under ``episodes_override``, and compare only with runs of the same count).

    Returns
    -------
    dict
        The results document (:mod:`.results`).
    """
    from odorloc import __version__
    from odorloc.core.loading import check_output_dir
    from odorloc.experiments.bench.board import write_leaderboard
    from odorloc.experiments.bench.run import run_task
    from odorloc.experiments.provenance import machine

    if tier not in TIERS:
        raise ConfigError("--tier", f"must be one of {', '.join(TIERS)}, got {tier!r}")
    s = load_suite(suite)
    chosen = s.select(tasks)
    if episodes is not None:
        if isinstance(episodes, bool) or not 1 <= int(episodes) <= 100_000:
            raise ConfigError("--episodes", f"must be in [1, 100000], got {episodes!r}")
        counts = {t: int(episodes) for t in TIERS}
        chosen = [t.model_copy(update={"episodes": counts}) for t in chosen]
    only = _methods(methods)
    more = [method_from_option(m) for m in extra]
    out = Path(out)
    check_output_dir(out, "--out")
    out.mkdir(parents=True, exist_ok=True)
    started = time.time()
    t0 = time.perf_counter()
    doc: dict[str, Any] = {
        "schema": SCHEMA,
        "suite": s.suite,
        "tier": tier,
        "seed": s.seed,
        "odorloc_version": __version__,
        "machine": machine(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
        "backend": "dask" if scheduler else backend,
        "workers": workers,
        "episodes_override": episodes,
        "tasks": [],
        "rows": [],
    }
    for task in chosen:
        df, app, wall = run_task(
            s,
            task,
            tier,
            out,
            methods=only,
            extra=more,
            backend=backend,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
        rows = task_rows(task, df, app.methods, s.seed)
        for r in rows:
            chk = reference_check(r, task.reference)
            if chk is not None:
                r["reference"] = chk
        n = task.episodes[tier]  # type: ignore[index]
        doc["tasks"].append(
            {
                "name": task.name,
                "scenario": task.scenario,
                "summary": task.summary,
                "rule": task.rule,
                "rank_by": task.rank_by,
                "metrics": list(task.metrics),
                "episodes": n,
                "overrides": task.overrides(tier),
                "wall_time_s": round(wall, 2),
                "cpu_time_s": round(float(df["cpu_time"].sum()), 2) if "cpu_time" in df else 0,
                "skipped": app.skipped,
                "seeds": _seeds(df),
                "reference": task.reference,
            }
        )
        doc["rows"].extend(rows)
    doc["wall_time_s"] = round(time.perf_counter() - t0, 2)
    write_results(out / "results.json", doc)
    if html:
        write_leaderboard(doc, out)
    return doc
