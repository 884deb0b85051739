"""Reactive single-robot strategies: each rule's decision on hand-made readings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.behaviours.surge_cast import CastParams, SurgeCast
from odorloc.core.errors import ConfigError
from odorloc.core.registry import make_params
from odorloc.core.types import Observation, SearchContext, SensorInfo
from odorloc.geometry.arena import Arena
from odorloc.searchers.reactive import (
    AnemotaxisSearcher,
    ChemotaxisSearcher,
    FluxotaxisSearcher,
    SurgeCastSearcher,
    SurgeSpiralSearcher,
)

ARENA = Arena.box((0.0, 0.0), (20.0, 20.0), 0.1)
WIND = np.array([1.0, 0.0])  # blows towards +x: upwind is -x


def _ctx(dim: int = 2) -> SearchContext:
    arena = ARENA if dim == 2 else Arena.box((0.0, 0.0, 0.0), (20.0, 20.0, 20.0), 0.5)
    return SearchContext(
        arena=arena,
        dt=1.0,
        agent_ids=(0,),
        start=np.full((1, dim), 10.0),
        speed_limits=np.array([0.5]),
        sensor=SensorInfo("concentration", 1.0, "reading"),
    )


def _obs(pos, gas: float, wind=WIND, ready: bool = True) -> Observation:
    p = np.asarray(pos, float)
    return Observation(0, 0.0, p, 0.0, float(gas), gas >= 1.0, np.asarray(wind, float), ready)


def _build(cls, **params):
    name = {
        SurgeCastSearcher: "surge-cast",
        SurgeSpiralSearcher: "surge-spiral",
        ChemotaxisSearcher: "chemotaxis",
        AnemotaxisSearcher: "anemotaxis",
        FluxotaxisSearcher: "fluxotaxis",
    }[cls]
    s = cls(make_params("searcher", name, params))
    s.reset(_ctx(), np.random.default_rng(0))
    return s


def _move(s, o) -> np.ndarray:
    a = s.act([o], np.random.default_rng(1))
    c = a.commands[0]
    assert c is not None and c.kind == "move"
    return c.value


def test_surge_cast_surges_upwind_then_casts() -> None:
    s = _build(SurgeCastSearcher, surge_steps=2, cast={"angle_deg": 90.0})
    pos = np.array([10.0, 10.0])
    d = _move(s, _obs(pos, 3.0))
    np.testing.assert_allclose(d, [-0.5, 0.0], atol=1e-12)  # upwind, one period at 0.5 m/s
    d = _move(s, _obs(pos, 0.0))
    np.testing.assert_allclose(d, [-0.5, 0.0], atol=1e-12)  # the surge goes on
    d = _move(s, _obs(pos, 0.0))
    assert abs(d[0]) < 1e-9 and abs(abs(d[1]) - 0.5) < 1e-9  # lost: crosswind cast
    assert s.diagnostics()["phase"] == "cast"
    assert s.act([_obs(pos, 0.0, ready=False)], np.random.default_rng(0)).commands[0] is None


def test_surge_spiral_spirals_where_the_odor_was_lost() -> None:
    s = _build(
        SurgeSpiralSearcher, surge_steps=1, spiral={"initial_step": 1.0, "step_increment": 0.4}
    )
    pos = np.array([10.0, 10.0])
    np.testing.assert_allclose(_move(s, _obs(pos, 2.0)), [-0.5, 0.0], atol=1e-12)
    leg = _move(s, _obs(pos, 0.0))
    # the first spiral leg: one step forward (upwind) and one to the left, facing upwind
    np.testing.assert_allclose(leg, [-1.0, -1.0], atol=1e-12)
    assert s.diagnostics()["phase"] == "spiral"
    # a detection during a leg ends it and surges at once
    np.testing.assert_allclose(
        _move(s, _obs(pos + leg / 2, 2.0, ready=False)), [-0.5, 0.0], atol=1e-12
    )


def test_chemotaxis_climbs_and_turns_back() -> None:
    s = _build(ChemotaxisSearcher, memory=3)
    # readings rise along +y: keep going +y
    for y, c in ((10.0, 1.0), (10.5, 2.0)):
        s.act([_obs([10.0, y], c)], np.random.default_rng(0))
    d = _move(s, _obs([10.0, 11.0], 3.0))
    assert d[1] > 0 and abs(d[0]) < 1e-9
    # readings fall: head back towards the best sample (y = 11)
    s.act([_obs([10.0, 11.5], 1.5)], np.random.default_rng(0))
    d = _move(s, _obs([10.0, 12.0], 1.2))
    assert d[1] < 0
    # no detection in memory: the rule is silent and the robot casts crosswind
    s2 = _build(ChemotaxisSearcher, memory=2, cast={"angle_deg": 90.0})
    s2.act([_obs([5.0, 5.0], 0.2)], np.random.default_rng(0))
    d = _move(s2, _obs([5.0, 5.0], 0.5))
    assert abs(d[0]) < 1e-9


def test_anemotaxis_goes_upwind_only_while_every_reading_exceeds() -> None:
    s = _build(AnemotaxisSearcher, memory=2, cast={"angle_deg": 90.0})
    s.act([_obs([10.0, 10.0], 2.0)], np.random.default_rng(0))
    np.testing.assert_allclose(_move(s, _obs([10.0, 10.0], 1.5)), [-0.5, 0.0], atol=1e-12)
    d = _move(s, _obs([10.0, 10.0], 0.5))  # one reading below: cast
    assert abs(d[0]) < 1e-9 and s.diagnostics()["phase"] == "cast"


def test_taxis_rules_count_a_reading_at_the_sensor_threshold_as_odor() -> None:
    # a hit counter: threshold 1 hit, one encounter is a detection, and for the taxis rules it is
    # a reading that exceeds rho_T (the default rho_T is the sensor's detection threshold)
    s = _build(AnemotaxisSearcher, memory=2, cast={"angle_deg": 90.0})
    s.act([_obs([10.0, 10.0], 1.0)], np.random.default_rng(0))
    np.testing.assert_allclose(_move(s, _obs([10.0, 10.0], 1.0)), [-0.5, 0.0], atol=1e-12)
    # an explicit rho_T keeps the paper's strict "exceeds"
    s = _build(AnemotaxisSearcher, memory=2, cast={"angle_deg": 90.0}, threshold=1.0)
    s.act([_obs([10.0, 10.0], 1.0)], np.random.default_rng(0))
    assert abs(_move(s, _obs([10.0, 10.0], 1.0))[0]) < 1e-9


def test_fluxotaxis_heads_for_the_inflow() -> None:
    # samples around (10, 10); wind towards +x: the sample on the upwind side (x = 9) has the
    # inflowing flux rho v . n < 0 (n points to -x, v to +x). The strongest reading sits
    # crosswind (y = 11), where v . n = 0: chemotaxis would go there, fluxotaxis must not.
    pts = [(9.0, 10.0), (10.0, 9.0), (10.0, 11.0), (11.0, 10.0)]
    readings = (2.0, 2.0, 3.0, 2.0)
    directions = {}
    for cls in (FluxotaxisSearcher, ChemotaxisSearcher):
        s = _build(cls, memory=4)
        for p, c in zip(pts[:-1], readings[:-1], strict=True):
            s.act([_obs(p, c)], np.random.default_rng(0))
        d = _move(s, _obs(pts[-1], readings[-1]))
        directions[cls] = d / np.linalg.norm(d)
    np.testing.assert_allclose(directions[FluxotaxisSearcher], [-1.0, 0.0], atol=1e-12)
    # the same samples tell the two rules apart
    np.testing.assert_allclose(directions[ChemotaxisSearcher], [0.0, 1.0], atol=1e-12)


def test_three_d_casts_sweep_heights() -> None:
    sc = SurgeCast(CastParams(amplitude=0.4, growth=1.0, elevation_deg=30.0))
    arena = Arena.box((0.0, 0.0, 0.0), (20.0, 20.0, 20.0), 0.5)
    up = np.array([-1.0, 0.0, 0.0])
    zs = [sc.direction(arena, np.full(3, 10.0), up, 0.2)[2] for _ in range(16)]
    # two legs up, two legs down: heights are swept both ways
    assert max(zs) == pytest.approx(math.sin(math.radians(30.0)))
    assert min(zs) == pytest.approx(-math.sin(math.radians(30.0)))
    flat = SurgeCast(CastParams())
    assert flat.direction(arena, np.full(3, 10.0), up, 0.2)[2] == 0.0


def test_reactive_bad_input() -> None:
    with pytest.raises(ConfigError, match="memory"):
        make_params("searcher", "chemotaxis", {"memory": 1})
    with pytest.raises(ConfigError, match="step_length"):
        make_params("searcher", "surge-cast", {"step_length": -1.0})
    with pytest.raises(ConfigError, match=r"cast\.elevation_deg"):
        make_params("searcher", "anemotaxis", {"cast": {"elevation_deg": 95.0}})
