"""Episode engine speed: control steps per second for a zigzag episode on the filament plume,
and the engine's own share of the time.

Side by side in one run: (a) the full episode through the engine, (b) a bare loop that only
steps the same world the same number of times and calls the same searcher. The engine overhead
is the share of episode wall time spent outside world stepping (the plume's warm-up included)
and the searcher (sensing, platforms, messaging, bookkeeping); steps per second are counted
without the warm-up.

    .venv/bin/python benchmarks/episode_speed.py
"""

from __future__ import annotations

import os
import platform
import statistics
import time

import numpy as np

from odorloc.core.seeds import episode_generators, episode_seeds
from odorloc.core.types import Observation
from odorloc.engine.episode import prepare_world, run_episode
from odorloc.scenarios import Scenario
from odorloc.scenarios.build import build, search_context

SCENARIO = {
    "name": "bench-zigzag-filament",
    "world": {
        "arena": {"lower": [0.0, 0.0], "upper": [20.0, 10.0], "resolution": 0.1},
        "sources": [{"position": [2.0, 5.0], "rate": 10.0}],
        "wind": {"type": "uniform", "velocity": [1.0, 0.0]},
        "plume": {"type": "filament"},
        "dt": 0.1,
        "warmup": 20.0,
    },
    "platform": {"type": "holonomic", "max_speed": 0.5},
    "agents": {"starts": [[17.0, 3.0]]},
    "searcher": {"type": "zigzag"},
    "limits": {"control_dt": 0.5, "time": 300.0},
}


def bare_loop(sc: Scenario, world_seed: int, agent_seed: int, steps: int) -> tuple[float, float]:
    """Seconds of the plume's warm-up, and of ``steps`` control periods of only world stepping
    + searcher calls."""
    b = build(sc)
    _, _, ra = episode_generators(world_seed, agent_seed)
    n_sub = round(sc.limits.control_dt / sc.world.dt)
    wdt = sc.limits.control_dt / n_sub
    tw = time.perf_counter()
    world, rw, _ = prepare_world(sc, world_seed, b.world)
    warmup = time.perf_counter() - tw
    start = np.asarray(sc.agents.starts, float)
    for k, pl in enumerate(b.platforms):
        pl.reset(start[k], 0.0)
    b.searcher.reset(search_context(sc, b), ra)
    obs = [Observation(0, 0.0, start[0], 0.0, 0.0, False, np.array([1.0, 0.0]))]
    t0 = time.perf_counter()
    for _ in range(steps):
        b.searcher.act(obs, ra)
        for _ in range(n_sub):
            world.step(wdt, rw)
    return warmup, time.perf_counter() - t0


def main() -> None:
    sc = Scenario.from_dict(SCENARIO)
    w, a = episode_seeds(0, "bench", 0)
    run_episode(sc, w, a, record=False)  # warm caches / JIT
    rows = []
    for rep in range(3):
        w, a = episode_seeds(0, "bench", rep)
        res = run_episode(sc, w, a, record=False)
        m = res.metrics
        # The episode's wall time includes the plume's warm-up (counted as world time); the
        # same warm-up, timed in the bare loop, is taken off for the per-step rate and ratio.
        warmup, bare = bare_loop(sc, w, a, m["steps"])
        total = m["wall_time"]
        rows.append(
            {
                "steps": m["steps"],
                "total_s": total,
                "warmup_s": warmup,
                "steps_per_s": m["steps"] / (total - warmup),
                "world_frac": m["world_fraction"],
                "searcher_frac": m["searcher_fraction"],
                "bare_s": bare,
            }
        )
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}"
    )
    print(
        f"{'rep':>3} {'steps':>6} {'episode s':>10} {'steps/s':>9} {'world %':>8} "
        f"{'searcher %':>11} {'bare loop s':>12}"
    )
    for i, r in enumerate(rows):
        print(
            f"{i:>3} {r['steps']:>6} {r['total_s']:>10.3f} {r['steps_per_s']:>9.0f} "
            f"{100 * r['world_frac']:>7.1f}% {100 * r['searcher_frac']:>10.1f}% "
            f"{r['bare_s']:>12.3f}"
        )
    sps = statistics.median(r["steps_per_s"] for r in rows)
    overhead = statistics.median(1.0 - r["world_frac"] - r["searcher_frac"] for r in rows)
    ratio = statistics.median((r["total_s"] - r["warmup_s"]) / r["bare_s"] for r in rows)
    print(f"episode / bare-loop time ratio (both without the plume's warm-up): {ratio:.2f}")
    print(f"RESULT steps_per_s={sps:.0f} engine_overhead={overhead:.3f}")


if __name__ == "__main__":
    main()
