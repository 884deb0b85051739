"""Release-rate calibration of ``virtual-physics-two-groups``: thresholds in the paper's units.

The paper's thresholds are absolute (``rho_T = 0.005 kg/m^3``, ``Phi_T = 0.05 kg/m^2 s``), its
FLUENT plume is not available, and the Eulerian plume is linear in the release rate ``Q``. So
``Q`` is set once, for every rule, by one stated criterion: in the steady plume of the mean
inflow (5 m/s along +x, no meander, constant release), the total mass flux through a formation
centred on a source (a regular hexagon of radius ``r``, :func:`~odorloc.behaviours.taxis.
mass_flux`) is :data:`TARGET_FLUX_RATIO` times ``Phi_T`` -- the declaration statistic then clears
its threshold around a source with a margin even at the release minimum of a sine modulation of
depth 0.5, and is negative inside the plume away from the sources. The concentrations near the
sources then lie at a few ``rho_T``, and the plume core at the start line still exceeds ``rho_T``.

:func:`calibrated_rate` computes ``Q`` from a run at unit rate; :func:`steady_report` gives the
numbers the README quotes (concentration at the robots around a source, the flux there and away
from it, the plume core at the start line).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from odorloc.behaviours.formation import regular_polygon
from odorloc.behaviours.taxis import mass_flux
from odorloc.engine.episode import prepare_world
from odorloc.scenarios import Scenario, get_scenario

__all__ = ["SCENARIO", "TARGET_FLUX_RATIO", "calibrated_rate", "steady_report", "steady_world"]

SCENARIO = "virtual-physics-two-groups"
#: Total flux through a formation centred on a source, in units of ``Phi_T``, at the mean wind.
TARGET_FLUX_RATIO = 5.0
_STEADY_WARMUP = 20.0  # s: 100 m of 5 m/s inflow, several crossings of the 20 m field


def steady_world(scenario: Scenario, rate: float = 1.0) -> Any:
    """The scenario's world at steady state under its mean wind, every source at ``rate``."""
    data = scenario.to_dict()
    wind = data["world"]["wind"]
    for key in ("direction_swing", "speed_std"):
        if key in wind:
            wind[key] = 0.0
    for s in data["world"]["sources"]:
        s["rate"] = float(rate)
        s["modulation"] = {"kind": "constant"}
    data["world"]["warmup"] = _STEADY_WARMUP
    world, _, _ = prepare_world(Scenario.from_dict(data), 0)
    return world


def _ring_flux(world: Any, centre: np.ndarray, radius: float, phase: float) -> tuple[float, float]:
    """``(total flux, largest reading)`` of a hexagon of ``radius`` around ``centre``."""
    ring = regular_polygon(centre, radius, 6, phase)
    rho = world.plume.concentration(ring)
    v = world.wind.velocity(ring)
    _, total = mass_flux(centre, ring, rho, v)
    return total, float(rho.max())


def steady_report(
    scenario: Scenario | None = None, rate: float | None = None, radius: float = 0.3
) -> dict[str, Any]:
    """Steady-plume numbers at release ``rate`` (default the scenario's first source's).

    Returns
    -------
    dict
        ``rate``; per source ``i``: ``flux_i`` (total flux through a hexagon centred on it, mean
        of a vertex and an edge facing the wind), ``peak_i`` (largest reading on that hexagon);
        ``flux_downwind_min/max`` (total flux of hexagons 1-15 m downwind of the downwind source,
        on the plume axis); ``core_start`` (largest concentration on the start line x = 18 m);
        ``rho_T`` and ``phi_T`` of the searcher defaults.
    """
    from odorloc.searchers.virtual_physics import VirtualPhysicsParams

    sc = scenario if scenario is not None else get_scenario(SCENARIO)
    q = float(sc.world.sources[0].rate if rate is None else rate)
    world = steady_world(sc, q)
    out: dict[str, Any] = {"rate": q}
    for i, s in enumerate(sc.world.sources):
        c = s.pos[:2]
        vals = [_ring_flux(world, c, radius, ph) for ph in (0.0, math.pi / 6)]
        out[f"flux_{i}"] = float(np.mean([v[0] for v in vals]))
        out[f"peak_{i}"] = float(np.max([v[1] for v in vals]))
    downwind = max(sc.world.sources, key=lambda s: s.pos[0]).pos[:2]
    away = [
        _ring_flux(world, downwind + np.array([dx, 0.0]), radius, 0.0)[0] for dx in range(1, 16)
    ]
    out["flux_downwind_min"] = float(min(away))
    out["flux_downwind_max"] = float(max(away))
    ys = np.linspace(sc.world.arena.lower[1], sc.world.arena.upper[1], 201)
    line = np.column_stack([np.full_like(ys, 18.0), ys])
    out["core_start"] = float(world.plume.concentration(line).max())
    p = VirtualPhysicsParams()
    out["rho_T"], out["phi_T"] = p.rho_T, p.phi_T
    return out


def calibrated_rate(
    scenario: Scenario | None = None, ratio: float = TARGET_FLUX_RATIO, radius: float = 0.3
) -> float:
    """The release rate giving ``ratio * Phi_T`` of total flux around the sources (their mean),
    from a steady run at unit rate (the plume is linear in the rate)."""
    rep = steady_report(scenario, rate=1.0, radius=radius)
    n = sum(1 for k in rep if k.startswith("flux_") and k[5:].isdigit())
    per_unit = float(np.mean([rep[f"flux_{i}"] for i in range(n)]))
    return ratio * rep["phi_T"] / per_unit
