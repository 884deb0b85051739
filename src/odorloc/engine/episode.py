"""The episode engine: sense -> decide -> move -> world step, with recording and metrics.

Randomness: an episode takes two integer seeds. ``world_seed`` drives the wind, the plume and the
sensor noise; ``agent_seed`` drives the searcher. Two searchers run with the same ``world_seed``
therefore face the same plume realisation (common random numbers) as long as the world does not
depend on what the agents do, which holds for every plume model here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from odorloc.engine.recorder import Recorder, Recording
from odorloc.platforms.team import CommGraph
from odorloc.scenarios.build import Built, build
from odorloc.scenarios.config import Scenario
from odorloc.searchers.base import Action, Declaration, Message, Observation, SearchContext


def episode_generators(
    world_seed: int, agent_seed: int
) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """Independent generators for (world, sensors, searcher) from the two episode seeds."""
    w_ss, s_ss = np.random.SeedSequence(world_seed).spawn(2)
    a_ss = np.random.SeedSequence(agent_seed)
    return (
        np.random.Generator(np.random.PCG64(w_ss)),
        np.random.Generator(np.random.PCG64(s_ss)),
        np.random.Generator(np.random.PCG64(a_ss)),
    )


def seeds_for(root: int, episode: int) -> tuple[int, int]:
    """(world_seed, agent_seed) of episode ``episode`` under root seed ``root``."""
    ss = np.random.SeedSequence([int(root), int(episode)])
    w, a = ss.spawn(2)
    return int(w.generate_state(1, np.uint64)[0]), int(a.generate_state(1, np.uint64)[0])


@dataclass
class EpisodeResult:
    """Outcome of one episode: a flat metrics row and (optionally) the recording."""

    metrics: dict[str, Any]
    recording: Recording | None = None
    declaration: Declaration | None = None
    sources: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


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


def run_episode(
    scenario: Scenario,
    world_seed: int,
    agent_seed: int,
    *,
    record: bool | None = None,
    built: Built | None = None,
) -> EpisodeResult:
    """Run one episode of ``scenario`` and return its metrics (and recording).

    Parameters
    ----------
    scenario : Scenario
    world_seed, agent_seed : int
        Seeds of the world (wind, plume, sensors) and of the searcher.
    record : bool, optional
        Keep a :class:`Recording`; defaults to ``scenario.recording.enabled``.
    built : Built, optional
        Pre-built components (fresh ones are built when omitted).
    """
    wall0 = time.perf_counter()
    b = built or build(scenario)
    world = b.world
    arena = world.arena
    rng_world, rng_sense, rng_agent = episode_generators(world_seed, agent_seed)
    lim = scenario.limits
    T = lim.control_dt
    n_sub = max(1, round(T / scenario.world.dt))
    wdt = T / n_sub
    n_agents = len(scenario.agents.starts)
    sources = world.sources
    starts = np.asarray(scenario.agents.starts, float)

    world.reset(rng_world)
    n_warm = round(scenario.world.warmup / wdt)
    for _ in range(n_warm):
        world.step(wdt, rng_world)

    for k, pl in enumerate(b.platforms):
        pl.reset(starts[k], scenario.agents.heading)
    for s in (*b.gas_sensors, *b.anemometers):
        s.reset(rng_sense)
    gas_params = b.gas_sensors[0].params
    ctx = SearchContext(
        arena=arena,
        dt=T,
        n_agents=n_agents,
        start=starts.copy(),
        max_speed=float(b.platforms[0].speed_limit),
        gas_threshold=float(getattr(gas_params, "threshold", 0.0)),
        info=dict(scenario.info),
    )
    b.searcher.reset(ctx, rng_agent)
    comm = CommGraph(scenario.agents.comm_radius)
    inbox: list[tuple[Message, ...]] = [() for _ in range(n_agents)]
    do_record = scenario.recording.enabled if record is None else record
    rec = Recorder(scenario, arena, sources) if do_record else None

    n_steps = math.floor(lim.time / T + 1e-9)
    first_detection = math.nan
    declaration: Declaration | None = None
    termination = "time_limit"
    searcher_time = 0.0
    world_time = 0.0
    bytes_total = 0
    step = 0
    for step in range(n_steps + 1):
        # Exact step arithmetic: summing dt would drift (9.999999 s instead of 10 s).
        t = step * T
        obs = []
        for k, pl in enumerate(b.platforms):
            reading = b.gas_sensors[k].measure(world.plume, pl.position, T, rng_sense)
            wind = b.anemometers[k].measure(world.wind, pl.position, pl.velocity, T, rng_sense)
            obs.append(
                Observation(
                    agent=k,
                    t=t,
                    position=pl.position.copy(),
                    heading=float(pl.heading),
                    gas=float(reading.value),
                    detection=bool(reading.detection),
                    wind=np.asarray(wind, float),
                    ready=bool(pl.ready),
                    messages=inbox[k],
                    energy=float(pl.energy),
                )
            )
            if reading.detection and math.isnan(first_detection):
                first_detection = t
        ts = time.perf_counter()
        action: Action = b.searcher.act(obs, rng_agent)
        searcher_time += time.perf_counter() - ts
        if len(action.commands) != n_agents:
            raise RuntimeError(
                f"searcher returned {len(action.commands)} commands for {n_agents} agents"
            )
        if rec is not None:
            rec.record(step, t, obs, b.platforms, b.searcher, world)
        if action.declaration is not None:
            declaration = action.declaration
            termination = "declared"
            break
        if step == n_steps:
            break
        if any(getattr(pl, "exhausted", False) for pl in b.platforms):
            termination = "energy"
            break
        # Messages broadcast now are received at the next step.
        positions = np.array([pl.position for pl in b.platforms])
        inbox, sent = comm.deliver(positions, action.messages)
        bytes_total += sent
        for k, pl in enumerate(b.platforms):
            if hasattr(pl, "add_comm_energy"):
                pl.add_comm_energy(comm.bytes_sent_by(k, positions, action.messages))
            pl.apply(action.commands[k], T, arena)
        tw = time.perf_counter()
        for _ in range(n_sub):
            world.step(wdt, rng_world)
        world_time += time.perf_counter() - tw
        if sum(pl.energy for pl in b.platforms) > lim.energy:
            termination = "energy"
            break

    t_end = step * T
    wall = time.perf_counter() - wall0
    metrics: dict[str, Any] = {
        "termination": termination,
        "declared": declaration is not None,
        "search_time": float(t_end),
        "steps": step,
        "path_length": float(sum(pl.path_length for pl in b.platforms)),
        "first_detection_time": float(first_detection),
        "energy": float(sum(pl.energy for pl in b.platforms)),
        "bytes": int(bytes_total),
        "start_distance": float(
            np.min(np.linalg.norm(starts[:, None, :] - sources[None, :, :], axis=2))
        ),
        "wall_time": wall,
        "wall_per_step_ms": 1e3 * wall / max(step, 1),
        "searcher_fraction": searcher_time / wall if wall > 0 else math.nan,
        "world_fraction": world_time / wall if wall > 0 else math.nan,
    }
    if declaration is not None:
        ok, err, found, false = score_declaration(
            declaration.positions, sources, scenario.success_radius
        )
        metrics.update(success=ok, loc_error=err, sources_found=found, false_sources=false)
    else:
        metrics.update(success=False, loc_error=math.nan, sources_found=0, false_sources=0)
    metrics.update(b.searcher.final_metrics() if hasattr(b.searcher, "final_metrics") else {})
    recording = rec.finish(metrics, declaration) if rec is not None else None
    return EpisodeResult(metrics, recording, declaration, sources)
