"""Groups of robots around virtual leaders: paths over the plume, and an animation.

A group appears in a :class:`~odorloc.engine.recorder.Recording` as its agents' positions and
its leader's diagnostics ``vr_x<suffix>``, ``vr_y<suffix>`` (and ``declared<suffix>``), the
suffix being ``""`` for the first group of a ``per-group`` team and ``_<first agent>`` for the
others (:func:`groups_of`). Matplotlib is imported only by the functions that draw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.engine.recorder import Recording

__all__ = [
    "GROUP_COLORS",
    "GroupView",
    "animate_groups",
    "draw_groups",
    "groups_of",
    "leader_path",
    "panels_figure",
    "plume_image",
    "relative_paths",
]

GROUP_COLORS = ("tab:red", "tab:blue", "tab:green", "tab:orange")


@dataclass(frozen=True)
class GroupView:
    """How one group appears in a recording: its name, agents and diagnostics suffix."""

    name: str
    agents: tuple[int, ...]
    suffix: str


def groups_of(scenario: Any) -> list[GroupView]:
    """The groups of a scenario's ``agents.groups`` as they appear in its recordings."""
    return [
        GroupView(g.name or f"group{k}", tuple(g.agents), "" if k == 0 else f"_{g.agents[0]}")
        for k, g in enumerate(scenario.agents.groups)
    ]


def leader_path(rec: Recording, suffix: str) -> np.ndarray:
    """The leader's positions ``(N, 2)`` over the recording (empty when not recorded)."""
    vx = rec.diagnostics.get(f"vr_x{suffix}")
    vy = rec.diagnostics.get(f"vr_y{suffix}")
    if vx is None or vy is None:
        return np.zeros((0, 2))
    return np.column_stack([vx, vy])


def plume_image(ax: Any, rec: Recording, frame: int, floor: float) -> Any:
    """The plume frame ``frame`` on a log scale from ``floor`` (lower values transparent)."""
    from matplotlib import colors

    if not len(rec.plume_frames):
        return None
    b = rec.arena_bounds
    f = np.asarray(rec.plume_frames[frame], float)
    hi = max(float(np.nanmax(f)), 100 * floor)
    return ax.imshow(
        np.where(f > floor, f, np.nan).T,
        origin="lower",
        extent=(b[0, 0], b[1, 0], b[0, 1], b[1, 1]),
        cmap="viridis",
        norm=colors.LogNorm(vmin=floor, vmax=hi),
        alpha=0.8,
        zorder=1,
    )


def draw_groups(ax: Any, rec: Recording, groups: list[GroupView], title: str, floor: float) -> None:
    """Robot paths (one colour per group), leaders (+, large at the end), sources (*) and
    declarations (x) over the last recorded plume frame."""
    plume_image(ax, rec, len(rec.plume_frames) - 1, floor)
    for g, col in zip(groups, GROUP_COLORS, strict=False):
        for a in g.agents:
            p = rec.positions[:, a, :2]
            ax.plot(p[:, 0], p[:, 1], "-", color=col, lw=0.5, alpha=0.7, zorder=3)
            ax.plot(*p[-1], "o", color=col, mec="k", mew=0.4, ms=3.5, zorder=5)
        vr = leader_path(rec, g.suffix)
        if len(vr):
            step = max(1, len(vr) // 40)
            ax.plot(vr[::step, 0], vr[::step, 1], "+", color="k", ms=4, mew=0.8, zorder=4)
            ax.plot(*vr[-1], "+", color="k", ms=9, mew=1.6, zorder=6)
            ax.annotate(
                g.name, vr[0], color=col, fontsize=8, xytext=(4, 4), textcoords="offset points"
            )
    ax.plot(rec.sources[:, 0], rec.sources[:, 1], "*", color="gold", mec="k", ms=12, zorder=7)
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], "x", color="magenta", ms=9, mew=2, zorder=8)
    m = rec.meta
    ok = "all found" if m.get("success") else f"{int(m.get('sources_found', 0))} found"
    ax.set_title(f"{title}: {ok}, t = {float(m.get('search_time', math.nan)):.0f} s", fontsize=9)
    b = rec.arena_bounds
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)


def animate_groups(
    rec: Recording,
    groups: list[GroupView],
    path: Path,
    *,
    forbidden_radius: float,
    floor: float,
    body: float = 0.1,
    window: float = 3.0,
    max_frames: int = 120,
    fps: int = 8,
) -> Path:
    """GIF of the groups over the plume: the whole field (robots, leaders and their trails, the
    forbidden circle of a group once it has declared, sources) and a ``window`` m view following
    each of the first two leaders (robot bodies of radius ``body`` to scale)."""
    import matplotlib.pyplot as plt
    from matplotlib import animation
    from matplotlib.patches import Circle

    path = Path(path)
    half = 0.5 * window
    b = rec.arena_bounds
    fig = plt.figure(figsize=(9.6, 6.0))
    gs = fig.add_gridspec(2, 2, width_ratios=(2.0, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    zooms = [fig.add_subplot(gs[i, 1]) for i in range(len(groups[:2]))]
    images = [plume_image(a, rec, 0, floor) for a in (ax, *zooms)]
    if images[0] is not None:
        fig.colorbar(images[0], ax=ax, shrink=0.7, label="concentration")
    for a in (ax, *zooms):
        a.plot(rec.sources[:, 0], rec.sources[:, 1], "*", color="gold", mec="k", ms=13, zorder=7)
        a.set_aspect("equal")
        a.tick_params(labelsize=7)
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    robots, trails, leaders, circles, bodies, zleaders = [], [], [], [], [], []
    for k, (g, col) in enumerate(zip(groups, GROUP_COLORS, strict=False)):
        robots.append(
            ax.plot(
                [], [], "o", color=col, mec="k", mew=0.4, ms=4, zorder=6, label=f"group {g.name}"
            )[0]
        )
        trails.append(ax.plot([], [], "-", color=col, lw=0.8, alpha=0.8, zorder=4)[0])
        leaders.append(ax.plot([], [], "+", color="k", ms=8, mew=1.4, zorder=6)[0])
        c = Circle(
            (0, 0), forbidden_radius, fill=False, ec=col, ls="--", lw=1, visible=False, zorder=5
        )
        ax.add_patch(c)
        circles.append(c)
        if k < len(zooms):
            bodies.append(
                [
                    zooms[k].add_patch(Circle((0, 0), body, fc=col, ec="k", lw=0.5, zorder=6))
                    for _ in g.agents
                ]
            )
            zleaders.append(zooms[k].plot([], [], "+", color="k", ms=12, mew=2, zorder=7)[0])
            zooms[k].set_title(f"group {g.name}: {window:g} m window, robots to scale", fontsize=8)
    ax.legend(loc="upper right", fontsize=7)
    title = ax.set_title("", fontsize=9)
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))
    paths = [leader_path(rec, g.suffix) for g in groups]

    def draw(i: int) -> list[Any]:
        k = steps[i]
        t = rec.t[k]
        if images[0] is not None:
            f = max(int(np.searchsorted(rec.plume_t, t, side="right") - 1), 0)
            fr = np.asarray(rec.plume_frames[f], float)
            for im in images:
                im.set_data(np.where(fr > floor, fr, np.nan).T)
        for j, g in enumerate(groups):
            p = rec.positions[k, list(g.agents), :2]
            robots[j].set_data(p[:, 0], p[:, 1])
            vr = paths[j]
            if not len(vr):
                continue
            trails[j].set_data(vr[: k + 1, 0], vr[: k + 1, 1])
            leaders[j].set_data([vr[k, 0]], [vr[k, 1]])
            done = rec.diagnostics.get(f"declared{g.suffix}")
            if done is not None and done[k] > 0:
                circles[j].center = (vr[k, 0], vr[k, 1])
                circles[j].set_visible(True)
            if j < len(zooms):
                for patch, q in zip(bodies[j], p, strict=True):
                    patch.center = (q[0], q[1])
                zleaders[j].set_data([vr[k, 0]], [vr[k, 1]])
                zooms[j].set_xlim(vr[k, 0] - half, vr[k, 0] + half)
                zooms[j].set_ylim(vr[k, 1] - half, vr[k, 1] + half)
        title.set_text(f"t = {t:6.1f} s   (dashed: forbidden area of a group that has declared)")
        return [*robots, *trails, *leaders, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(steps), blit=False)
    anim.save(path, writer=animation.PillowWriter(fps=fps), dpi=72)
    plt.close(fig)
    return path


def panels_figure(
    recs: dict[str, Recording],
    groups: list[GroupView],
    titles: list[str],
    path: Path,
    *,
    title: str,
    floor: float,
) -> None:
    """One :func:`draw_groups` panel per title (three per row; "not stored" where
    ``recs`` has none)."""
    import matplotlib.pyplot as plt

    rows = math.ceil(len(titles) / 3)
    fig, axes = plt.subplots(rows, 3, figsize=(13, 4.3 * rows), squeeze=False)
    for ax, name in zip(axes.ravel(), titles, strict=False):
        if name in recs:
            draw_groups(ax, recs[name], groups, name, floor)
        else:
            ax.set_axis_off()
            ax.set_title(f"{name}: not stored", fontsize=9)
    for ax in axes.ravel()[len(titles) :]:
        ax.set_axis_off()
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def relative_paths(
    recs: list[Recording], groups: list[GroupView], sources: np.ndarray, window: float
) -> list[tuple[int, np.ndarray]]:
    """Each leader's path relative to the source it ended nearest, from the first time it came
    within ``window`` m of it (along each axis): ``[(source index, (N, 2) offsets)]``."""
    out = []
    for rec in recs:
        for g in groups:
            vr = leader_path(rec, g.suffix)
            if not len(vr):
                continue
            i = int(np.argmin(np.linalg.norm(sources - vr[-1], axis=1)))
            rel = vr - sources[i]
            inside = np.flatnonzero(np.abs(rel).max(axis=1) <= window)
            if inside.size:
                out.append((i, rel[inside[0] :]))
    return out
