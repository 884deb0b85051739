"""Figures of gas distribution maps: mean, variance and confidence beside the truth.

:func:`draw_cells` draws one per-cell array on a map axis; :func:`plot_gas_map` puts a map's
panels side by side (the time-averaged truth first when it is known, on the mean's colour
scale), with the path of the readings, the true sources and the map maxima. A 3-D map is drawn
as the horizontal slice of cells holding its highest maximum (or, without one, its middle
layer).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import colors
from matplotlib.axes import Axes

from odorloc.geometry.grid import CellGrid

__all__ = ["draw_cells", "horizontal", "plot_gas_map"]

BLOCKED_GREY = colors.ListedColormap(["0.35"])


def horizontal(grid: CellGrid, values: np.ndarray, height: float | None = None) -> np.ndarray:
    """``values`` of a 2-D grid, or the horizontal layer of a 3-D grid holding ``height``
    (metres; default the middle layer)."""
    if grid.dim == 2:
        return values
    zs = grid.axis_centers(2)
    k = len(zs) // 2 if height is None else int(np.argmin(np.abs(zs - height)))
    return values[:, :, k]


def draw_cells(
    ax: Axes,
    grid: CellGrid,
    values: np.ndarray,
    *,
    cmap: str = "viridis",
    norm: colors.Normalize | None = None,
    blocked: np.ndarray | None = None,
) -> Any:
    """Draw a ``(nx, ny)`` per-cell array over the grid's extent; blocked cells in grey.

    Returns the image (for a colour bar).
    """
    lo, hi = grid.lower, grid.upper
    extent = (lo[0], hi[0], lo[1], hi[1])
    im = ax.imshow(
        np.asarray(values, float).T,
        origin="lower",
        extent=extent,
        cmap=cmap,
        norm=norm,
        interpolation="nearest",
    )
    if blocked is not None and blocked.any():
        ax.imshow(
            np.ma.masked_where(~blocked.T, blocked.T),
            origin="lower",
            extent=extent,
            cmap=BLOCKED_GREY,
            vmin=0,
            vmax=1,
            interpolation="nearest",
        )
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    return im


def _mean_norm(*fields: np.ndarray) -> colors.Normalize:
    top = max((float(np.percentile(f, 99.5)) for f in fields if f.size), default=1.0)
    low = min((float(f.min()) for f in fields if f.size), default=0.0)
    return colors.Normalize(vmin=min(0.0, low), vmax=top if top > min(0.0, low) else 1.0)


def plot_gas_map(
    grid: CellGrid,
    mean: np.ndarray,
    variance: np.ndarray,
    confidence: np.ndarray,
    path: str | Path | None = None,
    *,
    blocked: np.ndarray | None = None,
    positions: np.ndarray | None = None,
    sources: np.ndarray | None = None,
    maxima: np.ndarray | None = None,
    truth: np.ndarray | None = None,
    title: str = "",
) -> Any:
    """Panels of one map: [truth,] mean, standard deviation (square root of the variance) and
    confidence.

    Parameters
    ----------
    grid : CellGrid
    mean, variance, confidence : (nx, ny[, nz]) ndarray
    path : path, optional
        Write a PNG there (the figure is closed).
    blocked : bool ndarray, optional
        Cells drawn grey.
    positions : (K, d) ndarray, optional
        Where the readings were taken (drawn as a thin path).
    sources : (S, d) ndarray, optional
        True sources (gold stars).
    maxima : (k, d) ndarray, optional
        The map's maxima (white crosses).
    truth : (nx, ny[, nz]) ndarray, optional
        The time-averaged concentration on the same cells, drawn first on the mean's scale.
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    height = float(maxima[0, 2]) if grid.dim == 3 and maxima is not None and len(maxima) else None
    layer = (lambda a: horizontal(grid, a, height)) if grid.dim == 3 else (lambda a: a)
    hgrid = (
        CellGrid(grid.lower[:2], tuple(grid.cells[:2]), grid.shape[:2]) if grid.dim == 3 else grid
    )
    panels: list[tuple[str, np.ndarray, str, colors.Normalize | None]] = []
    m = layer(mean)
    fields = [m] + ([layer(truth)] if truth is not None else [])
    norm = _mean_norm(*fields)
    if truth is not None:
        panels.append(("time-averaged truth", layer(truth), "viridis", norm))
    panels.append(("mean", m, "viridis", norm))
    panels.append(("standard deviation", np.sqrt(np.maximum(layer(variance), 0.0)), "magma", None))
    panels.append(("confidence", layer(confidence), "Greys", colors.Normalize(0.0, 1.0)))
    w, h = hgrid.upper[0] - hgrid.lower[0], hgrid.upper[1] - hgrid.lower[1]
    size = 3.6
    fig, axes = plt.subplots(
        1,
        len(panels),
        figsize=(size * len(panels), max(2.4, min(6.0, size * h / max(w, 1e-9))) + 0.9),
        squeeze=False,
    )
    bl = layer(blocked) if blocked is not None else None
    for ax, (name, values, cmap, nrm) in zip(axes[0], panels, strict=True):
        im = draw_cells(ax, hgrid, values, cmap=cmap, norm=nrm, blocked=bl)
        fig.colorbar(im, ax=ax, shrink=0.8)
        if positions is not None and len(positions):
            ax.plot(positions[:, 0], positions[:, 1], "-", color="tab:red", lw=0.5, alpha=0.7)
        if sources is not None and len(sources):
            ax.plot(sources[:, 0], sources[:, 1], "*", color="gold", mec="k", ms=11)
        if maxima is not None and len(maxima) and name != "time-averaged truth":
            ax.plot(maxima[:, 0], maxima[:, 1], "x", color="white", mew=2, ms=8)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].set_ylabel("y (m)", fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
