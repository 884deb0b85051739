"""Tests of the uncertainty-driven route planner (D-S paper, section 3)."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from odorloc.core.errors import ConfigError
from odorloc.inference.evidence.dempster_shafer import DSGrid, DSParams
from odorloc.inference.odor_path import CellGrid, OdorPathEstimator, OdorPathParams, PathPatch
from odorloc.planning.uncertainty_route import (
    UncertaintyRouteParams,
    UncertaintyRoutePlanner,
    fitness_map,
)

GRID = CellGrid((0.0, 0.0), 1.0, (10, 10))


def certain_grid(unknown: list[tuple[int, int]] = ()) -> DSGrid:
    """Every cell known free (X = 0) except ``unknown`` cells (X = q = 3)."""
    g = DSGrid(DSParams(), GRID)
    g.m_u[:] = 0.0
    g.m_n[:] = 1.0
    for c in unknown:
        g.m_u[c], g.m_n[c] = 1.0, 0.0
    return g


def upwind_patch(ref=(5, 5)) -> PathPatch:
    """Path map 0.5 on the robot cell and 0.5 on the cell upwind (-x) of it."""
    return PathPatch(ref[0] - 1, ref[1], np.array([[0.5], [0.5]]), GRID, np.array(ref))


def brute_force_fitness(x: np.ndarray, pi: np.ndarray, ref: tuple[int, int]) -> np.ndarray:
    """E_P = sum_c pi(c - Delta) X(c) by explicitly shifting the dense map for every P."""
    nx, ny = x.shape
    out = np.zeros((nx, ny))
    for px in range(nx):
        for py in range(ny):
            dx, dy = px - ref[0], py - ref[1]
            shifted = np.zeros_like(pi)
            src = pi[max(0, -dx) : nx - max(0, dx), max(0, -dy) : ny - max(0, dy)]
            shifted[
                max(0, dx) : max(0, dx) + src.shape[0], max(0, dy) : max(0, dy) + src.shape[1]
            ] = src
            out[px, py] = np.sum(shifted * x)
    return out


def test_fitness_map_equals_explicit_shifts():
    rng = np.random.default_rng(0)
    x = rng.random((10, 10)) * 3
    pi = np.zeros((10, 10))
    pi[1:5, 3:6] = rng.random((4, 3))
    patch = PathPatch(1, 3, pi[1:5, 3:6].copy(), GRID, np.array([4, 4]))
    np.testing.assert_allclose(
        fitness_map(x, patch), brute_force_fitness(x, pi, (4, 4)), atol=1e-12
    )
    sub = fitness_map(x, patch, (2, 7, 0, 4))
    np.testing.assert_allclose(sub, brute_force_fitness(x, pi, (4, 4))[2:7, 0:4], atol=1e-12)


def test_picks_highest_uncertainty_weighted_fitness():
    # Robot in cell (5, 5); unknown cells (6, 5) and (8, 5). Candidates within 1.5 m are the
    # 3 x 3 block around the robot. E(6, 5) = 0.5 X(6, 5) + 0.5 X(5, 5) = 1.5, every other
    # candidate covers only known cells (E = 0); (7, 5) would score 1.5 + 0 too but is out of
    # reach, as is (8, 5) / (9, 5).
    ds = certain_grid([(6, 5), (8, 5)])
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.5))
    plan = planner.route(ds, upwind_patch(), (5.5, 5.5), np.random.default_rng(0))
    np.testing.assert_allclose(plan.target, [6.5, 5.5])
    assert plan.fitness == pytest.approx(1.5)
    assert plan.reason == "ok" and plan.n_candidates == 9 and not plan.done


def test_widens_range_when_nothing_nearby_is_uncertain():
    # Only cell (0, 0) is uncertain; P = (0, 0) and P = (1, 0) both cover it (E = 1.5): a tie
    ds = certain_grid([(0, 0)])
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.0))
    targets = set()
    for seed in range(20):
        plan = planner.route(ds, upwind_patch(), (5.5, 5.5), np.random.default_rng(seed))
        assert (
            plan.reason == "widened" and plan.radius >= 4.0 and plan.fitness == pytest.approx(1.5)
        )
        targets.add(tuple(plan.target))
    assert targets == {(0.5, 0.5), (1.5, 0.5)}
    again = [
        planner.route(ds, upwind_patch(), (5.5, 5.5), np.random.default_rng(3)).target
        for _ in range(2)
    ]
    np.testing.assert_array_equal(again[0], again[1])


def test_threshold_and_stop():
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.0, eta_e=0.5))
    rng = np.random.default_rng(0)
    # all cells known: the whole area is below eta_E -> finished
    plan = planner.route(certain_grid(), upwind_patch(), (5.5, 5.5), rng)
    assert plan.done and plan.target is None and plan.reason == "finished"
    assert planner.route(certain_grid(), upwind_patch(), (5.5, 5.5), rng).target is None
    # one partly known cell, X = -m(notS) log2 m(notS) + 3 m(U) = 0.328 + 0.8; the best
    # E = 0.5 X, so the plan depends on which side of eta_E it falls
    ds = certain_grid()
    ds.m_n[2, 2], ds.m_u[2, 2] = 1 - 0.8 / 3, 0.8 / 3
    x = ds.uncertainty()[2, 2]
    assert x == pytest.approx(-(1 - 0.8 / 3) * np.log2(1 - 0.8 / 3) + 0.8)
    below = UncertaintyRoutePlanner(UncertaintyRouteParams(eta_e=0.5 * x + 1e-6))
    above = UncertaintyRoutePlanner(UncertaintyRouteParams(eta_e=0.5 * x - 1e-6))
    assert below.route(ds, upwind_patch(), (5.5, 5.5), rng).target is None
    assert above.route(ds, upwind_patch(), (5.5, 5.5), rng).target is not None


def test_region_limits_candidates_and_counted_uncertainty():
    ds = certain_grid([(8, 8), (2, 2)])
    region = ((0.0, 0.0), (5.0, 5.0))
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.0, region=region))
    plan = planner.route(ds, upwind_patch((3, 3)), (3.5, 3.5), np.random.default_rng(0))
    assert plan.target is not None
    assert np.all(plan.target <= 5.0)
    assert tuple(plan.target) in {(2.5, 2.5), (3.5, 2.5)}
    # obstacles: forbid both cells covering (2, 2) -> the planner finishes
    allowed = np.ones(GRID.shape, bool)
    allowed[2, 2] = allowed[3, 2] = False
    rng = np.random.default_rng(0)
    assert planner.route(ds, upwind_patch((3, 3)), (3.5, 3.5), rng, allowed).target is None


def test_edge_reach_covers_the_downwind_edge_of_the_region():
    """Readings cover the cells upwind of the sensor only, so the region's downwind-most column
    is out of reach from the region's cell centres; edge_reach lets the robot stand on the edge.
    """
    region = ((1.0, 1.0), (6.0, 9.0))  # cells 1..5 along x; the margin column 6 lies outside
    ds = certain_grid([(5, 4)])  # the unknown cell is in the region's last column
    pi = PathPatch(4, 4, np.array([[1.0], [0.0]]), GRID, np.array([5, 4]))  # one cell upwind
    rng = np.random.default_rng(0)
    inside = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.5, region=region))
    plan = inside.route(ds, pi, (4.5, 3.5), rng)
    # no candidate centre in the region has (5, 4) one cell upwind: the cell can never be read
    assert plan.done and plan.target is None and plan.fitness == 0.0
    edge = UncertaintyRoutePlanner(
        UncertaintyRouteParams(step_range=1.5, region=region, edge_reach=0.5)
    )
    plan = edge.route(ds, pi, (4.5, 3.5), rng)
    # the margin cell (6, 4) has it one cell upwind; its centre (6.5, 4.5) is clamped onto the
    # region's edge x = 6
    assert plan.fitness == pytest.approx(3.0)
    np.testing.assert_allclose(plan.target, [6.0, 4.5])
    # cells further out than edge_reach stay excluded, and uncertainty outside never counts
    ds2 = certain_grid([(6, 4)])
    far = edge.route(ds2, pi, (4.5, 3.5), rng)
    assert far.done


def test_empty_path_map_holds_position():
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams())
    empty = PathPatch(0, 0, np.zeros((0, 0)), GRID, np.array([5, 5]))
    plan = planner.route(DSGrid(DSParams(), GRID), empty, (5.2, 5.7), np.random.default_rng(0))
    assert plan.reason == "empty_path_map" and not plan.done
    np.testing.assert_allclose(plan.target, [5.5, 5.5])


def test_works_with_estimator_and_dense_map():
    rng = np.random.default_rng(0)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2), (0, 0), (10, 10))
    for i in range(21):
        est.update(i * 0.5, (6.0, 5.0), np.array([0.8, 0.0]) + rng.normal(0, 0.05, 2), 0.0)
    ds = DSGrid(DSParams(), est.grid)
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=0.25))
    a = planner.route(ds, est, (6.0, 5.0), np.random.default_rng(1))
    b = planner.route(ds, est.path_map(), (6.0, 5.0), np.random.default_rng(1))
    assert a.reason == "ok" and b.reason == "ok"
    np.testing.assert_allclose(a.target, b.target)
    assert np.linalg.norm(a.target - [6.0, 5.0]) <= 0.25 + 0.15
    # all unknown: E is 3 * (sum of the map inside the grid) for every in-range candidate
    assert a.fitness == pytest.approx(3.0 * est.path_map().sum(), rel=1e-6)
    with pytest.raises(ConfigError):
        planner.route(DSGrid(DSParams(), GRID), est, (6.0, 5.0), rng)


def test_bad_params_raise():
    with pytest.raises(pydantic.ValidationError, match="widen_factor"):
        UncertaintyRouteParams(widen_factor=1.0)
    with pytest.raises(pydantic.ValidationError, match="region"):
        UncertaintyRouteParams(region=((5.0, 0.0), (1.0, 1.0)))
    with pytest.raises(pydantic.ValidationError, match="step_range"):
        UncertaintyRouteParams(step_range=0.0)
    with pytest.raises(pydantic.ValidationError, match="eta"):
        UncertaintyRouteParams(eta=0.5)
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams())
    ds = certain_grid([(1, 1)])
    with pytest.raises(ConfigError, match="allowed"):
        planner.route(
            ds, upwind_patch(), (5.5, 5.5), np.random.default_rng(0), np.ones((3, 3), bool)
        )
    with pytest.raises(ConfigError, match="position"):
        planner.route(ds, upwind_patch(), (np.nan, 5.5), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="path_model"):
        planner.route(ds, np.zeros((4, 4)), (5.5, 5.5), np.random.default_rng(0))


# --------------------------------------------------------------- closed loop vs fixed pattern
_SOURCES = np.array([[2.0, 3.5], [4.0, 6.5]])
_DT = 0.5


def _wind(t: float) -> np.ndarray:
    th = 0.45 * np.sin(2 * np.pi * t / 30.0) + 0.25 * np.sin(2 * np.pi * t / 11.0 + 1.0)
    return np.array([np.cos(th), np.sin(th)])


def _detect(p: np.ndarray, history: np.ndarray) -> bool:
    """Gaussian puffs from both sources carried by the uniform wind ``history`` (newest first)."""
    disp = np.cumsum(history * _DT, axis=0)
    s2 = 0.05**2 + 2 * 0.01 * _DT * np.arange(1, len(history) + 1)
    d = p[None, None, :] - disp[:, None, :] - _SOURCES[None, :, :]
    g = np.exp(-np.sum(d * d, axis=2) / (2 * s2[:, None])) / (2 * np.pi * s2[:, None])
    return bool(g.sum() * _DT > 0.3)


def _explore(mode: str, n_steps: int, seed: int) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2), (0, 0), (10, 10))
    ds = DSGrid(DSParams(), est.grid)
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=0.25))
    lanes = []
    for k, x in enumerate(np.arange(9.5, 0.0, -1.0)):  # rectangular wave from the start corner
        ys = np.arange(0.5, 9.51, 0.25)
        lanes += [(x, y) for y in (ys[::-1] if k % 2 else ys)]
    route = np.array(lanes * 3)
    history = np.zeros((40, 2))
    p = np.array([9.5, 0.5])
    travelled = 0.0
    for i in range(n_steps):
        u = _wind(i * _DT)
        history = np.vstack([u, history[:-1]])
        det = _detect(p, history) and rng.random() < 0.9
        est.update(i * _DT, p, u + rng.normal(0.0, 0.05, 2), float(det))
        ds.update(est.path_patch(), det)
        if mode == "wave":
            nxt = route[i + 1]
        else:
            target = planner.route(ds, est, p, rng).target
            assert target is not None
            d = target - p
            dist = np.linalg.norm(d)
            nxt = p + (d if dist <= 0.25 else d / dist * 0.25)  # 0.5 m/s for 0.5 s
        travelled += float(np.linalg.norm(nxt - p))
        p = nxt
    return ds.total_uncertainty(), travelled


@pytest.mark.slow
def test_planned_route_clears_uncertainty_faster_than_rectangular_wave():
    # The paper's headline ordering (section 4.4): the dynamic route leaves less uncertainty
    # with a shorter trajectory than the predefined rectangular wave.
    for seed in (1, 2):
        u_plan, d_plan = _explore("plan", 600, seed)
        u_wave, d_wave = _explore("wave", 600, seed)
        assert u_plan < 0.9 * u_wave
        assert d_plan < d_wave


def test_route_widen_factor_must_be_finite_in_the_searcher_config():
    from odorloc.searchers.ds_mapping import DSMappingParams

    for bad in (float("inf"), float("nan"), 1.0):
        with pytest.raises(pydantic.ValidationError, match="widen_factor"):
            DSMappingParams(widen_factor=bad)


@pytest.mark.parametrize("name", ["ds-mapping", "ds-rectangular-wave"])
def test_odor_path_span_shorter_than_the_control_period_is_refused(name):
    from odorloc.core import registry
    from odorloc.core.types import SearchContext
    from odorloc.geometry.arena import Arena

    entry = registry.entry("searcher", name)

    ctx = SearchContext(
        arena=Arena.box((0, 0), (10, 10), 0.25),
        dt=0.5,
        agent_ids=(0,),
        start=np.array([[3.0, 3.0]]),
        speed_limits=np.array([0.5]),
    )
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigError, match=r"searcher\.t_thr"):
        entry.build(entry.params(t_thr=0.4)).reset(ctx, rng)
    entry.build(entry.params(t_thr=0.5)).reset(ctx, rng)  # one sub-window


def test_dynamic_route_goes_around_a_wall_instead_of_stopping_at_it():
    """Wind towards -x: the cells left of the wall are covered only from the left, so the route
    has to pass the wall's gap (y > 8.5); no target lies inside the wall."""
    from odorloc.core.types import Observation, SearchContext
    from odorloc.geometry.arena import Arena
    from odorloc.searchers.ds_mapping import DSMappingParams, DSMappingSearcher

    arena = Arena.box((0, 0), (10, 10), 0.25).with_boxes([((5.0, 0.0), (5.5, 8.5))])
    ctx = SearchContext(
        arena=arena,
        dt=0.5,
        agent_ids=(0,),
        start=np.array([[8.0, 2.0]]),
        speed_limits=np.array([0.5]),
    )
    rng = np.random.default_rng(0)
    searcher = DSMappingSearcher(DSMappingParams(cell_size=0.5, dwell_periods=0))
    searcher.reset(ctx, rng)
    p = np.array([8.0, 2.0])
    xs, targets = [], []
    for i in range(500):
        o = Observation(0, 0.5 * i, p.copy(), 0.0, 0.0, False, np.array([-1.0, 0.0]))
        cmd = searcher.act([o], rng).commands[0]
        plan = searcher.last_plan
        if plan is not None and plan.target is not None:
            targets.append(plan.target)
        if cmd.kind == "waypoint":
            d = cmd.value[:2] - p
            dist = float(np.hypot(*d))
            goal = p + d * min(1.0, 0.25 / dist) if dist > 0 else p
            p = p + arena.first_hit(p, goal)[0] * (goal - p)  # an idealised platform
        xs.append(p[0])
    assert arena.is_free(np.array(targets)).all()
    assert min(xs) < 4.0
