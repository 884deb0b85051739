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
from collections.abc import Sequence
from typing import Any

import numpy as np

from odorloc.engine.episode import control_substeps, prepare_world
from odorloc.models.vergassola import vergassola_rate
from odorloc.scenarios.config import Scenario

__all__ = ["detection_map", "fit_detection_model"]


def detection_map(
    scenario: Scenario, points: np.ndarray, duration: float, seed: int = 0
) -> tuple[np.ndarray, int, np.ndarray]:
    """Detection frequency of probe points over ``duration`` seconds of the world's flow.

    A probe detects when the plume's concentration times the gas sensor's gain reaches its
    threshold (noise and lag left out), once per control period.

    Returns
    -------
    hits : (Q,) int ndarray
        Periods with a detection at each point.
    periods : int
    mean_wind : (d,) ndarray, m/s
        Mean wind over the probes and the periods.
    """
    world, rng, _ = prepare_world(scenario, seed)
    gas = scenario.sensors.gas.values
    threshold = float(gas.get("threshold", 1.0))
    gain = float(gas.get("gain", 1.0))
    _, n_sub, wdt = control_substeps(scenario)
    periods = round(duration / scenario.limits.control_dt)
    pts = np.asarray(points, float)
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
    D: Sequence[float] = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0),
    tau: Sequence[float] = (5.0, 10.0, 20.0, 50.0, 100.0, 200.0),
    Q: Sequence[float] = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0),
) -> dict[str, Any]:
    """The grid point of ``(D, tau, Q)`` maximising the binomial likelihood of the detections.

    Returns
    -------
    dict
        ``Q, V, D, tau, sensor_radius, wind_direction`` (model parameters of
        :class:`~odorloc.models.vergassola.VergassolaModel`) and ``log_likelihood``.
    """
    pts = np.asarray(points, float)
    k = np.asarray(hits, float)
    v = float(np.linalg.norm(wind))
    e = np.asarray(wind, float) / max(v, 1e-12)
    src = np.asarray(source, float)[None, :]
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
    return best
