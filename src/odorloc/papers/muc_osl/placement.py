"""Where the UAVs of ``muc-osl-3d`` start, for any team size.

The paper's three UAVs start on the lower edge of the arena's downwind side, at
``[10, 10, 5]``, ``[30, 10, 5]`` and ``[60, 10, 5]`` (Sect. VI.2, Fig. 3); its UAV-count sweep
(1 to 8 UAVs) gives no positions for the others. Here further UAVs continue along the same edge
(``y = 10``, ``z = 5``) on the free multiples of 10 m of ``x``, in increasing order: 20, 40, 50,
70, 80, 90 (then 0 and 100 in a 100 m wide arena), so ``n`` UAVs always include the first
``n - 1``'s positions.
"""

from __future__ import annotations

from odorloc.core.errors import ConfigError

__all__ = ["PAPER_STARTS", "uav_starts"]

#: The paper's three start positions, metres.
PAPER_STARTS = ((10.0, 10.0, 5.0), (30.0, 10.0, 5.0), (60.0, 10.0, 5.0))


def uav_starts(n: int, width: float = 100.0, y: float = 10.0, z: float = 5.0) -> list[list[float]]:
    """Start positions of ``n`` UAVs (see the module docstring), metres.

    Parameters
    ----------
    n : int
        Number of UAVs (>= 1).
    width : float, metres
        Extent of the arena along ``x`` (positions stay in ``[0, width]``).
    y, z : float, metres
        The edge the UAVs start on.
    """
    xs = [p[0] for p in PAPER_STARTS if p[0] <= width]
    extra = [10.0 * k for k in range(1, int(width // 10) + 1)]
    xs += [x for x in extra if x not in xs and x < width]
    xs += [x for x in (0.0, float(width)) if x not in xs]
    if not 1 <= n <= len(xs):
        raise ConfigError("n_uavs", f"must be between 1 and {len(xs)} for a {width:g} m arena")
    return [[x, float(y), float(z)] for x in xs[:n]]
