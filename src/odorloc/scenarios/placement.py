"""Start positions of a team of any size along one edge of an arena.

A paper often gives the starts of its default team only (the multi-UAV paper: three UAVs at
``[10, 10, 5]``, ``[30, 10, 5]``, ``[60, 10, 5]``, Sect. VI.2) and sweeps the team size without
more. :func:`edge_starts` keeps the given starts first and continues along the same edge
(fixed ``y`` and ``z``) on the free multiples of ``spacing`` of ``x`` strictly inside the arena,
in increasing order, then on its two walls; so ``n`` agents always include the first
``n - 1``'s positions (for the paper's starts in a 100 m wide arena: 10, 30, 60, 20, 40, 50,
70, 80, 90, then 0 and 100; 60 m wide: 10, 30, 20, 40, 50, then 0 and 60).

An arena no wider than ``spacing`` has no multiple of it strictly inside, so its first agent
would start on a wall: such a width is refused (:class:`~odorloc.core.errors.ConfigError`
naming ``width``), as is an edge ``y`` or ``z`` outside the arena's depth or height.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from odorloc.core.errors import ConfigError

__all__ = ["edge_starts"]


def _finite(field: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise ConfigError(field, f"must be a number of metres, got {value!r}")
    if not math.isfinite(float(value)):
        raise ConfigError(field, f"must be finite, got {float(value)}")
    return float(value)


def edge_starts(
    n: int,
    first: Sequence[float] = (),
    spacing: float = 10.0,
    width: float = 100.0,
    y: float = 10.0,
    z: float = 5.0,
    *,
    depth: float = 60.0,
    height: float = 30.0,
) -> list[list[float]]:
    """Start positions of ``n`` agents along the edge ``(y, z)`` (module docstring), metres.

    Parameters
    ----------
    n : int
        Number of agents (>= 1).
    first : sequence of float, metres
        The ``x`` of the starts to take first (those inside the arena), e.g. a paper's.
    spacing : float, metres
        The further starts are the multiples of it along ``x``.
    width : float, metres
        Extent of the arena along ``x`` (positions stay in ``[0, width]``); above ``spacing``.
    y, z : float, metres
        The edge, within ``[0, depth]`` and ``[0, height]``.
    depth, height : float, metres
        Extent of the arena along ``y`` and ``z``.

    Returns
    -------
    list of n [x, y, z] lists of float, metres

    Raises
    ------
    ConfigError
        Naming ``n_agents``, ``width``, ``depth``, ``height``, ``y`` or ``z``.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise ConfigError("n_agents", f"must be a whole number, got {n!r}")
    width = _finite("width", width)
    if width <= spacing:
        raise ConfigError(
            "width",
            f"must exceed {spacing:g} m so that a start lies inside the arena, got {width:g}",
        )
    for field, value, name, extent in (("y", y, "depth", depth), ("z", z, "height", height)):
        value, extent = _finite(field, value), _finite(name, extent)
        if extent <= 0:
            raise ConfigError(name, f"must be > 0 m, got {extent:g}")
        if not 0.0 <= value <= extent:
            raise ConfigError(field, f"{value:g} m is outside the arena's [0, {extent:g}] m")
    # a start on the far wall could not move away from it in x: inner positions come first
    xs = [float(x) for x in first if 0.0 < x < width]
    extra = [spacing * k for k in range(1, int(width // spacing) + 1)]
    xs += [x for x in extra if x not in xs and x < width]
    xs += [x for x in (0.0, width) if x not in xs]
    if not 1 <= n <= len(xs):
        raise ConfigError("n_agents", f"must be between 1 and {len(xs)} for a {width:g} m arena")
    return [[x, float(y), float(z)] for x in xs[: int(n)]]
