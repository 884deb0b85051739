"""A cheap, deterministic stand-in for the real episode function (used by the harness tests).

Knobs are read from the cell's searcher parameters:

- ``skill`` (float, default 1.0): larger means faster and more often successful;
- ``fail_on`` (list of int): episode indices that raise ``RuntimeError``;
- ``crash_on`` (list of int): episode indices that kill the worker process (``os._exit``);
- ``sleep`` (float, s): sleep this long (an episode that waits, e.g. on I/O);
- ``work_iters`` (int): this many 64 x 64 matrix products (an episode that computes; a fixed
  amount of work, so it takes longer when the CPU is shared, like a real episode);
- ``trajectory`` (bool): return a random-walk trajectory under ``"arrays"``.

The world (start distance, wind noise) is drawn from ``task.world_seed`` only, so every searcher
faces the same world in episode ``i`` (common random numbers); the searcher's luck comes from
``task.agent_seed``.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np


def busy(iters: int, rng: np.random.Generator) -> float:
    """A fixed amount of NumPy work; returns a checksum so it is not optimised away."""
    a = rng.standard_normal((64, 64)) / 8.0
    acc = 0.0
    for _ in range(int(iters)):
        acc += float(np.linalg.norm(a @ a.T))
    return acc


def calibrate(ms: float) -> int:
    """Iterations of :func:`busy` taking about ``ms`` milliseconds on this machine."""
    rng = np.random.default_rng(0)
    busy(50, rng)
    n = 200
    t0 = time.perf_counter()
    busy(n, rng)
    per = (time.perf_counter() - t0) / n
    return max(1, round(ms / 1000.0 / per))


def stub_episode(task) -> dict:
    p = task.cell.get("searcher_params", {})
    sp = task.cell.get("scenario_params", {})
    if task.episode in p.get("fail_on", ()):
        raise RuntimeError(f"stub failure in episode {task.episode}")
    if task.episode in p.get("crash_on", ()):
        os._exit(13)
    world = np.random.default_rng(task.world_seed)
    agent = np.random.default_rng(task.agent_seed)
    start_distance = float(world.uniform(1.0, 6.0)) * float(sp.get("scale", 1.0))
    difficulty = float(world.exponential(1.0))
    skill = float(p.get("skill", 1.0))
    if p.get("sleep"):
        time.sleep(float(p["sleep"]))
    if p.get("work_iters"):
        busy(int(p["work_iters"]), np.random.default_rng(task.agent_seed + 1))
    prob = 1.0 / (1.0 + math.exp(-(2.0 * skill - 0.4 * start_distance - 0.5 * difficulty + 1.0)))
    success = bool(agent.random() < prob)
    time_limit = float(sp.get("time_limit", 600.0))
    search_time = min(
        time_limit, 20.0 * start_distance / skill + 30.0 * difficulty + agent.exponential(10.0)
    )
    if not success:
        search_time = time_limit
    row = {
        "success": success,
        "search_time": search_time,
        "path_length": 0.2 * search_time + agent.random(),
        "loc_error": float(agent.uniform(0.0, 0.5)) if success else math.nan,
        "first_detection_time": float(agent.exponential(5.0)),
        "energy": 3.0 * search_time,
        "bytes": int(agent.integers(0, 1000)),
        "steps": int(search_time / 0.5),
        "termination": "declared" if success else "time_limit",
        "start_distance": start_distance,
        "status": "ok",
        "error": "",
        "difficulty": difficulty,
    }
    if p.get("agents"):
        # a team: each member's own cue count and declaration time, kept per agent
        row["agent_metrics"] = {
            a: {"cues": float(a + task.episode), "declaration_time": 10.0 * (a + 1)}
            for a in range(int(p["agents"]))
        }
    if p.get("trajectory"):
        n = 40
        steps = agent.normal(0.0, 0.3, size=(n, 2))
        pos = np.cumsum(steps, axis=0) + np.array([start_distance, 0.0])
        row["arrays"] = {
            "positions": pos,
            "times": np.arange(n) * 0.5,
            "source": np.zeros(2),
        }
    return row
