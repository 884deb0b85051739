"""Search regions: axis-aligned boxes ``(lower, upper)`` a task asks to search or map."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.types import Region

if TYPE_CHECKING:
    from odorloc.core.types import SearchContext

__all__ = ["check_region", "narrow_box", "resolve_region", "task_region"]


def check_region(region: Sequence[Sequence[float]], field: str = "region") -> Region:
    """``region`` as a tuple box; :class:`ConfigError` naming ``field`` unless it is valid.

    A valid region has two corners of 2 or 3 finite components with ``upper > lower`` on
    every axis.
    """
    try:
        lo_s, hi_s = region
        lo = tuple(float(v) for v in lo_s)
        hi = tuple(float(v) for v in hi_s)
    except (TypeError, ValueError):
        raise ConfigError(field, "needs two corners ((x0, y0), (x1, y1))") from None
    if len(lo) != len(hi) or len(lo) not in (2, 3):
        raise ConfigError(field, "corners need the same 2 or 3 components")
    if not all(math.isfinite(v) for v in (*lo, *hi)):
        raise ConfigError(field, "corners must be finite")
    if any(h <= l for l, h in zip(lo, hi, strict=True)):  # noqa: E741
        raise ConfigError(field, f"upper corner {hi} must exceed lower {lo} on every axis")
    return lo, hi


def task_region(
    ctx: SearchContext, region: Sequence[Sequence[float]] | None = None
) -> Region | None:
    """The region a component works in: its own ``region`` (checked, named
    ``searcher.region``), else the task's search region, else ``None`` (no restriction)."""
    if region is not None:
        return check_region(region, "searcher.region")
    if ctx.search_region is not None:
        return check_region(ctx.search_region, "task.region")
    return None


def resolve_region(
    ctx: SearchContext, region: Sequence[Sequence[float]] | None = None, dims: int = 2
) -> Region:
    """The region to work in: ``region``, else the task's search region, else the arena.

    Only the first ``dims`` axes are returned (2: a horizontal region).
    """
    box = task_region(ctx, region)
    lo, hi = box if box is not None else (tuple(ctx.arena.lower), tuple(ctx.arena.upper))
    return tuple(lo[:dims]), tuple(hi[:dims])


def narrow_box(
    lower: ArrayLike,
    upper: ArrayLike,
    region: Sequence[Sequence[float]] | None,
    field: str = "region",
) -> tuple[np.ndarray, np.ndarray]:
    """The box ``[lower, upper]`` narrowed to ``region`` on the region's axes, ``(d,)`` each.

    A region with fewer components than the box (a horizontal region of a 3-D arena) keeps the
    box's extent on the other axes; ``None`` keeps the whole box.

    Raises
    ------
    ConfigError
        Naming ``field`` when the region does not overlap the box.
    """
    lo = np.array(lower, dtype=float)
    hi = np.array(upper, dtype=float)
    if region is None:
        return lo, hi
    k = len(region[0])
    if k > lo.size:
        raise ConfigError(field, f"has more components than the {lo.size}D arena")
    lo[:k] = np.maximum(lo[:k], np.asarray(region[0], float))
    hi[:k] = np.minimum(hi[:k], np.asarray(region[1], float))
    if np.any(hi[:k] <= lo[:k]):
        raise ConfigError(field, "does not overlap the arena")
    return lo, hi
