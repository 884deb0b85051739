"""The regression set: every built-in scenario x the simple searchers x two seeds.

A refactor that must not change behaviour is checked by running this before and after and
comparing the two files::

    .venv/bin/python tools/regression_set.py run --out before.json
    # ... change the code ...
    .venv/bin/python tools/regression_set.py run --out after.json
    .venv/bin/python tools/regression_set.py compare before.json after.json

Each episode is summarised by its metrics row (wall-clock columns left out) and a SHA-256 of its
recorded trajectory, readings and declarations, so that two runs agree only when the episodes are
the same to the bit. ``--only SCENARIO`` (repeatable) limits the set; ``--time-limit S`` shortens
long scenarios (the same limit must be given to both runs); ``--wide`` adds the paper methods
and baselines wherever a scenario accepts them.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from typing import Any

import numpy as np

#: Searchers tried on every scenario besides its own; those a scenario refuses are skipped.
SIMPLE = ("zigzag", "random-walk", "surge-cast", "spiral", "chemotaxis", "passive", "infotaxis")
#: With ``--wide``: the paper methods and baselines too (where a scenario accepts them).
WIDE = (
    "particle-infotaxis",
    "entrotaxis",
    "space-aware-infotaxis",
    "greedy",
    "mean-distance",
    "gradient-bionic",
    "anemotaxis",
    "fluxotaxis",
    "surge-spiral",
    "rectangular-wave",
    "ds-mapping",
    "ds-rectangular-wave",
    "col-inf",
    "col-pf",
    "adap-pp",
)
ROOTS = (1, 2)
_SKIP_COLUMNS = {
    "wall_time",
    "wall_per_step_ms",
    "searcher_fraction",
    "world_fraction",
    "compute_ms",
}


def _digest(arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for key in sorted(arrays):
        if key not in ("t", "positions", "gas", "detection", "wind", "declared"):
            continue
        a = np.ascontiguousarray(np.asarray(arrays[key]))
        if a.dtype == object:
            continue
        h.update(key.encode())
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def _clean(v: Any) -> Any:
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    if isinstance(v, np.generic):
        return _clean(v.item())
    return v


def run(only: list[str], time_limit: float | None, wide: bool = False) -> dict[str, Any]:
    from odorloc.core.errors import ConfigError
    from odorloc.core.seeds import episode_seeds
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario
    from odorloc.scenarios.build import build
    from odorloc.scenarios.catalog import builtin_names

    out: dict[str, Any] = {}
    for name in builtin_names():
        if only and name not in only:
            continue
        base = cell_scenario({"scenario": name})
        tried = (base.searcher.type, *SIMPLE, *(WIDE if wide else ()))
        for searcher in dict.fromkeys(tried):
            cell: dict[str, Any] = {"scenario": name, "searcher": searcher}
            if time_limit is not None:
                cell["overrides"] = {"limits.time": min(time_limit, base.limits.time)}
            try:
                sc = cell_scenario(cell)
                build(sc)
            except (ConfigError, ValueError) as exc:
                print(f"skip {name} x {searcher}: {exc}", file=sys.stderr)
                continue
            for root in ROOTS:
                ws, ag = episode_seeds(root, name, 0)
                t0 = time.perf_counter()
                res = run_episode(sc, ws, ag, record=True)
                row = {k: _clean(v) for k, v in sorted(res.metrics.items())}
                row = {k: v for k, v in row.items() if k not in _SKIP_COLUMNS}
                agents = {
                    str(a): {k: _clean(v) for k, v in sorted(vals.items())}
                    for a, vals in sorted(res.metrics.agents.items())
                }
                arrays = res.recording.to_arrays() if res.recording is not None else {}
                key = f"{name} | {searcher} | root={root}"
                out[key] = {"metrics": row, "agents": agents, "digest": _digest(arrays)}
                print(f"{key}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return out


def _columns(entry: dict[str, Any]) -> dict[str, Any]:
    """An episode's metrics with its per-agent values as ``agent[<id>].<key>`` entries; a file
    written before per-agent values were kept apart (``key_<agent>`` columns) is read through
    the results store's reader of such rows."""
    if "agents" in entry:
        metrics, agents = dict(entry["metrics"]), entry["agents"]
    else:
        from odorloc.experiments.store import split_legacy_extra

        metrics, agents = split_legacy_extra(entry["metrics"])
    for a, vals in agents.items():
        for k, v in vals.items():
            metrics[f"agent[{a}].{k}"] = v
    return metrics


def compare(a: dict[str, Any], b: dict[str, Any]) -> int:
    same = changed = 0
    for key in sorted(set(a) | set(b)):
        if key not in a or key not in b:
            print(f"only in {'first' if key in a else 'second'}: {key}")
            changed += 1
            continue
        ra, rb = a[key], b[key]
        ma, mb = _columns(ra), _columns(rb)
        diffs = [
            f"{k}: {ma.get(k)!r} -> {mb.get(k)!r}"
            for k in sorted(set(ma) | set(mb))
            if k not in _SKIP_COLUMNS and ma.get(k) != mb.get(k)
        ]
        if ra["digest"] != rb["digest"]:
            diffs.append("recording differs")
        if diffs:
            changed += 1
            print(f"CHANGED {key}: " + "; ".join(diffs[:6]))
        else:
            same += 1
    print(f"{same} identical, {changed} changed")
    return 0 if changed == 0 else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", required=True)
    r.add_argument("--only", action="append", default=[])
    r.add_argument("--time-limit", type=float, default=None)
    r.add_argument("--wide", action="store_true", help="also the paper methods and baselines")
    c = sub.add_parser("compare")
    c.add_argument("first")
    c.add_argument("second")
    args = ap.parse_args()
    if args.cmd == "run":
        data = run(args.only, args.time_limit, args.wide)
        with open(args.out, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=1, sort_keys=True)
        print(f"{len(data)} episodes written to {args.out}")
        return 0
    with open(args.first, encoding="utf-8") as fa, open(args.second, encoding="utf-8") as fb:
        return compare(json.load(fa), json.load(fb))


if __name__ == "__main__":
    sys.exit(main())
