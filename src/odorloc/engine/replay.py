"""Record a flow once, replay it to many searchers (common random numbers on one recorded flow).

The D-S mapping paper compares its exploration methods on one recorded plume "movie"; the
virtual-physics and multi-UAV reproductions do the same. :func:`record_flow` records the wind and
plume an episode of a scenario would see with a world seed (after the same warm-up,
:func:`~odorloc.engine.episode.prepare_world`), one frame per control period;
:func:`on_replay` gives the scenario and components that run any searcher on that movie. The
sensors keep the episode's sensor stream, so a replayed episode differs from a live one only in
the plume and wind being played back frame by frame.
"""

from __future__ import annotations

from typing import Any

from odorloc.engine.episode import control_substeps, prepare_world
from odorloc.plume.replay import Movie
from odorloc.scenarios.build import Built, build
from odorloc.scenarios.config import Scenario
from odorloc.world.world import World

__all__ = ["on_replay", "record_flow"]


def record_flow(scenario: Scenario, world_seed: int, duration: float | None = None) -> Movie:
    """The flow an episode of ``scenario`` with ``world_seed`` would see, as a movie.

    Parameters
    ----------
    scenario : Scenario
    world_seed : int
    duration : float, optional
        Seconds recorded after the warm-up (default the time limit); one frame per control
        period. The wind is sampled on the Farrell node grid of the scenario's wind when it has
        one (``nodes``; in 3-D on two layers, the field being the same at every height), else on
        15 nodes per horizontal axis (5 vertically).
    """
    world, rng_world, _ = prepare_world(scenario, world_seed)
    T, _, wdt = control_substeps(scenario)
    nodes: Any = scenario.world.wind.values.get("nodes")
    shape = tuple(int(n) for n in nodes) if nodes is not None else None
    if shape is not None and len(shape) == len(scenario.world.arena.lower) - 1:
        # a horizontal node grid in 3-D (the layered Farrell field): two layers hold it
        shape = (*shape, 2)
    return world.record(
        float(duration if duration is not None else scenario.limits.time),
        T,
        rng_world,
        dt=wdt,
        wind_shape=shape,
    )


def on_replay(scenario: Scenario, movie: Movie) -> tuple[Scenario, Built]:
    """``(scenario, built)`` running ``scenario`` on the replay of ``movie``.

    The returned scenario names the replayed wind and plume and has no warm-up (the movie starts
    where the recorded warm-up ended); the built components are the scenario's own sensors,
    platforms and searcher in a :meth:`~odorloc.world.world.World.replay` world.
    """
    data = scenario.to_dict()
    data["world"]["warmup"] = 0.0
    data["world"]["wind"] = {"type": "replay"}
    data["world"]["plume"] = {"type": "replay"}
    replayed = Scenario.from_dict(data)
    world = World.replay(movie, list(scenario.world.sources))
    return replayed, build(scenario, world=world)
