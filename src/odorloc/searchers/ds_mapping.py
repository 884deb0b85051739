"""Dempster-Shafer mapping of several odor sources with an uncertainty-driven route (D-S paper).

A recipe composed of three reusable parts:

* :class:`~odorloc.inference.odor_path.OdorPathEstimator` turns the robot's wind record into the
  air-mass path map ``pi`` of the air now at the robot (odor-path paper, eqs. 10-17);
* :class:`~odorloc.inference.dempster_shafer.DSGrid` fuses every reading -- detection *and*
  non-detection -- through that map with Dempster's rule (D-S paper, eqs. 1-4);
* :class:`~odorloc.planning.uncertainty_route.UncertaintyRoutePlanner` picks the next position
  maximising the uncertainty the next reading would cover (D-S paper, eqs. 5-7).

:class:`DSMapper` bundles the first two so that any motion strategy can build the same map:
:class:`DSMappingSearcher` (the paper's dynamic route) and :class:`DSRectangularWaveSearcher`
(the paper's baseline: the predefined rectangular-wave path of
:class:`~odorloc.searchers.simple.RectangularWaveSearcher`, same map).

Readings of the paper (each configurable):

* Map extent. The evidence grid covers the search region (``ctx.info["search_region"]``, else
  the arena) grown by ``map_margin`` (default one cell: the paper's maps mark cells outside the
  work area too, which "should be ignored"; only the region's cells count in ``sum X``, in the
  planner and in the mapped sources); cells are ``cell_size`` metres. The paper does not give
  its cell size, but its residual sums do bound it: 1317.4 after 400 s and 1089.0 after one
  round exceed ``3 M`` (the sum at total ignorance, ``q m(U) = 3`` per cell) unless the
  14 m x 20 m region has ``M > 439`` cells, i.e. cells below about 0.8 m. 0.5 m (``M = 1120``,
  ``3 M = 3360``) is the default: the residual sums are then on the paper's scale and a 0.3 m
  source falls in one or two cells. Finer cells (e.g. 0.25 m, ``M = 4480``) make every reading
  resolve a smaller area, so the route needs several times longer to finish. ``sum X`` is
  reported together with its initial value ``3 M``.
* Reading. ``obs.detection`` (the binarised gas reading) is the event ``D`` or ``notD``; the
  anemometer reading ``obs.wind`` is the air velocity in the world frame (eq. 1, odor-path
  paper). The map of a reading is computed at the reading's own record (no sensor delay: the
  simulated sensor has none unless configured).
* Motion (both routes alike). The paper's robot has a 0.5 m/s speed limit yet both of its
  routes average about half of it: the rectangular wave covers 193.5 m in 781.5 s, 627.1 m in
  2532.5 s and 1060.8 m in 4283.5 s (0.248 m/s at a constant pace over the rounds) and the
  dynamic route 97.4 m in its first 400 s (0.244 m/s). A constant half speed on a predefined
  path means the robot does not move in every time step: it samples at discrete points.
  ``dwell_periods = 1`` (default) reads this as stop-and-go: a move of at most one control
  period at full speed (0.25 m), then one period standing still while reading (on a real
  robot a reading at rest needs no correction for the robot's own motion);
  ``dwell_periods = 0`` drives continuously at full speed. Every period's reading is fused
  either way ("at each time step, the robot collects the odor concentration, airflow speed
  and direction", section 4.1).
* Route. A new target is planned whenever the robot reached the previous one. The candidates
  are "a number of positions around the robot" (section 3), cell centres (eq. 7), "within the
  access of the robot in the next time step". The default reads this as the neighbouring
  cells, excluding the robot's own (``stay_candidate=False``): the first ring is
  ``max(max_speed * dt, sqrt(2) cell_size)``, i.e. the eight neighbours of a 0.5 m cell,
  the positions the robot reaches by its next sample point(s). The paper's dynamic robot
  kept almost the wave's pace early on (0.244 vs 0.248 m/s), so it seldom stood still
  between decisions. ``stay_candidate=True`` with ``step_range = max_speed * dt`` is the
  literal alternative in which, with cells wider than one step, the robot's own cell is the
  only first candidate: the robot then stays and keeps reading while its own air-mass path
  covers ``E >= eta_E`` -- long stops that make the route slower than the wave.
* Region edge. A reading covers only cells upwind of the sensor, so from the centres of the
  region's own cells the downwind-most column can never be read; its cells would keep
  ``X = q`` and keep the stop rule from firing (measured before this was handled: they made
  up 85 % of the dynamic route's residual). The candidates therefore reach half a cell
  past the region (``edge_reach``), clamped onto its edge, where the wave drives anyway.
* Fitness map. Eq. 7 weighs ``X`` with the same ``pi`` that eq. 4 uses (``fitness_path=
  "map"``, default). That map is the maximum over about 20 window-normalised sub-windows, so
  it sums to far more than 1 (about 16 on the paper's scenario) and ``E_P >= eta_E`` holds
  wherever a little uncertainty lies upwind: the route runs on until the map is nearly
  certain. ``fitness_path="distribution"`` divides the map by its sum for eq. 7 only
  (``pi^{P*}`` read as "the probability that the air mass ... comes from the cell C_i", one
  distribution); measured over 5 flows it stops far too early (0.18 of the wave's time,
  3.3 times its residual), so it is not the default.
* Wave rounds. "When the robot arrives at the left-top corner (called 1 round) ... the robot
  comes back to the right-bottom corner, and starts a new round" (section 4.2):
  ``round_order="restart"`` (default) ends each round at the corner diagonally opposite its
  first one (extending the last lane if needed) and goes straight back to the first corner;
  this gives the paper's lengths (193.5 m for round 1, 1060.8 m for five rounds; ours
  194.4 m and 1067.7 m). ``round_order="alternate"`` runs every other round backwards.
* Declaration. The paper leaves it open ("some other methods should be considered next to
  declare the mapped odor sources"). When the planner finds even the whole region below
  ``eta_E`` the searcher declares one position per connected region with
  ``m(S) >= source_min_mass``. Default (``source_rule="peak"``): the centre of the region's
  cell with the largest ``m(S)``. A region is the footprint of where the robot detected
  (``pi`` is concentrated just upwind of the robot, so that is where eq. 4-a puts most mass),
  i.e. the source plus the plume downwind of it; the net support for ``S`` grows with the
  local detection rate (each detection multiplies ``m(notS)/m(S)`` by about 0.46 at
  ``pi = 1``, each non-detection by about 1/0.7), and that rate is highest at the source and
  falls downwind as the filaments meander and dilute. So the ``m(S)`` maximum marks the
  source while the ``m(S)``-weighted centroid (``"centroid"``, :meth:`DSGrid.sources`) is
  pulled downwind by the footprint; ``"upwind"`` takes the centroid of the region's upwind
  end instead. Long runs of detections round ``m(S)`` to exactly 1.0 in many cells, so the
  peak is ranked by ``m(notS) + m(U)`` (stored apart, exact), i.e. by the evidence itself.
  Measured over 10 recorded flows (root seeds 2024 and 7, final maps of both routes): both
  sources within 1.5 m in 10/10 wave and 8/10 dynamic maps with ``"peak"`` (3/10 dynamic
  when ties went by index order), 9/10 and 2/10 with ``"upwind"``, 2/10 and 6/10 with
  ``"centroid"``. If no cell passes the threshold the cell with the largest ``m(S)`` is
  declared with confidence 0, so an episode always scores.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, model_validator
from scipy import ndimage

from odorloc.errors import ConfigError
from odorloc.inference.belief import GridBelief
from odorloc.inference.dempster_shafer import DSGrid, DSParams, EvidenceSource
from odorloc.inference.odor_path import OdorPathEstimator, OdorPathParams, PathPatch
from odorloc.params import NonNegative, Params, Positive
from odorloc.planning.uncertainty_route import (
    RoutePlan,
    UncertaintyRouteParams,
    UncertaintyRoutePlanner,
)
from odorloc.registry import register
from odorloc.searchers.base import (
    Action,
    Command,
    Declaration,
    Observation,
    SearchContext,
    Searcher,
)
from odorloc.searchers.simple import rectangular_wave

__all__ = [
    "DSMapper",
    "DSMapperParams",
    "DSMappingParams",
    "DSMappingSearcher",
    "DSRectangularWaveParams",
    "DSRectangularWaveSearcher",
    "search_region",
    "wave_waypoints",
]

Region = tuple[tuple[float, float], tuple[float, float]]
FloatArray = NDArray[np.float64]
_REACHED = 1e-6  # metres: a goal this close counts as reached


def _check_region(region: Region | None) -> Region | None:
    if region is not None:
        (x0, y0), (x1, y1) = region
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1)) or x1 <= x0 or y1 <= y0:
            raise ValueError("region needs finite ((x0, y0), (x1, y1)) with x1 > x0, y1 > y0")
    return region


class DSMapperParams(Params):
    """Parameters of the D-S map shared by the mapping searchers.

    Attributes
    ----------
    cell_size : float, metres
        Side of an evidence/path-map cell (see the module notes; 0.5 m).
    map_margin : float, metres, optional
        The map covers the search region grown by this margin on every side; default one cell
        (see the module notes).
    region : ((x0, y0), (x1, y1)), optional
        Search region, metres; default ``ctx.info["search_region"]``, else the arena bounds.
    t_thr : float, seconds
        Wind history that opens sub-windows (odor-path paper: 10 s).
    noise_time_scale : float, seconds
        ``tau`` of the path-map variance ``(t_c - t_r) tau sigma_u^2`` (odor-path estimator).
    min_variance : float, m^2/s^2
        Floor on the wind-velocity variance per axis.
    kernel : {"point", "cell"}
        Path-map kernel (odor-path paper eq. 11 or the exact cell integral).
    ds : DSParams
        Belief-mass and uncertainty parameters (mu_D 0.9, mu_notD 1.0, zeta 0.6, rho 0.5, q 3).
    source_min_mass : float
        ``m(S)`` a cell needs to belong to a mapped source, in (0, 1].
    source_min_cells : int
        Smallest connected region counted as a mapped source.
    source_rule : {"centroid", "upwind", "peak"}
        Position declared for a mapped region: the centre of its cell with the largest
        ``m(S)`` (``"peak"``, default, see the module notes), its ``m(S)``-weighted centroid
        (``"centroid"``, the paper's maps are read by eye), or the weighted centroid
        of its cells within ``upwind_depth`` of its most upwind cell along the mean recorded
        wind (``"upwind"``: detections also mark the plume downwind of a source, so a region
        stretches downwind and its centroid lies downwind of the source).
    upwind_depth : float, metres
        Depth of the upwind end used by ``source_rule="upwind"``.
    dwell_periods : int
        Control periods the robot stands still reading after each move of at most one period
        (stop-and-go sampling, see the module notes; 0 drives continuously).
    path_normalise : {"window", "total"}
        ``pi`` as the odor-path estimator gives it (each sub-window normalised, the maximum
        over windows: odor-path paper eq. 17; default), or that map divided by its sum so that
        ``sum_i pi_i = 1`` (``"total"``: "the probability that the air mass arrived at the
        robot comes from the cell C_i", D-S paper section 2.2, read as one distribution).
        Measured: with ``"total"`` each reading carries so little mass that after 4274 s the
        wave still leaves ``sum X`` = 1516 and the dynamic route 1030 after 5000 s (paper:
        254.1 and 157.1; ``"window"``: 88 and 114), so ``"window"`` is the default.
    """

    cell_size: Positive = 0.5
    map_margin: NonNegative | None = None
    region: Region | None = None
    t_thr: Positive = 10.0
    noise_time_scale: Positive = 1.0
    min_variance: Positive = 1e-4
    kernel: Literal["point", "cell"] = "point"
    ds: DSParams = DSParams()
    source_min_mass: float = Field(0.5, gt=0.0, le=1.0)
    source_min_cells: int = Field(1, ge=1)
    source_rule: Literal["centroid", "upwind", "peak"] = "peak"
    upwind_depth: Positive = 1.5
    dwell_periods: int = Field(1, ge=0)
    path_normalise: Literal["window", "total"] = "window"

    @model_validator(mode="after")
    def _check(self) -> DSMapperParams:
        _check_region(self.region)
        return self


def search_region(ctx: SearchContext, region: Region | None = None) -> Region:
    """The region to map: ``region``, else ``ctx.info["search_region"]``, else the arena."""
    if region is not None:
        lo, hi = region
    elif "search_region" in ctx.info:
        lo, hi = ctx.info["search_region"]
    else:
        lo, hi = ctx.arena.lo[:2], ctx.arena.hi[:2]
    lo_t = (float(lo[0]), float(lo[1]))
    hi_t = (float(hi[0]), float(hi[1]))
    if (
        not all(math.isfinite(v) for v in (*lo_t, *hi_t))
        or hi_t[0] <= lo_t[0]
        or hi_t[1] <= lo_t[1]
    ):
        raise ConfigError("info.search_region", f"invalid region {lo_t}, {hi_t}")
    return lo_t, hi_t


def _as_distribution(patch: PathPatch) -> PathPatch:
    """The path map divided by its sum (unchanged if empty)."""
    total = float(patch.values.sum()) if patch.values.size else 0.0
    if total <= 0:
        return patch
    return PathPatch(patch.ix0, patch.iy0, patch.values / total, patch.grid, patch.ref_cell)


class DSMapper:
    """Odor-path estimator + Dempster-Shafer grid: the map both mapping searchers build.

    Parameters
    ----------
    params : DSMapperParams
    region : ((x0, y0), (x1, y1)), metres
        Search region (uncertainty and sources are reported over it).
    dt : float, seconds
        Record period (the control period).
    """

    def __init__(self, params: DSMapperParams, region: Region, dt: float) -> None:
        self.params = params
        self.region = region
        m = params.cell_size if params.map_margin is None else params.map_margin
        lower = (region[0][0] - m, region[0][1] - m)
        upper = (region[1][0] + m, region[1][1] + m)
        self.estimator = OdorPathEstimator(
            OdorPathParams(
                cell_size=params.cell_size,
                t_thr=params.t_thr,
                dt=dt,
                noise_time_scale=params.noise_time_scale,
                min_variance=params.min_variance,
                kernel=params.kernel,
            ),
            lower,
            upper,
        )
        self.grid = DSGrid(params.ds, self.estimator.grid)
        self.n_detections = 0
        self.n_readings = 0
        self.wind_sum = np.zeros(2)
        self.initial_uncertainty = self.total_uncertainty()
        self.last_patch: PathPatch | None = None

    def update(self, t: float, position: np.ndarray, wind: np.ndarray, detected: bool) -> PathPatch:
        """Fuse one reading: record it, compute its air-mass path map, update the grid.

        Parameters
        ----------
        t : float, seconds
        position : (d,) ndarray, metres
            Sensor position (the first two components are used).
        wind : (d,) ndarray, m/s
            Anemometer reading, world frame.
        detected : bool
            Detection (eq. 4-a) or non-detection (eq. 4-b), D-S paper.

        Returns
        -------
        PathPatch
            The air-mass path map ``pi`` of this reading.
        """
        pos = np.asarray(position, float)[:2]
        u = np.asarray(wind, float)[:2]
        self.estimator.update(t, pos, u, 1.0 if detected else 0.0)
        # The path map is the same for both events; only the masses differ (eq. 4).
        patch = self.estimator.path_patch()
        if self.params.path_normalise == "total":
            patch = _as_distribution(patch)
        self.grid.update(patch, bool(detected))
        self.n_readings += 1
        self.n_detections += int(bool(detected))
        self.wind_sum += u
        self.last_patch = patch
        return patch

    def total_uncertainty(self) -> float:
        """``sum_i X_i`` over the search region (eq. 5)."""
        return self.grid.total_uncertainty(self.region)

    def sources(self) -> list[EvidenceSource]:
        """Mapped sources inside the search region, heaviest first (``m(S)`` centroids)."""
        return self.grid.sources(
            min_mass=self.params.source_min_mass,
            min_cells=self.params.source_min_cells,
            region=self.region,
        )

    def _regions(self) -> tuple[NDArray[np.intp], list[int]]:
        """Connected ``m(S) >= source_min_mass`` regions in the search region: the label image
        and the labels of those with ``source_min_cells`` cells or more, heaviest first (the
        order of :meth:`sources`)."""
        p = self.params
        mask = (self.grid.m_s >= p.source_min_mass) & self.grid.grid.region_mask(self.region)
        labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
        kept = []
        for lab in range(1, n + 1):
            cells = labels == lab
            if np.count_nonzero(cells) >= p.source_min_cells:
                kept.append((float(self.grid.m_s[cells].sum()), lab))
        kept.sort(key=lambda v: -v[0])
        return labels, [lab for _, lab in kept]

    def upwind_ends(self) -> FloatArray:
        """``(K, 2)`` upwind-end positions of the mapped regions, same order as :meth:`sources`.

        For each connected region the ``m(S)``-weighted centroid of its cells within
        ``upwind_depth`` metres (along the mean recorded wind) of its most upwind cell.
        """
        g = self.grid.grid
        labels, kept = self._regions()
        norm = float(np.hypot(*self.wind_sum))
        u = self.wind_sum / norm if norm > 0 else np.array([1.0, 0.0])
        centres = g.centers()
        along = centres @ u  # metres downwind
        out = []
        for lab in kept:
            cells = labels == lab
            tip = cells & (along <= along[cells].min() + self.params.upwind_depth)
            wt = np.where(tip, self.grid.m_s, 0.0)
            out.append((wt[..., None] * centres).sum((0, 1)) / wt.sum())
        return np.array(out).reshape(-1, 2)

    def peaks(self) -> FloatArray:
        """``(K, 2)`` centre of the cell with the largest ``m(S)`` of each mapped region, same
        order as :meth:`sources` (ranked by ``m(notS) + m(U)``, see below; exact ties: the
        first cell in index order)."""
        labels, kept = self._regions()
        if not kept:
            return np.zeros((0, 2))
        # m(S) = 1 - (m(notS) + m(U)) rounds to exactly 1.0 in every cell of a long run of
        # detections, which would leave the choice to index order; the doubt m(notS) + m(U) is
        # stored separately and keeps ranking those cells by their evidence
        doubt = self.grid.m_n + self.grid.m_u
        pos = ndimage.minimum_position(doubt, labels, kept)
        return self.grid.grid.center(np.array(pos)).reshape(-1, 2)

    def source_positions(self) -> FloatArray:
        """``(K, 2)`` mapped source positions by ``source_rule``, heaviest region first."""
        if self.params.source_rule == "upwind":
            return self.upwind_ends()
        if self.params.source_rule == "peak":
            return self.peaks()
        return np.array([s.position for s in self.sources()]).reshape(-1, 2)

    def declaration(self) -> Declaration:
        """The mapped sources as a declaration (see the module notes for the empty case)."""
        found = self.source_positions()
        if len(found):
            return Declaration(found, confidence=1.0)
        ms = np.where(self.grid.grid.region_mask(self.region), self.grid.m_s, -1.0)
        best = np.unravel_index(int(np.argmax(ms)), ms.shape)
        return Declaration(self.grid.grid.center(np.array(best)), confidence=0.0)

    def final_metrics(self) -> dict[str, float]:
        """Row fields: residual/initial uncertainty, mapped-source count and positions.

        ``mapped_x_k, mapped_y_k`` follow ``source_rule``; ``centroid_*_k``, ``upwind_*_k``
        and ``peak_*_k`` are the three estimates of the same regions whatever the rule.
        """
        found = self.sources()
        pos = self.source_positions()
        tips = self.upwind_ends()
        tops = self.peaks()
        out: dict[str, float] = {
            "residual_uncertainty": self.total_uncertainty(),
            "initial_uncertainty": self.initial_uncertainty,
            "mapped_sources": float(len(found)),
            "detections": float(self.n_detections),
            "max_conflict": float(self.grid.max_conflict),
        }
        for k, s in enumerate(found):
            out[f"mapped_x_{k}"] = float(pos[k, 0])
            out[f"mapped_y_{k}"] = float(pos[k, 1])
            out[f"mapped_mass_{k}"] = float(s.total_mass)
            out[f"upwind_x_{k}"] = float(tips[k, 0])
            out[f"upwind_y_{k}"] = float(tips[k, 1])
            out[f"centroid_x_{k}"] = float(s.position[0])
            out[f"centroid_y_{k}"] = float(s.position[1])
            out[f"peak_x_{k}"] = float(tops[k, 0])
            out[f"peak_y_{k}"] = float(tops[k, 1])
        return out


class _StopAndGo:
    """Stop-and-go motion towards a goal: a move of at most ``step`` metres, then ``dwell``
    periods standing still (see the module notes).

    Parameters
    ----------
    step : float, metres
        Longest move per control period (speed limit times period).
    dwell : int
        Periods held after each move.
    """

    def __init__(self, step: float, dwell: int) -> None:
        self.step = float(step)
        self.dwell = int(dwell)
        self.goal: FloatArray | None = None
        self.hold_left = 0
        self._last_dist = math.inf

    def set_goal(self, goal: ArrayLike) -> None:
        """Head for ``goal`` (2,), metres."""
        self.goal = np.asarray(goal, float)[:2].copy()
        self._last_dist = math.inf

    def arrived(self, position: ArrayLike) -> bool:
        """``True`` when there is no goal, it was reached, or the last move made no progress
        (e.g. blocked), once the dwell after the last move is over."""
        if self.hold_left > 0:
            return False
        if self.goal is None:
            return True
        dist = float(np.hypot(*(np.asarray(position, float)[:2] - self.goal)))
        if dist <= _REACHED or dist >= self._last_dist - _REACHED:
            self.goal = None
            return True
        return False

    def command(self, position: ArrayLike) -> Command:
        """The command of this period: hold while dwelling, else one move towards the goal."""
        if self.hold_left > 0 or self.goal is None:
            self.hold_left = max(self.hold_left - 1, 0)
            return Command.hold()
        pos = np.asarray(position, float)
        d = self.goal - pos[:2]
        dist = float(np.hypot(*d))
        self._last_dist = dist
        target = pos.copy()
        target[:2] = pos[:2] + d * min(1.0, self.step / dist) if dist > 0 else self.goal
        self.hold_left = self.dwell
        return Command.waypoint(target)


def _reset_mapper(params: DSMapperParams, ctx: SearchContext) -> DSMapper:
    if ctx.n_agents != 1:
        raise ConfigError("agents.starts", "the D-S mapping searchers drive a single robot")
    return DSMapper(params, search_region(ctx, params.region), ctx.dt)


# ------------------------------------------------------------------------ dynamic route
class DSMappingParams(DSMapperParams):
    """Parameters of :class:`DSMappingSearcher` (the map's plus the route's).

    Attributes
    ----------
    step_range : float, metres, optional
        First candidate radius; default ``max(max_speed * dt, sqrt(2) cell_size)`` (the
        neighbouring cells), or ``max_speed * dt`` with ``stay_candidate`` (see the module
        notes).
    stay_candidate : bool
        Whether the robot's own cell is a candidate (staying put); default ``False``.
    fitness_path : {"map", "distribution"}
        ``pi`` weighing ``X`` in eq. 7: the reading's path map as eq. 4 uses it (default), or
        that map divided by its sum (see the module notes).
    edge_reach : float, metres, optional
        Candidate cells may have centres this far outside the region, their targets clamped
        onto its edge (:class:`~odorloc.planning.uncertainty_route.UncertaintyRouteParams`);
        default half a cell, so the robot can stand on the region's edge like the wave and
        cover the downwind-most cells (see the module notes).
    widen_factor : float
        Radius multiplier while the best fitness is below ``eta_e`` (> 1).
    eta_e : float
        ``eta_E`` of the stop rule (0.5, D-S paper section 3).
    """

    step_range: Positive | None = None
    stay_candidate: bool = False
    edge_reach: NonNegative | None = None
    fitness_path: Literal["map", "distribution"] = "map"
    widen_factor: float = Field(2.0, gt=1.0)
    eta_e: NonNegative = 0.5


@register(
    "searcher",
    "ds-mapping",
    DSMappingParams,
    "D-S evidence map of several sources + uncertainty-driven route (D-S paper)",
)
class DSMappingSearcher(Searcher):
    """The D-S paper's method: map every reading, go where the most uncertainty is covered.

    Declares the mapped sources when no position in the whole region reaches ``eta_E``.
    """

    def __init__(self, params: DSMappingParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        self.mapper = _reset_mapper(p, ctx)
        # "within the access of the robot in the next time step" (section 3)
        reach = ctx.max_speed * ctx.dt
        if p.step_range is not None:
            step = p.step_range
        elif p.stay_candidate:
            step = reach
        else:
            # the eight neighbouring cell centres (the tolerance keeps the diagonals in)
            step = max(reach, math.sqrt(2.0) * p.cell_size * (1.0 + 1e-9))
        self.planner = UncertaintyRoutePlanner(
            UncertaintyRouteParams(
                step_range=step,
                widen_factor=p.widen_factor,
                eta_e=p.eta_e,
                region=self.mapper.region,
                include_current=p.stay_candidate,
                edge_reach=0.5 * p.cell_size if p.edge_reach is None else p.edge_reach,
            )
        )
        self.motion = _StopAndGo(reach, p.dwell_periods)
        self.last_plan: RoutePlan | None = None
        self.n_plans = 0
        self.finished_at = math.nan

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        patch = self.mapper.update(o.t, o.position, o.wind, o.detection)
        if not self.motion.arrived(o.position):
            return Action([self.motion.command(o.position)])
        if self.params.fitness_path == "distribution":
            patch = _as_distribution(patch)
        plan = self.planner.plan_detailed(self.mapper.grid, patch, o.position[:2], rng)
        self.last_plan = plan
        self.n_plans += 1
        if plan.target is None:
            self.finished_at = o.t
            return Action([Command.hold()], declaration=self.mapper.declaration())
        self.motion.set_goal(plan.target)
        return Action([self.motion.command(o.position)])

    def belief(self) -> GridBelief:
        return self.mapper.grid.belief()

    def diagnostics(self) -> dict[str, float]:
        fit = self.last_plan.fitness if self.last_plan is not None else math.nan
        return {
            "total_uncertainty": self.mapper.total_uncertainty(),
            "mapped_sources": float(len(self.mapper.sources())),
            "fitness": float(fit),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`) plus the planner's count."""
        return {**self.mapper.final_metrics(), "plans": float(self.n_plans)}


def wave_waypoints(
    region: Region,
    lane_spacing: float,
    lanes_along: str,
    rounds: int,
    start: ArrayLike,
    margin: float = 0.0,
    round_order: str = "restart",
) -> FloatArray:
    """Corners of the rectangular-wave path over all rounds, ``(W, 2)`` metres.

    Parameters
    ----------
    region : ((x0, y0), (x1, y1)), metres
    lane_spacing : float, metres
    lanes_along : {"x", "y"}
    rounds : int
    start : (2,) array_like, metres
        The first round starts at the region corner nearest to it.
    margin : float, metres
        Distance kept from the region's edges.
    round_order : {"restart", "alternate"}
        See :class:`DSRectangularWaveParams`.
    """
    lo = np.asarray(region[0], float) + margin
    hi = np.asarray(region[1], float) - margin
    if np.any(hi <= lo):
        raise ConfigError("searcher.margin", "leaves no area to cover")
    one = rectangular_wave(lo, hi, lane_spacing, lanes_along, np.asarray(start, float)[:2])
    if round_order == "alternate":
        return np.concatenate([one if r % 2 == 0 else one[::-1] for r in range(rounds)])
    # "arrives at the left-top corner (called 1 round) ... comes back to the right-bottom
    # corner, and starts a new round" (section 4.2)
    opposite = lo + hi - one[0]
    if not np.allclose(one[-1], opposite):
        one = np.vstack([one, opposite])
    return np.concatenate([one] * rounds)


# ------------------------------------------------------------------- rectangular wave
class DSRectangularWaveParams(DSMapperParams):
    """Parameters of :class:`DSRectangularWaveSearcher` (the map's plus the path's).

    Attributes
    ----------
    lane_spacing : float, metres
        Lane offset (2 m in the D-S paper).
    lanes_along : {"x", "y"}
        Direction of the long legs (``"y"``: vertical legs, as in the paper).
    rounds : int
        Passes over the region (5 in the paper).
    margin : float, metres
        Distance kept from the region's edges.
    round_order : {"restart", "alternate"}
        ``"restart"``: every round ends at the corner diagonally opposite its first corner and
        the robot goes straight back to start the next (the paper, section 4.2);
        ``"alternate"``: every other round is run backwards (see the module notes).
    """

    lane_spacing: Positive = 2.0
    lanes_along: Literal["x", "y"] = "y"
    rounds: int = Field(5, ge=1)
    margin: NonNegative = 0.0
    round_order: Literal["restart", "alternate"] = "restart"


@register(
    "searcher",
    "ds-rectangular-wave",
    DSRectangularWaveParams,
    "rectangular-wave coverage building the same D-S map (D-S paper baseline)",
)
class DSRectangularWaveSearcher(Searcher):
    """The D-S paper's baseline: a predefined rectangular-wave path, the same D-S map.

    The lanes are those of :class:`~odorloc.searchers.simple.RectangularWaveSearcher`
    (:func:`~odorloc.searchers.simple.rectangular_wave`); rounds follow ``round_order`` and the
    robot moves stop-and-go like the dynamic route (``dwell_periods``). After the last round the
    mapped sources are declared.
    """

    def __init__(self, params: DSRectangularWaveParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        self.mapper = _reset_mapper(p, ctx)
        self.waypoints = wave_waypoints(
            self.mapper.region,
            p.lane_spacing,
            p.lanes_along,
            p.rounds,
            ctx.start[0, :2],
            p.margin,
            p.round_order,
        )
        self.index = 0
        self.motion = _StopAndGo(ctx.max_speed * ctx.dt, p.dwell_periods)
        self.motion.set_goal(self.waypoints[0])

    @property
    def done(self) -> bool:
        """``True`` once the last waypoint of the last round was reached."""
        return self.index >= len(self.waypoints)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        self.mapper.update(o.t, o.position, o.wind, o.detection)
        if not self.done and self.motion.arrived(o.position):
            self.index += 1
            if not self.done:
                self.motion.set_goal(self.waypoints[self.index])
        if self.done:
            return Action([Command.hold()], declaration=self.mapper.declaration())
        return Action([self.motion.command(o.position)])

    def belief(self) -> GridBelief:
        return self.mapper.grid.belief()

    def diagnostics(self) -> dict[str, float]:
        return {
            "total_uncertainty": self.mapper.total_uncertainty(),
            "mapped_sources": float(len(self.mapper.sources())),
            "waypoint": float(self.index),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`)."""
        return self.mapper.final_metrics()
