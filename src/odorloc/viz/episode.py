"""Figures and animations of one recorded episode.

Everything here reads a :class:`~odorloc.engine.recorder.Recording`; nothing touches the
simulator, so the same functions draw live runs and runs loaded from disk.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import animation, colors, transforms
from matplotlib.axes import Axes
from matplotlib.legend_handler import HandlerTuple
from matplotlib.lines import Line2D

from odorloc.engine.recorder import Recording
from odorloc.viz.backend import pyplot

AGENT_COLORS = ["tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown"]

#: Particles coloured by weight: a grey ramp (light grey = lightest weight, black = heaviest),
#: so that no weight can be mistaken for an agent's colour or for the viridis plume.
PARTICLE_CMAP = colors.LinearSegmentedColormap.from_list("particle_weight", ["0.82", "0.0"])

#: The declared-source marker, the same in the still figures and the animations.
DECLARED_STYLE: dict[str, Any] = {
    "marker": "X",
    "linestyle": "",
    "color": "magenta",
    "mec": "k",
    "ms": 12,
    "zorder": 7,
    "label": "declared source",
}


def _agent_color(a: int) -> str:
    return AGENT_COLORS[a % len(AGENT_COLORS)]


def _weight_norm() -> colors.Normalize:
    """Weights divided by the largest one, on a fixed 0-1 scale: equal weights all read 1 (and
    the colour bar keeps its range) instead of an auto-scaled 0.9-1.1 bar."""
    return colors.Normalize(vmin=0.0, vmax=1.0)


def _relative_weights(snap: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Particle positions (first two axes) and weights over the largest, lightest first (so the
    heaviest particles are drawn on top)."""
    pts = np.asarray(snap["positions"], float)
    w = np.asarray(snap["weights"], float) if "weights" in snap else np.ones(len(pts))
    rel = w / max(float(w.max()), 1e-300) if len(w) else w
    order = np.argsort(rel, kind="stable")
    return pts[order, :2], rel[order]


def _agent_rgba(a: int, rel: np.ndarray) -> np.ndarray:
    """One agent's particles in that agent's colour, fainter than its path (and fainter still
    for lighter weights), so they read as its belief and not as robots."""
    rgb = 0.6 * np.asarray(colors.to_rgb(_agent_color(a))) + 0.4
    rgba = np.empty((len(rel), 4))
    rgba[:, :3] = rgb
    rgba[:, 3] = 0.35 + 0.45 * rel
    return rgba


def _colour_by_agent(rec: Recording, holder: int) -> bool:
    """Whether a belief held by ``holder`` is drawn in its agent's colour (one agent's belief in
    a team) rather than on the grey weight ramp (a single robot's, or a central belief)."""
    return rec.positions.shape[1] > 1 and holder >= 0


def _particle_holders(rec: Recording) -> list[int]:
    """Agents (``-1`` = central) with particle snapshots in the recording."""
    return sorted({int(s.get("agent", -1)) for _, s in rec.beliefs if "positions" in s})


def _particles_at(rec: Recording, t: float) -> dict[int, dict[str, np.ndarray]]:
    """The latest particle snapshot of each belief holder recorded at or before ``t``."""
    out: dict[int, dict[str, np.ndarray]] = {}
    for bt, snap in rec.beliefs:
        if bt <= t + 1e-9 and "positions" in snap:
            out[int(snap.get("agent", -1))] = snap
    return out


def _declarations(rec: Recording) -> list[tuple[float, np.ndarray]]:
    """Declared positions with the time each was declared, ``(t, (K, d))``.

    Times come from the recording's ``declaration`` events; a recording without them (a
    replayed log, or events not kept) gets its declared positions at ``inf``, i.e. shown from
    the last frame on.
    """
    out: list[tuple[float, np.ndarray]] = []
    for ev in rec.meta.get("events", None) or []:
        if (
            isinstance(ev, dict)
            and ev.get("kind") == "declaration"
            and ev.get("position") is not None
        ):
            pos = np.atleast_2d(np.asarray(ev["position"], float))
            out.append((float(ev.get("t", np.inf)), pos))
    if not out and len(rec.declared):
        out.append((float("inf"), np.atleast_2d(np.asarray(rec.declared, float))))
    return out


def _conc_norm(frames: np.ndarray) -> colors.Normalize:
    pos = frames[frames > 0]
    if pos.size == 0:
        return colors.Normalize(0, 1)
    hi = float(np.percentile(pos, 99.5))
    lo = max(hi * 1e-3, float(pos.min()))
    return colors.LogNorm(vmin=lo, vmax=max(hi, lo * 10))


def _draw_static(ax: Axes, rec: Recording) -> None:
    """Obstacles, sources and bounds."""
    b = rec.arena_bounds
    if rec.occupancy is not None:
        ax.imshow(
            np.ma.masked_where(~rec.occupancy.T, rec.occupancy.T),
            origin="lower",
            extent=(b[0, 0], b[1, 0], b[0, 1], b[1, 1]),
            cmap=colors.ListedColormap(["0.35"]),
            vmin=0,
            vmax=1,
            zorder=2,
            interpolation="nearest",
        )
    ax.plot(
        rec.sources[:, 0],
        rec.sources[:, 1],
        "*",
        color="gold",
        mec="k",
        ms=16,
        zorder=6,
        label="true source",
    )
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def _summary(rec: Recording) -> str:
    m = rec.meta
    parts = [str(m.get("scenario", ""))]
    if "searcher" in m:
        parts.append(str(m["searcher"]))
    ok = m.get("success")
    if ok is not None:
        parts.append("success" if ok else f"failure ({m.get('termination', '')})")
    if "search_time" in m:
        parts.append(f"t = {m['search_time']:.1f} s")
    le = m.get("loc_error")
    if le is not None and np.isfinite(le):
        parts.append(f"error = {le:.2f} m")
    return " | ".join(parts)


def plot_trajectory(rec: Recording, path: str | Path | None = None, ax: Axes | None = None) -> Any:
    """Trajectory over the time-averaged plume, with detections, start, declaration and source.

    Returns the figure (saved as PNG when ``path`` is given).
    """
    plt = pyplot()
    own = ax is None
    if ax is None:
        b = rec.arena_bounds
        w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
        fig, ax = plt.subplots(figsize=(7.5, max(3.5, min(9.0, 7.0 * h / max(w, 1e-9)))))
    fig = ax.figure
    b = rec.arena_bounds
    if len(rec.plume_frames):
        mean = rec.plume_frames.mean(axis=0)
        im = ax.imshow(
            np.where(mean > 0, mean, np.nan).T,
            origin="lower",
            extent=tuple(rec.plume_extent),
            cmap="viridis",
            norm=_conc_norm(mean),
            alpha=0.85,
            zorder=1,
        )
        fig.colorbar(im, ax=ax, shrink=0.8, label="time-averaged concentration")
    _draw_static(ax, rec)
    for a in range(rec.positions.shape[1]):
        col = AGENT_COLORS[a % len(AGENT_COLORS)]
        p = rec.positions[:, a, :]
        ax.plot(
            p[:, 0], p[:, 1], "-", color=col, lw=1.6, zorder=4, label="path" if a == 0 else None
        )
        ax.plot(
            p[0, 0],
            p[0, 1],
            "o",
            color=col,
            mec="k",
            ms=8,
            zorder=5,
            label="start" if a == 0 else None,
        )
        det = rec.detection[:, a]
        if det.any():
            ax.plot(
                p[det, 0],
                p[det, 1],
                ".",
                color="white",
                mec=col,
                ms=7,
                zorder=5,
                label="detection" if a == 0 else None,
            )
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], **DECLARED_STYLE)
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    ax.set_title(_summary(rec), fontsize=9)
    if own:
        fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def _agent_name(n_agents: int, a: int) -> str:
    return "robot" if n_agents == 1 else f"agent {a}"


def _particle_legend(rec: Recording, holders: list[int]) -> list[tuple[Any, str]]:
    """Legend entries for the particles of ``holders``.

    Scatter markers this small are nearly invisible in a legend, so bigger proxy markers stand
    in: three greys of the weight ramp, or one dot per agent in its particles' colour.
    """
    entries: list[tuple[Any, str]] = []
    if any(not _colour_by_agent(rec, h) for h in holders):
        ramp = tuple(
            Line2D([], [], ls="", marker="o", ms=5, color=PARTICLE_CMAP(v)) for v in (0.2, 0.6, 1.0)
        )
        entries.append((ramp, "belief (particles by weight, darker = heavier)"))
    agents = [h for h in holders if _colour_by_agent(rec, h)]
    if agents:
        dots = tuple(
            Line2D([], [], ls="", marker="o", ms=5, color=_agent_rgba(a, np.ones(1))[0])
            for a in agents
        )
        who = "each agent's" if len(agents) > 1 else f"agent {agents[0]}'s"
        entries.append((dots, f"{who} belief (particles, in its colour)"))
    return entries


def _legend_below(ax: Axes, entries: list[tuple[Any, str]], fontsize: float = 7) -> None:
    """A legend just under the axes' x label, where it cannot hide agents near the arena's
    edges; as many columns as fit the figure's width."""
    if not entries:
        return
    fig = ax.figure
    handles, labels = (list(v) for v in zip(*entries, strict=True))
    # Anchored to the axes (it follows them when an equal aspect shrinks them), a fixed
    # distance in points below their lower edge: clear of tick labels and the x label.
    anchor = transforms.offset_copy(ax.transAxes, fig=fig, y=-30, units="points")
    renderer = fig.canvas.get_renderer()
    fig_w = fig.get_window_extent(renderer).width
    for ncol in range(len(entries), 0, -1):
        leg = ax.legend(
            handles,
            labels,
            loc="upper center",
            bbox_to_anchor=(0.5, 0.0),
            bbox_transform=anchor,
            ncol=ncol,
            fontsize=fontsize,
            frameon=False,
            handler_map={tuple: HandlerTuple(ndivide=None)},
        )
        if leg.get_window_extent(renderer).width <= 0.98 * fig_w:
            break


def animate(
    rec: Recording,
    path: str | Path,
    *,
    fps: int = 10,
    max_frames: int = 150,
    dpi: int = 70,
) -> Path:
    """Animate plume, agents (with trails), belief and declarations.

    Particles of a single robot (or a central belief) are drawn on a grey ramp by weight; in a
    team each agent's particles are drawn, faded, in that agent's colour. A declared source
    appears, with the same marker as in :func:`plot_trajectory`, from the frame at which it was
    declared (from the last frame when the recording has no declaration events).

    Parameters
    ----------
    rec : Recording
        The episode.
    path : str or Path
        Output file: GIF, or MP4 when it ends in ``.mp4`` (needs ffmpeg).
    fps : int
        Frames per second.
    max_frames : int
        At most this many frames are drawn (recorded steps are subsampled evenly).
    dpi : int
        Resolution of the frames.

    Returns
    -------
    Path
        ``path``.
    """
    plt = pyplot()
    path = Path(path)
    b = rec.arena_bounds
    w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
    # Extra height for the legend under the axes.
    fig, ax = plt.subplots(figsize=(6.4, max(3.2, min(8.0, 6.0 * h / max(w, 1e-9))) + 0.4))
    norm = _conc_norm(rec.plume_frames) if len(rec.plume_frames) else colors.Normalize(0, 1)
    im = None
    if len(rec.plume_frames):
        im = ax.imshow(
            np.where(rec.plume_frames[0] > 0, rec.plume_frames[0], np.nan).T,
            origin="lower",
            extent=tuple(rec.plume_extent),
            cmap="viridis",
            norm=norm,
            zorder=1,
        )
        fig.colorbar(im, ax=ax, shrink=0.8, label="concentration")
    _draw_static(ax, rec)
    entries: list[tuple[Any, str]] = list(zip(*ax.get_legend_handles_labels(), strict=True))
    n_agents = rec.positions.shape[1]
    trails = [
        ax.plot([], [], "-", color=_agent_color(a), lw=1.4, zorder=4)[0] for a in range(n_agents)
    ]
    heads = [
        # Unclipped: an agent on the arena's edge stays a whole marker.
        ax.plot([], [], "o", color=_agent_color(a), mec="k", ms=8, zorder=6, clip_on=False)[0]
        for a in range(n_agents)
    ]
    holders = _particle_holders(rec)
    particles: dict[int, Any] = {}
    for hld in holders:
        if _colour_by_agent(rec, hld):
            particles[hld] = ax.scatter(np.zeros(0), np.zeros(0), s=8, lw=0, zorder=3)
        else:
            particles[hld] = ax.scatter(
                np.zeros(0), np.zeros(0), s=5, lw=0, c=np.zeros(0), cmap=PARTICLE_CMAP,
                norm=_weight_norm(), zorder=3,
            )  # fmt: skip
    declarations = _declarations(rec)
    (declared,) = ax.plot([], [], **DECLARED_STYLE)
    entries += [
        (
            Line2D([], [], color=_agent_color(a), lw=1.4, marker="o", mec="k", ms=6),
            _agent_name(n_agents, a),
        )
        for a in range(n_agents)
    ]
    entries += _particle_legend(rec, holders)
    if declarations:
        entries.append((declared, "declared source"))
    title = ax.set_title("t = 0.0 s", fontsize=9)
    _legend_below(ax, entries)
    fig.tight_layout()
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))
    last = len(rec.t) - 1

    def draw(i: int) -> list[Any]:
        k = steps[i]
        t = rec.t[k]
        if im is not None:
            f = int(np.searchsorted(rec.plume_t, t, side="right") - 1)
            f = max(f, 0)
            im.set_data(np.where(rec.plume_frames[f] > 0, rec.plume_frames[f], np.nan).T)
        for a in range(n_agents):
            p = rec.positions[: k + 1, a]
            trails[a].set_data(p[:, 0], p[:, 1])
            heads[a].set_data([p[-1, 0]], [p[-1, 1]])
        snaps = _particles_at(rec, t)
        for hld, sc in particles.items():
            snap = snaps.get(hld)
            if snap is None:
                sc.set_offsets(np.zeros((0, 2)))
                continue
            pts, rel = _relative_weights(snap)
            sc.set_offsets(pts)
            if _colour_by_agent(rec, hld):
                sc.set_facecolor(_agent_rgba(hld, rel))
            else:
                sc.set_array(rel)
        # A declaration made after the last recorded step still belongs on the last frame.
        shown = [pos for td, pos in declarations if td <= t + 1e-9 or k == last]
        if shown:
            xy = np.vstack(shown)
            declared.set_data(xy[:, 0], xy[:, 1])
        else:
            declared.set_data([], [])
        det = "  DETECT" if rec.detection[k].any() else ""
        title.set_text(f"t = {t:6.1f} s{det}")
        return [*trails, *heads, *particles.values(), declared, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(steps), blit=False)
    if path.suffix == ".mp4":
        anim.save(path, writer=animation.FFMpegWriter(fps=fps), dpi=dpi)
    else:
        anim.save(path, writer=animation.PillowWriter(fps=fps), dpi=dpi)
    plt.close(fig)
    return path


def ffmpeg_available() -> bool:
    """``True`` when an ``ffmpeg`` executable is on the PATH (for MP4 output)."""
    return shutil.which("ffmpeg") is not None


#: Diagnostics drawn by :func:`plot_traces`, in this order, when a searcher reports them.
TRACE_DIAGNOSTICS = {
    "entropy": "posterior entropy (nats)",
    "spread": "particle spread",
    "ess": "effective sample size",
    "uncertainty": "map uncertainty",
}


def plot_traces(rec: Recording, path: str | Path | None = None) -> Any:
    """Gas readings with detections, wind, and the searcher's key diagnostics over time.

    The wind panel shows agent 0's anemometer readings (world frame): the horizontal speed, and
    the direction the air moves towards, in degrees counter-clockwise from +x (so wind towards
    -y reads -90). Each diagnostic (entropy, spread, ESS, ...) gets its own axis.

    Parameters
    ----------
    rec : Recording
        The episode.
    path : str or Path, optional
        PNG to write.

    Returns
    -------
    Figure
    """
    plt = pyplot()
    diag = {
        k: v for k, v in rec.diagnostics.items() if k in TRACE_DIAGNOSTICS and np.isfinite(v).any()
    }
    n = 2 + len(diag)
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.9 * n + 0.6), sharex=True)
    t = rec.t
    ax = axes[0]
    n_agents = rec.gas.shape[1]
    for a in range(n_agents):
        ax.plot(t, rec.gas[:, a], lw=1, color=_agent_color(a), label=f"agent {a}")
        d = rec.detection[:, a]
        ax.plot(t[d], rec.gas[d, a], "|", color="k", ms=8)
    ax.set_ylabel("gas reading")
    ax.set_title("sensor readings (| = detection)", fontsize=9)
    if n_agents > 1:
        ax.legend(loc="upper right", fontsize=7, ncol=min(n_agents, 6), framealpha=0.85)
    ax = axes[1]
    wind = rec.wind[:, 0, :2]
    # Black and cyan: not the colour of any agent, so the panel is not read as agents 1 and 3.
    ax.plot(t, np.linalg.norm(wind, axis=1), color="k", lw=1)
    speed = "horizontal speed" if rec.wind.shape[2] == 3 else "speed"
    ax.set_ylabel(f"{speed} (m/s)", fontsize=8)
    ax2 = ax.twinx()
    ax2.plot(t, np.degrees(np.arctan2(wind[:, 1], wind[:, 0])), color="tab:cyan", lw=0.8)
    ax2.set_ylabel("towards (deg from +x)", color="tab:cyan", fontsize=8)
    who = "the robot" if n_agents == 1 else "agent 0"
    ax.set_title(
        f"wind at {who}: {speed} (black); direction the air moves towards, deg ccw from +x (cyan)",
        fontsize=9,
    )
    for ax, (k, v) in zip(axes[2:], diag.items(), strict=True):
        ax.plot(t[: len(v)], v, lw=1.2, color="tab:purple")
        ax.set_ylabel(TRACE_DIAGNOSTICS[k], fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def _grid_probabilities(snap: dict[str, np.ndarray]) -> tuple[np.ndarray, str] | None:
    """A grid snapshot's horizontal map and its colour-bar label, or ``None`` without a grid.

    A Dempster-Shafer map recorded without ``prob`` is drawn as its normalised source mass; a
    3-D grid is summed over height.
    """
    if "prob" in snap:
        p = np.asarray(snap["prob"], float)
        label = "belief (probability per cell)"
    elif "m_s" in snap:
        m = np.asarray(snap["m_s"], float)
        total = float(m.sum())
        p = m / total if total > 0 else np.full(m.shape, 1.0 / m.size)
        label = "belief (normalised source mass per cell)"
    else:
        return None
    return (p if p.ndim == 2 else p.sum(axis=2)), label


def _grid_extent(
    rec: Recording, snap: dict[str, np.ndarray], shape: tuple[int, ...]
) -> tuple[float, float, float, float] | None:
    """``(xmin, xmax, ymin, ymax)`` of a grid belief, or ``None`` when it cannot be known.

    Snapshots of replayed logs carry their extent (``lower``, ``upper``). Simulated episodes do
    not: their grid is taken to start at the arena's lower corner when square cells of one size
    give exactly ``shape`` cells over the arena (grids keep whole cells, so a strip narrower
    than a cell may be left at the upper edges). A grid over a smaller search region fails this
    test and is not drawn rather than drawn in the wrong place.
    """
    if "lower" in snap and "upper" in snap:
        lo, hi = np.asarray(snap["lower"], float), np.asarray(snap["upper"], float)
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
    b = np.asarray(rec.arena_bounds, float)
    size = b[1, :2] - b[0, :2]
    n = np.asarray(shape[:2], float)
    cell = float(np.min(size / n))
    if cell <= 0 or not np.all(np.floor(size / cell + 1e-9) == n):
        return None
    hi = b[0, :2] + n * cell
    return float(b[0, 0]), float(hi[0]), float(b[0, 1]), float(hi[1])


def plot_belief_map(
    rec: Recording, path: str | Path | None = None, index: int = -1, ax: Axes | None = None
) -> Any:
    """A belief snapshot (default: the last) over the map, with the paths and their detections.

    Every belief recorded at the snapshot's time is drawn: particles on a grey ramp by weight
    for a single robot or a central belief, each agent's particles in that agent's colour in a
    team; a grid belief as an image (one holder's: images would hide each other). The title
    says whose belief it is. When nothing can be drawn (no belief, or a grid whose extent is
    unknown) the axes say so.

    Parameters
    ----------
    rec : Recording
        The episode (simulated, or replayed from a log).
    path : str or Path, optional
        PNG to write.
    index : int
        Index into ``rec.beliefs`` of a snapshot; its time selects the beliefs drawn.
    ax : Axes, optional
        Axes to draw into (a new figure when omitted).

    Returns
    -------
    Figure
    """
    plt = pyplot()
    own = ax is None
    if ax is None:
        b = rec.arena_bounds
        w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
        fig, ax = plt.subplots(figsize=(7.5, max(3.5, min(9.0, 7.0 * h / max(w, 1e-9)))))
    fig = ax.figure
    n_agents = rec.positions.shape[1]
    if rec.beliefs:
        t = rec.beliefs[index][0]
        snaps = {int(s.get("agent", -1)): s for bt, s in rec.beliefs if bt == t}
    else:
        t, snaps = float("nan"), {}
    drawn: list[int] = []
    entries: list[tuple[Any, str]] = []
    note = None
    cloud = [hld for hld, s in snaps.items() if "positions" in s]
    grids = {hld: g for hld, s in snaps.items() if (g := _grid_probabilities(s)) is not None}
    if cloud:
        for hld in cloud:
            pts, rel = _relative_weights(snaps[hld])
            if _colour_by_agent(rec, hld):
                ax.scatter(pts[:, 0], pts[:, 1], s=8, lw=0, color=_agent_rgba(hld, rel), zorder=3)
            else:
                sc = ax.scatter(
                    pts[:, 0], pts[:, 1], c=rel, cmap=PARTICLE_CMAP, norm=_weight_norm(), s=6,
                    lw=0, zorder=3,
                )  # fmt: skip
                if not any(not _colour_by_agent(rec, d) for d in drawn):
                    fig.colorbar(sc, ax=ax, shrink=0.8, label="particle weight / largest weight")
            drawn.append(hld)
        entries = _particle_legend(rec, drawn)
    elif grids:
        hld, (p2, label) = next(iter(grids.items()))
        extent = _grid_extent(rec, snaps[hld], p2.shape)
        if extent is None:
            note = (
                "grid belief not drawn:\nits extent was not recorded\nand it does not fit the arena"
            )
        else:
            # From 0: a flat (e.g. uniform) map then reads as one level, not as noise.
            im = ax.imshow(
                np.where(p2 > 0, p2, np.nan).T, origin="lower", extent=extent, cmap="magma_r",
                norm=colors.Normalize(0.0, max(float(p2.max()), 1e-300)), zorder=1, alpha=0.9,
                interpolation="nearest",
            )  # fmt: skip
            fig.colorbar(im, ax=ax, shrink=0.8, label=label)
            drawn.append(hld)
    elif snaps:
        note = "the belief snapshot holds\nneither particles nor a grid"
    else:
        note = "no belief was recorded"
    _draw_static(ax, rec)
    for a in range(n_agents):
        col = _agent_color(a)
        p = rec.positions[:, a, :]
        ax.plot(p[:, 0], p[:, 1], "-", color=col, lw=1.2, zorder=4,
                label="path" if n_agents == 1 else f"agent {a}")  # fmt: skip
        det = rec.detection[:, a]
        if det.any():
            ax.plot(p[det, 0], p[det, 1], ".", color="white", mec=col, ms=6, zorder=5,
                    label="detection" if a == 0 else None)  # fmt: skip
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], **DECLARED_STYLE)
    if note is not None:
        ax.text(
            0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=10,
            zorder=10, bbox={"boxstyle": "round", "fc": "white", "ec": "0.6"},
        )  # fmt: skip
    handles, labels = ax.get_legend_handles_labels()
    for hd, lb in entries:
        handles.append(hd)
        labels.append(lb)
    ax.legend(handles, labels, loc="best", fontsize=8, framealpha=0.85,
              handler_map={tuple: HandlerTuple(ndivide=None)})  # fmt: skip
    if len(drawn) > 1:
        whose = "each agent's belief"
    elif drawn and n_agents > 1:
        whose = "central belief" if drawn[0] < 0 else f"agent {drawn[0]}'s belief"
    else:
        whose = "belief"
    est = rec.meta.get("searcher", "")
    ax.set_title(f"{rec.meta.get('scenario', '')} | {est} {whose} at t = {t:.1f} s", fontsize=9)
    if own:
        fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
