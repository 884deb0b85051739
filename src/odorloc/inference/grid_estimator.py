"""The grid Bayes filter as an estimator (registry ``estimator``: ``grid-filter``).

The belief is a :class:`~odorloc.inference.grid_filter.GridFilter` over the arena's free cells
at ``cell_size`` (default the occupancy cells), the prior uniform over the search region
(``region``, else the task's, else the arena), optionally with the release rate marginalised on
``releases``. The caller's measurement model (its parameters are the searcher's knowledge, not
the world's) is tabulated over lattice offsets (:func:`~odorloc.models.lattice.tabulate`) with
the exposure and the measured mean wind (its direction and velocity; the reading part
:class:`~odorloc.inference.readings.OutcomeClassReading`), and tabulated again when the mean
wind turns by more than ``retabulate_deg``. Tables depend only on the model's parameters, the
conditions and the lattice, so the episodes of a process share them.

Every update (one control period): the source is not within ``found_radius`` of where the agent
stands (a search that ends when the source is reached would have ended), so those cells are
excluded; the reading (its outcome class) updates the belief through the tables, or through the
model itself where the agent's cell lies beyond them.

The belief handed out is a :class:`LatticeBelief`: the position probabilities plus the joint
release-position belief and the tables, which the lattice planners
(:mod:`odorloc.planning.infotaxis`) score candidate cells with.
"""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Observation, Region, SearchContext
from odorloc.geometry.regions import task_region
from odorloc.inference.belief import GridBelief
from odorloc.inference.estimator import Estimator
from odorloc.inference.grid_filter import GridFilter
from odorloc.inference.readings import OutcomeClassParams, OutcomeClassReading
from odorloc.models.base import MeasurementModel
from odorloc.models.lattice import OffsetTable, tabulate

__all__ = ["GridFilterEstimator", "GridFilterParams", "LatticeBelief"]


@dataclass(frozen=True, eq=False)
class LatticeBelief(GridBelief):
    """A grid belief with what lattice planners need besides the probabilities.

    Attributes
    ----------
    joint : (K, n1, ..., nd) ndarray
        Belief over release hypotheses and cells (sums to one; read-only).
    tables : tuple of OffsetTable
        The model tabulated for each release at the current conditions.
    found_radius : float, metres
        A source within this distance of a cell centre the agent moves onto is found there.
    """

    joint: np.ndarray | None = None
    tables: tuple[OffsetTable, ...] = ()
    found_radius: float = 0.0


class GridFilterParams(Params):
    """Parameters of :class:`GridFilterEstimator` (see the module docstring).

    Attributes
    ----------
    cell_size : float, metres, optional
        Belief cell side (default: the arena's occupancy cells).
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Where the prior puts the source (default: the task's search region, else the arena).
    found_radius : float, metres, optional
        Cells within this distance of the agent hold the source only if the episode ends there
        (set it to the task's reach radius; default half a cell).
    releases : tuple of float, optional
        Release rates marginalised with the position (the model's ``release`` condition).
    reading : OutcomeClassParams
        What a reading is and its model conditions: ``reading`` (auto, hits or detection),
        ``n_classes``, ``exposure``, ``wind_average``.
    retabulate_deg : float, degrees
        Tabulate the model again when the mean wind turns by more than this.
    """

    cell_size: Positive | None = None
    region: Region | None = None
    found_radius: Positive | None = None
    releases: tuple[Positive, ...] | None = None
    reading: OutcomeClassParams = OutcomeClassParams()
    retabulate_deg: NonNegative = 10.0


# Tables shared by the episodes of a process (a table depends only on the model's parameters,
# the conditions and the lattice, all in the key).
_TABLES: OrderedDict[str, OffsetTable] = OrderedDict()
_TABLE_CACHE = 16


def _table_key(
    model: MeasurementModel, cell: np.ndarray, half: tuple[int, ...], cond: dict[str, Any]
) -> str:
    plain = {k: np.asarray(v, float).round(12).tolist() for k, v in sorted(cond.items())}
    spec = [type(model).__module__, type(model).__qualname__, model.params.model_dump(mode="json")]
    return json.dumps([spec, np.asarray(cell).round(12).tolist(), list(half), plain])


@register("estimator", "grid-filter", GridFilterParams, "grid Bayes filter over tabulated models")
class GridFilterEstimator(Estimator):
    """A grid Bayes filter fed through tabulated model outcomes (module docstring)."""

    params: GridFilterParams
    Params = GridFilterParams
    default_model: ClassVar[dict[str, Any] | None] = {"type": "vergassola"}

    def __init__(self, params: GridFilterParams | None = None) -> None:
        super().__init__(params or GridFilterParams())
        self.reading = OutcomeClassReading(self.params.reading)

    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        """A fresh belief over the region; the model is tabulated at the first reading."""
        if model is None:
            raise ConfigError("model", "the grid filter needs a measurement model")
        p = self.params
        self.ctx = ctx
        self.model = model
        region = task_region(ctx, p.region)
        f = GridFilter.over_arena(ctx.arena, cell_size=p.cell_size, releases=p.releases)
        grid = f.grid
        if region is not None:
            inside = grid.region_mask(region)
            if not (inside & f.free).any():
                raise ConfigError("searcher.region", "holds no free cell of the belief grid")
            f = GridFilter(grid, free=f.free & inside, releases=p.releases)
        self.filter = f
        self.cell = float(np.min(grid.cells))
        self.found_radius = p.found_radius if p.found_radius is not None else 0.5 * self.cell
        self.reading.reset(ctx)
        self.tables: tuple[OffsetTable, ...] = ()
        self._table_wind: np.ndarray | None = None
        self._entropy0 = math.nan

    # ----------------------------------------------------------------- model tables
    def _tabulate(self, wind: np.ndarray) -> None:
        grid = self.filter.grid
        half = tuple(n - 1 for n in grid.shape)
        cond = self.reading.conditions_for(wind)
        releases = self.filter.releases
        tabs = []
        for k in range(self.filter.n_releases):
            c = dict(cond)
            if releases is not None:
                c["release"] = float(releases[k])
            key = _table_key(self.model, grid.cells, half, c)
            table = _TABLES.get(key)
            if table is None:
                table = tabulate(self.model, grid.cells, half, **c)
                _TABLES[key] = table
                while len(_TABLES) > _TABLE_CACHE:
                    _TABLES.popitem(last=False)
            tabs.append(table)
        z = tabs[0].n_classes
        if self.reading.kind == "detection" and z != 2:
            raise ConfigError("searcher.n_classes", f"detections need 2 classes, the model has {z}")
        self.tables = tuple(tabs)
        self._table_wind = np.asarray(wind, float).copy()

    def _refresh_tables(self, mean: np.ndarray) -> None:
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

    # ----------------------------------------------------------------- one reading
    def update(self, observation: Observation) -> None:
        """Exclude the agent's surroundings, then update with the reading's class."""
        o = observation
        pos = np.asarray(o.position, float)
        self._refresh_tables(self.reading.update(o)["wind"])
        f = self.filter
        f.exclude_near(pos, self.found_radius)
        z = self.reading.class_of(o, self.tables[0].n_classes)
        cell = tuple(int(v) for v in f.grid.index(pos, clip=False)[0])
        if self.tables[0].covers(cell, f.shape):
            f.observe_table(self.tables, z, cell)
        else:
            self._observe_direct(z, pos)
        if math.isnan(self._entropy0):
            self._entropy0 = f.entropy()

    def _observe_direct(self, z: int, pos: np.ndarray) -> None:
        """Update from the model itself (the agent's cell lies beyond the tables)."""
        f = self.filter
        assert self._table_wind is not None  # tabulated before the first update
        cond = self.reading.conditions_for(self._table_wind)
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

    # ----------------------------------------------------------------- outputs
    def belief(self) -> LatticeBelief:
        """The position belief with the joint belief and the tables (a snapshot)."""
        b = self.filter.belief()
        return LatticeBelief(
            b.grid, b.prob, b.extra, self.filter.joint, self.tables, float(self.found_radius)
        )

    def estimate(self) -> np.ndarray:
        """The expected source position, ``(1, d)`` metres."""
        return self.filter.mean()[None, :]

    def conditions(self) -> dict[str, Any]:
        """The conditions the tables were made for (those of the next reading)."""
        if self._table_wind is None:
            return {}
        return self.reading.conditions_for(self._table_wind)

    @property
    def entropy_init(self) -> float:
        """Entropy of the belief (bits) after the first reading (NaN before)."""
        return self._entropy0

    def diagnostics(self) -> dict[str, float]:
        """``entropy`` (bits) and ``p_max`` (the most probable cell)."""
        return {"entropy": self.filter.entropy(), "p_max": float(self.filter.prob.max())}

    def final_metrics(self) -> dict[str, Any]:
        """Entropy (bits) after the first reading and at the end, belief restarts."""
        return {
            "entropy_init": self._entropy0,
            "entropy_end": self.filter.entropy(),
            "belief_restarts": float(self.filter.restarts),
        }
