"""Searches over a source-term posterior: infotaxis, entrotaxis and a lawn-mower (``planner``).

The candidates are ``position + step u`` for ``directions`` horizontal unit vectors ``u``
evenly spaced from +x (4, 8 or 16 in the source-term literature; ``vertical`` adds up and down
in 3-D) that walls and obstacles allow. Each is scored over ``n_plan`` particles thinned from
the posterior (systematic, deterministic) with the outcome classes of the posterior's model
(:meth:`~odorloc.models.source_term.SourceTermModel.outcome_probabilities`: a censored
concentration reading cut into bins of one noise width, a detection, or a count) and the
conditions of the next reading (the measured wind, the exposure):

- :class:`SourceTermInfotaxis` (``ste-infotaxis``): the smallest expected entropy of the
  particle weights after the reading, ``sum_z P(z) H(w | z)`` (Vergassola et al. 2007, over a
  source-term posterior as in Ristic et al. 2016);
- :class:`SourceTermEntrotaxis` (``ste-entrotaxis``): the largest entropy of the predicted
  reading, ``-sum_z P(z) log P(z)`` with ``P(z) = sum_i w_i p(z | theta_i)`` (Hutchinson,
  Oh & Chen 2018, eq. 10: maximum-entropy sampling);
- :class:`LawnmowerPlanner` (``ste-lawnmower``): the posterior-blind baseline, a
  boustrophedon over the search region (:func:`~odorloc.planning.coverage.rectangular_wave`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Region, SearchContext
from odorloc.geometry.regions import check_region, narrow_box, task_region
from odorloc.geometry.vectors import ring
from odorloc.planning import rewards
from odorloc.planning.base import Plan, Planner, Pose
from odorloc.planning.candidates import reachable
from odorloc.planning.coverage import rectangular_wave
from odorloc.planning.selection import select

__all__ = [
    "LawnmowerParams",
    "LawnmowerPlanner",
    "SourceTermEntrotaxis",
    "SourceTermInfotaxis",
    "SourceTermPlannerParams",
    "candidate_directions",
]


def candidate_directions(n: int, dim: int, vertical: bool = False) -> np.ndarray:
    """``n`` horizontal unit vectors from +x (plus up and down in 3-D with ``vertical``)."""
    u = ring(n, dim)
    if vertical and dim == 3:
        u = np.vstack([u, [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]])
    return u


class SourceTermPlannerParams(Params):
    """Parameters of the information planners over a source-term posterior.

    Attributes
    ----------
    directions : int
        Horizontal move directions (4, 8 or 16 in the literature).
    vertical : bool
        3-D: also up and down.
    step : float, metres, optional
        Move length (default: one control period at the speed limit).
    n_plan : int
        Particles the scores are computed over (thinned from the posterior).
    ties : {"first", "random"}
        Among moves of equal score, take the first in candidate order or one drawn uniformly
        from the episode's generator.
    """

    directions: int = Field(8, ge=3, le=64)
    vertical: bool = False
    step: Positive | None = None
    n_plan: int = Field(500, ge=10, le=100_000)
    ties: Literal["first", "random"] = "first"


class _InformationPlanner(Planner):
    """Infotaxis / entrotaxis over a source-term posterior (module docstring)."""

    params: SourceTermPlannerParams
    policy: ClassVar[str] = ""
    #: the posterior planned on: the source-term filter (fewer particles than its default, for a
    #: contract check) over a Gaussian plume
    belief_estimator: ClassVar[Mapping[str, Any]] = {"type": "ste-pf", "n_particles": 1000}
    belief_model: ClassVar[Mapping[str, Any] | None] = {"type": "ste-gaussian"}

    def __init__(self, params: SourceTermPlannerParams | None = None) -> None:
        super().__init__(params or SourceTermPlannerParams())

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        if model is None:
            raise ConfigError("model", f"the {self.policy} planner needs a measurement model")
        super().reset(ctx, model)
        p = self.params
        self.step = p.step if p.step is not None else ctx.max_speed * ctx.dt
        if not self.step > 0:
            raise ConfigError("step", "needs a step > 0 (the platform's speed limit is 0)")
        self.directions = candidate_directions(p.directions, ctx.dim, p.vertical)

    def plan(self, belief: Any, pose: Pose, rng: np.random.Generator) -> Plan:
        """Score the moves of ``pose`` over the posterior ``belief`` (a
        :class:`~odorloc.inference.source_terms.belief.SourceTermBelief`)."""
        pos = np.asarray(pose.position, float)
        targets = pos[None, :] + self.step * self.directions
        ok = reachable(self.ctx.arena, pos, targets)
        scores = np.full(len(targets), np.inf)
        work = 0
        if ok.any() and belief is not None:
            terms, lw = belief.thin(self.params.n_plan)
            q = self.model.outcome_probabilities(targets[ok], terms, **dict(pose.conditions))
            work = int(q.size)
            if self.policy == "infotaxis":
                scores[ok] = rewards.expected_entropy(lw, q)
            else:
                scores[ok] = -rewards.predictive_entropy(lw, q)
        index = select(scores, mode="min", feasible=ok, ties=self.params.ties, rng=rng)
        return Plan(index, targets, scores, ok, work)


@register("planner", "ste-infotaxis", SourceTermPlannerParams, "infotaxis over source terms")
class SourceTermInfotaxis(_InformationPlanner):
    """Least expected posterior entropy over a source-term posterior (module docstring)."""

    policy = "infotaxis"
    Params = SourceTermPlannerParams


@register("planner", "ste-entrotaxis", SourceTermPlannerParams, "entrotaxis over source terms")
class SourceTermEntrotaxis(_InformationPlanner):
    """Largest predictive entropy of the next reading (module docstring)."""

    policy = "entrotaxis"
    Params = SourceTermPlannerParams


class LawnmowerParams(Params):
    """Parameters of :class:`LawnmowerPlanner`.

    Attributes
    ----------
    spacing : float, metres
        Distance between lanes.
    along : {"x", "y"}
        Direction of the long legs.
    region : ((x0, y0), (x1, y1)), optional
        Box to sweep (default: the task's search region, else the arena).
    margin : float, metres
        Distance kept from the box's edges.
    rounds : int
        Passes over the box (every other one backwards).
    altitude : float, metres, optional
        3-D: the height flown (default: the start's).
    """

    spacing: Positive = 5.0
    along: Literal["x", "y"] = "y"
    region: Region | None = None
    margin: NonNegative = 1.0
    rounds: int = Field(1, ge=1, le=1000)
    altitude: float | None = Field(None, allow_inf_nan=False)


@register("planner", "ste-lawnmower", LawnmowerParams, "boustrophedon over the search region")
class LawnmowerPlanner(Planner):
    """The waypoints of a boustrophedon, one per :meth:`plan` call (the posterior is not used);
    ``index=None`` once the last round is done."""

    params: LawnmowerParams
    Params = LawnmowerParams
    needs_model: ClassVar[bool] = False
    belief_estimator: ClassVar[Mapping[str, Any]] = {"type": "ste-pf", "n_particles": 1000}
    belief_model: ClassVar[Mapping[str, Any] | None] = {"type": "ste-gaussian"}

    def __init__(self, params: LawnmowerParams | None = None) -> None:
        super().__init__(params or LawnmowerParams())

    def reset(self, ctx: SearchContext, model: Any = None) -> None:
        super().reset(ctx, model)
        p = self.params
        if p.region is not None:
            region, field = check_region(p.region, "planner.region"), "planner.region"
        else:
            region, field = task_region(ctx), "task.region"
        horizontal = None if region is None else (region[0][:2], region[1][:2])
        lo2, hi2 = narrow_box(ctx.arena.lo[:2], ctx.arena.hi[:2], horizontal, field)
        lo2, hi2 = lo2 + p.margin, hi2 - p.margin
        if np.any(hi2 <= lo2):
            raise ConfigError("planner.margin", "leaves nothing of the region to sweep")
        start = ctx.start[0]
        one = rectangular_wave(lo2, hi2, p.spacing, p.along, start[:2])
        legs = [one if r % 2 == 0 else one[::-1] for r in range(p.rounds)]
        wp = np.vstack(legs)
        if ctx.dim == 3:
            z = float(start[2]) if p.altitude is None else p.altitude
            z = float(np.clip(z, ctx.arena.lo[2], ctx.arena.hi[2]))
            wp = np.column_stack([wp, np.full(len(wp), z)])
        self.waypoints = wp
        self.next = 0

    def plan(self, belief: Any, pose: Pose, rng: np.random.Generator) -> Plan:
        """The next waypoint (none after the last)."""
        if self.next >= len(self.waypoints):
            empty = np.zeros((0, self.ctx.dim))
            return Plan(None, empty, np.zeros(0), np.zeros(0, bool))
        target = self.waypoints[self.next]
        self.next += 1
        return Plan(0, target[None, :], np.zeros(1), np.ones(1, bool), extra={"leg": self.next})

    @property
    def done(self) -> bool:
        """Whether every waypoint has been given out."""
        return self.next >= len(self.waypoints)

    @property
    def length(self) -> float:
        """Length of the whole route from the first waypoint, metres."""
        return float(np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1).sum())
