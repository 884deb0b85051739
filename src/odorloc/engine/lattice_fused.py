"""Whole episodes of OTTO's lattice problem in one compiled call.

:class:`LatticeProblem` is what a ``lattice-isotropic-*`` scenario fixes for every episode: the
first-hit law, the start beliefs the plume draws the source from, the mean hits per offset the
sensor draws from, the step cap and the stuck rule (the batched lattice environment,
:mod:`odorloc.envs.vector`, steps the same episodes).

:func:`run_fused` plays one episode of such a scenario with the ``lattice-infotaxis`` searcher
(:mod:`odorloc.searchers.lattice_fused`) in one compiled call: the world's draws from the
episode's world and sensor streams exactly as the engine makes them (the first hit and the
source from the world stream, each hit count from the sensor stream by NumPy's Poisson
sampler), the searcher's belief update and decision by the same kernels its ``act`` calls, in
the engine's order (the reading, the decision, the step cap, the move, the next reading, the
reach and the stuck rule). Its metrics row has the engine's columns and values
(:meth:`~odorloc.engine.episode.Episode.result`), except the measured times: ``wall_time`` and
``wall_per_step_ms`` are the compiled episode's, ``world_fraction`` is NaN and
``searcher_fraction`` 1 (the world and the searcher are not timed apart: the whole is counted
as the searcher's, an upper bound of its share). There is no
recording: :func:`~odorloc.engine.episode.run_episode` takes this path only without one.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_generators
from odorloc.core.types import Event
from odorloc.engine.steps import control_substeps, step_count
from odorloc.models.lattice import (
    IsotropicHitModel,
    IsotropicHitParams,
    auto_n_hits,
    initial_belief,
    initial_hit_probabilities,
    isotropic_mean_hits,
    tabulate,
)
from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import vergassola_rate
from odorloc.planning.lattice_step import LatticeKernels
from odorloc.scenarios import Scenario

__all__ = ["LatticeProblem", "run_fused"]

_TERMINATIONS = ("running", "reached", "time_limit", "stuck")


def _cdf(p: np.ndarray) -> np.ndarray:
    """The cumulative sum ``numpy.random.Generator.choice`` searches for ``p``."""
    cdf = np.asarray(p, float).cumsum()
    cdf /= cdf[-1]
    return cdf


class LatticeProblem:
    """What a scenario of OTTO's lattice problem fixes for every episode, checked once from its
    built parts."""

    def __init__(self, sc: Scenario) -> None:
        from odorloc.plume.lattice import LatticeIsotropicPlume
        from odorloc.scenarios.build import build, search_context
        from odorloc.sensors.encounter import EncounterSensor

        built = build(sc)
        plume = built.world.plume
        if not isinstance(plume, LatticeIsotropicPlume) or plume.params.start != "initial-hit":
            raise ConfigError(
                "world.plume",
                "needs a lattice-isotropic plume with start: initial-hit",
            )
        if sc.platform.type != "lattice":
            raise ConfigError("platform.type", "needs a lattice platform")
        if len(built.platforms) != 1:
            raise ConfigError("agents", "needs one agent per episode")
        sensor = built.gas_sensors[0]
        if not isinstance(sensor, EncounterSensor):
            raise ConfigError("sensors.gas", "needs an encounter counter")
        if sc.world.source_draw is not None:
            raise ConfigError("world.source_draw", "the lattice plume draws the source itself")
        arena = plume.arena
        if arena.occ is not None:
            raise ConfigError("world.arena", "needs an open arena")
        grid = arena.grid
        shape = tuple(int(v) for v in grid.shape)
        dim = len(shape)
        cell = float(plume.cell)
        self.dim, self.cell, self.shape = dim, cell, shape
        self.length = float(plume.params.length)
        rate = float(plume.sources[0].rate_at(0.0))
        self.intensity = rate * float(plume.params.exposure)
        nh = plume.params.n_hits
        z = nh if nh is not None else auto_n_hits(self.length, self.intensity, cell, dim)
        self.z = int(z)
        self.start = tuple(int(v) for v in grid.index(plume.origin)[0])
        agent = tuple(int(v) for v in grid.index(np.asarray(sc.agents.starts[0], float))[0])
        if agent != self.start:
            raise ConfigError("agents.starts", "the agent must start in the plume's origin cell")
        self.dt = float(control_substeps(sc)[0])
        # what a compiled episode needs besides: the context a searcher is reset with, the
        # sensor's detection threshold, the cell centres the source is drawn among, the start
        self.context = search_context(sc, built)
        self.threshold = int(sensor.params.threshold)
        self.centres = grid.flat_centers()
        self.starts = np.asarray(sc.agents.starts, float)
        self.anchor = self.starts[0].copy()
        self.walker_cell = float(built.platforms[0].params.cell)
        self.end_reach = sc.task.end == "reach"
        self.reach_radius = sc.task.reach_radius
        self.n_sources = len(sc.world.sources)
        self.n_steps = step_count(sc)
        stuck = sc.task.stuck_limit
        self.stuck = -1 if stuck is None else int(stuck)
        # the first-hit law and the start beliefs, as the plume computes them
        self.p_h0 = initial_hit_probabilities(self.length, self.intensity, cell, dim, self.z)
        centres = grid.flat_centers()
        d = np.linalg.norm(centres - plume.origin, axis=1)
        mu0 = isotropic_mean_hits(d, self.length, self.intensity, cell, dim)
        like = censored_poisson(mu0, self.z)
        # Generator.choice(p=...) draws one uniform number and searches the normalised
        # cumulative sum: the same search on the same sums draws the same index
        self.cdf_h0 = _cdf(self.p_h0)
        self.b0: list[np.ndarray | None] = []
        for h in range(self.z):
            if self.p_h0[h] > 0:
                b0 = initial_belief(like[:, h].reshape(shape), self.start)
                self.b0.append(b0.reshape(-1))
            else:
                self.b0.append(None)
        self.cdf_b0 = [None if b is None else _cdf(b) for b in self.b0]
        # the searcher's belief update: the problem's own model, tabulated over the offsets
        model = IsotropicHitModel(IsotropicHitParams(length=self.length, intensity=self.intensity))
        table = tabulate(model, cell, tuple(n - 1 for n in shape))
        if table.n_classes != self.z:
            raise ConfigError("world.plume.n_hits", f"must be the model's {table.n_classes}")
        self.kernels = LatticeKernels(table.prob)
        # exp(-mean hits) per source-minus-agent offset: the plume's encounter rate at the
        # offset, times the sensor's gain and the control period, as the sensor computes it
        offs = [np.arange(-(n - 1), n) * cell for n in shape]
        pts = np.stack(np.meshgrid(*offs, indexing="ij"), -1).reshape(-1, dim)
        r = vergassola_rate(
            -pts,
            np.zeros((1, dim)),
            np.array([rate]),
            V=0.0,
            D=1.0,
            tau=self.length**2,
            a=0.5 * cell,
        )[:, 0]
        mu = sensor.params.gain * r * self.dt
        if np.any(mu[np.isfinite(mu)] >= 10.0):
            raise ConfigError("world.sources[0].rate", "mean hits of 10 or more per step")
        with np.errstate(over="ignore"):
            el = np.exp(-mu).reshape(tuple(2 * n - 1 for n in shape))
        self.enlam = np.ascontiguousarray(el if dim == 3 else el[None])
        # every first hit's start-belief cumulative sum as one array (zeros for classes that
        # cannot come first)
        self.cdf_b0_rows = np.zeros((self.z, len(self.centres)))
        for h, cdf in enumerate(self.cdf_b0):
            if cdf is not None:
                self.cdf_b0_rows[h] = cdf


_PROBLEMS: dict[str, LatticeProblem | None] = {}


def _problem(scenario: Scenario) -> LatticeProblem | None:
    """The scenario's :class:`LatticeProblem` (kept per configuration), or ``None`` when it is
    not a scenario of the lattice problem."""
    key = scenario.model_dump_json()  # a configuration's key, cheaper than its hash
    if key not in _PROBLEMS:
        try:
            _PROBLEMS[key] = LatticeProblem(scenario)
        except ConfigError:
            _PROBLEMS[key] = None
        while len(_PROBLEMS) > 16:
            _PROBLEMS.pop(next(iter(_PROBLEMS)))
    return _PROBLEMS[key]


def _state(g: np.random.Generator) -> np.ndarray:
    """A PCG64 generator's state as the compiled streams hold it ``(4,)`` uint64."""
    st = g.bit_generator.state["state"]
    m = (1 << 64) - 1
    s, inc = int(st["state"]), int(st["inc"])
    return np.array([s >> 64, s & m, inc >> 64, inc & m], np.uint64)


def run_fused(
    scenario: Scenario,
    searcher: Any | None,
    world_seed: int,
    agent_seed: int,
) -> Any:
    """One episode of ``scenario`` with ``searcher`` (``None``: the scenario's) played in one
    compiled call: the parts of its :class:`~odorloc.engine.episode.EpisodeResult` (the core
    metrics, the searcher's final and per-agent metrics, the sources ``(S, d)`` and the events),
    or ``None`` when this path does not apply (another searcher, or not a scenario of the
    lattice problem); see the module docstring. The searcher is reset with the episode's
    searcher stream, as the engine resets it."""
    from odorloc.searchers.lattice_fused import LatticeInfotaxisSearcher, play

    if searcher is None:
        if scenario.searcher.type != "lattice-infotaxis":
            return None
        from odorloc.scenarios.build import build_searcher

        searcher = build_searcher(scenario)
    if type(searcher) is not LatticeInfotaxisSearcher:
        return None
    pr = _problem(scenario)
    if pr is None:
        return None
    wall0 = time.perf_counter()
    world, sense, agent_rng = episode_generators(world_seed, agent_seed)
    searcher.reset(pr.context, agent_rng)
    k = searcher.kernels
    if k.shape != pr.kernels.shape:
        return None
    b, logb = searcher.start_belief()
    cells = np.zeros((3, 3), np.int64)
    out = np.full(6, math.nan)
    anchor = np.zeros(3)
    anchor[3 - pr.dim :] = pr.anchor
    scores = np.empty(2 * k.dim)
    start = np.zeros(3, np.int64)
    start[3 - pr.dim :] = pr.start
    code = play(
        True, -1, _state(world), _state(sense), pr.cdf_h0, pr.cdf_b0_rows, start, anchor,
        pr.walker_cell, pr.enlam, k.prob,
        k.channels, k.half, k.dim, k.code, pr.z, pr.n_steps, pr.stuck, pr.threshold, b, logb,
        scores, cells, out,
    )  # fmt: skip
    searcher.adopt(b, out[1], out[2], int(out[3]))
    steps = int(out[4])
    t = steps * pr.dt
    d = pr.dim
    src_cell = cells[0, 3 - d :]
    sources = pr.centres[int(np.ravel_multi_index(tuple(src_cell), pr.shape))][None, :].copy()
    termination = _TERMINATIONS[code]
    wall = time.perf_counter() - wall0
    det = out[0]

    def position(c: np.ndarray) -> np.ndarray:
        # the walker's node: its start plus whole cells (platforms.lattice)
        return pr.anchor + (c[3 - d :] - np.asarray(pr.start)) * pr.walker_cell

    events: list[Event] = []
    first = math.nan if det < 0 else float(int(det) * pr.dt)
    if not math.isnan(first):
        events.append(Event(first, "first_detection", agent=0, position=position(cells[2])))
    reached = code == 1
    if reached:
        events.append(Event(t, "source_reached", agent=0, source=0, position=position(cells[1])))
    events.append(Event(t, "end", detail=termination))
    path = float(out[5])
    metrics: dict[str, Any] = {
        "termination": termination,
        "declared": False,
        "search_time": float(t),
        "steps": steps,
        "path_length": path,
        "first_detection_time": first,
        "energy": 0.0,
        "bytes": 0,
        "start_distance": float(
            np.min(np.linalg.norm(pr.starts[:, None, :] - sources[None], axis=2))
        ),
        "wall_time": wall,
        "wall_per_step_ms": 1e3 * wall / max(steps, 1),
        "world_fraction": math.nan,
        "success": False,
        "loc_error": math.nan,
        "sources_found": 0,
        "false_sources": 0,
    }
    if pr.end_reach:
        metrics["success"] = reached
    if pr.reach_radius is not None:
        metrics["reach_time"] = float(t) if reached else math.nan
        metrics["reach_agent"] = 0 if reached else -1
    metrics["declarations"] = 0
    for s in range(pr.n_sources):
        metrics[f"found_time_{s}"] = math.nan
    # the compiled episode is not timed apart: all of it counts as the searcher's (an upper
    # bound of its share; the world's part is a Poisson draw per step)
    metrics["searcher_fraction"] = 1.0
    return metrics, searcher.final_metrics(), searcher.agent_metrics(), sources, events
