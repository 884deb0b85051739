"""Error bars from intervals, safe for any data a store may hold."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["bars_with_intervals", "errorbar_lengths"]


def errorbar_lengths(
    center: ArrayLike, lo: ArrayLike, hi: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(below, above)`` error-bar lengths of points ``center`` with intervals ``[lo, hi]``.

    Matplotlib refuses negative lengths, which an interval that excludes its point (a bootstrap
    interval of a mean of one value, a Wilson interval at the edge) or a NaN bound produces;
    such a side is drawn with length 0 (the interval is widened to reach its point) and a NaN
    bound gives no bar. Shapes broadcast.
    """
    c = np.asarray(center, float)
    below = c - np.asarray(lo, float)
    above = np.asarray(hi, float) - c
    below = np.where(np.isfinite(below), np.maximum(below, 0.0), 0.0)
    above = np.where(np.isfinite(above), np.maximum(above, 0.0), 0.0)
    return below, above


def bars_with_intervals(
    ax: Any,
    x: ArrayLike,
    center: ArrayLike,
    lo: ArrayLike,
    hi: ArrayLike,
    *,
    horizontal: bool = False,
    **bar: Any,
) -> None:
    """Bars of height (or, ``horizontal``, length) ``center`` at ``x`` with interval error bars
    (:func:`errorbar_lengths`; NaN bars are drawn empty). ``bar`` goes to ``Axes.bar``."""
    c = np.asarray(center, float)
    shown = np.nan_to_num(c)
    err = np.vstack(errorbar_lengths(c, lo, hi))
    if horizontal:
        ax.barh(x, shown, **bar)
        ax.errorbar(shown, x, xerr=err, fmt="none", ecolor="k", capsize=2, lw=0.8)
    else:
        ax.bar(x, shown, **bar)
        ax.errorbar(x, shown, yerr=err, fmt="none", ecolor="k", capsize=2, lw=0.8)
