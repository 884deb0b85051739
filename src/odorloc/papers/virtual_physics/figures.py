"""Figures of the virtual-physics reproduction: paths (Figs. 5, 7, 9), search-time bars
(Figs. 6, 8, 10), the rule summary, the ablations and an animation of both formations."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation, colors

from odorloc.engine.recorder import Recording
from odorloc.experiments.stats import bootstrap_ci, wilson_interval
from odorloc.papers.virtual_physics import reference as ref

__all__ = [
    "ablation_figure",
    "animate_formations",
    "animation_recording",
    "kept_recordings",
    "paths_figure",
    "search_time_figure",
    "summary_figure",
]

SCENARIO = "virtual-physics-two-groups"
GROUP_COLORS = ("tab:red", "tab:blue")
FREQ_COLORS = {1: "tab:green", 2: "tab:orange", 3: "tab:purple"}
FREQ_NAMES = {1: "standard", 2: "twice", 3: "treble"}
RULES = ("chemotaxis", "anemotaxis", "fluxotaxis")
_RHO_T = 0.005


def _groups() -> list[tuple[str, list[int], str]]:
    """``(name, agents, diagnostics suffix)`` of the scenario's groups."""
    from odorloc.scenarios import get_scenario

    sc = get_scenario(SCENARIO)
    return [
        (g.name or f"group{k}", list(g.agents), "" if k == 0 else f"_{g.agents[0]}")
        for k, g in enumerate(sc.agents.groups)
    ]


def _episode0(df: Any, label: str, freq: int, start: str) -> Any:
    sel = df[
        (df["searcher"] == label)
        & (df["scenario.frequency"].astype(float) == float(freq))
        & (df["scenario.start_set"] == start)
        & (df["episode"] == 0)
    ]
    return sel.iloc[0] if len(sel) else None


def kept_recordings(df: Any, store: Any, freq: int) -> dict[str, dict[str, Recording]]:
    """Episode 0's recordings at frequency ``freq``: ``{label: {start: Recording}}``."""
    out: dict[str, dict[str, Recording]] = {}
    for label in sorted(set(df["searcher"])):
        for start in ref.START_SETS:
            row = _episode0(df, label, freq, start)
            if row is None:
                continue
            arrays = store.arrays(str(row.cell_id), 0)
            if arrays is None:
                continue
            out.setdefault(label, {})[start] = Recording.from_arrays(arrays)
    return out


def animation_recording(df: Any, store: Any, label: str, start: str, freq: int) -> Recording | None:
    """The recording of the animated episode (episode 0 of one cell), if stored."""
    row = _episode0(df, label, freq, start)
    if row is None:
        return None
    arrays = store.arrays(str(row.cell_id), 0)
    return None if arrays is None else Recording.from_arrays(arrays)


def _plume_image(ax: Any, rec: Recording, frame: int) -> Any:
    b = rec.arena_bounds
    if not len(rec.plume_frames):
        return None
    f = np.asarray(rec.plume_frames[frame], float)
    hi = max(float(np.nanmax(f)), 10 * _RHO_T)
    norm = colors.LogNorm(vmin=_RHO_T / 10, vmax=hi)
    return ax.imshow(
        np.where(f > _RHO_T / 10, f, np.nan).T,
        origin="lower",
        extent=(b[0, 0], b[1, 0], b[0, 1], b[1, 1]),
        cmap="viridis",
        norm=norm,
        alpha=0.8,
        zorder=1,
    )


def _vr(rec: Recording, suffix: str) -> np.ndarray:
    vx = rec.diagnostics.get(f"vr_x{suffix}")
    vy = rec.diagnostics.get(f"vr_y{suffix}")
    if vx is None or vy is None:
        return np.zeros((0, 2))
    return np.column_stack([vx, vy])


def _draw_episode(ax: Any, rec: Recording, title: str) -> None:
    frame = len(rec.plume_frames) - 1
    _plume_image(ax, rec, frame)
    for (name, agents, suffix), col in zip(_groups(), GROUP_COLORS, strict=False):
        for a in agents:
            p = rec.positions[:, a, :2]
            ax.plot(p[:, 0], p[:, 1], "-", color=col, lw=0.5, alpha=0.7, zorder=3)
            ax.plot(*p[-1], "o", color=col, mec="k", mew=0.4, ms=3.5, zorder=5)
        vr = _vr(rec, suffix)
        if len(vr):
            step = max(1, len(vr) // 40)
            ax.plot(vr[::step, 0], vr[::step, 1], "+", color="k", ms=4, mew=0.8, zorder=4)
            ax.plot(*vr[-1], "+", color="k", ms=9, mew=1.6, zorder=6)
            ax.annotate(
                name, vr[0], color=col, fontsize=8, xytext=(4, 4), textcoords="offset points"
            )
    ax.plot(rec.sources[:, 0], rec.sources[:, 1], "*", color="gold", mec="k", ms=12, zorder=7)
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], "x", color="magenta", ms=9, mew=2, zorder=8)
    m = rec.meta
    ok = "both found" if m.get("success") else f"{int(m.get('sources_found', 0))} found"
    ax.set_title(f"{title}: {ok}, t = {float(m.get('search_time', math.nan)):.0f} s", fontsize=9)
    b = rec.arena_bounds
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)


def paths_figure(recs: dict[str, Recording], label: str, path: Path) -> None:
    """Six panels (P1-P6): both groups' robot paths, virtual robots (+), sources (stars),
    declared positions (x) over the last recorded plume frame."""
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.6))
    for ax, start in zip(axes.ravel(), ref.START_SETS, strict=True):
        rec = recs.get(start)
        if rec is None:
            ax.set_axis_off()
            ax.set_title(f"{start}: not stored", fontsize=9)
            continue
        _draw_episode(ax, rec, start)
    fig.suptitle(
        f"{label}, treble frequency, episode 0\nrobots (o, red group A, blue group B), virtual "
        "robots (+), sources (*), declarations (x); plume at the last frame (log, from rho_T/10)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _cell(df: Any, label: str, freq: int | None = None, start: str | None = None) -> Any:
    g = df[df["searcher"] == label]
    if "status" in g:
        g = g[g["status"] != "error"]
    if freq is not None:
        g = g[g["scenario.frequency"].astype(float) == float(freq)]
    if start is not None:
        g = g[g["scenario.start_set"] == start]
    return g


def _mean_ci(t: np.ndarray, seed: int) -> tuple[float, float, float]:
    t = t[np.isfinite(t)]
    if t.size == 0:
        return math.nan, math.nan, math.nan
    lo, hi = bootstrap_ci(t, np.random.default_rng(seed), "mean", 0.95, 2000)
    return float(t.mean()), lo, hi


def _err(c: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.nan_to_num(np.vstack([np.maximum(c - lo, 0), np.maximum(hi - c, 0)]))


def _bars(ax: Any, df: Any, label: str, col: str, which: str, seed: int) -> float:
    """Grouped bars (one per frequency) of the mean of ``col`` per start over the episodes
    selected by ``which`` ("success" or "found"); returns the top of the drawing."""
    starts = list(ref.START_SETS)
    w = 0.26
    top = 0.0
    for j, f in enumerate((1, 2, 3)):
        c, lo, hi, txt = [], [], [], []
        for s in starts:
            g = _cell(df, label, f, s)
            if which == "success":
                sel = g[g["success"].fillna(False).astype(bool)]
            else:
                sel = g[np.isfinite(g[col].to_numpy(float))] if col in g else g.iloc[:0]
            m, a, b = _mean_ci(sel[col].to_numpy(float) if len(sel) else np.zeros(0), seed)
            c.append(m)
            lo.append(a)
            hi.append(b)
            txt.append(f"{len(sel)}/{len(g)}")
        c_, lo_, hi_ = (np.array(v, float) for v in (c, lo, hi))
        x = np.arange(len(starts)) + (j - 1) * w
        ax.bar(x, np.nan_to_num(c_), w, color=FREQ_COLORS[f], label=FREQ_NAMES[f])
        ax.errorbar(
            x,
            np.nan_to_num(c_),
            yerr=_err(c_, lo_, hi_),
            fmt="none",
            ecolor="k",
            capsize=2,
            lw=0.8,
        )
        for xi, ci, hi_i, t in zip(x, c_, hi_, txt, strict=True):
            y = hi_i if np.isfinite(hi_i) else (ci if np.isfinite(ci) else 0.0)
            ax.text(xi, y + 8, t, ha="center", va="bottom", fontsize=6.5)
            top = max(top, y)
    ax.set_xticks(np.arange(len(starts)), starts)
    ax.grid(axis="y", alpha=0.3)
    return top


def search_time_figure(df: Any, label: str, path: Path, seed: int) -> None:
    """Top: mean time to find both sources per start, one bar per frequency (successful
    episodes, 95 % bootstrap intervals, successes/n above); the paper's quoted values as stars.
    Bottom: mean time the first source was found (episodes that found one)."""
    starts = list(ref.START_SETS)
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.6), sharex=True)
    top = _bars(axes[0], df, label, "search_time", "success", seed)
    w = 0.26
    if label == "chemotaxis":
        xs = np.arange(len(starts)) + w
        ys = [ref.CHEMOTAXIS_TREBLE_BY_START[s] for s in starts]
        axes[0].plot(xs, ys, "k*", ms=9, label="paper, treble (Sec. 3.1)")
        top = max(top, max(ys))
    elif label in ("anemotaxis", "fluxotaxis"):
        xs = [i for i, s in enumerate(starts) if s in ref.ANEMOTAXIS_BY_START]
        ys = [ref.ANEMOTAXIS_BY_START[starts[i]] for i in xs]
        axes[0].plot(xs, ys, "k*", ms=9, label="paper, anemotaxis (Sec. 3.2)")
        axes[0].plot([starts.index("P4")], [30], "kx", ms=9, mew=2, label="paper anem.: fails")
        top = max(top, max(ys))
    axes[0].set_ylim(0, top * 1.15 + 40)
    axes[0].set_ylabel("both sources found (s)")
    axes[0].set_title(
        f"{label}: mean time of the episodes that found both sources (successes/n above)",
        fontsize=10,
    )
    axes[0].legend(fontsize=7.5, ncol=3)
    top = _bars(axes[1], df, label, "first_found", "found", seed)
    axes[1].set_ylim(0, top * 1.15 + 40)
    axes[1].set_ylabel("first source found (s)")
    axes[1].set_title("time the first source was found (episodes that found one / n)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def summary_figure(df: Any, path: Path, seed: int) -> None:
    """Success rate (Wilson 95 %) and mean time (bootstrap 95 %) per rule and frequency."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    w = 0.26
    for j, f in enumerate((1, 2, 3)):
        sr, slo, shi, tm, tlo, thi = [], [], [], [], [], []
        for label in RULES:
            g = _cell(df, label, f)
            ok = g[g["success"].fillna(False).astype(bool)]
            n, k = len(g), len(ok)
            lo, hi = wilson_interval(k, n) if n else (math.nan, math.nan)
            sr.append(100 * k / n if n else math.nan)
            slo.append(100 * lo)
            shi.append(100 * hi)
            m, a, b = _mean_ci(ok["search_time"].to_numpy(float), seed)
            tm.append(m)
            tlo.append(a)
            thi.append(b)
        x = np.arange(len(RULES)) + (j - 1) * w
        for ax, c, lo, hi in ((axes[0], sr, slo, shi), (axes[1], tm, tlo, thi)):
            c_, lo_, hi_ = (np.array(v, float) for v in (c, lo, hi))
            ax.bar(x, np.nan_to_num(c_), w, color=FREQ_COLORS[f], label=FREQ_NAMES[f])
            ax.errorbar(
                x,
                np.nan_to_num(c_),
                yerr=_err(c_, lo_, hi_),
                fmt="none",
                ecolor="k",
                capsize=2,
                lw=0.8,
            )
    axes[0].plot([0 - w, 0, w], [100, 100, 100], "k*", ms=9, label="paper")
    axes[0].plot([1 - w, 1, 1 + w], [500 / 6] * 3, "k*", ms=9)
    axes[1].plot(
        [0 - w, 0 + w], [ref.CHEMOTAXIS_TIME[1], ref.CHEMOTAXIS_TIME[3]], "k*", ms=9, label="paper"
    )
    axes[1].plot(
        [0.6, 2.4], [ref.FAST_RULES_BOUND] * 2, "k--", lw=1, label="paper: anem./flux. below"
    )
    axes[0].set_ylabel("success rate, both sources (%)")
    axes[0].set_ylim(0, 110)
    axes[1].set_ylabel("mean time of successes (s)")
    for ax in axes:
        ax.set_xticks(np.arange(len(RULES)), RULES)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def ablation_figure(
    df: Any, path: Path, seed: int, variants: Sequence[str], same_reach: float
) -> None:
    """Success, different sources reached, both groups ending at one source (within
    ``same_reach`` m) and mean time per variant."""
    labels = [lab for lab in variants if len(_cell(df, lab))]
    fig, axes = plt.subplots(1, 4, figsize=(15, 4.2))
    cols = ("success", "reached_both", "same_source")
    names = (
        "both sources declared (%)",
        "groups reached different sources (%)",
        f"both groups ended within {same_reach:g} m of one source (%)",
    )
    y = np.arange(len(labels))
    for ax, col, name in zip(axes[:3], cols, names, strict=True):
        v, lo, hi = [], [], []
        for lab in labels:
            g = _cell(df, lab)
            k = int(g[col].fillna(False).astype(bool).sum()) if col in g else 0
            n = len(g)
            a, b = wilson_interval(k, n) if n else (math.nan, math.nan)
            v.append(100 * k / n if n else math.nan)
            lo.append(100 * a)
            hi.append(100 * b)
        c_, lo_, hi_ = (np.array(x, float) for x in (v, lo, hi))
        ax.barh(y, np.nan_to_num(c_), color="tab:gray")
        ax.errorbar(
            np.nan_to_num(c_), y, xerr=_err(c_, lo_, hi_), fmt="none", ecolor="k", capsize=2, lw=0.8
        )
        ax.set_xlim(0, 105)
        ax.set_title(name, fontsize=9)
    t, tlo, thi = [], [], []
    for lab in labels:
        g = _cell(df, lab)
        ok = g[g["success"].fillna(False).astype(bool)]
        m, a, b = _mean_ci(ok["search_time"].to_numpy(float), seed)
        t.append(m)
        tlo.append(a)
        thi.append(b)
    c_, lo_, hi_ = (np.array(x, float) for x in (t, tlo, thi))
    axes[3].barh(y, np.nan_to_num(c_), color="tab:gray")
    axes[3].errorbar(
        np.nan_to_num(c_), y, xerr=_err(c_, lo_, hi_), fmt="none", ecolor="k", capsize=2, lw=0.8
    )
    axes[3].set_title("mean time of successes (s)", fontsize=9)
    for k, ax in enumerate(axes):
        ax.set_yticks(y, labels if k == 0 else [""] * len(labels))
        ax.invert_yaxis()
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle("Ablations (all frequencies and starts pooled; 95 % intervals)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def animate_formations(rec: Recording, path: Path, max_frames: int = 120, fps: int = 8) -> Path:
    """GIF of both formations moving over the plume: the whole field (robots, virtual robots
    and their trails, the forbidden circle of a group once it has declared, sources) and a
    3 m window following each group's virtual robot (robot bodies to scale)."""
    from matplotlib.patches import Circle

    from odorloc.searchers.virtual_physics import VirtualPhysicsParams

    r_T = VirtualPhysicsParams().r_T
    body = 0.1
    half = 1.5
    path = Path(path)
    groups = _groups()
    b = rec.arena_bounds
    fig = plt.figure(figsize=(9.6, 6.0))
    gs = fig.add_gridspec(2, 2, width_ratios=(2.0, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    zooms = [fig.add_subplot(gs[i, 1]) for i in range(len(groups[:2]))]
    images = [_plume_image(a, rec, 0) for a in (ax, *zooms)]
    if images[0] is not None:
        fig.colorbar(images[0], ax=ax, shrink=0.7, label="concentration (kg/m^3)")
    for a in (ax, *zooms):
        a.plot(rec.sources[:, 0], rec.sources[:, 1], "*", color="gold", mec="k", ms=13, zorder=7)
        a.set_aspect("equal")
        a.tick_params(labelsize=7)
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    robots, trails, vrs, circles, bodies, zvr = [], [], [], [], [], []
    for g, ((name, agents, _), col) in enumerate(zip(groups, GROUP_COLORS, strict=False)):
        robots.append(
            ax.plot(
                [], [], "o", color=col, mec="k", mew=0.4, ms=4, zorder=6, label=f"group {name}"
            )[0]
        )
        trails.append(ax.plot([], [], "-", color=col, lw=0.8, alpha=0.8, zorder=4)[0])
        vrs.append(ax.plot([], [], "+", color="k", ms=8, mew=1.4, zorder=6)[0])
        c = Circle((0, 0), r_T, fill=False, ec=col, ls="--", lw=1, visible=False, zorder=5)
        ax.add_patch(c)
        circles.append(c)
        if g < len(zooms):
            bodies.append(
                [
                    zooms[g].add_patch(Circle((0, 0), body, fc=col, ec="k", lw=0.5, zorder=6))
                    for _ in agents
                ]
            )
            zvr.append(zooms[g].plot([], [], "+", color="k", ms=12, mew=2, zorder=7)[0])
            zooms[g].set_title(f"group {name}: 3 m window, robots to scale", fontsize=8)
    ax.legend(loc="upper right", fontsize=7)
    title = ax.set_title("", fontsize=9)
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))

    def draw(i: int) -> list[Any]:
        k = steps[i]
        t = rec.t[k]
        if images[0] is not None:
            f = max(int(np.searchsorted(rec.plume_t, t, side="right") - 1), 0)
            fr = np.asarray(rec.plume_frames[f], float)
            for im in images:
                im.set_data(np.where(fr > _RHO_T / 10, fr, np.nan).T)
        for g, (_, agents, suffix) in enumerate(groups):
            p = rec.positions[k, agents, :2]
            robots[g].set_data(p[:, 0], p[:, 1])
            vr = _vr(rec, suffix)
            if not len(vr):
                continue
            trails[g].set_data(vr[: k + 1, 0], vr[: k + 1, 1])
            vrs[g].set_data([vr[k, 0]], [vr[k, 1]])
            done = rec.diagnostics.get(f"declared{suffix}")
            if done is not None and done[k] > 0:
                circles[g].center = (vr[k, 0], vr[k, 1])
                circles[g].set_visible(True)
            if g < len(zooms):
                for patch, q in zip(bodies[g], p, strict=True):
                    patch.center = (q[0], q[1])
                zvr[g].set_data([vr[k, 0]], [vr[k, 1]])
                zooms[g].set_xlim(vr[k, 0] - half, vr[k, 0] + half)
                zooms[g].set_ylim(vr[k, 1] - half, vr[k, 1] + half)
        title.set_text(f"t = {t:6.1f} s   (dashed: forbidden area of a group that has declared)")
        return [*robots, *trails, *vrs, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(steps), blit=False)
    anim.save(path, writer=animation.PillowWriter(fps=fps), dpi=72)
    plt.close(fig)
    return path
