"""Environment step overhead: the Gymnasium / PettingZoo adapters against the bare episode.

Side by side in one run, on the same seeds and the same action sequence: (a) the bare stepping
episode, ``Episode.step(Action([Command.velocity(v)]))``; (b) ``SearchEnv.step(action)`` (the
policy encoding: decoding the action, encoding the observation, the reward, the step info).
Reset and warm-up are outside the timed loops. The two run in lockstep, one step of (a) then
one of (b) (alternating which goes first), so that load on a shared machine hits both alike;
medians over rounds. In the team case the environment's agents also broadcast their readings
(the radio and its accounting are part of what it costs). The overhead is ``(b - a) / a``.

Batched environments: agent-steps per second of :class:`~odorloc.envs.vector.LatticeVectorEnv`
on ``lattice-isotropic-2d`` at B = 1, 64, 1 024 and 4 096 sub-environments, beside Gymnasium's
``SyncVectorEnv`` (B = 64) and ``AsyncVectorEnv`` (B = 2, one process per sub-environment) of
the single environment ``SearchEnv`` with discrete lattice moves, uniform random moves, in
alternating rounds (best of each). The batched env runs on one thread (``threads=1``, like
for like with the synchronous vector); ``lattice_steps_per_s_4096_threads`` is B = 4 096 on
every thread numba was given (``threads=None``).

The 3-D encounter-rate world (:class:`~odorloc.envs.vector_encounter.EncounterVectorEnv` on
``muc-osl-3d``, three UAVs, random axis moves or staying): agent-steps per second of the batched
team at every B, and of one UAV alone at B = 4 096, beside the single environments (B = 64):
PettingZoo's ``ParallelSearchEnv`` stepped one after another for the team (Gymnasium has no
vector of PettingZoo environments), Gymnasium's ``SyncVectorEnv`` of ``SearchEnv`` for one UAV;
keys ``encounter_steps_per_s_<B>``, ``encounter_solo_steps_per_s_4096``,
``encounter_loop_steps_per_s``, ``encounter_sync_steps_per_s``, ``encounter_batched_vs_loop``
and ``encounter_solo_vs_sync`` (one thread against one thread).

The last line is ``RESULT env_overhead=<x> env_steps_per_s=<y> env_overhead_farrell=<z>
pz_overhead=<w> pz_bare_ms=<v> pz_adapter_overhead=<u> lattice_steps_per_s_1=...
lattice_steps_per_s_64=... lattice_steps_per_s_1024=... lattice_steps_per_s_4096=...
lattice_steps_per_s_4096_threads=... sync_steps_per_s=... async_steps_per_s=...
batched_vs_sync=<batched at 4096 / sync>`` (the first two of ``indoor-ventilated``, the
Gymnasium headline; the PettingZoo overhead and bare step time of the three-UAV ``muc-osl-3d``;
``pz_adapter_overhead`` the same with a bare team that broadcasts the same readings, i.e. the
adapter alone, without the radio's delivery and energy accounting). ``--no-adapters`` /
``--no-batched`` leave one part out. Without the ``rl`` extra it stops with a one-line message.

    .venv/bin/python benchmarks/env_speed.py [--rounds 5] [--quick]
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

from odorloc.core.jit import threads as jit_threads
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


def lockstep(
    name: str, acts: np.ndarray, root: int, n: int, radio: bool = False
) -> tuple[float, float, int]:
    """Seconds of bare episode steps and of environment steps, taken alternately step by step
    on the same seeds and actions (so load on a shared machine hits both alike). With
    ``radio`` the bare step also broadcasts what the environment's agents broadcast (built
    and delivered inside the timed step)."""
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

    io = e.unwrapped.core.io if n == 1 else e.core.io

    def bare_step(v: np.ndarray) -> float:
        t0 = clock()
        msgs = io.broadcasts(ep.observations) if radio else {}
        cmds = [Command.velocity(v.astype(float) * vmax[k]) for k in range(n)]
        ep.step(Action(cmds, messages=msgs))
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


# ---------------------------------------------------------------------- batched lattice env
BATCHES = (1, 64, 1024, 4096)
LATTICE = "lattice-isotropic-2d"
ENCOUNTER = "muc-osl-3d"
SYNC_B = 64  # Gymnasium's SyncVectorEnv of single environments
ASYNC_B = 2  # AsyncVectorEnv: one process per sub-environment, as many as the machine has cores


def _single(scenario: str) -> Any:
    from odorloc.envs.gym_env import SearchEnv

    return SearchEnv(scenario, action={"kind": "discrete", "declare": "none"})


def batched_rate(b: int, steps: int, seed: int, threads: int | None = 1) -> float:
    """Agent-steps per second of :class:`~odorloc.envs.vector.LatticeVectorEnv` with ``b``
    sub-environments on ``threads`` threads (``None``: all; uniform random moves; reset and one
    warm-up step untimed)."""
    from odorloc.envs.vector import LatticeVectorEnv

    env = LatticeVectorEnv(LATTICE, num_envs=b, threads=threads)
    env.reset(seed=seed)
    acts = np.random.default_rng(seed).integers(0, 4, size=(steps + 1, b))
    env.step(acts[0])
    t0 = time.perf_counter()
    for a in acts[1:]:
        env.step(a)
    return b * steps / (time.perf_counter() - t0)


def gym_vector_rate(kind: str, b: int, steps: int, seed: int) -> float:
    """Agent-steps per second of Gymnasium's ``SyncVectorEnv`` / ``AsyncVectorEnv`` of ``b``
    single environments (``SearchEnv``, discrete lattice moves) on the same scenario."""
    import gymnasium as gym

    from odorloc.scenarios import get_scenario

    sc = get_scenario(LATTICE)
    fns = [lambda: _single(sc) for _ in range(b)]
    env = gym.vector.SyncVectorEnv(fns) if kind == "sync" else gym.vector.AsyncVectorEnv(fns)
    try:
        env.reset(seed=seed)
        acts = np.random.default_rng(seed).integers(0, 4, size=(steps + 1, b))
        env.step(acts[0])
        t0 = time.perf_counter()
        for a in acts[1:]:
            env.step(a)
        return b * steps / (time.perf_counter() - t0)
    finally:
        env.close()


def _encounter_scenario(team: bool) -> Any:
    """``muc-osl-3d`` (three UAVs) or the same world with its first UAV alone."""
    sc = get_scenario(ENCOUNTER)
    return sc if team else sc.with_overrides({"agents.starts": [sc.agents.starts[0]]})


def encounter_rate(b: int, steps: int, seed: int, team: bool) -> float:
    """Agent-steps per second of :class:`~odorloc.envs.vector_encounter.EncounterVectorEnv`
    (``b`` sub-environments, one thread, uniform random axis moves or staying)."""
    from odorloc.envs.vector_encounter import EncounterVectorEnv

    env = EncounterVectorEnv(_encounter_scenario(team), num_envs=b)
    env.reset(seed=seed)
    n = env.n_agents
    shape = (steps + 1, b, n) if n > 1 else (steps + 1, b)
    acts = np.random.default_rng(seed).integers(0, 7, size=shape)
    env.step(acts[0])
    t0 = time.perf_counter()
    for a in acts[1:]:
        env.step(a)
    return b * n * steps / (time.perf_counter() - t0)


def encounter_single_rate(b: int, steps: int, seed: int, team: bool) -> float:
    """Agent-steps per second of the single environments on the same world: Gymnasium's
    ``SyncVectorEnv`` of ``SearchEnv`` (one UAV), or ``b`` PettingZoo ``ParallelSearchEnv``
    stepped one after another (the team: Gymnasium has no vector of PettingZoo
    environments)."""
    import gymnasium as gym

    from odorloc.envs.gym_env import SearchEnv
    from odorloc.envs.parallel import ParallelSearchEnv

    sc = _encounter_scenario(team)
    kw = {"action": {"kind": "discrete", "declare": "none"}}
    rng = np.random.default_rng(seed)
    if not team:
        env = gym.vector.SyncVectorEnv([lambda: SearchEnv(sc, **kw) for _ in range(b)])
        env.reset(seed=seed)
        acts = rng.integers(0, 7, size=(steps + 1, b))
        env.step(acts[0])
        t0 = time.perf_counter()
        for a in acts[1:]:
            env.step(a)
        dt = time.perf_counter() - t0
        env.close()
        return b * steps / dt
    envs = [ParallelSearchEnv(sc, **kw) for _ in range(b)]
    for i, e in enumerate(envs):
        e.reset(seed=seed, options={"episode": i})
    names = envs[0].possible_agents
    acts = rng.integers(0, 7, size=(steps, b, len(names)))
    t0 = time.perf_counter()
    for a in acts:
        for i, e in enumerate(envs):
            if not e.agents:
                e.reset()
            e.step({x: int(a[i, k]) for k, x in enumerate(names)})
    return b * len(names) * steps / (time.perf_counter() - t0)


def encounter(rounds: int, quick: bool) -> dict[str, float]:
    """The 3-D encounter-rate world: agent-steps per second of the batched team (every B) and
    one UAV (the largest B) beside the single environments, best of ``rounds`` rounds."""
    work = 5_000 if quick else 400_000
    single_steps = 3 if quick else 40
    best: dict[str, float] = {}
    for r in range(rounds):
        for b in BATCHES:
            steps = max(5, min(2000, work // (3 * b)))
            k = f"encounter_steps_per_s_{b}"
            best[k] = max(best.get(k, 0.0), encounter_rate(b, steps, r, team=True))
        top = BATCHES[-1]
        k = f"encounter_solo_steps_per_s_{top}"
        rate = encounter_rate(top, max(5, min(2000, work // top)), r, team=False)
        best[k] = max(best.get(k, 0.0), rate)
        rate = encounter_single_rate(SYNC_B, single_steps, r, team=True)
        best["encounter_loop_steps_per_s"] = max(best.get("encounter_loop_steps_per_s", 0), rate)
        rate = encounter_single_rate(SYNC_B, single_steps, r, team=False)
        best["encounter_sync_steps_per_s"] = max(best.get("encounter_sync_steps_per_s", 0), rate)
    top = BATCHES[-1]
    best["encounter_batched_vs_loop"] = (
        best[f"encounter_steps_per_s_{top}"] / best["encounter_loop_steps_per_s"]
    )
    best["encounter_solo_vs_sync"] = (
        best[f"encounter_solo_steps_per_s_{top}"] / best["encounter_sync_steps_per_s"]
    )
    print(
        f"\nAgent-steps per second on {ENCOUNTER} (3 UAVs; 'one UAV': its first UAV alone; "
        f"uniform random axis moves or staying; best of {rounds} rounds)"
    )
    print(f"{'environment':<44} {'B':>6} {'agent-steps/s':>14}")
    for b in BATCHES:
        print(f"{'EncounterVectorEnv, team (odorloc)':<44} {b:>6} "
              f"{best[f'encounter_steps_per_s_{b}']:>14,.0f}")  # fmt: skip
    print(f"{'EncounterVectorEnv, one UAV (odorloc)':<44} {top:>6} "
          f"{best[f'encounter_solo_steps_per_s_{top}']:>14,.0f}")  # fmt: skip
    print(f"{'ParallelSearchEnv, team, one after another':<44} {SYNC_B:>6} "
          f"{best['encounter_loop_steps_per_s']:>14,.0f}")  # fmt: skip
    print(f"{'SyncVectorEnv of SearchEnv, one UAV':<44} {SYNC_B:>6} "
          f"{best['encounter_sync_steps_per_s']:>14,.0f}")  # fmt: skip
    return best


def batched(rounds: int, quick: bool) -> dict[str, float]:
    """Agent-steps per second of every case, best of ``rounds`` alternating rounds."""
    work = 5_000 if quick else 400_000  # agent-steps per timed run of the batched env
    cases: list[tuple[str, int, int]] = [
        ("batched", b, max(5, min(2000, work // b))) for b in BATCHES
    ]
    top = BATCHES[-1]
    cases.append(("threads", top, max(5, min(2000, work // top))))
    cases.append(("sync", SYNC_B, 3 if quick else 30))
    cases.append(("async", ASYNC_B, 20 if quick else 300))
    best: dict[tuple[str, int], float] = {}
    for r in range(rounds):
        for kind, b, steps in cases:
            if kind == "batched":
                rate = batched_rate(b, steps, r)
            elif kind == "threads":
                rate = batched_rate(b, steps, r, threads=None)
            else:
                rate = gym_vector_rate(kind, b, steps, r)
            best[(kind, b)] = max(best.get((kind, b), 0.0), rate)
    print(f"\nAgent-steps per second on {LATTICE} (uniform random moves; best of {rounds} rounds)")
    print(f"{'environment':<34} {'B':>6} {'agent-steps/s':>14}")
    names = {
        "batched": "LatticeVectorEnv (odorloc)",
        "threads": f"LatticeVectorEnv, {jit_threads()} threads",
        "sync": "SyncVectorEnv of SearchEnv",
        "async": "AsyncVectorEnv of SearchEnv",
    }
    for (kind, b), rate in best.items():
        print(f"{names[kind]:<34} {b:>6} {rate:>14,.0f}")
    out = {f"lattice_steps_per_s_{b}": best[("batched", b)] for b in BATCHES}
    out[f"lattice_steps_per_s_{top}_threads"] = best[("threads", top)]
    out["sync_steps_per_s"] = best[("sync", SYNC_B)]
    out["async_steps_per_s"] = best[("async", ASYNC_B)]
    out["batched_vs_sync"] = out[f"lattice_steps_per_s_{BATCHES[-1]}"] / out["sync_steps_per_s"]
    print(
        f"(the synchronous vector runs B = {SYNC_B}, the asynchronous one B = {ASYNC_B}: one "
        "process per sub-environment; their throughput per agent does not grow with B; "
        "batched_vs_sync compares one thread with one thread)"
    )
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer steps in the batched cases")
    ap.add_argument("--no-adapters", action="store_true", help="only the batched cases")
    ap.add_argument("--no-batched", action="store_true", help="only the adapter overheads")
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
    keys: list[str] = []
    if not args.no_adapters:
        keys.append(adapters(args.rounds))
    if not args.no_batched:
        vec = batched(max(1, min(args.rounds, 3)), args.quick)
        vec.update(encounter(max(1, min(args.rounds, 3)), args.quick))
        keys.append(
            " ".join(
                f"{k}={v:.2f}" if k.endswith(("_vs_sync", "_vs_loop")) else f"{k}={v:.0f}"
                for k, v in vec.items()
            )
        )
    print("RESULT " + " ".join(keys))


def adapters(rounds: int) -> str:
    """The adapters' overhead over the bare step (module docstring); the RESULT keys."""
    cases = [
        ("indoor-ventilated", 2, 1, False),  # the headline: filament plume, one robot
        ("two-sources-farrell", 2, 1, False),
        ("muc-osl-3d", 3, 3, False),  # PettingZoo, three UAVs exchanging messages
        ("muc-osl-3d", 3, 3, True),  # the same, the bare team broadcasting the same messages
    ]
    print(f"{STEPS} control steps per run, {rounds} rounds, medians")
    print(
        f"{'scenario':<22} {'adapter':<12} {'bare ms/step':>13} {'env ms/step':>12} {'overhead':>9}"
    )
    results: dict[tuple[str, bool], tuple[float, float, float]] = {}
    for name, dim, n, radio in cases:
        acts = actions(STEPS, dim, 1)
        b_times, e_times = [], []
        for r in range(rounds + 1):
            tb, te, steps = lockstep(name, acts, r, n, radio)
            if r > 0:  # the first round warms caches
                b_times.append(tb / steps)
                e_times.append(te / steps)
        ratios = [e / b - 1.0 for e, b in zip(e_times, b_times, strict=True)]
        b, e, ov = statistics.median(b_times), statistics.median(e_times), statistics.median(ratios)
        adapter = "Gymnasium" if n == 1 else "PettingZoo" + (" *" if radio else "")
        print(f"{name:<22} {adapter:<12} {1e3 * b:>13.3f} {1e3 * e:>12.3f} {100 * ov:>8.1f}%")
        results[(name, radio)] = (ov, b, e)
    print(
        "(* the bare team broadcasts the same messages: the adapter alone;\n"
        " timings on a shared machine; the ratio is what to compare)"
    )
    head, farrell, team, adapter_only = (results[(c[0], c[3])] for c in cases)
    return (
        f"env_overhead={head[0]:.3f} env_steps_per_s={1.0 / head[2]:.0f} "
        f"env_overhead_farrell={farrell[0]:.3f} pz_overhead={team[0]:.3f} "
        f"pz_bare_ms={1e3 * team[1]:.3f} pz_adapter_overhead={adapter_only[0]:.3f}"
    )


if __name__ == "__main__":
    main()
