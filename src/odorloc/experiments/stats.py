"""Statistics of sweep results: intervals per cell and paired comparisons between searchers.

- Success rates get Wilson score intervals (good coverage even for rates near 0 or 1 and small
  n, where the normal approximation fails).
- Mean and median search times get percentile bootstrap intervals from a seeded Generator, so a
  report is reproducible to the last digit.
- Searchers are compared on the same worlds: episode ``i`` of two cells with the same world key
  faced the same world realisation (common random numbers), so differences are paired by
  ``(world_key, episode)`` and tested with the Wilcoxon signed-rank test (or a paired t test) for
  continuous metrics and the exact McNemar test for success.

Search time is averaged over successful episodes by default (``time_over="success"``, the usual
convention of the source-localisation literature); pass ``time_over="all"`` to include every
episode that ran without error, a failure at the time it ended (the time limit, or earlier when
a searcher got stuck or declared wrongly: read such times beside the success rate).

The paired difference of success rates gets Newcombe's interval for paired proportions (method
10, built on Wilson's intervals): a bootstrap of a handful of identical 0/1 differences would
give an interval of zero width.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from scipy import stats as sps

from odorloc.core.errors import ConfigError

Statistic = Literal["mean", "median"] | Callable[..., Any]


def _z(level: float) -> float:
    if not 0 < level < 1:
        raise ConfigError("level", f"must be in (0, 1), got {level}")
    return float(sps.norm.ppf(0.5 + level / 2))


def wilson_interval(k: Any, n: Any, level: float = 0.95) -> tuple[Any, Any]:
    """Wilson score interval of a binomial proportion.

    ``p_hat = k/n``, ``z`` the normal quantile;
    centre ``(p_hat + z^2/2n) / (1 + z^2/n)``, half width
    ``z / (1 + z^2/n) * sqrt(p_hat (1 - p_hat)/n + z^2/4n^2)`` (Wilson 1927).

    Parameters
    ----------
    k, n : int or array of int
        Successes and trials (``n = 0`` gives ``(0, 1)``).
    level : float
        Confidence level.

    Returns
    -------
    lo, hi : float or ndarray
    """
    z = _z(level)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    if np.any(k < 0) or np.any(k > n):
        raise ConfigError("k", "successes must satisfy 0 <= k <= n")
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where(n > 0, k / np.where(n > 0, n, 1), 0.5)
        nn = np.where(n > 0, n, 1)
        denom = 1 + z**2 / nn
        centre = (p + z**2 / (2 * nn)) / denom
        half = z / denom * np.sqrt(p * (1 - p) / nn + z**2 / (4 * nn**2))
    lo = np.where(n > 0, np.clip(centre - half, 0, 1), 0.0)
    hi = np.where(n > 0, np.clip(centre + half, 0, 1), 1.0)
    if lo.ndim == 0:
        return float(lo), float(hi)
    return lo, hi


def _stat_fn(statistic: Statistic) -> Callable[..., Any]:
    if statistic == "mean":
        return np.mean
    if statistic == "median":
        return np.median
    if callable(statistic):
        return statistic
    raise ConfigError("statistic", f"expected 'mean', 'median' or a callable, got {statistic!r}")


def bootstrap_ci(
    x: Any,
    rng: np.random.Generator,
    statistic: Statistic = "mean",
    level: float = 0.95,
    n_boot: int = 2000,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``statistic(x)``.

    Parameters
    ----------
    x : (n,) array_like
        Sample (NaN values are dropped).
    rng : numpy.random.Generator
        Source of the resampling indices.
    statistic : {"mean", "median"} or callable
        A callable must accept ``axis=1`` on an ``(n_boot, n)`` array.
    level : float
        Confidence level.
    n_boot : int
        Bootstrap replicates.

    Returns
    -------
    lo, hi : float
        ``(nan, nan)`` for fewer than two values (one value says nothing of the spread).
    """
    _z(level)
    x = np.asarray(x, float)
    x = x[~np.isnan(x)]
    if x.size < 2:
        return math.nan, math.nan
    fn = _stat_fn(statistic)
    idx = rng.integers(0, x.size, size=(n_boot, x.size))
    reps = fn(x[idx], axis=1)
    alpha = (1 - level) / 2
    lo, hi = np.quantile(reps, [alpha, 1 - alpha])
    return float(lo), float(hi)


def paired_proportion_ci(
    both: int, only_a: int, only_b: int, neither: int, level: float = 0.95
) -> tuple[float, float]:
    """Interval of ``p_a - p_b`` for paired successes (Newcombe 1998, method 10).

    Parameters
    ----------
    both, only_a, only_b, neither : int
        Pairs where both succeeded, only A, only B, neither.
    level : float
        Confidence level.

    Returns
    -------
    lo, hi : float
        In ``[-1, 1]``; ``(nan, nan)`` without pairs. With ``(l_i, u_i)`` the Wilson intervals
        of ``p_a`` and ``p_b`` and ``phi`` the correlation of the pairs (0 where undefined):
        ``lo = d - sqrt((p_a - l_a)^2 - 2 phi (p_a - l_a)(u_b - p_b) + (u_b - p_b)^2)`` and
        ``hi = d + sqrt((u_a - p_a)^2 - 2 phi (u_a - p_a)(p_b - l_b) + (p_b - l_b)^2)``.
    """
    a, b, c, d = (int(v) for v in (both, only_a, only_b, neither))
    if min(a, b, c, d) < 0:
        raise ConfigError("pairs", "counts must be >= 0")
    n = a + b + c + d
    if n == 0:
        return math.nan, math.nan
    pa, pb = (a + b) / n, (a + c) / n
    la, ua = wilson_interval(a + b, n, level)
    lb, ub = wilson_interval(a + c, n, level)
    den = (a + b) * (c + d) * (a + c) * (b + d)
    phi = (a * d - b * c) / math.sqrt(den) if den > 0 else 0.0
    diff = pa - pb
    dl = math.sqrt(max((pa - la) ** 2 - 2 * phi * (pa - la) * (ub - pb) + (ub - pb) ** 2, 0.0))
    du = math.sqrt(max((ua - pa) ** 2 - 2 * phi * (ua - pa) * (pb - lb) + (pb - lb) ** 2, 0.0))
    return max(diff - dl, -1.0), min(diff + du, 1.0)


def _ok(df: Any) -> Any:
    return df[df["status"] != "error"]


def _success_columns(g: Any, ok: Any, level: float) -> dict[str, Any]:
    """``n`` (episodes without error), ``errors``, ``successes``, ``success_rate`` and its
    Wilson interval ``success_lo``/``success_hi`` of a group ``g`` whose rows without error are
    ``ok``."""
    n = len(ok)
    k = int(ok["success"].fillna(False).astype(bool).sum())
    lo, hi = wilson_interval(k, n, level)
    return {
        "n": n,
        "errors": int(len(g) - n),
        "successes": k,
        "success_rate": k / n if n else math.nan,
        "success_lo": lo,
        "success_hi": hi,
    }


def _times(ok: Any, time_over: str) -> np.ndarray:
    if time_over == "success":
        ok = ok[ok["success"].fillna(False).astype(bool)]
    elif time_over != "all":
        raise ConfigError("time_over", f"expected 'success' or 'all', got {time_over!r}")
    return ok["search_time"].to_numpy(dtype=float)


def _cell_rng(seed: int, cell_index: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), int(cell_index)])


def summarize(
    df: Any,
    level: float = 0.95,
    n_boot: int = 2000,
    seed: int = 0,
    time_over: Literal["success", "all"] = "success",
) -> Any:
    """One row per cell: counts, success rate with its Wilson interval, time statistics.

    Parameters
    ----------
    df : pandas.DataFrame
        Episode table (as from :meth:`ResultStore.frame`).
    level : float
        Confidence level of every interval.
    n_boot : int
        Bootstrap replicates.
    seed : int
        Seed of the bootstrap (combined with the cell index).
    time_over : {"success", "all"}
        Episodes whose search time is averaged.

    Returns
    -------
    pandas.DataFrame
        Columns ``cell_id, world_key, scenario, searcher, n, errors, successes, success_rate,
        success_lo, success_hi, mean_time, mean_time_lo, mean_time_hi, median_time,
        median_time_lo, median_time_hi, mean_loc_error, mean_path_length, mean_start_distance,
        mean_energy, mean_sources_found, mean_false_sources`` plus the swept-parameter columns
        (a mean is NaN where the table has no such column).
    """
    import pandas as pd

    out = []
    order = "cell_index" if "cell_index" in df.columns else "cell_id"
    swept_cols = [c for c in df.columns if c.startswith(("scenario.", "searcher."))]
    for i, (cid, g) in enumerate(df.sort_values([order, "episode"]).groupby("cell_id", sort=False)):
        ok = _ok(g)
        success = _success_columns(g, ok, level)
        t = _times(ok, time_over)
        cidx = int(g["cell_index"].iloc[0]) if "cell_index" in g.columns else i
        rng = _cell_rng(seed, cidx)
        mlo, mhi = bootstrap_ci(t, rng, "mean", level, n_boot)
        dlo, dhi = bootstrap_ci(t, rng, "median", level, n_boot)
        row = {
            "cell_id": cid,
            "cell_index": cidx,
            "world_key": g["world_key"].iloc[0] if "world_key" in g.columns else "",
            "scenario": g["scenario"].iloc[0] if "scenario" in g.columns else "",
            "searcher": g["searcher"].iloc[0] if "searcher" in g.columns else "",
            **success,
            "mean_time": float(np.mean(t)) if t.size else math.nan,
            "mean_time_lo": mlo,
            "mean_time_hi": mhi,
            "median_time": float(np.median(t)) if t.size else math.nan,
            "median_time_lo": dlo,
            "median_time_hi": dhi,
            "mean_loc_error": _nanmean(ok, "loc_error"),
            "mean_path_length": _nanmean(ok, "path_length"),
            "mean_start_distance": _nanmean(ok, "start_distance"),
            "mean_energy": _nanmean(ok, "energy"),
            # what explains a failure: sources found and false sources per episode
            "mean_sources_found": _nanmean(ok, "sources_found"),
            "mean_false_sources": _nanmean(ok, "false_sources"),
        }
        for c in swept_cols:
            row[c] = g[c].iloc[0]
        out.append(row)
    return pd.DataFrame(out)


def outcome_table(
    df: Any, by: Sequence[str] = ("scenario", "searcher"), seed: int = 0, level: float = 0.95
) -> Any:
    """One row per group of ``by`` (in order of appearance): success and what the successes
    cost.

    Columns: the ``by`` columns, ``n`` (episodes without error), ``errors``, ``successes``,
    ``success_rate`` with its Wilson interval ``success_lo``/``success_hi``, ``mean_time`` (s)
    and ``mean_path`` (m) of the successful episodes with their bootstrap intervals
    (``time_lo``/``time_hi``, ``path_lo``/``path_hi``; NaN for fewer than two successes) and
    ``detected`` (fraction of episodes with a first detection). Group ``i`` bootstraps from
    ``default_rng([seed, i])``, times first, so a table is reproducible to the last digit.
    """
    import pandas as pd

    rows = []
    for key, g in df.groupby(list(by), sort=False):
        ok = _ok(g)
        success = _success_columns(g, ok, level)
        n = success["n"]
        succ = ok[ok["success"].fillna(False).astype(bool)]
        rng = np.random.default_rng([seed, len(rows)])
        t = succ["search_time"].to_numpy(float)
        p = succ["path_length"].to_numpy(float)
        tl, th = bootstrap_ci(t, rng, level=level)
        pl, ph = bootstrap_ci(p, rng, level=level)
        first = ok["first_detection_time"].astype(float)
        rows.append(
            {
                **dict(zip(by, key if isinstance(key, tuple) else (key,), strict=True)),
                **success,
                "mean_time": float(t.mean()) if t.size else math.nan,
                "time_lo": tl,
                "time_hi": th,
                "mean_path": float(p.mean()) if p.size else math.nan,
                "path_lo": pl,
                "path_hi": ph,
                "detected": float(np.isfinite(first).mean()) if n else math.nan,
            }
        )
    return pd.DataFrame(rows, columns=[*by, *OUTCOME_COLUMNS])


#: Columns of :func:`outcome_table` after its ``by`` columns.
OUTCOME_COLUMNS = (
    "n",
    "errors",
    "successes",
    "success_rate",
    "success_lo",
    "success_hi",
    "mean_time",
    "time_lo",
    "time_hi",
    "mean_path",
    "path_lo",
    "path_hi",
    "detected",
)


def mean_sd(x: Any) -> tuple[float, float]:
    """Mean and sample standard deviation of the finite values of ``x`` (``(nan, nan)`` for
    none; a standard deviation of 0 for one value)."""
    a = np.asarray(x, float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return math.nan, math.nan
    return float(a.mean()), float(a.std(ddof=1)) if a.size > 1 else 0.0


def _nanmean(df: Any, col: str) -> float:
    if col not in df.columns:
        return math.nan
    v = df[col].to_numpy(dtype=float)
    v = v[~np.isnan(v)]
    return float(v.mean()) if v.size else math.nan


def interval_width(
    df: Any,
    metric: Literal["success", "search_time"] = "success",
    level: float = 0.95,
    seed: int = 0,
    n_boot: int = 1000,
    time_over: Literal["success", "all"] = "success",
) -> float:
    """Full width of the interval of one cell's ``metric`` (``inf`` when it is undefined).

    ``success``: Wilson interval of the success rate; ``search_time``: bootstrap interval of
    the mean search time, seconds (fewer than two times give ``inf``).
    """
    if len(df) == 0:
        return math.inf
    ok = _ok(df)
    if metric == "success":
        if len(ok) == 0:
            return math.inf
        k = int(ok["success"].fillna(False).astype(bool).sum())
        lo, hi = wilson_interval(k, len(ok), level)
        return hi - lo
    if metric == "search_time":
        t = _times(ok, time_over)
        if t.size < 2:
            return math.inf
        cidx = int(df["cell_index"].iloc[0]) if "cell_index" in df.columns else 0
        lo, hi = bootstrap_ci(t, _cell_rng(seed, cidx), "mean", level, n_boot)
        return hi - lo
    raise ConfigError("adaptive.metric", f"expected 'success' or 'search_time', got {metric!r}")


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value from the discordant counts.

    ``b`` = pairs where only the first searcher succeeded, ``c`` = only the second; under the
    null each discordant pair goes either way with probability 1/2, so ``b ~ Binomial(b+c, 1/2)``.
    """
    if b + c == 0:
        return 1.0
    return float(sps.binomtest(int(b), int(b + c), 0.5).pvalue)


def paired_test(a: Any, b: Any, test: Literal["wilcoxon", "t"] = "wilcoxon") -> tuple[float, float]:
    """``(statistic, p_value)`` of a paired test of ``a - b`` (equal-length arrays); the p value
    is NaN with fewer than two pairs and 1 when every difference is 0."""
    d = np.asarray(a, float) - np.asarray(b, float)
    if d.size < 2:
        return math.nan, math.nan
    if np.all(d == 0):
        return math.nan, 1.0
    if test == "wilcoxon":
        r = sps.wilcoxon(d)
    elif test == "t":
        r = sps.ttest_1samp(d, 0.0)
    else:
        raise ConfigError("test", f"expected 'wilcoxon' or 't', got {test!r}")
    return float(r.statistic), float(r.pvalue)


def paired_comparison(
    df: Any,
    cell_a: str,
    cell_b: str,
    metric: str = "search_time",
    test: Literal["wilcoxon", "t"] = "wilcoxon",
    level: float = 0.95,
    seed: int = 0,
    n_boot: int = 2000,
) -> dict[str, Any]:
    """Paired difference ``a - b`` of ``metric`` between two cells of the same world key.

    Episodes are matched by index; an episode missing or in error in either cell is dropped.
    For ``metric="success"`` the test is the exact McNemar test and the difference is in
    success rate; otherwise ``test`` is applied to the per-episode differences (episodes with a
    NaN value in either cell are dropped too).

    Returns
    -------
    dict
        ``cell_a, cell_b, metric, n_pairs, mean_a, mean_b, mean_diff, diff_lo, diff_hi, test,
        statistic, p_value`` (``diff_lo/hi``: Newcombe's interval of the difference of success
        rates, or the bootstrap interval of the mean difference; ``p_value`` NaN without pairs).
    """
    ga = _ok(df[df["cell_id"] == cell_a]).set_index("episode")
    gb = _ok(df[df["cell_id"] == cell_b]).set_index("episode")
    if len(ga) and len(gb) and "world_key" in df.columns:
        wa, wb = ga["world_key"].iloc[0], gb["world_key"].iloc[0]
        if wa != wb:
            raise ConfigError(
                "cells", f"{cell_a!r} and {cell_b!r} do not share worlds ({wa} vs {wb})"
            )
    return _paired(ga, gb, cell_a, cell_b, metric, test, level, seed, n_boot)


def _paired(
    ga: Any,
    gb: Any,
    cell_a: str,
    cell_b: str,
    metric: str,
    test: Literal["wilcoxon", "t"],
    level: float,
    seed: int,
    n_boot: int,
) -> dict[str, Any]:
    """:func:`paired_comparison` of two cells' episodes without errors, indexed by episode."""
    common = ga.index.intersection(gb.index).sort_values()
    a = ga.loc[common, metric].astype(float).to_numpy()
    b = gb.loc[common, metric].astype(float).to_numpy()
    return _paired_values(a, b, cell_a, cell_b, metric, test, level, seed, n_boot)


def _paired_values(
    a: np.ndarray,
    b: np.ndarray,
    cell_a: str,
    cell_b: str,
    metric: str,
    test: Literal["wilcoxon", "t"],
    level: float,
    seed: int,
    n_boot: int,
) -> dict[str, Any]:
    """:func:`_paired` of the two cells' values of ``metric`` on their common episodes, in
    episode order (``(n,)`` each)."""
    keep = ~(np.isnan(a) | np.isnan(b))
    a, b = a[keep], b[keep]
    d = a - b
    if metric == "success":
        bb = int(np.sum((a == 1) & (b == 0)))
        cc = int(np.sum((a == 0) & (b == 1)))
        both = int(np.sum((a == 1) & (b == 1)))
        lo, hi = paired_proportion_ci(both, bb, cc, d.size - both - bb - cc, level)
        name, stat, p = "mcnemar", float(bb - cc), mcnemar_exact(bb, cc)
        if d.size == 0:
            p = math.nan
    else:
        lo, hi = bootstrap_ci(d, np.random.default_rng(seed), "mean", level, n_boot)
        name = test
        stat, p = paired_test(a, b, test)
    return {
        "cell_a": cell_a,
        "cell_b": cell_b,
        "metric": metric,
        "n_pairs": int(d.size),
        "mean_a": float(a.mean()) if a.size else math.nan,
        "mean_b": float(b.mean()) if b.size else math.nan,
        "mean_diff": float(d.mean()) if d.size else math.nan,
        "diff_lo": lo,
        "diff_hi": hi,
        "test": name,
        "statistic": stat,
        "p_value": p,
    }


def compare_searchers(
    df: Any,
    metrics: tuple[str, ...] = ("success", "search_time"),
    test: Literal["wilcoxon", "t"] = "wilcoxon",
    level: float = 0.95,
    seed: int = 0,
) -> Any:
    """Paired comparisons of every pair of cells sharing a world key, for each metric.

    Returns
    -------
    pandas.DataFrame
        One row per (world key, cell pair, metric) with the fields of :func:`paired_comparison`.
    """
    import pandas as pd

    rows = []
    order = "cell_index" if "cell_index" in df.columns else "cell_id"
    cells = df.sort_values(order).drop_duplicates("cell_id")[["cell_id", "world_key"]]
    # each cell's episodes split off once (not once per pair and metric), as arrays in
    # episode order: the pairs then meet by array lookups, not by pandas indexing
    frames = {cid: _ok(g).set_index("episode") for cid, g in df.groupby("cell_id", sort=False)}
    values = {
        cid: (f.index.to_numpy(), {m: f[m].astype(float).to_numpy() for m in metrics})
        for cid, f in frames.items()
        if f.index.is_unique
    }

    def pair(x: str, y: str, m: str) -> dict[str, Any]:
        if x not in values or y not in values:  # an episode stored twice: pandas pairs them
            return _paired(frames[x], frames[y], x, y, m, test, level, seed, 2000)
        (ea, va), (eb, vb) = values[x], values[y]
        _, ia, ib = np.intersect1d(ea, eb, assume_unique=True, return_indices=True)
        return _paired_values(va[m][ia], vb[m][ib], x, y, m, test, level, seed, 2000)

    for wk, g in cells.groupby("world_key", sort=False):
        ids = list(g["cell_id"])
        for i in range(len(ids)):
            for j in range(i + 1, len(ids)):
                for m in metrics:
                    r = pair(ids[i], ids[j], m)
                    r["world_key"] = wk
                    rows.append(r)
    return pd.DataFrame(rows)
