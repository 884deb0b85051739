"""Grid-belief search policies: infotaxis and its successors, each a short recipe.

Recipe (:class:`GridPolicySearcher`; the policy is the class's):

1. **Belief**: a grid Bayes filter (:class:`~odorloc.inference.grid_filter.GridFilter`) over the
   arena's free cells at ``cell_size`` (default the occupancy cells), the prior uniform over the
   search region (``region``, else the task's, else the arena), optionally with the release rate
   marginalised on ``releases``.
2. **Model**: the searcher's measurement model (``model``, any of :mod:`odorloc.models`; its
   parameters are the searcher's knowledge, not the world's) tabulated over lattice offsets
   (:func:`~odorloc.models.lattice.tabulate`) with the exposure ``dt`` and the measured mean
   wind (its direction ``direction`` and velocity ``wind``); it is tabulated again when the mean
   wind turns by more than ``retabulate_deg``.
3. **Every control period**: the source is not within ``found_radius`` of where the agent stands
   (the episode would have ended), so those cells are excluded; the reading updates the belief
   (its class: the hit count, capped at the last class, or the detection).
4. **Motion**, when the last move is done: the neighbour cells (``moves``: the ``2d`` lattice
   moves in the order ``-x, +x, -y, +y[, -z, +z]``, optionally "stay", or all ``3^d - 1``
   neighbours) that are free and reachable are scored by the policy
   (:class:`~odorloc.planning.infotaxis.GridPolicyPlanner`) and the agent moves to the centre of
   the chosen one.

The searchers never declare: they suit tasks that end when the source is reached
(``task.end: reach``). On the lattice problem of infotaxis (the built-in scenarios
``lattice-isotropic-*``) this is the problem of Loisy & Eloy (2022) exactly, and the choices are
those of their reference implementation (OTTO) on the same beliefs.

Policies: ``infotaxis`` (Vergassola et al. 2007), ``space-aware-infotaxis`` (Loisy & Eloy 2022),
``entrotaxis`` (Hutchinson et al. 2018), ``greedy`` and ``mean-distance`` (Loisy & Eloy 2022).
"""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Observation, Region, SearchContext
from odorloc.geometry.regions import check_region
from odorloc.inference.belief import GridBelief
from odorloc.inference.grid_filter import GridFilter
from odorloc.models.base import MeasurementModel
from odorloc.models.lattice import OffsetTable, tabulate
from odorloc.planning.infotaxis import GridPolicyPlanner, neighbour_cells
from odorloc.searchers.base import Searcher

__all__ = [
    "EntrotaxisSearcher",
    "GreedySearcher",
    "GridPolicyParams",
    "GridPolicySearcher",
    "InfotaxisSearcher",
    "MeanDistanceSearcher",
    "SpaceAwareInfotaxisSearcher",
    "reading_class",
]


class GridPolicyParams(Params):
    """Parameters of the grid-belief policies (see the module docstring).

    Attributes
    ----------
    model : dict
        The searcher's measurement model, ``{type: name, **params}``.
    cell_size : float, metres, optional
        Belief cell side (default: the arena's occupancy cells).
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Where the prior puts the source (default: the task's search region, else the arena).
    moves : {"lattice", "lattice-stay", "neighbours"}
        Candidate moves (one cell each).
    found_radius : float, metres, optional
        Cells within this distance of the agent hold the source only if the episode ends there
        (set it to the task's reach radius; default half a cell).
    reading : {"auto", "hits", "detection"}
        What a reading is: a hit count (class ``min(hits, Z - 1)``) or a detection (class 0/1);
        ``auto``: hits when the sensor counts hits, else detections.
    n_classes : int, optional
        Outcome classes of the model (default: 2 for detections, else the model's own choice).
    releases : tuple of float, optional
        Release rates marginalised with the position (the model's ``release`` condition).
    exposure : float, seconds, optional
        Exposure of one reading (the model's ``dt``; default the control period).
    wind_average : int
        Anemometer readings averaged for the model's wind.
    retabulate_deg : float, degrees
        Tabulate the model again when the mean wind turns by more than this.
    entropy_floor : float
        The reference conventions of OTTO (:mod:`odorloc.planning.rewards`); 0: exact.
    tie_tolerance : float
        Scores within this of the best tie (bits for the entropy policies).
    ties : {"first", "random"}
        Ties go to the first candidate in move order (OTTO's rule) or to a drawn one.
    """

    model: Ref("model") = ComponentRef(type="vergassola")
    cell_size: Positive | None = None
    region: Region | None = None
    moves: Literal["lattice", "lattice-stay", "neighbours"] = "lattice"
    found_radius: Positive | None = None
    reading: Literal["auto", "hits", "detection"] = "auto"
    n_classes: int | None = Field(None, ge=2, le=64)
    releases: tuple[Positive, ...] | None = None
    exposure: Positive | None = None
    wind_average: int = Field(10, ge=1, le=10_000)
    retabulate_deg: NonNegative = 10.0
    entropy_floor: NonNegative = 1e-10
    tie_tolerance: NonNegative = 1e-10
    ties: Literal["first", "random"] = "first"


# Tables of the searchers' models, shared by the episodes of a process (a table depends only on
# the model's parameters, the conditions and the lattice, all in the key).
_TABLES: OrderedDict[str, OffsetTable] = OrderedDict()
_TABLE_CACHE = 16


def _table_key(model: ComponentRef, cell: np.ndarray, half: tuple[int, ...], cond: dict) -> str:
    plain = {k: np.asarray(v, float).round(12).tolist() for k, v in sorted(cond.items())}
    spec = json.dumps(model.model_dump(mode="json"), sort_keys=True)
    return json.dumps([spec, np.asarray(cell).round(12).tolist(), list(half), plain])


def reading_class(o: Observation, kind: str, n_classes: int) -> int:
    """The outcome class of a reading: ``min(hits, Z - 1)`` or the detection (0/1)."""
    if kind == "hits":
        h = float(o.gas)
        if not (math.isfinite(h) and h >= 0):
            raise ConfigError("reading", f"a hit count must be finite and >= 0, got {o.gas}")
        return min(round(h), n_classes - 1)
    return int(bool(o.detection))


class GridPolicySearcher(Searcher):
    """Base of the grid-belief policies; subclasses set :attr:`policy`."""

    params: GridPolicyParams
    max_agents = 1
    declares = False
    policy: ClassVar[str] = "infotaxis"

    def __init__(self, params: GridPolicyParams | None = None) -> None:
        super().__init__(params or GridPolicyParams())
        p = self.params
        self.model: MeasurementModel = p.model.build("model", field="searcher.model")
        self.planner = GridPolicyPlanner(
            self.policy,  # type: ignore[arg-type]
            floor=p.entropy_floor,
            tie_tol=p.tie_tolerance,
            ties=p.ties,
        )

    # ----------------------------------------------------------------- lifecycle
    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """A fresh belief over the region; the model is tabulated at the first reading."""
        super().reset(ctx, rng)
        p = self.params
        arena = ctx.arena
        region = p.region if p.region is not None else ctx.search_region
        self.filter = GridFilter.over_arena(arena, cell_size=p.cell_size, releases=p.releases)
        grid = self.filter.grid
        if region is not None:
            lo, hi = check_region(region, "searcher.region")
            inside = grid.region_mask((lo, hi))
            if not (inside & self.filter.free).any():
                raise ConfigError("searcher.region", "holds no free cell of the belief grid")
            self.filter = GridFilter(
                grid,
                free=self.filter.free & inside,
                releases=p.releases,
            )
        self.cell = float(np.min(grid.cells))
        self.found_radius = p.found_radius if p.found_radius is not None else 0.5 * self.cell
        kind = p.reading
        if kind == "auto":
            kind = "hits" if ctx.sensor.unit == "hits" else "detection"
        self.kind = kind
        if p.n_classes is not None:
            self.n_classes: int | None = p.n_classes
        else:
            self.n_classes = 2 if kind == "detection" else None
        self.exposure = p.exposure if p.exposure is not None else ctx.dt
        self.tables: list[OffsetTable] = []
        self._table_wind: np.ndarray | None = None
        self._winds: list[np.ndarray] = []
        self._entropy0 = math.nan
        self._last_plan_rescored = 0
        self._decisions = 0

    # ----------------------------------------------------------------- model tables
    def _conditions(self, wind: np.ndarray) -> dict[str, Any]:
        cond: dict[str, Any] = {"dt": self.exposure, "wind": wind}
        speed = float(np.linalg.norm(wind))
        if speed > 1e-9:
            cond["direction"] = wind / speed
        if self.n_classes is not None:
            cond["n_classes"] = self.n_classes
        return cond

    def _tabulate(self, wind: np.ndarray) -> None:
        grid = self.filter.grid
        half = tuple(n - 1 for n in grid.shape)
        cond = self._conditions(wind)
        releases = self.filter.releases
        tabs = []
        for k in range(self.filter.n_releases):
            c = dict(cond)
            if releases is not None:
                c["release"] = float(releases[k])
            key = _table_key(self.params.model, grid.cells, half, c)
            table = _TABLES.get(key)
            if table is None:
                table = tabulate(self.model, grid.cells, half, **c)
                _TABLES[key] = table
                while len(_TABLES) > _TABLE_CACHE:
                    _TABLES.popitem(last=False)
            tabs.append(table)
        z = tabs[0].n_classes
        if self.kind == "detection" and z != 2:
            raise ConfigError("searcher.n_classes", f"detections need 2 classes, the model has {z}")
        self.tables = tabs
        self._table_wind = np.asarray(wind, float).copy()

    def _refresh_tables(self, wind: np.ndarray) -> None:
        self._winds.append(np.asarray(wind, float))
        if len(self._winds) > self.params.wind_average:
            del self._winds[0]
        mean = sum(self._winds) / len(self._winds)
        if not self.tables:
            self._tabulate(mean)
            return
        old = self._table_wind
        assert old is not None
        na, nb = float(np.linalg.norm(old)), float(np.linalg.norm(mean))
        if nb < 1e-9:
            return  # calm now: keep the tables of the last wind
        if na < 1e-9:
            # tables made in calm air have no wind direction: make them as soon as there is one
            self._tabulate(mean)
            return
        cos = float(np.clip(old @ mean / (na * nb), -1.0, 1.0))
        if math.degrees(math.acos(cos)) > self.params.retabulate_deg:
            self._tabulate(mean)

    # ----------------------------------------------------------------- acting
    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Exclude the agent's surroundings, update with the reading, move when ready."""
        o = observations[0]
        pos = np.asarray(o.position, float)
        self._refresh_tables(np.asarray(o.wind, float))
        f = self.filter
        grid = f.grid
        f.exclude_near(pos, self.found_radius)
        z = reading_class(o, self.kind, self.tables[0].n_classes)
        cell = tuple(int(v) for v in grid.index(pos, clip=False)[0])
        if self.tables[0].covers(cell, f.shape):
            f.observe_table(self.tables, z, cell)
        else:
            self._observe_direct(z, pos)
        if math.isnan(self._entropy0):
            self._entropy0 = f.entropy()
        if not o.ready:
            return Action([None])
        here = grid.index(pos)[0]
        cells = neighbour_cells(here, self.params.moves)
        inside = np.all((cells >= 0) & (cells < np.asarray(f.shape)), axis=1)
        targets = grid.center(np.clip(cells, 0, np.asarray(f.shape) - 1))
        arena = self.ctx.arena
        ok = inside & arena.is_free(targets)
        if arena.occ is not None:
            ok &= arena.segment_free(pos, targets)
        plan = self.planner.plan(
            f.joint, self.tables, cells, feasible=ok, found_radius=self.found_radius, rng=rng
        )
        self._decisions += 1
        self._last_plan_rescored = plan.rescored
        if plan.index is None:
            return Action([Command.hold()])
        return Action([Command.move(targets[plan.index] - pos)])

    def _observe_direct(self, z: int, pos: np.ndarray) -> None:
        """Update from the model itself (the agent's cell lies beyond the tables)."""
        f = self.filter
        assert self._table_wind is not None  # tabulated before the first update
        cond = self._conditions(self._table_wind)
        centres = f.grid.flat_centers()
        rows = []
        for k in range(f.n_releases):
            c = dict(cond)
            if f.releases is not None:
                c["release"] = float(f.releases[k])
            q = self.model.outcome_probabilities(pos[None, :], centres, **c)
            with np.errstate(divide="ignore"):
                rows.append(np.log(q[0, z]))
        f.update(np.where(f.free, np.stack(rows).reshape(f.n_releases, *f.shape), 0.0))

    # ----------------------------------------------------------------- reporting
    def belief(self) -> GridBelief:
        """The position belief."""
        return self.filter.belief()

    def diagnostics(self) -> dict[str, float]:
        """``entropy`` (bits), ``p_max`` (most probable cell), ``rescored`` candidates."""
        return {
            "entropy": self.filter.entropy(),
            "p_max": float(self.filter.prob.max()),
            "rescored": float(self._last_plan_rescored),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Entropy (bits) after the first reading and at the end, decisions, belief restarts."""
        return {
            "entropy_init": self._entropy0,
            "entropy_end": self.filter.entropy(),
            "decisions": float(self._decisions),
            "belief_restarts": float(self.filter.restarts),
        }


@register("searcher", "infotaxis", GridPolicyParams, "infotaxis on a grid belief")
class InfotaxisSearcher(GridPolicySearcher):
    """Infotaxis (Vergassola, Villermaux & Shraiman 2007): the move that minimises the expected
    entropy of the source belief, the found outcome included."""

    policy = "infotaxis"


@register(
    "searcher", "space-aware-infotaxis", GridPolicyParams, "space-aware infotaxis (Loisy & Eloy)"
)
class SpaceAwareInfotaxisSearcher(GridPolicySearcher):
    """Space-aware infotaxis (Loisy & Eloy 2022): minimises the expected
    ``log2(D + 2^(S - 1) - 1/2)``, distance and entropy together."""

    policy = "space-aware"


@register("searcher", "entrotaxis", GridPolicyParams, "entrotaxis (Hutchinson et al.)")
class EntrotaxisSearcher(GridPolicySearcher):
    """Entrotaxis (Hutchinson, Oh & Chen 2018): the move whose outcome (found, or the reading)
    is the most uncertain."""

    policy = "entrotaxis"


@register("searcher", "greedy", GridPolicyParams, "move to the most probable neighbour cell")
class GreedySearcher(GridPolicySearcher):
    """Greedy: the neighbour cell most likely to hold the source."""

    policy = "greedy"


@register("searcher", "mean-distance", GridPolicyParams, "minimise the expected mean distance")
class MeanDistanceSearcher(GridPolicySearcher):
    """Mean distance (Loisy & Eloy 2022): the move that minimises the expected posterior mean
    (Manhattan) distance to the source."""

    policy = "mean-distance"
