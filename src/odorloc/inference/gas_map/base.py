"""The gas distribution map family (registry family ``gas_map``) on the estimator seam.

A gas map turns gas readings taken at known positions (and, for some members, the wind and the
time of each) into a map of the expected reading per cell, with a variance and a confidence.
Every member derives from :class:`GasMap`, itself an
:class:`~odorloc.inference.estimator.Estimator` that needs no measurement model::

    gm = build_gas_map("kernel-dmv", kernel_width=0.3)
    gm.start(CellGrid.from_extent((0, 0), (10, 5), 0.1, "ceil"))     # offline, or reset(ctx, ...)
    gm.update(positions, readings, wind=winds, t=times)              # batches of arrays
    gm.mean(), gm.variance(), gm.confidence()                        # (nx, ny[, nz]) arrays
    gm.estimate()                                                    # (k, d) map maxima

``update(observation)`` (the estimator hook) folds in one agent's reading, its position, wind
and time. Readings are kept (in time order) and the maps are computed from all of them when
asked, then cached until the next update: Kernel DM+V's variance needs the mean at every
reading's cell (Lilienthal et al. 2009, eq. 6), time-dependent members weigh every reading by
its age at the latest reading's time, and the GMRF solves one linear system over all readings.

Obstacles: cells whose centre lies in an obstacle or outside the arena are *blocked*. No member
reports a blocked cell as known: its mean and variance are the prior's and its confidence is 0,
and the map maxima are never in a blocked cell. Only the GMRF also keeps mass from crossing a
wall (cells on either side of one are not coupled); the kernels of Kernel DM+V and its
extensions know no obstacles, as in their papers.

The hooks of the estimator seam:

* :meth:`GasMap.reset` builds the grid from the context: ``region`` (default the task's search
  region, else the arena bounds), narrowed to the arena (a 2-component region of a 3-D arena
  spans the arena's height),
  ``cell_size`` cells with the last cell of an axis reaching past the region's edge when it
  does not divide it;
* :meth:`GasMap.belief` is a :class:`GasMapBelief` (``None`` before the first reading);
* :meth:`GasMap.estimate` is the ``max_sources`` highest local maxima of the mean map among the
  free cells whose confidence reaches ``min_confidence``, at least ``peak_separation`` apart.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.types import Observation, Region
from odorloc.geometry.grid import CellGrid
from odorloc.geometry.regions import check_region, narrow_box, task_region
from odorloc.inference.estimator import Estimator
from odorloc.inference.gas_map.readings import Readings, as_readings

if TYPE_CHECKING:
    from odorloc.core.types import SearchContext
    from odorloc.geometry.arena import Arena
    from odorloc.models.base import MeasurementModel

__all__ = [
    "GasMap",
    "GasMapBelief",
    "GasMapParams",
    "blocked_cells",
    "build_gas_map",
    "map_grid",
    "map_maxima",
    "nlpd",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class GasMapParams(Params):
    """Parameters every gas map has.

    Attributes
    ----------
    cell_size : float, metres
        Side of a map cell (used by :meth:`GasMap.reset`; :meth:`GasMap.start` takes a grid).
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Extent mapped by :meth:`GasMap.reset`; default the task's search region, else the
        arena's bounds (either narrowed to the arena; one that misses it is refused).
    max_sources : int
        Map maxima :meth:`GasMap.estimate` reports.
    peak_separation : float, metres
        Least distance between two reported maxima (a local maximum must also be the largest
        mean within this distance).
    min_confidence : float
        Confidence a cell needs to hold a reported maximum, in [0, 1).
    """

    cell_size: Positive = 0.25
    region: Region | None = None
    max_sources: int = Field(1, ge=1, le=100)
    peak_separation: Positive = 1.0
    min_confidence: float = Field(0.0, ge=0.0, lt=1.0)


@dataclass(frozen=True, eq=False)
class GasMapBelief:
    """A gas map as a belief: the cells, and the mean, variance and confidence per cell.

    Parameters
    ----------
    grid : CellGrid
    mean : (nx, ny[, nz]) ndarray
        Expected reading per cell (the sensor's units).
    variance : (nx, ny[, nz]) ndarray
        The member's variance map (units squared; see :meth:`GasMap.variance`).
    confidence : (nx, ny[, nz]) ndarray
        In [0, 1].
    """

    grid: CellGrid
    mean: FloatArray
    variance: FloatArray
    confidence: FloatArray

    def snapshot(self) -> dict[str, np.ndarray]:
        """Arrays for recording, prefixed ``gas_`` so that they sit beside a searcher's own
        belief in one snapshot: ``gas_mean``, ``gas_variance``, ``gas_confidence`` and the
        grid's extent ``gas_lower``, ``gas_upper`` (metres)."""
        return {
            "gas_mean": self.mean.copy(),
            "gas_variance": self.variance.copy(),
            "gas_confidence": self.confidence.copy(),
            "gas_lower": np.asarray(self.grid.lower, float),
            "gas_upper": np.asarray(self.grid.upper, float),
        }


def map_grid(
    lower: ArrayLike, upper: ArrayLike, cell_size: float, field: str = "cell_size"
) -> CellGrid:
    """The grid of ``cell_size`` cells from ``lower`` covering ``upper`` (last cells may reach
    past it); :class:`ConfigError` naming ``field`` for a cell size that is not > 0."""
    if not (math.isfinite(cell_size) and cell_size > 0):
        raise ConfigError(field, f"must be a finite number > 0, got {cell_size}")
    try:
        return CellGrid.from_extent(lower, upper, cell_size, rounding="ceil")
    except ConfigError as exc:
        raise ConfigError(field, exc.problem) from None


def blocked_cells(grid: CellGrid, arena: Arena | None) -> BoolArray:
    """``(nx, ny[, nz])`` mask of the cells whose centre is outside ``arena`` or in one of its
    obstacles (none blocked without an arena)."""
    if arena is None:
        return np.zeros(grid.shape, bool)
    if arena.dim != grid.dim:
        raise ConfigError("grid", f"a {grid.dim}-D grid for a {arena.dim}-D arena")
    return ~arena.is_free(grid.flat_centers()).reshape(grid.shape)


def nlpd(
    mean: ArrayLike, variance: ArrayLike, readings: ArrayLike, variance_floor: float = 1e-12
) -> float:
    """Average negative log predictive density of ``readings`` under ``N(mean, variance)``.

    ``NLPD = 1/2 log(2 pi) + 1/(2n) sum_i [log v_i + (r_i - m_i)^2 / v_i]`` (Lilienthal et al.
    2009, eq. 8), with ``m_i, v_i`` the prediction at reading ``i``'s cell. Variances below
    ``variance_floor`` (a map built from identical readings predicts 0) are raised to it, so a
    perfect prediction scores a large negative number rather than ``-inf``.

    Parameters
    ----------
    mean, variance, readings : (n,) array_like
        Predicted means and variances of the readings, and the readings.

    Returns
    -------
    float
        NaN for no readings.
    """
    m = np.asarray(mean, float)
    v = np.maximum(np.asarray(variance, float), variance_floor)
    r = np.asarray(readings, float)
    if r.size == 0:
        return math.nan
    return float(0.5 * math.log(2 * math.pi) + 0.5 * np.mean(np.log(v) + (r - m) ** 2 / v))


class GasMap(Estimator):
    """Base class of the ``gas_map`` family (see the module docstring).

    Subclasses implement ``_compute_mean`` (the mean map of the readings in :attr:`readings`)
    and ``_compute_spread`` (the variance, confidence and predictive variance maps, after the
    mean); the base class keeps the readings, caches the maps until the next update, masks the
    blocked cells, checks that every map is finite and answers the estimator hooks.

    Class attributes
    ----------------
    needs_wind : bool
        ``True`` when every reading needs the wind (Kernel DM+V/W).
    needs_time : bool
        ``True`` when every reading needs its time (time-dependent members).
    """

    params: GasMapParams
    needs_model: ClassVar[bool] = False
    needs_wind: ClassVar[bool] = False
    needs_time: ClassVar[bool] = False

    def __init__(self, params: GasMapParams | None = None) -> None:
        super().__init__(params if params is not None else GasMapParams())
        self._grid: CellGrid | None = None

    # ------------------------------------------------------------------ lifecycle
    def reset(
        self,
        ctx: SearchContext,
        model: MeasurementModel | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        """Start a new episode on the grid the context and the parameters give (see the
        module docstring); ``model`` and ``rng`` are not used (the maps are deterministic)."""
        arena = ctx.arena
        if self.params.region is not None:
            region, field = check_region(self.params.region, "region"), "region"
        else:
            region, field = task_region(ctx), "task.region"
        lo, hi = narrow_box(arena.lower, arena.upper, region, field)
        self.start(map_grid(lo, hi, self.params.cell_size), arena)

    def start(self, grid: CellGrid, arena: Arena | None = None) -> None:
        """Start an empty map on ``grid`` (offline use; :meth:`reset` calls it).

        Parameters
        ----------
        grid : CellGrid
            The cells to map (2-D or 3-D).
        arena : Arena, optional
            Obstacles and bounds: cells whose centre is not free are blocked.
        """
        self._grid = grid
        self._arena = arena
        self._blocked = blocked_cells(grid, arena)
        self._parts: list[Readings] = []
        self._all: Readings | None = Readings.concat([], grid.dim)
        self._n = 0
        self._with_wind: bool | None = None
        self._invalidate()
        self._prepare()

    def _invalidate(self) -> None:
        self._mean: FloatArray | None = None
        self._raw_mean: FloatArray | None = None
        self._spread: tuple[FloatArray, FloatArray, FloatArray] | None = None

    def _prepare(self) -> None:
        """Per-grid work of a member, done once at :meth:`start` (default none)."""

    # ------------------------------------------------------------------ data
    @property
    def grid(self) -> CellGrid:
        """The map's cells."""
        if self._grid is None:
            raise RuntimeError("call reset(ctx) or start(grid) before using the map")
        return self._grid

    @property
    def blocked(self) -> BoolArray:
        """``(nx, ny[, nz])`` mask of the blocked cells."""
        self.grid  # noqa: B018 - raises before start
        return self._blocked

    @property
    def readings(self) -> Readings:
        """Every reading so far, in the order given."""
        self.grid  # noqa: B018 - raises before start
        if self._all is None:
            self._all = Readings.concat(self._parts, self.grid.dim)
            self._parts = [self._all]
        return self._all

    @property
    def n_readings(self) -> int:
        """Number of readings so far."""
        self.grid  # noqa: B018 - raises before start
        return self._n

    @overload
    def update(self, observation: Observation) -> None: ...

    @overload
    def update(
        self,
        position: ArrayLike,
        reading: ArrayLike,
        wind: ArrayLike | None = None,
        t: ArrayLike | float | None = None,
    ) -> None: ...

    def update(
        self,
        position: Observation | ArrayLike,
        reading: ArrayLike | None = None,
        wind: ArrayLike | None = None,
        t: ArrayLike | float | None = None,
    ) -> None:
        """Add readings: a batch of arrays, or one :class:`~odorloc.core.types.Observation`.

        Parameters
        ----------
        position : (N, d) or (d,) array_like, metres; or Observation
            Where the readings were taken (an observation brings its own reading, wind and
            time).
        reading : (N,) array_like
            The gas readings (the sensor's units).
        wind : (N, d) or (d,) array_like, m/s, optional
            The wind measured with each reading (members that need it refuse a batch without).
        t : (N,) array_like or float, seconds, optional
            The time of each reading (members that weigh readings by age refuse a batch
            without). Readings are taken to come in time order.

        Raises
        ------
        ConfigError
            Naming the field: a wrong shape, a non-finite value, a missing wind or time.
        """
        grid = self.grid
        if isinstance(position, Observation):
            o = position
            batch = as_readings(o.position, [o.gas], o.wind, o.t, dim=grid.dim)
        else:
            if reading is None:
                raise ConfigError("reading", "is required with a position")
            batch = as_readings(position, reading, wind, t, dim=grid.dim)
        if self.needs_wind and batch.wind is None:
            raise ConfigError("wind", f"{type(self).__name__} needs the wind of every reading")
        if self._time_needed() and not batch.has_times:
            raise ConfigError("t", f"{type(self).__name__} needs the time of every reading")
        if not len(batch):
            return
        if self._with_wind is not None and self._with_wind != (batch.wind is not None):
            raise ConfigError("wind", "give the wind with every batch or with none")
        self._with_wind = batch.wind is not None
        self._n += len(batch)
        self._parts.append(batch)
        self._all = None
        self._invalidate()

    # ------------------------------------------------------------------ maps
    @abstractmethod
    def _compute_mean(self, readings: Readings) -> FloatArray:
        """The mean map of ``readings`` (at least one), of the grid's shape; blocked cells are
        masked by the caller. A member may keep what :meth:`_compute_spread` needs."""

    @abstractmethod
    def _compute_spread(
        self, readings: Readings, mean: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(variance, confidence, predictive variance)`` maps of ``readings``, computed after
        :meth:`_compute_mean` gave ``mean`` (not yet masked)."""

    def _prior(self, readings: Readings) -> tuple[float, float]:
        """``(mean, variance)`` reported in blocked cells (the member's prior)."""
        return 0.0, 0.0

    def _time_needed(self) -> bool:
        """Whether every reading needs a time (default: :attr:`needs_time`)."""
        return self.needs_time

    def _check(self, name: str, arr: FloatArray) -> FloatArray:
        if arr.shape != self.grid.shape or not np.all(np.isfinite(arr)):
            raise RuntimeError(f"{type(self).__name__} computed a bad {name} map")
        return arr

    def _mean_map(self) -> FloatArray:
        if self._mean is None:
            rd = self.readings
            if not len(rd):
                raise RuntimeError("the map has no readings yet")
            raw = self._compute_mean(rd)
            self._raw_mean = raw
            m0, _ = self._prior(rd)
            self._mean = self._check("mean", np.where(self._blocked, m0, raw))
        return self._mean

    def _check_spread(self) -> None:
        """Refuse (a :class:`ConfigError`) spread maps the member cannot afford on this grid,
        before any work (default: none refused)."""

    def _spread_maps(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        if self._spread is None:
            self._check_spread()
            self._mean_map()
            rd = self.readings
            var, conf, pvar = self._compute_spread(rd, self._raw_mean)
            _, v0 = self._prior(rd)
            self._spread = (
                self._check("variance", np.where(self._blocked, v0, var)),
                self._check("confidence", np.where(self._blocked, 0.0, conf)),
                self._check("predictive variance", np.where(self._blocked, v0, pvar)),
            )
        return self._spread

    def mean(self) -> FloatArray:
        """``(nx, ny[, nz])`` expected reading per cell."""
        return self._mean_map().copy()

    def variance(self) -> FloatArray:
        """``(nx, ny[, nz])`` variance map, as the member's paper defines it: the variance of
        the readings in a cell for the kernel methods, the posterior variance of the cell's
        mean for the GMRF (units squared)."""
        return self._spread_maps()[0].copy()

    def confidence(self) -> FloatArray:
        """``(nx, ny[, nz])`` confidence in [0, 1] (0: the cell says only the prior)."""
        return self._spread_maps()[1].copy()

    def predictive_variance(self) -> FloatArray:
        """``(nx, ny[, nz])`` variance of a new reading in each cell (what the NLPD scores):
        the variance map for the kernel methods, the posterior variance plus the noise of one
        reading for the GMRF."""
        return self._spread_maps()[2].copy()

    def predict(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Predicted mean and variance of a reading at each point: the values of the cell
        that holds it (points outside the grid take the nearest cell), ``((Q,), (Q,))``."""
        p = np.atleast_2d(np.asarray(points, float))
        idx = tuple(self.grid.index(p).T)
        return self.mean()[idx], self.predictive_variance()[idx]

    def score_nlpd(self, held_out: Readings) -> float:
        """NLPD (:func:`nlpd`) of held-out readings under this map's predictions."""
        m, v = self.predict(held_out.positions)
        return nlpd(m, v, held_out.values)

    # ------------------------------------------------------------------ estimator hooks
    def belief(self) -> GasMapBelief | None:
        """The maps as a :class:`GasMapBelief` (``None`` before the first reading)."""
        if self._grid is None or not self._n:
            return None
        var, conf, _ = self._spread_maps()
        return GasMapBelief(self.grid, self.mean(), var.copy(), conf.copy())

    def estimate(self) -> FloatArray:
        """The map maxima (see the module docstring), ``(k, d)`` metres, highest first."""
        if self._grid is None or not self._n:
            d = self._grid.dim if self._grid is not None else 2
            return np.zeros((0, d))
        allowed = ~self._blocked
        if self.params.min_confidence > 0:
            allowed = allowed & (self._spread_maps()[1] >= self.params.min_confidence)
        return map_maxima(
            self.grid,
            self._mean_map(),
            allowed,
            self.params.max_sources,
            self.params.peak_separation,
        )

    def diagnostics(self) -> dict[str, float]:
        """``gas_map_readings``: the readings so far (cheap: no map is computed)."""
        n = 0 if self._grid is None else self.n_readings
        return {"gas_map_readings": float(n)}

    def final_metrics(self) -> dict[str, Any]:
        """``gas_map_readings`` and the highest maximum's coordinates ``gas_map_peak_x, _y
        (, _z)`` (NaN without readings)."""
        d = self._grid.dim if self._grid is not None else 2
        peak = self.estimate()
        out: dict[str, Any] = {"gas_map_readings": 0 if self._grid is None else self.n_readings}
        for a, name in enumerate("xyz"[:d]):
            out[f"gas_map_peak_{name}"] = float(peak[0, a]) if len(peak) else math.nan
        return out


def map_maxima(
    grid: CellGrid, values: FloatArray, allowed: BoolArray, k: int, separation: float
) -> FloatArray:
    """The ``k`` highest local maxima of ``values`` among ``allowed`` cells, each the largest
    value within ``separation`` metres and at least that far from every higher one; ``(k', d)``
    cell centres, highest first (ties: lowest cell index first)."""
    from scipy import ndimage

    if not allowed.any():
        return np.zeros((0, grid.dim))
    v = np.where(allowed, values, -np.inf)
    reach = np.maximum(1, np.floor(separation / grid.cells).astype(int))
    size = tuple(int(2 * r + 1) for r in reach)
    local = (v == ndimage.maximum_filter(v, size=size, mode="constant", cval=-np.inf)) & allowed
    cand = np.flatnonzero(local.ravel())
    order = cand[np.argsort(-v.ravel()[cand], kind="stable")]
    centres = grid.flat_centers()
    chosen: list[np.ndarray] = []
    for c in order:
        p = centres[c]
        if all(float(np.linalg.norm(p - q)) >= separation for q in chosen):
            chosen.append(p)
            if len(chosen) == k:
                break
    return np.array(chosen).reshape(-1, grid.dim)


def build_gas_map(name: str, **params: Any) -> GasMap:
    """A gas map by its registry name and parameters (checked; errors name the field)."""
    from odorloc.core import registry

    p = registry.make_params("gas_map", name, params)
    gm = registry.entry("gas_map", name).build(p)
    if not isinstance(gm, GasMap):  # pragma: no cover - a plugin registered something else
        raise ConfigError("type", f"{name!r} is not a gas map")
    return gm
