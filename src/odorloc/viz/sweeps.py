"""Grouped bars of sets of sweep rows with their intervals.

Each bar is ``stat(rows) -> (value, lo, hi, text)`` of one set of rows (e.g.
:func:`odorloc.experiments.cells.stat_interval`). Matplotlib is imported only by the function
that draws.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from odorloc.viz.intervals import bars_with_intervals

__all__ = ["grouped_bars"]


def grouped_bars(
    ax: Any,
    cells: Mapping[tuple[Any, Any], Any],
    categories: Sequence[Any],
    series: Mapping[Any, tuple[str, str]],
    stat: Callable[[Any], tuple[float, float, float, str]],
    *,
    horizontal: bool = False,
    annotate: bool = False,
) -> float:
    """One group of bars per category, one bar per series (``series[key] = (label, colour)``)
    of ``stat`` over ``cells[(category, key)]``, with its interval; ``annotate`` writes
    ``k/n`` above each bar. Returns the highest point drawn."""
    width = 0.8 / max(len(series), 1)
    top = 0.0
    for j, (key, (label, colour)) in enumerate(series.items()):
        vals = [stat(cells[(c, key)]) for c in categories]
        v, lo, hi = (np.array([x[i] for x in vals], float) for i in range(3))
        pos = np.arange(len(categories)) + (j - (len(series) - 1) / 2) * width
        bars_with_intervals(
            ax,
            pos,
            v,
            lo,
            hi,
            horizontal=horizontal,
            color=colour,
            label=label,
            **({"height": width} if horizontal else {"width": width}),
        )
        for p, c, h, (_, _, _, txt) in zip(pos, v, hi, vals, strict=True):
            y = h if np.isfinite(h) else (c if np.isfinite(c) else 0.0)
            top = max(top, y)
            if annotate:
                ax.text(p, y, txt, ha="center", va="bottom", fontsize=6.5)
    ticks = np.arange(len(categories))
    (ax.set_yticks if horizontal else ax.set_xticks)(ticks, [str(c) for c in categories])
    ax.grid(axis="x" if horizontal else "y", alpha=0.3)
    return top
