"""Finite footprints: bodies with a radius never pass through each other."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import small_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.core.types import Action, Command
from odorloc.engine.episode import Episode
from odorloc.geometry.arena import Arena
from odorloc.platforms import UAV, HolonomicParams, HolonomicRobot, UAVParams
from odorloc.platforms.base import body_contact_fraction
from odorloc.scenarios import Scenario


def test_contact_fraction_hand_computed() -> None:
    start, end = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    # head on: contact when the centres are 0.1 + 0.2 apart, at x = 0.7
    f = body_contact_fraction(start, end, 0.1, np.array([[1.0, 0.0]]), np.array([0.2]))
    assert f == pytest.approx(0.7)
    # passing 0.3 m to the side of a body with combined radius 0.3: grazing, no contact
    assert body_contact_fraction(start, end, 0.1, np.array([[0.5, 0.31]]), np.array([0.2])) == 1.0
    # off-centre: |(s, 0) - (0.5, 0.2)| = 0.3 at s = 0.5 - sqrt(0.05)
    f = body_contact_fraction(start, end, 0.1, np.array([[0.5, 0.2]]), np.array([0.2]))
    assert f == pytest.approx(0.5 - math.sqrt(0.09 - 0.04))
    # the nearest of several bodies counts; bodies behind or out of reach do not
    c = np.array([[0.8, 0.0], [0.5, 0.0], [-0.4, 0.0], [5.0, 5.0]])
    assert body_contact_fraction(start, end, 0.1, c, np.full(4, 0.1)) == pytest.approx(0.3)
    # touching: moving closer is refused, moving away or along is free
    touch = np.array([[0.2, 0.0]])
    assert body_contact_fraction(start, end, 0.1, touch, np.array([0.1])) == 0.0
    assert body_contact_fraction(start, -end, 0.1, touch, np.array([0.1])) == 1.0
    assert body_contact_fraction(start, np.array([0.0, 1.0]), 0.1, touch, np.array([0.1])) == 1.0
    assert body_contact_fraction(start, start, 0.1, touch, np.array([0.1])) == 1.0
    assert body_contact_fraction(start, end, 0.1, np.zeros((0, 2)), np.zeros(0)) == 1.0


def test_platform_stops_at_another_body_and_becomes_ready() -> None:
    arena = Arena.box((0.0, 0.0), (5.0, 5.0), 0.1)
    pl = HolonomicRobot(HolonomicParams(max_speed=1.0, radius=0.1))
    pl.reset([1.0, 1.0])
    other = (np.array([[2.0, 1.0]]), np.array([0.1]))
    pl.apply(Command.waypoint([3.0, 1.0]), 1.0, arena, bodies=other)
    np.testing.assert_allclose(pl.position, [1.8, 1.0])
    assert pl.ready and pl.blocked and pl.collided == 1
    pl.apply(Command.waypoint([3.0, 1.0]), 1.0, arena, bodies=other)  # still in the way
    np.testing.assert_allclose(pl.position, [1.8, 1.0])
    pl.apply(Command.waypoint([1.8, 2.5]), 1.0, arena, bodies=other)  # sliding away is free
    np.testing.assert_allclose(pl.position, [1.8, 2.0])


def test_resent_waypoint_is_retried_once_the_blocking_body_has_gone() -> None:
    arena = Arena.box((0.0, 0.0), (5.0, 5.0), 0.1)
    pl = HolonomicRobot(HolonomicParams(max_speed=1.0, radius=0.1))
    pl.reset([1.0, 1.0])
    other = (np.array([[2.0, 1.0]]), np.array([0.1]))
    pl.apply(Command.waypoint([3.0, 1.0]), 1.0, arena, bodies=other)
    assert pl.ready and pl.blocked
    # the other body has moved on; the searcher re-issues its target every period
    pl.apply(Command.waypoint([3.0, 1.0]), 1.0, arena)
    np.testing.assert_allclose(pl.position, [2.8, 1.0])
    assert not pl.ready and not pl.blocked
    pl.apply(Command.waypoint([3.0, 1.0]), 1.0, arena)
    np.testing.assert_allclose(pl.position, [3.0, 1.0])
    assert pl.ready and pl.collided == 1


def test_uav_blocked_by_a_body_finishes_its_hover_then_retries() -> None:
    sky = Arena.box((0.0, 0.0, 0.0), (20.0, 20.0, 10.0), 1.0)
    u = UAV(UAVParams(radius=0.5))
    u.reset([5.0, 5.0, 5.0])
    other = (np.array([[6.5, 5.0, 5.0]]), np.array([0.5]))
    target = Command.waypoint([10.0, 5.0, 5.0])
    u.apply(target, 1.0, sky, bodies=other)  # 0.5 m flown, blocked, 0.5 s of hover
    np.testing.assert_allclose(u.position, [5.5, 5.0, 5.0])
    assert not u.ready
    u.apply(target, 1.0, sky)  # re-sent during the hover: the hover goes on
    np.testing.assert_allclose(u.position, [5.5, 5.0, 5.0])
    assert u.ready and u.stats["n_hovers"] == 1 and u.stats["hover_time"] == pytest.approx(1.0)
    steps = 0
    while True:  # re-sent once ready: a new attempt, straight on (no turn)
        u.apply(target, 1.0, sky)
        steps += 1
        if u.ready:
            break
    assert steps == 6  # 4.5 m and a 1 s hover
    np.testing.assert_allclose(u.position, [10.0, 5.0, 5.0])
    assert u.stats["n_turns"] == 0 and u.stats["n_hovers"] == 2


def _two_robots(radius: float) -> Scenario:
    d = small_scenario_dict("passive")
    d["agents"] = {"starts": [[2.0, 2.5], [6.0, 2.5], [4.0, 1.0]]}
    d["platform"] = {"type": "holonomic", "max_speed": 0.5, "radius": radius}
    d["limits"]["time"] = 20.0
    return Scenario.from_dict(d)


def test_robots_crossing_head_on_never_overlap() -> None:
    ep = Episode(_two_robots(0.2), record=False)
    ep.reset(1, 2)
    gaps = []
    while not ep.done:
        pos = np.array([pl.position for pl in ep.platforms])
        gaps.append(np.linalg.norm(pos[:, None] - pos[None], axis=2)[np.triu_indices(3, 1)])
        # 0 and 1 swap places, 2 drives through the meeting point
        cmds = [
            Command.waypoint([6.0, 2.5]),
            Command.waypoint([2.0, 2.5]),
            Command.waypoint([4.0, 4.0]),
        ]
        ep.step(Action(cmds))
    assert np.min(gaps) >= 0.4 - 1e-9
    assert any(pl.collided for pl in ep.platforms)
    # point robots (radius 0) pass through each other as before
    ep = Episode(_two_robots(0.0), record=False)
    ep.reset(1, 2)
    while not ep.done:
        ep.step(Action([Command.waypoint([6.0, 2.5]), Command.waypoint([2.0, 2.5]), None]))
    np.testing.assert_allclose(ep.platforms[0].position, [6.0, 2.5])
    np.testing.assert_allclose(ep.platforms[1].position, [2.0, 2.5])


def test_overlapping_start_bodies_are_refused() -> None:
    d = small_scenario_dict("passive")
    d["agents"] = {"starts": [[2.0, 2.5], [2.3, 2.5]]}
    d["platform"] = {"type": "holonomic", "radius": 0.2}
    with pytest.raises(ConfigError) as ei:
        Episode(Scenario.from_dict(d))
    assert ei.value.field == "agents.starts[1]"
    assert "overlap" in ei.value.problem
    d["platform"] = {"type": "holonomic", "radius": 0.1}
    Episode(Scenario.from_dict(d))  # 0.3 m apart, bodies of 0.1 m: fine


def test_body_free_is_the_disc_or_ball_against_the_cells() -> None:
    room = Arena.box((0.0, 0.0), (10.0, 5.0), 0.1).with_boxes([((4.0, 1.0), (5.0, 4.0))])
    # 0.3 m and 0.25 m left of the box face; 0.2 m and 0.25 m left of and below its corner
    # (0.28 m and 0.35 m away)
    pts = [[3.7, 2.5], [3.75, 2.5], [3.8, 0.8], [3.75, 0.75]]
    assert room.body_free(pts, 0.3).tolist() == [True, False, False, True]
    assert room.body_free(pts, 0.0).tolist() == [True] * 4
    assert room.body_free([[4.5, 2.5]], 0.1).tolist() == [False]  # in the box itself
    cube = Arena.box((0.0, 0.0, 0.0), (4.0, 4.0, 2.0), 0.1).with_boxes(
        [((1.0, 1.0, 0.0), (2.0, 2.0, 1.0))]
    )
    # above the cube's top face (z = 1.0), 0.25 m or 0.15 m clear of it
    assert cube.body_free([[1.5, 1.5, 1.25], [1.5, 1.5, 1.15]], 0.2).tolist() == [True, False]


@pytest.mark.parametrize(
    "start, boxes, problem",
    [
        ([8.0, 2.0], [[[8.1, 1.0], [9.0, 3.0]]], "too close to an obstacle"),
        ([7.9, 2.0], [[[8.1, 1.0], [9.0, 3.0]]], "too close to an obstacle"),
        ([9.9, 2.0], [], "from the arena's edge"),
        ([8.0, 0.1], [], "from the arena's edge"),
    ],
)
def test_a_start_body_inside_a_wall_is_refused(start, boxes, problem) -> None:
    d = small_scenario_dict("passive")
    d["agents"] = {"starts": [[2.0, 2.5], start]}
    d["platform"] = {"type": "holonomic", "radius": 0.3}
    d["world"]["arena"]["obstacles"] = {"boxes": boxes}
    with pytest.raises(ConfigError) as ei:
        Episode(Scenario.from_dict(d))
    assert ei.value.field == "agents.starts[1]"
    assert problem in ei.value.problem and "radius 0.3 m" in ei.value.problem
    # the same start with a point body, or far enough off, is fine
    d["platform"] = {"type": "holonomic", "radius": 0.0}
    Episode(Scenario.from_dict(d))
    d["platform"] = {"type": "holonomic", "radius": 0.1}
    Episode(Scenario.from_dict(d))
