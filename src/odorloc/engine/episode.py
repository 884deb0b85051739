"""The episode: a world, its agents and a task, stepped one control period at a time.

:class:`Episode` is the stepping core (what Gymnasium and PettingZoo adapters wrap)::

    ep = Episode(scenario)
    obs = ep.reset(world_seed, agent_seed)          # observations at t = 0
    while not ep.done:
        res = ep.step(action)                       # -> StepResult: observations, events, flags
    result = ep.result()                            # metrics row, recording, declarations

One step is: record the observations the action answers; register its declarations (and the
sources they find); end if the scenario's rule says so (``task.end``), or at the time limit or an
exhausted platform; otherwise deliver the messages (charging radio energy), charge the reported
computation, move the platforms, advance the world by one control period and observe again.

Platforms with a body (``radius > 0``) never pass through each other: they move one after
another in agent order, each stopped where it would touch another body at that body's current
position (:func:`~odorloc.platforms.base.body_contact_fraction`), as walls and obstacles stop
it.

:func:`run_episode` is the driver that lets a searcher answer: it is all that ``odorloc run``,
sweeps and reproductions use.

Randomness: an episode takes two integer seeds (:mod:`odorloc.core.seeds`). ``world_seed`` drives
the wind, the plume and the sensor noise; ``agent_seed`` drives the searcher. Two searchers run
with the same ``world_seed`` face the same plume (common random numbers), since no plume model
depends on what the agents do. :func:`prepare_world` is the one warm-up, shared with flow
recording (:mod:`odorloc.engine.replay`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from odorloc.core.seeds import episode_generators
from odorloc.core.types import Action, Declaration, Event, Message, Observation, SearchContext
from odorloc.engine.metrics import EpisodeMetrics
from odorloc.engine.recorder import Recorder, Recording
from odorloc.engine.steps import control_substeps, step_count
from odorloc.platforms.team import CommGraph
from odorloc.scenarios.build import Built, build, build_world, search_context
from odorloc.scenarios.config import Scenario
from odorloc.searchers.base import Searcher
from odorloc.world.world import World

__all__ = [
    "Episode",
    "EpisodeResult",
    "StepResult",
    "control_substeps",
    "first_within",
    "prepare_world",
    "run_episode",
    "score_declaration",
]


def prepare_world(
    scenario: Scenario, world_seed: int, world: World | None = None
) -> tuple[World, np.random.Generator, np.random.Generator]:
    """The world of an episode after its reset and warm-up.

    Parameters
    ----------
    scenario : Scenario
    world_seed : int
    world : World, optional
        A built world to use (default: built from the scenario).

    Returns
    -------
    world : World
        Its sources drawn for this episode when the scenario says so (``world.source_draw``),
        reset, and warmed up for ``scenario.world.warmup`` seconds (in world steps of
        :func:`control_substeps`).
    rng_world, rng_sense : numpy.random.Generator
        The world's stream (positioned after the warm-up) and the sensors' stream.
    """
    w = world if world is not None else build_world(scenario)
    rng_world, rng_sense, _ = episode_generators(world_seed, 0)
    _, _, wdt = control_substeps(scenario)
    draw = scenario.world.source_draw
    if draw is not None:
        # the world's own stream: every searcher of this episode faces the same sources
        drawer = draw.build("source_draw", field="world.source_draw")
        starts = np.asarray(scenario.agents.starts, float)
        w.plume.set_sources(drawer.draw(list(scenario.world.sources), w.arena, starts, rng_world))
    w.reset(rng_world)
    for _ in range(round(scenario.world.warmup / wdt)):
        w.step(wdt, rng_world)
    return w, rng_world, rng_sense


def score_declaration(
    declared: np.ndarray, sources: np.ndarray, radius: float
) -> tuple[bool, float, int, int]:
    """Match declared positions to true sources.

    Returns
    -------
    success : bool
        Every true source has a declared position within ``radius`` metres.
    loc_error : float
        Mean over true sources of the distance to the nearest declared position, metres.
    found : int
        True sources with a declared position within ``radius``.
    false : int
        Declared positions farther than ``radius`` from every true source.
    """
    d = np.linalg.norm(declared[:, None, :] - sources[None, :, :], axis=2)  # (K, S)
    nearest = d.min(axis=0)
    found = int(np.sum(nearest <= radius))
    false = int(np.sum(d.min(axis=1) > radius))
    return found == len(sources), float(nearest.mean()), found, false


class Probe(Protocol):
    """What the recorder asks of whoever chose the action (a searcher satisfies it)."""

    def diagnostics(self) -> dict[str, float]: ...

    def beliefs(self) -> Any: ...


@dataclass
class StepResult:
    """What one :meth:`Episode.step` produced.

    Attributes
    ----------
    observations : list of Observation
        The next observations (empty once the episode is done).
    events : list of Event
        Events of this step (declarations, sources found or reached, the end).
    terminated : bool
        The task ended the episode (declarations by ``task.end``, or a source reached).
    truncated : bool
        A limit ended it (time, energy or the back-and-forth rule).
    termination : str
        ``"running"``, ``"declared"``, ``"reached"``, ``"time_limit"``, ``"energy"`` or
        ``"stuck"`` (``task.stuck_limit``).
    t : float
        Time of ``observations`` (or of the end), seconds.
    """

    observations: list[Observation]
    events: list[Event]
    terminated: bool
    truncated: bool
    termination: str
    t: float

    @property
    def done(self) -> bool:
        """``True`` when the episode is over."""
        return self.terminated or self.truncated


@dataclass
class EpisodeResult:
    """Outcome of one episode: its metrics (core and extra columns, per-agent values), the
    recording, declarations and events."""

    metrics: EpisodeMetrics
    recording: Recording | None = None
    declarations: list[Declaration] = field(default_factory=list)
    sources: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    events: list[Event] = field(default_factory=list)

    @property
    def declaration(self) -> Declaration | None:
        """All declared positions as one declaration (``None`` if nothing was declared)."""
        if not self.declarations:
            return None
        if len(self.declarations) == 1:
            return self.declarations[0]
        return Declaration(
            np.vstack([d.positions for d in self.declarations]),
            confidence=float(np.mean([d.confidence for d in self.declarations])),
        )


class Episode:
    """A steppable episode of a scenario (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
    built : Built, optional
        Pre-built components (default: built from the scenario). Their searcher is unused here;
        :func:`run_episode` drives it.
    record : bool, optional
        Keep a :class:`Recording`; defaults to ``scenario.recording.enabled``.
    """

    def __init__(
        self, scenario: Scenario, *, built: Built | None = None, record: bool | None = None
    ) -> None:
        self.scenario = scenario
        self.built = built if built is not None else build(scenario)
        self.record = scenario.recording.enabled if record is None else bool(record)
        T, n_sub, wdt = control_substeps(scenario)
        self.n_steps = step_count(scenario)
        self._T, self._n_sub, self._wdt = T, n_sub, wdt
        self.n_agents = len(scenario.agents.starts)
        self._started = False

    # ------------------------------------------------------------------ lifecycle
    def reset(self, world_seed: int, agent_seed: int) -> list[Observation]:
        """Start the episode; return the observations at ``t = 0``.

        After the call, :attr:`context` is what the searcher may know and :attr:`agent_rng` the
        searcher's own random stream.
        """
        self._wall0 = time.perf_counter()
        sc, b = self.scenario, self.built
        world, self._rng_world, self._rng_sense = prepare_world(sc, world_seed, b.world)
        # the plume's warm-up is world time too (it is in the episode's wall time)
        warmup = time.perf_counter() - self._wall0
        self.agent_rng = episode_generators(world_seed, agent_seed)[2]
        self.world = world
        self.sources = world.sources
        self._source_rows = np.asarray(self.sources, float).tolist()
        self._starts = np.asarray(sc.agents.starts, float)
        for k, pl in enumerate(b.platforms):
            pl.reset(self._starts[k], sc.agents.heading)
        radii = np.array([float(pl.radius) for pl in b.platforms])
        self._radii: np.ndarray | None = None
        if self.n_agents > 1 and np.any(radii > 0):
            self._radii = radii
            # farthest a pair of bodies can close in one period: both radii and both reaches
            reach = np.array([float(pl.speed_limit) for pl in b.platforms]) * self._T
            self._contact = (radii + reach)[:, None] + (radii + reach)[None, :]
        for s in (*b.gas_sensors, *b.anemometers):
            s.reset(self._rng_sense)
        for k, gs in enumerate(b.gas_sensors):
            gs.start(world.plume, self._starts[k])
        self.context: SearchContext = search_context(sc, b)
        self._comm = CommGraph(sc.agents.comm_radius)
        self._inbox: list[tuple[Message, ...]] = [() for _ in range(self.n_agents)]
        self._rec = Recorder(sc, world.arena, self.sources) if self.record else None
        self._step = 0
        self._t = 0.0
        self._first_detection = math.nan
        self._first_detection_agent: set[int] = set()
        self._declarations: list[Declaration] = []
        self._declared_groups: set[int] = set()
        self._found_time = np.full(len(self.sources), math.nan)
        self._reach_time = math.nan
        self._reach_agent = -1
        self._reach_stats: dict[str, float] = {}
        # positions after the last two steps and the back-and-forth counters (task.stuck_limit)
        self._recent: list[np.ndarray] = []
        self._back_and_forth = np.zeros(self.n_agents, int)
        self._events: list[Event] = []
        self._termination = "running"
        self._world_time = warmup
        self._bytes = 0
        self._done = False
        self._started = True
        # _observe files its events in self._events itself
        self._obs = self._observe([])
        self._recent = [np.array([o.position for o in self._obs])]
        if self._task_done():
            if self._rec is not None:
                self._rec.final_pose(self._t, self._obs, None)
            self._finish("reached", self._events)
        return self._obs

    @property
    def done(self) -> bool:
        """``True`` once the episode has ended."""
        return self._done

    @property
    def t(self) -> float:
        """Current episode time, seconds."""
        return self._t

    @property
    def observations(self) -> list[Observation]:
        """The observations the next action answers."""
        return self._obs

    @property
    def events(self) -> list[Event]:
        """Every event so far."""
        return list(self._events)

    @property
    def platforms(self) -> list[Any]:
        """The agents' platforms (read their state; do not command them directly)."""
        return self.built.platforms

    # ------------------------------------------------------------------ one step
    def step(self, action: Action, probe: Probe | None = None) -> StepResult:
        """Apply ``action`` to the current observations and advance one control period.

        Parameters
        ----------
        action : Action
            One command per agent (agent-id order), messages, declarations, computation.
        probe : object with ``diagnostics()`` and ``beliefs()``, optional
            Asked for what to record with this step (usually the searcher).
        """
        if not self._started:
            raise RuntimeError("call reset(world_seed, agent_seed) before step()")
        if self._done:
            raise RuntimeError("the episode is over; call reset() to start another")
        if len(action.commands) != self.n_agents:
            raise RuntimeError(
                f"action has {len(action.commands)} commands for {self.n_agents} agents"
            )
        step, t, b = self._step, self._t, self.built
        events: list[Event] = []
        if self._rec is not None:
            self._rec.record(step, t, self._obs, b.platforms, probe, self.world)
        for d in action.declarations:
            self._declare(d, t, events)
        if self._task_done():
            return self._finish("declared", events, probe)
        if step == self.n_steps:
            return self._finish("time_limit", events, probe)
        if any(pl.exhausted for pl in b.platforms):
            return self._finish("energy", events, probe)
        # Messages broadcast now are received at the next step.
        positions = np.array([pl.position for pl in b.platforms])
        self._inbox, sent = self._comm.deliver(positions, action.messages)
        self._bytes += sent
        arena = self.world.arena
        # Bodies with a footprint stop each other: each agent moves against the others' current
        # positions (those already moved this period included), so none enters another.
        near = self._near(positions) if self._radii is not None else None
        for k, pl in enumerate(b.platforms):
            nbytes = self._comm.bytes_sent_by(k)
            if nbytes:
                pl.charge_comm(nbytes)
            bits = action.compute_bits.get(k, 0.0)
            if bits:
                pl.charge_compute(bits)
            if near is not None and near[k].any():
                assert self._radii is not None
                others = near[k]
                pl.apply(
                    action.commands[k],
                    self._T,
                    arena,
                    bodies=(positions[others], self._radii[others]),
                )
                positions[k] = pl.position
            else:
                pl.apply(action.commands[k], self._T, arena)
                if near is not None:
                    positions[k] = pl.position
        tw = time.perf_counter()
        for _ in range(self._n_sub):
            self.world.step(self._wdt, self._rng_world)
        self._world_time += time.perf_counter() - tw
        if sum(pl.energy for pl in b.platforms) > self.scenario.limits.energy:
            return self._finish("energy", events, probe)
        self._step = step + 1
        # Exact step arithmetic: summing dt would drift (9.999999 s instead of 10 s).
        self._t = self._step * self._T
        self._obs = self._observe(events)
        ended = "reached" if self._task_done() else "stuck" if self._stuck() else None
        if ended is not None:
            if self._rec is not None:
                self._rec.final_pose(self._t, self._obs, probe)
            return self._finish(ended, events, probe)
        return StepResult(self._obs, events, False, False, "running", self._t)

    # ------------------------------------------------------------------ internals
    def _near(self, positions: np.ndarray) -> np.ndarray:
        """``(N, N)`` pairs of bodies that could touch during this period (none on the
        diagonal); the others cannot, whatever they are commanded."""
        diff = positions[:, None, :] - positions[None, :, :]
        near = np.einsum("ijd,ijd->ij", diff, diff) < self._contact**2
        np.fill_diagonal(near, False)
        return near

    def _observe(self, events: list[Event]) -> list[Observation]:
        b, t = self.built, self._t
        obs = []
        # The plume and the wind are read once at every agent's position (one vectorised query
        # each); every agent's own instruments then respond in agent order, drawing their noise
        # from the sensor stream in the same order as one measurement after another.
        positions = np.array([pl.position for pl in b.platforms])
        truth = b.gas_sensors[0].sample(self.world.plume, positions)
        air = self.world.wind.velocity(positions)
        for k, pl in enumerate(b.platforms):
            reading = b.gas_sensors[k].respond(float(truth[k]), self._T, self._rng_sense)
            wind = b.anemometers[k].respond(air[k], pl.velocity, self._T, self._rng_sense)
            o = Observation(
                agent=k,
                t=t,
                position=positions[k].copy(),
                heading=float(pl.heading),
                gas=float(reading.value),
                detection=bool(reading.detection),
                wind=np.asarray(wind, float),
                ready=bool(pl.ready),
                messages=self._inbox[k],
                energy=float(pl.energy),
            )
            obs.append(o)
            if o.detection and k not in self._first_detection_agent:
                self._first_detection_agent.add(k)
                if math.isnan(self._first_detection):
                    self._first_detection = t
                ev = Event(t, "first_detection", agent=k, position=o.position.copy())
                events.append(ev)
                self._events.append(ev)
        reach = self.scenario.task.reach_radius
        if reach is not None and math.isnan(self._reach_time):
            hit = self._first_within(positions, reach)
            if hit is not None:
                agent, src = hit
                self._reach_time = t
                self._reach_agent = agent
                # the reaching agent's own totals at this moment (e.g. a UAV's busy time)
                self._reach_stats = dict(self.built.platforms[agent].stats)
                ev = Event(
                    t, "source_reached", agent=agent, source=src, position=positions[agent].copy()
                )
                events.append(ev)
                self._events.append(ev)
        return obs

    def _first_within(self, positions: np.ndarray, radius: float) -> tuple[int, int] | None:
        return first_within(positions, self._source_rows, radius)

    def _stuck(self) -> bool:
        """Update the back-and-forth counters; ``True`` when every agent exceeds the limit.

        At the step that reaches the time limit the limit wins (the episode ends there anyway).
        """
        limit = self.scenario.task.stuck_limit
        if limit is None:
            return False
        pos = np.array([o.position for o in self._obs])
        if len(self._recent) == 2:
            back = np.all(np.abs(pos - self._recent[0]) <= 1e-9, axis=1)
            self._back_and_forth = np.where(back, self._back_and_forth + 1, 0)
        self._recent = [*self._recent[-1:], pos]
        return bool(np.all(self._back_and_forth > limit)) and self._step < self.n_steps

    def _declare(self, d: Declaration, t: float, events: list[Event]) -> None:
        pos = np.atleast_2d(np.asarray(d.positions, float))
        if pos.ndim != 2 or pos.shape[1] != self.world.arena.dim or not np.all(np.isfinite(pos)):
            raise RuntimeError(
                f"declaration positions must be finite (K, {self.world.arena.dim}), got "
                f"{np.shape(d.positions)}"
            )
        self._declarations.append(d)
        ev = Event(t, "declaration", agent=d.agent, group=d.group, position=pos.copy())
        events.append(ev)
        self._events.append(ev)
        groups = self.context.groups
        if d.group is not None:
            self._declared_groups.add(int(d.group))
        elif d.agent is not None and groups:
            g = self.context.group_of(int(d.agent))
            if g is not None:
                self._declared_groups.add(g.index)
        else:
            self._declared_groups.update(range(max(len(groups), 1)))
        radius = self.scenario.task.success_radius
        dist = np.linalg.norm(pos[:, None, :] - self.sources[None, :, :], axis=2).min(axis=0)
        for s in np.flatnonzero((dist <= radius) & np.isnan(self._found_time)):
            self._found_time[s] = t
            ev = Event(t, "source_found", agent=d.agent, group=d.group, source=int(s))
            events.append(ev)
            self._events.append(ev)

    def _task_done(self) -> bool:
        rule = self.scenario.task.end
        if rule == "first_declaration":
            return bool(self._declarations)
        if rule == "all_groups":
            n_groups = max(len(self.scenario.agents.groups), 1)
            return len(self._declared_groups) >= n_groups
        if rule == "reach":
            return not math.isnan(self._reach_time)
        return False

    def _finish(
        self, termination: str, events: list[Event], probe: Probe | None = None
    ) -> StepResult:
        self._termination = termination
        self._done = True
        ev = Event(self._t, "end", detail=termination)
        events.append(ev)
        self._events.append(ev)
        if self._rec is not None and probe is not None:
            self._rec.final_beliefs(self._t, probe)
        terminated = termination in ("declared", "reached")
        return StepResult([], events, terminated, not terminated, termination, self._t)

    # ------------------------------------------------------------------ outcome
    def result(
        self,
        extra: Mapping[str, Any] | None = None,
        *,
        agents: Mapping[int, Mapping[str, Any]] | None = None,
        searcher_time: float | None = None,
    ) -> EpisodeResult:
        """The metrics (and recording) of the finished episode.

        Parameters
        ----------
        extra : mapping, optional
            Extra columns (e.g. a searcher's :meth:`~odorloc.searchers.base.Searcher.
            final_metrics`), added beside the episode's core columns; one named like a core
            column is refused (:class:`~odorloc.engine.metrics.MetricsError`).
        agents : mapping, optional
            Per-agent values (a searcher's :meth:`~odorloc.searchers.base.Searcher.
            agent_metrics`).
        searcher_time : float, optional
            Seconds the searcher spent choosing actions; adds the core column
            ``searcher_fraction`` (its share of the wall time).
        """
        if not self._done:
            raise RuntimeError("the episode is not over yet")
        b = self.built
        wall = time.perf_counter() - self._wall0
        step = self._step
        metrics: dict[str, Any] = {
            "termination": self._termination,
            "declared": bool(self._declarations),
            "search_time": float(self._t),
            "steps": step,
            "path_length": float(sum(pl.path_length for pl in b.platforms)),
            "first_detection_time": float(self._first_detection),
            "energy": float(sum(pl.energy for pl in b.platforms)),
            "bytes": int(self._bytes),
            "start_distance": float(
                np.min(np.linalg.norm(self._starts[:, None, :] - self.sources[None], axis=2))
            ),
            "wall_time": wall,
            "wall_per_step_ms": 1e3 * wall / max(step, 1),
            "world_fraction": self._world_time / wall if wall > 0 else math.nan,
        }
        declared = (
            np.vstack([np.atleast_2d(d.positions) for d in self._declarations])
            if self._declarations
            else None
        )
        radius = self.scenario.task.success_radius
        if declared is not None:
            ok, err, found, false = score_declaration(declared, self.sources, radius)
            metrics.update(success=ok, loc_error=err, sources_found=found, false_sources=false)
        else:
            metrics.update(success=False, loc_error=math.nan, sources_found=0, false_sources=0)
        if self.scenario.task.end == "reach":
            metrics["success"] = not math.isnan(self._reach_time)
        if self.scenario.task.reach_radius is not None:
            metrics["reach_time"] = float(self._reach_time)
            metrics["reach_agent"] = int(self._reach_agent)
            for key in b.platforms[0].stats:
                metrics[f"reach_{key}"] = float(self._reach_stats.get(key, math.nan))
        metrics["declarations"] = len(self._declarations)
        for s, ft in enumerate(self._found_time):
            metrics[f"found_time_{s}"] = float(ft)
        breakdown: dict[str, float] = {}
        for pl in b.platforms:
            for key, v in pl.energy_breakdown().items():
                breakdown[key] = breakdown.get(key, 0.0) + float(v)
        for key, v in breakdown.items():
            metrics[f"energy_{key}"] = v
        totals: dict[str, float] = {}
        for pl in b.platforms:
            for key, v in pl.stats.items():
                totals[key] = totals.get(key, 0.0) + float(v)
        for key, v in totals.items():
            metrics[f"team_{key}"] = v
        if searcher_time is not None:
            metrics["searcher_fraction"] = searcher_time / wall if wall > 0 else math.nan
        record = EpisodeMetrics(metrics, extra, agents)
        recording = None
        if self._rec is not None:
            decl = Declaration(declared) if declared is not None else None
            meta = record.row()
            if record.agents:
                meta["agent_metrics"] = {str(a): v for a, v in record.agents.items()}
            recording = self._rec.finish(meta, decl, [e.as_dict() for e in self._events])
        return EpisodeResult(
            record, recording, list(self._declarations), self.sources, list(self._events)
        )


def first_within(
    positions: np.ndarray, sources: list[list[float]], radius: float
) -> tuple[int, int] | None:
    """The first ``(agent, source)`` pair, in agent-major order, within ``radius`` (metres).

    Distances in Python floats, summed over the axes in order (as ``numpy.linalg.norm`` of the
    difference sums them): checked every step, where array calls on a few numbers cost more
    than the arithmetic.

    Parameters
    ----------
    positions : (n, d) ndarray, metres
        Agent positions.
    sources : list of list of float
        Source positions, one row each (as ``ndarray.tolist()`` gives them).
    radius : float, metres
    """
    for k, p in enumerate(positions.tolist()):
        for j, s in enumerate(sources):
            acc = 0.0
            for a, b in zip(p, s, strict=True):
                acc += (a - b) * (a - b)
            if math.sqrt(acc) <= radius:
                return k, j
    return None


def run_episode(
    scenario: Scenario,
    world_seed: int,
    agent_seed: int,
    *,
    record: bool | None = None,
    built: Built | None = None,
    searcher: Searcher | None = None,
    fused: bool = True,
) -> EpisodeResult:
    """Run one episode of ``scenario`` with its searcher and return its metrics (and recording).

    Parameters
    ----------
    scenario : Scenario
    world_seed, agent_seed : int
        Seeds of the world (wind, plume, sensors) and of the searcher.
    record : bool, optional
        Keep a :class:`Recording`; defaults to ``scenario.recording.enabled``.
    built : Built, optional
        Pre-built components (fresh ones are built when omitted).
    searcher : Searcher, optional
        Use this searcher instead of the scenario's.
    fused : bool
        Without a recording, play a whole episode of a searcher that has a compiled episode
        (``lattice-infotaxis`` on the lattice problem: :mod:`odorloc.engine.lattice_fused`) in
        one call; the same episode as the loop below, whose measured times alone differ.
    """
    keep = scenario.recording.enabled if record is None else bool(record)
    if fused and not keep:
        from odorloc.engine.lattice_fused import run_fused

        given = searcher if searcher is not None else built.searcher if built is not None else None
        parts = run_fused(scenario, given, world_seed, agent_seed)
        if parts is not None:
            metrics, extra, agents, sources, events = parts
            return EpisodeResult(EpisodeMetrics(metrics, extra, agents), None, [], sources, events)
    ep = Episode(scenario, built=built, record=record)
    agent = searcher if searcher is not None else ep.built.searcher
    obs = ep.reset(world_seed, agent_seed)
    rng = ep.agent_rng
    agent.reset(ep.context, rng)
    searcher_time = 0.0
    while not ep.done:
        ts = time.perf_counter()
        action = agent.act(obs, rng)
        searcher_time += time.perf_counter() - ts
        obs = ep.step(action, agent).observations
    return ep.result(
        agent.final_metrics(), agents=agent.agent_metrics(), searcher_time=searcher_time
    )
