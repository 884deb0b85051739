"""Episode tasks: the picklable unit of work that every backend runs.

:func:`run_task` turns a task (scenario cell + episode index + seeds) into one flat result row.
It never raises for a failing episode: the row then has ``status="error"`` and the error text,
and the traceback goes to the log.
"""

from __future__ import annotations

import logging
import math
import time
import traceback
from functools import lru_cache
from typing import Any

from odorloc.engine.episode import run_episode
from odorloc.scenarios import Scenario, get_scenario

log = logging.getLogger("odorloc.runner")

#: Metric columns every row carries (NaN/defaults for failed episodes).
ROW_DEFAULTS: dict[str, Any] = {
    "success": False,
    "declared": False,
    "termination": "error",
    "search_time": math.nan,
    "path_length": math.nan,
    "loc_error": math.nan,
    "first_detection_time": math.nan,
    "energy": math.nan,
    "bytes": 0,
    "steps": 0,
    "start_distance": math.nan,
    "sources_found": 0,
    "false_sources": 0,
    "wall_time": math.nan,
    "wall_per_step_ms": math.nan,
}


@lru_cache(maxsize=64)
def _base_scenario(name: str) -> Scenario:
    return get_scenario(name)


def cell_scenario(cell: dict[str, Any]) -> Scenario:
    """The scenario of a sweep cell: base scenario, searcher swap, then dotted overrides.

    ``cell`` keys: ``scenario`` (name or path), optional ``searcher`` (registry name; its
    parameters then start from defaults unless the base scenario already uses that searcher),
    optional ``overrides`` (dotted path -> value).
    """
    sc = _base_scenario(str(cell["scenario"]))
    searcher = cell.get("searcher")
    if searcher and searcher != sc.searcher.type:
        data = sc.to_dict()
        data["searcher"] = {"type": searcher}
        sc = Scenario.from_dict(data)
    overrides = cell.get("overrides") or {}
    if overrides:
        sc = sc.with_overrides(dict(overrides))
    return sc


def run_cell_episode(cell: dict[str, Any], world_seed: int, agent_seed: int) -> dict[str, Any]:
    """Run one episode of a cell and return its row (never raises for episode errors)."""
    t0 = time.perf_counter()
    row = dict(ROW_DEFAULTS)
    try:
        sc = cell_scenario(cell)
        res = run_episode(sc, world_seed, agent_seed, record=False)
        row.update(res.metrics)
        row.update(status="ok", error="")
    except Exception as exc:  # one bad episode must not stop a batch
        tb = traceback.format_exc()
        log.error("episode failed (cell %s): %s\n%s", cell, exc, tb)
        row.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=tb)
        row["wall_time"] = time.perf_counter() - t0
    return row


def run_task(task: Any) -> dict[str, Any]:
    """Run an :class:`odorloc.experiments.sweep.EpisodeTask` (any object with ``cell``,
    ``world_seed`` and ``agent_seed``)."""
    return run_cell_episode(task.cell, task.world_seed, task.agent_seed)
