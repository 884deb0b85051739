"""Statistics of the multi-UAV reproduction: per-episode measures, per-point summaries and the
paper's statements tested with intervals.

Measures of an episode (Sect. VI.1 of the paper):

- success: some UAV came within the reach radius of the source before the 20-minute limit;
- search time ``T``: the flying + hovering + turning time of the first UAV to reach the source,
  and the time limit for an episode where none did. The mean search time (MST) of a point is
  the mean of ``T`` over all its episodes (the paper averages "the search times of 200 Monte
  Carlo simulations"); the mean over successes alone is reported beside it;
- ``E_M``: the team's movement energy (eqs. 4-6), kJ.

Intervals are 95 %: Wilson for a success rate, percentile bootstrap (2000 resamples, seeded)
for means and for every difference, slope or contrast. Episode ``i`` of every algorithm at a
point faced the same world (common random numbers), so a contrast between algorithms resamples
episode indices jointly for all of them (a paired bootstrap); different points are resampled
independently.

A statement is *held* when the intervals support it, *not held* when they contradict it, and
*undecided* when they are too wide to tell (see :func:`verdict`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odorloc.experiments import stats

__all__ = [
    "Cells",
    "PointSummary",
    "add_uav_search_time",
    "bootstrap",
    "slope",
    "summarize_point",
    "verdict",
]

#: Bootstrap resamples of every interval.
N_BOOT = 2000
#: Confidence level of every interval.
LEVEL = 0.95


#: Team metrics the tables and figures read (absent from a store of failed episodes).
TEAM_METRICS = (
    "reach_fly_time",
    "reach_hover_time",
    "reach_turn_time",
    "energy_fly",
    "energy_hover",
    "energy_turn",
    "energy_compute",
    "energy_comm",
    "team_hover_time",
    "team_turn_time",
)


def add_uav_search_time(df: Any, limit: float = 1200.0) -> Any:
    """Rows with ``uav_search_time``: flying + hovering + turning time (s) of the first UAV to
    reach the source (Sect. VI.1), ``limit`` for episodes where none did; and ``movement_kj``,
    the team's movement energy ``E_M`` (eqs. 4-6) in kJ."""
    out = df.copy()
    for name in TEAM_METRICS:
        # a store of failed episodes has none of the team's metrics: NaN, never a KeyError
        if name not in out:
            out[name] = math.nan
    busy = out["reach_fly_time"] + out["reach_hover_time"] + out["reach_turn_time"]
    reached = out["success"].fillna(False).astype(bool)
    out["uav_search_time"] = np.where(reached, busy, limit)
    out["movement_kj"] = (out["energy_fly"] + out["energy_hover"] + out["energy_turn"]) / 1e3
    return out


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
        together (e.g. the episodes of every algorithm at one point: a paired resample).
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


@dataclass(frozen=True)
class PointSummary:
    """Success rate and search time of one algorithm at one point.

    Attributes
    ----------
    n, k : int
        Episodes and successes.
    sr, sr_lo, sr_hi : float
        Success rate and its Wilson interval (fractions).
    mst, mst_lo, mst_hi : float, seconds
        Mean search time over all episodes (failures at the limit) and its bootstrap interval.
    mst_success : float, seconds
        Mean search time of the successes (NaN without any).
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
        Stored rows (with :func:`add_uav_search_time` columns).
    """

    def __init__(self, df: Any) -> None:
        ok = df[df["status"] != "error"] if len(df) else df
        self._by = {key: g for key, g in ok.groupby(["world_key", "searcher"])} if len(ok) else {}

    def get(self, world: str, label: str) -> Any:
        """Episodes of one cell with columns ``success``, ``time``, ``energy``, ... (may be
        empty)."""
        import pandas as pd

        g = self._by.get((world, label))
        if g is None:
            return pd.DataFrame(columns=["success", "time", "energy"])
        out = pd.DataFrame(
            {
                "success": g["success"].fillna(False).astype(bool).to_numpy(),
                "time": g["uav_search_time"].to_numpy(float),
                "energy": g["movement_kj"].to_numpy(float),
                "hover": g["team_hover_time"].to_numpy(float),
                "turn": g["team_turn_time"].to_numpy(float),
                "distance": g["path_length"].to_numpy(float),
            },
            index=g["episode"].to_numpy(int),
        )
        return out.sort_index()

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
