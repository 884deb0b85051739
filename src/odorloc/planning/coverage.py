"""Coverage patterns: the rectangular wave (boustrophedon lanes) and its repeated rounds."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.core.types import Region

__all__ = ["rectangular_wave", "wave_waypoints"]

FloatArray = NDArray[np.float64]


def rectangular_wave(
    lower: Sequence[float],
    upper: Sequence[float],
    spacing: float,
    along: str,
    start: Sequence[float] | None = None,
) -> np.ndarray:
    """Waypoints of one boustrophedon pass, ``(W, 2)`` metres.

    Lanes are ``spacing`` apart across the region; the pass starts at the corner nearest to
    ``start`` when given.
    """
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    across = 0 if along == "y" else 1
    long = 1 - across
    n_lanes = math.floor((hi[across] - lo[across]) / spacing + 1e-9) + 1
    lanes = lo[across] + spacing * np.arange(n_lanes)
    if start is not None and abs(start[across] - hi[across]) < abs(start[across] - lo[across]):
        lanes = lanes[::-1]
    first_at_hi = start is not None and abs(start[long] - hi[long]) < abs(start[long] - lo[long])
    pts = []
    for i, c in enumerate(lanes):
        ends = [lo[long], hi[long]]
        if (i % 2 == 1) != first_at_hi:
            ends = ends[::-1]
        for e in ends:
            p = np.zeros(2)
            p[across], p[long] = c, e
            pts.append(p)
    return np.array(pts)


def wave_waypoints(
    region: Region,
    lane_spacing: float,
    lanes_along: str,
    rounds: int,
    start: ArrayLike,
    margin: float = 0.0,
    round_order: str = "restart",
) -> FloatArray:
    """Corners of the rectangular-wave path over all rounds, ``(W, 2)`` metres.

    Parameters
    ----------
    region : ((x0, y0), (x1, y1)), metres
    lane_spacing : float, metres
    lanes_along : {"x", "y"}
    rounds : int
    start : (2,) array_like, metres
        The first round starts at the region corner nearest to it.
    margin : float, metres
        Distance kept from the region's edges.
    round_order : {"restart", "alternate"}
        ``"restart"``: every round ends at the corner diagonally opposite its first corner and
        goes straight back to it (D-S paper, section 4.2: "when the robot arrives at the
        left-top corner (called 1 round) ... the robot comes back to the right-bottom corner,
        and starts a new round"; the last lane is extended to that corner if needed);
        ``"alternate"``: every other round is run backwards.
    """
    lo = np.asarray(region[0], float) + margin
    hi = np.asarray(region[1], float) - margin
    if np.any(hi <= lo):
        raise ConfigError("searcher.margin", "leaves no area to cover")
    one = rectangular_wave(lo, hi, lane_spacing, lanes_along, np.asarray(start, float)[:2])
    if round_order == "alternate":
        return np.concatenate([one if r % 2 == 0 else one[::-1] for r in range(rounds)])
    # "arrives at the left-top corner (called 1 round) ... comes back to the right-bottom
    # corner, and starts a new round" (section 4.2)
    opposite = lo + hi - one[0]
    if not np.allclose(one[-1], opposite):
        one = np.vstack([one, opposite])
    return np.concatenate([one] * rounds)
