"""Contract checkers for every component family, shipped as API.

Anyone adding a wind, plume, sensor, platform, searcher, measurement model, resampler,
single-agent estimator, planner or gas map can check it the way odorloc's own tests do::

    from odorloc import checks
    checks.check_searcher("my-searcher")            # 2-D and 3-D, one and three agents
    checks.check_plume("my-plume", {"rate_scale": 2.0})
    checks.check_measurement_model("my-model", conditions={"dt": 0.5})
    checks.check_resampler("my-resampler")
    checks.check_estimator("my-estimator")          # a recorded stream, twice per seed
    checks.check_planner("my-planner")              # on the belief of its own estimator
    checks.check_gas_map("my-gas-map")              # 2-D and 3-D, with a wall

Each checker builds the component by its registry name (with ``params``, default its defaults)
in small worlds, exercises it and raises :class:`ContractError` naming what is wrong: shapes,
finiteness, determinism per seed, staying inside the arena, the declaration format, stable
``final_metrics`` keys. They return a short report of what was checked.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Command, Observation, Payload, SearchContext, SensorInfo
from odorloc.engine.episode import Episode, EpisodeResult, run_episode
from odorloc.geometry.arena import Arena
from odorloc.plume.sources import Source
from odorloc.scenarios.config import Scenario
from odorloc.world.world import World

__all__ = [
    "ContractError",
    "check_estimator",
    "check_gas_map",
    "check_measurement_model",
    "check_planner",
    "check_platform",
    "check_plume",
    "check_resampler",
    "check_searcher",
    "check_sensor",
    "check_step_planner",
    "check_team_estimator",
    "check_wind",
    "compare_runs",
    "observation_stream",
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
    # along +x at 1 m/s: the windy lattice problem's wind and the Vergassola plume's default
    # speed, which both refuse a world wind that disagrees with them
    wv = (1.0, 0.0) if dim == 2 else (1.0, 0.0, 0.0)
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
    if plume == "vergassola":
        plume_cfg["V"] = None  # the world's wind speed (a different V is refused)
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
    declarations are finite ``(K, d)`` and absent when the searcher says it never declares
    (:meth:`~odorloc.searchers.base.Searcher.may_declare`); rows and recordings are identical
    per seed; ``final_metrics`` has the same keys every time; the beliefs recorded give arrays.
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
            searcher = registry.ComponentRef(**spec).build("searcher")
            _require(
                searcher.may_declare() or not a.declarations,
                f"{tag}: declared although may_declare() says it never does",
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


# ---------------------------------------------------------------------- measurement models
def check_measurement_model(
    name: str,
    params: Mapping[str, Any] | None = None,
    conditions: Mapping[str, Any] | None = None,
    dims: Sequence[int] = (2, 3),
) -> str:
    """The measurement-model contract (:class:`~odorloc.models.base.MeasurementModel`) in 2-D
    and 3-D.

    Checked: ``outcome_probabilities`` is ``(M, Z, N)``, finite, in ``[0, 1]`` and sums to one
    over the ``Z`` classes; ``outcome_values`` names ``Z`` readings; ``log_likelihood`` of
    each class's reading is ``(N,)`` and never NaN or ``+inf`` (``-inf``, an impossible
    hypothesis, is allowed), also for a hypothesis on the sensor itself; both are deterministic
    and leave their inputs and the model's parameters unchanged; ``log_likelihood_rows`` equals
    one ``log_likelihood`` per reading; a bound model (``bind``) answers as the model does.

    Parameters
    ----------
    name : str
        Registry name (family ``model``).
    params : mapping, optional
        The model's parameters (default its defaults).
    conditions : mapping, optional
        The keyword conditions its calls need (a wind window, an exposure time), the same in
        every dimension; ``wind`` and ``wind_window`` given in 3 components are cut to 2 for
        2-D.
    dims : sequence of int
        Dimensions to check.
    """
    from odorloc.models.base import MeasurementModel

    e = registry.entry("model", name)
    p = registry.make_params("model", name, dict(params or {}))
    model = e.build(p)
    _require(isinstance(model, MeasurementModel), f"model {name}: not a MeasurementModel")
    before = p.model_dump()
    done = []
    rng = np.random.default_rng(17)
    for dim in dims:
        tag = f"model {name} {dim}D"
        cond = {
            k: (np.asarray(v)[..., :dim] if k in ("wind", "wind_window") else v)
            for k, v in (conditions or {}).items()
        }
        sensors = _probe_points(dim, 3)
        hyp = np.vstack([_probe_points(dim, 40) + 0.01 * rng.random((40, dim)), sensors[:1]])
        s0, h0 = sensors.copy(), hyp.copy()
        try:
            probs = np.asarray(model.outcome_probabilities(sensors, hyp, **cond))
        except TypeError as exc:
            raise ContractError(f"{tag}: needs other conditions ({exc})") from None
        m, n = len(sensors), len(hyp)
        _require(
            probs.ndim == 3 and probs.shape[0] == m and probs.shape[2] == n,
            f"{tag}: outcome_probabilities shape {probs.shape}, expected ({m}, Z, {n})",
        )
        _require(bool(np.all(np.isfinite(probs))), f"{tag}: non-finite outcome probabilities")
        _require(
            bool(np.all((probs >= -1e-12) & (probs <= 1 + 1e-12))),
            f"{tag}: outcome probabilities outside [0, 1]",
        )
        total = np.abs(probs.sum(axis=1) - 1.0).max()
        _require(total <= 1e-9, f"{tag}: classes sum to 1 within {total:.2e}, not 1e-9")
        values = np.asarray(model.outcome_values(sensors, hyp, **cond))
        _require(
            values.shape == (probs.shape[1],),
            f"{tag}: {values.shape} outcome values for {probs.shape[1]} classes",
        )
        for z in values[: min(len(values), 4)]:
            ll = np.asarray(model.log_likelihood(z, sensors[0], hyp, **cond))
            _require(ll.shape == (n,), f"{tag}: log_likelihood shape {ll.shape}, expected ({n},)")
            _require(not bool(np.isnan(ll).any()), f"{tag}: NaN log-likelihood for z = {z}")
            _require(not bool(np.isposinf(ll).any()), f"{tag}: +inf log-likelihood for z = {z}")
            again = np.asarray(model.log_likelihood(z, sensors[0], hyp, **cond))
            _require(np.array_equal(ll, again), f"{tag}: log_likelihood not deterministic")
            bound = np.asarray(model.bind(**cond).log_likelihood(z, sensors[0], hyp))
            _require(np.array_equal(ll, bound), f"{tag}: the bound model answers differently")
        zs = values[: min(len(values), len(sensors))]
        rows = np.asarray(model.log_likelihood_rows(zs, sensors[: len(zs)], hyp, **cond))
        single = np.array(
            [model.log_likelihood(z, s, hyp, **cond) for z, s in zip(zs, sensors, strict=False)]
        )
        # a vectorised rows method may sum in another order: equal up to round-off
        _require(
            rows.shape == single.shape and np.allclose(rows, single, rtol=1e-9, atol=1e-9),
            f"{tag}: log_likelihood_rows differs from one log_likelihood per reading",
        )
        again = np.asarray(model.bind(**cond).outcome_probabilities(sensors, hyp))
        _require(np.array_equal(probs, again), f"{tag}: outcome_probabilities not deterministic")
        _require(
            np.array_equal(sensors, s0) and np.array_equal(hyp, h0),
            f"{tag}: the inputs were modified",
        )
        done.append(f"{dim}D")
    _require(p.model_dump() == before, f"model {name}: parameters changed while running")
    return f"model {name}: {', '.join(done)}"


# ---------------------------------------------------------------------- resamplers
def check_resampler(name: str, params: Mapping[str, Any] | None = None) -> str:
    """The resampler contract (:class:`~odorloc.inference.particles.resampling.Resampler`).

    Checked, in 2-D and 3-D: the output is a new finite ``(M, d)`` array with uniform
    normalised log-weights ``-log M``; ``M`` is the input count by default and the target
    count ``n`` when one is given (a resampler whose parameters bound the count instead may
    stay within its bounds); the inputs and the parameters are unchanged; the same seed gives
    the same particles; weights that all underflowed (every log-weight ``-inf``) give no NaN;
    with an arena constraint every particle stays in free space; and resampling moves the
    cloud towards its weight (the resampled mean is closer to the weighted mean than the
    unweighted one is). Bad input (an empty set, mismatched shapes, a target count of 0) is a
    :class:`~odorloc.core.errors.ConfigError`.
    """
    from odorloc.core.errors import ConfigError
    from odorloc.inference.particles.constraints import ArenaConstraint
    from odorloc.inference.particles.resampling import Resampler

    e = registry.entry("resampler", name)
    p = registry.make_params("resampler", name, dict(params or {}))
    r = e.build(p)
    _require(isinstance(r, Resampler), f"resampler {name}: not a Resampler")
    before = p.model_dump()
    bounded = getattr(p, "count", "keep") == "bounded"
    done = []
    for dim in (2, 3):
        tag = f"resampler {name} {dim}D"
        arena = _arena(dim)
        rng = np.random.default_rng(dim)
        pos = arena.lo + 0.5 * arena.size * (0.5 + rng.random((300, dim)))
        peak = arena.lo + 0.8 * arena.size
        lw = -0.5 * np.sum((pos - peak) ** 2, axis=1) / 0.5
        pos0, lw0 = pos.copy(), lw.copy()
        for n in (None, 150, 450):
            out, olw = r.resample(pos, lw, np.random.default_rng(1), n=n)
            m = len(out)
            want = len(pos) if n is None else n
            _require(
                out.ndim == 2 and out.shape[1] == dim and m >= 1,
                f"{tag}: output shape {out.shape}",
            )
            _require(bounded or m == want, f"{tag}: {m} particles for a target of {want}")
            _require(bool(np.all(np.isfinite(out))), f"{tag}: non-finite particles")
            _require(
                olw.shape == (m,) and np.allclose(olw, -math.log(m)),
                f"{tag}: log-weights not uniform -log M",
            )
            _require(out is not pos, f"{tag}: returned its input array")
            again, _ = r.resample(pos, lw, np.random.default_rng(1), n=n)
            _require(np.array_equal(out, again), f"{tag}: not deterministic per seed")
        _require(np.array_equal(pos, pos0) and np.array_equal(lw, lw0), f"{tag}: inputs modified")
        w = np.exp(lw - lw.max())
        w /= w.sum()
        target = w @ pos
        out, _ = r.resample(pos, lw, np.random.default_rng(2))
        moved = np.linalg.norm(out.mean(axis=0) - target)
        _require(
            moved < np.linalg.norm(pos.mean(axis=0) - target),
            f"{tag}: resampling does not move the cloud towards its weight",
        )
        dead, dlw = r.resample(pos, np.full(len(pos), -np.inf), np.random.default_rng(3))
        _require(
            bool(np.all(np.isfinite(dead)) and np.all(np.isfinite(dlw))),
            f"{tag}: all weights underflowed gives non-finite output",
        )
        walls = ArenaConstraint(arena)
        inside, _ = r.resample(pos, lw, np.random.default_rng(4), constraint=walls)
        _require(bool(np.all(walls.admissible(inside))), f"{tag}: a particle left free space")
        for x, y, n in ((pos[:0], lw[:0], None), (pos, lw[:-1], None), (pos, lw, 0)):
            try:
                r.resample(x, y, np.random.default_rng(0), n=n)
            except ConfigError:
                continue
            raise ContractError(f"{tag}: bad input accepted without a ConfigError")
        done.append(f"{dim}D")
    _require(p.model_dump() == before, f"resampler {name}: parameters changed while running")
    return f"resampler {name}: {', '.join(done)}"


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
    per_agent = {f"agent[{a}].{k}" for a, v in s.agent_metrics().items() for k in v}
    return sorted(s.final_metrics()) + sorted(per_agent)


# ---------------------------------------------------------------------- estimators and planners
@lru_cache(maxsize=4)
def observation_stream(
    dim: int, time: float = 40.0, seed: int = 5
) -> tuple[SearchContext, list[Observation]]:
    """A recorded single-agent stream for estimator and planner checks: the observations of a
    zigzag run of ``time`` seconds in the small contract world with a steady Gaussian plume (so
    that some readings detect), and the context of that run (kept for the next call: do not
    modify them)."""
    sc = small_scenario({"type": "zigzag"}, dim, 1, time, plume="gaussian")
    ep = Episode(sc, record=False)
    obs = ep.reset(seed, seed + 1)
    s = ep.built.searcher
    s.reset(ep.context, ep.agent_rng)
    out = [obs[0]]
    while not ep.done:
        res = ep.step(s.act(obs, ep.agent_rng), s)
        obs = res.observations
        if obs:
            out.append(obs[0])
    return ep.context, out


def _model_of(spec: Mapping[str, Any] | None, needed: bool, tag: str) -> Any:
    if spec is None:
        _require(not needed, f"{tag}: needs a measurement model and names no default_model")
        return None
    return registry.ComponentRef(**dict(spec)).build("model", field="model")


def _same(a: Any, b: Any) -> bool:
    """Equal arrays (NaN equal to NaN) or equal values."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    return bool(a == b or (a != a and b != b))


def _check_snapshot(belief: Any, tag: str) -> dict[str, np.ndarray]:
    snap = belief.snapshot()
    _require(isinstance(snap, dict) and snap, f"{tag}: belief snapshot is not a dict of arrays")
    for k, v in snap.items():
        _require(isinstance(v, np.ndarray), f"{tag}: belief snapshot {k!r} is not an array")
        if v.dtype.kind == "f":
            _require(bool(np.all(np.isfinite(v))), f"{tag}: belief snapshot {k!r} not finite")
    return snap


def _roll_estimator(
    est: Any, ctx: SearchContext, mdl: Any, stream: list[Observation], tag: str, est_dim: int
) -> list[Any]:
    """Reset ``est`` (seed 11), feed it ``stream`` and collect estimates and snapshots every
    tenth step (and at the end), then the final_metrics keys."""
    est.reset(ctx, mdl, np.random.default_rng(11))
    out: list[Any] = []
    for k, o in enumerate(stream):
        est.update(o)
        _require(isinstance(est.converged(), bool), f"{tag}: converged() not a bool")
        _require(isinstance(est.conditions(), dict), f"{tag}: conditions() not a dict")
        for key, v in est.diagnostics().items():
            _require(isinstance(v, float | int), f"{tag}: diagnostic {key!r} not a float")
        if k % 10 and k != len(stream) - 1:
            continue
        x = np.asarray(est.estimate())
        _require(
            x.ndim == 2 and x.shape[1] == est_dim,
            f"{tag}: estimate shape {x.shape}, expected (k, {est_dim})",
        )
        _require(bool(np.all(np.isfinite(x))), f"{tag}: non-finite estimate")
        b = est.belief()
        out.append((x, None if b is None else _check_snapshot(b, tag)))
    out.append(sorted(est.final_metrics()))
    return out


def check_estimator(
    name: str,
    params: Mapping[str, Any] | None = None,
    dims: Sequence[int] | None = None,
    model: Mapping[str, Any] | None = None,
    family: str = "estimator",
) -> str:
    """Feed an estimator a recorded stream in 2-D and 3-D (where it declares them), twice per
    seed, and once more after a second :meth:`reset`.

    ``family``: the registry family the estimator is registered in (``gas_map`` for a gas map:
    its members are estimators too).

    Checked: ``reset`` refuses a missing model when the estimator needs one; ``update`` takes
    every observation; ``belief()`` is ``None`` or gives a snapshot of finite arrays;
    ``estimate()`` is a finite ``(k, d)`` array in the world's dimension ``d`` (a horizontal
    map declares ``dims = (2,)``); ``converged()`` is a bool; ``diagnostics()`` gives floats;
    ``conditions()`` a dict; ``final_metrics`` keys are stable; the same seed and observations
    give the same beliefs and estimates, also after a reset.
    """
    e = registry.entry(family, name)
    cls = e.build
    done = []
    for dim in _dims_of(cls, dims):
        ctx, stream = observation_stream(dim)
        tag = f"estimator {name} {dim}D"
        spec = model if model is not None else cls.default_model
        mdl = _model_of(spec, cls.needs_model, tag)

        p = registry.make_params(family, name, dict(params or {}))
        if cls.needs_model:
            probe = cls(p)
            try:
                probe.reset(ctx, None, np.random.default_rng(0))
            except ConfigError:
                pass
            else:
                raise ContractError(f"{tag}: reset accepts no model though it needs one")
        first = cls(p)
        a = _roll_estimator(first, ctx, mdl, stream, tag, dim)
        b = _roll_estimator(cls(p), ctx, mdl, stream, tag, dim)
        again = _roll_estimator(first, ctx, mdl, stream, tag, dim)
        for run, what in ((b, "per seed"), (again, "after a reset")):
            _require(run[-1] == a[-1], f"{tag}: final_metrics keys change {what}")
            for (xa, sa), (xb, sb) in zip(a[:-1], run[:-1], strict=True):
                _require(_same(xa, xb), f"{tag}: estimates differ {what}")
                _require((sa is None) == (sb is None), f"{tag}: beliefs differ {what}")
                if sa is not None:
                    _require(
                        sa.keys() == sb.keys() and all(_same(sa[k], sb[k]) for k in sa),
                        f"{tag}: beliefs differ {what}",
                    )
        formed = sum(s is not None for _, s in a[:-1])
        done.append(f"{dim}D ({formed}/{len(a) - 1} snapshots with a belief)")
    return f"estimator {name}: {', '.join(done)}"


def check_planner(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] | None = None
) -> str:
    """Plan on the belief of the planner's own estimator (``belief_estimator``) along a
    recorded stream, in 2-D and 3-D where declared.

    Checked: every :class:`~odorloc.planning.base.Plan` has ``(M, d)`` candidates, ``(M,)``
    scores and feasibility, an index that is ``None`` or a feasible candidate with a finite
    score, a target inside the arena, and a work count >= 0; a planner built anew with the
    same seed plans the same.
    """
    from odorloc.planning.base import Pose

    e = registry.entry("planner", name)
    cls = e.build
    p = registry.make_params("planner", name, dict(params or {}))
    done = []
    for dim in _dims_of(cls, dims):
        ctx, stream = observation_stream(dim)
        tag = f"planner {name} {dim}D"
        spec = dict(cls.belief_estimator)
        ecls = registry.entry("estimator", spec["type"]).build
        mspec = cls.belief_model if cls.belief_model is not None else ecls.default_model
        mdl = _model_of(mspec, cls.needs_model or ecls.needs_model, tag)
        est = registry.ComponentRef(**spec).build("estimator", field="belief_estimator")
        est.reset(ctx, mdl, np.random.default_rng(11))
        planners = [cls(p), cls(p)]
        for pl in planners:
            pl.reset(ctx, mdl)
        lo, hi = ctx.arena.lo, ctx.arena.hi
        plans = 0
        for k, o in enumerate(stream):
            est.update(o)
            belief = est.belief()
            if belief is None or k % 5:
                continue
            pose = Pose(np.asarray(o.position, float), o.heading, o.wind, est.conditions())
            a, b = (pl.plan(belief, pose, np.random.default_rng(k)) for pl in planners)
            m = len(a.candidates)
            d_out = a.candidates.shape[1] if a.candidates.ndim == 2 else -1
            _require(
                a.candidates.ndim == 2 and d_out in (2, dim),
                f"{tag}: candidates shape {a.candidates.shape}",
            )
            _require(
                a.scores.shape == (m,) and a.feasible.shape == (m,) and a.feasible.dtype == bool,
                f"{tag}: scores or feasibility do not match {m} candidates",
            )
            _require(isinstance(a.work, int) and a.work >= 0, f"{tag}: work {a.work!r}")
            if a.index is not None:
                _require(0 <= a.index < m and bool(a.feasible[a.index]), f"{tag}: bad index")
                _require(math.isfinite(a.score), f"{tag}: the chosen score is not finite")
                t = a.target
                assert t is not None
                _require(
                    bool(np.all(t >= lo[:d_out] - 1e-9) and np.all(t <= hi[:d_out] + 1e-9)),
                    f"{tag}: target {t} outside the arena",
                )
            _require(
                a.index == b.index
                and _same(a.scores, b.scores)
                and _same(a.candidates, b.candidates),
                f"{tag}: not deterministic per seed",
            )
            plans += 1
        _require(plans > 0, f"{tag}: the estimator {spec['type']} formed no belief to plan on")
        done.append(f"{dim}D ({plans} plans)")
    return f"planner {name}: {', '.join(done)}"


def _uav_context(dim: int) -> SearchContext:
    arena = _arena(dim)
    start = [0.5] * dim
    return SearchContext(arena=arena, dt=1.0, agent_ids=(0,), start=[start], speed_limits=[1.0])


def _uav_model(dim: int) -> Any:
    """The Vergassola encounter model of the UAV members (its defaults: a 1 m sensor)."""
    return registry.ComponentRef(type="vergassola").build("model")


def _check_particles(tag: str, positions: np.ndarray, weights: np.ndarray, arena: Arena) -> None:
    _require(
        positions.ndim == 2 and positions.shape == (len(weights), arena.dim),
        f"{tag}: particles {positions.shape} for {len(weights)} weights",
    )
    _require(bool(np.all(np.isfinite(positions))), f"{tag}: non-finite particles")
    _require(bool(np.all(arena.is_free(positions))), f"{tag}: a particle outside the free arena")
    _require(
        bool(np.all(weights >= 0)) and abs(float(weights.sum()) - 1.0) < 1e-9,
        f"{tag}: weights not normalised",
    )


def _check_message(msg: Any, tag: str) -> None:
    """A team message: a frozen payload whose declared size is a non-negative whole number of
    bytes and whose numbers are finite floats."""
    _require(isinstance(msg, Payload), f"{tag}: a message that is no Payload ({type(msg)})")
    _require(isinstance(msg.nbytes, int) and msg.nbytes >= 0, f"{tag}: message size {msg.nbytes!r}")
    stack = [msg]
    while stack:
        part = stack.pop()
        _require(dataclasses.is_dataclass(part), f"{tag}: a message that is no dataclass")
        for f in dataclasses.fields(part):
            v = getattr(part, f.name)
            if isinstance(v, Payload):
                stack.append(v)
            elif isinstance(v, np.ndarray):
                _require(
                    v.dtype.kind == "f" and bool(np.all(np.isfinite(v))),
                    f"{tag}: message {f.name} holds non-finite or non-float numbers",
                )


def check_team_estimator(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] = (2, 3)
) -> str:
    """Run two members of a ``team_estimator`` side by side for a few iterations, exchanging
    their messages, in 2-D and 3-D, twice per seed.

    Checked: particles finite, inside the free arena, weights normalised, after the reset and
    every update; a finite estimate and spread; messages that are payloads of a declared size
    holding finite float arrays; a finite,
    non-negative count of processed numbers; acceptance rates in ``[0, 1]`` (or NaN before any
    move); identical particles per seed; a message of another shape refused naming
    ``message``.
    """
    from odorloc.core.types import ArrayPayload
    from odorloc.inference.particles.team_estimators import Measurement

    entry = registry.entry("team_estimator", name)
    pp = registry.make_params("team_estimator", name, dict(params or {}))
    done = []
    for dim in dims:
        tag = f"team estimator {name} {dim}D"
        ctx, model = _uav_context(dim), _uav_model(dim)
        wind = np.zeros(dim)
        wind[0] = 1.0
        runs = []
        for _ in range(2):
            rng = np.random.default_rng(5)
            team = [entry.build(pp), entry.build(pp)]
            for est in team:
                est.reset(ctx, model, rng)
                b = est.belief()
                _check_particles(f"{tag} reset", b.positions, b.weights, ctx.arena)
            inbox: list[dict] = [{}, {}]
            for k in range(1, 7):
                for i, est in enumerate(team):
                    pos = ctx.arena.lo + (0.2 + 0.1 * k + 0.3 * i) * ctx.arena.size
                    count = float(k % 3 == 0)
                    est.update(Measurement(count, pos, 1.0, k, wind), inbox[i], rng)
                    b = est.belief()
                    _check_particles(f"{tag} iteration {k}", b.positions, b.weights, ctx.arena)
                    _require(
                        est.estimate().shape == (dim,)
                        and bool(np.all(np.isfinite(est.estimate())))
                        and math.isfinite(est.spread())
                        and est.spread() >= 0,
                        f"{tag}: estimate or spread not finite",
                    )
                    _require(
                        math.isfinite(est.processed) and est.processed >= 0,
                        f"{tag}: processed count {est.processed}",
                    )
                    for key, v in est.acceptance().items():
                        _require(math.isnan(v) or 0.0 <= v <= 1.0, f"{tag}: acceptance {key} {v}")
                msgs = [est.message() for est in team]
                for msg in msgs:
                    if msg is not None:
                        _check_message(msg, tag)
                inbox = [
                    {} if msgs[1] is None else {1: msgs[1]},
                    {} if msgs[0] is None else {0: msgs[0]},
                ]
            runs.append([est.belief().positions for est in team])
        _require(
            all(np.array_equal(a, b) for a, b in zip(*runs, strict=True)),
            f"{tag}: particles differ per seed",
        )
        if inbox[0]:
            # a payload of another kind than the member sends
            bad = {1: ArrayPayload({"x": np.zeros(1)})}
            try:
                team[0].update(
                    Measurement(0.0, ctx.arena.lo + 0.5 * ctx.arena.size, 1.0, 7, wind),
                    bad,
                    np.random.default_rng(0),
                )
            except ConfigError as exc:
                _require(exc.field == "message", f"{tag}: a bad message refused as {exc.field}")
            else:
                raise ContractError(f"{tag}: a message of another shape was accepted")
        done.append(f"{dim}D")
    return f"team estimator {name}: {', '.join(done)}"


def check_step_planner(
    name: str, params: Mapping[str, Any] | None = None, dims: Sequence[int] = (2, 3)
) -> str:
    """Plan from several beliefs and positions (a corner among them) in 2-D and 3-D, twice per
    seed, through the :class:`~odorloc.planning.base.Planner` interface.

    Checked: a model is required at reset (``ConfigError`` naming ``model``); one candidate
    per lattice direction; scores ``(M,)``, ``inf`` where infeasible; the chosen index feasible
    and its target free and inside the arena; ``extra`` gives an integer ``length`` in
    ``1 .. l_max``; ``work`` a non-negative integer; the same plan per seed.
    """
    from odorloc.inference.belief import ParticleBelief
    from odorloc.planning.base import Plan, Pose
    from odorloc.planning.steps import lattice_offsets

    entry = registry.entry("step_planner", name)
    pp = registry.make_params("step_planner", name, dict(params or {}))
    done = []
    for dim in dims:
        tag = f"step planner {name} {dim}D"
        ctx, model, arena = _uav_context(dim), _uav_model(dim), _arena(dim)
        try:
            entry.build(pp).reset(ctx)
        except ConfigError as exc:
            _require(exc.field == "model", f"{tag}: no model refused as {exc.field}")
        else:
            raise ContractError(f"{tag}: reset without a measurement model was accepted")
        rng = np.random.default_rng(9)
        cases = []
        for j in range(4):
            x = arena.lo + rng.random((60, dim)) * arena.size
            lw = rng.normal(0.0, 1.0 + j, 60)
            lw -= lw.max() + np.log(np.exp(lw - lw.max()).sum())
            pos = arena.lo.copy() if j == 0 else arena.lo + rng.random(dim) * arena.size
            cases.append((ParticleBelief(x, lw), pos, x[:5]))
        wind = np.zeros(dim)
        wind[0] = 1.0
        plans: list[list[Plan]] = []
        for _ in range(2):
            planner = entry.build(pp)
            planner.reset(ctx, model)
            got = []
            for belief, pos, hist in cases:
                for h in hist:
                    planner.record(h)
                pose = Pose(pos, conditions={"dt": 1.0, "direction": wind})
                got.append(planner.plan(belief, pose, np.random.default_rng(3)))
            plans.append(got)
        m = len(lattice_offsets(dim))
        for p, q in zip(*plans, strict=True):
            _require(
                p.candidates.shape == (m, dim)
                and p.scores.shape == (m,)
                and p.feasible.shape == (m,),
                f"{tag}: plan shapes",
            )
            _require(
                bool(np.all(np.isinf(p.scores[~p.feasible]))),
                f"{tag}: a finite score for an infeasible direction",
            )
            _require(isinstance(p.work, int) and p.work >= 0, f"{tag}: work {p.work!r}")
            extra = p.extra or {}
            if p.index is not None:
                _require(bool(p.feasible[p.index]), f"{tag}: an infeasible direction chosen")
                _require(bool(arena.is_free(p.target[None])[0]), f"{tag}: target not free")
                length, l_max = extra.get("length"), extra.get("l_max")
                _require(
                    isinstance(length, int) and isinstance(l_max, int) and 1 <= length <= l_max,
                    f"{tag}: length {length}, l_max {l_max}",
                )
            _require(
                p.index == q.index and np.array_equal(p.scores, q.scores),
                f"{tag}: plans differ per seed",
            )
        _require(plans[0][0].index is not None, f"{tag}: no direction feasible from the corner")
        done.append(f"{dim}D")
    return f"step planner {name}: {', '.join(done)}"


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
