"""Turn a validated :class:`Scenario` into live components."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core import registry
from odorloc.core.errors import ConfigError, join_field
from odorloc.core.types import Group, SearchContext
from odorloc.geometry.arena import Arena
from odorloc.platforms.base import Platform
from odorloc.scenarios.config import ArenaConfig, Scenario
from odorloc.searchers.base import Searcher
from odorloc.sensors.anemometer import Anemometer
from odorloc.sensors.base import GasSensor
from odorloc.world.world import World


def build_arena(cfg: ArenaConfig) -> Arena:
    """The arena with its obstacles (boxes, polygons, then an occupancy file)."""
    arena = Arena(tuple(cfg.lower), tuple(cfg.upper), cfg.resolution)
    obs = cfg.obstacles
    if obs.file:
        path = Path(obs.file)
        if not path.is_file():
            what = "is a folder, not a file" if path.is_dir() else "does not exist"
            raise ConfigError("world.arena.obstacles.file", f"{path} {what}")
        loader = Arena.from_csv if path.suffix.lower() == ".csv" else Arena.from_image
        try:
            grid = loader(path, cfg.resolution, cfg.lower)
        except ConfigError as exc:
            raise ConfigError("world.arena.obstacles.file", exc.problem) from None
        if grid.grid_shape != arena.grid_shape:
            raise ConfigError(
                "world.arena.obstacles.file",
                f"grid {grid.grid_shape} does not match the arena's {arena.grid_shape}",
            )
        arena = grid
    try:
        if obs.boxes:
            arena = arena.with_boxes(obs.boxes)
        if obs.polygons:
            arena = arena.with_polygons(obs.polygons)
    except ConfigError as exc:
        raise ConfigError(f"world.arena.{exc.field}", exc.problem) from None
    return arena


_TOP_LEVEL = ("world.", "sensors.", "platform.", "agents.", "searcher.", "limits.")


def prefixed(field: str, fn: Any, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)``, its :class:`ConfigError` named under ``field`` (a component's
    own field names are relative to it)."""
    try:
        return fn(*args, **kwargs)
    except ConfigError as exc:
        inner = exc.field
        # Components name fields relative to themselves ("sigma0"); errors that already carry
        # a scenario path ("world.sources[0]...") are kept as they are.
        if not inner.startswith(_TOP_LEVEL):
            inner = join_field(field, inner)
        raise ConfigError(inner, exc.problem) from None


def build_world(sc: Scenario) -> World:
    """Arena, wind and plume of a scenario (not yet reset)."""
    arena = prefixed("world.arena", build_arena, sc.world.arena)
    wp = sc.world.wind.params("wind", "world.wind")
    wind = prefixed("world.wind", registry.entry("wind", sc.world.wind.type).build, wp, arena)
    pp = sc.world.plume.params("plume", "world.plume")
    plume = prefixed(
        "world.plume",
        registry.entry("plume", sc.world.plume.type).build,
        pp,
        arena,
        wind,
        tuple(sc.world.sources),
    )
    # what the world step rules out (a filament release too large for one step) is refused
    # here, with the scenario, rather than at the first step of the first episode
    prefixed("world.plume", plume.check_step, sc.world.dt)
    return World(arena, wind, plume)


@dataclass(eq=False)
class Built:
    """Everything an episode needs, freshly constructed."""

    scenario: Scenario
    world: World
    gas_sensors: list[GasSensor]
    anemometers: list[Anemometer]
    platforms: list[Platform]
    searcher: Searcher


def _check_searcher(sc: Scenario, searcher: Searcher) -> None:
    n = len(sc.agents.starts)
    d = len(sc.world.arena.lower)
    cls = type(searcher)
    if d not in cls.dims:
        raise ConfigError("searcher.type", f"{sc.searcher.type!r} works in {cls.dims}D, not {d}D")
    if n < cls.min_agents:
        raise ConfigError(
            "agents.starts",
            f"{sc.searcher.type!r} needs at least {cls.min_agents} agents, the scenario has {n}",
        )
    if cls.max_agents is not None and n > cls.max_agents:
        raise ConfigError(
            "searcher.type",
            f"{sc.searcher.type!r} drives at most {cls.max_agents} agent(s) but the scenario has "
            f"{n}; run it in a team (type: per-agent, member: {{type: {sc.searcher.type}}})",
        )


def build_searcher(sc: Scenario) -> Searcher:
    """The scenario's searcher, checked against its dimension and team size."""
    se = registry.entry("searcher", sc.searcher.type)
    sp = sc.searcher.params("searcher", "searcher")
    searcher = prefixed("searcher", se.build, sp)
    _check_searcher(sc, searcher)
    return searcher


def build(sc: Scenario, world: World | None = None) -> Built:
    """Construct the world (unless given), one sensor pair and platform per agent, and the
    searcher."""
    world = world if world is not None else build_world(sc)
    n = len(sc.agents.starts)
    starts = np.asarray(sc.agents.starts, float)
    for k, s in enumerate(starts):
        if not world.arena.is_free(s)[0]:
            raise ConfigError(f"agents.starts[{k}]", f"{_where(s)} is outside the arena or blocked")
    gp = sc.sensors.gas.params("gas_sensor", "sensors.gas")
    ap = sc.sensors.anemometer.params("anemometer", "sensors.anemometer")
    gas_cls = registry.entry("gas_sensor", sc.sensors.gas.type).build
    an_cls = registry.entry("anemometer", sc.sensors.anemometer.type).build
    pl_cls = registry.entry("platform", sc.platform.type).build
    plp = sc.platform.params("platform", "platform")
    searcher = build_searcher(sc)
    platforms = [prefixed("platform", pl_cls, plp) for _ in range(n)]
    radii = np.array([float(pl.radius) for pl in platforms])
    _check_clearance(world.arena, starts, radii)
    _check_bodies(starts, radii)
    _check_not_reached(sc, world, starts)
    return Built(
        scenario=sc,
        world=world,
        gas_sensors=[prefixed("sensors.gas", gas_cls, gp) for _ in range(n)],
        anemometers=[prefixed("sensors.anemometer", an_cls, ap) for _ in range(n)],
        platforms=platforms,
        searcher=searcher,
    )


def _check_not_reached(sc: Scenario, world: World, starts: np.ndarray) -> None:
    """Refuse a start that already reaches a configured source where reaching ends the
    episode: it would end, a success, before its first step. Sources drawn per episode keep
    their own distance rules (``world.source_draw``, the lattice problem's first hit)."""
    reach = sc.task.reach_radius
    if sc.task.end != "reach" or reach is None:
        return
    if sc.world.source_draw is not None or world.plume.draws_sources:
        return
    sources = world.plume.source_positions
    for k, s in enumerate(starts):
        d = np.linalg.norm(sources - s, axis=1)
        j = int(np.argmin(d))
        if d[j] <= reach:
            # named like the environments' check of an episode over at reset
            raise ConfigError(
                "task.reach_radius",
                f"agents.starts[{k}] {_where(s)} is {d[j]:.3g} m from world.sources[{j}], "
                f"within this radius ({reach:g} m): the episode would end before its first step",
            )


def _where(point: np.ndarray) -> str:
    """A point as ``(x, y[, z])`` for an error message (plain numbers, metres)."""
    return "(" + ", ".join(f"{float(x):g}" for x in point) + ")"


def _check_clearance(arena: Arena, starts: np.ndarray, radii: np.ndarray) -> None:
    """Refuse start positions where a body (``radius > 0``) reaches past the arena's bounds or
    into an obstacle: the robot would start inside a wall.

    Parameters
    ----------
    arena : Arena
    starts : (N, d) ndarray, metres
        Body centres (each already a free point).
    radii : (N,) ndarray, metres
    """
    for k in np.flatnonzero(radii > 0):
        s, r = starts[k], float(radii[k])
        margin = float(arena.distance_to_bounds(s)[0])
        # touching the edge is fine, also when decimal coordinates round it a hair short
        if margin < r - 1e-9 * arena.resolution:
            raise ConfigError(
                f"agents.starts[{k}]",
                f"{_where(s)} is {margin:.3g} m from the arena's edge: the body (radius {r:g} m) "
                "reaches past it",
            )
        if not arena.body_free(s, r)[0]:
            raise ConfigError(
                f"agents.starts[{k}]",
                f"{_where(s)} is too close to an obstacle: the body (radius {r:g} m) overlaps it",
            )


def _check_bodies(starts: np.ndarray, radii: np.ndarray) -> None:
    """Refuse start positions where two bodies (``radius > 0``) overlap."""
    if len(starts) < 2 or not np.any(radii > 0):
        return
    d = np.linalg.norm(starts[:, None, :] - starts[None, :, :], axis=2)
    clash = np.argwhere(np.triu(d < radii[:, None] + radii[None, :], k=1))
    if len(clash):
        i, j = (int(v) for v in clash[0])
        raise ConfigError(
            f"agents.starts[{j}]",
            f"{tuple(starts[j])} is {d[i, j]:.3g} m from agent {i}: the bodies (radius "
            f"{radii[j]:g} m) overlap",
        )


def search_context(sc: Scenario, built: Built) -> SearchContext:
    """The typed :class:`SearchContext` of a scenario: what its searcher may know."""
    n = len(sc.agents.starts)
    starts = np.asarray(sc.agents.starts, float)
    groups = tuple(
        Group(k, g.name or f"group{k}", tuple(int(a) for a in g.agents))
        for k, g in enumerate(sc.agents.groups)
    )
    d = starts.shape[1]
    return SearchContext(
        arena=built.world.arena,
        dt=sc.limits.control_dt,
        agent_ids=tuple(range(n)),
        start=starts.copy(),
        speed_limits=np.array([float(pl.speed_limit) for pl in built.platforms]),
        sensor=built.gas_sensors[0].info,
        groups=groups,
        start_sets={k: np.asarray(v, float) for k, v in sc.agents.start_sets.items()},
        start_points=np.asarray(sc.agents.start_points, float).reshape(-1, d),
        search_region=sc.task.region,
        comm_radius=float(sc.agents.comm_radius),
        n_agents_total=n,
    )
