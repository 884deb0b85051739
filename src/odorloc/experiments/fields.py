"""Fields measured over a running world: what a formation of sensors would read at every point.

:func:`steady_world` is a scenario's world at steady state: its wind's fluctuations and its
sources' modulations off (the mean flow and the mean release), warmed up.

:func:`ring_flux_series` places the same ring of sensors (a formation's robots around its
centre) at every centre of a grid and records, at every control period of a world's run, the
total mass flux through it (``sum_k rho_k v_k . n_k``, :func:`~odorloc.behaviours.taxis.mass_flux`
for all centres at once). Fed to :func:`~odorloc.behaviours.formation.declaration_series`, it maps
where a flux declaration would fire: the geometry of a declaration, independent of how a searcher
gets there (:func:`flux_maps_around`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.engine.episode import control_substeps, prepare_world
from odorloc.scenarios import Scenario

__all__ = ["flux_maps_around", "ring_flux_series", "steady_world"]

#: Wind settings that make a wind fluctuate (set to 0 for the steady world).
_FLUCTUATIONS = ("direction_swing", "speed_std", "vertical_std")


def steady_world(
    scenario: Scenario, rate: float | None = None, warmup: float = 20.0, seed: int = 0
) -> Any:
    """The scenario's world under its mean wind with constant sources, after ``warmup`` s.

    Parameters
    ----------
    scenario : Scenario
    rate : float, optional
        Release of every source (default: each its own ``rate``).
    warmup : float, seconds
        Long enough for the plume to cross the arena several times (20 s: 100 m at 5 m/s).
    seed : int
        World seed.
    """
    data = scenario.to_dict()
    wind = data["world"]["wind"]
    for key in _FLUCTUATIONS:
        if key in wind:
            wind[key] = 0.0
    for s in data["world"]["sources"]:
        if rate is not None:
            s["rate"] = float(rate)
        s["modulation"] = {"kind": "constant"}
    data["world"]["warmup"] = float(warmup)
    world, _, _ = prepare_world(Scenario.from_dict(data), seed)
    return world


def ring_flux_series(
    world: Any,
    rng: np.random.Generator,
    centres: ArrayLike,
    ring: ArrayLike,
    periods: int,
    substeps: int,
    dt: float,
) -> NDArray[np.float32]:
    """Total flux through a ring of sensors at every centre, once per control period.

    Parameters
    ----------
    world : World
        A prepared world (:func:`~odorloc.engine.episode.prepare_world`); it is stepped.
    rng : numpy.random.Generator
        The world's stream.
    centres : (M, d) array_like, metres
        Ring centres.
    ring : (K, d) array_like, metres
        Sensor offsets from the centre (not on it); the outward normal of sensor ``k`` is its
        offset's direction.
    periods : int
        Control periods to record (the first is read before the world moves).
    substeps : int
        World steps per period.
    dt : float, seconds
        World step.

    Returns
    -------
    (periods, M) float32 ndarray
        Readings x m/s.
    """
    c = np.atleast_2d(np.asarray(centres, float))
    r = np.atleast_2d(np.asarray(ring, float))
    if r.shape[1] != c.shape[1]:
        raise ConfigError("ring", f"expected {c.shape[1]} components, got {r.shape[1]}")
    norm = np.linalg.norm(r, axis=1, keepdims=True)
    if np.any(norm <= 0):
        raise ConfigError("ring", "a sensor on the centre has no outward normal")
    if periods < 1 or substeps < 1:
        raise ConfigError("periods", "periods and substeps must be >= 1")
    normals = r / norm
    pts = (c[:, None, :] + r[None, :, :]).reshape(-1, c.shape[1])
    out = np.empty((int(periods), len(c)), np.float32)
    for k in range(int(periods)):
        rho = world.plume.concentration(pts).reshape(len(c), len(r))
        v = world.wind.velocity(pts).reshape(len(c), len(r), -1)
        out[k] = np.einsum("mk,mkd,kd->m", rho, v, normals)
        if k + 1 < periods:
            for _ in range(int(substeps)):
                world.step(dt, rng)
    return out


def flux_maps_around(
    scenario: Scenario,
    seed: int,
    seconds: float,
    points: ArrayLike,
    offsets: ArrayLike,
    ring: ArrayLike,
    threshold: float,
    fires: Callable[[np.ndarray], np.ndarray],
) -> list[dict[str, np.ndarray]]:
    """Maps of the total flux through ``ring`` centred at every offset around each point, over
    ``seconds`` of the scenario's world (world seed ``seed``, one sample per control period).

    Parameters
    ----------
    points : (S, 2) array_like, metres
    offsets : (n,) array_like, metres
        Offsets along each axis; the centres are ``point + (offsets[i], offsets[j])``.
    ring : (K, 2) array_like, metres
    threshold : float
    fires : callable
        ``fires(series)`` with ``series`` ``(T, M)`` gives where a declaration would fire
        (:func:`~odorloc.behaviours.formation.declaration_series`).

    Returns
    -------
    list of dict
        Per point: ``mean`` (mean flux), ``above`` (fraction of steps above ``threshold``),
        ``declares`` (fraction of steps ``fires``), each ``(n, n)`` indexed ``[i, j]``.
    """
    p = np.atleast_2d(np.asarray(points, float))
    off = np.asarray(offsets, float)
    grid = np.stack(np.meshgrid(off, off, indexing="ij"), axis=-1).reshape(-1, 2)
    centres = (p[:, None, :] + grid[None]).reshape(-1, 2)
    T, n_sub, wdt = control_substeps(scenario)
    world, rng, _ = prepare_world(scenario, seed)
    series = ring_flux_series(world, rng, centres, ring, round(seconds / T), n_sub, wdt)
    shape = (len(p), len(off), len(off))
    stats = {
        "mean": series.mean(axis=0),
        "above": (series > threshold).mean(axis=0),
        "declares": np.asarray(fires(series), bool).mean(axis=0),
    }
    return [{k: v.reshape(shape)[i] for k, v in stats.items()} for i in range(len(p))]
