"""Arena geometry: bounds, obstacles, segment and line-of-sight queries, loaders."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena


@pytest.fixture
def room() -> Arena:
    return Arena.box((0.0, 0.0), (10.0, 5.0), 0.1).with_boxes([((4.0, 1.0), (5.0, 4.0))])


def test_grid_shape_and_centres(room: Arena) -> None:
    assert room.grid_shape == (100, 50)
    cx, cy = room.cell_centers()
    assert cx[0] == pytest.approx(0.05) and cy[-1] == pytest.approx(4.95)


def test_contains_and_obstacles_vectorised(room: Arena) -> None:
    pts = np.array([[1.0, 1.0], [4.5, 2.5], [11.0, 1.0], [4.5, 0.5], [10.0, 5.0]])
    assert room.contains(pts).tolist() == [True, True, False, True, True]
    assert room.in_obstacle(pts).tolist() == [False, True, False, False, False]
    assert room.is_free(pts).tolist() == [True, False, False, True, True]


def test_segment_and_line_of_sight(room: Arena) -> None:
    a = np.array([[1.0, 2.5], [1.0, 0.5], [1.0, 2.5]])
    b = np.array([[8.0, 2.5], [8.0, 0.5], [1.0, 4.9]])
    assert room.segment_free(a, b).tolist() == [False, True, True]
    assert room.line_of_sight(a, b).tolist() == [False, True, True]
    # Broadcasting one start against many ends.
    assert room.segment_free([1.0, 2.5], b).shape == (3,)


def test_first_hit_stops_before_obstacle(room: Arena) -> None:
    s = room.first_hit([[1.0, 2.5]], [[9.0, 2.5]])[0]
    x_stop = 1.0 + s * 8.0
    assert 3.9 <= x_stop < 4.0  # the wall face is at x = 4.0
    assert room.first_hit([[1.0, 0.5]], [[9.0, 0.5]])[0] == 1.0


def test_3d_arena_boxes() -> None:
    a = Arena.box((0, 0, 0), (4, 4, 2), 0.2).with_boxes([((1, 1, 0), (2, 2, 1))])
    assert a.dim == 3 and a.grid_shape == (20, 20, 10)
    assert a.in_obstacle([[1.5, 1.5, 0.5], [1.5, 1.5, 1.5]]).tolist() == [True, False]
    assert a.segment_free([[0.5, 1.5, 0.5]], [[3.5, 1.5, 0.5]]).tolist() == [False]
    assert a.segment_free([[0.5, 1.5, 1.5]], [[3.5, 1.5, 1.5]]).tolist() == [True]


def test_polygon_obstacle() -> None:
    a = Arena.box((0, 0), (4, 4), 0.05).with_polygons([[(1, 1), (3, 1), (2, 3)]])
    assert a.in_obstacle([[2.0, 1.5], [0.5, 3.5], [2.9, 2.9]]).tolist() == [True, False, False]


def test_csv_and_image_loaders_agree(tmp_path) -> None:
    grid = np.zeros((5, 8), int)  # rows = y (top row = max y), columns = x
    grid[0, 7] = 1  # top-right corner cell
    csv_path = tmp_path / "map.csv"
    np.savetxt(csv_path, grid, fmt="%d", delimiter=",")
    a = Arena.from_csv(csv_path, resolution=0.5)
    assert a.upper == (4.0, 2.5)
    assert a.in_obstacle([[3.75, 2.25], [0.25, 0.25]]).tolist() == [True, False]
    img = np.where(grid == 1, 0, 255).astype(np.uint8)  # dark = obstacle (ROS map style)
    png = tmp_path / "map.png"
    Image.fromarray(img).save(png)
    b = Arena.from_image(png, resolution=0.5)
    assert np.array_equal(a.occ, b.occ)


@pytest.mark.parametrize(
    ("lower", "upper", "res", "field"),
    [
        ((0, 0), (-1, 5), 0.1, "arena.upper"),
        ((0, 0), (1, 1, 1), 0.1, "arena.lower"),
        ((0, 0), (1, float("nan")), 0.1, "arena.upper"),
        ((0, 0), (1, 1), 0.0, "arena.resolution"),
    ],
)
def test_invalid_arena(lower, upper, res, field) -> None:
    with pytest.raises(ConfigError) as ei:
        Arena(tuple(lower), tuple(upper), res)
    assert ei.value.field == field


def test_bad_points_shape(room: Arena) -> None:
    with pytest.raises(ConfigError, match="points"):
        room.contains(np.zeros((3, 3)))


@pytest.fixture
def diagonal_wall() -> Arena:
    """A wall of cells that touch only at their corners, from (0, 1) to (1, 0)."""
    occ = np.zeros((10, 10), bool)
    for i in range(10):
        occ[i, 9 - i] = True
    return Arena((0.0, 0.0), (1.0, 1.0), 0.1, occ)


def test_segments_cannot_slip_through_a_diagonal_wall(diagonal_wall: Arena) -> None:
    a = np.array([[0.35, 0.55], [0.30, 0.58], [0.32, 0.55], [0.10, 0.30]])
    b = np.array([[0.45, 0.65], [0.50, 0.62], [0.47, 0.64], [0.90, 0.70]])
    assert diagonal_wall.is_free(a).all() and diagonal_wall.is_free(b).all()
    # through the corner between two wall cells, or clipping a wall cell by less than a
    # sample spacing
    assert not diagonal_wall.segment_free(a, b).any()
    s = diagonal_wall.first_hit(a, b)
    assert np.all(s < 1.0)
    stop = a + s[:, None] * (b - a)
    assert (stop.sum(axis=1) < 1.0).all()  # every stop is on the near side of the wall
    assert diagonal_wall.segment_free(a, stop).all()


def test_segment_free_agrees_with_dense_sampling() -> None:
    rng = np.random.default_rng(3)
    base = Arena.box((0.0, 0.0), (2.0, 2.0), 0.1)
    arena = Arena(base.lower, base.upper, 0.1, rng.random(base.grid_shape) < 0.1)
    a = rng.uniform(0.0, 2.0, (400, 2))
    b = a + rng.normal(scale=0.4, size=(400, 2))
    s = np.linspace(0.0, 1.0, 2001)
    dense = np.array(
        [arena.is_free(p + s[:, None] * (q - p)).all() for p, q in zip(a, b, strict=True)]
    )
    np.testing.assert_array_equal(arena.segment_free(a, b), dense)
    stop = a + arena.first_hit(a, b)[:, None] * (b - a)
    start_free = arena.is_free(a)
    assert arena.segment_free(a[start_free], stop[start_free]).all()


def test_a_wall_thinner_than_a_cell_is_kept() -> None:
    coarse = Arena.box((0.0, 0.0), (10.0, 5.0), 0.25)
    # 0.1 m thick: no cell centre (4.125, 4.375, ...) lies inside it
    wall = coarse.with_boxes([((4.0, 0.0), (4.1, 5.0))])
    assert wall.occ is not None and wall.occ.sum() == wall.grid_shape[1]
    assert wall.in_obstacle([[4.05, 2.5]]).tolist() == [True]
    assert not wall.segment_free([1.0, 2.5], [8.0, 2.5])[0]
    # boxes wide enough to hold cell centres are marked by their centres, as before
    room = coarse.with_boxes([((4.0, 1.0), (5.0, 4.0))])
    assert room.occ is not None and room.occ.sum() == 4 * 12
    # a box wholly outside the bounds marks nothing
    assert coarse.with_boxes([((11.0, 1.0), (11.05, 4.0))]).occ is None


def _strip(start: tuple[float, float], end: tuple[float, float], width: float) -> np.ndarray:
    """A thin rectangle (4 vertices) of ``width`` metres along ``start -> end``."""
    s, e = np.asarray(start, float), np.asarray(end, float)
    d = (e - s) / np.linalg.norm(e - s)
    n = np.array([-d[1], d[0]]) * 0.5 * width
    return np.array([s - n, e - n, e + n, s + n])


def test_a_polygon_thinner_than_a_cell_is_kept() -> None:
    room = Arena.box((0.0, 0.0), (5.0, 5.0), 0.1)
    # 0.03 m thick, between the rows of centres at y = 2.05 and 2.15
    wall = room.with_polygons([[(1.0, 2.06), (4.0, 2.06), (4.0, 2.09), (1.0, 2.09)]])
    assert wall.occ is not None and wall.occ.sum() == 30
    assert not wall.segment_free([2.5, 1.0], [2.5, 3.0])[0]
    # smaller than a cell on both axes: the cell it lies in
    speck = room.with_polygons([[(1.01, 1.01), (1.04, 1.01), (1.02, 1.03)]])
    assert speck.occ is not None and np.argwhere(speck.occ).tolist() == [[10, 10]]
    # wholly outside the bounds: nothing
    assert room.with_polygons([[(6.0, 1.0), (7.0, 1.0), (7.0, 2.0)]]).occ is None


@pytest.mark.parametrize(
    "start, end",
    [
        ((-0.1, -0.07), (5.1, 5.13)),  # 45 degrees, just off the cell centres
        ((-0.1, 1.03), (5.1, 2.33)),  # shallow
        ((1.02, -0.1), (1.9, 5.1)),  # steep
        ((-0.1, 0.53), (5.1, 4.43)),
    ],
)
def test_a_thin_diagonal_polygon_leaves_no_gap(start, end) -> None:
    from odorloc.planning.astar import astar_path

    # 0.03 m thick, from wall to wall: it parts the room in two
    wall = Arena.box((0.0, 0.0), (5.0, 5.0), 0.1).with_polygons([_strip(start, end, 0.03)])
    assert wall.occ is not None
    s, e = np.asarray(start), np.asarray(end)
    d = (e - s) / np.linalg.norm(e - s)
    across = 0.4 * np.array([-d[1], d[0]])
    along = s + np.linspace(0.1, 0.9, 60)[:, None] * (e - s)
    a, b = along - across, along + across
    both = wall.is_free(a) & wall.is_free(b)
    assert both.sum() > 30
    # no straight crossing, and no planned path from one side to the other
    assert not wall.segment_free(a[both], b[both]).any()
    k = int(np.flatnonzero(both)[len(np.flatnonzero(both)) // 2])
    assert astar_path(wall, a[k], b[k]) is None


def test_thick_polygons_keep_their_centre_cells() -> None:
    from matplotlib.path import Path as MplPath
    from matplotlib.transforms import Bbox

    room = Arena.box((0.0, 0.0), (5.0, 4.0), 0.1)
    gx, gy = np.meshgrid(*room.cell_centers(), indexing="ij")
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    rng = np.random.default_rng(0)
    for _ in range(30):
        k = int(rng.integers(3, 9))
        ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
        r = rng.uniform(0.3, 1.0) * rng.uniform(0.5, 1.0, (k, 1))
        poly = rng.uniform(1.0, 3.0, 2) + r * np.column_stack([np.cos(ang), np.sin(ang)])
        centres = MplPath(poly).contains_points(xy).reshape(gx.shape)
        occ = room.with_polygons([poly]).occ
        assert occ is not None and np.all(occ >= centres)
        # a cell added without its centre inside (a pointed tip) still overlaps the polygon
        outline = MplPath(np.vstack([poly, poly[:1]]), closed=True)
        for i, j in np.argwhere(occ & ~centres):
            cell = Bbox.from_extents(0.1 * i, 0.1 * j, 0.1 * (i + 1), 0.1 * (j + 1))
            assert outline.intersects_bbox(cell, filled=True)


def test_cell_index_of_a_point_that_is_not_finite_is_an_error() -> None:
    from odorloc.geometry.grid import CellGrid

    grid = CellGrid((0.0, 0.0), 1.0, (3, 3))
    assert grid.index([[2.5, 0.5]]).tolist() == [[2, 0]]
    with pytest.raises(ConfigError, match="points: must be finite"):
        grid.index([[np.nan, 0.5]])
