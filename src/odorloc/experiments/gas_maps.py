"""Gas maps scored against the simulated truth, and the readings of a recording.

The truth of a gas map is the plume's *time-averaged* concentration over the same cells, as the
rest of odorloc averages a plume: the recorder samples the concentration on a grid of cells
every ``recording.plume_stride`` steps (:class:`~odorloc.engine.recorder.Recorder`; the
trajectory figure shows the mean of these frames), and :func:`time_averaged_truth` averages the
frames of a recording over the episode. :func:`frame_grid` gives those cells as a
:class:`~odorloc.geometry.grid.CellGrid`, so a map built on it is scored cell by cell (set
``recording.plume_grid`` to ``1 / cell size`` and ``recording.plume_stride`` to the averaging
step; the recorder keeps at least 20 cells per axis).

:func:`score_map` gives, over the cells of a mask (a search region, the free cells):

* ``rmse``: root mean square of ``mean - truth``, in reading units (the concentration sensor's
  readings are concentrations when its gain is 1 and its offset 0);
* ``kl``: the Kullback-Leibler divergence ``sum_k P_k log(P_k / Q_k)`` of the map normalised
  into a distribution ``Q`` from the normalised truth ``P`` (nats; the map is clipped at 0 and
  every cell raised by ``floor`` times the map's average, so that a cell the map calls empty
  costs a large but finite amount);
* ``nlpd``: the NLPD of held-out readings under the map's predicted mean and variance
  (Lilienthal et al. 2009, eq. 8);
* ``peak_distance_i``: the distance from source ``i`` to the nearest of the map's ``K``
  highest separated maxima (``K`` the number of sources), and ``max_distance_i`` from the map's
  single highest cell; ``peak_distance`` is their mean over the sources.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odorloc.core.errors import ConfigError
from odorloc.engine.recorder import Recording
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.gas_map.base import GasMap, build_gas_map, map_grid, map_maxima
from odorloc.inference.gas_map.readings import Readings, as_readings
from odorloc.inference.gas_map.selection import Selection, select_parameters

__all__ = [
    "MappedLog",
    "arena_of",
    "default_cell_size",
    "frame_grid",
    "kl_divergence",
    "map_readings",
    "map_recording",
    "readings_from_observations",
    "readings_from_recording",
    "rmse",
    "score_map",
    "source_distances",
    "time_averaged_truth",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def frame_grid(rec: Recording) -> CellGrid:
    """The cells of a recording's plume frames (a horizontal slice in 3-D)."""
    if rec.plume_frames.ndim != 3 or len(rec.plume_frames) == 0:
        raise ConfigError("recording", "has no plume frames (recording.plume_stride)")
    nx, ny = rec.plume_frames.shape[1:]
    x0, x1, y0, y1 = (float(v) for v in rec.plume_extent)
    return CellGrid((x0, y0), ((x1 - x0) / nx, (y1 - y0) / ny), (nx, ny))


def time_averaged_truth(rec: Recording) -> tuple[CellGrid, FloatArray]:
    """``(cells, concentration)``: the recording's plume frames averaged over time, on
    :func:`frame_grid`."""
    grid = frame_grid(rec)
    return grid, np.asarray(rec.plume_frames, float).mean(axis=0)


def readings_from_recording(rec: Recording, agents: list[int] | None = None) -> Readings:
    """Every reading of a recording (the chosen agents', default all), in time order.

    Positions, readings and winds of a 3-D recording stay 3-D.
    """
    n_agents = rec.positions.shape[1]
    chosen = list(range(n_agents)) if agents is None else [int(a) for a in agents]
    for a in chosen:
        if not 0 <= a < n_agents:
            raise ConfigError("agent", f"{a} is not an agent of the recording (0..{n_agents - 1})")
    pos = rec.positions[:, chosen, :].reshape(-1, rec.positions.shape[2])
    gas = rec.gas[:, chosen].reshape(-1)
    wind = rec.wind[:, chosen, :].reshape(-1, rec.wind.shape[2])
    t = np.repeat(np.asarray(rec.t, float), len(chosen))
    if len(gas) == 0:
        raise ConfigError("recording", "holds no readings")
    return as_readings(pos, gas, wind, t)


def rmse(mean: FloatArray, truth: FloatArray, mask: BoolArray | None = None) -> float:
    """Root mean square error of a mean map against the truth over the masked cells."""
    m = np.ones(truth.shape, bool) if mask is None else mask
    if mean.shape != truth.shape:
        raise ConfigError("mean", f"shape {mean.shape} differs from the truth's {truth.shape}")
    if not m.any():
        return math.nan
    return float(np.sqrt(np.mean((mean[m] - truth[m]) ** 2)))


def kl_divergence(
    truth: FloatArray, mean: FloatArray, mask: BoolArray | None = None, floor: float = 1e-3
) -> float:
    """``KL(P || Q)`` of the normalised truth ``P`` and the normalised map ``Q`` over the
    masked cells, nats (see the module docstring; NaN when the truth is 0 everywhere)."""
    m = np.ones(truth.shape, bool) if mask is None else mask
    p = np.clip(truth[m], 0.0, None)
    if not p.sum() > 0:
        return math.nan
    p = p / p.sum()
    q = np.clip(mean[m], 0.0, None)
    q = q + floor * (q.mean() if q.sum() > 0 else 1.0)
    q = q / q.sum()
    keep = p > 0
    return float(np.sum(p[keep] * np.log(p[keep] / q[keep])))


def source_distances(
    grid: CellGrid,
    mean: FloatArray,
    allowed: BoolArray,
    sources: FloatArray,
    separation: float = 1.0,
) -> dict[str, float]:
    """``peak_distance_i``, ``max_distance_i`` and ``peak_distance`` (see the module
    docstring), metres; horizontal distances for a 2-D map of 3-D sources."""
    src = np.atleast_2d(np.asarray(sources, float))[:, : grid.dim]
    out: dict[str, float] = {}
    peaks = map_maxima(grid, mean, allowed, max(len(src), 1), separation)
    top = map_maxima(grid, mean, allowed, 1, separation)
    near = []
    for i, s in enumerate(src):
        d = float(np.min(np.linalg.norm(peaks - s, axis=1))) if len(peaks) else math.nan
        out[f"peak_distance_{i}"] = d
        out[f"max_distance_{i}"] = float(np.linalg.norm(top[0] - s)) if len(top) else math.nan
        near.append(d)
    out["peak_distance"] = float(np.mean(near)) if near else math.nan
    return out


def score_map(
    gas_map: GasMap,
    truth: FloatArray,
    sources: FloatArray,
    held_out: Readings | None = None,
    mask: BoolArray | None = None,
    separation: float = 1.0,
) -> dict[str, Any]:
    """Every score of :mod:`this module <odorloc.experiments.gas_maps>` for a built map.

    Parameters
    ----------
    gas_map : GasMap
        With readings; its grid must be the truth's cells.
    truth : (nx, ny[, nz]) ndarray
        Time-averaged concentration per cell.
    sources : (S, d) ndarray, metres
    held_out : Readings, optional
        Readings left out of the map (``nlpd`` is NaN without).
    mask : bool ndarray, optional
        Cells scored (default all); blocked cells are never scored.
    separation : float, metres
        Least distance between the map maxima compared with the sources.
    """
    if truth.shape != gas_map.grid.shape:
        raise ConfigError("truth", f"shape {truth.shape} is not the map's {gas_map.grid.shape}")
    m = ~gas_map.blocked if mask is None else mask & ~gas_map.blocked
    mean = gas_map.mean()
    out: dict[str, Any] = {
        "rmse": rmse(mean, truth, m),
        "kl": kl_divergence(truth, mean, m),
        "nlpd": gas_map.score_nlpd(held_out)
        if held_out is not None and len(held_out)
        else math.nan,
    }
    out.update(source_distances(gas_map.grid, mean, m, sources, separation))
    return out


def readings_from_observations(observations: Iterable[Any], dim: int) -> Readings:
    """The readings of a stream of observations (e.g. a bag's), in order."""
    pos, gas, wind, t = [], [], [], []
    for o in observations:
        pos.append(np.asarray(o.position, float))
        gas.append(float(o.gas))
        wind.append(np.asarray(o.wind, float))
        t.append(float(o.t))
    if not gas:
        raise ConfigError("log", "no observations (not one full period of data)")
    return as_readings(np.array(pos), gas, np.array(wind), t, dim=dim)


def arena_of(rec: Recording) -> Arena:
    """The arena of a recording: its bounds and, for a 2-D recording, its obstacles."""
    lo, hi = (tuple(float(v) for v in row) for row in rec.arena_bounds)
    occ = rec.occupancy
    if occ is None or len(lo) != 2 or np.asarray(occ).ndim != 2:
        return Arena.box(lo, hi, float(min(np.subtract(hi, lo)) / 100.0))
    occ = np.asarray(occ, bool)
    res = (hi[0] - lo[0]) / occ.shape[0]
    return Arena(lo, hi, res, occ)


MAX_DEFAULT_CELLS = 200_000
"""Most cells of a map whose cell size the user left to the default."""


def default_cell_size(lower: Sequence[float], upper: Sequence[float], cell: float = 0.25) -> float:
    """``cell`` metres, or larger cells when ``cell`` would give more than
    :data:`MAX_DEFAULT_CELLS` over the extent (a large 3-D arena)."""
    size = np.asarray(upper, float) - np.asarray(lower, float)
    volume = float(np.prod(size))
    need = (volume / MAX_DEFAULT_CELLS) ** (1.0 / len(size))
    return float(max(cell, need))


@dataclass
class MappedLog:
    """A gas map built offline and what it was built from.

    Attributes
    ----------
    gas_map : GasMap
    readings : Readings
    params : dict
        The member's parameters used (the selected ones included).
    selection : Selection or None
        The cross-validation, when parameters were selected.
    truth : ndarray or None
        The time-averaged concentration on the map's cells, when the recording holds plume
        frames on those cells.
    """

    gas_map: GasMap
    readings: Readings
    params: dict[str, Any]
    selection: Selection | None = None
    truth: FloatArray | None = None


def map_readings(
    readings: Readings,
    grid: CellGrid,
    method: str,
    params: Mapping[str, Any] | None = None,
    arena: Arena | None = None,
    select: Mapping[str, Sequence[Any]] | None = None,
    folds: int = 5,
    block: float = 10.0,
) -> MappedLog:
    """Build the map ``method`` of ``readings`` on ``grid``; with ``select``, first choose
    those parameters by cross-validated NLPD
    (:func:`~odorloc.inference.gas_map.selection.select_parameters`). A ``cell_size`` among
    the candidates builds grids of the same extent."""
    settings = dict(params or {})
    selection = None
    if select:
        lo, hi = grid.lower, grid.upper

        def grid_for(cell: float) -> CellGrid:
            return grid if "cell_size" not in select else map_grid(lo, hi, cell)

        selection = select_parameters(
            method, readings, grid_for, select, settings, folds, block, arena
        )
        settings.update(selection.best)
        if "cell_size" in selection.best:
            grid = map_grid(lo, hi, float(selection.best["cell_size"]))
    gm = build_gas_map(method, **settings)
    gm.start(grid, arena)
    gm.update(
        readings.positions,
        readings.values,
        wind=readings.wind,
        t=readings.t if readings.has_times else None,
    )
    return MappedLog(gm, readings, settings, selection)


def map_recording(
    rec: Recording,
    method: str,
    params: Mapping[str, Any] | None = None,
    cell_size: float | None = None,
    select: Mapping[str, Sequence[Any]] | None = None,
    agents: list[int] | None = None,
) -> MappedLog:
    """Map a recording's readings offline.

    The map covers the arena. Without ``cell_size`` (and without ``cell_size`` among the
    ``select`` candidates) a recording with plume frames is mapped on the frames' cells and the
    result carries the time-averaged truth on them; otherwise the cells are ``cell_size``
    (default :func:`default_cell_size`: 0.25 m, coarser in a large arena) from the arena's lower
    corner.
    """
    readings = readings_from_recording(rec, agents)
    arena = arena_of(rec)
    truth = None
    use_frames = (
        cell_size is None
        and not (select and "cell_size" in select)
        and rec.plume_frames.ndim == 3
        and len(rec.plume_frames) > 0
        and arena.dim == 2
    )
    if use_frames:
        grid, truth = time_averaged_truth(rec)
    else:
        cell = default_cell_size(arena.lower, arena.upper) if cell_size is None else cell_size
        grid = map_grid(arena.lower, arena.upper, cell)
    out = map_readings(readings, grid, method, params, arena, select)
    out.truth = truth
    return out
