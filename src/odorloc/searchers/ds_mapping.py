"""Dempster-Shafer mapping of several odor sources: the dynamic route and its baseline (D-S paper).

Both searchers build the same map (:class:`~odorloc.inference.evidence.mapper.DSMapper`: odor-path
maps fused by Dempster's rule) and differ in how they move:

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
* Wave rounds: ``round_order="restart"`` (default; section 4.2) or ``"alternate"``.
* Declaration. When the planner finds even the whole region below ``eta_E`` (dynamic route),
  or after the last round (wave), the mapped sources are declared (placed by the map's
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
from odorloc.geometry.regions import resolve_region
from odorloc.inference.belief import GridBelief
from odorloc.inference.evidence.mapper import DSMapParams, DSMapper, as_distribution
from odorloc.planning.coverage import wave_waypoints
from odorloc.planning.uncertainty_route import (
    RoutePlan,
    UncertaintyRouteParams,
    UncertaintyRoutePlanner,
)
from odorloc.searchers.base import Searcher

__all__ = [
    "DSMappingParams",
    "DSMappingSearcher",
    "DSRectangularWaveParams",
    "DSRectangularWaveSearcher",
]


def _reset_mapper(params: DSMapParams, ctx: SearchContext) -> DSMapper:
    if ctx.n_agents != 1:
        raise ConfigError("agents.starts", "the D-S mapping searchers drive a single robot")
    return DSMapper(params, resolve_region(ctx, params.region), ctx.dt)


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
        cover the downwind-most cells (see the module notes).
    widen_factor : float
        Radius multiplier while the best fitness is below ``eta_e`` (> 1).
    eta_e : float
        ``eta_E`` of the stop rule (0.5, D-S paper section 3).
    """

    dwell_periods: int = Field(1, ge=0, le=1000)
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

    params: DSMappingParams
    max_agents = 1
    dims = (2,)

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
        self.motion = StopAndGo(reach, p.dwell_periods)
        self.last_plan: RoutePlan | None = None
        self.n_plans = 0
        self.finished_at = math.nan

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        patch = self.mapper.update(o.t, o.position, o.wind, o.detection, o.gas)
        if not self.motion.arrived(o.position):
            return Action([self.motion.command(o.position)])
        if patch is None:  # the first pre-processed reading is not due yet
            return Action([Command.hold()])
        if self.params.fitness_path == "distribution":
            patch = as_distribution(patch)
        plan = self.planner.plan_detailed(self.mapper.grid, patch, o.position[:2], rng)
        self.last_plan = plan
        self.n_plans += 1
        if plan.target is None:
            self.finished_at = o.t
            decl = self.mapper.declaration()
            return Action([Command.hold()], declaration=_tag(decl, o.agent))
        self.motion.set_goal(plan.target)
        return Action([self.motion.command(o.position)])

    def belief(self) -> GridBelief:
        return self.mapper.grid.belief()

    def diagnostics(self) -> dict[str, float]:
        fit = self.last_plan.fitness if self.last_plan is not None else math.nan
        return {
            "total_uncertainty": self.mapper.total_uncertainty(),
            "mapped_regions": float(len(self.mapper.sources())),
            "fitness": float(fit),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`) plus the planner's count."""
        return {**self.mapper.final_metrics(), "plans": float(self.n_plans)}


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
class DSRectangularWaveSearcher(Searcher):
    """The D-S paper's baseline: a predefined rectangular-wave path, the same D-S map.

    The lanes are those of :class:`~odorloc.searchers.simple.RectangularWaveSearcher`
    (:func:`~odorloc.planning.coverage.rectangular_wave`); rounds follow ``round_order`` and the
    robot moves stop-and-go like the dynamic route (``dwell_periods``). After the last round the
    mapped sources are declared.
    """

    params: DSRectangularWaveParams
    max_agents = 1
    dims = (2,)

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
        self.motion = StopAndGo(ctx.max_speed * ctx.dt, p.dwell_periods)
        self.motion.set_goal(self.waypoints[0])

    @property
    def done(self) -> bool:
        """``True`` once the last waypoint of the last round was reached."""
        return self.index >= len(self.waypoints)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        self.mapper.update(o.t, o.position, o.wind, o.detection, o.gas)
        if not self.done and self.motion.arrived(o.position):
            self.index += 1
            if not self.done:
                self.motion.set_goal(self.waypoints[self.index])
        if self.done:
            return Action([Command.hold()], declaration=_tag(self.mapper.declaration(), o.agent))
        return Action([self.motion.command(o.position)])

    def belief(self) -> GridBelief:
        return self.mapper.grid.belief()

    def diagnostics(self) -> dict[str, float]:
        return {
            "total_uncertainty": self.mapper.total_uncertainty(),
            "mapped_regions": float(len(self.mapper.sources())),
            "waypoint": float(self.index),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Extra row fields (see :meth:`DSMapper.final_metrics`)."""
        return self.mapper.final_metrics()
