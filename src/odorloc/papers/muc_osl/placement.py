"""Where the UAVs of ``muc-osl-3d`` start, for any team size.

The paper's three UAVs start on the lower edge of the arena's downwind side, at
``[10, 10, 5]``, ``[30, 10, 5]`` and ``[60, 10, 5]`` (Sect. VI.2, Fig. 3); its UAV-count sweep
(1 to 8 UAVs) gives no positions for the others. Here further UAVs continue along the same edge
(``y = 10``, ``z = 5``) on the free multiples of 10 m of ``x``, in increasing order: 20, 40, 50,
70, 80, 90 (then 0 and 100 in a 100 m wide arena), so ``n`` UAVs always include the first
``n - 1``'s positions. In a narrower arena only the positions strictly inside it are used first
(60 m wide: 10, 30, 20, 40, 50, then 0 and 60).

An arena at most 10 m wide has no multiple of 10 m strictly inside it, so its first UAV would
start on a wall: such a width is refused (:class:`~odorloc.core.errors.ConfigError` naming
``width``), as is an edge ``y`` or ``z`` outside the arena's depth or height.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.errors import ConfigError

__all__ = ["PAPER_STARTS", "uav_starts"]

#: The paper's three start positions, metres.
PAPER_STARTS = ((10.0, 10.0, 5.0), (30.0, 10.0, 5.0), (60.0, 10.0, 5.0))
#: Spacing of the start positions along ``x``, metres.
SPACING = 10.0


def _finite(field: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise ConfigError(field, f"must be a number of metres, got {value!r}")
    if not math.isfinite(float(value)):
        raise ConfigError(field, f"must be finite, got {float(value)}")
    return float(value)


def uav_starts(
    n: int,
    width: float = 100.0,
    y: float = 10.0,
    z: float = 5.0,
    *,
    depth: float = 60.0,
    height: float = 30.0,
) -> list[list[float]]:
    """Start positions of ``n`` UAVs (see the module docstring), metres.

    Parameters
    ----------
    n : int
        Number of UAVs (>= 1).
    width : float, metres
        Extent of the arena along ``x`` (positions stay in ``[0, width]``); above 10 m.
    y, z : float, metres
        The edge the UAVs start on, within ``[0, depth]`` and ``[0, height]``.
    depth, height : float, metres
        Extent of the arena along ``y`` and ``z`` (default: the paper's 100 x 60 x 30 m).

    Returns
    -------
    list of n [x, y, z] lists of float, metres

    Raises
    ------
    ConfigError
        Naming ``n_uavs``, ``width``, ``depth``, ``height``, ``y`` or ``z``.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise ConfigError("n_uavs", f"must be a whole number, got {n!r}")
    width = _finite("width", width)
    if width <= SPACING:
        raise ConfigError(
            "width",
            f"must exceed {SPACING:g} m so that a start lies inside the arena, got {width:g}",
        )
    for field, value, name, extent in (("y", y, "depth", depth), ("z", z, "height", height)):
        value, extent = _finite(field, value), _finite(name, extent)
        if extent <= 0:
            raise ConfigError(name, f"must be > 0 m, got {extent:g}")
        if not 0.0 <= value <= extent:
            raise ConfigError(field, f"{value:g} m is outside the arena's [0, {extent:g}] m")
    # a start on the far wall could not move away from it in x: inner positions come first
    xs = [p[0] for p in PAPER_STARTS if p[0] < width]
    extra = [SPACING * k for k in range(1, int(width // SPACING) + 1)]
    xs += [x for x in extra if x not in xs and x < width]
    xs += [x for x in (0.0, width) if x not in xs]
    if not 1 <= n <= len(xs):
        raise ConfigError("n_uavs", f"must be between 1 and {len(xs)} for a {width:g} m arena")
    return [[x, float(y), float(z)] for x in xs[: int(n)]]
