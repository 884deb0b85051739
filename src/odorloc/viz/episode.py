"""Figures and animations of one recorded episode.

Everything here reads a :class:`~odorloc.engine.recorder.Recording`; nothing touches the
simulator, so the same functions draw live runs and runs loaded from disk.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation, colors
from matplotlib.axes import Axes

from odorloc.engine.recorder import Recording

AGENT_COLORS = ["tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown"]


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
        ax.plot(
            rec.declared[:, 0],
            rec.declared[:, 1],
            "X",
            color="magenta",
            mec="k",
            ms=12,
            zorder=7,
            label="declared source",
        )
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    ax.set_title(_summary(rec), fontsize=9)
    if own:
        fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def _belief_at(rec: Recording, t: float) -> dict[str, np.ndarray] | None:
    best = None
    for bt, snap in rec.beliefs:
        if bt <= t + 1e-9:
            best = snap
    return best


def animate(
    rec: Recording,
    path: str | Path,
    *,
    fps: int = 10,
    max_frames: int = 150,
    dpi: int = 70,
) -> Path:
    """Animate plume, agents (with trails) and belief; GIF, or MP4 when ``path`` ends in .mp4.

    At most ``max_frames`` frames are drawn (recorded steps are subsampled evenly).
    """
    path = Path(path)
    b = rec.arena_bounds
    w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
    fig, ax = plt.subplots(figsize=(6.4, max(3.2, min(8.0, 6.0 * h / max(w, 1e-9)))))
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
    n_agents = rec.positions.shape[1]
    trails = [
        ax.plot([], [], "-", color=AGENT_COLORS[a % 6], lw=1.4, zorder=4)[0]
        for a in range(n_agents)
    ]
    heads = [
        ax.plot([], [], "o", color=AGENT_COLORS[a % 6], mec="k", ms=8, zorder=6)[0]
        for a in range(n_agents)
    ]
    particles = ax.scatter([], [], s=4, c=[], cmap="autumn_r", zorder=3, alpha=0.8)
    heads[0].set_label("robot")
    particles.set_label("belief (particles, by weight)")
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    title = ax.set_title("", fontsize=9)
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))
    belief_img = None

    def draw(i: int) -> list[Any]:
        nonlocal belief_img
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
        snap = _belief_at(rec, t)
        if snap is not None and "positions" in snap:
            w_ = snap["weights"]
            particles.set_offsets(snap["positions"][:, :2])
            particles.set_array(w_ / max(w_.max(), 1e-300))
            particles.set_clim(0, 1)
        det = "  DETECT" if rec.detection[k].any() else ""
        title.set_text(f"t = {t:6.1f} s{det}")
        return [*trails, *heads, particles, title]

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
    """Gas reading with detections, wind speed/direction, and the searcher's key diagnostics
    (entropy, spread, ESS, ... each on its own axis) over time."""
    diag = {
        k: v for k, v in rec.diagnostics.items() if k in TRACE_DIAGNOSTICS and np.isfinite(v).any()
    }
    n = 2 + len(diag)
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.9 * n + 0.6), sharex=True)
    t = rec.t
    ax = axes[0]
    for a in range(rec.gas.shape[1]):
        ax.plot(t, rec.gas[:, a], lw=1, color=AGENT_COLORS[a % 6], label=f"agent {a}")
        d = rec.detection[:, a]
        ax.plot(t[d], rec.gas[d, a], "|", color="k", ms=8)
    ax.set_ylabel("gas reading")
    ax.set_title("sensor readings (| = detection)", fontsize=9)
    ax = axes[1]
    wind = rec.wind[:, 0, :2]
    ax.plot(t, np.linalg.norm(wind, axis=1), color="tab:blue", lw=1)
    ax.set_ylabel("wind speed (m/s)", color="tab:blue")
    ax2 = ax.twinx()
    ax2.plot(t, np.degrees(np.arctan2(wind[:, 1], wind[:, 0])), color="tab:orange", lw=0.8)
    ax2.set_ylabel("wind dir (deg)", color="tab:orange")
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


def plot_belief_map(
    rec: Recording, path: str | Path | None = None, index: int = -1, ax: Axes | None = None
) -> Any:
    """A belief snapshot (default: the last) over the map, with the path and its detections.

    Particles are drawn coloured by weight; a grid belief (a snapshot with ``prob`` and its
    extent ``lower``/``upper``) as an image. Returns the figure (saved as PNG with ``path``).
    """
    if ax is None:
        b = rec.arena_bounds
        w, h = b[1, 0] - b[0, 0], b[1, 1] - b[0, 1]
        fig, ax = plt.subplots(figsize=(7.5, max(3.5, min(9.0, 7.0 * h / max(w, 1e-9)))))
    fig = ax.figure
    t, snap = rec.beliefs[index] if rec.beliefs else (float("nan"), {})
    if "positions" in snap and "weights" in snap:
        wts = np.asarray(snap["weights"], float)
        order = np.argsort(wts)
        pts = np.asarray(snap["positions"], float)[order]
        sc = ax.scatter(
            pts[:, 0], pts[:, 1], c=wts[order] / max(wts.max(), 1e-300), s=5, cmap="autumn_r",
            zorder=3, label="particles",
        )  # fmt: skip
        fig.colorbar(sc, ax=ax, shrink=0.8, label="relative weight")
    elif "prob" in snap and "lower" in snap:
        p = np.asarray(snap["prob"], float)
        p2 = p if p.ndim == 2 else p.sum(axis=2)
        lo, hi = np.asarray(snap["lower"]), np.asarray(snap["upper"])
        im = ax.imshow(
            np.where(p2 > 0, p2, np.nan).T, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]),
            cmap="magma_r", zorder=1, alpha=0.9, interpolation="nearest",
        )  # fmt: skip
        fig.colorbar(im, ax=ax, shrink=0.8, label="belief (probability per cell)")
    _draw_static(ax, rec)
    p = rec.positions[:, 0, :]
    ax.plot(p[:, 0], p[:, 1], "-", color="tab:blue", lw=1.2, zorder=4, label="path")
    det = rec.detection[:, 0]
    if det.any():
        ax.plot(p[det, 0], p[det, 1], ".", color="white", mec="tab:blue", ms=6, zorder=5,
                label="detection")  # fmt: skip
    if len(rec.declared):
        ax.plot(rec.declared[:, 0], rec.declared[:, 1], "X", color="magenta", mec="k", ms=12,
                zorder=7, label="declared")  # fmt: skip
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    est = rec.meta.get("searcher", "")
    ax.set_title(f"{rec.meta.get('scenario', '')} | {est} belief at t = {t:.1f} s", fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
