"""Figures of a reproduction's paired points (:class:`~odorloc.experiments.claims.Points`).

- :func:`sweep_figure`: mean time and success rate against a swept value, one line per method,
  95 % intervals (bootstrap, Wilson);
- :func:`success_time_figure`: success rate against time, one column per sweep, one row per
  method, one colour per swept value (and a second set of cells dashed, e.g. another world);
- :func:`comparison_figure`: success rate and mean time of every method at one point, one row
  per world;
- :func:`trace_figure`: a quantity against an iteration counter, mean and inter-quartile band
  over episodes, one line per variant (:mod:`~odorloc.experiments.traces`).

pyplot is imported inside each function (only drawing needs it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.experiments.claims import Points, summarize_point

__all__ = [
    "SUCCESS_YLIM",
    "comparison_figure",
    "success_curve",
    "success_time_figure",
    "sweep_figure",
    "trace_figure",
]

#: Limits of every success-rate axis, %: a little beyond 0-100 so that markers, bars and
#: interval ends at 0 % or 100 % are not cut by the frame.
SUCCESS_YLIM = (-2.0, 102.0)
_MARKERS = "osD^v<>ph*"


def success_curve(g: Any, times: np.ndarray) -> np.ndarray:
    """Fraction of the episodes ``g`` that succeeded within each of ``times`` (seconds)."""
    if len(g) == 0:
        return np.full(len(times), np.nan)
    t = np.sort(g.loc[g["success"].to_numpy(bool), "time"].to_numpy(float))
    return np.searchsorted(t, times, side="right") / len(g)


def sweep_figure(
    data: Points,
    values: Sequence[Any],
    point_of: Callable[[Any], Hashable],
    methods: Sequence[str],
    path: Path,
    seed: int,
    title: str,
    xlabel: str,
    names: Mapping[str, str],
    colors: Mapping[str, str],
    ticks: Callable[[Any], str] | None = None,
    limit: float = 1200.0,
) -> None:
    """Two panels against the swept value: mean time (failures at ``limit``) and success rate,
    one line per method, 95 % intervals. ``ticks`` makes the axis categorical."""
    import matplotlib.pyplot as plt

    fig, (ax_t, ax_s) = plt.subplots(1, 2, figsize=(11, 4.0))
    xs = np.arange(len(values), dtype=float) if ticks else np.array(values, float)
    span = (xs.max() - xs.min()) if len(xs) > 1 else 1.0
    n_min = math.inf
    for i, a in enumerate(methods):
        rng = np.random.default_rng([seed, 9, i])
        ps = [summarize_point(data.one(point_of(v), a), rng) for v in values]
        n_min = min([n_min, *(p.n for p in ps)])
        off = (i - (len(methods) - 1) / 2) * 0.012 * span
        for ax, v, lo, hi, scale in (
            (ax_t, "mst", "mst_lo", "mst_hi", 1.0),
            (ax_s, "sr", "sr_lo", "sr_hi", 100.0),
        ):
            y = np.array([getattr(p, v) for p in ps]) * scale
            err = np.array(
                [[getattr(p, v) - getattr(p, lo), getattr(p, hi) - getattr(p, v)] for p in ps]
            ).T
            ax.errorbar(
                xs + off,
                y,
                yerr=np.nan_to_num(np.maximum(err * scale, 0.0)),
                color=colors.get(a),
                marker=_MARKERS[i % len(_MARKERS)],
                ms=5,
                capsize=3,
                lw=1.4,
                label=names.get(a, a),
            )
    for ax in (ax_t, ax_s):
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
        if ticks:
            ax.set_xticks(xs, [ticks(v) for v in values])
        else:
            ax.set_xticks(xs)
    ax_t.set_ylabel(f"mean search time (s), failures at {limit / 60:g} min")
    ax_t.set_ylim(0, 1.04 * limit)
    ax_s.set_ylabel("success rate (%)")
    ax_s.set_ylim(*SUCCESS_YLIM)
    ax_s.legend(fontsize=8, loc="best")
    n = 0 if math.isinf(n_min) else int(n_min)
    fig.suptitle(f"{title} ({n} episodes per point, 95 % intervals)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def success_time_figure(
    data: Points,
    panels: Sequence[tuple[str, Sequence[Any], Callable[[Any], Hashable], Callable[[Any], str]]],
    methods: Sequence[str],
    names: Mapping[str, str],
    path: Path,
    title: str,
    compare: Points | None = None,
    at: float | None = None,
    limit: float = 1200.0,
) -> None:
    """Success rate against time: one column per panel ``(title, values, point_of, tick)``, one
    row per method, one colour per value; ``compare``'s cells dashed, a dotted line at ``at``
    seconds (left out at or beyond the time axis' end, ``limit``)."""
    import matplotlib.pyplot as plt

    times = np.linspace(0.0, limit, 241)
    mark = at if at is not None and at < limit else None
    fig, axes = plt.subplots(
        len(methods),
        len(panels),
        figsize=(3.3 * len(panels), 2.5 * len(methods) + 0.6),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    cmap = plt.get_cmap("viridis")
    n_min = math.inf
    for c, (head, values, point_of, tick) in enumerate(panels):
        shades = [cmap(0.9 * k / max(len(values) - 1, 1)) for k in range(len(values))]
        for r, a in enumerate(methods):
            ax = axes[r, c]
            for v, col in zip(values, shades, strict=True):
                g = data.one(point_of(v), a)
                n_min = min(n_min, len(g))
                ax.plot(times / 60, 100 * success_curve(g, times), color=col, lw=1.6, label=tick(v))
                if compare is not None:
                    h = compare.one(point_of(v), a)
                    ax.plot(times / 60, 100 * success_curve(h, times), color=col, lw=1.0, ls="--")
            if mark is not None:
                ax.axvline(mark / 60, color="0.5", ls=":", lw=1)
            ax.grid(alpha=0.3)
            if c == 0:
                ax.set_ylabel(f"{names.get(a, a)}\nsuccess (%)")
            if r == len(methods) - 1:
                ax.set_xlabel("time (min)")
            if r == 0:
                ax.set_title(head, fontsize=9)
                ax.legend(fontsize=7, loc="upper left", handlelength=1.2)
    axes[0, 0].set_ylim(*SUCCESS_YLIM)
    axes[0, 0].set_xlim(0, limit / 60)
    n = 0 if math.isinf(n_min) else int(n_min)
    note = "; dashed: compared world" if compare is not None else ""
    if mark is not None:
        note += f"; dotted: {mark / 60:g} min"
    fig.suptitle(f"{title} ({n} episodes per curve{note})", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def comparison_figure(
    rows: Sequence[tuple[str, Points, Hashable]],
    entries: Sequence[tuple[str, str, str]],
    path: Path,
    seed: int,
    title: str,
    limit: float = 1200.0,
) -> None:
    """Success rate and mean time of every entry ``(method, name, colour)`` at one point, one
    row of panels per ``(title, points, point)``."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 3.6 * len(rows)), squeeze=False)
    for r, (head, data, point) in enumerate(rows):
        names, cols, summaries = [], [], []
        for i, (method, name, colour) in enumerate(entries):
            p = summarize_point(data.one(point, method), np.random.default_rng([seed, 3, i]))
            if p.n:
                names.append(name)
                cols.append(colour)
                summaries.append(p)
        x = np.arange(len(names))
        for ax, v, lo, hi, scale, lab in (
            (axes[r, 0], "sr", "sr_lo", "sr_hi", 100.0, "success rate (%)"),
            (axes[r, 1], "mst", "mst_lo", "mst_hi", 1.0, "mean search time (s)"),
        ):
            y = np.array([getattr(p, v) for p in summaries]) * scale
            err = (
                np.array(
                    [
                        [getattr(p, v) - getattr(p, lo), getattr(p, hi) - getattr(p, v)]
                        for p in summaries
                    ]
                )
                .reshape(-1, 2)
                .T
            )
            ax.bar(x, y, color=cols)
            ax.errorbar(
                x,
                y,
                yerr=np.nan_to_num(np.maximum(err * scale, 0.0)),
                fmt="none",
                ecolor="k",
                capsize=4,
            )
            ax.set_xticks(x, names, fontsize=8)
            ax.set_ylabel(lab)
            ax.grid(axis="y", alpha=0.3)
            ax.set_title(f"{head} ({summaries[0].n if summaries else 0} episodes each)", fontsize=9)
        axes[r, 0].set_ylim(*SUCCESS_YLIM)
        axes[r, 1].set_ylim(0, 1.04 * limit)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def trace_figure(
    traces: Mapping[str, Sequence[np.ndarray]],
    path: Path,
    title: str,
    xlabel: str,
    ylabel: str,
    colors: Mapping[str, str] | None = None,
    lines: Mapping[str, float] | None = None,
    min_traces: int = 3,
) -> None:
    """Mean (line) and inter-quartile range (band) over traces of a quantity against their
    index, one line per label; an index is drawn while at least ``min_traces`` traces reach it.
    ``lines``: horizontal reference lines ``{label: y}``."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 4.2))
    for label, runs in traces.items():
        if not runs:
            continue
        length = max(len(r) for r in runs)
        stack = np.full((len(runs), length), np.nan)
        for i, r in enumerate(runs):
            stack[i, : len(r)] = r
        alive = np.sum(~np.isnan(stack), axis=0)
        keep = np.flatnonzero(alive >= min(min_traces, len(runs)))
        if not len(keep):
            continue
        stop = keep[-1] + 1
        k = np.arange(1, stop + 1)
        with np.errstate(all="ignore"):
            mean = np.nanmean(stack[:, :stop], axis=0)
            q1, q3 = np.nanquantile(stack[:, :stop], [0.25, 0.75], axis=0)
        colour = (colors or {}).get(label)
        ax.plot(k, mean, color=colour, lw=1.8, label=f"{label} ({len(runs)} traces)")
        ax.fill_between(k, q1, q3, color=colour, alpha=0.18, lw=0)
    for name, y in (lines or {}).items():
        ax.axhline(y, color="0.3", ls=":", lw=1)
        ax.annotate(
            name,
            (1.0, y),
            xycoords=("axes fraction", "data"),
            xytext=(-4, -11),
            textcoords="offset points",
            ha="right",
            fontsize=8,
            color="0.3",
        )
    lo, hi = ax.get_ylim()
    ys = [lo, hi, *(lines or {}).values()]
    pad = 0.04 * (max(ys) - min(ys))
    ax.set_ylim(min(ys) - pad, max(ys) + pad)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
