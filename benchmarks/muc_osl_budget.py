"""Time budget of ``odorloc reproduce muc-osl``, and what replaying a recorded flow saves.

1. A stratified sample of the reproduction's own work items runs in this process, one after
   another: of each method in each rate sweep, every ``--stride``-th of its cells (one episode
   each, the episode index spread over the default count; a sweep's CPU time per item is the
   methods' means weighted by their cells) and every ``--stride-groups``-th world group of
   the filament sweeps (the recording of one flow and its replay to every algorithm there).
   CPU time (``time.process_time``) is what an idle core spends on them; the mean per item times the
   number of items gives the projected wall time of the default run (both worlds) and of the
   paper's 200 episodes in the rate world, on 2 cores. Wall times of the same items are printed
   beside it: on a loaded machine they are longer than the CPU times.
2. The default filament world's episode 0 for the four algorithms, live (every episode
   simulates the filament plume itself) and as one recorded flow replayed four times; the rows
   must agree in what the searchers saw (the episodes' outcome: ``same_rows``), and the ratio
   is the saving.

Targets (the issue): default run of both worlds <= 30 min, the paper's 200 episodes in the
rate world <= 90 min, on 2 cores. The study has grown since that target was set (the printed
readings of PUGL and MUC-OSL without eq. 16 beside the paper's four methods at every point);
``paper_rate_min`` projects the paper's four methods alone
(``--methods muc-osl,col-inf,col-pf,adap-pp``), ``full_rate_min`` every method. The last line
is machine-readable::

    RESULT default_min=<x> full_rate_min=<y> paper_rate_min=<z> rate_task_cpu_s=<a>
    filament_group_cpu_s=<b> replay_speedup=<c> same_rows=<yes|no|n/a>

Run: ``python benchmarks/muc_osl_budget.py [--stride 6] [--stride-groups 3]``.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numpy as np

from odorloc.engine.episode import run_episode
from odorloc.experiments.reproduction import Reproduction
from odorloc.experiments.runner import cell_scenario, run_replay_group, run_task
from odorloc.experiments.sweep import expand_cells, load_sweep, make_task
from odorloc.papers.muc_osl.reproduction import FILAMENT, FILAMENT_EPISODES, MucOslReproduction
from odorloc.papers.muc_osl.sweeps import ALGORITHMS, DEFAULT

CORES = 2
FULL = 200


def _clock() -> tuple[float, float]:
    return time.process_time(), time.perf_counter()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stride", type=int, default=6, help="sample every k-th rate cell")
    ap.add_argument("--stride-groups", type=int, default=3, help="every k-th filament world")
    ap.add_argument("--seed", type=int, default=2024)
    args = ap.parse_args(argv)

    rep = MucOslReproduction()
    specs = {k: load_sweep(v) for k, v in rep.sweeps(None, args.seed).items()}
    n_default = {k: s.episodes for k, s in specs.items()}

    print("CPU s per work item, sampled from the reproduction's sweeps (shared machine)")
    print(
        f"{'sweep':<20} {'items':>6} {'sampled':>8} {'CPU s':>7} {'wall s':>7} {'default min':>12}"
    )
    cpu_mean: dict[str, float] = {}
    items: dict[str, int] = {}
    # CPU s per episode of every cell of a method, summed over its cells (rate sweeps)
    by_method: dict[str, dict[str, float]] = defaultdict(dict)
    for name, spec in specs.items():
        cells = expand_cells(spec)
        if spec.replay:
            worlds = sorted({c.world_key for c in cells}, key=[c.world_key for c in cells].index)
            by_world = defaultdict(list)
            for c in cells:
                by_world[c.world_key].append(c)
            chosen = worlds[:: args.stride_groups]
            n_items = len(worlds) * spec.episodes
            cpu, wall = [], []
            for i, w in enumerate(chosen):
                ep = i % spec.episodes
                tasks = [make_task(spec, c, ep) for c in by_world[w]]
                c0, w0 = _clock()
                rows = run_replay_group(tasks)
                c1, w1 = _clock()
                assert all(r["status"] == "ok" for r in rows), [r.get("error") for r in rows]
                cpu.append(c1 - c0)
                wall.append(w1 - w0)
            sampled, cpu_mean[name] = len(cpu), float(np.mean(cpu))
        else:
            # stratified by method: a method's episodes cost what its simulated time costs (a
            # printed reading runs to the limit), and a plain stride through cells ordered
            # world by world would sample the same method in every world
            groups = defaultdict(list)
            for c in cells:
                groups[Reproduction.method_of(c)].append(c)
            n_items = len(cells) * spec.episodes
            wall, sampled = [], 0
            for g, (key, members) in enumerate(groups.items()):
                # each method starts at another offset, so the methods see different worlds
                chosen = members[g % min(args.stride, len(members)) :: args.stride]
                spent = []
                for i, c in enumerate(chosen):
                    task = make_task(spec, c, (i * 3 + g) % spec.episodes)
                    c0, w0 = _clock()
                    row = run_task(task)
                    c1, w1 = _clock()
                    assert row["status"] == "ok", row.get("error")
                    spent.append(c1 - c0)
                    wall.append(w1 - w0)
                sampled += len(spent)
                by_method[name][key] = float(np.mean(spent)) * len(members)
            # the stratified mean: each method's mean weighted by its share of the cells
            cpu_mean[name] = sum(by_method[name].values()) / len(cells)
        items[name] = n_items
        proj = cpu_mean[name] * n_items / CORES / 60
        print(
            f"{name:<20} {n_items:>6} {sampled:>8} {cpu_mean[name]:7.2f} "
            f"{float(np.mean(wall)):7.2f} {proj:12.1f}"
        )
    default_min = sum(cpu_mean[k] * items[k] for k in specs) / CORES / 60
    rate = [k for k in specs if k.startswith("rate")]
    full_rate_min = sum(cpu_mean[k] * items[k] / n_default[k] * FULL for k in rate) / CORES / 60
    paper_rate_min = (
        sum(v for k in rate for m, v in by_method[k].items() if m in ALGORITHMS) * FULL / CORES / 60
    )
    print(
        f"projected on {CORES} idle cores: default run {default_min:.1f} min (target 30); "
        f"rate world at {FULL} episodes, every method {full_rate_min:.1f} min, the paper's four "
        f"(--methods {','.join(ALGORITHMS)}) {paper_rate_min:.1f} min (target 90)"
    )

    # ---- live against replayed filament episodes
    spec = specs["filament"]
    tasks = [
        make_task(spec, c, 0)
        for c in expand_cells(spec)
        if c.world_key == FILAMENT + DEFAULT.world_suffix()
    ]
    c0, _ = _clock()
    live = []
    for t in tasks:
        sc = cell_scenario(t.cell)
        live.append(run_episode(sc, t.world_seed, t.agent_seed, record=False).metrics)
    c1, _ = _clock()
    replayed = run_replay_group(tasks)
    c2, _ = _clock()
    same = [
        (a["success"], a["steps"]) == (b["success"], b["steps"])
        for a, b in zip(live, replayed, strict=True)
    ]
    speedup = (c1 - c0) / (c2 - c1)
    print(
        f"\nfilament world, default setting, episode 0 of {len(tasks)} algorithms: live "
        f"{c1 - c0:.1f} CPU s, one recording + replays {c2 - c1:.1f} CPU s ({speedup:.2f}x); "
        f"same outcome in {sum(same)}/{len(same)}"
    )
    print(
        f"(filament default episodes per point: {FILAMENT_EPISODES}; CPU times hold on an idle "
        "machine, wall times only there)"
    )
    print(
        f"RESULT default_min={default_min:.1f} full_rate_min={full_rate_min:.1f} "
        f"paper_rate_min={paper_rate_min:.1f} "
        f"rate_task_cpu_s={cpu_mean['rate']:.2f} "
        f"filament_group_cpu_s={cpu_mean['filament']:.2f} replay_speedup={speedup:.2f} "
        f"same_rows={'n/a' if not same else 'yes' if all(same) else 'no'}"
    )


if __name__ == "__main__":
    main()
