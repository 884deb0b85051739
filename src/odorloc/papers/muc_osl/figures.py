"""Figures of the multi-UAV reproduction: the sweeps (Figs. 4-7), success against time (Fig. 9),
the comparison at the default setting, and Fig. 3 (one MUC-OSL episode in 3-D)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.papers.muc_osl.analysis import Cells, summarize_point
from odorloc.papers.muc_osl.reference import ALGORITHMS
from odorloc.papers.muc_osl.sweeps import DEFAULT, SweepDef, cell_of

__all__ = [
    "COLORS",
    "LABELS",
    "SUCCESS_YLIM",
    "comparison_figure",
    "success_curve",
    "success_time_figure",
    "sweep_figure",
]

LABELS = {"muc-osl": "MUC-OSL", "col-inf": "Col-Inf", "col-pf": "Col-PF", "adap-pp": "Adap-PP"}
COLORS = {
    "muc-osl": "tab:red",
    "col-inf": "tab:blue",
    "col-pf": "tab:green",
    "adap-pp": "tab:orange",
}
_MARKERS = {"muc-osl": "o", "col-inf": "s", "col-pf": "^", "adap-pp": "D"}
#: Limits of every success-rate axis, %: a little beyond 0-100 so that markers, bars and
#: interval ends at 0 % or 100 % are not cut by the frame.
SUCCESS_YLIM = (-2.0, 102.0)


def success_curve(g: Any, times: np.ndarray) -> np.ndarray:
    """Fraction of the episodes ``g`` that succeeded within each of ``times`` (seconds)."""
    if len(g) == 0:
        return np.full(len(times), np.nan)
    t = np.sort(g.loc[g["success"].to_numpy(bool), "time"].to_numpy(float))
    return np.searchsorted(t, times, side="right") / len(g)


def sweep_figure(
    cells: Cells,
    scenario: str,
    sweep: SweepDef,
    path: Path,
    seed: int,
    title: str,
    algorithms: Sequence[str] = ALGORITHMS,
    limit: float = 1200.0,
) -> None:
    """Two panels against the swept value: mean search time and success rate, one line per
    algorithm, 95 % intervals (bootstrap, Wilson)."""
    import matplotlib.pyplot as plt

    fig, (ax_t, ax_s) = plt.subplots(1, 2, figsize=(11, 4.0))
    categorical = sweep.key == "area"
    xs = np.arange(len(sweep.values), dtype=float) if categorical else np.array(sweep.values, float)
    span = (xs.max() - xs.min()) if len(xs) > 1 else 1.0
    n_min = math.inf
    for i, a in enumerate(algorithms):
        rng = np.random.default_rng([seed, 9, i])
        ps = [summarize_point(cells.get(*cell_of(scenario, s, a)), rng) for s in sweep.settings()]
        n_min = min([n_min, *(p.n for p in ps)])
        off = (i - (len(algorithms) - 1) / 2) * 0.012 * span
        for ax, v, lo, hi, scale in (
            (ax_t, "mst", "mst_lo", "mst_hi", 1.0),
            (ax_s, "sr", "sr_lo", "sr_hi", 100.0),
        ):
            y = np.array([getattr(p, v) for p in ps]) * scale
            err = (
                np.array(
                    [[getattr(p, v) - getattr(p, lo), getattr(p, hi) - getattr(p, v)] for p in ps]
                ).T
                * scale
            )
            ax.errorbar(
                xs + off,
                y,
                yerr=np.nan_to_num(np.maximum(err, 0.0)),
                color=COLORS.get(a),
                marker=_MARKERS.get(a, "o"),
                ms=5,
                capsize=3,
                lw=1.4,
                label=LABELS.get(a, a),
            )
    for ax in (ax_t, ax_s):
        ax.set_xlabel(sweep.xlabel)
        ax.grid(alpha=0.3)
        if categorical:
            ax.set_xticks(xs, [sweep.tick(v) for v in sweep.values])
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
    cells: Cells,
    scenario: str,
    sweeps: Sequence[SweepDef],
    path: Path,
    compare: str | None = None,
    at: float | None = 480.0,
    limit: float = 1200.0,
    algorithms: Sequence[str] = ALGORITHMS,
) -> None:
    """Fig. 9: success rate against time, one column per sweep, one row per algorithm, one
    colour per setting; solid in ``scenario``'s world, dashed in ``compare``'s (the rate
    world), a dotted line at ``at`` seconds (the paper's 8 minutes).

    The time axis runs to the episode ``limit`` (s); a mark at or beyond it (a run with a
    limit shorter than 8 minutes) would be off the axis or on its end, so it is left out, with
    its mention in the title."""
    import matplotlib.pyplot as plt

    times = np.linspace(0.0, limit, 241)
    mark = at if at is not None and at < limit else None
    fig, axes = plt.subplots(
        len(algorithms),
        len(sweeps),
        figsize=(3.3 * len(sweeps), 2.5 * len(algorithms) + 0.6),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    cmap = plt.get_cmap("viridis")
    n_min = math.inf
    for c, sw in enumerate(sweeps):
        colors = [cmap(0.9 * k / max(len(sw.values) - 1, 1)) for k in range(len(sw.values))]
        for r, a in enumerate(algorithms):
            ax = axes[r, c]
            for v, col in zip(sw.values, colors, strict=True):
                s = sw.setting(v)
                g = cells.get(*cell_of(scenario, s, a))
                n_min = min(n_min, len(g))
                ax.plot(
                    times / 60, 100 * success_curve(g, times), color=col, lw=1.6, label=sw.tick(v)
                )
                if compare is not None:
                    h = cells.get(*cell_of(compare, s, a))
                    ax.plot(times / 60, 100 * success_curve(h, times), color=col, lw=1.0, ls="--")
            if mark is not None:
                ax.axvline(mark / 60, color="0.5", ls=":", lw=1)
            ax.grid(alpha=0.3)
            if c == 0:
                ax.set_ylabel(f"{LABELS.get(a, a)}\nsuccess (%)")
            if r == len(algorithms) - 1:
                ax.set_xlabel("time (min)")
            if r == 0:
                ax.set_title(f"{sw.figure.replace('Fig.', 'cf. Fig.')}: {sw.xlabel}", fontsize=9)
                ax.legend(fontsize=7, loc="upper left", title_fontsize=7, handlelength=1.2)
    axes[0, 0].set_ylim(*SUCCESS_YLIM)
    axes[0, 0].set_xlim(0, limit / 60)
    n = 0 if math.isinf(n_min) else int(n_min)
    note = "; dashed: rate world" if compare is not None else ""
    if mark is not None:
        note += f"; dotted: {mark / 60:g} min"
    fig.suptitle(
        f"Fig. 9: success rate against time in the filament world ({n} episodes per curve{note})",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def comparison_figure(
    cells: Cells,
    worlds: Sequence[tuple[str, str]],
    labels: dict[str, str],
    path: Path,
    seed: int,
    limit: float = 1200.0,
) -> None:
    """Success rate and mean search time of every algorithm (and ablation) at the default
    setting, one row per world ``(title, scenario)``."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(worlds), 2, figsize=(11, 3.6 * len(worlds)), squeeze=False)
    for r, (title, scenario) in enumerate(worlds):
        names, rows, cols = [], [], []
        for i, (key, text) in enumerate(labels.items()):
            world, label = cell_of(scenario, DEFAULT, key) if key in LABELS else (scenario, key)
            p = summarize_point(cells.get(world, label), np.random.default_rng([seed, 3, i]))
            if p.n == 0:
                continue
            names.append(text)
            rows.append(p)
            cols.append(COLORS.get(key, "0.6"))
        x = np.arange(len(names))
        for ax, v, lo, hi, scale, lab in (
            (axes[r, 0], "sr", "sr_lo", "sr_hi", 100.0, "success rate (%)"),
            (axes[r, 1], "mst", "mst_lo", "mst_hi", 1.0, "mean search time (s)"),
        ):
            y = np.array([getattr(p, v) for p in rows]) * scale
            err = (
                np.array(
                    [[getattr(p, v) - getattr(p, lo), getattr(p, hi) - getattr(p, v)] for p in rows]
                )
                .reshape(-1, 2)
                .T
                * scale
            )
            ax.bar(x, y, color=cols)
            ax.errorbar(
                x, y, yerr=np.nan_to_num(np.maximum(err, 0.0)), fmt="none", ecolor="k", capsize=4
            )
            ax.set_xticks(x, names, fontsize=8)
            ax.set_ylabel(lab)
            ax.grid(axis="y", alpha=0.3)
            ax.set_title(f"{title} ({rows[0].n if rows else 0} episodes each)", fontsize=9)
        axes[r, 0].set_ylim(*SUCCESS_YLIM)
        axes[r, 1].set_ylim(0, 1.04 * limit)
    fig.suptitle("Default setting: 3 UAVs in 100 x 60 x 30 m (95 % intervals)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
