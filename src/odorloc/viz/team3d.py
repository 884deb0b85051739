"""3-D views of a team episode: UAV paths, cue points and each UAV's particles.

Reads a :class:`~odorloc.engine.recorder.Recording` of a 3-D episode whose beliefs are recorded
per agent (a ``per-agent`` team). A belief snapshot may carry ``cues`` (the points where that
agent captured a cue, ``(C, 3)``) and ``estimate``; without ``cues`` the recorded detections
are drawn instead.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import animation

from odorloc.engine.recorder import Recording
from odorloc.viz.backend import pyplot
from odorloc.viz.episode import AGENT_COLORS

__all__ = ["animate_team_3d", "beliefs_at", "key_moments", "plot_team_3d"]


def beliefs_at(rec: Recording, t: float) -> dict[int, dict[str, np.ndarray]]:
    """The latest belief snapshot of each agent recorded at or before ``t`` (seconds)."""
    out: dict[int, dict[str, np.ndarray]] = {}
    for bt, snap in rec.beliefs:
        if bt <= t + 1e-9 and "positions" in snap:
            out[int(snap.get("agent", np.array(-1)))] = snap
    return out


def key_moments(rec: Recording) -> list[tuple[float, str]]:
    """Four moments like the paper's Fig. 3: the start, the first cue, every UAV cue-captured,
    and the end.

    A moment that never happens is replaced by a time between its neighbours, labelled by its
    fraction of the episode and by how many UAVs had a cue by then: with no cue at all, 50 %
    and 75 % of the episode, each "no cue".

    Parameters
    ----------
    rec : Recording
        A team episode.

    Returns
    -------
    list of (float, str)
        ``(time s, label)`` of each moment, in time order.
    """
    t = rec.t
    end = float(t[-1]) if len(t) else 0.0
    det = rec.detection
    first = [float(t[np.argmax(det[:, a])]) for a in range(det.shape[1]) if det[:, a].any()]

    def fraction(moment: float) -> str:
        pct = 100.0 * moment / end if end > 0 else 0.0
        cued = sum(f <= moment for f in first)
        if cued == 0:
            return f"{pct:.0f} % of the episode, no cue"
        if cued < det.shape[1]:
            return f"{pct:.0f} % of the episode, {cued} of {det.shape[1]} UAVs cued"
        return f"{pct:.0f} % of the episode"

    if first:
        t_first, first_label = min(first), "first cue"
    else:
        t_first = 0.5 * end
        first_label = fraction(t_first)
    all_cued = bool(first) and len(first) == det.shape[1]
    t_all, all_label = max(first) if all_cued else 0.0, "every UAV has a cue"
    if not (all_cued and t_first < t_all < end):
        t_all = 0.5 * (t_first + end)
        all_label = fraction(t_all)
    return [(0.0, "start"), (t_first, first_label), (t_all, all_label), (end, "end")]


def _draw(ax: Any, rec: Recording, t: float, legend: bool = False) -> None:
    b = rec.arena_bounds
    k = int(np.searchsorted(rec.t, t, side="right"))
    k = max(k, 1)
    snaps = beliefs_at(rec, t)
    n_agents = rec.positions.shape[1]
    cue_label = "cue" if legend else None
    for a in range(n_agents):
        col = AGENT_COLORS[a % len(AGENT_COLORS)]
        p = rec.positions[:k, a]
        ax.plot(p[:, 0], p[:, 1], p[:, 2], "-", color=col, lw=1.2, label=f"agent {a}")
        ax.scatter(*p[-1], color=col, edgecolor="k", s=40, depthshade=False)
        snap = snaps.get(a)
        if snap is not None:
            x = snap["positions"]
            ax.scatter(x[:, 0], x[:, 1], x[:, 2], color=col, s=3, alpha=0.45, depthshade=False)
            cues = snap.get("cues")
        else:
            cues = None
        if cues is None:
            cues = p[rec.detection[:k, a]]
        if len(cues):
            cues = np.asarray(cues).reshape(-1, 3)
            ax.scatter(
                cues[:, 0],
                cues[:, 1],
                cues[:, 2],
                marker="o",
                facecolor="white",
                edgecolor=col,
                s=30,
                linewidth=1.2,
                depthshade=False,
                label=cue_label,
            )
            # One legend entry, from the first UAV with a cue (not only when agent 0 has one).
            cue_label = None
    s = rec.sources
    ax.scatter(s[:, 0], s[:, 1], s[:, 2], marker="*", color="k", s=160, label="source")
    ax.set_xlim(b[0, 0], b[1, 0])
    ax.set_ylim(b[0, 1], b[1, 1])
    ax.set_zlim(b[0, 2], b[1, 2])
    ax.set_box_aspect(tuple(b[1] - b[0]), zoom=1.15)
    ax.set_xlabel("x (m)", fontsize=7, labelpad=-4)
    ax.set_ylabel("y (m)", fontsize=7, labelpad=-4)
    ax.set_zlabel("z (m)", fontsize=7, labelpad=-6)
    ax.tick_params(labelsize=6, pad=-2)
    ax.view_init(elev=24, azim=-60)


def plot_team_3d(
    rec: Recording,
    path: str | Path | None = None,
    times: Sequence[float] | None = None,
    titles: Sequence[str] | None = None,
) -> Any:
    """Paths, cue points and per-UAV particles (coloured by UAV) at four moments (Fig. 3).

    Parameters
    ----------
    rec : Recording
        A 3-D team episode.
    path : str or Path, optional
        PNG to write.
    times : sequence of float, optional
        Moments to draw, seconds (default :func:`key_moments`).
    titles : sequence of str, optional
        Panel titles (default the times).
    """
    plt = pyplot()
    if rec.positions.shape[2] != 3:
        raise ValueError("plot_team_3d needs a 3-D recording")
    if times is None:
        moments = key_moments(rec)
        times = [m[0] for m in moments]
        names = [m[1] for m in moments]
    else:
        times = list(times)
        names = [""] * len(times)
    fig = plt.figure(figsize=(11, 7.4))
    for i, t in enumerate(times):
        ax = fig.add_subplot(2, (len(times) + 1) // 2, i + 1, projection="3d")
        last = i == len(times) - 1
        _draw(ax, rec, t, legend=last)
        if titles is not None:
            title = titles[i]
        else:
            title = f"{names[i]}, t = {t:.0f} s" if names[i] else f"t = {t:.0f} s"
        ax.set_title(f"({chr(97 + i)}) {title}", fontsize=9, y=0.94)
        if last:
            handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
    fig.suptitle(str(rec.meta.get("title", rec.meta.get("scenario", ""))), fontsize=10)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.05, top=0.93, wspace=0.0, hspace=0.08)
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def animate_team_3d(
    rec: Recording, path: str | Path, *, fps: int = 8, max_frames: int = 80, dpi: int = 90
) -> Path:
    """Animation of :func:`plot_team_3d`'s view over the episode (GIF, or MP4 for ``.mp4``)."""
    plt = pyplot()
    path = Path(path)
    fig = plt.figure(figsize=(7, 5.6))
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    steps = np.unique(np.linspace(0, len(rec.t) - 1, min(max_frames, len(rec.t))).astype(int))

    legend: list[Any] = []

    def draw(i: int) -> list[Any]:
        ax.cla()
        t = float(rec.t[steps[i]])
        _draw(ax, rec, t, legend=True)
        # Under the axes, where it cannot hide a UAV; redrawn as the cue entry may appear.
        for leg in legend:
            leg.remove()
        handles, labels = ax.get_legend_handles_labels()
        legend[:] = [
            fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=7,
                       frameon=False)
        ]  # fmt: skip
        ax.set_title(f"t = {t:6.0f} s", fontsize=9)
        return []

    anim = animation.FuncAnimation(fig, draw, frames=len(steps), blit=False)
    if path.suffix == ".mp4":
        anim.save(path, writer=animation.FFMpegWriter(fps=fps), dpi=dpi)
    else:
        anim.save(path, writer=animation.PillowWriter(fps=fps), dpi=dpi)
    plt.close(fig)
    return path
