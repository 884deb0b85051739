"""Particle-belief infotaxis: a particle filter with infotaxis over direction x step moves.

Recipe (the single-agent base of the multi-UAV paper's Col-Inf baseline: "traditional particle
filter + POMDP with fixed moving step", i.e. infotaxis):

1. **Belief**: ``n_particles`` source hypotheses uniform over the free part of the search region
   (:class:`~odorloc.inference.particles.ParticleFilter`), resampled by the configured resampler
   when ``N_eff < resample_threshold N``.
2. **Every control period**: particles within ``found_radius`` of the agent are removed (the
   episode would have ended), and the reading updates the weights with the outcome law of the
   searcher's model at the agent's position (its class as in :mod:`odorloc.searchers.infotaxis`).
3. **Motion**, when the last move is done: the candidates ``position + step u`` (``moves``:
   ``lattice``, the ``2d`` axis directions, or ``neighbours``, 8 horizontal directions in 2-D and
   the 26 of :func:`~odorloc.geometry.vectors.directions_26` in 3-D) that walls and obstacles
   allow are scored by :class:`~odorloc.planning.infotaxis.ParticleInfotaxisPlanner` (expected
   entropy of the weights after the move, the found outcome included; or entrotaxis) with the
   model bound to the exposure and the measured mean wind.

Candidates and the outcome model are the planner's arguments, so a team recipe (collaborative
infotaxis) reuses it with its own candidate sets and joint outcome models.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Observation, Region, SearchContext
from odorloc.geometry.regions import check_region
from odorloc.geometry.vectors import directions_26, lattice_moves, ring
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.particles import ArenaConstraint, ParticleFilter, Resampler
from odorloc.models.base import MeasurementModel
from odorloc.planning.candidates import reachable
from odorloc.planning.infotaxis import ParticleInfotaxisPlanner
from odorloc.searchers.base import Searcher
from odorloc.searchers.infotaxis import reading_class

__all__ = ["ParticleInfotaxisParams", "ParticleInfotaxisSearcher", "move_directions_of"]


class ParticleInfotaxisParams(Params):
    """Parameters of :class:`ParticleInfotaxisSearcher` (see the module docstring).

    Attributes
    ----------
    model : dict
        The searcher's measurement model, ``{type: name, **params}``.
    n_particles : int
        Number of particles of the belief.
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Where the initial particles lie (default: the task's search region, else the arena).
    moves : {"lattice", "neighbours"}
        Candidate directions.
    step : float, metres, optional
        Length of one move (default: one control period at the platform's speed limit).
    found_radius : float, metres, optional
        Particles within this distance of the agent are found there (set it to the task's
        reach radius; default half a step).
    policy : {"infotaxis", "entrotaxis"}
        The reward: expected entropy (infotaxis) or predictive entropy (entrotaxis).
    reading, n_classes, exposure, wind_average
        As for the grid policies (:class:`~odorloc.searchers.infotaxis.GridPolicyParams`).
    resampler : dict
        The resampler, ``{type: name, **params}`` (default systematic with a 0.2 m jitter).
    resample_threshold : float
        Resample when ``N_eff < resample_threshold N``.
    ties : {"first", "random"}
        Equal scores: the first candidate, or one drawn at random.
    """

    model: Ref("model") = ComponentRef(type="vergassola")
    n_particles: int = Field(500, ge=2, le=1_000_000)
    region: Region | None = None
    moves: Literal["lattice", "neighbours"] = "neighbours"
    step: Positive | None = None
    found_radius: Positive | None = None
    policy: Literal["infotaxis", "entrotaxis"] = "infotaxis"
    reading: Literal["auto", "hits", "detection"] = "auto"
    n_classes: int | None = Field(None, ge=2, le=64)
    exposure: Positive | None = None
    wind_average: int = Field(10, ge=1, le=10_000)
    resampler: Ref("resampler") = ComponentRef(type="systematic", jitter_std=0.2)
    resample_threshold: float = Field(0.5, ge=0.0, le=1.0)
    ties: Literal["first", "random"] = "first"


def move_directions_of(dim: int, moves: str) -> np.ndarray:
    """Unit directions of a move set, ``(K, dim)``: ``lattice`` (``2 dim`` axis moves) or
    ``neighbours`` (8 horizontal directions in 2-D, the 26 lattice directions in 3-D)."""
    if moves == "lattice":
        return np.asarray(lattice_moves(dim), float)
    if moves == "neighbours":
        return np.asarray(directions_26(), float) if dim == 3 else ring(8, 2)
    raise ConfigError("moves", f"unknown move set {moves!r}")


@register(
    "searcher", "particle-infotaxis", ParticleInfotaxisParams, "particle filter + infotaxis moves"
)
class ParticleInfotaxisSearcher(Searcher):
    """Infotaxis on a particle belief over direction x step candidates. Single agent."""

    params: ParticleInfotaxisParams
    max_agents = 1
    declares = False

    def __init__(self, params: ParticleInfotaxisParams | None = None) -> None:
        super().__init__(params or ParticleInfotaxisParams())
        p = self.params
        self.model: MeasurementModel = p.model.build("model", field="searcher.model")
        self.planner = ParticleInfotaxisPlanner(p.policy, ties=p.ties)

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Uniform particles over the free part of the region."""
        super().reset(ctx, rng)
        p = self.params
        arena = ctx.arena
        region = p.region if p.region is not None else ctx.search_region
        lo, hi = arena.lo.copy(), arena.hi.copy()
        if region is not None:
            rlo, rhi = check_region(region, "searcher.region")
            k = len(rlo)
            lo[:k] = np.maximum(lo[:k], rlo)
            hi[:k] = np.minimum(hi[:k], rhi)
            if np.any(hi <= lo):
                raise ConfigError("searcher.region", "does not overlap the arena")
        self.lo, self.hi = lo, hi
        self.pf = ParticleFilter(
            self._uniform(p.n_particles, rng),
            resampler=self._resampler(),
            resample_threshold=p.resample_threshold,
            constraint=ArenaConstraint(arena),
        )
        self.step = p.step if p.step is not None else ctx.max_speed * ctx.dt
        self.found_radius = p.found_radius if p.found_radius is not None else 0.5 * self.step
        kind = p.reading
        if kind == "auto":
            kind = "hits" if ctx.sensor.unit == "hits" else "detection"
        self.kind = kind
        self.n_classes = (
            p.n_classes if p.n_classes is not None else (2 if kind == "detection" else None)
        )
        self.exposure = p.exposure if p.exposure is not None else ctx.dt
        self.directions = move_directions_of(arena.dim, p.moves)
        self._winds: list[np.ndarray] = []
        self._redraws = 0
        self._last_eh = math.nan

    def _resampler(self) -> Resampler:
        return self.params.resampler.build("resampler", field="searcher.resampler")

    def _uniform(self, n: int, rng: np.random.Generator) -> np.ndarray:
        arena = self.ctx.arena
        out = np.zeros((0, arena.dim))
        for _ in range(200):
            cand = self.lo + rng.random((max(2 * (n - len(out)), 16), arena.dim)) * (
                self.hi - self.lo
            )
            out = np.concatenate([out, cand[arena.is_free(cand)]])
            if len(out) >= n:
                return out[:n]
        raise ConfigError("searcher.region", "too little free space for the particles")

    def _conditions(self) -> dict[str, Any]:
        wind = sum(self._winds) / len(self._winds)
        cond: dict[str, Any] = {"dt": self.exposure, "wind": wind}
        speed = float(np.linalg.norm(wind))
        if speed > 1e-9:
            cond["direction"] = wind / speed
        if self.n_classes is not None:
            cond["n_classes"] = self.n_classes
        return cond

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Remove the found particles, update with the reading, plan when ready."""
        o = observations[0]
        pos = np.asarray(o.position, float)
        self._winds.append(np.asarray(o.wind, float))
        if len(self._winds) > self.params.wind_average:
            del self._winds[0]
        cond = self._conditions()
        pf = self.pf
        near = np.linalg.norm(pf.positions - pos, axis=1) <= self.found_radius
        if near.all():
            # every hypothesis sat where the agent is: start again away from it
            fresh = self._uniform(self.params.n_particles, rng)
            fresh = fresh[np.linalg.norm(fresh - pos, axis=1) > self.found_radius]
            if len(fresh):
                pf.replace(fresh)
                self._redraws += 1
            near = np.linalg.norm(pf.positions - pos, axis=1) <= self.found_radius
        q = self.model.outcome_probabilities(pos[None, :], pf.positions, **cond)
        z = reading_class(o, self.kind, q.shape[1])
        with np.errstate(divide="ignore"):
            ll = np.log(q[0, z])
        pf.update(np.where(near, -np.inf, ll))
        pf.resample_if_needed(rng)
        if not o.ready:
            return Action([None])
        targets = pos[None, :] + self.step * self.directions
        ok = reachable(self.ctx.arena, pos, targets)
        plan = self.planner.plan(
            pf.belief(),
            targets,
            self.model.bind(**cond),
            feasible=ok,
            found_radius=self.found_radius,
            rng=rng,
        )
        if plan.index is None:
            return Action([Command.hold()])
        self._last_eh = float(plan.scores[plan.index])
        return Action([Command.move(targets[plan.index] - pos)])

    def belief(self) -> ParticleBelief:
        """The particle set."""
        return self.pf.belief()

    def diagnostics(self) -> dict[str, float]:
        """``ess``, ``entropy`` (of the weights, nats) and the chosen move's score."""
        b = self.pf.belief()
        return {"ess": b.ess, "entropy": b.entropy, "score": self._last_eh}

    def final_metrics(self) -> dict[str, Any]:
        """Resamplings and redraws of the particle set."""
        return {"resamples": float(self.pf.n_resamples), "redraws": float(self._redraws)}
