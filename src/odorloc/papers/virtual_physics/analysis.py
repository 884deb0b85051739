"""The world of ``virtual-physics-two-groups`` measured: its release rate, the declaration's
geometry and the plume near the inflow.

- :func:`calibrated_rate`: the paper's thresholds are absolute (``rho_T = 0.005 kg/m^3``,
  ``Phi_T = 0.05 kg/m^2 s``), its FLUENT plume is not available, and the Eulerian plume is
  linear in the release rate ``Q``. So ``Q`` is set once, for every rule, by one criterion: in
  the steady plume of the mean inflow, the total mass flux through a formation centred on a
  source (a hexagon of radius ``r``) is :data:`TARGET_FLUX_RATIO` times ``Phi_T``: the statistic
  then clears its threshold around a source even at the release minimum of a sine modulation
  of depth 0.5. :func:`steady_report` gives the numbers behind it.

- :func:`flux_maps`: the total flux through a formed hexagon (the declaration statistic, Sec.
  2.2.3) centred at every offset around each source over a run of the world at each frequency.
- :func:`plume_check`: the steady plume around the upwind source, 1 m from the inflow, beside
  the closed-form solution with ``D`` and with the upwind scheme's ``D + U h / 2`` along the
  wind, and with the inflow boundary moved 4 m upwind.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from odorloc.behaviours.formation import declaration_series, equilibrium_radius, regular_polygon
from odorloc.behaviours.taxis import mass_flux
from odorloc.experiments.fields import flux_maps_around, steady_world
from odorloc.models.advection_diffusion import point_source_2d
from odorloc.plume.eulerian import upwind_diffusivity
from odorloc.scenarios import Scenario, get_scenario

__all__ = [
    "MAP_HALF_WIDTH",
    "MAP_SPACING",
    "TARGET_FLUX_RATIO",
    "calibrated_rate",
    "flux_maps",
    "formation_ring",
    "plume_check",
    "steady_report",
]

SCENARIO = "virtual-physics-two-groups"

#: Half width (m) and spacing (m) of the grid of formation centres around each source.
MAP_HALF_WIDTH = 1.2
MAP_SPACING = 0.05
#: Inflow boundary moved this far upwind (m) for the boundary check.
BOUNDARY_SHIFT = 4.0
POINTS = ("c 0.5 m upwind", "c 1 m downwind", "c 3 m downwind")


def formation_ring(params: Any) -> np.ndarray:
    """Offsets ``(6, 2)`` of a formed hexagon from its centre (a robot straight upwind, as the
    formations start and, in the recorded episodes, stay)."""
    R = equilibrium_radius(6, params.radius, params.k_r, params.k_s)
    return regular_polygon((0.0, 0.0), R, 6)


def flux_maps(frequencies: tuple[int, ...], seconds: float, seed: int) -> dict[str, Any]:
    """Declaration maps (:func:`~odorloc.experiments.fields.flux_maps_around`) of the scenario's
    world at each ``frequency`` (``seconds`` after the warm-up, world seed ``seed``) for its
    member searcher's settings: ``offsets`` (n,), ``sources`` (S, 2), ``phi_T`` and
    ``maps[f][i]`` (``mean``, ``above``, ``declares``, each ``(n, n)``, ``[x, y]`` offset)."""
    from odorloc.searchers.virtual_physics import VirtualPhysicsParams

    base = get_scenario(SCENARIO)
    member = dict(base.to_dict()["searcher"].get("member", {}))
    member.pop("type", None)
    p = VirtualPhysicsParams(**member)
    d = p.declaration
    off = np.arange(-MAP_HALF_WIDTH, MAP_HALF_WIDTH + 1e-9, MAP_SPACING)
    sources = np.array([s.pos[:2] for s in base.world.sources])

    def fires(series: np.ndarray) -> np.ndarray:
        return declaration_series(series, p.phi_T, p.n_s, d.reading, d.window)

    args = (seed, seconds, sources, off, formation_ring(p), p.phi_T, fires)
    maps = {f: flux_maps_around(base.with_overrides({"frequency": f}), *args) for f in frequencies}
    return {"offsets": off, "sources": sources, "phi_T": p.phi_T, "maps": maps}


def _scenario_with_inflow_at(lower_x: float) -> Scenario:
    data = get_scenario(SCENARIO).to_dict()
    lower = list(data["world"]["arena"]["lower"])
    data["world"]["arena"]["lower"] = [float(lower_x), *lower[1:]]
    return Scenario.from_dict(data)


def plume_check(radius: float = 0.3) -> dict[str, Any]:
    """The steady plume around the upwind source beside the closed-form solution.

    Returns
    -------
    dict
        ``rows`` (quantity, Eulerian with the inflow at the arena edge, with the inflow moved
        :data:`BOUNDARY_SHIFT` m upwind, closed form with ``D``, closed form with the upwind
        scheme's ``D + U h / 2`` along the wind); ``profiles``: ``x`` (along the wind through
        the source, m from it) and ``y`` (across, 0.3 m downwind) with the concentration of the
        same four; ``source``, ``D``, ``D_along``, ``U``, ``h``.
    """
    sc = get_scenario(SCENARIO)
    src = min(sc.world.sources, key=lambda s: s.pos[0])
    s = np.asarray(src.pos[:2], float)
    q = float(src.rate)
    worlds = [steady_world(sc, q), steady_world(_scenario_with_inflow_at(-BOUNDARY_SHIFT), q)]
    plume = worlds[0].plume
    U = float(sc.world.wind.speed)
    D = float(plume.params.D)
    h = float(plume.h)
    Da = upwind_diffusivity(D, U, h)
    # where the plume puts the source: the cell containing it, or the point itself
    at = s if plume.params.deposit == "linear" else plume.grid.center(plume.grid.index(s))[0]

    def models(points: np.ndarray) -> list[np.ndarray]:
        pts = np.atleast_2d(points)
        return [w.plume.concentration(pts) for w in worlds] + [
            point_source_2d(pts, at, q, (U, 0.0), Dx, D) for Dx in (D, Da)
        ]

    ring = regular_polygon(s, radius, 6)
    normals = (ring - s) / radius
    cols = models(ring)
    points = s + np.array([[-0.5, 0.0], [1.0, 0.0], [3.0, 0.0]])
    along = models(points)
    rows = [
        ["c at the upwind robot", *(float(c[3]) for c in cols)],
        ["c at the downwind robot", *(float(c[0]) for c in cols)],
        ["total flux through the ring", *(float((c * U * normals[:, 0]).sum()) for c in cols)],
        *([name, *(float(c[k]) for c in along)] for k, name in enumerate(POINTS)),
    ]
    xs = np.linspace(-1.0, 4.0, 101)
    ys = np.linspace(-1.0, 1.0, 81)
    line_x = np.column_stack([s[0] + xs, np.full_like(xs, at[1])])
    line_y = np.column_stack([np.full_like(ys, s[0] + 0.3), s[1] + ys])
    profiles = {"x": (xs, models(line_x)), "y": (ys, models(line_y))}
    return dict(rows=rows, profiles=profiles, source=s, D=D, D_along=Da, U=U, h=h)


#: Total flux through a formation centred on a source, in units of ``Phi_T``, at the mean wind.
TARGET_FLUX_RATIO = 5.0


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

    Returns ``rate``; per source ``i`` ``flux_i`` (total flux through a hexagon centred on it,
    mean of a vertex and an edge facing the wind) and ``peak_i`` (its largest reading);
    ``flux_downwind_min/max`` (hexagons 1-15 m downwind of the downwind source, on the axis);
    ``core_start`` (largest concentration at x = 18 m); ``rho_T`` and ``phi_T``.
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
    away = [_ring_flux(world, downwind + np.array([dx, 0]), radius, 0)[0] for dx in range(1, 16)]
    out["flux_downwind_min"], out["flux_downwind_max"] = float(min(away)), float(max(away))
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
