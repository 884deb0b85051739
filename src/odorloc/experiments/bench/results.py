"""The board: rows per task and method with intervals, ranks, the results JSON and its diff.

Results JSON (schema ``odorloc-bench/1``)
-----------------------------------------
::

    {
      "schema": "odorloc-bench/1",
      "suite": "2027.1", "tier": "quick", "seed": 2027001,
      "odorloc_version": "0.2.0", "machine": "Linux ... 2 CPUs, Python 3.11",
      "started": "2026-12-05T17:00:00Z", "wall_time_s": 250.3,
      "backend": "local", "workers": 2,
      "tasks": [{"name", "scenario", "summary", "rule", "rank_by", "metrics", "episodes",
                 "wall_time_s", "skipped": {method: reason},
                 "seeds": [[world_seed, agent_seed], ...]    # one pair per episode index
                 "reference": {...} | null}],
      "rows": [{"task", "method", "searcher", "source", "episodes", "errors",
                "success", "success_lo", "success_hi",          # fraction, Wilson 95 %
                "search_time", "search_time_lo", "search_time_hi",   # s, successes only
                "path_ratio", ...,          # path length / start-to-source distance, successes
                "loc_error", ...,           # m, episodes with a declaration
                "energy", "bytes", "emd", "rate_error", ...   # where the task has them
                "cpu_ms_per_decision",      # ms of CPU per decision (searcher share; median)
                "failures": {cause: count}, # unsuccessful episodes by how they ended
                "rank", "reference": {...} | absent}]
    }

Every mean (the CPU time per decision: a median) carries its percentile-bootstrap 95 %
interval (``_lo``, ``_hi``; NaN as ``null`` when fewer than two values), computed with a
generator seeded from the suite's seed, so the same rows give the same file.

Ranks
-----
Within a task, method A is *better* than B when A's success interval lies entirely above B's
or, for tasks ranked by search time, when their success intervals overlap and A's search-time
interval lies entirely below B's. A method's rank is one plus the number of methods better
than it: methods whose intervals overlap share a rank. The overall board averages each
method's normalised rank ``(rank - 1) / (methods of the task - 1)`` over the tasks it ran.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.experiments.cells import stat_interval
from odorloc.experiments.stats import bootstrap_ci

__all__ = [
    "SCHEMA",
    "compare_results",
    "load_results",
    "overall_board",
    "rank_rows",
    "reference_check",
    "task_rows",
]

SCHEMA = "odorloc-bench/1"

#: Mean metrics of a row: name -> (row column, flag column or None, better direction).
MEANS: dict[str, tuple[str, str | None, int]] = {
    "search_time": ("search_time", "success", -1),
    "path_ratio": ("path_ratio", "success", -1),
    "loc_error": ("loc_error", "declared", -1),
    "energy": ("energy", None, -1),
    "bytes": ("bytes", None, -1),
    "emd": ("emd", None, -1),
    "rate_error": ("rate_error", "declared", -1),
    "cpu_ms_per_decision": ("cpu_ms_per_decision", None, -1),
}

#: Metrics ``bench compare`` judges (CPU time is machine-dependent: shown, never judged).
JUDGED = (
    "success",
    "search_time",
    "path_ratio",
    "loc_error",
    "energy",
    "bytes",
    "emd",
    "rate_error",
)


def _episode_columns(df: Any) -> Any:
    """Derived per-episode columns: path ratio, CPU per decision, rate error factor."""
    df = df.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        df["path_ratio"] = df["path_length"] / df["start_distance"].where(df["start_distance"] > 0)
        frac = df.get("searcher_fraction", np.nan)
        cpu = df.get("cpu_time", np.nan)
        df["cpu_ms_per_decision"] = 1e3 * cpu * frac / df["steps"].where(df["steps"] > 0)
        if "est_rate" in df and "true_rate" in df:
            ratio = df["est_rate"] / df["true_rate"]
            df["rate_error"] = np.exp(np.abs(np.log(ratio.where(ratio > 0))))
        else:
            df["rate_error"] = np.nan
    if "declared" not in df:
        df["declared"] = df["loc_error"].notna()
    return df


def _num(x: Any) -> float | None:
    """A JSON number (``None`` for NaN)."""
    x = float(x)
    return x if math.isfinite(x) else None


def task_rows(task: Any, df: Any, methods: Sequence[Any], seed: int) -> list[dict[str, Any]]:
    """The board rows of one task from its stored episodes (``df``: the task store's frame)."""
    rows: list[dict[str, Any]] = []
    if len(df) == 0:
        return rows
    df = _episode_columns(df)
    for mi, m in enumerate(methods):
        sub = df[df["searcher"] == m.name]
        if len(sub) == 0:
            continue
        ok = sub[sub["status"] == "ok"]
        row: dict[str, Any] = {
            "task": task.name,
            "method": m.name,
            "searcher": m.searcher,
            "source": m.source,
            "episodes": len(sub),
            "errors": int((sub["status"] != "ok").sum()),
        }
        k = int(sub["success"].fillna(0).astype(bool).sum())
        v, lo, hi, _ = stat_interval(sub, ("rate", "success"), seed)
        row.update(successes=k, success=v / 100, success_lo=lo / 100, success_hi=hi / 100)
        wanted = ["search_time", "path_ratio", "loc_error", "cpu_ms_per_decision", *task.metrics]
        for name in wanted:
            col, flag, _ = MEANS[name]
            vals = ok[ok[flag].fillna(False).astype(bool)][col] if flag else ok[col]
            vals = vals.to_numpy(float)
            vals = vals[np.isfinite(vals)]
            if name == "cpu_ms_per_decision":
                # the median: a process's first episode also compiles its kernels
                v = float(np.median(vals)) if vals.size else math.nan
                lo, hi = bootstrap_ci(vals, np.random.default_rng(seed + mi), "median")
            else:
                stat = ("mean", col, flag) if flag else ("mean", col)
                v, lo, hi, _ = stat_interval(ok, stat, seed + mi)
            row[name], row[f"{name}_lo"], row[f"{name}_hi"] = _num(v), _num(lo), _num(hi)
            row[f"{name}_sem"] = (
                _num(vals.std(ddof=1) / math.sqrt(vals.size)) if vals.size > 1 else None
            )
        failed = sub[~sub["success"].fillna(0).astype(bool)]
        causes = failed["termination"].fillna("error").where(failed["status"] == "ok", "error")
        # an unsuccessful episode that ended on its declaration declared the wrong place
        causes = causes.replace({"declared": "wrong declaration"})
        row["failures"] = {str(c): int(n) for c, n in causes.value_counts().sort_index().items()}
        rows.append(row)
    return rank_rows(rows, task.rank_by)


def _better(a: Mapping[str, Any], b: Mapping[str, Any], rank_by: str) -> bool:
    """``a`` better than ``b`` (module docstring: Ranks)."""
    if a["success_lo"] > b["success_hi"]:
        return True
    if rank_by != "search_time" or b["success_lo"] > a["success_hi"]:
        return False
    ahi, blo = a.get("search_time_hi"), b.get("search_time_lo")
    if ahi is None or blo is None:
        # a mean with one success has no interval: it is better only than a method without any
        return a.get("search_time") is not None and b.get("search_time") is None
    return bool(ahi < blo)


def rank_rows(rows: list[dict[str, Any]], rank_by: str) -> list[dict[str, Any]]:
    """Set ``rank`` on every row of one task and sort them by it (then by name)."""
    for r in rows:
        r["rank"] = 1 + sum(_better(o, r, rank_by) for o in rows if o is not r)
    key = "search_time" if rank_by == "search_time" else "success"
    sign = 1 if rank_by == "search_time" else -1

    def order(r: Mapping[str, Any]) -> tuple[Any, ...]:
        v = r.get(key)
        return (r["rank"], -r["success"], math.inf if v is None else sign * v, r["method"])

    return sorted(rows, key=order)


def overall_board(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per method: tasks run, tasks ranked first, mean normalised rank (0 best)."""
    by_task: dict[str, int] = {}
    for r in rows:
        by_task[r["task"]] = by_task.get(r["task"], 0) + 1
    acc: dict[str, dict[str, Any]] = {}
    for r in rows:
        a = acc.setdefault(
            r["method"], {"method": r["method"], "tasks": 0, "firsts": 0, "norm": [], "ranks": {}}
        )
        n = by_task[r["task"]]
        a["tasks"] += 1
        a["firsts"] += int(r["rank"] == 1)
        a["norm"].append((r["rank"] - 1) / (n - 1) if n > 1 else 0.0)
        a["ranks"][r["task"]] = r["rank"]
    out = []
    for a in acc.values():
        norm = a.pop("norm")
        a["mean_rank"] = float(np.mean(norm))
        out.append(a)
    return sorted(out, key=lambda a: (a["mean_rank"], -a["tasks"], a["method"]))


def reference_check(row: Mapping[str, Any], reference: Mapping[str, Any] | None) -> dict | None:
    """Agreement of a row's mean search time with a published mean: the difference against
    1.96 times the combined standard error (ours from the sample, theirs as published)."""
    if not reference:
        return None
    ref = reference.get("search_time", {}).get(row["method"])
    if ref is None or row.get("search_time") is None:
        return None
    mean, sem = float(ref[0]), float(ref[1])
    ours = row.get("search_time_sem") or 0.0
    tol = 1.96 * math.hypot(ours, sem)
    diff = row["search_time"] - mean
    return {
        "mean": mean,
        "sem": sem,
        "source": reference.get("source", ""),
        "difference": diff,
        "tolerance": tol,
        "agrees": bool(abs(diff) <= tol),
    }


# ----------------------------------------------------------------------------- files


def write_results(path: Path, doc: Mapping[str, Any]) -> Path:
    """Write the results JSON (NaN written as ``null``)."""

    def clean(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, np.generic):
            return clean(v.item())
        if isinstance(v, Mapping):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    path.write_text(json.dumps(clean(doc), indent=1, sort_keys=False) + "\n", encoding="utf-8")
    return path


def load_results(path: str | Path, field: str = "results") -> dict[str, Any]:
    """Read a results JSON, checking its schema (:class:`ConfigError` naming ``field``)."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(field, f"{p} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(field, f"{p} is not a results JSON ({type(exc).__name__})") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        raise ConfigError(field, f"{p} is not a benchmark results file (schema {SCHEMA})")
    for key in ("suite", "tier", "rows", "tasks"):
        if key not in doc:
            raise ConfigError(field, f"{p} has no {key!r}")
    return doc


def compare_results(a: Mapping[str, Any], b: Mapping[str, Any]) -> dict[str, Any]:
    """What changed from ``a`` to ``b``, per task and method.

    A metric got *better* or *worse* when ``b``'s value lies outside ``a``'s 95 % interval
    (the success rate's Wilson interval, a mean's bootstrap interval), in the metric's good or
    bad direction; values inside it are unchanged. Rows only in one file are listed as added or
    removed. Results of different suite versions are refused (their tasks differ).
    """
    if a["suite"] != b["suite"]:
        raise ConfigError(
            "suite", f"the files hold suites {a['suite']} and {b['suite']}: compare one suite"
        )
    ka = {(r["task"], r["method"]): r for r in a["rows"]}
    kb = {(r["task"], r["method"]): r for r in b["rows"]}
    changes: list[dict[str, Any]] = []
    for key in [k for k in ka if k in kb]:
        ra, rb = ka[key], kb[key]
        for metric in JUDGED:
            va, vb = ra.get(metric), rb.get(metric)
            lo, hi = ra.get(f"{metric}_lo"), ra.get(f"{metric}_hi")
            if va is None or vb is None or lo is None or hi is None:
                continue
            sense = 1 if metric == "success" else MEANS[metric][2]
            if lo <= vb <= hi:
                continue
            up = vb > hi
            changes.append(
                {
                    "task": key[0],
                    "method": key[1],
                    "metric": metric,
                    "a": va,
                    "a_lo": lo,
                    "a_hi": hi,
                    "b": vb,
                    "verdict": "better" if up == (sense > 0) else "worse",
                }
            )
    return {
        "suite": a["suite"],
        "tiers": [a["tier"], b["tier"]],
        "changes": changes,
        "added": sorted(f"{t}/{m}" for t, m in kb if (t, m) not in ka),
        "removed": sorted(f"{t}/{m}" for t, m in ka if (t, m) not in kb),
    }
