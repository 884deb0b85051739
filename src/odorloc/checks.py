"""Contract checkers for every component family, shipped as API.

Anyone adding a wind, plume, sensor, platform, searcher or gas map can check it the way
odorloc's own tests do::

    from odorloc import checks
    checks.check_searcher("my-searcher")            # 2-D and 3-D, one and three agents
    checks.check_plume("my-plume", {"rate_scale": 2.0})

Each checker builds the component by its registry name (with ``params``, default its defaults)
in small worlds, exercises it and raises :class:`ContractError` naming what is wrong: shapes,
finiteness, determinism per seed, staying inside the arena, the declaration format, stable
``final_metrics`` keys. They return a short report of what was checked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from odorloc.core import registry
from odorloc.core.types import Command, SensorInfo
from odorloc.engine.episode import Episode, EpisodeResult, run_episode
from odorloc.geometry.arena import Arena
from odorloc.plume.sources import Source
from odorloc.scenarios.config import Scenario
from odorloc.world.world import World

__all__ = [
    "ContractError",
    "check_gas_map",
    "check_platform",
    "check_plume",
    "check_searcher",
    "check_sensor",
    "check_wind",
    "compare_runs",
    "small_scenario",
]


class ContractError(AssertionError):
    """A component breaks the contract of its family."""


def _require(ok: bool, what: str) -> None:
    if not ok:
        raise ContractError(what)


def _arena(dim: int) -> Arena:
    if dim == 2:
        return Arena.box((0.0, 0.0), (10.0, 6.0), 0.1)
    return Arena.box((0.0, 0.0, 0.0), (10.0, 6.0, 4.0), 0.25)


def _probe_points(dim: int, n: int = 25) -> np.ndarray:
    rng = np.random.default_rng(123)
    a = _arena(dim)
    return a.lo + rng.random((n, dim)) * a.size


def _world(
    dim: int, plume: str = "gaussian", plume_params: Mapping[str, Any] | None = None
) -> World:
    arena = _arena(dim)
    wv = (0.8, 0.1) if dim == 2 else (0.8, 0.1, 0.0)
    wind = registry.entry("wind", "uniform").build(
        registry.make_params("wind", "uniform", {"velocity": wv}), arena
    )
    src = [Source(position=(1.5, 3.0) if dim == 2 else (1.5, 3.0, 2.0), rate=10.0)]
    pp = registry.make_params("plume", plume, dict(plume_params or {}))
    return World(arena, wind, registry.entry("plume", plume).build(pp, arena, wind, src))


def _dims_of(cls: Any, dims: Sequence[int] | None) -> list[int]:
    supported = tuple(getattr(cls, "dims", (2, 3)))
    return [d for d in (dims or (2, 3)) if d in supported]


# ---------------------------------------------------------------------- wind
def check_wind(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] | None = None
) -> str:
    """Shapes, finiteness and determinism per seed of a wind model in 2-D and 3-D."""
    e = registry.entry("wind", name)
    p = registry.make_params("wind", name, dict(params or {}))
    done = []
    for dim in _dims_of(e.build, dims):
        pts = _probe_points(dim)

        def roll(seed: int, dim: int = dim, pts: np.ndarray = pts) -> np.ndarray:
            w = e.build(p, _arena(dim))
            rng = np.random.default_rng(seed)
            w.reset(rng)
            out = []
            for _ in range(10):
                w.step(0.25, rng)
                out.append(w.velocity(pts))
            return np.array(out)

        a, b = roll(5), roll(5)
        _require(a.shape == (10, len(pts), dim), f"wind {name} {dim}D: velocity shape {a.shape}")
        _require(bool(np.all(np.isfinite(a))), f"wind {name} {dim}D: non-finite velocity")
        _require(np.array_equal(a, b), f"wind {name} {dim}D: not deterministic per seed")
        done.append(f"{dim}D")
    return f"wind {name}: {', '.join(done)}"


# ---------------------------------------------------------------------- plume
def check_plume(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] | None = None
) -> str:
    """Concentration and encounter rate shapes, finiteness, non-negativity, determinism per
    seed and a faithful :meth:`frame` (a replay of a recorded movie gives the same field)."""
    e = registry.entry("plume", name)
    done = []
    for dim in _dims_of(e.build, dims):
        pts = _probe_points(dim)
        if name == "replay":
            live = _world(dim, "gaussian")
            movie = live.record(2.0, 0.5, np.random.default_rng(1), dt=0.25)
            world = World.replay(movie)
            world.reset(np.random.default_rng(0))
            c = world.plume.concentration(pts)
            live2 = _world(dim, "gaussian")
            live2.reset(np.random.default_rng(1))
            _require(
                np.allclose(c, live2.plume.concentration(pts)),
                f"plume replay {dim}D: the first frame differs from the recorded plume",
            )
            done.append(f"{dim}D")
            continue

        def roll(seed: int, dim: int = dim, pts: np.ndarray = pts) -> tuple[np.ndarray, Any]:
            w = _world(dim, name, params)
            rng = np.random.default_rng(seed)
            w.reset(rng)
            out = []
            for _ in range(8):
                w.step(0.25, rng)
                out.append(w.plume.concentration(pts))
            rate = w.plume.encounter_rate(pts)
            return np.array(out), (w, rate)

        a, (w, rate) = roll(3)
        b, _ = roll(3)
        tag = f"plume {name} {dim}D"
        _require(a.shape == (8, len(pts)), f"{tag}: concentration shape {a.shape}")
        _require(
            bool(np.all(np.isfinite(a)) and np.all(a >= 0)), f"{tag}: concentration < 0 or NaN"
        )
        _require(np.array_equal(a, b), f"{tag}: not deterministic per seed")
        _require(rate.shape == (len(pts),), f"{tag}: encounter_rate shape {rate.shape}")
        _require(
            bool(np.all(np.isfinite(rate)) and np.all(rate >= 0)), f"{tag}: bad encounter rate"
        )
        frame = w.plume.frame()
        _require("model" in frame, f"{tag}: frame() lacks 'model'")
        from odorloc.plume.replay import Movie

        probe = Movie(
            times=np.array([w.plume.t]),
            frames=[frame],
            wind_axes=[
                np.linspace(lo, hi, 3) for lo, hi in zip(w.arena.lower, w.arena.upper, strict=True)
            ],
            wind=np.zeros((1, *([3] * dim), dim)),
            arena_lower=w.arena.lo,
            arena_upper=w.arena.hi,
            resolution=w.arena.resolution,
            source_positions=w.plume.source_positions,
            source_rates=np.ones(len(w.plume.sources)),
        )
        _require(
            np.allclose(probe.concentration(0, pts), w.plume.concentration(pts)),
            f"{tag}: frame() does not reproduce the concentration",
        )
        done.append(f"{dim}D")
    return f"plume {name}: {', '.join(done)}"


# ---------------------------------------------------------------------- sensors
def check_sensor(name: str, params: Mapping[str, Any] | None = None) -> str:
    """A gas sensor: finite readings, a detection consistent with the threshold it states,
    determinism per seed.

    The sensor is carried along the plume's axis from clean air upwind of the source, past the
    source and downwind, so that its readings fall on both sides of its threshold; a sensor
    whose readings there are all detections, or none, fails (with its parameters the threshold
    could not be checked): give ``params`` that place the threshold inside the readings.
    """
    e = registry.entry("gas_sensor", name)
    p = registry.make_params("gas_sensor", name, dict(params or {}))
    # two points upwind of the source (x = 1.5) read nothing; 5 cm downwind of it the gaussian
    # world gives about 120 concentration units, falling to about 1.3 at x = 9
    xs = np.concatenate(([0.5, 1.0], np.linspace(1.55, 9.0, 20)))

    def roll(seed: int) -> list[Any]:
        w = _world(2, "gaussian")
        s = e.build(p)
        rng = np.random.default_rng(seed)
        w.reset(rng)
        s.reset(rng)
        out = []
        for x in xs:
            out.append(s.measure(w.plume, np.array([x, 3.0]), 0.5, rng))
        return out

    a, b = roll(9), roll(9)
    s = e.build(p)
    info = s.info
    _require(isinstance(info, SensorInfo), f"sensor {name}: info is not a SensorInfo")
    _require(math.isfinite(info.threshold), f"sensor {name}: threshold not finite")
    for r in a:
        _require(math.isfinite(r.value) and math.isfinite(r.raw), f"sensor {name}: bad reading")
        if not info.binary:
            _require(
                r.detection == (r.value >= info.threshold),
                f"sensor {name}: detection disagrees with its stated threshold",
            )
    detections = sum(bool(r.detection) for r in a)
    _require(
        0 < detections < len(a),
        f"sensor {name}: {detections} of {len(a)} probe readings are detections (threshold "
        f"{info.threshold:g} {info.unit}); the check needs readings on both sides of the "
        "threshold: give parameters that detect near the source and not in clean air",
    )
    _require(
        [(r.value, r.detection) for r in a] == [(r.value, r.detection) for r in b],
        f"sensor {name}: not deterministic per seed",
    )
    return f"gas sensor {name}: {detections} of {len(a)} readings detected"


# ---------------------------------------------------------------------- platforms
def check_platform(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] | None = None
) -> str:
    """A platform: every command kind keeps it inside free space, the path length and energy
    never decrease, ``ready`` after reaching a waypoint, hooks return energies >= 0."""
    e = registry.entry("platform", name)
    p = registry.make_params("platform", name, dict(params or {}))
    done = []
    for dim in _dims_of(e.build, dims):
        arena = _arena(dim)
        pl = e.build(p)
        start = arena.lo + 0.5 * arena.size
        pl.reset(start, 0.3)
        tag = f"platform {name} {dim}D"
        unit = np.zeros(dim)
        unit[0] = 1.0
        cmds = [
            Command.velocity(unit * 100.0),
            None,
            Command.move(-unit * 1.0),
            Command.waypoint(start + 0.5 * unit),
            Command.hold(),
            Command.velocity(-unit * 100.0),
        ]
        last_path, last_energy = 0.0, 0.0
        for c in cmds * 6:
            pl.apply(c, 0.5, arena)
            pos = pl.position
            _require(bool(arena.is_free(pos)[0]), f"{tag}: left free space at {pos}")
            _require(pl.path_length >= last_path - 1e-12, f"{tag}: path length decreased")
            _require(pl.energy >= last_energy - 1e-9, f"{tag}: energy decreased")
            last_path, last_energy = pl.path_length, pl.energy
        for _ in range(200):
            pl.apply(Command.waypoint(start), 0.5, arena)
            if pl.ready:
                break
        _require(pl.ready, f"{tag}: never ready after a waypoint in free space")
        _require(pl.charge_comm(100) >= 0 and pl.charge_compute(1000) >= 0, f"{tag}: negative J")
        _require(pl.speed_limit > 0, f"{tag}: speed limit must be > 0")
        done.append(f"{dim}D")
    return f"platform {name}: {', '.join(done)}"


# ---------------------------------------------------------------------- searchers
def small_scenario(
    searcher: Mapping[str, Any],
    dim: int = 2,
    n_agents: int = 1,
    time: float = 20.0,
    plume: str = "filament",
) -> Scenario:
    """A small scenario for contract runs: a 10 m x 6 m (x 4 m) box, a uniform wind, one source,
    ``n_agents`` agents downwind, a task region."""
    if dim == 2:
        lower, upper = [0.0, 0.0], [10.0, 6.0]
        src = [1.5, 3.0]
        starts = [[8.0, 2.0 + 1.0 * k] for k in range(n_agents)]
        wind = [0.6, 0.0]
        region = [[0.5, 0.5], [9.5, 5.5]]
    else:
        lower, upper = [0.0, 0.0, 0.0], [10.0, 6.0, 4.0]
        src = [1.5, 3.0, 2.0]
        starts = [[8.0, 2.0 + 1.0 * k, 2.0] for k in range(n_agents)]
        wind = [0.6, 0.0, 0.0]
        region = [[0.5, 0.5], [9.5, 5.5]]
    plume_cfg: dict[str, Any] = {"type": plume}
    data = {
        "name": f"contract-{dim}d-{n_agents}",
        "world": {
            "arena": {"lower": lower, "upper": upper, "resolution": 0.1 if dim == 2 else 0.25},
            "sources": [{"position": src, "rate": 20.0}],
            "wind": {"type": "uniform", "velocity": wind},
            "plume": plume_cfg,
            "dt": 0.1,
            "warmup": 5.0,
        },
        "sensors": {"gas": {"type": "concentration", "threshold": 0.5}},
        "platform": {"type": "holonomic", "max_speed": 0.5},
        "agents": {
            "starts": starts,
            "comm_radius": 5.0,
            "groups": [{"name": "all", "agents": list(range(n_agents))}],
        },
        "searcher": dict(searcher),
        "task": {"region": region, "success_radius": 0.5},
        "limits": {"control_dt": 0.5, "time": time},
        "recording": {"plume_stride": 20, "belief_stride": 4},
    }
    return Scenario.from_dict(data)


def compare_runs(a: EpisodeResult, b: EpisodeResult, tag: str) -> None:
    """Two runs of the same seeds must give the same trajectories and metrics."""
    ra, rb = a.recording, b.recording
    assert ra is not None and rb is not None
    _require(np.array_equal(ra.positions, rb.positions), f"{tag}: trajectories differ per seed")
    skip = {"wall_time", "wall_per_step_ms", "searcher_fraction", "world_fraction"}
    for k, v in a.metrics.items():
        if k in skip:
            continue
        w = b.metrics.get(k)
        same = v == w or (
            isinstance(v, float) and isinstance(w, float) and math.isnan(v) and math.isnan(w)
        )
        _require(same, f"{tag}: metric {k} differs per seed ({v} vs {w})")


def check_searcher(
    name: str,
    params: Mapping[str, Any] | None = None,
    dims: Sequence[int] | None = None,
    agents: Sequence[int] = (1, 3),
    time: float = 20.0,
) -> str:
    """Run short episodes in 2-D and 3-D, single- and multi-agent, twice per seed.

    A searcher that drives at most one agent runs the multi-agent case inside a ``per-agent``
    team. Checked: the action has one command per agent; the agents stay inside the arena;
    declarations are finite ``(K, d)``; rows and recordings are identical per seed;
    ``final_metrics`` has the same keys every time; the beliefs recorded give arrays.
    """
    cls = registry.entry("searcher", name).build
    done = []
    for dim in _dims_of(cls, dims):
        for n in sorted({max(n, cls.min_agents) for n in agents}):
            spec: dict[str, Any] = {"type": name, **dict(params or {})}
            if cls.max_agents is not None and n > cls.max_agents:
                spec = {"type": "per-agent", "member": spec}
            sc = small_scenario(spec, dim, n, time)
            tag = f"searcher {name} {dim}D x{n}"
            a = run_episode(sc, 101, 202, record=True)
            b = run_episode(sc, 101, 202, record=True)
            compare_runs(a, b, tag)
            m = a.metrics
            _require(
                m["termination"] in ("declared", "time_limit", "energy", "reached", "stuck"),
                f"{tag}: termination {m['termination']!r}",
            )
            _require(
                0.0 <= m["search_time"] <= time + 1e-9, f"{tag}: search time {m['search_time']}"
            )
            rec = a.recording
            assert rec is not None
            lo, hi = np.asarray(sc.world.arena.lower), np.asarray(sc.world.arena.upper)
            _require(
                bool(np.all(rec.positions >= lo - 1e-9) and np.all(rec.positions <= hi + 1e-9)),
                f"{tag}: an agent left the arena",
            )
            for d in a.declarations:
                _require(
                    d.positions.ndim == 2 and d.positions.shape[1] == dim,
                    f"{tag}: declaration shape {d.positions.shape}",
                )
                _require(bool(np.all(np.isfinite(d.positions))), f"{tag}: non-finite declaration")
            keys_a = set(_final_keys(sc))
            keys_b = set(_final_keys(sc))
            _require(keys_a == keys_b, f"{tag}: final_metrics keys change between runs")
            for _, snap in rec.beliefs:
                _require(
                    all(isinstance(v, np.ndarray) for v in snap.values()),
                    f"{tag}: a belief snapshot holds non-arrays",
                )
            done.append(f"{dim}D x{n}")
    return f"searcher {name}: {', '.join(done)}"


def _final_keys(sc: Scenario) -> list[str]:
    ep = Episode(sc, record=False)
    obs = ep.reset(7, 8)
    s = ep.built.searcher
    s.reset(ep.context, ep.agent_rng)
    for _ in range(4):
        if ep.done:
            break
        res = ep.step(s.act(obs, ep.agent_rng), s)
        obs = res.observations
    return sorted(s.final_metrics())


# ---------------------------------------------------------------------- gas maps
def check_gas_map(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] | None = None
) -> str:
    """A gas map (family ``gas_map``) in 2-D and 3-D, in a small arena with an obstacle.

    Checked: no belief and no estimate before a reading; the mean, variance, predictive
    variance and confidence maps have the grid's shape, are finite, variances are >= 0 and
    confidences in [0, 1], 0 in blocked cells; the map maxima are ``(k, d)`` free points;
    readings given at once, in batches or as observations give the same maps; readings all
    equal to ``c`` give the mean ``c`` wherever the confidence is high; the belief records
    arrays; ``final_metrics`` keys are stable; bad readings (NaN, wrong shapes, a missing wind
    the member needs) are refused with a :class:`~odorloc.core.errors.ConfigError` naming the
    field, leaving no reading behind.
    """
    e = registry.entry("gas_map", name)
    p = registry.make_params("gas_map", name, {"cell_size": 0.5, **dict(params or {})})
    done = []
    for dim in _dims_of(e.build, dims):
        _check_gas_map_in(e.build, p, dim, f"gas map {name} {dim}D")
        done.append(f"{dim}D")
    return f"gas map {name}: {', '.join(done)}"


def _check_gas_map_in(build: Any, p: Any, dim: int, tag: str) -> None:
    from odorloc.core.errors import ConfigError
    from odorloc.core.types import Observation, SearchContext
    from odorloc.inference.gas_map.base import GasMap

    wall = ((4.0, 0.0, 0.0)[:dim], (4.5, 4.0, 4.0)[:dim])
    arena = _arena(dim).with_boxes([wall])
    ctx = SearchContext(
        arena=arena, dt=0.5, agent_ids=(0,), start=arena.lo + 0.5, speed_limits=[0.5]
    )
    rng = np.random.default_rng(21)
    pos = arena.lo + 0.05 + rng.random((120, dim)) * (arena.size - 0.1)
    pos = pos[arena.is_free(pos)]
    n = len(pos)
    vals = 5.0 * np.exp(-np.sum((pos - pos[0]) ** 2, axis=1) / 4.0) + rng.normal(0.0, 0.2, n)
    wind = np.tile(np.eye(dim)[0] * 0.6, (n, 1)) + rng.normal(0.0, 0.05, (n, dim))
    t = 0.5 * np.arange(n)

    def fresh() -> GasMap:
        gm = build(p)
        _require(isinstance(gm, GasMap), f"{tag}: not a GasMap")
        gm.reset(ctx, None, np.random.default_rng(0))
        return gm

    gm = fresh()
    _require(gm.belief() is None, f"{tag}: a belief before any reading")
    _require(gm.estimate().shape == (0, dim), f"{tag}: an estimate before any reading")
    gm.update(pos, vals, wind=wind, t=t)
    shape = gm.grid.shape
    maps = {
        "mean": gm.mean(),
        "variance": gm.variance(),
        "predictive variance": gm.predictive_variance(),
        "confidence": gm.confidence(),
    }
    for what, arr in maps.items():
        _require(arr.shape == shape, f"{tag}: {what} shape {arr.shape}, grid {shape}")
        _require(bool(np.all(np.isfinite(arr))), f"{tag}: non-finite {what}")
    _require(bool(np.all(maps["variance"] >= 0)), f"{tag}: negative variance")
    _require(bool(np.all(maps["predictive variance"] >= 0)), f"{tag}: negative variance")
    conf = maps["confidence"]
    _require(bool(np.all((conf >= 0) & (conf <= 1))), f"{tag}: confidence outside [0, 1]")
    _require(bool(gm.blocked.any()), f"{tag}: the wall blocks no cell")
    _require(bool(np.all(conf[gm.blocked] == 0)), f"{tag}: confidence in a blocked cell")
    est = gm.estimate()
    _require(est.ndim == 2 and est.shape[1] == dim and len(est) >= 1, f"{tag}: estimate")
    _require(bool(np.all(arena.is_free(est))), f"{tag}: a map maximum in an obstacle")
    belief = gm.belief()
    _require(belief is not None, f"{tag}: no belief after readings")
    snap = belief.snapshot()  # type: ignore[union-attr]
    _require(all(isinstance(v, np.ndarray) for v in snap.values()), f"{tag}: snapshot non-arrays")
    keys = sorted(gm.final_metrics())
    # in batches, and one observation at a time: the same readings, the same maps
    parts = fresh()
    for sl in (slice(0, n // 3), slice(n // 3, n - 5)):
        parts.update(pos[sl], vals[sl], wind=wind[sl], t=t[sl])
    for k in range(n - 5, n):
        parts.update(Observation(0, float(t[k]), pos[k], 0.0, float(vals[k]), False, wind[k]))
    _require(np.array_equal(parts.mean(), maps["mean"]), f"{tag}: mean depends on batching")
    _require(
        np.array_equal(parts.variance(), maps["variance"]), f"{tag}: variance depends on batching"
    )
    _require(sorted(parts.final_metrics()) == keys, f"{tag}: final_metrics keys change")
    # a constant field is a constant map where the map is confident
    flat = fresh()
    flat.update(pos, np.full(n, 3.0), wind=wind, t=t)
    sure = flat.confidence() > 0.5
    _require(bool(sure.any()), f"{tag}: no confident cell after {n} readings")
    _require(
        bool(np.allclose(flat.mean()[sure], 3.0, rtol=0.0, atol=1e-6)),
        f"{tag}: a constant field is not recovered where the confidence is high",
    )
    # bad input is refused before it reaches the map
    two = {"wind": wind[:2], "t": t[:2]}
    bad: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = [
        ("reading", (pos[:2], [1.0, math.nan]), two),
        ("position", (pos[:2, :1], vals[:2]), two),
        ("reading", (pos[:2], vals[:3]), two),
        ("wind", (pos[:2], vals[:2]), {"wind": wind[:1], "t": t[:2]}),
        ("t", (pos[:2], vals[:2]), {"wind": wind[:2], "t": [0.0, math.inf]}),
    ]
    if type(gm).needs_wind:
        bad.append(("wind", (pos[:2], vals[:2]), {"t": t[:2]}))
    for field, args, kwargs in bad:
        g = fresh()
        try:
            g.update(*args, **kwargs)
        except ConfigError as exc:
            _require(exc.field == field, f"{tag}: bad {field} refused as {exc.field!r}")
        else:
            raise ContractError(f"{tag}: bad {field} accepted")
        _require(g.n_readings == 0, f"{tag}: a refused batch left readings behind")
