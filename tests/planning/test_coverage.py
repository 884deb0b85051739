"""Rectangular-wave coverage around obstacles: every reachable stretch of a lane is swept."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from helpers import small_scenario_dict
from odorloc.engine.episode import Episode
from odorloc.geometry.arena import Arena
from odorloc.planning.coverage import free_stretches, route_around_obstacles, wave_waypoints
from odorloc.scenarios import Scenario

REGION = ((0.0, 0.0), (10.0, 5.0))
BOX = ((3.0, 1.5), (5.0, 3.5))  # cuts the lane x = 4 between y = 1.5 and 3.5


def _on_path(path: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance of each point to the polyline ``path``, metres."""
    a, b = path[:-1], path[1:]
    d = b - a
    t = np.clip(
        np.einsum("qkd,kd->qk", pts[:, None] - a, d) / np.maximum((d * d).sum(axis=1), 1e-300),
        0.0,
        1.0,
    )
    near = a + t[..., None] * d
    return np.linalg.norm(pts[:, None] - near, axis=2).min(axis=1)


def test_free_paths_are_left_as_they_are() -> None:
    start = (0.5, 0.5)
    corners = wave_waypoints(REGION, 2.0, "y", 2, start)
    empty = Arena.box(*REGION, 0.1)
    assert route_around_obstacles(empty, corners, start) is corners
    np.testing.assert_array_equal(wave_waypoints(REGION, 2.0, "y", 2, start, arena=empty), corners)
    # an obstacle off every lane changes nothing either
    aside = empty.with_boxes([((0.5, 1.0), (1.5, 2.0))])
    np.testing.assert_array_equal(route_around_obstacles(aside, corners, start), corners)


def test_a_lane_cut_by_an_obstacle_is_swept_on_both_sides() -> None:
    start = np.array([0.5, 0.5])
    arena = Arena.box(*REGION, 0.1).with_boxes([BOX])
    corners = wave_waypoints(REGION, 2.0, "y", 1, start)
    path = route_around_obstacles(arena, corners, start)
    legs = np.vstack([start, path])
    assert arena.segment_free(legs[:-1], legs[1:]).all()
    # every free point of every lane lies on the path (to within the quarter-cell sampling)
    for x in (0.0, 2.0, 4.0, 6.0, 8.0, 10.0):
        lane = np.column_stack([np.full(101, x), np.linspace(0.0, 5.0, 101)])
        free = lane[arena.is_free(lane)]
        assert _on_path(path, free).max() <= 0.03, x
    # the stretches of the cut lane, in order
    pieces = free_stretches(arena, (4.0, 0.0), (4.0, 5.0))
    assert len(pieces) == 2
    assert pieces[0][1][1] == pytest.approx(1.475) and pieces[1][0][1] == pytest.approx(3.5)


def test_a_stretch_that_cannot_be_reached_is_left_out() -> None:
    start = np.array([0.5, 0.5])
    # a closed pen around (4, 2.5): the lane x = 4 inside it cannot be reached
    walls = [
        ((3.0, 1.5), (5.0, 1.7)),
        ((3.0, 3.3), (5.0, 3.5)),
        ((3.0, 1.5), (3.2, 3.5)),
        ((4.8, 1.5), (5.0, 3.5)),
    ]
    arena = Arena.box(*REGION, 0.1).with_boxes(walls)
    corners = wave_waypoints(REGION, 2.0, "y", 1, start)
    path = route_around_obstacles(arena, corners, start)
    legs = np.vstack([start, path])
    assert arena.segment_free(legs[:-1], legs[1:]).all()
    inside = (path[:, 0] > 3.2) & (path[:, 0] < 4.8) & (path[:, 1] > 1.7) & (path[:, 1] < 3.3)
    assert not inside.any()
    np.testing.assert_array_equal(path[-4:], corners[-4:])  # the lanes beyond it are swept


def _wave_scenario(
    searcher: dict[str, Any],
    obstacles: bool = True,
    starts: list[list[float]] | None = None,
) -> Scenario:
    d = small_scenario_dict("passive")
    d["searcher"] = searcher
    if obstacles:
        d["world"]["arena"]["obstacles"] = {"boxes": [[list(BOX[0]), list(BOX[1])]]}
    d["agents"]["starts"] = starts or [[0.5, 0.5]]
    d["limits"]["time"] = 250.0
    return Scenario.from_dict(d)


@pytest.mark.parametrize(
    "searcher",
    [
        {"type": "rectangular-wave", "lane_spacing": 2.0},
        {"type": "ds-rectangular-wave", "lane_spacing": 2.0, "rounds": 1, "dwell_periods": 0},
    ],
)
def test_the_wave_reaches_the_lane_behind_an_obstacle(searcher: dict[str, Any]) -> None:
    ep = Episode(_wave_scenario(searcher), record=False)
    agent = ep.built.searcher
    obs = ep.reset(0, 0)
    agent.reset(ep.context, ep.agent_rng)
    visited = [ep.platforms[0].position]
    while not ep.done:
        obs = ep.step(agent.act(obs, ep.agent_rng)).observations
        visited.append(ep.platforms[0].position)
    pos = np.array(visited)
    on_lane = np.abs(pos[:, 0] - 4.0) < 0.05
    # the stretch of the lane x = 4 beyond the box (y > 3.5) is driven
    assert np.any(on_lane & (pos[:, 1] > 4.5))
    assert pos[:, 0].max() == pytest.approx(10.0)  # and the lanes after it
    assert ep.platforms[0].collided == 0


def test_the_wave_in_3d_routes_around_the_obstacles_at_its_height() -> None:
    arena = Arena.box((0.0, 0.0, 0.0), (10.0, 5.0, 3.0), 0.1).with_boxes(
        [((3.0, 1.5, 0.0), (5.0, 3.5, 1.0))]
    )
    low, high = arena.horizontal_slice(0.5), arena.horizontal_slice(2.0)
    assert low.dim == 2 and low.occ is not None and high.occ is None
    start = (0.5, 0.5)
    corners = wave_waypoints(REGION, 2.0, "y", 1, start)
    np.testing.assert_array_equal(wave_waypoints(REGION, 2.0, "y", 1, start, arena=high), corners)
    assert len(wave_waypoints(REGION, 2.0, "y", 1, start, arena=low)) > len(corners)


def test_every_agent_of_the_wave_is_routed_around_the_obstacle() -> None:
    # the lanes start at the corner (0, 0) nearest to agent 0; the straight way there from
    # agent 1's start crosses the box, and from agent 2's it passes just below the box
    starts = [[0.5, 0.5], [6.0, 4.0], [9.5, 2.5]]
    assert not Arena.box(*REGION, 0.1).with_boxes([BOX]).segment_free([6.0, 4.0], [0.0, 0.0])[0]
    ep = Episode(
        _wave_scenario({"type": "rectangular-wave", "lane_spacing": 2.0}, starts=starts),
        record=False,
    )
    agent = ep.built.searcher
    obs = ep.reset(0, 0)
    agent.reset(ep.context, ep.agent_rng)
    sent: list[list[np.ndarray]] = [[] for _ in starts]
    for _ in range(80):
        action = agent.act(obs, ep.agent_rng)
        for k, c in enumerate(action.commands):
            if c is not None and c.kind == "waypoint":
                sent[k].append(c.value[:2])
        obs = ep.step(action).observations
    arena = ep.context.arena
    for k, start in enumerate(starts):
        assert sent[k], k
        legs = np.vstack([start, *sent[k]])
        assert arena.segment_free(legs[:-1], legs[1:]).all(), k
        assert ep.platforms[k].collided == 0, k


def test_the_wave_index_stops_at_the_last_waypoint() -> None:
    sc = _wave_scenario(
        {"type": "rectangular-wave", "lane_spacing": 5.0, "declare_at_max": True},
        starts=[[0.5, 0.5], [6.0, 4.0]],
    )
    ep = Episode(sc, record=False)
    agent = ep.built.searcher
    obs = ep.reset(0, 0)
    agent.reset(ep.context, ep.agent_rng)
    # every agent reports its waypoint reached at each step: the path runs out after a few
    obs = [replace(o, ready=True) for o in obs]
    sent = [0, 0]
    holds = [0, 0]
    for _ in range(60):
        action = agent.act(obs, ep.agent_rng)
        for k, c in enumerate(action.commands):
            assert c is not None
            if c.kind == "waypoint":
                sent[k] += 1
            else:
                assert c.kind == "hold"
                holds[k] += 1
            assert 0 <= agent.index[k] <= sent[k] - 1, (k, agent.index[k], sent[k])
        assert agent.diagnostics()["waypoint"] <= sent[0] - 1
        # the strongest reading is declared only once every agent holds at its path's end
        all_hold = all(c is not None and c.kind == "hold" for c in action.commands)
        assert bool(action.declarations) == all_hold
    # the path is finished early on; the index rests on its last waypoint
    assert min(holds) > 30
    assert agent.index == [n - 1 for n in sent]
    assert agent.done
