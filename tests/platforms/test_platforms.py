"""Tests of the platforms: wheeled kinematics, collisions, UAV timing/energy, team communication."""

from __future__ import annotations

import math

import numpy as np
import pydantic
import pytest

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Command
from odorloc.geometry.arena import Arena
from odorloc.platforms import (
    UAV,
    CommGraph,
    HolonomicParams,
    HolonomicRobot,
    UAVParams,
    UnicycleParams,
    UnicycleRobot,
    free_fraction,
    message_nbytes,
    movement_energy,
    neighbour_matrix,
)

DT = 0.5


def run(pl, cmd, n, arena, dt=DT):
    """Apply ``cmd`` once, then ``None`` for ``n - 1`` more periods."""
    pl.apply(cmd, dt, arena)
    for _ in range(n - 1):
        pl.apply(None, dt, arena)


def steps_until_ready(pl, cmd, arena, dt=DT, limit=10_000):
    """Number of periods until ``pl.ready`` after issuing ``cmd``."""
    pl.apply(cmd, dt, arena)
    n = 1
    while not pl.ready:
        pl.apply(None, dt, arena)
        n += 1
        assert n < limit
    return n


@pytest.fixture
def room():
    return Arena.box((0.0, 0.0), (5.0, 5.0), resolution=0.1)


@pytest.fixture
def room_with_box(room):
    return room.with_boxes([((2.0, 2.0), (3.0, 3.0))])


# ---------------------------------------------------------------------- registry and params
@pytest.mark.parametrize("name", ["holonomic", "unicycle", "uav"])
def test_registered_and_buildable(name):
    e = registry.entry("platform", name)
    pl = e.build(e.params())
    pl.reset((1.0, 1.0))
    assert pl.ready and pl.energy == 0.0 and pl.path_length == 0.0
    assert pl.speed_limit == pytest.approx(1.0 if name == "uav" else 0.22)


@pytest.mark.parametrize(
    ("name", "values", "field"),
    [
        ("holonomic", {"max_speed": -1.0}, "max_speed"),
        ("holonomic", {"radius": -0.1}, "radius"),
        ("holonomic", {"max_sped": 1.0}, "max_sped"),
        ("unicycle", {"max_turn_rate": 0.0}, "max_turn_rate"),
        ("uav", {"speed": 0.0}, "speed"),
        ("uav", {"turn_angle": 4.0}, "turn_angle"),
        ("uav", {"energy_limit": -5.0}, "energy_limit"),
        ("uav", {"hover_time": math.nan}, "hover_time"),
        ("uav", {"transmit_rate": 0.0}, "transmit_rate"),
    ],
)
def test_bad_params_name_field(name, values, field):
    with pytest.raises(ConfigError) as ei:
        registry.make_params("platform", name, values, field="platform")
    assert ei.value.field == f"platform.{field}"


def test_params_models_reject_directly():
    with pytest.raises(pydantic.ValidationError, match="max_speed"):
        HolonomicParams(max_speed=0.0)
    assert UAVParams(energy_limit=math.inf).energy_limit == math.inf


def test_bad_inputs_raise_config_errors(room):
    r = HolonomicRobot()
    with pytest.raises(RuntimeError, match="reset"):
        r.apply(Command.hold(), DT, room)
    with pytest.raises(ConfigError, match="position"):
        r.reset((1.0, 2.0, 3.0, 4.0))
    r.reset((1.0, 1.0))
    with pytest.raises(ConfigError) as ei:
        r.apply(Command.velocity([1.0, 0.0, 0.0]), DT, room)
    assert ei.value.field == "command.value"
    with pytest.raises(ConfigError) as ei:
        r.apply(Command.waypoint([np.nan, 1.0]), DT, room)
    assert ei.value.field == "command.value"
    with pytest.raises(ConfigError) as ei:
        r.apply(Command.hold(), 0.0, room)
    assert ei.value.field == "dt"
    with pytest.raises(ConfigError) as ei:
        r.apply(Command("jump", np.zeros(2)), DT, room)  # type: ignore[arg-type]
    assert ei.value.field == "command.kind"
    r3 = HolonomicRobot()
    r3.reset((1.0, 1.0, 1.0))
    with pytest.raises(ConfigError, match="2D"):
        r3.apply(None, DT, room)


def test_start_inside_obstacle_is_rejected(room_with_box):
    r = HolonomicRobot()
    r.reset((2.5, 2.5))
    with pytest.raises(ConfigError) as ei:
        r.apply(Command.hold(), DT, room_with_box)
    assert ei.value.field == "position"


# ---------------------------------------------------------------------- wheeled kinematics
def test_holonomic_speed_clip_keeps_direction(room):
    r = HolonomicRobot()
    r.reset((1.0, 1.0))
    r.apply(Command.velocity([3.0, 4.0]), DT, room)
    # |v| = 5 m/s clipped to 0.22 m/s along (0.6, 0.8): displacement 0.11 m -> (0.066, 0.088)
    np.testing.assert_allclose(r.position, [1.066, 1.088], atol=1e-12)
    np.testing.assert_allclose(r.velocity, [0.132, 0.176], atol=1e-12)
    assert r.heading == pytest.approx(math.atan2(4.0, 3.0))
    # a slow command is not scaled up; None continues it
    r.apply(Command.velocity([0.1, 0.0]), DT, room)
    r.apply(None, DT, room)
    np.testing.assert_allclose(r.position, [1.166, 1.088], atol=1e-12)
    assert r.path_length == pytest.approx(0.11 + 0.1)
    assert r.ready


def test_holonomic_waypoint_persists_until_reached(room):
    r = HolonomicRobot(HolonomicParams(max_speed=0.2))
    r.reset((1.0, 1.0))
    # 1.0 m at 0.2 m/s = 5 s = 10 periods of 0.5 s
    r.apply(Command.waypoint([2.0, 1.0]), DT, room)
    for k in range(1, 10):
        assert not r.ready
        np.testing.assert_allclose(r.position, [1.0 + 0.1 * k, 1.0], atol=1e-12)
        r.apply(None, DT, room)
    assert r.ready
    np.testing.assert_array_equal(r.position, [2.0, 1.0])
    # re-sending the same waypoint is a no-op, a hold keeps it still
    r.apply(Command.waypoint([2.0, 1.0]), DT, room)
    r.apply(Command.hold(), DT, room)
    np.testing.assert_array_equal(r.position, [2.0, 1.0])
    np.testing.assert_array_equal(r.velocity, [0.0, 0.0])


def test_holonomic_move_target_fixed_at_receipt(room):
    r = HolonomicRobot()
    r.reset((1.0, 1.0))
    # 0.12 m step (virtual-physics robots): 0.11 m in the first period, 0.01 m in the second
    n = steps_until_ready(r, Command.move([0.0, 0.12]), room)
    assert n == 2
    np.testing.assert_allclose(r.position, [1.0, 1.12], atol=1e-12)
    np.testing.assert_allclose(r.velocity, [0.0, 0.02], atol=1e-12)  # average over the period
    n = steps_until_ready(r, Command.move([0.0, 0.12]), room)
    np.testing.assert_allclose(r.position, [1.0, 1.24], atol=1e-12)


def test_holonomic_3d(room):
    a3 = Arena.box((0, 0, 0), (5, 5, 3))
    r = HolonomicRobot()
    r.reset((1.0, 1.0, 1.0))
    r.apply(Command.velocity([0.0, 0.0, 1.0]), DT, a3)
    np.testing.assert_allclose(r.position, [1.0, 1.0, 1.11])


def test_unicycle_turn_rate_then_drive(room):
    r = UnicycleRobot()
    r.reset((1.0, 1.0), heading=0.0)
    r.apply(Command.velocity([0.0, 0.1]), DT, room)
    # pi/2 at 2.84 rad/s needs 0.5531 s > 0.5 s: only turning, 1.42 rad
    assert r.heading == pytest.approx(2.84 * 0.5)
    np.testing.assert_array_equal(r.position, [1.0, 1.0])
    r.apply(None, DT, room)
    # remaining (pi/2 - 1.42) / 2.84 s turning, then 0.1 m/s for the rest of the period
    t_turn = (math.pi / 2 - 1.42) / 2.84
    assert r.heading == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(r.position, [1.0, 1.0 + 0.1 * (0.5 - t_turn)], atol=1e-12)


def test_unicycle_heading_change_bounded_by_turn_rate(room):
    rng = np.random.default_rng(3)
    p = UnicycleParams(max_turn_rate=1.0, max_speed=0.3)
    r = UnicycleRobot(p)
    r.reset((2.5, 2.5), heading=0.3)
    for _ in range(200):
        h0, x0 = r.heading, r.position
        r.apply(Command.velocity(rng.normal(size=2)), DT, room)
        dh = abs(math.remainder(r.heading - h0, 2 * math.pi))
        assert dh <= 1.0 * DT + 1e-12
        assert np.linalg.norm(r.position - x0) <= 0.3 * DT + 1e-12


def test_unicycle_waypoint_time(room):
    r = UnicycleRobot()
    r.reset((1.0, 1.0), heading=0.0)
    # backwards target: half turn pi/2.84 = 1.106 s, then 0.44 m at 0.22 m/s = 2 s -> 3.106 s
    # -> ready in the 7th period (6 periods = 3.0 s are not enough)
    n = steps_until_ready(r, Command.waypoint([0.56, 1.0]), room)
    assert n == 7
    np.testing.assert_allclose(r.position, [0.56, 1.0], atol=1e-12)
    assert abs(r.heading) == pytest.approx(math.pi)


# ---------------------------------------------------------------------- collisions
def test_stops_at_wall(room):
    r = HolonomicRobot()
    r.reset((4.8, 1.0))
    run(r, Command.velocity([0.22, 0.0]), 5, room)
    # free 0.2 m to the wall; the robot stops at it (within one sample, 0.01 m) and stays inside
    assert 4.99 <= r.position[0] <= 5.0
    assert r.position[1] == 1.0
    assert r.collided >= 3  # blocked in periods 2..5
    assert r.path_length == pytest.approx(r.position[0] - 4.8)


def test_waypoint_into_obstacle_ends_ready(room_with_box):
    r = HolonomicRobot()
    r.reset((1.0, 2.5))
    n = steps_until_ready(r, Command.waypoint([2.5, 2.5]), room_with_box)
    # box face at x = 2.0 (cells centred >= 2.05 are occupied: face at 2.0): stops short of it
    assert 1.98 <= r.position[0] <= 2.0
    assert room_with_box.is_free(r.position)[0]
    assert r.collided == 1 and r.blocked
    assert n == math.ceil((r.position[0] - 1.0) / 0.11)


def test_radius_keeps_clearance(room_with_box):
    r = HolonomicRobot(HolonomicParams(radius=0.2))
    r.reset((1.0, 2.5))
    steps_until_ready(r, Command.waypoint([2.5, 2.5]), room_with_box)
    assert 1.78 <= r.position[0] <= 1.8  # the body edge stops at the face x = 2.0
    r.reset((4.5, 1.0))
    run(r, Command.velocity([0.22, 0.0]), 10, room_with_box)
    assert 4.78 <= r.position[0] <= 4.8


def _body_free(arena, pos, radius):
    a = np.linspace(0, 2 * math.pi, 128, endpoint=False)
    ring = pos + radius * np.column_stack([np.cos(a), np.sin(a)])
    return bool(arena.is_free(pos)[0] and arena.is_free(ring).all())


def _random_rollout(robot, arena, seed, n=250):
    rng = np.random.default_rng(seed)
    traj = []
    for _ in range(n):
        u = rng.random()
        if u < 0.5:
            cmd = Command.velocity(rng.normal(scale=0.3, size=2))
        elif u < 0.7:
            cmd = Command.waypoint(rng.uniform(-1.0, 6.0, size=2))  # some outside the room
        elif u < 0.9:
            cmd = Command.move(rng.normal(scale=1.0, size=2))
        else:
            cmd = None
        robot.apply(cmd, DT, arena)
        traj.append(robot.position)
    return np.array(traj)


@pytest.mark.parametrize("cls", [HolonomicRobot, UnicycleRobot])
@pytest.mark.parametrize("radius", [0.0, 0.15])
def test_random_commands_never_enter_obstacles(cls, radius):
    arena = Arena.box((0, 0), (4, 4), 0.1).with_boxes(
        [((1.0, 1.0), (1.6, 2.8)), ((2.4, 0.0), (3.0, 1.5)), ((2.5, 2.5), (3.5, 3.0))]
    )
    params = (UnicycleParams if cls is UnicycleRobot else HolonomicParams)(
        radius=radius, max_speed=0.5
    )
    robot = cls(params)
    robot.reset((0.5, 0.5))
    traj = _random_rollout(robot, arena, seed=11)
    # outline sampled every half cell, motion every 0.01 m: tolerate 0.015 m of overlap
    check_r = max(radius - 0.015, 0.0)
    assert all(_body_free(arena, p, check_r) for p in traj)
    assert robot.collided > 0  # the rollout did push against walls/obstacles
    assert robot.path_length > 5.0
    # same commands -> identical trajectory
    robot2 = cls(params)
    robot2.reset((0.5, 0.5))
    np.testing.assert_array_equal(traj, _random_rollout(robot2, arena, seed=11))


def test_energy_per_metre(room):
    r = HolonomicRobot(HolonomicParams(energy_per_metre=10.0))
    r.reset((1.0, 1.0))
    steps_until_ready(r, Command.waypoint([2.0, 1.0]), room)
    assert r.energy == pytest.approx(10.0)  # 1 m * 10 J/m
    assert r.energy_breakdown() == {"move": pytest.approx(10.0)}
    assert not r.exhausted


# ---------------------------------------------------------------------- UAV
@pytest.fixture
def sky():
    return Arena.box((0.0, 0.0, 0.0), (60.0, 60.0, 30.0), resolution=1.0)


def test_uav_timing_and_energy(sky):
    u = UAV()
    u.reset((10.0, 10.0, 5.0))
    # leg 1: 10 m at 1 m/s + 1 s hover = 11 s = 22 periods (first flight: no turn)
    n1 = steps_until_ready(u, Command.waypoint([20.0, 10.0, 5.0]), sky)
    assert n1 == 22
    # leg 2: direction changes by 90 deg -> 1 s turn + 5 m / 1 m/s + 1 s hover = 7 s = 14 periods
    n2 = steps_until_ready(u, Command.move([0.0, 5.0, 0.0]), sky)
    assert n2 == 14
    # leg 3: same direction again -> no turn: 3 m + 1 s hover = 4 s = 8 periods
    n3 = steps_until_ready(u, Command.move([0.0, 3.0, 0.0]), sky)
    assert n3 == 8
    np.testing.assert_allclose(u.position, [20.0, 18.0, 5.0], atol=1e-12)
    s = u.stats
    assert s["fly_time"] == pytest.approx(18.0)
    assert s["hover_time"] == pytest.approx(3.0)
    assert s["turn_time"] == pytest.approx(1.0)
    assert (s["n_turns"], s["n_hovers"]) == (1.0, 3.0)
    assert s["distance"] == pytest.approx(18.0)
    e = u.energy_breakdown()
    # fly: 663 W * 18 s = 11934 J (eq. 4); hover: 470 W * 3 * 1 s = 1410 J (eq. 5);
    # turn: 1 * 3415 J (eq. 6) -> E_M = 16759 J
    assert e["fly"] == pytest.approx(11934.0)
    assert e["hover"] == pytest.approx(1410.0)
    assert e["turn"] == pytest.approx(3415.0)
    assert u.movement_energy == pytest.approx(16759.0)
    assert u.energy == pytest.approx(16759.0)
    assert u.movement_energy == pytest.approx(movement_energy(u.params, 18.0, 3, 1))
    # the paper's search time of a UAV (fly + hover + turn, Sect. VI.1) and E_M in the stats
    assert s["fly_hover_turn_time"] == pytest.approx(18.0 + 3.0 + 1.0)
    assert s["movement_energy"] == pytest.approx(16759.0)
    u.charge_comm(1000.0)
    u.charge_compute(1e9)
    # radio and computation stay apart from the movement energy
    assert u.stats["movement_energy"] == pytest.approx(16759.0)
    assert u.energy > u.stats["movement_energy"]


def test_uav_phases_span_periods(sky):
    u = UAV(UAVParams(turn_time=1.0, hover_time=1.0))
    u.reset((10.0, 10.0, 5.0))
    steps_until_ready(u, Command.waypoint([11.0, 10.0, 5.0]), sky)
    u.apply(Command.waypoint([11.0, 10.6, 5.0]), DT, sky)  # turn 0.5 / 1 s
    np.testing.assert_array_equal(u.position, [11.0, 10.0, 5.0])
    assert not u.ready
    u.apply(None, DT, sky)  # turn done
    np.testing.assert_array_equal(u.position, [11.0, 10.0, 5.0])
    u.apply(None, DT, sky)  # fly 0.5 m
    np.testing.assert_allclose(u.position, [11.0, 10.5, 5.0])
    np.testing.assert_allclose(u.velocity, [0.0, 1.0, 0.0])
    u.apply(None, DT, sky)  # fly 0.1 m then hover 0.4 s
    np.testing.assert_allclose(u.position, [11.0, 10.6, 5.0])
    np.testing.assert_allclose(u.velocity, [0.0, 0.2, 0.0])
    u.apply(None, DT, sky)  # hover 0.5 s (0.9 s in all)
    assert not u.ready
    u.apply(None, DT, sky)  # hover 0.1 s, then idle
    assert u.ready
    assert u.stats["hover_time"] == pytest.approx(2.0)
    assert u.stats["idle_time"] == pytest.approx(0.4)
    assert u.energy_breakdown()["idle"] == 0.0  # idle_power defaults to 0


def test_uav_turn_counting(sky):
    u = UAV()
    u.reset((30.0, 30.0, 10.0))
    steps_until_ready(u, Command.move([1.0, 0.0, 0.0]), sky)
    steps_until_ready(u, Command.move([1.0, 0.01, 0.0]), sky)  # 0.57 deg < 1 deg: no turn
    assert u.stats["n_turns"] == 0
    steps_until_ready(u, Command.move([-1.0, 0.0, 0.0]), sky)  # reversal
    steps_until_ready(u, Command.move([0.0, 0.0, 1.0]), sky)  # climb
    steps_until_ready(u, Command.move([0.0, 0.0, 0.0]), sky)  # hover only, keeps direction
    steps_until_ready(u, Command.move([0.0, 0.0, 2.0]), sky)  # same direction: no turn
    assert u.stats["n_turns"] == 2
    assert u.stats["n_hovers"] == 6
    assert u.energy_breakdown()["turn"] == pytest.approx(2 * 3415.0)


def test_uav_resent_waypoint_does_not_restart(sky):
    u = UAV()
    u.reset((10.0, 10.0, 5.0))
    n = 0
    while True:  # a searcher re-issuing its target every period
        u.apply(Command.waypoint([13.0, 10.0, 5.0]), DT, sky)
        n += 1
        if u.ready:
            break
    assert n == 8  # 3 s flight + 1 s hover
    u.apply(Command.waypoint([13.0, 10.0, 5.0]), DT, sky)
    assert u.stats["n_hovers"] == 1 and u.stats["hover_time"] == pytest.approx(1.0)


def test_uav_velocity_command_and_2d():
    a2 = Arena.box((0.0, 0.0), (100.0, 60.0), 1.0)
    u = UAV()
    u.reset((10.0, 10.0), heading=0.0)
    run(u, Command.velocity([3.0, 0.0]), 4, a2)  # clipped to 1 m/s, 2 s
    np.testing.assert_allclose(u.position, [12.0, 10.0])
    assert u.ready
    run(u, Command.velocity([0.0, -0.5]), 4, a2)  # turn 1 s, then 1 s at 0.5 m/s
    np.testing.assert_allclose(u.position, [12.0, 9.5])
    assert u.heading == pytest.approx(-math.pi / 2)
    # fly: 663 W * (2 s + 1 s) = 1989 J, turn 3415 J, no hover for velocity commands
    assert u.energy == pytest.approx(1989.0 + 3415.0)


def test_uav_table2_movement_energy():
    p = UAVParams()
    # Table 2, multi-UAV paper, with 1 s per turn and per hover:
    # Col-Inf: 893 m * 0.663 + 261 * 0.47 + 223 * 3.415 = 592.059 + 122.67 + 761.545 = 1476.274 kJ
    assert movement_energy(p, 893.0, 261, 223) / 1e3 == pytest.approx(1476.27, abs=0.01)
    # MUC-OSL: 907 * 0.663 + 216 * 0.47 + 190 * 3.415 = 601.341 + 101.52 + 648.85 = 1351.711 kJ
    assert movement_energy(p, 907.0, 216, 190) / 1e3 == pytest.approx(1351.71, abs=0.01)


@pytest.mark.parametrize(
    ("args", "field"),
    [
        ((-10.0, 1, 0), "distance"),
        ((10.0, -1, 0), "n_hovers"),
        ((10.0, 1, math.nan), "n_turns"),
        ((math.inf, 1, 0), "distance"),
    ],
)
def test_movement_energy_refuses_negative_or_non_finite_amounts(args, field):
    with pytest.raises(ConfigError) as ei:
        movement_energy(UAVParams(), *args)
    assert ei.value.field == field


def test_uav_compute_and_comm_energy():
    u = UAV()
    u.reset((1.0, 1.0, 1.0))
    # eq. (8): 96 bytes = 768 bits; 0.1 W * 768 / 1e6 bit/s = 7.68e-5 J
    assert u.charge_comm(96) == pytest.approx(7.68e-5)
    # eq. (7): 1e28^-1 * 1000 * (1e9)^2 * 1e6 bits = 0.1 J
    assert u.charge_compute(1e6) == pytest.approx(0.1)
    # 1 ms of CPU at 1 GHz = 1e6 cycles = 1000 bits -> 1e-4 J
    assert u.charge_compute_time(1e-3) == pytest.approx(1e-4)
    e = u.energy_breakdown()
    assert e["comm"] == pytest.approx(7.68e-5)
    assert e["compute"] == pytest.approx(0.1001)
    assert u.energy == pytest.approx(0.1001 + 7.68e-5)
    with pytest.raises(ConfigError, match="nbytes"):
        u.charge_comm(-1)


def test_uav_energy_limit(sky):
    u = UAV(UAVParams(energy_limit=5000.0))
    u.reset((10.0, 10.0, 5.0))
    run(u, Command.velocity([1.0, 0.0, 0.0]), 20, sky)
    # 5000 J / 663 W = 7.541 s of flight -> 7.541 m, then it stops for good
    assert u.exhausted
    assert u.energy == pytest.approx(5000.0)
    np.testing.assert_allclose(u.position, [10.0 + 5000.0 / 663.0, 10.0, 5.0])
    x = u.position
    u.apply(Command.waypoint([30.0, 30.0, 5.0]), DT, sky)
    np.testing.assert_array_equal(u.position, x)
    assert u.ready
    # a turn the budget cannot pay for exhausts at once
    v = UAV(UAVParams(energy_limit=4000.0))
    v.reset((10.0, 10.0, 5.0))
    steps_until_ready(v, Command.move([0.5, 0.0, 0.0]), sky)  # 331.5 + 470 = 801.5 J
    v.apply(Command.move([0.0, 1.0, 0.0]), DT, sky)  # turn needs 3415 J > 3198.5 J left
    assert v.exhausted and v.energy == pytest.approx(4000.0)


def test_uav_idle_power(sky):
    u = UAV(UAVParams(idle_power=470.0))
    u.reset((10.0, 10.0, 5.0))
    run(u, Command.hold(), 4, sky)
    assert u.energy_breakdown()["idle"] == pytest.approx(470.0 * 2.0)
    assert u.stats["idle_time"] == pytest.approx(2.0)


def test_uav_blocked_hovers_and_is_ready():
    a = Arena.box((0.0, 0.0, 0.0), (20.0, 20.0, 10.0), 0.5).with_boxes(
        [((8.0, 0.0, 0.0), (10.0, 20.0, 10.0))]
    )
    u = UAV()
    u.reset((5.0, 5.0, 5.0))
    steps_until_ready(u, Command.waypoint([15.0, 5.0, 5.0]), a)
    assert 7.9 <= u.position[0] <= 8.0
    assert u.collided == 1
    assert u.stats["n_hovers"] == 1
    assert u.energy_breakdown()["fly"] == pytest.approx(663.0 * (u.position[0] - 5.0))


# ---------------------------------------------------------------------- team communication
def _gauss_payload():
    return {"mean": np.zeros(3), "cov": np.eye(3)}  # 12 float64 = 96 bytes


def test_message_nbytes():
    assert message_nbytes(_gauss_payload()) == 96
    assert message_nbytes({"x": np.zeros((100, 4), np.float32)}) == 1600
    assert message_nbytes({}) == 0


def test_chain_graph_and_byte_accounting():
    pos = np.column_stack([np.arange(5) * 1.0, np.zeros(5)])  # chain, 1 m apart
    g = CommGraph(1.0)
    adj = g.update(pos)
    expected = np.zeros((5, 5), bool)
    for i in range(4):
        expected[i, i + 1] = expected[i + 1, i] = True
    np.testing.assert_array_equal(adj, expected)
    np.testing.assert_array_equal(g.degree(), [1, 2, 2, 2, 1])
    np.testing.assert_array_equal(g.neighbours(2), [1, 3])
    np.testing.assert_array_equal(CommGraph(2.0).update(pos).sum(axis=1), [2, 3, 4, 3, 2])

    msgs = {k: _gauss_payload() for k in range(5)}
    inbox, nbytes = g.deliver(pos, msgs)
    # 96 bytes * (1 + 2 + 2 + 2 + 1) recipients = 768 bytes
    assert nbytes == 768 and g.bytes_total == 768
    np.testing.assert_array_equal(g.bytes_sent, [96, 192, 192, 192, 96])
    np.testing.assert_array_equal(g.bytes_received, [96, 192, 192, 192, 96])
    assert [m.sender for m in inbox[2]] == [1, 3]
    assert [m.sender for m in inbox[0]] == [1]
    assert g.messages_delivered == 8
    assert g.bytes_sent_by(1, pos, msgs) == 192
    assert g.bytes_sent_by(4) == 96
    # only agent 2 talks next: it reaches 1 and 3
    inbox, nbytes = g.deliver(pos, {2: {"w": np.ones(10)}})
    assert nbytes == 160 and g.bytes_total == 928
    assert [len(b) for b in inbox] == [0, 1, 0, 1, 0]
    np.testing.assert_array_equal(inbox[1][0].payload["w"], np.ones(10))
    # computed for other positions without touching the accounting
    far = pos * 10.0
    assert g.bytes_sent_by(2, far, msgs) == 0
    assert g.bytes_total == 928


def test_delivery_without_messages_keeps_the_graph_and_the_accounting():
    pos = np.column_stack([np.arange(5) * 1.0, np.zeros(5)])
    g = CommGraph(1.0)
    g.deliver(pos, {0: _gauss_payload()})
    inbox, nbytes = g.deliver(pos * 2.0, {})
    assert nbytes == 0 and inbox == [()] * 5 and g.bytes_total == 96
    # the graph of the last delivery, computed when asked for
    np.testing.assert_array_equal(g.adjacency, neighbour_matrix(pos * 2.0, 1.0))
    np.testing.assert_array_equal(g.degree(), [0, 0, 0, 0, 0])
    assert g.bytes_sent_by(0) == 0
    np.testing.assert_array_equal(g.bytes_sent, [96, 0, 0, 0, 0])
    with pytest.raises(ConfigError, match="positions"):
        g.deliver(np.zeros(3), {})
    with pytest.raises(ConfigError, match="team size"):
        g.deliver(np.zeros((4, 2)), {})


def test_comm_radius_zero_and_inf():
    pos = np.zeros((3, 2))  # co-located
    g0 = CommGraph(0.0)
    inbox, nbytes = g0.deliver(pos, {0: _gauss_payload()})
    assert nbytes == 0 and all(len(b) == 0 for b in inbox)
    ginf = CommGraph(math.inf)
    far = np.array([[0.0, 0.0], [1e6, 0.0], [0.0, 1e6]])
    inbox, nbytes = ginf.deliver(far, {0: _gauss_payload()})
    assert nbytes == 192 and [len(b) for b in inbox] == [0, 1, 1]


def test_neighbour_matrix_vectorised_matches_loop():
    rng = np.random.default_rng(5)
    pos = rng.uniform(0, 10, size=(30, 3))
    adj = neighbour_matrix(pos, 3.0)
    ref = np.array(
        [[i != j and np.linalg.norm(pos[i] - pos[j]) <= 3.0 for j in range(30)] for i in range(30)]
    )
    np.testing.assert_array_equal(adj, ref)


def test_comm_bad_input():
    with pytest.raises(ConfigError) as ei:
        CommGraph(-1.0)
    assert ei.value.field == "comm_radius"
    g = CommGraph(1.0)
    with pytest.raises(ConfigError, match="sender"):
        g.deliver(np.zeros((2, 2)), {5: _gauss_payload()})
    g.update(np.zeros((2, 2)))
    with pytest.raises(ConfigError, match="team size"):
        g.update(np.zeros((3, 2)))


def test_neighbour_matrix_refuses_a_bad_radius_or_position():
    pos = np.array([[0.0, 0.0], [0.5, 0.0]])
    for radius in (-1.0, math.nan):
        with pytest.raises(ConfigError) as ei:
            neighbour_matrix(pos, radius)  # -1 used to connect agents within 1 m
        assert ei.value.field == "radius"
    lost = np.array([[0.0, 0.0], [np.nan, 0.0], [0.5, 0.0]])
    for radius in (1.0, math.inf):
        with pytest.raises(ConfigError, match="agent 1") as ei:
            neighbour_matrix(lost, radius)  # used to cut agent 1 off (or connect it, with inf)
        assert ei.value.field == "positions"
    g = CommGraph(1.0)
    for msgs in ({}, {0: _gauss_payload()}):
        with pytest.raises(ConfigError) as ei:
            g.deliver(lost, msgs)
        assert ei.value.field == "positions"


def test_payload_values_must_be_arrays_of_numbers():
    g = CommGraph(math.inf)
    pos = np.zeros((2, 3))
    nested = {"fit": {"mean": np.zeros(3), "cov": np.eye(3)}}  # 96 bytes of numbers
    with pytest.raises(ConfigError) as ei:
        g.deliver(pos, {0: nested})  # used to be delivered and counted as 8 bytes
    assert ei.value.field == "messages[0].fit"
    with pytest.raises(ConfigError) as ei:
        g.deliver(pos, {1: {"parts": [np.zeros(3), np.zeros(5)]}})  # ragged
    assert ei.value.field == "messages[1].parts"
    with pytest.raises(ConfigError) as ei:
        message_nbytes(nested)
    assert ei.value.field == "payload.fit"
    assert g.bytes_total == 0 and g.messages_delivered == 0
    # numbers, flags and bytes are counted as they are
    assert message_nbytes({"flag": np.array([True]), "tag": np.array(b"abc")}) == 4
    assert g.deliver(pos, {0: {"x": [1.0, 2.0]}})[1] == 16


def test_agent_indices_are_checked():
    pos = np.column_stack([np.arange(3) * 1.0, np.zeros(3)])
    g = CommGraph(1.0)
    g.deliver(pos, {2: _gauss_payload()})
    assert g.bytes_sent_by(2) == 96
    for bad in (-1, 3, True):
        with pytest.raises(ConfigError) as ei:
            g.bytes_sent_by(bad)  # -1 used to answer for agent 2
        assert ei.value.field == "agent"
        with pytest.raises(ConfigError) as ei:
            g.neighbours(bad)
        assert ei.value.field == "agent"
        with pytest.raises(ConfigError) as ei:
            g.bytes_sent_by(bad, pos, {2: _gauss_payload()})
        assert ei.value.field == "agent"
    with pytest.raises(ConfigError, match="sender"):
        g.deliver(pos, {True: _gauss_payload()})  # not read as agent 1


def test_delivered_payload_is_a_copy():
    g = CommGraph(math.inf)
    data = np.zeros(3)
    inbox, _ = g.deliver(np.zeros((2, 2)), {0: {"x": data}})
    data[:] = 7.0
    np.testing.assert_array_equal(inbox[1][0].payload["x"], np.zeros(3))


def test_free_fraction_empty_box_matches_sampling():
    a = Arena.box((0.0, 0.0), (5.0, 5.0), 0.1)
    rng = np.random.default_rng(2)
    starts = rng.uniform(0.0, 5.0, size=(200, 2))
    ends = starts + rng.normal(scale=2.0, size=(200, 2))
    exact = np.array([free_fraction(a, s, e) for s, e in zip(starts, ends, strict=True)])
    sampled = a.first_hit(starts, ends)
    # sampling stops at the last sample before the wall: at most 0.1 * resolution short
    lengths = np.linalg.norm(ends - starts, axis=1)
    assert np.all(exact >= sampled - 1e-12)
    assert np.all((exact - sampled) * lengths <= 0.01 + 1e-9)
    assert np.mean(exact < 1.0) > 0.2  # many segments do hit a wall


def test_radius_in_empty_room_and_3d_ceiling(room):
    r = HolonomicRobot(HolonomicParams(radius=0.2))
    r.reset((4.5, 1.0))
    run(r, Command.velocity([0.22, 0.22]), 10, room)
    assert r.position[0] == pytest.approx(4.8)  # x wall at 5.0 minus the radius
    assert r.blocked
    run(r, Command.velocity([-0.22, 0.0]), 2, room)  # it can drive away from the wall
    assert r.position[0] == pytest.approx(4.8 - 0.22)
    u = UAV()
    u.reset((5.0, 5.0, 28.0))
    steps_until_ready(u, Command.waypoint([5.0, 5.0, 35.0]), Arena.box((0, 0, 0), (10, 10, 30)))
    np.testing.assert_allclose(u.position, [5.0, 5.0, 30.0])
    assert u.collided == 1 and u.energy_breakdown()["fly"] == pytest.approx(663.0 * 2.0)


def test_unicycle_in_3d_stays_at_its_height():
    a3 = Arena.box((0, 0, 0), (5, 5, 3))
    r = UnicycleRobot()
    r.reset((1.0, 1.0, 0.2), heading=0.0)
    n = steps_until_ready(r, Command.waypoint([2.1, 1.0, 2.0]), a3)
    assert n == 10  # 1.1 m at 0.22 m/s = 5 s, no turn; the target height is ignored
    np.testing.assert_allclose(r.position, [2.1, 1.0, 0.2], atol=1e-12)
    r.apply(Command.velocity([0.0, 0.0, 1.0]), DT, a3)  # purely vertical: nothing to do
    np.testing.assert_allclose(r.position, [2.1, 1.0, 0.2], atol=1e-12)
