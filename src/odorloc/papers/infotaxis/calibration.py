"""Fitting a searcher's detection model to a world, as a researcher would before a comparison.

The infotaxis-family searchers need a measurement model; in a world of filaments read through a
threshold that model is a simplification (a rate model of binary detections, the Vergassola
rate with ``P(detection) = 1 - exp(-R dt)``). :func:`detection_map` measures how often probe
points detect over a stretch of the world's own flow, and :func:`fit_detection_model` picks the
model parameters that make those detections most likely (binomial log-likelihood over the probes,
a coarse grid over the diffusivity, lifetime and release, the wind speed and direction being the
measured mean). The reproduction uses the fitted values it records, so the world is never tuned
for a method: the same fitted model serves every model-based searcher.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.engine.episode import control_substeps, prepare_world
from odorloc.models.vergassola import vergassola_rate
from odorloc.scenarios.config import Scenario

__all__ = ["FIT_GRID", "detection_map", "fit_detection_model"]

#: The grid of :func:`fit_detection_model`: 1-2-5 steps over D in 0.01..10 m^2/s, tau in
#: 5..5000 s and Q in 0.1..100. It reaches that far because the smoke-filled room is fitted best
#: at D = 0.01, tau = 5000 (the smoke hardly decays): a grid stopping at D = 0.05, tau = 200
#: returns a different, worse model on its own edge.
FIT_GRID: dict[str, tuple[float, ...]] = {
    "D": (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0),
    "tau": (5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0),
    "Q": (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0),
}


def detection_map(
    scenario: Scenario, points: np.ndarray, duration: float, seed: int = 0
) -> tuple[np.ndarray, int, np.ndarray]:
    """Detection frequency of probe points over ``duration`` seconds of the world's flow.

    A probe detects when the plume's concentration times the gas sensor's gain reaches its
    threshold (noise and lag left out), once per control period.

    Parameters
    ----------
    scenario : Scenario
    points : (P, d) ndarray, metres
        Probe positions.
    duration : float, seconds
        At least one control period.
    seed : int
        World seed.

    Returns
    -------
    hits : (P,) int ndarray
        Periods with a detection at each point.
    periods : int
    mean_wind : (d,) ndarray, m/s
        Mean wind over the probes and the periods.
    """
    dim = len(scenario.world.arena.lower)
    pts = np.asarray(points, float)
    if pts.ndim != 2 or pts.shape[1] != dim or not len(pts):
        raise ConfigError("points", f"must have shape (P, {dim}), got {pts.shape}")
    control_dt = scenario.limits.control_dt
    # fewer than one period would leave no reading and a mean wind of 0 / 0
    if not (math.isfinite(duration) and round(duration / control_dt) >= 1):
        raise ConfigError(
            "duration", f"must cover at least one control period ({control_dt:g} s), got {duration}"
        )
    periods = round(duration / control_dt)
    world, rng, _ = prepare_world(scenario, seed)
    gas = scenario.sensors.gas.values
    threshold = float(gas.get("threshold", 1.0))
    gain = float(gas.get("gain", 1.0))
    _, n_sub, wdt = control_substeps(scenario)
    hits = np.zeros(len(pts), int)
    wind = np.zeros(pts.shape[1])
    for _ in range(periods):
        for _ in range(n_sub):
            world.step(wdt, rng)
        hits += gain * world.plume.concentration(pts) >= threshold
        wind += world.wind.velocity(pts).mean(axis=0)
    return hits, periods, wind / periods


def fit_detection_model(
    points: np.ndarray,
    hits: np.ndarray,
    periods: int,
    source: Sequence[float],
    wind: np.ndarray,
    dt: float,
    *,
    sensor_radius: float = 0.1,
    D: Sequence[float] = FIT_GRID["D"],
    tau: Sequence[float] = FIT_GRID["tau"],
    Q: Sequence[float] = FIT_GRID["Q"],
) -> dict[str, Any]:
    """The grid point of ``(D, tau, Q)`` maximising the binomial likelihood of the detections.

    Parameters
    ----------
    points : (P, d) ndarray, metres
        Probe positions.
    hits : (P,) int ndarray
        Periods with a detection at each probe (:func:`detection_map`).
    periods : int
        Control periods the probes were read.
    source : (d,) sequence of float, metres
    wind : (d,) ndarray, m/s
        Mean wind; its norm is the model's ``V`` and its direction the plume's axis.
    dt : float, seconds
        Control period (the exposure of one reading).
    sensor_radius : float, metres
    D, tau, Q : sequence of float
        Candidate diffusivities (m^2/s), lifetimes (s) and release rates; default
        :data:`FIT_GRID`, the grid the reproduction's recorded fits come from.

    Returns
    -------
    dict
        ``Q, V, D, tau, sensor_radius, wind_direction`` (model parameters of
        :class:`~odorloc.models.vergassola.VergassolaModel`) and ``log_likelihood``.
    """
    pts = np.asarray(points, float)
    if pts.ndim != 2 or not len(pts):
        raise ConfigError("points", f"must have shape (P, d), got {pts.shape}")
    n_pts, dim = pts.shape
    k = np.asarray(hits, float)
    if k.shape != (n_pts,):
        raise ConfigError("hits", f"must hold one count per point, shape ({n_pts},), got {k.shape}")
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 1:
        raise ConfigError("periods", f"must be an integer >= 1, got {periods!r}")
    if not np.all((k >= 0) & (k <= periods)):
        raise ConfigError("hits", f"must lie in [0, periods = {periods}]")
    w = np.asarray(wind, float)
    v = float(np.linalg.norm(w)) if w.shape == (dim,) else math.nan
    # the model's plume lies along the mean wind: without one there is nothing to fit
    if not (math.isfinite(v) and v > 0):
        raise ConfigError("wind", f"must be a non-zero finite ({dim},) mean wind, got {wind!r}")
    e = w / v
    src = np.asarray(source, float)
    if src.shape != (dim,):
        raise ConfigError("source", f"must have shape ({dim},), got {src.shape}")
    src = src[None, :]
    best: dict[str, Any] = {"log_likelihood": -np.inf}
    for d, t, q in itertools.product(D, tau, Q):
        try:
            r = vergassola_rate(pts, src, q, V=v, D=d, tau=t, a=sensor_radius, direction=e)[:, 0]
        except ValueError:  # lambda below the sensor radius in 2-D
            continue
        p = np.clip(-np.expm1(-r * dt), 1e-9, 1 - 1e-9)
        ll = float(np.sum(k * np.log(p) + (periods - k) * np.log1p(-p)))
        if ll > best["log_likelihood"]:
            best = {
                "Q": q,
                "V": v,
                "D": d,
                "tau": t,
                "sensor_radius": sensor_radius,
                "wind_direction": tuple(float(x) for x in e),
                "log_likelihood": ll,
            }
    if "Q" not in best:
        raise ConfigError(
            "sensor_radius",
            f"{sensor_radius:g} m exceeds the correlation length at every grid point of (D, tau)",
        )
    return best
