"""The virtual-physics formation searcher: goal forces, declaration, messages, and a seeded
episode in which two groups find the two sources."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from odorloc.behaviours.formation import equilibrium_radius, regular_polygon
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Message, Observation, SearchContext
from odorloc.engine.episode import run_episode
from odorloc.geometry.arena import Arena
from odorloc.scenarios import get_scenario
from odorloc.searchers.virtual_physics import (
    GroupMessage,
    VirtualPhysicsParams,
    VirtualPhysicsSearcher,
)

CENTRE = np.array([10.0, 10.0])
RING = regular_polygon(CENTRE, equilibrium_radius(6, 0.3, 5.0, 1e5), 6)  # formed hexagon


def _searcher(**params) -> VirtualPhysicsSearcher:
    s = VirtualPhysicsSearcher(VirtualPhysicsParams(**params))
    ctx = SearchContext(
        arena=Arena.box((0.0, 0.0), (20.0, 20.0), 0.2),
        dt=0.5,
        agent_ids=tuple(range(6)),
        start=RING,
        speed_limits=np.full(6, 0.24),
    )
    s.reset(ctx, np.random.default_rng(0))
    return s


def _obs(gas, wind=(5.0, 0.0), t=0.0, positions=RING, messages=()) -> list[Observation]:
    w = np.broadcast_to(np.asarray(wind, float), (6, 2))
    return [
        Observation(
            agent=k,
            t=t,
            position=np.asarray(positions[k], float),
            heading=0.0,
            gas=float(gas[k]),
            detection=bool(gas[k] >= 0.005),
            wind=w[k].copy(),
            messages=tuple(messages),
        )
        for k in range(6)
    ]


def _moves(action) -> np.ndarray:
    return np.array([c.value for c in action.commands])


def test_chemotaxis_steps_s1_towards_the_strongest_robot() -> None:
    s = _searcher(rule="chemotaxis")
    gas = np.array([0.01, 0.02, 0.09, 0.03, 0.01, 0.0])
    a = s.act(_obs(gas), np.random.default_rng(0))
    u = (RING[2] - CENTRE) / np.linalg.norm(RING[2] - CENTRE)  # eq. 3
    np.testing.assert_allclose(s.vr, CENTRE + 0.06 * u)  # eq. 7
    # the formed hexagon is carried with its virtual robot (eq. 8 with follow)
    np.testing.assert_allclose(_moves(a), np.tile(0.06 * u, (6, 1)), atol=1e-3)
    # readings below k_c are no odor: the virtual robot waits (passive monitoring)
    s = _searcher(rule="chemotaxis")
    a = s.act(_obs(np.full(6, 5e-5)), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE)
    assert math.isnan(s.final_metrics()["plume_time"])


def test_anemotaxis_goes_upwind_of_the_mean_wind_inside_the_plume() -> None:
    s = _searcher(rule="anemotaxis")
    s.act(_obs(np.full(6, 0.01), wind=(4.0, 3.0)), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE - 0.06 * np.array([0.8, 0.6]))  # eq. 4
    # one robot out of the plume: re-centre on the strongest robot, or wait (literal)
    gas = np.array([0.02, 0.01, 0.01, 0.001, 0.01, 0.01])
    s = _searcher(rule="anemotaxis")
    s.act(_obs(gas), np.random.default_rng(0))
    u = (RING[0] - CENTRE) / np.linalg.norm(RING[0] - CENTRE)
    np.testing.assert_allclose(s.vr, CENTRE + 0.06 * u)
    s = _searcher(rule="anemotaxis", outside="wait")
    s.act(_obs(gas), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE)


def test_fluxotaxis_goes_towards_the_most_negative_flux() -> None:
    # wind along +x: the upwind robot (3, normal -x) has flux -rho_3 * 5, the most negative;
    # the strongest robot (1, normal (0.5, 0.87)) has outflowing flux, so only chemotaxis
    # would step towards it
    gas = np.array([0.01, 0.03, 0.02, 0.02, 0.02, 0.01])
    s = _searcher(rule="fluxotaxis")
    s.act(_obs(gas), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE + 0.06 * np.array([-1.0, 0.0]), atol=1e-12)  # eqs. 5-7
    s = _searcher(rule="chemotaxis")
    s.act(_obs(gas), np.random.default_rng(0))
    u = (RING[1] - CENTRE) / np.linalg.norm(RING[1] - CENTRE)
    np.testing.assert_allclose(u, [0.5, math.sqrt(3.0) / 2.0], atol=1e-12)
    np.testing.assert_allclose(s.vr, CENTRE + 0.06 * u, atol=1e-12)


def _source_inside() -> np.ndarray:
    """Readings of a formation around an emitter in a +x wind: high downwind, low upwind."""
    return np.array([0.08, 0.05, 0.006, 0.002, 0.006, 0.05])


def test_declares_after_n_s_steps_of_flux_above_phi_t_and_stops() -> None:
    s = _searcher(rule="anemotaxis", outside="wait", n_s=10)
    rng = np.random.default_rng(0)
    for k in range(9):
        a = s.act(_obs(_source_inside(), t=0.5 * k), rng)
        assert not a.declarations
        assert s.diagnostics()["flux_count"] == k + 1
    a = s.act(_obs(_source_inside(), t=4.5), rng)
    assert len(a.declarations) == 1
    d = a.declarations[0]
    np.testing.assert_allclose(d.positions, [s.vr])
    assert d.agent == 0
    assert all(c.kind == "hold" for c in a.commands)
    assert a.messages[0].declared
    np.testing.assert_allclose(a.messages[0].vr, s.vr)
    assert a.messages[0].nbytes == 17  # two float64 and a flag byte
    later = s.act(_obs(np.zeros(6), t=5.0), rng)
    assert not later.declarations and all(c.kind == "hold" for c in later.commands)
    assert s.final_metrics()["declared_time"] == 4.5
    # a total flux that is high but does not come from a surrounded emitter does not count
    s = _searcher(rule="anemotaxis", outside="wait", n_s=3)
    half = RING.copy()
    half[[2, 3, 4]] += [0.6, 0.0]  # every robot on the downwind side
    for k in range(5):
        a = s.act(_obs(_source_inside(), positions=half, t=0.5 * k), rng)
        assert not a.declarations


def test_listens_to_other_groups_repulsion_and_bypass() -> None:
    near = Message(6, GroupMessage(CENTRE + np.array([-1.0, 0.0]), False))
    s = _searcher(rule="anemotaxis")
    s.act(_obs(np.full(6, 0.01), messages=[near]), np.random.default_rng(0))
    # goal upwind (-x) plus the push away from the group 1 m upwind: they cancel, no step
    np.testing.assert_allclose(s.vr, CENTRE)
    assert s.final_metrics()["repelled_steps"] == 1
    # the same group, located: its forbidden circle (r_T 1.5 m) sends this one around it
    located = Message(6, GroupMessage(CENTRE + np.array([-1.52, 0.01]), True))
    s = _searcher(rule="anemotaxis", repulsion=False)
    s.act(_obs(np.full(6, 0.01), messages=[located]), np.random.default_rng(0))
    assert s.diagnostics()["rotary"] == 1.0
    assert abs(s.vr[1] - CENTRE[1]) == pytest.approx(0.06, abs=1e-3)
    # without the rotary force the step into the circle is refused
    s = _searcher(rule="anemotaxis", repulsion=False, rotary=False)
    s.act(_obs(np.full(6, 0.01), messages=[located]), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE)
    # without the forbidden area the group walks in
    s = _searcher(rule="anemotaxis", repulsion=False, rotary=False, forbidden_area=False)
    s.act(_obs(np.full(6, 0.01), messages=[located]), np.random.default_rng(0))
    np.testing.assert_allclose(s.vr, CENTRE - [0.06, 0.0])


def test_a_searching_group_out_of_range_is_forgotten_a_located_one_kept() -> None:
    rng = np.random.default_rng(0)
    near = Message(6, GroupMessage(CENTRE + np.array([-1.0, 0.0]), False))
    s = _searcher(rule="anemotaxis")
    s.act(_obs(np.full(6, 0.01), messages=[near]), rng)
    np.testing.assert_allclose(s.vr, CENTRE)  # repelled: no step
    # not heard next period (out of range): it has moved on, so no push from where it was
    s.act(_obs(np.full(6, 0.01), t=0.5), rng)
    assert s.diagnostics()["repelled"] == 0.0
    np.testing.assert_allclose(s.vr, CENTRE - [0.06, 0.0])
    # a located group has stopped: its forbidden circle stays closed when it is not heard
    located = Message(6, GroupMessage(CENTRE + np.array([-1.52, 0.01]), True))
    s = _searcher(rule="anemotaxis", repulsion=False)
    s.act(_obs(np.full(6, 0.01), messages=[located]), rng)
    first = s.vr.copy()
    s.act(_obs(np.full(6, 0.01), t=0.5), rng)
    assert s.diagnostics()["rotary"] == 1.0
    # the same sense of rotation: still moving away from the circle's axis, on the same side
    assert np.sign(s.vr[1] - first[1]) == np.sign(first[1] - CENTRE[1])


@pytest.mark.parametrize(
    ("params", "word"),
    [
        ({"s1": 0.12, "s2": 0.12}, "s2"),
        ({"s1": 0.2}, "s2"),
        ({"r_T": 0.2}, "r_T"),
        ({"rotary": True, "forbidden_area": False}, "rotary"),
        ({"rule": "infotaxis"}, "rule"),
    ],
)
def test_bad_parameters_are_refused(params, word) -> None:
    with pytest.raises(ConfigError) as ei:
        registry.make_params("searcher", "virtual-physics", params)
    assert word in str(ei.value)


def test_a_platform_too_slow_to_follow_the_virtual_robot_is_refused() -> None:
    # 0.24 m/s x 0.2 s = 0.048 m per period, less than s1 = 0.06 m: the robots would fall
    # behind their virtual robot at every step
    s = VirtualPhysicsSearcher(VirtualPhysicsParams())
    ctx = SearchContext(
        arena=Arena.box((0.0, 0.0), (20.0, 20.0), 0.2),
        dt=0.2,
        agent_ids=tuple(range(6)),
        start=RING,
        speed_limits=np.full(6, 0.24),
    )
    with pytest.raises(ConfigError) as ei:
        s.reset(ctx, np.random.default_rng(0))
    assert ei.value.field == "limits.control_dt"
    assert "0.048" in ei.value.problem and "s1" in ei.value.problem
    # a reach just above s1 is accepted, s2 capped at it
    s.reset(replace(ctx, dt=0.26), np.random.default_rng(0))
    assert s.s2 == pytest.approx(0.24 * 0.26)


def test_two_groups_find_the_two_sources_in_a_seeded_episode() -> None:
    sc = get_scenario("virtual-physics-two-groups").with_start_set("P2")
    sc = sc.with_overrides(
        {"searcher.member": {"type": "virtual-physics", "rule": "anemotaxis"}, "limits.time": 400.0}
    )
    res = run_episode(sc, 3, 4, record=True)
    m = res.metrics
    assert m["termination"] == "declared" and m["success"]
    assert np.isfinite(m["found_time_0"]) and np.isfinite(m["found_time_1"])
    decl = [e for e in res.events if e.kind == "declaration"]
    assert sorted(e.group for e in decl) == [0, 1]
    found = {e.source: e.group for e in res.events if e.kind == "source_found"}
    assert sorted(found) == [0, 1] and found[0] != found[1]  # different groups, different sources
    assert m["bytes"] > 0  # the groups talk
    # finite footprints: no two robots ever closer than two body radii
    p = res.recording.positions
    d = np.linalg.norm(p[:, :, None, :] - p[:, None, :, :], axis=3)
    d[:, np.arange(12), np.arange(12)] = np.inf
    assert d.min() >= 2 * 0.1 - 1e-9
    again = run_episode(sc, 3, 4, record=True)
    assert np.array_equal(again.recording.positions, p)  # the same seeds, the same episode


def test_a_formation_of_fewer_than_three_robots_is_refused() -> None:
    # the declaration needs the robots around the virtual robot, which two cannot do: such a
    # group would search to the time limit without a word
    from odorloc.scenarios import Scenario

    d = get_scenario("virtual-physics-two-groups").to_dict()
    d["agents"]["groups"][0]["agents"] = [0, 1]
    with pytest.raises(ConfigError, match=r"agents\.groups: .*group 'A' has 2"):
        run_episode(Scenario.from_dict(d), 1, 2)
    # a lone formation driven directly by the searcher
    d = get_scenario("virtual-physics-two-groups").to_dict()
    d["searcher"] = {"type": "virtual-physics"}
    d["agents"] = {"starts": d["agents"]["starts"][:2]}
    with pytest.raises(ConfigError, match=r"agents\.starts: .*at least 3 agents"):
        run_episode(Scenario.from_dict(d), 1, 2)
