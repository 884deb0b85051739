"""Figures of the virtual-physics reproduction: paths (Figs. 5, 7, 9), search-time bars (Figs. 6,
8, 10), the variants, an animation, the plume beside the closed form (pyplot: where it draws)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.engine.recorder import Recording
from odorloc.experiments.cells import stat_interval
from odorloc.papers.virtual_physics import reference as ref
from odorloc.viz.formations import GroupView, animate_groups, groups_of, panels_figure
from odorloc.viz.sweeps import grouped_bars

__all__ = [
    "ablation_figure",
    "animate_formations",
    "paths_figure",
    "plume_check_figure",
    "search_time_figure",
]

SCENARIO = "virtual-physics-two-groups"
FREQ_COLORS = {1: "tab:green", 2: "tab:orange", 3: "tab:purple"}
FREQ_NAMES = {1: "standard", 2: "twice", 3: "treble"}
RULES = ("chemotaxis", "anemotaxis", "fluxotaxis")
#: Plume drawn from a tenth of rho_T up.
_FLOOR = 0.0005


def groups() -> list[GroupView]:
    from odorloc.scenarios import get_scenario

    return groups_of(get_scenario(SCENARIO))


def paths_figure(recs: dict[str, Recording], label: str, path: Path) -> None:
    """Six panels (P1-P6): both groups' robot paths, virtual robots (+), sources (stars),
    declared positions (x) over the last recorded plume frame."""
    title = (
        f"{label}, treble frequency, episode 0\nrobots (o, red group A, blue group B), virtual "
        "robots (+), sources (*), declarations (x); plume at the last frame (log, from rho_T/10)"
    )
    panels_figure(recs, groups(), list(ref.START_SETS), path, title=title, floor=_FLOOR)


def select(df: Any, label: str, freq: int | None = None, start: str | None = None) -> Any:
    """The rows of one variant (and frequency, start) that did not fail to run."""
    g = df[(df["searcher"] == label) & (df["status"] != "error")]
    if freq is not None:
        g = g[g["scenario.frequency"].astype(float) == float(freq)]
    return g if start is None else g[g["scenario.start_set"] == start]


def _stat(stat: tuple[str, ...], seed: int) -> Any:
    return lambda rows: stat_interval(rows, stat, seed)


def _freqs() -> dict[int, tuple[str, str]]:
    return {f: (FREQ_NAMES[f], FREQ_COLORS[f]) for f in FREQ_NAMES}


def search_time_figure(df: Any, label: str, path: Path, *, seed: int) -> None:
    """Top: mean time to find both sources per start, one bar per frequency (successful
    episodes, 95 % bootstrap intervals, successes/n above); the paper's quoted values as stars.
    Bottom: mean time the first source was found (episodes that found one)."""
    import matplotlib.pyplot as plt

    starts = list(ref.START_SETS)
    cells = {(s, f): select(df, label, f, s) for s in starts for f in FREQ_NAMES}
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.6), sharex=True)
    times = _stat(("mean", "search_time", "success"), seed)
    top = grouped_bars(axes[0], cells, starts, _freqs(), times, annotate=True)
    if label == "chemotaxis":
        ys = [ref.CHEMOTAXIS_TREBLE_BY_START[s] for s in starts]
        axes[0].plot(np.arange(6) + 0.27, ys, "k*", ms=9, label="paper, treble (Sec. 3.1)")
    else:
        xs = [i for i, s in enumerate(starts) if s in ref.ANEMOTAXIS_BY_START]
        ys = [ref.ANEMOTAXIS_BY_START[starts[i]] for i in xs]
        axes[0].plot(xs, ys, "k*", ms=9, label="paper, anemotaxis (Sec. 3.2)")
        axes[0].plot([starts.index("P4")], [30], "kx", ms=9, mew=2, label="paper anem.: fails")
    axes[0].set_ylim(0, max(top, *ys) * 1.15 + 40)
    axes[0].set_ylabel("both sources found (s)")
    axes[0].set_title(f"{label}: mean time of the episodes that found both", fontsize=10)
    axes[0].legend(fontsize=7.5, ncol=3)
    first = _stat(("mean", "first_found"), seed)
    top = grouped_bars(axes[1], cells, starts, _freqs(), first, annotate=True)
    axes[1].set_ylim(0, top * 1.15 + 40)
    axes[1].set_ylabel("first source found (s)")
    axes[1].set_title("time the first source was found (episodes that found one / n)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def ablation_figure(df: Any, path: Path, seed: int, variants: Sequence[str], reach: float) -> None:
    """Success, different sources reached, both groups ending within ``reach`` m of one source
    and mean time, per variant."""
    import matplotlib.pyplot as plt

    labels = [lab for lab in variants if len(select(df, lab))]
    cells = {(lab, 0): select(df, lab) for lab in labels}
    fig, axes = plt.subplots(1, 4, figsize=(15, 4.6))
    stats = [("rate", "success"), ("rate", "reached_both"), ("rate", "same_source")]
    stats.append(("mean", "search_time", "success"))
    names = ["both sources declared (%)", "groups reached different sources (%)"]
    names += [f"both ended within {reach:g} m of one source (%)", "mean time of successes (s)"]
    for k, (ax, stat, name) in enumerate(zip(axes, stats, names, strict=True)):
        grouped_bars(ax, cells, labels, {0: ("", "tab:gray")}, _stat(stat, seed), horizontal=True)
        ax.set_title(name, fontsize=9)
        ax.invert_yaxis()
        if k:
            ax.set_yticklabels([])
    fig.suptitle(
        "Readings and ablations (all frequencies and starts pooled; 95 % intervals)", fontsize=10
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def animate_formations(rec: Recording, path: Path) -> Path:
    """GIF of both formations over the plume (:func:`~odorloc.viz.formations.animate_groups`),
    with the forbidden circle of the searcher's defaults."""
    from odorloc.searchers.virtual_physics import VirtualPhysicsParams

    r_T = VirtualPhysicsParams().r_T
    return animate_groups(rec, groups(), path, forbidden_radius=r_T, floor=_FLOOR)


def plume_check_figure(check: dict[str, Any], path: Path) -> None:
    """Concentration along the wind through the upwind source (inflow boundary, robots at
    +-0.3 m dotted) and across it 0.3 m downwind: the Eulerian plume (inflow at the arena edge,
    and moved upwind) beside the closed-form solution with ``D`` and with ``D + U h / 2``."""
    from odorloc.viz.fields import profiles_figure

    labels = [
        "Eulerian, inflow at x = 0",
        "Eulerian, inflow 4 m further upwind",
        f"closed form, D = {check['D']:g}",
        f"closed form, D along the wind = {check['D_along']:g}",
    ]
    xs, along = check["profiles"]["x"]
    ys, across = check["profiles"]["y"]
    panels = [
        (xs, along, "distance downwind of the source (m)"),
        (ys, across, "cross-wind offset 0.3 m downwind of the source (m)"),
    ]
    marks = [[-float(check["source"][0]), -0.3, 0.3], []]
    title = "Steady plume of the mean inflow around the upwind source (concentration, kg/m^3)"
    profiles_figure(panels, labels, path, title=title, marks=marks)
