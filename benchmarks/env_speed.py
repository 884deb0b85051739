"""Environment step overhead: the Gymnasium / PettingZoo adapters against the bare episode.

Side by side in one run, on the same seeds and the same action sequence: (a) the bare stepping
episode, ``Episode.step(Action([Command.velocity(v)]))``; (b) ``SearchEnv.step(action)`` (the
policy encoding: decoding the action, encoding the observation, the reward, the step info).
Reset and warm-up are outside the timed loops. The two run in lockstep, one step of (a) then
one of (b) (alternating which goes first), so that load on a shared machine hits both alike;
medians over rounds. In the team case the environment's agents also broadcast their readings
(the radio and its accounting are part of what it costs). The overhead is ``(b - a) / a``.

The last line is ``RESULT env_overhead=<x> env_steps_per_s=<y> env_overhead_farrell=<z>
pz_overhead=<w> pz_bare_ms=<v>`` (the first two of ``indoor-ventilated``, the Gymnasium headline;
the PettingZoo overhead and bare step time of the three-UAV ``muc-osl-3d``). Without the ``rl``
extra it stops with a one-line message.

    .venv/bin/python benchmarks/env_speed.py [--rounds 5]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from typing import Any

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.core.types import Action, Command
from odorloc.engine.episode import Episode
from odorloc.scenarios import get_scenario

STEPS = 600


def actions(n: int, dim: int, seed: int) -> np.ndarray:
    """A fixed sequence of velocity actions in [-1, 1]^d (a slowly turning heading)."""
    rng = np.random.default_rng(seed)
    a = np.cumsum(rng.normal(0.0, 0.3, n))
    out = np.zeros((n, dim), np.float32)
    out[:, 0], out[:, 1] = np.cos(a), np.sin(a)
    return out


def lockstep(name: str, acts: np.ndarray, root: int, n: int) -> tuple[float, float, int]:
    """Seconds of bare episode steps and of environment steps, taken alternately step by step
    on the same seeds and actions (so load on a shared machine hits both alike)."""
    from odorloc.envs import SearchEnv, parallel_env

    ep = Episode(get_scenario(name), record=False)
    ep.reset(*episode_seeds(root, name, 0))
    vmax = ep.context.speed_limits
    if n == 1:
        e: Any = SearchEnv(name, action={"declare": "none"})
    else:
        e = parallel_env(scenario=name, action={"declare": "none"})
    e.reset(seed=root)
    tb = te = 0.0
    steps = 0
    clock = time.perf_counter

    def bare_step(v: np.ndarray) -> float:
        t0 = clock()
        ep.step(Action([Command.velocity(v.astype(float) * vmax[k]) for k in range(n)]))
        return clock() - t0

    def env_step(v: np.ndarray) -> float:
        t0 = clock()
        if n == 1:
            e.step(v)
        else:
            e.step(dict.fromkeys(e.agents, v))
        return clock() - t0

    for i, v in enumerate(acts):
        if ep.done:
            break
        # alternate which goes first: the second of a pair finds warmer caches
        if i % 2 == 0:
            tb += bare_step(v)
            te += env_step(v)
        else:
            te += env_step(v)
            tb += bare_step(v)
        steps += 1
    return tb, te, steps


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    try:
        import gymnasium  # noqa: F401
        import pettingzoo  # noqa: F401
    except ImportError as exc:
        # both adapters are what is measured: without them there is nothing to compare
        print(
            f"env_speed: the environment adapters need the rl extra ({exc}); "
            "pip install 'odorloc[rl]'",
            file=sys.stderr,
        )
        raise SystemExit(2) from None
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}"
    )
    cases = [
        ("indoor-ventilated", 2, 1),  # the headline: filament plume, one robot
        ("two-sources-farrell", 2, 1),
        ("muc-osl-3d", 3, 3),  # PettingZoo, three UAVs exchanging messages
    ]
    print(f"{STEPS} control steps per run, {args.rounds} rounds, medians")
    print(
        f"{'scenario':<22} {'adapter':<12} {'bare ms/step':>13} {'env ms/step':>12} {'overhead':>9}"
    )
    results: dict[str, tuple[float, float, float]] = {}
    for name, dim, n in cases:
        acts = actions(STEPS, dim, 1)
        b_times, e_times = [], []
        for r in range(args.rounds + 1):
            tb, te, steps = lockstep(name, acts, r, n)
            if r > 0:  # the first round warms caches
                b_times.append(tb / steps)
                e_times.append(te / steps)
        ratios = [e / b - 1.0 for e, b in zip(e_times, b_times, strict=True)]
        b, e, ov = statistics.median(b_times), statistics.median(e_times), statistics.median(ratios)
        adapter = "Gymnasium" if n == 1 else "PettingZoo"
        print(f"{name:<22} {adapter:<12} {1e3 * b:>13.3f} {1e3 * e:>12.3f} {100 * ov:>8.1f}%")
        results[name] = (ov, b, e)
    print("(timings on a shared machine; the ratio is what to compare)")
    head, farrell, team = (results[name] for name, _, _ in cases)
    print(
        f"RESULT env_overhead={head[0]:.3f} env_steps_per_s={1.0 / head[2]:.0f} "
        f"env_overhead_farrell={farrell[0]:.3f} pz_overhead={team[0]:.3f} "
        f"pz_bare_ms={1e3 * team[1]:.3f}"
    )


if __name__ == "__main__":
    main()
