"""Search regions: axis-aligned boxes ``(lower, upper)`` a task asks to search or map."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from odorloc.core.errors import ConfigError
from odorloc.core.types import Region

if TYPE_CHECKING:
    from odorloc.core.types import SearchContext

__all__ = ["check_region", "resolve_region"]


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


def resolve_region(
    ctx: SearchContext, region: Sequence[Sequence[float]] | None = None, dims: int = 2
) -> Region:
    """The region to work in: ``region``, else the task's search region, else the arena.

    Only the first ``dims`` axes are returned (2: a horizontal region).
    """
    if region is not None:
        lo, hi = check_region(region, "searcher.region")
    elif ctx.search_region is not None:
        lo, hi = check_region(ctx.search_region, "task.region")
    else:
        lo, hi = tuple(ctx.arena.lower), tuple(ctx.arena.upper)
    return tuple(lo[:dims]), tuple(hi[:dims])
