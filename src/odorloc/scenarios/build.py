"""Turn a validated :class:`Scenario` into live components."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odorloc import registry
from odorloc.errors import ConfigError
from odorloc.scenarios.config import ArenaConfig, Scenario
from odorloc.world.arena import Arena
from odorloc.world.world import World


def build_arena(cfg: ArenaConfig) -> Arena:
    """The arena with its obstacles (boxes, polygons, then an occupancy file)."""
    arena = Arena(tuple(cfg.lower), tuple(cfg.upper), cfg.resolution)
    obs = cfg.obstacles
    if obs.file:
        path = Path(obs.file)
        if not path.exists():
            raise ConfigError("world.arena.obstacles.file", f"{path} does not exist")
        loader = Arena.from_csv if path.suffix.lower() == ".csv" else Arena.from_image
        grid = loader(path, cfg.resolution, cfg.lower)
        if grid.grid_shape != arena.grid_shape:
            raise ConfigError(
                "world.arena.obstacles.file",
                f"grid {grid.grid_shape} does not match the arena's {arena.grid_shape}",
            )
        arena = grid
    if obs.boxes:
        arena = arena.with_boxes(obs.boxes)
    if obs.polygons:
        arena = arena.with_polygons(obs.polygons)
    return arena


_TOP_LEVEL = ("world.", "sensors.", "platform.", "agents.", "searcher.", "limits.")


def _prefixed(field: str, fn: Any, *args: Any, **kwargs: Any) -> Any:
    try:
        return fn(*args, **kwargs)
    except ConfigError as exc:
        inner = exc.field
        # Components name fields relative to themselves ("sigma0"); errors that already carry
        # a scenario path ("world.sources[0]...") are kept as they are.
        if not inner.startswith(_TOP_LEVEL):
            inner = f"{field}.{inner}"
        raise ConfigError(inner, exc.problem) from None


def build_world(sc: Scenario) -> World:
    """Arena, wind and plume of a scenario (not yet reset)."""
    arena = _prefixed("world.arena", build_arena, sc.world.arena)
    wp = sc.world.wind.params("wind", "world.wind")
    wind = _prefixed("world.wind", registry.entry("wind", sc.world.wind.type).build, wp, arena)
    pp = sc.world.plume.params("plume", "world.plume")
    plume = _prefixed(
        "world.plume",
        registry.entry("plume", sc.world.plume.type).build,
        pp,
        arena,
        wind,
        tuple(sc.world.sources),
    )
    return World(arena, wind, plume)


@dataclass(eq=False)
class Built:
    """Everything an episode needs, freshly constructed."""

    scenario: Scenario
    world: World
    gas_sensors: list[Any]
    anemometers: list[Any]
    platforms: list[Any]
    searcher: Any


def build(sc: Scenario) -> Built:
    """Construct the world, one sensor pair and platform per agent, and the searcher."""
    world = build_world(sc)
    n = len(sc.agents.starts)
    starts = np.asarray(sc.agents.starts, float)
    for k, s in enumerate(starts):
        if not world.arena.is_free(s)[0]:
            raise ConfigError(f"agents.starts[{k}]", f"{tuple(s)} is outside the arena or blocked")
    gp = sc.sensors.gas.params("gas_sensor", "sensors.gas")
    ap = sc.sensors.anemometer.params("anemometer", "sensors.anemometer")
    gas_cls = registry.entry("gas_sensor", sc.sensors.gas.type).build
    an_cls = registry.entry("anemometer", sc.sensors.anemometer.type).build
    pl_cls = registry.entry("platform", sc.platform.type).build
    plp = sc.platform.params("platform", "platform")
    se = registry.entry("searcher", sc.searcher.type)
    sp = sc.searcher.params("searcher", "searcher")
    return Built(
        scenario=sc,
        world=world,
        gas_sensors=[_prefixed("sensors.gas", gas_cls, gp) for _ in range(n)],
        anemometers=[_prefixed("sensors.anemometer", an_cls, ap) for _ in range(n)],
        platforms=[_prefixed("platform", pl_cls, plp) for _ in range(n)],
        searcher=_prefixed("searcher", se.build, sp),
    )
