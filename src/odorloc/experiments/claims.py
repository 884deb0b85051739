"""A paper's statements judged on paired episodes: intervals, verdicts, and the usual statements.

A reproduction stores episodes by cell (world key x searcher label); episode ``i`` of every
searcher in one world faced the same world (common random numbers). This module turns them into
the numbers a statement needs and judges it:

- :class:`Cells`: the episodes of each cell as a small table (success and named measures,
  indexed by episode), and :meth:`Cells.paired`, the episodes every cell of a list shares;
- :class:`Points`: the cells of a paper's *points* (a setting of its parameters) and methods,
  through the paper's ``cell_of(point, method) -> (world key, label)``;
- :func:`bootstrap`: a percentile bootstrap of any statistic of one or more groups of
  episodes; the rows of a group are resampled together (a paired resample of every method at a
  point), different groups independently; :func:`slope` of a measure on a swept value;
- :func:`verdict` and :func:`combine`: *held* when the interval lies on the claimed side,
  *not held* when it lies on the other, *undecided* otherwise; a statement about several parts
  holds when every part does and fails when any part fails;
- :class:`Claim`: a statement, the paper's number, ours with its interval, the verdict;
- builders of the statements most method papers make: :func:`best_everywhere` (a method has
  the best mean at every point), :func:`trend_claims` (a measure rises or falls with a swept
  value, and levels off beyond a knee), :func:`relative_change` (a method's mean relative to
  another's, e.g. an energy saving), :func:`paired_difference`;
- :func:`summarize_point`: success rate (Wilson) and mean time (bootstrap) of one cell, and
  :func:`ci_text` / :func:`pct_text` to print them.

Intervals are 95 % (Wilson for a success rate, 2 000 seeded bootstrap resamples otherwise).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odorloc.experiments import stats

__all__ = [
    "LEVEL",
    "N_BOOT",
    "POINT_COLUMNS",
    "Cells",
    "Claim",
    "PointSummary",
    "Points",
    "best_everywhere",
    "bootstrap",
    "ci_text",
    "combine",
    "paired_difference",
    "pct_text",
    "rate_verdict",
    "relative_change",
    "slope",
    "slope_difference",
    "summarize_point",
    "summary_texts",
    "sweep_rows",
    "trend",
    "trend_claims",
    "verdict",
]

#: Bootstrap resamples of every interval.
N_BOOT = 2000
#: Confidence level of every interval.
LEVEL = 0.95


# ----------------------------------------------------------------------------- intervals
def _ci(reps: np.ndarray) -> tuple[float, float]:
    alpha = (1 - LEVEL) / 2
    if reps.size == 0 or np.all(np.isnan(reps)):
        return math.nan, math.nan
    lo, hi = np.nanquantile(reps, [alpha, 1 - alpha])
    return float(lo), float(hi)


def bootstrap(
    fn: Callable[[list[np.ndarray]], np.ndarray],
    groups: Sequence[np.ndarray],
    rng: np.random.Generator,
    n_boot: int = N_BOOT,
) -> tuple[float, float, float]:
    """``fn`` on the data and its percentile bootstrap interval.

    Parameters
    ----------
    fn : callable
        ``fn(arrays)`` with ``arrays[g]`` of shape ``(B, n_g, ...)`` returns ``(B,)``: the
        statistic of ``B`` data sets at once.
    groups : sequence of (n_g, ...) ndarray
        Independent samples (e.g. the points of a sweep); the rows of one group are resampled
        together (e.g. the episodes of every method at one point: a paired resample).
    rng : numpy.random.Generator
    n_boot : int

    Returns
    -------
    value, lo, hi : float
        ``value`` is ``fn`` on the data; NaN without groups or with an empty one.
    """
    arrays = [np.asarray(g, float) for g in groups]
    if not arrays or any(len(a) == 0 for a in arrays):
        return math.nan, math.nan, math.nan
    value = float(fn([a[None] for a in arrays])[0])
    reps = fn([a[rng.integers(0, len(a), size=(n_boot, len(a)))] for a in arrays])
    lo, hi = _ci(np.asarray(reps, float))
    return value, lo, hi


def slope(x: Sequence[float], means: np.ndarray, counts: Sequence[int]) -> np.ndarray:
    """Least-squares slope of the per-episode values on ``x`` from the point means.

    Parameters
    ----------
    x : (P,) sequence of float
        The swept values.
    means : (B, P) ndarray
        Mean of the values at each point, for ``B`` data sets.
    counts : (P,) sequence of int
        Episodes per point (the weights of the pooled fit).

    Returns
    -------
    (B,) ndarray
        Change of the value per unit of ``x`` (NaN with fewer than two distinct values).
    """
    xs = np.asarray(x, float)
    w = np.asarray(counts, float)
    xbar = float(w @ xs / w.sum())
    ybar = means @ w / w.sum()
    num = ((means - ybar[:, None]) * (w * (xs - xbar))[None, :]).sum(axis=1)
    den = float(w @ (xs - xbar) ** 2)
    return num / den if den > 0 else np.full(len(means), np.nan)


def verdict(lo: float, hi: float, direction: int, margin: float = 0.0) -> str:
    """``held`` / ``not held`` / ``undecided`` for a statement "the quantity is > margin"
    (``direction=+1``) or "< margin" (``-1``), given its interval ``[lo, hi]``.

    ``held`` if the interval lies on the claimed side of ``margin``, ``not held`` if it lies on
    the other side, else ``undecided`` (also for an undefined interval).
    """
    if math.isnan(lo) or math.isnan(hi):
        return "undecided"
    a, b = (lo - margin, hi - margin) if direction > 0 else (margin - hi, margin - lo)
    if a > 0:
        return "held"
    if b < 0:
        return "not held"
    return "undecided"


def combine(verdicts: Sequence[str]) -> str:
    """A statement about several parts holds if every part does, fails if any part fails."""
    if any(v == "not held" for v in verdicts):
        return "not held"
    if verdicts and all(v == "held" for v in verdicts):
        return "held"
    return "undecided"


def ci_text(v: float, lo: float, hi: float, scale: float = 1.0, digits: int = 0) -> str:
    """``+v [+lo, +hi]`` scaled, with a sign (``-`` when undefined)."""
    if math.isnan(v):
        return "-"
    return f"{v * scale:+.{digits}f} [{lo * scale:+.{digits}f}, {hi * scale:+.{digits}f}]"


def pct_text(k: int, n: int) -> str:
    """``k / n`` as a percentage with its Wilson interval: ``25 % [12, 44] (6/24)``."""
    if n == 0:
        return "-"
    lo, hi = stats.wilson_interval(k, n)
    return f"{100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] ({k}/{n})"


# ----------------------------------------------------------------------------- claims
@dataclass(frozen=True)
class Claim:
    """One statement of a paper and what the reproduction shows.

    Attributes
    ----------
    world : str
        Where it was judged (a reproduction's world or part, e.g. ``rate``).
    statement : str
    paper : str
        The paper's figure or number.
    ours : str
        Our quantity with its interval.
    verdict : str
        ``held``, ``not held`` or ``undecided``.
    """

    world: str
    statement: str
    paper: str
    ours: str
    verdict: str

    def row(self) -> list[str]:
        """The claim as a table row."""
        return [self.world, self.statement, self.paper, self.ours, self.verdict]


# ----------------------------------------------------------------------------- cells
@dataclass(frozen=True)
class PointSummary:
    """Success rate and mean time of one cell.

    Attributes
    ----------
    n, k : int
        Episodes and successes.
    sr, sr_lo, sr_hi : float
        Success rate and its Wilson interval (fractions).
    mst, mst_lo, mst_hi : float, seconds
        Mean time over all episodes (failures at the limit) and its bootstrap interval.
    mst_success : float, seconds
        Mean time of the successes (NaN without any).
    """

    n: int
    k: int
    sr: float
    sr_lo: float
    sr_hi: float
    mst: float
    mst_lo: float
    mst_hi: float
    mst_success: float


def summarize_point(g: Any, rng: np.random.Generator) -> PointSummary:
    """The :class:`PointSummary` of the episodes ``g`` (columns ``success``, ``time``)."""
    n = len(g)
    if n == 0:
        nan = math.nan
        return PointSummary(0, 0, nan, nan, nan, nan, nan, nan, nan)
    s = g["success"].to_numpy(bool)
    t = g["time"].to_numpy(float)
    k = int(s.sum())
    lo, hi = stats.wilson_interval(k, n, LEVEL)
    m, m_lo, m_hi = bootstrap(lambda a: a[0].mean(axis=1), [t], rng)
    return PointSummary(n, k, k / n, lo, hi, m, m_lo, m_hi, float(t[s].mean()) if k else math.nan)


class Cells:
    """The episodes of a reproduction by (world key, searcher label), indexed by episode.

    Parameters
    ----------
    df : pandas.DataFrame
        Stored rows (error rows are left out).
    columns : mapping of str to str
        The measures to keep: name in :meth:`get` -> column of ``df`` (a column ``df`` lacks
        reads as NaN). ``success`` is always kept (a missing success is no success).
    """

    def __init__(self, df: Any, columns: Mapping[str, str]) -> None:
        ok = df[df["status"] != "error"] if len(df) else df
        self.columns = dict(columns)
        self._by = {key: g for key, g in ok.groupby(["world_key", "searcher"])} if len(ok) else {}

    def get(self, world: str, label: str) -> Any:
        """Episodes of one cell: ``success`` and the named measures (may be empty)."""
        import pandas as pd

        g = self._by.get((world, label))
        if g is None:
            return pd.DataFrame(columns=["success", *self.columns])
        data: dict[str, Any] = {"success": g["success"].fillna(False).astype(bool).to_numpy()}
        for name, col in self.columns.items():
            data[name] = g[col].to_numpy(float) if col in g else np.full(len(g), np.nan)
        return pd.DataFrame(data, index=g["episode"].to_numpy(int)).sort_index()

    def paired(self, world: str, labels: Sequence[str], column: str) -> np.ndarray:
        """``(n, len(labels))`` values of ``column`` on the episodes every cell has."""
        frames = [self.get(world, lab) for lab in labels]
        common = frames[0].index
        for f in frames[1:]:
            common = common.intersection(f.index)
        return (
            np.column_stack([f.loc[common, column].to_numpy(float) for f in frames])
            if len(common)
            else np.zeros((0, len(labels)))
        )


class Points:
    """The cells of a paper's points and methods.

    Parameters
    ----------
    cells : Cells
    cell_of : callable
        ``cell_of(point, method) -> (world key, searcher label)``; the methods of one point
        must share the world key (their episodes are paired).
    """

    def __init__(self, cells: Cells, cell_of: Callable[[Hashable, str], tuple[str, str]]) -> None:
        self.cells = cells
        self.cell_of = cell_of

    def paired(self, point: Hashable, methods: Sequence[str], column: str) -> np.ndarray:
        """``(n, len(methods))`` paired values of ``column`` at ``point``."""
        where = [self.cell_of(point, m) for m in methods]
        worlds = {w for w, _ in where}
        if len(worlds) != 1:
            raise ValueError(f"methods {list(methods)} do not share a world at {point!r}")
        return self.cells.paired(worlds.pop(), [lab for _, lab in where], column)

    def one(self, point: Hashable, method: str) -> Any:
        """The episodes of one method at one point."""
        return self.cells.get(*self.cell_of(point, method))


# ----------------------------------------------------------------------------- statements
def _means(arrays: list[np.ndarray], column: int = 0) -> np.ndarray:
    """``(B, P)`` means of one column of every point's resampled ``(B, n, c)`` episodes."""
    return np.stack([a[..., column].mean(axis=1) for a in arrays], axis=1)


def best_everywhere(
    data: Points,
    points: Sequence[Hashable],
    method: str,
    baselines: Sequence[str],
    column: str,
    rng: np.random.Generator,
    names: Mapping[str, str],
    where: Callable[[Hashable], str] = str,
    higher: bool = True,
    scale: float = 1.0,
    unit: str = "",
) -> tuple[str, str]:
    """ "``method`` has the highest (lowest) mean ``column`` at every point": ``(ours,
    verdict)``.

    Each baseline at each point is a paired difference with its interval; the verdict combines
    them all. ``ours`` counts the points where the method's mean is the best, those where it is
    significantly worse than a baseline, and names the least favourable comparison.
    """
    best = lost = total = 0
    verdicts: list[str] = []
    # (margin in the claim's favour, difference, where): the least favourable comparison
    worst: tuple[float, float, str] = (math.inf, math.nan, "")
    for s in points:
        x = data.paired(s, [method, *baselines], column)
        if len(x) == 0:
            verdicts.append("undecided")
            continue
        total += 1
        m = x.mean(axis=0)
        if (m[0] >= m[1:]).all() if higher else (m[0] <= m[1:]).all():
            best += 1
        point_lost = False
        for j, b in enumerate(baselines, start=1):
            d, lo, hi = bootstrap(
                lambda a, j=j: (a[0][..., 0] - a[0][..., j]).mean(axis=1), [x], rng
            )
            v = verdict(lo, hi, +1 if higher else -1)
            verdicts.append(v)
            point_lost |= v == "not held"
            margin = d if higher else -d
            if margin < worst[0]:
                worst = (margin, d, f"{names.get(b, b)} at {where(s)}")
        lost += point_lost
    if not total:
        return "no episodes", combine(verdicts)
    diff = f"{worst[1] * scale:+.0f}{unit}"
    ours = (
        f"best at {best} of {total} points, significantly worse than a baseline at {lost}; "
        f"least favourable: {worst[2]} ({names.get(method, method)} {diff})"
    )
    return ours, combine(verdicts)


def trend(
    data: Points,
    values: Sequence[float],
    point_of: Callable[[float], Hashable],
    method: str,
    column: str,
    rng: np.random.Generator,
) -> tuple[float, float, float]:
    """Slope (per unit of the swept value) of ``column`` over ``values``, with its interval."""
    vals = list(values)
    groups = [data.paired(point_of(v), [method], column) for v in vals]
    counts = [len(g) for g in groups]
    return bootstrap(lambda a: slope(vals, _means(a), counts), groups, rng)


def trend_claims(
    data: Points,
    values: Sequence[float],
    point_of: Callable[[float], Hashable],
    methods: Sequence[str],
    knee: float,
    what: str,
    unit: str,
    figure: str,
    rng: np.random.Generator,
    names: Mapping[str, str],
    world: str,
    per: float = 1.0,
) -> list[Claim]:
    """ "SR rises / MST falls with more ``what`` (every method)" and "... levels off beyond
    ``knee``" (the slope up to the knee minus the slope from it is positive).

    Columns ``success`` (percentage points) and ``time`` (seconds); slopes are given per
    ``per`` units of the swept value (``unit`` names them).
    """
    out: list[Claim] = []
    if len(values) < 2:
        return out
    low = [v for v in values if v <= knee]
    high = [v for v in values if v >= knee]
    for column, name, direction, scale in (
        ("success", "SR rises", +1, 100.0),
        ("time", "MST falls", -1, 1.0),
    ):
        texts, verdicts, flat_texts, flat_verdicts = [], [], [], []
        for a in methods:
            v, lo, hi = trend(data, values, point_of, a, column, rng)
            texts.append(f"{names.get(a, a)} {ci_text(v * per, lo * per, hi * per, scale)}")
            verdicts.append(verdict(lo, hi, direction))
            if len(low) < 2 or len(high) < 2:
                continue
            groups_lo = [data.paired(point_of(x), [a], column) for x in low]
            groups_hi = [data.paired(point_of(x), [a], column) for x in high]
            c_lo, c_hi = [len(g) for g in groups_lo], [len(g) for g in groups_hi]

            def knee_fn(
                arr: list[np.ndarray], c_lo=c_lo, c_hi=c_hi, direction=direction
            ) -> np.ndarray:
                s_lo = slope(low, _means(arr[: len(low)]), c_lo)
                s_hi = slope(high, _means(arr[len(low) :]), c_hi)
                return direction * (s_lo - s_hi)

            d, d_lo, d_hi = bootstrap(knee_fn, [*groups_lo, *groups_hi], rng)
            s_lo = trend(data, low, point_of, a, column, rng)
            s_hi = trend(data, high, point_of, a, column, rng)
            diff = ci_text(d * per, d_lo * per, d_hi * per, scale)
            flat_texts.append(
                f"{names.get(a, a)} {s_lo[0] * per * scale:+.0f} then "
                f"{s_hi[0] * per * scale:+.0f} (diff {diff})"
            )
            flat_verdicts.append(
                combine([verdict(s_lo[1], s_lo[2], direction), verdict(d_lo, d_hi, +1)])
            )
        u = "pts" if column == "success" else "s"
        out.append(
            Claim(
                world,
                f"{name} with more {what} (all {len(methods)})",
                figure,
                f"slope, {u} per {unit}: " + "; ".join(texts),
                combine(verdicts),
            )
        )
        if flat_texts:
            out.append(
                Claim(
                    world,
                    f"{name.split()[0]} levels off beyond {knee:g} {what} (all {len(methods)})",
                    figure,
                    f"slope up to / from {knee:g}, {u} per {unit}: " + "; ".join(flat_texts),
                    combine(flat_verdicts),
                )
            )
    return out


def relative_change(
    data: Points, point: Hashable, method: str, other: str, column: str, rng: np.random.Generator
) -> tuple[float, float, float, int]:
    """``mean(method) / mean(other) - 1`` of ``column`` over the paired episodes at ``point``,
    its interval and the number of pairs."""
    x = data.paired(point, [method, other], column)

    def rel(a: list[np.ndarray]) -> np.ndarray:
        return a[0][..., 0].mean(axis=1) / a[0][..., 1].mean(axis=1) - 1.0

    v, lo, hi = bootstrap(rel, [x], rng)
    return v, lo, hi, len(x)


def paired_difference(
    data: Points,
    points: Sequence[Hashable],
    method: str,
    other: str,
    column: str,
    rng: np.random.Generator,
) -> tuple[float, float, float]:
    """Mean over ``points`` of the paired difference ``method - other`` of ``column``, with its
    interval (each point resampled on its own)."""
    groups = [data.paired(p, [method, other], column) for p in points]

    def diff(a: list[np.ndarray]) -> np.ndarray:
        return np.mean([(x[..., 0] - x[..., 1]).mean(axis=1) for x in a], axis=0)

    return bootstrap(diff, groups, rng)


def summary_texts(p: PointSummary) -> tuple[str, str]:
    """``("SR [lo, hi]", "MST [lo, hi]")`` of a cell (success in %, time in s; ``-`` if empty,
    and for a time when no episode has one)."""
    if p.n == 0:
        return "-", "-"
    mst = "-" if math.isnan(p.mst) else f"{p.mst:.0f} [{p.mst_lo:.0f}, {p.mst_hi:.0f}]"
    return f"{100 * p.sr:.0f} [{100 * p.sr_lo:.0f}, {100 * p.sr_hi:.0f}]", mst


#: Header of :func:`sweep_rows`' long rows after the caller's tag columns.
POINT_COLUMNS = [
    "value", "algorithm", "n", "successes", "SR %", "SR lo", "SR hi",
    "MST s", "MST lo", "MST hi", "MST successes s", "SR by time %",
]  # fmt: skip


def sweep_rows(
    data: Points,
    values: Sequence[Any],
    point_of: Callable[[Any], Hashable],
    tick: Callable[[Any], str],
    methods: Sequence[str],
    seed: int,
    at: float,
    tag: Sequence[str] = (),
) -> tuple[list[list[str]], list[list[str]], list[list[str]]]:
    """Per swept value: the success-rate row and the mean-time row of a console table (one
    column per method, with intervals), and one long row per value and method (``tag``, then
    :data:`POINT_COLUMNS`; the last is the success rate by ``at`` seconds)."""
    from odorloc.experiments.reproduction import fmt

    sr_rows, mst_rows, long = [], [], []
    for v in values:
        sr_row, mst_row = [tick(v)], [tick(v)]
        for i, a in enumerate(methods):
            g = data.one(point_of(v), a)
            p = summarize_point(g, np.random.default_rng([seed, i, *map(ord, tick(v))]))
            sr, mst = summary_texts(p)
            sr_row.append(sr)
            mst_row.append(mst)
            by = int((g["success"] & (g["time"] <= at)).sum()) if len(g) else 0
            numbers = (100 * p.sr, 100 * p.sr_lo, 100 * p.sr_hi, p.mst, p.mst_lo, p.mst_hi)
            long.append(
                [*tag, tick(v), a, str(p.n), str(p.k)]
                + [fmt(x, 1 if j < 3 else 0) for j, x in enumerate(numbers)]
                + [fmt(p.mst_success, 0), fmt(100 * by / p.n if p.n else math.nan, 1)]
            )
        sr_rows.append(sr_row)
        mst_rows.append(mst_row)
    return sr_rows, mst_rows, long


def slope_difference(
    data: Points,
    values: Sequence[float],
    point_of: Callable[[float], Hashable],
    method: str,
    other: str,
    column: str,
    rng: np.random.Generator,
) -> tuple[float, float, float]:
    """Slope of ``column`` on the swept value, ``method`` minus ``other`` (paired at each
    point), with its interval."""
    vals = list(values)
    groups = [data.paired(point_of(v), [method, other], column) for v in vals]
    counts = [len(g) for g in groups]

    def fn(a: list[np.ndarray]) -> np.ndarray:
        return slope(vals, _means(a, 0), counts) - slope(vals, _means(a, 1), counts)

    return bootstrap(fn, groups, rng)


def rate_verdict(k: int, n: int, margin: float, direction: int = +1) -> str:
    """The verdict of "the success rate ``k / n`` is above (``direction=+1``) or below
    ``margin``", by its Wilson interval (``undecided`` without episodes)."""
    if n == 0:
        return "undecided"
    lo, hi = stats.wilson_interval(k, n)
    return verdict(lo, hi, direction, margin)
