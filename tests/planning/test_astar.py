"""Tests of the A* planner's obstacle clearance (direct segment, detour and smoothing)."""

from __future__ import annotations

import itertools

import numpy as np

from odorloc.geometry.arena import Arena
from odorloc.planning.astar import astar_path


def _block() -> Arena:
    """A 10 m box with a 2 m x 5 m block standing on its lower wall."""
    return Arena.box((0, 0), (10, 10), 0.1).with_boxes([((4.0, 0.0), (6.0, 5.0))])


def _distance_to_block(path: np.ndarray) -> float:
    """Smallest distance from the legs of ``path`` to the block, metres."""
    s = np.linspace(0.0, 1.0, 400)[:, None]
    pts = np.concatenate([a + s * (b - a) for a, b in itertools.pairwise(path)])
    dx = np.maximum(0.0, np.maximum(4.0 - pts[:, 0], pts[:, 0] - 6.0))
    dy = np.maximum(0.0, pts[:, 1] - 5.0)
    return float(np.hypot(dx, dy).min())


def test_smoothed_detour_keeps_the_clearance():
    arena = _block()
    path = astar_path(arena, np.array([1.0, 1.0]), np.array([9.0, 1.0]), clearance=0.5)
    assert path is not None
    assert arena.segment_free(path[:-1], path[1:]).all()
    # grown on cell centres: within one cell of the requested clearance
    assert _distance_to_block(path) > 0.5 - 0.1
    raw = astar_path(arena, np.array([1.0, 1.0]), np.array([9.0, 1.0]), smooth=False)
    assert raw is not None and _distance_to_block(raw) < 0.2  # no clearance asked: hugs it


def test_direct_segment_skimming_an_obstacle_is_not_taken_with_clearance():
    arena = _block()
    start, goal = np.array([1.0, 5.05]), np.array([9.0, 5.05])
    assert len(astar_path(arena, start, goal)) == 2  # in sight: straight
    path = astar_path(arena, start, goal, clearance=0.5)
    assert path is not None and len(path) > 2
    np.testing.assert_allclose(path[[0, -1]], [start, goal])
    assert _distance_to_block(path) > 0.5 - 0.1


def test_goal_in_sight_through_a_gap_narrower_than_the_clearance_is_still_reached():
    arena = Arena.box((0, 0), (10, 10), 0.1).with_boxes(
        [((4.0, 0.0), (6.0, 4.8)), ((4.0, 5.2), (6.0, 10.0))]
    )
    start, goal = np.array([1.0, 5.0]), np.array([9.0, 5.0])
    path = astar_path(arena, start, goal, clearance=0.5)
    assert path is not None
    np.testing.assert_allclose(path, [start, goal])
    assert astar_path(arena, start, np.array([9.0, 1.0]), clearance=0.5) is None
