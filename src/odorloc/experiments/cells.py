"""Statistics of a set of episode rows (a pandas DataFrame of one cell or several).

A *stat* says what to compute:

- ``("rate", col)``: the percentage of rows whose ``col`` is true, with its Wilson interval;
- ``("mean", col)``: the mean of the finite values of ``col``, with a bootstrap interval;
- ``("mean", col, flag)``: the same over the rows whose ``flag`` column is true.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from odorloc.experiments.stats import bootstrap_ci, wilson_interval

__all__ = ["stat_interval"]


def stat_interval(rows: Any, stat: tuple[str, ...], seed: int) -> tuple[float, float, float, str]:
    """``(value, lo, hi, "k/n")`` of ``stat`` over ``rows`` (NaN when there is nothing)."""
    kind, col = stat[0], stat[1]
    n = len(rows)
    if kind == "rate":
        k = int(rows[col].fillna(False).astype(bool).sum()) if col in rows and n else 0
        lo, hi = wilson_interval(k, n) if n else (math.nan, math.nan)
        return (100 * k / n if n else math.nan), 100 * lo, 100 * hi, f"{k}/{n}"
    if len(stat) > 2 and n:
        rows = rows[rows[stat[2]].fillna(False).astype(bool)]
    a = rows[col].to_numpy(float) if col in rows and len(rows) else np.zeros(0)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return math.nan, math.nan, math.nan, f"0/{n}"
    lo, hi = bootstrap_ci(a, np.random.default_rng(seed), "mean", 0.95, 2000)
    return float(a.mean()), float(lo), float(hi), f"{a.size}/{n}"
