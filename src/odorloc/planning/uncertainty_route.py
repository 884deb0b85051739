"""Uncertainty-driven route planning over a Dempster-Shafer evidence grid (D-S paper, section 3).

The next position ``P`` maximises the fitness (eqs. 6-7)

    E_P = sum_i pi_i^{P*} X_i  ~=  sum_i pi_{i+Delta} X_i,

the uncertainty ``X_i`` (eq. 5) that the air-mass path of a reading taken at ``P`` would cover.
``pi^{P*}`` is approximated by the robot's current air-mass path map translated by the offset
``Delta`` from the robot's cell to ``P`` (uniform airflow; the one-step time difference is
ignored, as in the paper).

Readings of the paper:

* Shift direction. The path map moves with the robot: the map for a robot at ``P`` is
  ``pi^P(c) = pi(c - Delta)``, hence ``E_P = sum_c pi(c) X(c + Delta)``. This is the paper's
  ``pi_{i+Delta}`` with the index convention read so that the map follows the robot.
  Cells shifted out of the grid contribute nothing. All candidate shifts are evaluated at once as
  a cross-correlation of ``X`` with the path map's bounding box (:func:`scipy.signal.correlate`,
  direct or FFT), so no shifted map is ever built.
* Candidates. First the cell centres within ``step_range`` of the robot (the reach of the next
  step, max speed times period), plus the robot's own cell when ``include_current`` (the
  paper evaluates "a number of positions around the robot"; ``include_current=False`` reads
  that as excluding the robot's own cell, so the robot always moves on); while the best
  ``E_P < eta_E`` the
  radius is multiplied by ``widen_factor`` until it covers the whole area; if even then the best
  ``E_P < eta_E`` the mission is finished and :meth:`UncertaintyRoutePlanner.plan` returns
  ``None``.
* Search region. With ``region`` set, only cells whose centre lies in it are candidates and only
  their uncertainty counts in ``E_P`` (the paper's planner "never considered" cells outside the
  work area). Cells excluded by ``allowed`` (e.g. obstacles) are never candidates.
* Region edge. A reading covers the cells *upwind* of the sensor only (the nearest sub-window
  is one record period of travel upwind), so a robot confined to the centres of the region's
  cells can never cover the region's downwind-most cells: their ``X`` stays at ``q`` and,
  since the predicted path of a nearby position can still brush them when the wind swings,
  they keep ``E_P`` above ``eta_E`` for good. ``edge_reach`` (metres) also makes the cells
  whose centre lies up to that far outside the region candidates (the grid must extend that
  far); such a target is clamped onto the region's edge, where the rectangular wave drives
  too. Half a cell lets the robot stand on the edge, as the wave does.
* Ties are broken uniformly at random with the caller's generator.
* No path yet. If the path map is empty (e.g. before a second wind record exists) there is no
  evidence to weigh; the plan keeps the robot where it is (``reason="empty_path_map"``) rather
  than declaring the mission finished.
* Standing. With ``avoid_obstacles`` (the planner's :meth:`~UncertaintyRoutePlanner.plan`), a
  cell whose target (its centre, clamped onto the region as edge targets are) lies in an
  obstacle is never a candidate.

:meth:`UncertaintyRoutePlanner.plan` is the :class:`~odorloc.planning.base.Planner` interface
over the belief of the ``ds-map`` estimator
(:class:`~odorloc.inference.evidence.mapper.EvidenceBelief`); :meth:`~UncertaintyRoutePlanner.
route` plans from a D-S grid and a path map directly.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import model_validator
from scipy.signal import correlate

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Region, SearchContext
from odorloc.geometry.grid import CellGrid
from odorloc.geometry.regions import check_region
from odorloc.inference.evidence.dempster_shafer import DSGrid
from odorloc.inference.evidence.mapper import EvidenceBelief, as_distribution
from odorloc.inference.odor_path.estimator import OdorPathEstimator, PathPatch
from odorloc.planning.base import Plan, Planner, Pose
from odorloc.planning.selection import select

FloatArray = NDArray[np.float64]

__all__ = ["RoutePlan", "UncertaintyRouteParams", "UncertaintyRoutePlanner", "fitness_map"]


class UncertaintyRouteParams(Params):
    """Parameters of :class:`UncertaintyRoutePlanner`.

    Attributes
    ----------
    step_range : float, metres
        Initial candidate radius: how far the robot gets in the next step (0.5 m/s x 0.5 s).
    widen_factor : float
        Radius multiplier while the best fitness is below ``eta_e`` (> 1).
    eta_e : float
        ``eta_E``, the fitness threshold (0.5).
    region : ((x0, y0), (x1, y1)), optional
        Search region, metres; ``None`` is the whole grid.
    tie_rtol : float
        Candidates within this relative tolerance of the best fitness count as ties.
    include_current : bool
        Whether the robot's own cell is always a candidate (staying put); see the module notes.
    edge_reach : float, metres
        Candidates may lie this far outside ``region`` (targets are clamped onto it); see the
        module notes. 0 keeps every candidate inside.
    fitness_path : {"map", "distribution"}
        ``pi`` weighing ``X`` in eq. 7 (:meth:`UncertaintyRoutePlanner.plan`): the reading's
        path map as eq. 4 uses it, or that map divided by its sum.
    avoid_obstacles : bool
        :meth:`UncertaintyRoutePlanner.plan` never targets a cell whose target lies in an
        obstacle (see the module notes).
    """

    step_range: Positive = 0.25
    widen_factor: float = 2.0
    eta_e: NonNegative = 0.5
    region: tuple[tuple[float, float], tuple[float, float]] | None = None
    tie_rtol: NonNegative = 1e-9
    include_current: bool = True
    edge_reach: NonNegative = 0.0
    fitness_path: Literal["map", "distribution"] = "map"
    avoid_obstacles: bool = True

    @model_validator(mode="after")
    def _check(self) -> UncertaintyRouteParams:
        if not (math.isfinite(self.widen_factor) and self.widen_factor > 1.0):
            raise ValueError("widen_factor must be a finite number > 1")
        if self.region is not None:
            check_region(self.region, "region")
        return self


@dataclass(frozen=True, eq=False)
class RoutePlan:
    """Outcome of one planning call.

    Attributes
    ----------
    target : (2,) ndarray or None
        Centre of the chosen cell, metres; ``None`` when the mission is finished.
    fitness : float
        ``E_P`` of the target (the best fitness found when finished).
    radius : float, metres
        Candidate radius at which the decision was taken.
    n_candidates : int
        Candidates evaluated at that radius.
    done : bool
        ``True`` when even the whole area is below ``eta_E``.
    reason : str
        ``"ok"``, ``"widened"``, ``"finished"``, ``"empty_path_map"`` or ``"no_candidates"``.
    candidates : (M, 2) ndarray, metres
        The targets of the candidates at that radius (clamped onto the region).
    fitnesses : (M,) ndarray
        Their ``E_P``.
    index : int or None
        The chosen one among them.
    """

    target: FloatArray | None
    fitness: float
    radius: float
    n_candidates: int
    done: bool
    reason: str
    candidates: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    fitnesses: FloatArray = field(default_factory=lambda: np.zeros(0))
    index: int | None = None


def _as_patch(
    path_model: OdorPathEstimator | PathPatch | ArrayLike, grid: CellGrid, ref: NDArray[np.intp]
) -> PathPatch:
    """The path map as a :class:`PathPatch` on ``grid``."""
    if isinstance(path_model, OdorPathEstimator):
        if path_model.n_records == 0:
            return PathPatch(0, 0, np.zeros((0, 0)), grid, ref)
        patch = path_model.path_patch()
    elif isinstance(path_model, PathPatch):
        patch = path_model
    else:
        dense = np.asarray(path_model, float)
        if dense.shape != grid.shape:
            raise ConfigError("path_model", f"shape {dense.shape} != grid {grid.shape}")
        nz = np.nonzero(dense)
        if nz[0].size == 0:
            return PathPatch(0, 0, np.zeros((0, 0)), grid, ref)
        x0, x1 = nz[0].min(), nz[0].max() + 1
        y0, y1 = nz[1].min(), nz[1].max() + 1
        return PathPatch(int(x0), int(y0), dense[x0:x1, y0:y1].copy(), grid, ref)
    if not patch.grid.same_as(grid):
        raise ConfigError("path_model", "path map grid differs from the evidence grid")
    return patch


def fitness_map(
    uncertainty: FloatArray,
    patch: PathPatch,
    box: tuple[int, int, int, int] | None = None,
) -> FloatArray:
    """Fitness ``E_P`` (eq. 7) for every candidate cell ``P`` in an index box.

    Parameters
    ----------
    uncertainty : (nx, ny) ndarray
        ``X_i`` (eq. 5), zero where cells must not count.
    patch : PathPatch
        Current air-mass path map; ``patch.ref_cell`` is the robot cell it was computed for.
    box : (ix0, ix1, iy0, iy1), optional
        Candidate cells (end exclusive); default the whole grid.

    Returns
    -------
    (ix1 - ix0, iy1 - iy0) ndarray
        ``E`` for a robot moved to each cell of the box.
    """
    nx, ny = uncertainty.shape
    cx0, cx1, cy0, cy1 = box if box is not None else (0, nx, 0, ny)
    if cx1 <= cx0 or cy1 <= cy0:
        return np.zeros((max(cx1 - cx0, 0), max(cy1 - cy0, 0)))
    if patch.values.size == 0:
        return np.zeros((cx1 - cx0, cy1 - cy0))
    bx, by = patch.values.shape
    rx, ry = int(patch.ref_cell[0]), int(patch.ref_cell[1])
    # Map cell (u, v) of the patch lands on grid cell (ix0 + u + dx, iy0 + v + dy) for a shift
    # (dx, dy) = candidate - ref; the X needed spans the candidate box grown by the patch.
    sx0 = patch.ix0 + cx0 - rx
    sy0 = patch.iy0 + cy0 - ry
    wx = cx1 - cx0 + bx - 1
    wy = cy1 - cy0 + by - 1
    xs = np.zeros((wx, wy))
    gx0, gx1 = max(sx0, 0), min(sx0 + wx, nx)
    gy0, gy1 = max(sy0, 0), min(sy0 + wy, ny)
    if gx1 > gx0 and gy1 > gy0:
        xs[gx0 - sx0 : gx1 - sx0, gy0 - sy0 : gy1 - sy0] = uncertainty[gx0:gx1, gy0:gy1]
    e = correlate(xs, patch.values, mode="valid")
    return np.maximum(e, 0.0)  # FFT rounding can dip below zero


def standable(arena: Any, grid: CellGrid, region: Region | None) -> NDArray[np.bool_] | None:
    """Cells a route target may lie in, ``(nx, ny)`` bool: those whose target (the cell centre
    clamped onto ``region``, as edge targets are) is free; ``None`` when the arena has no
    obstacles."""
    if arena.occ is None:
        return None
    targets = grid.centers().reshape(-1, 2)
    if region is not None:
        targets = np.clip(targets, region[0], region[1])
    return arena.is_free(targets).reshape(grid.shape)


@register(
    "planner", "uncertainty-route", UncertaintyRouteParams, "most uncertainty covered (D-S map)"
)
class UncertaintyRoutePlanner(Planner):
    """Chooses the next position maximising the uncertainty covered (D-S paper, section 3).

    Parameters
    ----------
    params : UncertaintyRouteParams
    """

    params: UncertaintyRouteParams
    Params = UncertaintyRouteParams
    dims = (2,)
    needs_model = False
    belief_estimator: ClassVar[Mapping[str, Any]] = {"type": "ds-map"}

    def __init__(self, params: UncertaintyRouteParams | None = None) -> None:
        super().__init__(params or UncertaintyRouteParams())

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        super().reset(ctx, model)
        self._standable: tuple[CellGrid, Region | None, NDArray[np.bool_] | None] | None = None

    def _allowed(self, grid: CellGrid, region: Region | None) -> NDArray[np.bool_] | None:
        """:func:`standable` cells of the belief's grid (computed once per episode)."""
        if not self.params.avoid_obstacles:
            return None
        c = self._standable
        if c is None or c[0] is not grid or c[1] != region:
            self._standable = (grid, region, standable(self.ctx.arena, grid, region))
        return self._standable[2]

    def plan(self, belief: EvidenceBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        """The next target on the D-S map ``belief`` from ``pose`` (eqs. 6-7).

        :attr:`Plan.scores` are minus the fitness ``E_P`` of the candidates at the radius the
        decision was taken; :attr:`Plan.extra` holds ``fitness``, ``radius``, ``done`` and
        ``reason`` (:class:`RoutePlan`). ``index`` is ``None`` when the mission is finished.
        """
        if belief.uncertainty is None:
            raise ConfigError("belief", "the route planner needs the map's cell uncertainty")
        grid = belief.grid
        region = self.params.region if self.params.region is not None else belief.region
        pos = np.asarray(pose.position, float)[:2]
        robot_cell = grid.index(pos)[0]
        patch = belief.path
        if patch is None:
            patch = PathPatch(0, 0, np.zeros((0, 0)), grid, robot_cell)
        elif self.params.fitness_path == "distribution":
            patch = as_distribution(patch)
        rp = self._route(
            grid,
            belief.uncertainty,
            patch,
            pos,
            robot_cell,
            rng,
            self._allowed(grid, region),
            region,
        )
        work = int(rp.n_candidates * max(patch.values.size, 1))
        extra = {"fitness": rp.fitness, "radius": rp.radius, "done": rp.done, "reason": rp.reason}
        m = len(rp.candidates)
        return Plan(rp.index, rp.candidates, -rp.fitnesses, np.ones(m, bool), work, extra)

    def route(
        self,
        ds_grid: DSGrid,
        path_model: OdorPathEstimator | PathPatch | ArrayLike,
        position: ArrayLike,
        rng: np.random.Generator,
        allowed: NDArray[np.bool_] | None = None,
    ) -> RoutePlan:
        """Evaluate the candidates, widening the range as needed (eqs. 6-7).

        Parameters
        ----------
        ds_grid : DSGrid
            Current evidence grid (its uncertainty ``X`` is weighed).
        path_model : OdorPathEstimator, PathPatch or (nx, ny) array_like
            The current air-mass path map on the same grid (an estimator gives its map at the
            newest record, centred on the robot cell of that record; a dense array is taken as
            centred on the robot's current cell).
        position : (2,) array_like, metres
            Robot position.
        rng : numpy.random.Generator
            Breaks ties.
        allowed : (nx, ny) bool ndarray, optional
            Cells the robot may go to (e.g. free of obstacles).

        Returns
        -------
        RoutePlan
        """
        grid = ds_grid.grid
        pos = np.asarray(position, float).reshape(-1)
        if pos.shape != (2,) or not np.all(np.isfinite(pos)):
            raise ConfigError("position", f"needs 2 finite components, got {position!r}")
        robot_cell = grid.index(pos)[0]
        patch = _as_patch(path_model, grid, robot_cell)
        if allowed is not None:
            allowed = np.asarray(allowed, bool)
            if allowed.shape != grid.shape:
                raise ConfigError("allowed", f"shape {allowed.shape} != grid {grid.shape}")
        return self._route(
            grid, ds_grid.uncertainty(), patch, pos, robot_cell, rng, allowed, self.params.region
        )

    def _route(
        self,
        grid: CellGrid,
        uncertainty: FloatArray,
        patch: PathPatch,
        pos: FloatArray,
        robot_cell: NDArray[np.intp],
        rng: np.random.Generator,
        allowed: NDArray[np.bool_] | None,
        region: Region | None,
    ) -> RoutePlan:
        p = self.params
        if region is not None and p.edge_reach > 0:
            (rx0, ry0), (rx1, ry1) = region
            # a hair of tolerance keeps centres lying exactly edge_reach outside
            e = p.edge_reach * (1.0 + 1e-9) + 1e-12
            cand_mask = grid.region_mask(((rx0 - e, ry0 - e), (rx1 + e, ry1 + e)))
        else:
            cand_mask = grid.region_mask(region)
        if allowed is not None:
            cand_mask = cand_mask & allowed
        x = uncertainty
        if region is not None:
            x = np.where(grid.region_mask(region), x, 0.0)

        if patch.empty:
            here = grid.center(robot_cell)[0]
            return RoutePlan(
                here, 0.0, 0.0, 0, False, "empty_path_map", here[None, :], np.zeros(1), 0
            )
        if not cand_mask.any():
            return RoutePlan(None, 0.0, 0.0, 0, True, "no_candidates")

        xc, yc = grid.x_centers(), grid.y_centers()
        # the radius covers the whole area once it reaches the farthest corner of the
        # candidates' bounding box
        rows = np.flatnonzero(cand_mask.any(axis=1))
        cols = np.flatnonzero(cand_mask.any(axis=0))
        far = max(
            math.hypot(xc[i] - pos[0], yc[j] - pos[1])
            for i in (rows[0], rows[-1])
            for j in (cols[0], cols[-1])
        )
        radius = p.step_range
        best_e = 0.0
        n_cand = 0
        widened = False
        while True:
            whole = radius >= far
            r_eff = radius
            a = grid.cell_size
            box = (
                max(math.floor((pos[0] - r_eff - grid.lower[0]) / a), 0),
                min(math.floor((pos[0] + r_eff - grid.lower[0]) / a) + 1, grid.nx),
                max(math.floor((pos[1] - r_eff - grid.lower[1]) / a), 0),
                min(math.floor((pos[1] + r_eff - grid.lower[1]) / a) + 1, grid.ny),
            )
            ix0, ix1, iy0, iy1 = box
            dx = xc[ix0:ix1] - pos[0]
            dy = yc[iy0:iy1] - pos[1]
            in_range = (dx * dx)[:, None] + (dy * dy)[None, :] <= r_eff * r_eff
            rcx, rcy = robot_cell[0] - ix0, robot_cell[1] - iy0
            if 0 <= rcx < ix1 - ix0 and 0 <= rcy < iy1 - iy0:
                # staying put is a candidate only when allowed
                in_range[rcx, rcy] = p.include_current
            cand = in_range & cand_mask[ix0:ix1, iy0:iy1]
            n_cand = int(np.count_nonzero(cand))
            e_c = None
            if n_cand:
                e = fitness_map(x, patch, box)
                e_c = np.where(cand, e, -np.inf)
                best_e = float(e_c.max())
                if best_e >= p.eta_e:
                    flat = select(e_c.ravel(), mode="max", ties="random", rtol=p.tie_rtol, rng=rng)
                    pick = np.array(np.unravel_index(int(flat), e_c.shape))
                    target = grid.center(pick + np.array([ix0, iy0]))[0]
                    targets, fits = _candidates(grid, cand, e_c, (ix0, iy0), region)
                    if region is not None:
                        target = np.clip(target, region[0], region[1])
                    reason = "widened" if widened else "ok"
                    k = int(np.count_nonzero(cand.ravel()[: int(flat)]))
                    return RoutePlan(target, best_e, r_eff, n_cand, False, reason, targets, fits, k)
            if whole:
                targets, fits = (
                    _candidates(grid, cand, e_c, (ix0, iy0), region)
                    if e_c is not None
                    else (np.zeros((0, 2)), np.zeros(0))
                )
                return RoutePlan(None, best_e, r_eff, n_cand, True, "finished", targets, fits)
            radius *= p.widen_factor
            widened = True


def _candidates(
    grid: CellGrid,
    cand: NDArray[np.bool_],
    fitness: FloatArray,
    offset: tuple[int, int],
    region: Region | None,
) -> tuple[FloatArray, FloatArray]:
    """Targets ``(M, 2)`` (clamped onto ``region``) and fitness ``(M,)`` of the candidate cells
    of a box, in row-major order."""
    idx = np.argwhere(cand)
    targets = grid.center(idx + np.asarray(offset)).reshape(-1, 2)
    if region is not None:
        targets = np.clip(targets, region[0], region[1])
    return targets, fitness[cand]
