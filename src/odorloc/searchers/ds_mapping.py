"""Dempster-Shafer mapping of several odor sources: the dynamic route and its baseline (D-S paper).

Both searchers build the same map (the estimator ``ds-map``,
:class:`~odorloc.inference.evidence.mapper.DSMapEstimator`: odor-path maps fused by Dempster's
rule) and differ in how they move:

* :class:`DSMappingSearcher` (``ds-mapping``), the paper's dynamic route: the next position
  maximises the uncertainty the next reading would cover
  (:class:`~odorloc.planning.uncertainty_route.UncertaintyRoutePlanner`, eqs. 5-7);
* :class:`DSRectangularWaveSearcher` (``ds-rectangular-wave``), the paper's baseline: a
  predefined rectangular-wave path of several rounds (:mod:`odorloc.planning.coverage`).

Readings of the paper (each configurable):

* Motion (both routes alike). The paper's robot has a 0.5 m/s speed limit yet both routes
  average about half of it (0.248 m/s on the wave, 0.244 m/s for the dynamic route's first
  400 s), so the robot samples at discrete points: ``dwell_periods = 1`` (default) reads this as
  stop-and-go (:class:`~odorloc.behaviours.stop_and_go.StopAndGo`: a move of at most one
  period at full speed, then one period standing still while reading); ``0`` drives on. Every
  period's reading is fused either way ("at each time step, the robot collects the odor
  concentration, airflow speed and direction", section 4.1).
* Route. A new target is planned whenever the robot reached the previous one. The candidates
  are "a number of positions around the robot" (section 3), cell centres (eq. 7), "within the
  access of the robot in the next time step": by default the eight neighbouring cells
  (``stay_candidate=False``; the first ring is ``max(max_speed * dt, sqrt(2) cell_size)``).
  ``stay_candidate=True`` with ``step_range = max_speed * dt`` is the literal alternative in
  which, with cells wider than one step, the robot's own cell is the only first candidate.
* Region edge. A reading covers only cells upwind of the sensor, so from the centres of the
  region's own cells the downwind-most column could never be read and would hold the stop
  rule off; candidates reach ``edge_reach`` (half a cell) past the region, clamped onto its
  edge, where the wave drives anyway.
* Fitness map. Eq. 7 weighs ``X`` with the same ``pi`` that eq. 4 uses (``fitness_path="map"``,
  default); that map is the maximum over window-normalised sub-windows and sums to far more
  than 1, so the route runs on until the map is nearly certain. ``"distribution"`` divides it
  by its sum for eq. 7 only.
* Visiting the mapped sources. A detection marks every cell of its air-mass path, so the
  cells upwind of the readings along a plume saturate at ``m(S) = 1`` whether they hold the
  source or its footprint; their ``X`` is then about zero, eq. 7 never sends the robot closer,
  and readings taken ``d`` metres downwind cannot tell where along those ``d`` metres the
  source is (the likelihood estimate then lies just upwind of the nearest readings, metres
  downwind of the source). The paper leaves this open ("some other methods should be
  considered next to declare the mapped odor sources", section 4.4; "more exploration should
  be performed for these cells", section 4.2). When eq. 7's stop rule holds, the route
  therefore visits every mapped source whose cell has given fewer than ``visit_readings``
  readings whose air came over mapped cells, nearest first: it reads standing in that cell
  (its readings cover the cells just upwind), then in the next mapped cell upwind along the
  mean recorded wind, and so on up the mapped plume until a cell is not mapped or the region
  ends; a visit lasts at most ``visit_dwell``, the whole stage at most ``visit_time``. Then the
  estimates are read again and any new unvisited one is visited. Before the declaration the
  visited sources are re-placed by the readings of the visits alone
  (:meth:`~odorloc.inference.evidence.mapper.DSMapper.refined`): a walk up a plume detects
  while the source is upwind and stops detecting past it. The map update is unchanged; the
  stage only adds readings.
* Obstacles (the paper's area has none). The dynamic route never targets a cell whose target
  point lies in an obstacle, and reaches a target out of sight along an A* path
  (:func:`~odorloc.planning.astar.astar_path`) instead of stopping at the obstacle; the map
  itself, like the paper's air-mass paths, ignores obstacles.
* Wave rounds: ``round_order="restart"`` (default; section 4.2) or ``"alternate"``.
* Declaration. When the planner finds even the whole region below ``eta_E`` and the mapped
  sources have been visited (dynamic route), or after the last round (wave), the mapped
  sources are declared (placed by the map's
  ``source_rule``, see :mod:`odorloc.inference.evidence.mapper`); if there is none the
  strongest cell is declared with confidence 0, so an episode always scores.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import Field

from odorloc.behaviours.stop_and_go import StopAndGo
from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Positive
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.inference.belief import GridBelief
from odorloc.inference.estimator import Estimator
from odorloc.inference.evidence.mapper import DSMapEstimator, DSMapParams, DSMapper
from odorloc.inference.odor_path.estimator import PathPatch
from odorloc.models.base import MeasurementModel
from odorloc.planning.astar import astar_path
from odorloc.planning.base import Plan, Pose
from odorloc.planning.coverage import wave_waypoints
from odorloc.planning.uncertainty_route import UncertaintyRouteParams, UncertaintyRoutePlanner
from odorloc.searchers.base import Searcher

__all__ = [
    "DSMappingParams",
    "DSMappingSearcher",
    "DSRectangularWaveParams",
    "DSRectangularWaveSearcher",
]


class _MappingSearcher(Searcher):
    """A single robot building the D-S map (:attr:`map`, its :class:`DSMapper` :attr:`mapper`)."""

    params: DSMapParams
    max_agents = 1
    dims = (2,)

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """A blank map (one robot's)."""
        super().reset(ctx, rng)
        if ctx.n_agents != 1:
            raise ConfigError("agents.starts", "the D-S mapping searchers drive a single robot")
        self.map = DSMapEstimator(self.params)
        self.map.reset(ctx, None, rng)
        self.mapper: DSMapper = self.map.mapper

    def belief(self) -> GridBelief:
        return self.map.belief()

    def estimation(self) -> tuple[Estimator, MeasurementModel | None]:
        """The D-S map (it needs no model)."""
        return DSMapEstimator(self.params), None


def _tag(decl: Declaration, agent: int) -> Declaration:
    return Declaration(decl.positions, decl.confidence, agent=agent)


# ------------------------------------------------------------------------ dynamic route
class DSMappingParams(DSMapParams):
    """Parameters of :class:`DSMappingSearcher` (the map's plus the route's).

    Attributes
    ----------
    dwell_periods : int
        Control periods the robot stands still reading after each move of at most one period
        (stop-and-go sampling; 0 drives continuously).
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
        cover the downwind-most cells (see the module notes). Must not exceed the map's margin
        (``map_margin``), beyond which there are no cells.
    widen_factor : float
        Radius multiplier while the best fitness is below ``eta_e`` (> 1).
    eta_e : float
        ``eta_E`` of the stop rule (0.5, D-S paper section 3).
    visit_readings : int
        Readings taken in a mapped source's cell whose air came over mapped cells (``pi >=
        0.5`` on a cell with ``m(S) >= source_min_mass``) before the mission may end (see the
        module notes); 0 declares as soon as eq. 7's stop rule holds.
    visit_dwell : float, seconds
        Longest time one visit lasts (from the moment it is chosen), however few of its
        readings came over mapped cells.
    visit_time : float, seconds
        Longest time spent visiting mapped sources after eq. 7's stop rule held; then the
        sources mapped by then are declared.
    """

    dwell_periods: int = Field(1, ge=0, le=1000)
    step_range: Positive | None = None
    stay_candidate: bool = False
    edge_reach: NonNegative | None = None
    fitness_path: Literal["map", "distribution"] = "map"
    widen_factor: float = Field(2.0, gt=1.0, allow_inf_nan=False)
    eta_e: NonNegative = 0.5
    visit_readings: int = Field(10, ge=0, le=100_000)
    visit_time: NonNegative = 900.0
    visit_dwell: Positive = 120.0


@register(
    "searcher",
    "ds-mapping",
    DSMappingParams,
    "D-S evidence map of several sources + uncertainty-driven route (D-S paper)",
)
class DSMappingSearcher(_MappingSearcher):
    """The D-S paper's method: map every reading, go where the most uncertainty is covered.

    Declares the mapped sources when no position in the whole region reaches ``eta_E``.
    """

    params: DSMappingParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        # "within the access of the robot in the next time step" (section 3)
        reach = ctx.max_speed * ctx.dt
        if p.step_range is not None:
            step = p.step_range
        elif p.stay_candidate:
            step = reach
        else:
            # the eight neighbouring cell centres (the tolerance keeps the diagonals in)
            step = max(reach, math.sqrt(2.0) * p.cell_size * (1.0 + 1e-9))
        edge = 0.5 * p.cell_size if p.edge_reach is None else p.edge_reach
        margin = p.cell_size if p.map_margin is None else p.map_margin
        if edge > margin * (1.0 + 1e-9):
            # candidates beyond the map's margin have no cell: the robot could not stand on the
            # region's edge and the downwind-most cells would never be read (module notes)
            raise ConfigError(
                "searcher.edge_reach",
                f"{edge:g} m reaches past map_margin {margin:g} m, where the map has no cells; "
                "set map_margin >= edge_reach or edge_reach to 0",
            )
        self.planner = UncertaintyRoutePlanner(
            UncertaintyRouteParams(
                step_range=step,
                widen_factor=p.widen_factor,
                eta_e=p.eta_e,
                region=self.mapper.region,
                include_current=p.stay_candidate,
                edge_reach=edge,
                fitness_path=p.fitness_path,
            )
        )
        self.planner.reset(ctx)
        self.motion = StopAndGo(reach, p.dwell_periods)
        self.last_plan: Plan | None = None
        # the remaining waypoints of a detour around obstacles (see :meth:`_head_for`)
        self._route: list[np.ndarray] = []
        self.n_plans = 0
        self.finished_at = math.nan
        # readings taken in each cell whose air came over mapped cells (the visit stage's test)
        self.tests = np.zeros(self.mapper.grid.grid.shape, np.int64)
        self.stop_rule_at = math.nan
        self.n_visits = 0
        self._visit: tuple[int, ...] | None = None
        self._visit_since = math.nan

    def _tests_mapped(self, patch: PathPatch) -> bool:
        """Whether a reading's air came over a mapped cell (``pi >= 0.5`` on a cell with
        ``m(S) >= source_min_mass``): only such a reading tests where along a mapped plume its
        source lies."""
        occupied = self.mapper.grid.m_s[patch.slices] >= self.params.source_min_mass
        return bool(np.any(occupied & (patch.values >= 0.5)))

    def _upwind_of(self, cell: tuple[int, ...]) -> tuple[int, ...] | None:
        """The mapped, not yet visited cell one cell upwind (mean recorded wind) of ``cell``
        inside the region, or ``None``."""
        g = self.mapper.grid.grid
        u = self.mapper.wind_sum
        norm = float(np.hypot(*u))
        if norm <= 0:
            return None
        xy = g.center(np.array(cell))[0] - g.cell_size * u / norm
        (x0, y0), (x1, y1) = self.mapper.region
        if not (x0 <= xy[0] <= x1 and y0 <= xy[1] <= y1):
            return None
        up = self._cell(xy)
        if up == cell or self.mapper.visited[up]:
            return None
        if self.mapper.grid.m_s[up] < self.params.source_min_mass:
            return None
        return up

    def _head_for(self, target: np.ndarray, position: np.ndarray) -> None:
        """Head for ``target``: straight when in sight, else along an A* path around the
        obstacles, whose later waypoints :meth:`act` takes in turn (straight again if there is
        none: the stop-and-go motion then stops at the obstacle and a new target is chosen)."""
        arena = self.ctx.arena
        here = np.asarray(position, float)[:2]
        goal = np.asarray(target, float)[:2]
        self._route = []
        if arena.occ is not None and not arena.segment_free(here, goal)[0]:
            path = astar_path(arena, here, goal)
            if path is not None and len(path) > 2:
                self._route = list(path[2:])
                goal = path[1]
        self.motion.set_goal(goal)

    def _cell(self, xy: np.ndarray) -> tuple[int, ...]:
        return tuple(int(i) for i in self.mapper.grid.grid.index(np.asarray(xy, float)[:2])[0])

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        self.map.update(o)
        patch = self.map.fused
        if patch is not None and patch.values.size and self._tests_mapped(patch):
            # the cell the fused reading was taken in: with ``preprocess`` it is the reading of
            # ``delay`` seconds ago, not the robot's cell now
            self.tests[tuple(int(i) for i in patch.ref_cell)] += 1
        if not self.motion.arrived(o.position):
            return Action([self.motion.command(o.position)])
        if self._route:  # the next leg of a detour
            self.motion.set_goal(self._route.pop(0))
            return Action([self.motion.command(o.position)])
        if patch is None:  # the first pre-processed reading is not due yet
            return Action([Command.hold()])
        if math.isnan(self.stop_rule_at):
            plan = self.planner.plan(self.map.belief(), Pose(np.asarray(o.position, float)), rng)
            self.last_plan = plan
            self.n_plans += 1
            if plan.target is not None:
                self._head_for(plan.target, o.position)
                return Action([self.motion.command(o.position)])
            self.stop_rule_at = o.t
            if self.params.visit_readings > 0:
                # from now on the visited sources are placed by the visits' readings, also if
                # the time limit ends the stage
                self.mapper.start_close_look()
        target = self._next_visit(o)
        if target is None:
            self.finished_at = o.t
            decl = self.mapper.declaration()
            return Action([Command.hold()], declaration=_tag(decl, o.agent))
        if self._cell(target) == self._cell(o.position):
            return Action([Command.hold()])  # reading inside the visited cell
        self._head_for(target, o.position)
        return Action([self.motion.command(o.position)])

    def _next_visit(self, o: Observation) -> np.ndarray | None:
        """The mapped source to read from next (its cell centre), or ``None`` when every one has
        been read from ``visit_readings`` times or the stage's time is up."""
        p = self.params
        if p.visit_readings == 0 or o.t - self.stop_rule_at > p.visit_time:
            return None
        g = self.mapper.grid.grid
        if self._visit is not None:
            if (
                self.tests[self._visit] < p.visit_readings
                and o.t - self._visit_since <= p.visit_dwell
            ):
                return g.center(np.array(self._visit))[0]
            self.mapper.mark_visited(self._visit)
            up = self._upwind_of(self._visit)
            if up is not None:
                # walk on up the mapped plume: the next cell upwind is read in turn
                self._visit = up
                self._visit_since = o.t
                return g.center(np.array(up))[0]
        # the visit is over (or none is under way): read the estimates again
        pending = [
            xy
            for xy in self.mapper.source_positions()
            if self.tests[self._cell(xy)] < p.visit_readings
            and not self.mapper.visited[self._cell(xy)]
        ]
        if not pending:
            self._visit = None
            return None
        here = np.asarray(o.position, float)[:2]
        xy = min(pending, key=lambda v: float(np.hypot(*(v - here))))
        self._visit = self._cell(xy)
        self._visit_since = o.t
        self.n_visits += 1
        return g.center(np.array(self._visit))[0]

    def diagnostics(self) -> dict[str, float]:
        plan = self.last_plan
        fit = plan.extra["fitness"] if plan is not None and plan.extra else math.nan
        return {**self.map.diagnostics(), "fitness": float(fit)}

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`) plus the planner's count."""
        return {
            **self.map.final_metrics(),
            "plans": float(self.n_plans),
            "stop_rule_time": float(self.stop_rule_at),
            "source_visits": float(self.n_visits),
        }


# ------------------------------------------------------------------- rectangular wave
class DSRectangularWaveParams(DSMapParams):
    """Parameters of :class:`DSRectangularWaveSearcher` (the map's plus the path's).

    Attributes
    ----------
    dwell_periods : int
        Control periods the robot stands still reading after each move (stop-and-go).
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
        ``"alternate"``: every other round is run backwards
        (:func:`~odorloc.planning.coverage.wave_waypoints`).
    """

    dwell_periods: int = Field(1, ge=0, le=1000)
    lane_spacing: Positive = 2.0
    lanes_along: Literal["x", "y"] = "y"
    rounds: int = Field(5, ge=1, le=1000)
    margin: NonNegative = 0.0
    round_order: Literal["restart", "alternate"] = "restart"


@register(
    "searcher",
    "ds-rectangular-wave",
    DSRectangularWaveParams,
    "rectangular-wave coverage building the same D-S map (D-S paper baseline)",
)
class DSRectangularWaveSearcher(_MappingSearcher):
    """The D-S paper's baseline: a predefined rectangular-wave path, the same D-S map.

    The lanes are those of :class:`~odorloc.searchers.simple.RectangularWaveSearcher`
    (:func:`~odorloc.planning.coverage.rectangular_wave`); rounds follow ``round_order`` and the
    robot moves stop-and-go like the dynamic route (``dwell_periods``). Lanes that obstacles cut
    are swept on both sides of them (:func:`~odorloc.planning.coverage.route_around_obstacles`).
    After the last round the mapped sources are declared.
    """

    params: DSRectangularWaveParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        self.waypoints = wave_waypoints(
            self.mapper.region,
            p.lane_spacing,
            p.lanes_along,
            p.rounds,
            ctx.start[0, :2],
            p.margin,
            p.round_order,
            ctx.arena,
        )
        self.index = 0
        self.motion = StopAndGo(ctx.max_speed * ctx.dt, p.dwell_periods)
        self.motion.set_goal(self.waypoints[0])

    @property
    def done(self) -> bool:
        """``True`` once the last waypoint of the last round was reached."""
        return self.index >= len(self.waypoints)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        self.map.update(o)
        if not self.done and self.motion.arrived(o.position):
            self.index += 1
            if not self.done:
                self.motion.set_goal(self.waypoints[self.index])
        if self.done:
            return Action([Command.hold()], declaration=_tag(self.mapper.declaration(), o.agent))
        return Action([self.motion.command(o.position)])

    def diagnostics(self) -> dict[str, float]:
        return {**self.map.diagnostics(), "waypoint": float(self.index)}

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`)."""
        return self.map.final_metrics()
