"""Wall-time budget of the benchmark suite (`odorloc bench`): the quick tier's wall time per
task, measured, and the standard tier's estimated from it.

Runs the tier into a fresh folder (no resumed episodes) and prints, per task, the methods,
episodes, wall time and episode CPU time; the standard tier's wall time is estimated per task
as the measured wall time times the ratio of episode counts (and of episode lengths where the
tier shortens them: an upper bound). Budgets on 2 cores: quick <= 300 s, standard <= 3600 s.

    python benchmarks/bench_budget.py                 # the quick tier, 2 workers
    python benchmarks/bench_budget.py --tier standard # measure the standard tier itself
    python benchmarks/bench_budget.py --quick         # one task, 2 episodes (a smoke test)

Last line: ``RESULT tier=... wall_s=... budget_s=... standard_estimate_s=... ...``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import Any

from odorloc.experiments.bench import load_suite, run_bench


def scale(task: Any, tier: str, target: str) -> float:
    """How much longer the ``target`` tier's run of ``task`` is than the ``tier``'s."""
    ratio = task.episodes[target] / task.episodes[tier]
    limit = task.overrides(tier).get("limits.time")
    if limit is not None and target != tier:
        from odorloc.scenarios import get_scenario

        full = task.overrides(target).get("limits.time", get_scenario(task.scenario).limits.time)
        ratio *= float(full) / float(limit)
    return ratio


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tier", default="quick", choices=("quick", "standard"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one task, 2 episodes, 1 worker")
    args = ap.parse_args(argv)
    suite = load_suite()
    kw: dict[str, Any] = {"tier": args.tier, "workers": args.workers}
    if args.quick:
        kw.update(tasks=["otto-19x19"], methods=["infotaxis"], episodes=2, workers=1)
    with tempfile.TemporaryDirectory() as tmp:
        doc = run_bench(Path(tmp) / "bench", progress=False, html=False, **kw)
    budget = suite.tiers[args.tier].budget_s  # type: ignore[index]
    print(f"odorloc bench, suite {doc['suite']}, tier {doc['tier']}, {doc['machine']}")
    print(
        f"{'task':<28} {'methods':>7} {'episodes':>8} {'wall s':>8} {'CPU s':>8} "
        f"{'standard est. s':>15}"
    )
    est = 0.0
    for t in doc["tasks"]:
        task = suite.task(t["name"])
        n = len([r for r in doc["rows"] if r["task"] == t["name"]])
        s = t["wall_time_s"] * (1.0 if args.quick else scale(task, args.tier, "standard"))
        est += s
        print(
            f"{t['name']:<28} {n:>7} {t['episodes']:>8} {t['wall_time_s']:>8.1f} "
            f"{t['cpu_time_s']:>8.1f} {s:>15.0f}"
        )
    wall = float(doc["wall_time_s"])
    print(
        f"{'total':<28} {'':>7} {'':>8} {wall:>8.1f} "
        f"{sum(t['cpu_time_s'] for t in doc['tasks']):>8.1f} {est:>15.0f}"
    )
    if args.quick:
        print("smoke run (one task, two episodes): no budget verdict")
    else:
        print(
            f"budget {budget:.0f} s: {'met' if wall <= budget else 'NOT met'} on this machine "
            "(timings are the machine's: measure on an idle machine)"
        )
    result = {
        "tier": doc["tier"],
        "wall_s": round(wall, 1),
        "budget_s": budget,
        "standard_estimate_s": round(est),
        "standard_budget_s": suite.tiers["standard"].budget_s,
        "tasks": len(doc["tasks"]),
        "smoke": int(args.quick),
        "rows": len(doc["rows"]),
    }
    print("RESULT " + " ".join(f"{k}={v}" for k, v in result.items()))
    return result


if __name__ == "__main__":
    main()
