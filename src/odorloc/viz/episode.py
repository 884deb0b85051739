"""Figures and animations of one recorded episode.

Everything here reads a :class:`~odorloc.engine.recorder.Recording`; nothing touches the
simulator, so the same functions draw live runs, runs loaded from disk and replayed logs.

Conventions shared by every figure:

- each agent keeps one colour everywhere (:func:`odorloc.viz.team.team_style`: a palette for a
  few agents, one hue family per group for a team in groups);
- the true source (gold star) is drawn above everything, so no marker hides it: a declared
  source is a magenta ring and an estimate a black diamond outline, both drawn under it and
  larger than it;
- legends sit outside the map (right of it), where they cannot hide agents or sources;
- traces are small multiples: one column per agent up to six agents, one per group beyond,
  each group drawn as a band over its members.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import animation, colors, ticker
from matplotlib.axes import Axes
from matplotlib.legend_handler import HandlerTuple
from matplotlib.lines import Line2D

from odorloc.engine.recorder import Recording
from odorloc.viz.backend import pyplot
from odorloc.viz.team import PALETTE, TeamStyle, Unit, team_style

AGENT_COLORS = list(PALETTE)
"""Colours of the agents of a team without groups, in agent order (see :func:`team_style`)."""

#: Particles coloured by weight: a grey ramp (light grey = lightest weight, black = heaviest),
#: so that no weight can be mistaken for an agent's colour or for the viridis plume.
PARTICLE_CMAP = colors.LinearSegmentedColormap.from_list("particle_weight", ["0.82", "0.0"])

#: The true source: above every other marker.
SOURCE_STYLE: dict[str, Any] = {
    "marker": "*",
    "linestyle": "",
    "color": "gold",
    "mec": "k",
    "ms": 16,
    "zorder": 9,
    "label": "true source",
}

#: The declared-source marker, the same in the still figures and the animations: a ring wider
#: than the true source's star and drawn under it, so a declaration on a source shows both.
DECLARED_STYLE: dict[str, Any] = {
    "marker": "o",
    "linestyle": "",
    "mfc": "none",
    "mec": "magenta",
    "mew": 2.4,
    "ms": 21,
    "zorder": 8,
    "label": "declared source",
}

#: A source estimate that is not a declaration (a replayed log's estimator, a mapper's sources).
ESTIMATE_STYLE: dict[str, Any] = {
    "marker": "D",
    "linestyle": "",
    "mfc": "none",
    "mec": "k",
    "mew": 1.8,
    "ms": 15,
    "zorder": 8,
    "label": "estimated source",
}

#: Pixels an animation is at least wide.
MIN_ANIMATION_WIDTH = 800

Progress = Callable[[int, int], None]
"""``progress(frame, total)``, called after each animation frame is written."""


def _style(rec: Recording) -> TeamStyle:
    return team_style(rec.positions.shape[1], rec.meta)


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


def _agent_rgba(style: TeamStyle, a: int, rel: np.ndarray) -> np.ndarray:
    """One agent's particles in that agent's colour, fainter than its path (and fainter still
    for lighter weights), so they read as its belief and not as robots."""
    rgb = 0.6 * np.asarray(style.color(a)[:3]) + 0.4
    rgba = np.empty((len(rel), 4))
    rgba[:, :3] = rgb
    rgba[:, 3] = 0.35 + 0.45 * rel
    return rgba


def _colour_by_agent(rec: Recording, holder: int) -> bool:
    """Whether a belief held by ``holder`` is drawn in its agent's colour (one agent's belief in
    a team) rather than on the grey weight ramp (a single robot's, or a central belief)."""
    return rec.positions.shape[1] > 1 and 0 <= holder < rec.positions.shape[1]


def _particle_holders(rec: Recording) -> list[int]:
    """Agents (``-1`` = central) with particle snapshots in the recording."""
    return sorted({int(s.get("agent", -1)) for _, s in rec.beliefs if "positions" in s})


def _grid_holders(rec: Recording) -> list[int]:
    """Agents (``-1`` = central) with grid snapshots (probabilities or D-S masses)."""
    return sorted({int(s.get("agent", -1)) for _, s in rec.beliefs if "prob" in s or "m_s" in s})


def _latest_at(rec: Recording, t: float, kind: str) -> dict[int, dict[str, np.ndarray]]:
    """The latest snapshot of each holder recorded at or before ``t`` that holds particles
    (``kind="particles"``) or a grid (``kind="grid"``)."""
    out: dict[int, dict[str, np.ndarray]] = {}
    for bt, snap in rec.beliefs:
        if bt > t + 1e-9:
            continue
        has = "positions" in snap if kind == "particles" else ("prob" in snap or "m_s" in snap)
        if has:
            out[int(snap.get("agent", -1))] = snap
    return out


def _particles_at(rec: Recording, t: float) -> dict[int, dict[str, np.ndarray]]:
    """The latest particle snapshot of each belief holder recorded at or before ``t``."""
    return _latest_at(rec, t, "particles")


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


def _estimates(rec: Recording) -> np.ndarray:
    """``(K, 2+)`` source estimates recorded in ``meta["estimates"]`` (replayed logs)."""
    est = rec.meta.get("estimates")
    if est is None or not len(est):
        return np.zeros((0, 2))
    return np.atleast_2d(np.asarray(est, float))


def _conc_norm(frames: np.ndarray) -> colors.Normalize:
    pos = frames[frames > 0]
    if pos.size == 0:
        return colors.Normalize(0, 1)
    hi = float(np.percentile(pos, 99.5))
    lo = max(hi * 1e-3, float(pos.min()))
    return colors.LogNorm(vmin=lo, vmax=max(hi, lo * 10))


def _draw_static(ax: Axes, rec: Recording) -> None:
    """Obstacles, the true sources (when known) and bounds."""
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
    if len(rec.sources):
        # unclipped: a source on the arena's edge stays a whole star
        ax.plot(rec.sources[:, 0], rec.sources[:, 1], clip_on=False, **SOURCE_STYLE)
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


def _map_size(rec: Recording, width: float) -> tuple[float, float]:
    """``(width, height)`` inches of a map panel ``width`` inches wide, at the arena's aspect."""
    b = rec.arena_bounds
    w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
    return width, float(np.clip(width * h / max(w, 1e-9), 2.6, 8.0))


def _map_axes(rec: Recording) -> Axes:
    """The axes of a new map figure, with room on the right for a colour bar and the legend."""
    plt = pyplot()
    fig = plt.figure(figsize=_map_size(rec, 7.0), layout="constrained")
    fig.set_figwidth(fig.get_figwidth() + 3.4)
    ax = fig.add_subplot()
    # against its colour bar and legend: spare width goes left, where saving crops it
    ax.set_anchor("E")
    return ax


# ----------------------------------------------------------------------------- legends


def _agent_entries(style: TeamStyle) -> list[tuple[Any, str]]:
    """One entry per agent (a line with its start marker) for a few agents, else per group."""
    return [
        (Line2D([], [], color=u.color, lw=1.6, marker="o", mec="k", ms=6), u.label)
        for u in style.legend_units()
    ]


def _marker_entries(
    rec: Recording, declared: bool, estimates: bool, start: bool, detection: bool
) -> list[tuple[Any, str]]:
    out: list[tuple[Any, str]] = []
    if len(rec.sources):
        out.append((Line2D([], [], **{**SOURCE_STYLE, "label": None, "ms": 13}), "true source"))
    if declared:
        ring = {**DECLARED_STYLE, "label": None, "ms": 12, "mew": 2.0}
        out.append((Line2D([], [], **ring), "declared source"))
    if estimates:
        diamond = {**ESTIMATE_STYLE, "label": None, "ms": 10, "mew": 1.5}
        out.append((Line2D([], [], **diamond), "estimated source"))
    if start:
        out.append(
            (Line2D([], [], ls="", marker="o", color="0.75", mec="k", ms=7), "start (its colour)")
        )
    if detection:
        out.append((Line2D([], [], ls="", marker=".", color="white", mec="k", ms=8), "detection"))
    return out


def _particle_legend(rec: Recording, style: TeamStyle, holders: list[int]) -> list[tuple[Any, str]]:
    """Legend entries for the particles of ``holders``.

    Scatter markers this small are nearly invisible in a legend, so bigger proxy markers stand
    in: three greys of the weight ramp, or one dot per agent in its particles' colour.
    """
    entries: list[tuple[Any, str]] = []
    if any(not _colour_by_agent(rec, h) for h in holders):
        ramp = tuple(
            Line2D([], [], ls="", marker="o", ms=5, color=PARTICLE_CMAP(v)) for v in (0.2, 0.6, 1.0)
        )
        entries.append((ramp, "belief (particles by weight,\ndarker = heavier)"))
    agents = [h for h in holders if _colour_by_agent(rec, h)]
    if agents:
        dots = tuple(
            Line2D([], [], ls="", marker="o", ms=5, color=_agent_rgba(style, a, np.ones(1))[0])
            for a in agents[:8]
        )
        who = f"each {style.noun}'s" if len(agents) > 1 else f"{style.name(agents[0])}'s"
        entries.append((dots, f"{who} belief\n(particles, in its colour)"))
    return entries


def _legend_right(ax: Axes, entries: list[tuple[Any, str]], own: bool, fontsize: float = 8) -> Any:
    """A legend right of the map, outside it: right of the whole figure (colour bar included)
    when the figure is ours, else just right of ``ax``."""
    if not entries:
        return None
    handles, labels = (list(v) for v in zip(*entries, strict=True))
    kw: dict[str, Any] = {
        "fontsize": fontsize,
        "frameon": False,
        "handler_map": {tuple: HandlerTuple(ndivide=None)},
    }
    if own:
        return ax.figure.legend(handles, labels, loc="outside right upper", **kw)
    return ax.legend(
        handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, **kw
    )


# ----------------------------------------------------------------------------- map figures


def _draw_paths(
    ax: Axes, rec: Recording, style: TeamStyle, k: int | None = None, lw: float | None = None
) -> None:
    """Every agent's path (up to recorded step ``k``), start and detections, in its colour."""
    n = rec.positions.shape[1]
    lw = lw if lw is not None else (1.6 if n <= 8 else 1.0)
    det_ms = 7 if n <= 6 else 4
    for a in range(n):
        col = style.color(a)
        p = rec.positions[: None if k is None else k + 1, a, :]
        ax.plot(p[:, 0], p[:, 1], "-", color=col, lw=lw, zorder=4)
        ax.plot(p[0, 0], p[0, 1], "o", color=col, mec="k", ms=8 if n <= 8 else 6, zorder=5)
        det = rec.detection[: len(p), a]
        if det.any():
            ax.plot(p[det, 0], p[det, 1], ".", color="white", mec=col, ms=det_ms, zorder=5)


def plot_trajectory(rec: Recording, path: str | Path | None = None, ax: Axes | None = None) -> Any:
    """Trajectory over the time-averaged plume, with detections, starts, declarations and the
    true source (drawn above the rest); the legend sits right of the map.

    Parameters
    ----------
    rec : Recording
        The episode.
    path : str or Path, optional
        PNG to write.
    ax : Axes, optional
        Axes to draw into (a new figure when omitted).

    Returns
    -------
    Figure
    """
    plt = pyplot()
    own = ax is None
    style = _style(rec)
    ax = _map_axes(rec) if ax is None else ax
    fig = ax.figure
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
    _draw_paths(ax, rec, style)
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], **DECLARED_STYLE)
    est = _estimates(rec)
    if len(est):
        ax.plot(est[:, 0], est[:, 1], **ESTIMATE_STYLE)
    entries = _marker_entries(
        rec, bool(len(rec.declared)), bool(len(est)), True, bool(rec.detection.any())
    )
    _legend_right(ax, entries + _agent_entries(style), own)
    ax.set_title(_summary(rec), fontsize=9)
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight" if own else None)
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

    Snapshots carry their extent (``lower``, ``upper``). Older recordings do not: their grid is
    taken to start at the arena's lower corner when square cells of one size give exactly
    ``shape`` cells over the arena (grids keep whole cells, so a strip narrower than a cell may
    be left at the upper edges). A grid over a smaller search region fails this test and is not
    drawn rather than drawn in the wrong place.
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
    unknown) the axes say so. Source estimates recorded in ``meta["estimates"]`` (a replayed
    log's) are drawn as diamonds; the true sources only when they are known.

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
    style = _style(rec)
    ax = _map_axes(rec) if ax is None else ax
    fig = ax.figure
    n_agents = rec.positions.shape[1]
    if rec.beliefs:
        t = rec.beliefs[index][0]
        snaps = {int(s.get("agent", -1)): s for bt, s in rec.beliefs if bt == t}
    else:
        t, snaps = float("nan"), {}
    drawn = _draw_belief(ax, rec, style, snaps, colorbar=True)
    note = drawn.note
    _draw_static(ax, rec)
    _draw_paths(ax, rec, style, lw=1.2)
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], **DECLARED_STYLE)
    est = _estimates(rec)
    if len(est):
        ax.plot(est[:, 0], est[:, 1], **ESTIMATE_STYLE)
    if note is not None:
        ax.text(
            0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize=10,
            zorder=10, bbox={"boxstyle": "round", "fc": "white", "ec": "0.6"},
        )  # fmt: skip
    entries = _marker_entries(
        rec, bool(len(rec.declared)), bool(len(est)), False, bool(rec.detection.any())
    )
    entries += _agent_entries(style) if n_agents > 1 else [
        (Line2D([], [], color=style.color(0), lw=1.2), "path")
    ]  # fmt: skip
    entries += _particle_legend(rec, style, drawn.particles)
    _legend_right(ax, entries, own)
    head = " | ".join(str(p) for p in (rec.meta.get("scenario"), rec.meta.get("searcher")) if p)
    ax.set_title(f"{head} | {drawn.whose(style)} at t = {t:.1f} s", fontsize=9)
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight" if own else None)
        plt.close(fig)
    return fig


class _Drawn:
    """What :func:`_draw_belief` drew: the particle holders, the grid holder, a note."""

    def __init__(self, rec: Recording) -> None:
        self.rec = rec
        self.particles: list[int] = []
        self.grid: int | None = None
        self.note: str | None = None

    def whose(self, style: TeamStyle) -> str:
        held = [*self.particles, *([] if self.grid is None else [self.grid])]
        held = sorted(set(held))
        if len(held) > 1:
            return f"each {style.noun}'s belief"
        if held and self.rec.positions.shape[1] > 1:
            return "central belief" if held[0] < 0 else f"{style.name(held[0])}'s belief"
        return "belief"


def _draw_belief(
    ax: Axes,
    rec: Recording,
    style: TeamStyle,
    snaps: dict[int, dict[str, np.ndarray]],
    colorbar: bool,
) -> _Drawn:
    """Particles of every holder in ``snaps`` and, without particles, one grid."""
    drawn = _Drawn(rec)
    fig = ax.figure
    cloud = [hld for hld, s in snaps.items() if "positions" in s]
    grids = {hld: g for hld, s in snaps.items() if (g := _grid_probabilities(s)) is not None}
    if cloud:
        grey = False
        for hld in sorted(cloud):
            pts, rel = _relative_weights(snaps[hld])
            if _colour_by_agent(rec, hld):
                ax.scatter(
                    pts[:, 0], pts[:, 1], s=8, lw=0, color=_agent_rgba(style, hld, rel), zorder=3
                )
            else:
                sc = ax.scatter(
                    pts[:, 0], pts[:, 1], c=rel, cmap=PARTICLE_CMAP, norm=_weight_norm(), s=6,
                    lw=0, zorder=3,
                )  # fmt: skip
                if colorbar and not grey:
                    fig.colorbar(sc, ax=ax, shrink=0.8, label="particle weight / largest weight")
                grey = True
            drawn.particles.append(hld)
    elif grids:
        hld, (p2, label) = next(iter(sorted(grids.items())))
        extent = _grid_extent(rec, snaps[hld], p2.shape)
        if extent is None:
            drawn.note = (
                "grid belief not drawn:\nits extent was not recorded\nand it does not fit the arena"
            )
        else:
            # From 0: a flat (e.g. uniform) map then reads as one level, not as noise.
            im = ax.imshow(
                np.where(p2 > 0, p2, np.nan).T, origin="lower", extent=extent, cmap="magma_r",
                norm=colors.Normalize(0.0, max(float(p2.max()), 1e-300)), zorder=1, alpha=0.9,
                interpolation="nearest",
            )  # fmt: skip
            if colorbar:
                fig.colorbar(im, ax=ax, shrink=0.8, label=label)
            drawn.grid = hld
    elif snaps:
        drawn.note = "the belief snapshot holds\nneither particles nor a grid"
    else:
        drawn.note = "no belief was recorded"
    return drawn


# ----------------------------------------------------------------------------- animation


def animate(
    rec: Recording,
    path: str | Path,
    *,
    fps: int = 10,
    max_frames: int = 150,
    dpi: int = 80,
    progress: Progress | None = None,
) -> Path:
    """Animate the plume, the agents (with trails), the belief and the declarations.

    The left panel shows the plume and the agents; when the searcher recorded a belief, a
    second panel shows it beside: particles (a single robot's or a central belief on a grey
    ramp by weight, each agent's in a team faded in that agent's colour) over the latest grid
    belief (a Dempster-Shafer map, a grid filter's probabilities) of the same time. The legend
    has its own column right of the panels. A declared source appears, with the same marker as
    in :func:`plot_trajectory`, from the frame at which it was declared (from the last frame
    when the recording has no declaration events). Frames are at least
    :data:`MIN_ANIMATION_WIDTH` pixels wide.

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
        Resolution of the frames (the figure is widened so that frames keep their minimum
        width at any ``dpi``).
    progress : callable, optional
        ``progress(frame, total)`` after each frame is written (a progress bar).

    Returns
    -------
    Path
        ``path``.
    """
    plt = pyplot()
    path = Path(path)
    style = _style(rec)
    n_agents = rec.positions.shape[1]
    holders = _particle_holders(rec)
    grid_holders = _grid_holders(rec)
    with_belief = bool(holders or grid_holders)
    # one fixed layout, in inches, for every frame (a layout recomputed per frame would make
    # the panels jump): margins for titles and labels, the map panels at the arena's aspect,
    # their colour bars under them, the legend in a column of its own
    n_panels = 2 if with_belief else 1
    left, gap, right, legend_w = 0.65, 0.75, 0.1, 2.8
    top, below, bar_h, bottom = 0.6, 0.62, 0.14, 0.5
    fixed_w = left + gap * (n_panels - 1) + 0.35 + legend_w + right
    width = max(fixed_w + 5.2 * n_panels, MIN_ANIMATION_WIDTH / dpi + 0.01)
    panel_w = (width - fixed_w) / n_panels
    b = rec.arena_bounds
    aspect = (b[1, 1] - b[0, 1]) / max(b[1, 0] - b[0, 0], 1e-9)
    map_h = float(np.clip(panel_w * aspect, 2.0, 7.0))
    height = top + map_h + below + bar_h + bottom
    fig = plt.figure(figsize=(width, height))

    def place(x: float, y: float, w: float, h: float, **kw: Any) -> Axes:
        return fig.add_axes((x / width, y / height, w / width, h / height), **kw)

    map_y = bottom + bar_h + below
    xs = [left + k * (panel_w + gap) for k in range(n_panels)]
    ax = place(xs[0], map_y, panel_w, map_h)
    bax = place(xs[1], map_y, panel_w, map_h, sharex=ax, sharey=ax) if with_belief else None
    caxes = [place(x + 0.1 * panel_w, bottom, 0.8 * panel_w, bar_h) for x in xs]
    lax = place(xs[-1] + panel_w + 0.35, bottom, legend_w, map_h + below + bar_h)
    lax.axis("off")
    # named, so that a caller (or a test) can find the panels
    ax.set_label("map")
    lax.set_label("legend")
    if bax is not None:
        bax.set_label("belief")
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
        bar = fig.colorbar(im, cax=caxes[0], orientation="horizontal", label="concentration")
        if isinstance(norm, colors.LogNorm):
            # plain "1e-04" labels: mathtext labels are parsed again at every frame
            bar.formatter = ticker.LogFormatter(labelOnlyBase=True)
            bar.minorformatter = ticker.NullFormatter()
            bar.update_ticks()
    else:
        caxes[0].axis("off")
    panels = [ax] if bax is None else [ax, bax]
    for p in panels:
        _draw_static(p, rec)
        p.set_anchor("S")  # a map narrower than its box sits on its colour bar
    if bax is not None:
        bax.set_ylabel("")
    lw = 1.4 if n_agents <= 8 else 1.0
    ms = 8 if n_agents <= 8 else 6
    # fainter trails over the belief, so its particles stay visible under them
    trails = [
        [
            p.plot([], [], "-", color=style.color(a), lw=lw if j == 0 else 0.8 * lw,
                   alpha=1.0 if j == 0 else 0.55, zorder=4)[0]
            for a in range(n_agents)
        ]
        for j, p in enumerate(panels)
    ]  # fmt: skip
    heads = [
        # Unclipped: an agent on the arena's edge stays a whole marker.
        [
            p.plot([], [], "o", color=style.color(a), mec="k", ms=ms, zorder=6, clip_on=False)[0]
            for a in range(n_agents)
        ]
        for p in panels
    ]
    particles: dict[int, Any] = {}
    grid_img = None
    if bax is not None:
        weight_bar = None
        for hld in holders:
            if _colour_by_agent(rec, hld):
                particles[hld] = bax.scatter(np.zeros(0), np.zeros(0), s=8, lw=0, zorder=3)
            else:
                particles[hld] = bax.scatter(
                    np.zeros(0), np.zeros(0), s=5, lw=0, c=np.zeros(0), cmap=PARTICLE_CMAP,
                    norm=_weight_norm(), zorder=3,
                )  # fmt: skip
                weight_bar = particles[hld]
        if grid_holders:
            grid_img = bax.imshow(
                np.full((2, 2), np.nan), origin="lower", cmap="magma_r", zorder=1, alpha=0.9,
                interpolation="nearest", extent=tuple(rec.plume_extent),
                norm=colors.Normalize(0.0, 1.0),
            )  # fmt: skip
            fig.colorbar(
                grid_img, cax=caxes[1], orientation="horizontal",
                label="belief per cell / largest cell",
            )  # fmt: skip
        elif weight_bar is not None:
            fig.colorbar(
                weight_bar, cax=caxes[1], orientation="horizontal",
                label="particle weight / largest weight",
            )  # fmt: skip
        else:
            caxes[1].axis("off")
    declarations = _declarations(rec)
    declared = [p.plot([], [], **DECLARED_STYLE)[0] for p in panels]
    entries = _marker_entries(rec, bool(declarations), False, False, False)
    entries += [
        (Line2D([], [], color=u.color, lw=1.4, marker="o", mec="k", ms=6), u.label)
        for u in style.legend_units()
    ]
    entries += _particle_legend(rec, style, holders) if bax is not None else []
    if grid_img is not None:
        entries.append(
            (Line2D([], [], ls="", marker="s", ms=8, color=plt.get_cmap("magma_r")(0.7)),
             "grid belief\n(darker = more likely)")
        )  # fmt: skip
    if entries:
        handles, labels = (list(v) for v in zip(*entries, strict=True))
        lax.legend(
            handles, labels, loc="center left", fontsize=8, frameon=False,
            handler_map={tuple: HandlerTuple(ndivide=None)},
        )  # fmt: skip
    title = fig.suptitle("t = 0.0 s", fontsize=10)
    ax.set_title("plume and agents", fontsize=9)
    belief_title = bax.set_title("belief", fontsize=9) if bax is not None else None
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))
    last = len(rec.t) - 1

    def draw(i: int) -> list[Any]:
        k = steps[i]
        t = rec.t[k]
        if im is not None:
            f = int(np.searchsorted(rec.plume_t, t, side="right") - 1)
            f = max(f, 0)
            im.set_data(np.where(rec.plume_frames[f] > 0, rec.plume_frames[f], np.nan).T)
        for tr, hd in zip(trails, heads, strict=True):
            for a in range(n_agents):
                p = rec.positions[: k + 1, a]
                tr[a].set_data(p[:, 0], p[:, 1])
                hd[a].set_data([p[-1, 0]], [p[-1, 1]])
        snaps = _particles_at(rec, t)
        for hld, sc in particles.items():
            snap = snaps.get(hld)
            if snap is None:
                sc.set_offsets(np.zeros((0, 2)))
                continue
            pts, rel = _relative_weights(snap)
            sc.set_offsets(pts)
            if _colour_by_agent(rec, hld):
                sc.set_facecolor(_agent_rgba(style, hld, rel))
            else:
                sc.set_array(rel)
        whose = ""
        if grid_img is not None:
            grids = _latest_at(rec, t, "grid")
            if grids:
                hld = sorted(grids)[0]
                snap = grids[hld]
                got = _grid_probabilities(snap)
                assert got is not None
                p2 = got[0]
                extent = _grid_extent(rec, snap, p2.shape)
                top = float(np.nanmax(p2)) if p2.size else 0.0
                if extent is not None and top > 0:
                    grid_img.set_data(np.where(p2 > 0, p2 / top, np.nan).T)
                    grid_img.set_extent(extent)
                    whose = style.name(hld) if 0 <= hld < n_agents and n_agents > 1 else ""
            else:
                grid_img.set_data(np.full((2, 2), np.nan))
        if belief_title is not None:
            held = sorted(set(particles) | set(grid_holders))
            if len(held) > 1 and n_agents > 1:
                belief_title.set_text(f"each {style.noun}'s belief")
            elif whose:
                belief_title.set_text(f"{whose}'s belief")
            else:
                belief_title.set_text("belief")
        # A declaration made after the last recorded step still belongs on the last frame.
        shown = [pos for td, pos in declarations if td <= t + 1e-9 or k == last]
        for dc in declared:
            if shown:
                xy = np.vstack(shown)
                dc.set_data(xy[:, 0], xy[:, 1])
            else:
                dc.set_data([], [])
        det = rec.detection[k]
        if det.any():
            who = style.name(int(np.argmax(det))) if det.sum() == 1 else f"{int(det.sum())} agents"
            title.set_text(f"t = {t:7.1f} s   detection ({who})")
        else:
            title.set_text(f"t = {t:7.1f} s")
        return []

    anim = animation.FuncAnimation(fig, draw, frames=len(steps), blit=False)
    callback = None
    if progress is not None:
        total = len(steps)

        def callback(i: int, n: int) -> None:
            progress(i + 1, total)

    if path.suffix == ".mp4":
        anim.save(path, writer=animation.FFMpegWriter(fps=fps), dpi=dpi, progress_callback=callback)
    else:
        anim.save(path, writer=animation.PillowWriter(fps=fps), dpi=dpi, progress_callback=callback)
    plt.close(fig)
    return path


def ffmpeg_available() -> bool:
    """``True`` when an ``ffmpeg`` executable is on the PATH (for MP4 output)."""
    return shutil.which("ffmpeg") is not None


# ----------------------------------------------------------------------------- traces

#: Diagnostics drawn by :func:`plot_traces`, in this order, when a searcher reports them.
TRACE_DIAGNOSTICS = {
    "entropy": "posterior entropy (nats)",
    "spread": "particle spread (m)",
    "ess": "effective sample size",
    "uncertainty": "map uncertainty",
    "total_uncertainty": "map uncertainty",
}

_SUFFIX = re.compile(r"^(?P<base>.+)_(?P<agent>\d+)$")


def diagnostics_by_agent(rec: Recording) -> dict[str, dict[int, np.ndarray]]:
    """The recorded diagnostics of :data:`TRACE_DIAGNOSTICS`, per name and holder.

    A team records its first member's diagnostics under their own names and every other
    member's with the member's (first) agent appended (``spread_2``); the unsuffixed series then
    belongs to the lowest agent that has no suffixed one. A searcher without members (a single
    robot, or one central searcher for a team) reports under ``-1``.

    Returns
    -------
    dict of str to dict of int to (K,) ndarray
        ``{name: {agent or -1: series}}``, series with a finite value (text diagnostics, such
        as phase names, are left out).
    """
    n = rec.positions.shape[1]
    out: dict[str, dict[int, np.ndarray]] = {}
    plain: dict[str, np.ndarray] = {}
    for key, v in rec.diagnostics.items():
        v = np.asarray(v)
        if v.dtype.kind not in "biuf":
            continue  # text (a phase name) has no trace
        v = v.astype(float)
        if not np.isfinite(v).any():
            continue
        m = _SUFFIX.match(key)
        if m and m["base"] in TRACE_DIAGNOSTICS and int(m["agent"]) < n:
            out.setdefault(m["base"], {})[int(m["agent"])] = v
        elif key in TRACE_DIAGNOSTICS:
            plain[key] = v
    for key, v in plain.items():
        members = out.get(key)
        free = [a for a in range(n) if a not in (members or {})]
        if members and free:
            members[free[0]] = v
        else:
            out[key] = {-1: v}
    return {k: out[k] for k in TRACE_DIAGNOSTICS if k in out}


def _detection_strip(ax: Axes, t: np.ndarray, share: np.ndarray, color: Any) -> None:
    """Detections as a strip along the panel's bottom: filled where the agent detects (a unit
    of several: to the height of the share of its agents detecting)."""
    ax.fill_between(
        t, 0.0, 0.12 * share, step="post", color=color, alpha=0.85, lw=0,
        transform=ax.get_xaxis_transform(), zorder=1,
    )  # fmt: skip


def _band(ax: Axes, t: np.ndarray, values: np.ndarray, color: Any) -> None:
    """A line for one series; for several, the median and a min-max band."""
    if values.shape[1] == 1:
        ax.plot(t, values[:, 0], lw=1.0, color=color, zorder=3)
        return
    with np.errstate(all="ignore"):
        ok = np.isfinite(values).any(axis=1)
        lo = np.where(ok, np.nanmin(np.where(ok[:, None], values, 0.0), axis=1), np.nan)
        hi = np.where(ok, np.nanmax(np.where(ok[:, None], values, 0.0), axis=1), np.nan)
        med = np.where(ok, np.nanmedian(np.where(ok[:, None], values, 0.0), axis=1), np.nan)
    ax.fill_between(t, lo, hi, color=color, alpha=0.3, lw=0, zorder=2)
    ax.plot(t, med, lw=1.0, color=color, zorder=3)


def plot_traces(rec: Recording, path: str | Path | None = None) -> Any:
    """Gas readings with detections, wind, and the searcher's diagnostics over time, as small
    multiples.

    One column per agent (titled with its name, in its colour) up to
    :data:`~odorloc.viz.team.MAX_AGENT_PANELS` agents; beyond, one column per group, drawn as
    the members' median with a min-max band. Rows: the gas reading (detections as a strip
    along the bottom; for a group, as high as the share of its agents detecting), the wind at
    the agent (horizontal speed in its colour; the direction the air moves towards, degrees
    counter-clockwise from +x, in grey, so wind towards -y reads -90), and each diagnostic
    the searcher reports (:data:`TRACE_DIAGNOSTICS`): per member in its column, or one panel
    across the columns for a central belief.

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
    style = _style(rec)
    units: list[Unit] = style.units()
    diag = diagnostics_by_agent(rec)
    rows = ["gas", "wind", *diag]
    ncols = len(units)
    fig = plt.figure(
        figsize=(max(8.0, 3.0 * ncols + 1.2), 1.75 * len(rows) + 1.0), layout="constrained"
    )
    gs = fig.add_gridspec(len(rows), ncols)
    t = rec.t
    first: Axes | None = None
    gas_axes: list[Axes] = []
    wind_axes: list[Axes] = []
    diag_axes: dict[str, list[Axes]] = {}
    for r, row in enumerate(rows):
        central = row in diag and set(diag[row]) == {-1}
        cols = [slice(None)] if central else list(range(ncols))
        for c, col in enumerate(cols):
            ax = fig.add_subplot(gs[r, col], sharex=first)
            first = first or ax
            unit = units[c] if not central else None
            if unit is not None and r == 0:
                ax.set_title(unit.label, color=unit.color, fontsize=9, fontweight="bold")
            if row == "gas":
                assert unit is not None
                agents = list(unit.agents)
                _band(ax, t, rec.gas[:, agents], unit.color)
                _detection_strip(ax, t, rec.detection[:, agents].mean(axis=1), unit.color)
                gas_axes.append(ax)
                if c == 0:
                    ax.set_ylabel("gas reading", fontsize=8)
            elif row == "wind":
                assert unit is not None
                agents = list(unit.agents)
                w = rec.wind[:, agents, :2]
                _band(ax, t, np.linalg.norm(w, axis=2), unit.color)
                mean = w.mean(axis=1)
                ax2 = ax.twinx()
                ax2.plot(
                    t, np.degrees(np.arctan2(mean[:, 1], mean[:, 0])), color="0.55", lw=0.7,
                    zorder=1,
                )  # fmt: skip
                ax2.set_ylim(-185, 185)
                ax2.set_yticks([-180, -90, 0, 90, 180])
                ax2.tick_params(labelsize=7, colors="0.45")
                if c == ncols - 1:
                    ax2.set_ylabel("towards (deg from +x)", color="0.45", fontsize=8)
                else:
                    ax2.tick_params(right=False, labelright=False)
                wind_axes.append(ax)
                if c == 0:
                    speed = "horizontal speed" if rec.wind.shape[2] == 3 else "wind speed"
                    ax.set_ylabel(f"{speed} (m/s)", fontsize=8)
            else:
                series = diag[row]
                if central:
                    v = series[-1]
                    ax.plot(t[: len(v)], v, lw=1.2, color="0.2")
                    whose = ", central belief" if style.n_agents > 1 else ""
                    ax.set_title(f"{TRACE_DIAGNOSTICS[row]}{whose}", fontsize=8, loc="left")
                else:
                    assert unit is not None
                    diag_axes.setdefault(row, []).append(ax)
                    own = [a for a in unit.agents if a in series]
                    if own:
                        vals = np.column_stack([series[a][: len(t)] for a in own])
                        _band(ax, t[: len(vals)], vals, unit.color)
                    else:
                        ax.text(
                            0.5, 0.5, "no belief of its own", transform=ax.transAxes,
                            ha="center", va="center", fontsize=8, color="0.4",
                        )  # fmt: skip
                    if c == 0:
                        ax.set_ylabel(TRACE_DIAGNOSTICS[row], fontsize=8)
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
            if r == len(rows) - 1:
                ax.set_xlabel("time (s)", fontsize=8)
            else:
                ax.tick_params(labelbottom=False)
    # the same scale in every column of a row, so agents compare at a glance
    for row_axes in [gas_axes, wind_axes, *diag_axes.values()]:
        if len(row_axes) > 1:
            lo = min(a.get_ylim()[0] for a in row_axes)
            hi = max(a.get_ylim()[1] for a in row_axes)
            for a in row_axes:
                a.set_ylim(lo, hi)
    for a in gas_axes:
        # room under the readings for the detection strip
        lo, hi = a.get_ylim()
        a.set_ylim(lo - 0.16 * (hi - lo), hi)
    what = style.noun if ncols == style.n_agents else "group: median and min-max band"
    share = "" if ncols == style.n_agents else " (height: share of the group detecting)"
    fig.suptitle(
        f"{rec.meta.get('scenario', '')}: one column per {what}\n"
        f"strip under the gas readings = detections{share}; "
        "wind speed in colour, direction in grey",
        fontsize=9,
    )
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
