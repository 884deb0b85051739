"""Episode tasks: the picklable unit of work that every backend runs.

:func:`run_task` turns a task (scenario cell + episode index + seeds) into one flat result row.
It never raises for a failing episode: the row then has ``status="error"``, the error text and
its traceback, which also goes to the ``odorloc.runner`` log (shown where the application
configures logging).
"""

from __future__ import annotations

import logging
import math
import time
import traceback
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Any

from odorloc.core.errors import ConfigError
from odorloc.engine.episode import EpisodeResult, run_episode
from odorloc.engine.replay import on_replay, record_flow
from odorloc.experiments.store import AGENT_METRICS
from odorloc.scenarios import Scenario, get_scenario

log = logging.getLogger("odorloc.runner")
# The row carries the traceback (stored, and written to errors.log by the command line); without
# this, Python's last-resort handler would print every failed episode's traceback on stderr of
# whichever process ran it, even when the application configured no logging at all.
log.addHandler(logging.NullHandler())

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
    or ``overrides`` (dotted paths such as ``"limits.time"``). Two shorthands move the agents:
    ``start_index: i`` starts the (single) agent at ``agents.start_points[i]`` and
    ``start_set: NAME`` moves every group onto ``agents.start_sets[NAME]``.
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
    start_index = overrides.pop("start_index", None)
    start_set = overrides.pop("start_set", None)
    sc = Scenario.from_dict(data)
    if overrides:
        sc = sc.with_overrides(overrides)
    if start_index is not None:
        if isinstance(start_index, bool) or not isinstance(start_index, int):
            raise ConfigError("start_index", f"must be an integer, got {start_index!r}")
        sc = sc.with_start_point(start_index)
    if start_set is not None:
        sc = sc.with_start_set(str(start_set))
    return sc


def _light_recording(sc: Scenario) -> Scenario:
    """A light recording: trajectory, readings and a few plume/belief frames."""
    rc = sc.recording
    return sc.model_copy(
        update={
            "recording": rc.model_copy(
                update={"plume_stride": max(rc.plume_stride, 20), "belief_stride": 20}
            )
        }
    )


def result_row(res: EpisodeResult) -> dict[str, Any]:
    """The stored row of a finished episode: the defaults, its metrics (core and extra
    columns), its per-agent values under :data:`~odorloc.experiments.store.AGENT_METRICS` and
    ``status="ok"``."""
    row = dict(ROW_DEFAULTS)
    row.update(res.metrics.row())
    row[AGENT_METRICS] = res.metrics.agents
    row.update(status="ok", error="")
    return row


def error_row(cell: dict[str, Any], exc: Exception, t0: float) -> dict[str, Any]:
    """The row of an episode that raised ``exc`` (started at ``perf_counter() == t0``): the
    defaults, ``status="error"``, the error text and its traceback (also logged)."""
    tb = traceback.format_exc()
    log.error("episode failed (cell %s): %s\n%s", cell, exc, tb)
    row = dict(ROW_DEFAULTS)
    row.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=tb)
    row["wall_time"] = time.perf_counter() - t0
    return row


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
            sc = _light_recording(sc)
        res = run_episode(sc, world_seed, agent_seed, record=keep_arrays)
        row = result_row(res)
        if keep_arrays and res.recording is not None:
            row["arrays"] = res.recording.to_arrays()
    except Exception as exc:  # one bad episode must not stop a batch
        return error_row(cell, exc, t0)
    return row


def run_task(task: Any) -> dict[str, Any]:
    """Run an :class:`odorloc.experiments.sweep.EpisodeTask`; the recording is attached as
    ``arrays`` only when the task asks for it (``task.keep_arrays``), so ordinary sweeps pay
    nothing for recording."""
    return run_cell_episode(task.cell, task.world_seed, task.agent_seed, task.keep_arrays)


Extras = Callable[[Any, EpisodeResult, dict[str, Any]], dict[str, Any]]
"""``extras(task, result, rows_so_far_by_cell_id) -> columns`` for a replayed episode."""


def run_replay_group(
    tasks: Sequence[Any],
    *,
    record: bool = False,
    extras: Extras | None = None,
    prepare: Callable[[Scenario, Any], Scenario] | None = None,
) -> list[dict[str, Any]]:
    """Run a group of tasks that share one world (flow key and episode) on one recorded flow.

    The flow is recorded once (:func:`~odorloc.engine.replay.record_flow`) with the group's
    world seed and replayed to every task in order, so every searcher faces exactly the same
    plume and wind. Rows get ``replay=True``, ``movie_wall_time`` and ``movie_cpu_time`` (s,
    the recording's wall and CPU time), ``group_size`` (tasks sharing it) and ``cpu_time`` (s,
    the episode's CPU time: on a shared machine a better measure of cost than wall time).

    Parameters
    ----------
    tasks : sequence of EpisodeTask
        Same ``flow_key`` and ``episode``.
    record : bool
        Record every episode (for ``extras``); arrays are stored only for tasks that keep them.
    extras : callable, optional
        More columns per episode, computed from its result and the rows of the group so far.
    prepare : callable, optional
        ``prepare(scenario, task)`` adjusts each task's scenario before it runs (e.g. recording
        strides).
    """
    if not tasks:
        return []
    keys = {(t.flow_key, t.episode, t.world_seed) for t in tasks}
    if len(keys) != 1:
        raise ValueError("a replay group must share one flow key, episode and world seed")
    t0 = time.perf_counter()
    c0 = time.process_time()
    rows: list[dict[str, Any]] = []
    by_cell: dict[str, dict[str, Any]] = {}
    try:
        first = cell_scenario(tasks[0].cell)
        movie = record_flow(first, tasks[0].world_seed)
    except Exception as exc:
        return [error_row(t.cell, exc, t0) for t in tasks]
    movie_wall = time.perf_counter() - t0
    movie_cpu = time.process_time() - c0
    for task in tasks:
        t1 = time.perf_counter()
        c1 = time.process_time()
        try:
            sc = cell_scenario(task.cell)
            if task.keep_arrays and not record:
                sc = _light_recording(sc)
            if prepare is not None:
                sc = prepare(sc, task)
            sc_r, built = on_replay(sc, movie)
            res = run_episode(
                sc_r,
                task.world_seed,
                task.agent_seed,
                built=built,
                record=record or task.keep_arrays,
            )
            res.metrics.add(
                {
                    "replay": True,
                    "movie_wall_time": movie_wall,
                    "movie_cpu_time": movie_cpu,
                    "group_size": len(tasks),
                    "cpu_time": time.process_time() - c1,
                },
                source="replay",
            )
            if extras is not None:
                res.metrics.add(extras(task, res, by_cell), source="extras")
            row = result_row(res)
            if task.keep_arrays and res.recording is not None:
                row["arrays"] = res.recording.to_arrays()
        except Exception as exc:  # one bad episode must not stop the group
            row = error_row(task.cell, exc, t1)
        by_cell[task.cell_id] = row
        rows.append(row)
    return rows


def run_live_group(
    tasks: Sequence[Any], *, prepare: Callable[[Scenario, Any], Scenario] | None = None
) -> list[dict[str, Any]]:
    """Run a group of tasks one after another on live worlds (no recorded flow), each
    scenario adjusted by ``prepare(scenario, task)``: the counterpart of
    :func:`run_replay_group` for a group function whose worlds are not replayed (a steady
    analytic plume, or one a replay cannot stand for). Rows as :func:`run_cell_episode`'s."""
    rows = []
    for task in tasks:
        t0 = time.perf_counter()
        try:
            sc = cell_scenario(task.cell)
            if prepare is not None:
                sc = prepare(sc, task)
            res = run_episode(sc, task.world_seed, task.agent_seed, record=task.keep_arrays)
            row = result_row(res)
            if task.keep_arrays and res.recording is not None:
                row["arrays"] = res.recording.to_arrays()
        except Exception as exc:  # one bad episode must not stop the group
            row = error_row(task.cell, exc, t0)
        rows.append(row)
    return rows


def run_with_reference(
    tasks: Sequence[Any],
    is_reference: Callable[[Any], bool],
    make_reference: Callable[[Any], Any],
    **replay: Any,
) -> list[dict[str, Any]]:
    """A replay group (:func:`run_replay_group`, with ``replay``'s options) whose reference
    task runs first, so that ``extras`` of the others can read its row.

    The rows come back in the order of ``tasks``. When the group holds no reference task (a
    resumed run that stored it already), ``make_reference(any task)`` builds one; it runs first
    and its row is not returned (nothing is stored twice).
    """
    order = sorted(range(len(tasks)), key=lambda i: not is_reference(tasks[i]))
    ordered = [tasks[i] for i in order]
    if ordered and not is_reference(ordered[0]):
        rows = run_replay_group([make_reference(ordered[0]), *ordered], **replay)[1:]
    else:
        rows = run_replay_group(ordered, **replay)
    back: list[dict[str, Any]] = [{}] * len(tasks)
    for i, r in zip(order, rows, strict=True):
        back[i] = r
    return back


def replay_group(tasks: Sequence[Any]) -> list[dict[str, Any]]:
    """The default group function of sweeps with ``replay: true``."""
    return run_replay_group(tasks)
