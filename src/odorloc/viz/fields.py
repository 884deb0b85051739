"""Maps over offsets from a set of points, and concentration profiles beside models.

Matplotlib is imported only by the functions that draw.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["declaration_map_figure", "profiles_figure"]


def declaration_map_figure(
    maps: dict[str, Any],
    paths: dict[Any, list[tuple[int, np.ndarray]]],
    path: Path,
    *,
    radius: float,
    column: dict[Any, str],
) -> None:
    """Where a formation would declare around each source (rows), per setting (columns).

    Parameters
    ----------
    maps : dict
        ``offsets`` (n,) metres, ``sources`` (S, 2), ``phi_T``, and ``maps[key][i]`` with
        ``declares`` (fraction of steps a formation centred there would declare, drawn in
        colour), ``above`` (fraction of steps above ``phi_T``: dashed contour at 0.5) and
        ``mean`` (mean flux: solid contour at ``phi_T``), each ``(n, n)`` indexed
        ``[x offset, y offset]`` (:func:`odorloc.papers.virtual_physics.analysis.flux_maps`).
    paths : dict
        ``paths[key]``: ``(source, (N, 2) offsets)`` of leaders' paths to draw (end dot).
    path : Path
    radius : float, metres
        A circle around each source (the success radius).
    column : dict
        Title of each setting ``key``.
    """
    import matplotlib.pyplot as plt

    off = maps["offsets"]
    keys = sorted(maps["maps"])
    n_src = len(maps["sources"])
    fig, axes = plt.subplots(
        n_src, len(keys), figsize=(4.0 * len(keys), 3.7 * n_src), squeeze=False
    )
    ext = (off[0], off[-1], off[0], off[-1])
    t = np.linspace(0, 2 * np.pi, 100)
    image = None
    for j, key in enumerate(keys):
        for i in range(n_src):
            ax, m = axes[i, j], maps["maps"][key][i]
            image = ax.imshow(
                m["declares"].T, origin="lower", extent=ext, cmap="magma", vmin=0, vmax=1
            )
            ax.contour(off, off, m["above"].T, [0.5], colors="w", linestyles="--", linewidths=0.8)
            ax.contour(off, off, m["mean"].T, [maps["phi_T"]], colors="w", linewidths=1.0)
            ax.plot(radius * np.cos(t), radius * np.sin(t), ":", color="0.7", lw=1)
            for src, rel in paths.get(key, []):
                if src == i and len(rel):
                    ax.plot(rel[:, 0], rel[:, 1], "-", color="c", lw=0.6, alpha=0.8)
                    ax.plot(*rel[-1], "o", color="c", ms=3)
            ax.plot(0, 0, "*", color="gold", mec="k", ms=11)
            ax.set_xlim(off[0], off[-1])
            ax.set_ylim(off[0], off[-1])
            ax.set_aspect("equal")
            ax.tick_params(labelsize=7)
            s = maps["sources"][i]
            ax.set_title(f"source ({s[0]:g}, {s[1]:g}), {column.get(key, key)}", fontsize=9)
            if i == n_src - 1:
                ax.set_xlabel("centre offset along x (m)", fontsize=8)
            if j == 0:
                ax.set_ylabel("centre offset along y (m)", fontsize=8)
    fig.colorbar(image, ax=axes, shrink=0.8, label="fraction of steps the declaration fires")
    fig.suptitle(
        "Where a formation declares, by the offset of its centre from a source (dashed: flux "
        "above Phi_T half the time; solid: mean flux = Phi_T; dotted: success radius; cyan: "
        "virtual robots)",
        fontsize=9,
    )
    fig.savefig(path, dpi=90)
    plt.close(fig)


def profiles_figure(
    panels: list[tuple[np.ndarray, list[np.ndarray], str]],
    labels: list[str],
    path: Path,
    *,
    title: str,
    marks: list[list[float]] | None = None,
) -> None:
    """Concentration profiles (log scale) of several models side by side, one panel per
    ``(x, [curve per model], x label)``; ``marks[k]`` adds dotted vertical lines to panel k."""
    import matplotlib.pyplot as plt

    styles = (("k", "-"), ("0.6", "--"), ("tab:red", "-"), ("tab:blue", ":"), ("tab:green", "-."))
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4), squeeze=False)
    for k, (ax, (xs, curves, xlabel)) in enumerate(zip(axes[0], panels, strict=True)):
        for c, lab, (col, ls) in zip(curves, labels, styles, strict=False):
            ax.plot(xs, c, ls, color=col, label=lab, lw=1.2)
        for x in (marks or [[]] * len(panels))[k]:
            ax.axvline(x, color="0.4", lw=0.7, ls=":")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("concentration", fontsize=9)
    axes[0, 0].legend(fontsize=7.5)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
