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
from odorloc.errors import ConfigError
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
    """The scenario of a sweep cell.

    ``cell`` keys: ``scenario`` (built-in name or file path); optional ``searcher`` (registry
    name; replaces the scenario's searcher, whose parameters then start from defaults);
    optional ``searcher_params`` (the searcher's own parameters); optional ``scenario_params``
    or ``overrides`` (dotted paths such as ``"limits.time"``). The shorthand ``start_index: i``
    starts the (single) agent at ``info.start_points[i]`` of the scenario.
    """
    sc = _base_scenario(str(cell["scenario"]))
    data = sc.to_dict()
    searcher = cell.get("searcher")
    if searcher and searcher != sc.searcher.type:
        data["searcher"] = {"type": searcher}
    sp = cell.get("searcher_params") or {}
    if sp:
        data["searcher"] = {**data["searcher"], **dict(sp)}
    overrides = dict(cell.get("scenario_params") or {})
    overrides.update(cell.get("overrides") or {})
    if "start_index" in overrides:
        i = int(overrides.pop("start_index"))
        points = sc.info.get("start_points") or []
        if not 0 <= i < len(points):
            raise ConfigError("start_index", f"{i} is not an index of info.start_points")
        overrides["agents.starts"] = [list(points[i])]
    sc = Scenario.from_dict(data)
    if overrides:
        sc = sc.with_overrides(overrides)
    return sc


def run_cell_episode(
    cell: dict[str, Any], world_seed: int, agent_seed: int, keep_arrays: bool = False
) -> dict[str, Any]:
    """Run one episode of a cell and return its row (never raises for episode errors).

    With ``keep_arrays`` the row also carries ``arrays``: the episode's recording as a dict of
    arrays (see :meth:`~odorloc.engine.recorder.Recording.to_arrays`).
    """
    t0 = time.perf_counter()
    row = dict(ROW_DEFAULTS)
    try:
        sc = cell_scenario(cell)
        if keep_arrays:
            # A light recording: trajectory, readings and a few plume/belief frames.
            rc = sc.recording
            sc = sc.model_copy(
                update={
                    "recording": rc.model_copy(
                        update={"plume_stride": max(rc.plume_stride, 20), "belief_stride": 20}
                    )
                }
            )
        res = run_episode(sc, world_seed, agent_seed, record=keep_arrays)
        row.update(res.metrics)
        row.update(status="ok", error="")
        if keep_arrays and res.recording is not None:
            row["arrays"] = res.recording.to_arrays()
    except Exception as exc:  # one bad episode must not stop a batch
        tb = traceback.format_exc()
        log.error("episode failed (cell %s): %s\n%s", cell, exc, tb)
        row.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=tb)
        row["wall_time"] = time.perf_counter() - t0
    return row


def run_task(task: Any) -> dict[str, Any]:
    """Run an :class:`odorloc.experiments.sweep.EpisodeTask` (any object with ``cell``,
    ``world_seed`` and ``agent_seed``); the recording is attached as ``arrays`` only when the
    task asks for it (``task.keep_arrays``), so ordinary sweeps pay nothing for recording."""
    keep = bool(getattr(task, "keep_arrays", False))
    return run_cell_episode(task.cell, task.world_seed, task.agent_seed, keep_arrays=keep)
