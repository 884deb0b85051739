"""Tests of the D-S mapping searchers (D-S multi-source paper) and their reproduction helpers."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pydantic
import pytest

from odorloc.behaviours.stop_and_go import StopAndGo
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_generators
from odorloc.core.types import Observation, SearchContext
from odorloc.engine.episode import run_episode
from odorloc.engine.replay import on_replay, record_flow
from odorloc.geometry.arena import Arena
from odorloc.inference.evidence.dempster_shafer import DSParams
from odorloc.inference.evidence.mapper import DSMapParams as DSMapperParams
from odorloc.inference.evidence.mapper import DSMapper, ReadingLog
from odorloc.papers.ds_multi_source.reproduction import map_errors
from odorloc.planning.coverage import wave_waypoints
from odorloc.scenarios import Scenario, get_scenario
from odorloc.scenarios.build import build_world
from odorloc.searchers.ds_mapping import (
    DSMappingParams,
    DSMappingSearcher,
    DSRectangularWaveParams,
)

VOLATILE = ("wall_time", "wall_per_step_ms", "searcher_fraction", "world_fraction")


def reduced_farrell(
    time: float = 40.0,
    searcher: dict | None = None,
    region: list | None = None,
) -> Scenario:
    """The paper's scenario cut to a 6 m x 8 m region around the sources and a short time."""
    sc = get_scenario("two-sources-farrell")
    data = sc.to_dict()
    data["world"]["warmup"] = 20.0
    data["limits"]["time"] = time
    data["agents"]["starts"] = [[25.0, 50.0]]
    data["task"]["region"] = region or [[19.0, 48.0], [25.0, 56.0]]
    data["searcher"] = searcher or {"type": "ds-mapping"}
    return Scenario.from_dict(data)


def steady_world(searcher: dict, time: float = 400.0) -> Scenario:
    """Uniform 1 m/s wind along +x, steady Gaussian plumes of two sources."""
    return Scenario.from_dict(
        {
            "name": "steady-two-sources",
            "world": {
                "arena": {"lower": [0.0, 0.0], "upper": [14.0, 12.0], "resolution": 0.25},
                "sources": [
                    {"position": [3.0, 4.0], "rate": 1.0},
                    {"position": [5.0, 8.0], "rate": 1.0},
                ],
                "wind": {"type": "uniform", "velocity": [1.0, 0.0]},
                "plume": {"type": "gaussian"},
                "dt": 0.5,
            },
            "sensors": {"gas": {"type": "concentration", "threshold": 0.3}},
            "platform": {"type": "holonomic", "max_speed": 0.5},
            "agents": {"starts": [[12.0, 2.0]]},
            "searcher": searcher,
            "limits": {"control_dt": 0.5, "time": time},
            "task": {"success_radius": 1.5, "region": [[1.0, 1.0], [13.0, 11.0]]},
        }
    )


def _stable(m: dict) -> dict:
    """The row without timings, NaN made comparable."""
    return {
        k: ("nan" if isinstance(v, float) and math.isnan(v) else v)
        for k, v in m.items()
        if k not in VOLATILE
    }


# ------------------------------------------------------------------------------- the mapper
def test_mapper_first_detection_follows_eq4() -> None:
    """One detection puts m(S) = mu_D zeta pi and m(U) = 1 - m(S) on the path cells (eq. 4-a)."""
    mp = DSMapper(DSMapperParams(cell_size=0.5), ((0.0, 0.0), (10.0, 10.0)), 0.5)
    mp.update(0.0, np.array([8.0, 5.0]), np.array([1.0, 0.0]), False)
    mp.update(0.5, np.array([8.0, 5.0]), np.array([1.0, 0.0]), False)
    before = (mp.grid.m_s.copy(), mp.grid.m_n.copy(), mp.grid.m_u.copy())
    patch = mp.update(1.0, np.array([8.0, 5.0]), np.array([1.0, 0.0]), True)
    pi = patch.to_dense()
    assert pi.max() > 0.1
    # Dempster's rule of (S, notS, U) = before with (0.54 pi, 0, 1 - 0.54 pi), by hand
    s1, n1, u1 = before
    s2 = 0.9 * 0.6 * pi
    u2 = 1.0 - s2
    k = n1 * s2
    exp_s = (s1 * s2 + s1 * u2 + u1 * s2) / (1 - k)
    exp_n = (n1 * u2) / (1 - k)
    np.testing.assert_allclose(mp.grid.m_s, exp_s, atol=1e-12)
    np.testing.assert_allclose(mp.grid.m_n, exp_n, atol=1e-12)
    np.testing.assert_allclose(mp.grid.m_s + mp.grid.m_n + mp.grid.m_u, 1.0, atol=1e-12)
    # the air came from upwind (-x): evidence sits at x <= robot
    cells = np.argwhere(pi > 0)
    assert mp.grid.grid.center(cells)[:, 0].max() <= 8.0 + 0.5
    m = mp.final_metrics()
    assert m["initial_uncertainty"] == pytest.approx(3.0 * 20 * 20)
    assert m["residual_uncertainty"] < m["initial_uncertainty"]
    assert m["detections"] == 1.0


def test_total_normalised_path_map_sums_to_one() -> None:
    """path_normalise="total": the reading's map is divided by its sum before eq. 4-a."""
    maps = []
    for how in ("window", "total"):
        mp = DSMapper(DSMapperParams(cell_size=0.5, path_normalise=how), ((0, 0), (10, 10)), 0.5)
        for i, det in enumerate((False, False, True)):
            patch = mp.update(0.5 * i, np.array([8.0, 5.0]), np.array([1.0, 0.2 * i]), det)
        maps.append((patch.to_dense(), mp.grid.m_s.copy()))
    (pi_w, _), (pi_t, ms_t) = maps
    assert pi_w.sum() > 1.5  # the max over window-normalised maps is not a distribution
    np.testing.assert_allclose(pi_t, pi_w / pi_w.sum())
    assert pi_t.sum() == pytest.approx(1.0)
    # the first two records give no path map yet, so m(S) = mu_D zeta pi exactly (eq. 4-a)
    np.testing.assert_allclose(ms_t, 0.54 * pi_t, atol=1e-12)


def test_upwind_end_of_a_plume_shaped_region() -> None:
    """A region stretching 4 m downwind of (2, 5): centroid 2 m downwind, upwind end at 2.5 m."""
    p = DSMapperParams(cell_size=1.0, map_margin=0.0, upwind_depth=1.0)
    mp = DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.5)
    mp.wind_sum[:] = (3.0, 0.0)  # the air moved towards +x
    mp.grid.m_s[2:6, 5], mp.grid.m_u[2:6, 5] = 0.9, 0.1  # cells x in [2, 6), y in [5, 6)
    np.testing.assert_allclose(mp.sources()[0].position, [4.0, 5.5])
    # cells within 1 m of the most upwind centre (2.5) along +x: centres 2.5 and 3.5
    np.testing.assert_allclose(mp.upwind_ends(), [[3.0, 5.5]])
    mp.wind_sum[:] = (-3.0, 0.0)  # the other way round: the upwind end is at x = 5.5
    np.testing.assert_allclose(mp.upwind_ends(), [[5.0, 5.5]])
    up = DSMapper(p.model_copy(update={"source_rule": "upwind"}), mp.region, 0.5)
    up.grid = mp.grid
    up.wind_sum[:] = (3.0, 0.0)
    np.testing.assert_allclose(up.declaration().positions, [[3.0, 5.5]])
    m = up.final_metrics()
    assert (m["mapped_x_0"], m["upwind_x_0"]) == (3.0, 3.0)


def test_peak_rule_takes_the_strongest_cell_of_each_region() -> None:
    """Two regions; each one's peak is its largest-m(S) cell, in the order of sources()."""
    p = DSMapperParams(cell_size=1.0, map_margin=0.0, source_rule="peak")
    mp = DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.5)
    mp.grid.m_s[2:6, 5], mp.grid.m_u[2:6, 5] = 0.9, 0.1  # heavier region, peak at ix = 3
    mp.grid.m_s[3, 5], mp.grid.m_u[3, 5] = 0.97, 0.03
    mp.grid.m_s[8, 1:3], mp.grid.m_u[8, 1:3] = (0.6, 0.7), (0.4, 0.3)  # lighter, peak iy = 2
    np.testing.assert_allclose(mp.peaks(), [[3.5, 5.5], [8.5, 2.5]])
    np.testing.assert_allclose(mp.declaration().positions, [[3.5, 5.5], [8.5, 2.5]])
    m = mp.final_metrics()
    assert (m["peak_x_1"], m["peak_y_1"]) == (8.5, 2.5) and m["mapped_sources"] == 2.0
    w = np.array([0.9, 0.97, 0.9, 0.9])
    assert m["centroid_x_0"] == pytest.approx(w @ [2.5, 3.5, 4.5, 5.5] / w.sum())
    empty = DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.5)
    assert empty.peaks().shape == (0, 2)


def _line_readings(sources: list[tuple[int, int]], reach: int = 10) -> tuple[ReadingLog, Any]:
    """Readings of a robot at every cell of a 20 x 10 grid (1 m cells), wind towards +x: each
    reading's path map is its own row from ``reach`` cells upwind to the robot (pi = 1); it
    detects every other time when that stretch holds a source (intermittency 0.5)."""
    from odorloc.geometry.grid import CellGrid
    from odorloc.inference.odor_path.estimator import PathPatch

    grid = CellGrid((0.0, 0.0), 1.0, (20, 10))
    log = ReadingLog(grid.shape)
    k = 0
    for rep in range(2):
        for y in range(10):
            for x in range(20):
                x0 = max(0, x - reach)
                values = np.ones((x - x0 + 1, 1))
                covered = any(sy == y and x0 <= sx <= x for sx, sy in sources)
                k += 1
                det = covered and (k + rep) % 2 == 0
                log.add(PathPatch(x0, y, values, grid, np.array([x, y])), det)
    return log, grid


@pytest.mark.parametrize(
    "sources",
    [[(5, 3)], [(5, 3), (8, 6)], [(5, 3), (8, 4)]],
    ids=["one", "apart", "side-by-side"],
)
def test_likelihood_rule_finds_the_sources_not_their_footprints(sources) -> None:
    """A source's detections also cover every cell between it and the robots downwind (its
    footprint); the likelihood rule places one estimate on each source cell, even when two
    footprints touch across the wind, and nothing on the footprints."""
    log, grid = _line_readings(sources)
    cand = np.ones(grid.shape, bool)
    cells, gains = log.greedy_sources(
        cand,
        grid.centers().reshape(-1, 2),
        alpha=0.8,
        eps=0.02,
        min_gain=0.15,
        exclusion=(3.0, 0.5),
        wind=np.array([1.0, 0.0]),
        max_sources=8,
    )
    found = sorted((int(c) // 10, int(c) % 10) for c in cells)
    assert found == sorted(sources)
    assert np.all(gains > 0) and np.all(np.diff(gains) <= 0)


def test_likelihood_rule_closed_form_gain() -> None:
    """One cell passed by one detection and one non-detection (pi = 0.5 each): the first gain
    is log(P(D | c) / P(D | none)) + log(P(notD | c) / P(notD | none)) with the noisy-OR
    P(D | c) = 1 - (1 - eps)(1 - alpha pi)."""
    from odorloc.geometry.grid import CellGrid
    from odorloc.inference.odor_path.estimator import PathPatch

    grid = CellGrid((0.0, 0.0), 1.0, (3, 3))
    log = ReadingLog(grid.shape)
    half = np.full((1, 1), 0.5)
    log.add(PathPatch(1, 1, half, grid, np.array([1, 1])), True)
    log.add(PathPatch(1, 1, half, grid, np.array([1, 1])), False)
    cells, gains = log.greedy_sources(
        np.ones(grid.shape, bool),
        grid.centers().reshape(-1, 2),
        alpha=0.6,
        eps=0.1,
        min_gain=0.5,
        exclusion=(0.0, 0.0),
        wind=np.array([1.0, 0.0]),
        max_sources=3,
    )
    assert list(cells) == [4]
    p_det = 1.0 - 0.9 * 0.7
    assert gains[0] == pytest.approx(math.log(p_det / 0.1) + math.log(0.9 * 0.7 / 0.9))


def test_likelihood_is_the_default_rule_and_leaves_the_map_alone() -> None:
    """The default rule reads the map without changing it: the same readings give the same
    masses under every rule."""
    assert DSMapperParams().source_rule == "likelihood"
    region = ((0.0, 0.0), (10.0, 6.0))
    maps = {}
    rng = np.random.default_rng(3)
    readings = [
        (0.5 * k, np.array([8.0 - 0.05 * k, 3.0]), np.array([1.0, 0.1 * rng.standard_normal()]))
        for k in range(60)
    ]
    for rule in ("likelihood", "peak"):
        mp = DSMapper(DSMapperParams(cell_size=0.5, source_rule=rule), region, 0.5)
        for t, pos, wind in readings:
            mp.update(t, pos, wind, bool(pos[0] < 6.0))
        mp.final_metrics()
        maps[rule] = (mp.grid.m_s.copy(), mp.grid.m_n.copy(), mp.grid.m_u.copy())
    for a, b in zip(maps["likelihood"], maps["peak"], strict=True):
        np.testing.assert_array_equal(a, b)


def test_peak_rule_ranks_saturated_cells_by_their_doubt() -> None:
    """After long runs of detections m(S) rounds to exactly 1.0 in several cells; the peak is
    still the cell with the most evidence (smallest m(notS) + m(U)), not the first in index
    order."""
    p = DSMapperParams(cell_size=1.0, map_margin=0.0, t_thr=1.0)
    mp = DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.5)
    g = mp.grid
    pi = np.zeros(g.grid.shape)
    for n, ix in ((60, 2), (80, 4)):  # 60 and 80 full-weight detections on cells 2 and 4
        pi[:] = 0.0
        pi[ix, 5] = 1.0
        for _ in range(n):
            g.update(pi, True)
    assert g.m_s[2, 5] == 1.0 and g.m_s[4, 5] == 1.0  # indistinguishable by m(S)
    assert g.m_u[4, 5] < g.m_u[2, 5]  # but not by the doubt left
    g.m_s[3, 5], g.m_u[3, 5] = 0.9, 0.1  # join them into one region
    np.testing.assert_allclose(mp.peaks(), [[4.5, 5.5]])


def test_declaration_falls_back_to_strongest_cell() -> None:
    mp = DSMapper(DSMapperParams(cell_size=1.0, map_margin=0.0), ((0.0, 0.0), (5.0, 5.0)), 0.5)
    mp.grid.m_s[2, 3], mp.grid.m_u[2, 3] = 0.3, 0.7  # below source_min_mass
    d = mp.declaration()
    assert d.confidence == 0.0
    np.testing.assert_allclose(d.positions, [[2.5, 3.5]])
    mp.grid.m_s[1, 1], mp.grid.m_u[1, 1] = 0.8, 0.2
    d = mp.declaration()
    assert d.confidence == 1.0
    np.testing.assert_allclose(d.positions, [[1.5, 1.5]])


# ---------------------------------------------------------------------------- stop rule
def _ctx(region=((0.0, 0.0), (6.0, 6.0))) -> SearchContext:
    arena = Arena((0.0, 0.0), (6.0, 6.0), 0.25)
    return SearchContext(
        arena=arena,
        dt=0.5,
        agent_ids=(0,),
        start=np.array([[3.0, 3.0]]),
        speed_limits=np.array([0.5]),
        search_region=region,
    )


def _obs(t: float, det: bool = False) -> list[Observation]:
    return [
        Observation(
            agent=0,
            t=t,
            position=np.array([3.0, 3.0]),
            heading=0.0,
            gas=0.0,
            detection=det,
            wind=np.array([1.0, 0.0]),
            ready=True,
        )
    ]


def test_declares_exactly_when_the_planner_stops() -> None:
    rng = np.random.default_rng(0)
    # eta_E above any reachable fitness: the first real plan finds nothing worth visiting
    s = DSMappingSearcher(
        DSMappingParams(cell_size=0.5, eta_e=1e6, dwell_periods=0, visit_readings=0)
    )
    s.reset(_ctx(), rng)
    a0 = s.act(_obs(0.0), rng)  # a single record: no path map yet, no decision
    assert not a0.declarations and s.last_plan.extra["reason"] == "empty_path_map"
    a1 = s.act(_obs(0.5, det=True), rng)
    assert s.last_plan.extra["done"] and a1.declarations
    assert s.finished_at == 0.5
    assert a1.declarations[0].positions.shape[1] == 2
    # with the paper's eta_E the same map is far from finished
    s2 = DSMappingSearcher(DSMappingParams(cell_size=0.5, dwell_periods=0))
    s2.reset(_ctx(), rng)
    s2.act(_obs(0.0), rng)
    a = s2.act(_obs(0.5, det=True), rng)
    assert not a.declarations and a.commands[0].kind == "waypoint"
    assert math.hypot(*(a.commands[0].value - 3.0)) <= 0.5


def _walk(s: DSMappingSearcher, source: tuple[float, float], n: int, rng) -> list[Any]:
    """Drive ``s`` with perfect motion in a steady +x wind: a reading detects when the robot is
    within 3 m downwind of ``source`` and within 0.5 m across. Returns every action."""
    pos = np.array([3.0, 3.0])
    out = []
    for k in range(n):
        det = 0.0 < pos[0] - source[0] <= 3.0 and abs(pos[1] - source[1]) <= 0.5
        obs = _obs(0.5 * k, bool(det))
        obs[0] = dataclasses.replace(obs[0], position=pos.copy())
        a = s.act(obs, rng)
        out.append(a)
        if a.declarations:
            break
        if a.commands[0].kind == "waypoint":
            pos = np.asarray(a.commands[0].value, float)[:2].copy()
    return out


def test_mapped_sources_are_visited_up_their_plume_before_declaring() -> None:
    """When eq. 7's stop rule holds while a mapped source has not been read from, the route
    goes there and reads standing in its cell, walks on upwind along the mapped cells, and only
    then declares; with ``visit_readings=0`` it declares at the stop rule."""
    rng = np.random.default_rng(0)
    params = dict(cell_size=0.5, eta_e=1e6, dwell_periods=0, visit_readings=3, visit_time=60.0)
    s = DSMappingSearcher(DSMappingParams(**params))
    s.reset(_ctx(), rng)
    acts = _walk(s, (1.0, 3.0), 400, rng)
    assert acts[-1].declarations, "the visit stage must end"
    assert s.stop_rule_at <= 1.0 and s.n_visits >= 1
    assert s.finished_at > s.stop_rule_at  # the visits came first
    assert s.finished_at - s.stop_rule_at <= 60.0 + 0.5
    # the robot stood upwind of where it read at the stop rule, up the mapped plume
    xs = [float(a.commands[0].value[0]) for a in acts if a.commands[0].kind == "waypoint"]
    assert min(xs) < 3.0 - 1.0
    s0 = DSMappingSearcher(DSMappingParams(**{**params, "visit_readings": 0}))
    s0.reset(_ctx(), rng)
    acts0 = _walk(s0, (1.0, 3.0), 10, rng)
    assert acts0[-1].declarations and s0.finished_at == s0.stop_rule_at <= 1.0


def test_close_readings_place_a_source_the_far_ones_put_downwind() -> None:
    """Readings taken only far downwind of a source (path maps fading upwind) make the cell just
    upwind of the nearest readings the likeliest source, metres downwind of it; the readings of
    a walk up the plume (detections while the source is upwind, none past it) re-place it on
    the source. An estimate whose cell was not visited, or readings that do not bear on it,
    leave it where it was."""
    from odorloc.inference.odor_path.estimator import PathPatch

    p = DSMapperParams(cell_size=1.0, map_margin=0.0)
    mp = DSMapper(p, ((0.0, 0.0), (20.0, 10.0)), 0.5)
    grid = mp.grid.grid
    src = (5, 3)

    def read(x: int, k: int) -> None:
        # the path covers the 8 cells upwind of the robot, fading upwind (0.8 per cell)
        x0 = max(0, x - 8)
        values = (0.8 ** np.arange(x - x0, 0, -1) / 0.8)[:, None]
        covered = x0 <= src[0] < x
        det = covered and k % 2 == 0  # intermittent plume
        patch = PathPatch(x0, src[1], values, grid, np.array([x, src[1]]))
        mp.add_reading(patch, det, np.array([1.0, 0.0]))

    k = 0
    for _ in range(6):
        for x in range(9, 14):  # far: 4-8 m downwind of the source
            read(x, k)
            k += 1
    far = mp.source_positions()
    assert far[0][0] >= 7.5, far  # the old estimate: downwind, inside the footprint
    since = mp.n_readings
    for x in range(8, 3, -1):  # the walk up the plume, past the source
        for _ in range(6):
            read(x, k)
            k += 1
    visited = np.zeros(grid.shape, bool)
    visited[4:9, src[1]] = True
    visited[int(far[0][0]), src[1]] = True
    np.testing.assert_allclose(mp.refined(far[:1], since, visited), [[5.5, 3.5]])
    # the estimate's own cell not visited, or no reading since: unchanged
    np.testing.assert_allclose(mp.refined(far[:1], since, np.zeros(grid.shape, bool)), far[:1])
    np.testing.assert_allclose(mp.refined(far[:1], mp.n_readings), far[:1])
    # the mapper applies it once a route starts its close look and marks the cells it read from
    mp.start_close_look(since)
    for cell in np.argwhere(visited):
        mp.mark_visited(tuple(cell))
    np.testing.assert_array_equal(mp.visited, visited)
    np.testing.assert_allclose(mp.source_positions()[0], [5.5, 3.5])


def test_default_candidates_are_the_neighbours_not_the_own_cell() -> None:
    """Default: the first ring holds the neighbouring cell centres and excludes the robot's own
    cell; the move towards the chosen one is one step (max_speed * dt) long."""
    rng = np.random.default_rng(0)
    s = DSMappingSearcher(DSMappingParams(cell_size=0.5, dwell_periods=0))
    s.reset(_ctx(), rng)
    assert s.planner.params.step_range == pytest.approx(math.sqrt(2) * 0.5)
    assert not s.planner.params.include_current
    s.act(_obs(0.0), rng)  # no path map yet
    a = s.act(_obs(0.5, det=True), rng)
    target = s.motion.goal
    assert s.last_plan.extra["reason"] == "ok"
    # a cell centre next to the robot at (3, 3), not the robot's own cell (3.25, 3.25)
    assert not np.allclose(target, [3.25, 3.25])
    assert math.hypot(*(target - 3.0)) <= math.sqrt(2) * 0.5
    k = (target - 0.25) / 0.5
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    step = a.commands[0].value[:2] - 3.0
    assert math.hypot(*step) == pytest.approx(min(0.25, math.hypot(*(target - 3.0))))


def test_stay_candidate_is_the_literal_one_step_reach() -> None:
    """stay_candidate=True: radius max_speed * dt = 0.25 m, so only the own cell is in reach."""
    rng = np.random.default_rng(0)
    s = DSMappingSearcher(DSMappingParams(cell_size=0.5, stay_candidate=True, dwell_periods=0))
    s.reset(_ctx(), rng)
    assert s.planner.params.step_range == pytest.approx(0.25)
    s.act(_obs(0.0), rng)
    a = s.act(_obs(0.5, det=True), rng)
    assert s.last_plan.extra["reason"] == "ok"
    assert s.last_plan.extra["radius"] == pytest.approx(0.25)
    np.testing.assert_allclose(s.motion.goal, [3.25, 3.25])
    # one 0.25 m step along the diagonal towards the cell centre
    np.testing.assert_allclose(a.commands[0].value, 3.0 + 0.25 / math.sqrt(2))
    wide = DSMappingSearcher(DSMappingParams(cell_size=0.5, step_range=0.75))
    wide.reset(_ctx(), rng)
    assert wide.planner.params.step_range == 0.75


def test_planner_without_current_cell_never_stays() -> None:
    """With include_current=False the own cell is never chosen, even when it is the most
    uncertain: the planner widens to the neighbours instead."""
    from odorloc.inference.evidence.dempster_shafer import DSGrid
    from odorloc.planning.uncertainty_route import UncertaintyRouteParams, UncertaintyRoutePlanner

    g = DSGrid.from_extent(DSParams(), (0.0, 0.0), (5.0, 5.0), 1.0)
    g.m_n[:], g.m_u[:] = 1.0, 0.0  # everything known free (X = 0) ...
    g.m_n[2, 2], g.m_u[2, 2] = 0.0, 1.0  # ... but the robot's own cell (X = 3)
    g.m_n[2, 4], g.m_u[2, 4] = 0.0, 1.0  # and one cell two rows up
    pi = np.zeros((5, 5))
    pi[2, 2] = 1.0  # the path map covers the robot's cell only
    rng = np.random.default_rng(0)
    stay = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.0))
    np.testing.assert_allclose(stay.route(g, pi, (2.5, 2.5), rng).target, [2.5, 2.5])
    move = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=1.0, include_current=False))
    plan = move.route(g, pi, (2.5, 2.5), rng)
    # E = X at the candidate itself: only (2, 4) scores, reached after widening 1 -> 2 m
    np.testing.assert_allclose(plan.target, [2.5, 4.5])
    assert plan.reason == "widened" and plan.fitness == pytest.approx(3.0)


def test_stop_and_go_moves_one_step_then_dwells() -> None:
    """dwell_periods=1: a move of at most max_speed * dt, then a period standing still."""
    m = StopAndGo(0.25, 1)
    m.set_goal((1.0, 0.0))
    pos = np.array([0.0, 0.0])
    kinds, visited = [], []
    for _ in range(12):
        if m.arrived(pos):
            break
        c = m.command(pos)
        kinds.append(c.kind)
        if c.kind == "waypoint":
            pos = c.value.copy()
        visited.append(pos.copy())
    assert kinds == ["waypoint", "hold"] * 4
    np.testing.assert_allclose(visited[-1], [1.0, 0.0])
    np.testing.assert_allclose(np.diff(np.array(visited)[::2, 0]), 0.25)
    # a blocked robot (no progress) gives the goal up instead of pushing forever
    m.set_goal((5.0, 0.0))
    m.command(pos)
    m.hold_left = 0
    assert m.arrived(pos) and m.goal is None


def test_wave_rounds_restart_like_the_paper() -> None:
    """The paper's region and start: round 1 = 0.42 m approach + 8 lanes of 20 m + 7 shifts of
    2 m + the last lane back up to the left-top corner (194.4 m vs the paper's 193.5 m); each
    further round adds the 24.4 m return diagonal (five rounds: 1067.7 m vs 1060.8 m)."""
    region = ((18.7, 40.3), (32.7, 60.3))
    start = np.array([33.0, 40.0])
    wp = wave_waypoints(region, 2.0, "y", 5, start)
    n = len(wp) // 5
    np.testing.assert_allclose(wp[0], [32.7, 40.3])
    np.testing.assert_allclose(wp[n - 1], [18.7, 60.3])
    path = np.vstack([start, wp])
    legs = np.linalg.norm(np.diff(path, axis=0), axis=1)
    first = math.hypot(0.3, 0.3) + 8 * 20.0 + 7 * 2.0 + 20.0
    assert legs[:n].sum() == pytest.approx(first)
    assert legs.sum() == pytest.approx(first + 4 * (math.hypot(14.0, 20.0) + first - 0.3 * 2**0.5))
    alt = wave_waypoints(region, 2.0, "y", 2, start, round_order="alternate")
    np.testing.assert_allclose(alt[len(alt) // 2 :], alt[: len(alt) // 2][::-1])


# --------------------------------------------------------------------------- episodes
def test_reduced_episode_gives_row_and_map() -> None:
    sc = reduced_farrell(40.0)
    res = run_episode(sc, 11, 12, record=True)
    m = res.metrics
    assert m["termination"] in ("time_limit", "declared")
    for k in ("residual_uncertainty", "initial_uncertainty", "mapped_sources", "plans"):
        assert k in m and np.isfinite(m[k])
    # 12 x 16 cells of 0.5 m, 3 units of uncertainty each at the start
    assert m["initial_uncertainty"] == pytest.approx(3.0 * 12 * 16)
    assert 0 < m["residual_uncertainty"] < m["initial_uncertainty"]
    for k in range(int(m["mapped_sources"])):
        assert 19.0 <= m[f"mapped_x_{k}"] <= 25.0 and 48.0 <= m[f"mapped_y_{k}"] <= 56.0
    rec = res.recording
    snaps = [b for _, b in rec.beliefs if "m_s" in b]
    # the 6 m x 8 m region at 0.5 m plus the default one-cell margin on every side
    assert snaps and snaps[-1]["m_s"].shape == (14, 18)
    total = snaps[-1]["m_s"] + snaps[-1]["m_n"] + snaps[-1]["m_u"]
    np.testing.assert_allclose(total, 1.0, atol=1e-9)
    assert "total_uncertainty" in rec.diagnostics
    tu = rec.diagnostics["total_uncertainty"]
    assert tu[0] == pytest.approx(m["initial_uncertainty"], rel=0.05)
    assert tu[-1] == pytest.approx(m["residual_uncertainty"], rel=0.05)


def test_same_seed_same_episode() -> None:
    sc = reduced_farrell(25.0)
    a = run_episode(sc, 3, 4, record=True)
    b = run_episode(sc, 3, 4, record=True)
    assert _stable(a.metrics) == _stable(b.metrics)
    np.testing.assert_array_equal(a.recording.positions, b.recording.positions)
    # the route planner draws nothing from the agent's stream: another agent seed, same world,
    # same route; another world seed, another route
    c = run_episode(sc, 3, 5, record=True)
    np.testing.assert_array_equal(c.recording.positions, a.recording.positions)
    e = run_episode(sc, 4, 4, record=True)
    assert not np.array_equal(e.recording.gas, a.recording.gas)


def test_rectangular_wave_variant_moves_like_the_baseline_and_declares() -> None:
    base = {"lane_spacing": 2.0, "lanes_along": "y", "rounds": 1}
    region = [[21.0, 48.0], [25.0, 52.0]]
    ds = {"type": "ds-rectangular-wave", "dwell_periods": 0, **base}
    sc_ds = reduced_farrell(200.0, ds, region)
    sc_rw = reduced_farrell(200.0, {"type": "rectangular-wave", **base}, region)
    a = run_episode(sc_ds, 1, 2, record=True)
    b = run_episode(sc_rw, 1, 2, record=True)
    n = min(len(a.recording.t), len(b.recording.t))
    np.testing.assert_allclose(a.recording.positions[:n], b.recording.positions[:n])
    assert a.metrics["termination"] == "declared"
    # 3 lanes 4 m long, 2 steps of 2 m across, plus the approach from (25, 50) to (25, 48)
    assert a.metrics["path_length"] == pytest.approx(3 * 4 + 2 * 2 + 2, abs=0.3)
    assert a.metrics["residual_uncertainty"] < a.metrics["initial_uncertainty"]
    # stop-and-go (the default): the same path, about twice the time
    c = run_episode(reduced_farrell(200.0, {**ds, "dwell_periods": 1}, region), 1, 2)
    assert c.metrics["path_length"] == pytest.approx(a.metrics["path_length"], abs=1e-6)
    assert c.metrics["search_time"] == pytest.approx(2 * a.metrics["search_time"], abs=3.0)


@pytest.mark.slow
def test_both_sources_mapped_in_a_steady_world() -> None:
    # a 4 s air-mass path (the steady plume is 1-2 m wide, a 10 m path would reach past the
    # sources); neighbours as first candidates so the robot reaches the plumes within 400 s
    sc = steady_world({"type": "ds-mapping", "t_thr": 4.0, "step_range": 0.75})
    res = run_episode(sc, 0, 1, record=False)
    m = res.metrics
    row = dict(m)
    err = map_errors(row, res.sources, sc.task.success_radius)
    assert err["source_error_0"] <= 1.5 and err["source_error_1"] <= 1.5, (err, m)
    assert err["map_false_sources"] == 0 and m["detections"] > 0


def test_replay_reproduces_the_recorded_flow() -> None:
    """The movie equals the live world frame by frame, and an episode on its replay reads the
    same gas values as the live episode with the same seeds."""
    sc = reduced_farrell(10.0, {"type": "ds-rectangular-wave", "rounds": 1})
    movie = record_flow(sc, 7, duration=10.0)
    assert len(movie.times) == 21  # one frame per control period, plus the first
    world = build_world(sc)
    rng = episode_generators(7, 0)[0]
    world.reset(rng)
    for _ in range(round(sc.world.warmup / sc.world.dt)):
        world.step(sc.world.dt, rng)
    gx, gy = np.meshgrid(np.linspace(19, 30, 12), np.linspace(46, 58, 13), indexing="ij")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    for k in range(len(movie.times)):
        if k:
            world.step(sc.world.dt, rng)
            world.step(sc.world.dt, rng)
        np.testing.assert_array_equal(movie.concentration(k, pts), world.plume.concentration(pts))
        np.testing.assert_allclose(
            movie.wind_velocity(k, pts), world.wind.velocity(pts), rtol=1e-12, atol=1e-12
        )
    sc_r, built = on_replay(sc, movie)
    assert sc_r.world.warmup == 0.0 and sc_r.world.plume.type == "replay"
    replay = run_episode(sc_r, 7, 8, built=built, record=True).recording
    live = run_episode(sc, 7, 8, record=True).recording
    np.testing.assert_allclose(replay.positions, live.positions, atol=1e-9)
    np.testing.assert_allclose(replay.gas, live.gas, rtol=1e-12, atol=1e-12)
    assert live.gas.max() > 0


def test_map_errors_closed_form() -> None:
    sources = np.array([[20.0, 50.0], [24.0, 55.0]])
    row = {
        "mapped_sources": 3,
        "mapped_x_0": 20.0,
        "mapped_y_0": 51.0,
        "mapped_x_1": 27.0,
        "mapped_y_1": 59.0,
        "mapped_x_2": 30.0,
        "mapped_y_2": 45.0,
    }
    e = map_errors(row, sources, 1.5)
    assert e["source_error_0"] == pytest.approx(1.0)
    assert e["source_error_1"] == pytest.approx(5.0)  # 3-4-5 triangle
    assert e["map_false_sources"] == 2 and not e["map_success"]
    e = map_errors({"mapped_sources": 0}, sources, 1.5)
    assert math.isnan(e["source_error_0"]) and not e["map_success"]


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("name", "values", "field"),
    [
        ("ds-mapping", {"cell_size": -0.5}, "cell_size"),
        ("ds-mapping", {"eta_e": -1.0}, "eta_e"),
        ("ds-mapping", {"widen_factor": 1.0}, "widen_factor"),
        ("ds-mapping", {"widen_factor": math.inf}, "widen_factor"),
        ("ds-mapping", {"ds": {"zeta": 1.5}}, "ds.zeta"),
        ("ds-mapping", {"source_min_mass": 0.0}, "source_min_mass"),
        ("ds-mapping", {"cel_size": 0.5}, "cel_size"),
        ("ds-mapping", {"region": [[5.0, 0.0], [1.0, 1.0]]}, "region"),
        ("ds-rectangular-wave", {"rounds": 0}, "rounds"),
        ("ds-rectangular-wave", {"lane_spacing": 0.0}, "lane_spacing"),
    ],
)
def test_bad_params_name_the_field(name: str, values: dict, field: str) -> None:
    with pytest.raises(ConfigError) as info:
        registry.make_params("searcher", name, values, field="searcher")
    assert field in info.value.field or field in str(info.value)


def test_params_models_reject_directly() -> None:
    with pytest.raises(pydantic.ValidationError, match="cell_size"):
        DSMappingParams(cell_size=0.0)
    with pytest.raises(pydantic.ValidationError, match="rounds"):
        DSRectangularWaveParams(rounds=0)
    assert DSMappingParams().ds == DSParams()


@pytest.mark.parametrize("name", ["ds-mapping", "ds-rectangular-wave"])
def test_region_the_map_cannot_cover_is_refused(name: str) -> None:
    """A searcher region outside the arena, or cells so large that no cell centre lies in the
    region, would give a blank map (sum X = 0, nothing to map) instead of an error."""
    rng = np.random.default_rng(0)
    cls = registry.entry("searcher", name).build
    outside = registry.make_params(
        "searcher", name, {"region": [[100.0, 100.0], [110.0, 110.0]]}, field="searcher"
    )
    with pytest.raises(ConfigError, match=r"searcher\.region"):
        cls(outside).reset(_ctx(), rng)
    huge = registry.make_params("searcher", name, {"cell_size": 30.0}, field="searcher")
    with pytest.raises(ConfigError, match=r"searcher\.cell_size"):
        cls(huge).reset(_ctx(), rng)
    with pytest.raises(ConfigError, match="cell_size"):
        DSMapper(DSMapperParams(cell_size=1.0), ((2.1, 2.1), (2.4, 2.4)), 0.5)
    # a region reaching past the arena is fine: only its part inside can be read
    part = registry.make_params(
        "searcher", name, {"region": [[5.0, 5.0], [8.0, 8.0]]}, field="searcher"
    )
    cls(part).reset(_ctx(), rng)


def test_visit_readings_count_in_the_cell_the_reading_was_taken() -> None:
    """With the pre-processing (sensor delay 2 s = 4 periods) each fused reading belongs to
    the cell the robot stood in 2 s earlier; the visit stage's count must follow it, not the
    robot's cell at the time of fusing."""
    from odorloc.sensors.preprocessing import PreprocessorParams

    rng = np.random.default_rng(0)
    pre = PreprocessorParams(delay=2.0, period=0.5)
    s = DSMappingSearcher(DSMappingParams(cell_size=0.5, dwell_periods=0, preprocess=pre))
    s.reset(_ctx(), rng)
    g = s.mapper.grid
    g.m_s[:], g.m_u[:] = 0.9, 0.1  # every cell mapped: every reading tests a mapped cell
    here, there = np.array([1.25, 3.25]), np.array([4.25, 3.25])
    fused = []
    for k in range(12):  # six readings here, then six there
        o = _obs(0.5 * k)
        o[0] = dataclasses.replace(o[0], position=here if k < 6 else there, gas=1.0)
        before = s.mapper.n_readings
        s.act(o, rng)
        if s.mapper.n_readings > before and s.mapper.last_patch.values.size:
            fused.append(k - 4)  # the reading taken 4 periods ago
    assert fused, "no reading was fused"
    n_here = sum(k < 6 for k in fused)
    assert n_here >= 4 and len(fused) - n_here == 2
    cells = s.mapper.grid.grid.index(np.array([here, there]))
    assert s.tests[tuple(cells[0])] == n_here
    assert s.tests[tuple(cells[1])] == len(fused) - n_here
    assert s.tests.sum() == len(fused)


def test_multi_agent_is_refused() -> None:
    ctx = _ctx()
    ctx2 = SearchContext(
        arena=ctx.arena,
        dt=0.5,
        agent_ids=(0, 1),
        start=np.zeros((2, 2)),
        speed_limits=np.full(2, 0.5),
        search_region=ctx.search_region,
    )
    with pytest.raises(ConfigError, match="single robot"):
        DSMappingSearcher(DSMappingParams()).reset(ctx2, np.random.default_rng(0))


def test_fitness_path_distribution_divides_the_map_by_its_sum() -> None:
    """fitness_path="distribution" weighs X with pi / sum(pi) in eq. 7: on the same readings
    and map the best fitness is the default's divided by the path map's sum (same target)."""
    fits, sums = [], []
    for how in ("map", "distribution"):
        rng = np.random.default_rng(3)
        s = DSMappingSearcher(DSMappingParams(cell_size=0.5, dwell_periods=0, fitness_path=how))
        s.reset(_ctx(), rng)
        for i in range(6):  # uniform wind: every plan sees the same map shape
            s.act(_obs(0.5 * i, det=i % 2 == 0), rng)
        fits.append((s.last_plan.extra["fitness"], tuple(s.motion.goal)))
        sums.append(float(s.mapper.last_patch.values.sum()))
    (f_map, goal_map), (f_dist, goal_dist) = fits
    assert sums[0] == pytest.approx(sums[1]) and sums[0] > 1.5
    assert goal_map == goal_dist
    assert f_dist == pytest.approx(f_map / sums[0], rel=1e-9)
    assert f_dist <= 3.0 + 1e-12  # a weighted mean of X <= q


def test_reproduction_stores_each_flow_and_resumes(tmp_path) -> None:
    """A short ds-multi-source run on the ordinary (replay) sweep writes rows, scene residuals
    and figures; running it again reruns nothing, more episodes add only the missing flows,
    and a store of other settings is refused."""
    from odorloc.papers.ds_multi_source.reproduction import DSReproduction

    repro = DSReproduction(time_limit=20.0)
    first = repro.run(tmp_path, episodes=1, workers=1, progress=False)
    df = first.results
    assert sorted(df.searcher) == ["ds-mapping", "ds-rectangular-wave"]
    assert df["replay"].all() and df["scene_residual_0"].notna().all()
    assert (df.residual_uncertainty <= df.initial_uncertainty).all()
    assert "time_to_baseline_residual" in df
    for name in ("state_maps.png", "uncertainty_vs_time.png", "report.html", "paired.csv"):
        assert (tmp_path / name).is_file(), name
    assert not first.failed_figures
    stamp = {r.searcher: r.finished_at for r in _stored(tmp_path).itertuples()}
    again = repro.run(tmp_path, episodes=1, workers=1, progress=False)
    assert {r.searcher: r.finished_at for r in _stored(tmp_path).itertuples()} == stamp
    cols = ["search_time", "residual_uncertainty", "path_length"]
    np.testing.assert_array_equal(
        again.results.sort_values("searcher")[cols], df.sort_values("searcher")[cols]
    )
    more = repro.run(tmp_path, episodes=2, workers=1, progress=False)
    assert len(more.results) == 4
    with pytest.raises(ConfigError, match="store"):
        DSReproduction(time_limit=25.0).run(tmp_path, episodes=1, workers=1, progress=False)


def _stored(path):
    import sqlite3

    import pandas as pd

    with sqlite3.connect(path / "results.sqlite") as con:
        return pd.read_sql("SELECT searcher, episode, finished_at FROM episodes", con)


def test_preprocessed_readings_are_fused_at_the_period_they_belong_to() -> None:
    """With the odor-path paper's pre-processing (eqs. 1-5) a sensor delayed by 1 s (two
    periods) is read back: each reading is fused with the position and time of the air it
    sampled, and its detection comes from the signal intensity."""
    from odorloc.sensors.preprocessing import PreprocessorParams

    p = DSMapperParams(
        cell_size=0.5,
        preprocess=PreprocessorParams(delay=1.0, period=0.5),
        intensity_threshold=0.5,
    )
    mp = DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.5)
    readings = [1.0, 1.0, 1.0, 3.0, 1.0, 1.0]  # the jump belongs to t = 0.5 s (1 s earlier)
    out = []
    for i, c in enumerate(readings):
        pos = np.array([5.0 + 0.5 * i, 5.0])
        out.append(mp.update(0.5 * i, pos, np.array([1.0, 0.0]), c >= 2.0, reading=c))
    assert out[0] is None and out[1] is None and all(o is not None for o in out[2:])
    np.testing.assert_allclose(mp.estimator.times, [0.0, 0.5, 1.0, 1.5])
    assert mp.n_detections == 1 and mp.n_readings == 4
    # the last reading fused is the one taken at (6.5, 5.0), 1 s before the last call
    np.testing.assert_array_equal(out[-1].ref_cell, mp.grid.grid.index([[6.5, 5.0]])[0])
    with pytest.raises(ConfigError, match="reading"):
        mp.update(3.0, np.array([5.0, 5.0]), np.array([1.0, 0.0]), False)


def test_preprocessing_period_must_be_the_control_period() -> None:
    """The pre-processor counts the sensor delay in its own periods, one reading per call: at a
    0.25 s control period a 0.5 s ``period`` would align a 1 s delay as 0.5 s, so it is refused;
    at the matching period the jump read at t = 1.25 s is fused with the record of t = 0.25 s."""
    from odorloc.sensors.preprocessing import PreprocessorParams

    def mapper(period: float) -> DSMapper:
        pre = PreprocessorParams(delay=1.0, period=period)
        p = DSMapperParams(cell_size=0.5, preprocess=pre, intensity_threshold=0.5)
        return DSMapper(p, ((0.0, 0.0), (10.0, 10.0)), 0.25)

    with pytest.raises(ConfigError, match=r"preprocess\.period"):
        mapper(0.5)
    mp = mapper(0.25)
    readings = [1.0] * 5 + [3.0] + [1.0] * 4
    fused_at = []
    for i, c in enumerate(readings):
        pos = np.array([5.0 + 0.25 * i, 5.0])
        before = mp.n_detections
        mp.update(0.25 * i, pos, np.array([1.0, 0.0]), c >= 2.0, reading=c)
        if mp.n_detections > before:
            fused_at.append(float(mp.estimator.times[-1]))
    assert fused_at == [0.25]


def test_failed_wave_episode_leaves_the_dynamic_row_valid() -> None:
    """The dynamic route's row compares it with the wave's final residual on the same flow;
    when the wave's episode failed (its row has no mapping columns) the comparison is missing
    (NaN) and the dynamic route's own columns are still computed."""
    from types import SimpleNamespace

    from odorloc.experiments.runner import ROW_DEFAULTS
    from odorloc.papers.ds_multi_source.reproduction import ds_extras

    res = run_episode(reduced_farrell(5.0), 1, 2, record=True)
    task = SimpleNamespace(cell={"scenario": "two-sources-farrell", "searcher": "ds-mapping"})
    failed = {**ROW_DEFAULTS, "status": "error", "error": "RuntimeError: failed"}
    out = ds_extras(task, res, {"0/two-sources-farrell/ds-rectangular-wave": failed})
    assert math.isnan(out["time_to_baseline_residual"])
    assert math.isnan(out["distance_to_baseline_residual"])
    assert "scene_residual_0" in out and "map_success" in out


def test_edge_reach_past_the_map_margin_is_refused() -> None:
    """Candidates ``edge_reach`` past the region need map cells there: with ``map_margin=0``
    the default half-cell reach would find none, the robot could never stand on the region's
    edge and its downwind-most cells would never be read, so the combination is refused."""
    rng = np.random.default_rng(0)
    ctx = _ctx(region=((1.0, 1.0), (5.0, 5.0)))
    for bad in ({"map_margin": 0.0}, {"map_margin": 0.5, "edge_reach": 0.75}):
        s = DSMappingSearcher(DSMappingParams(cell_size=0.5, **bad))
        with pytest.raises(ConfigError, match=r"searcher\.edge_reach"):
            s.reset(ctx, rng)
    for good in ({}, {"map_margin": 0.0, "edge_reach": 0.0}, {"map_margin": 0.25}):
        s = DSMappingSearcher(DSMappingParams(cell_size=0.5, **good))
        s.reset(ctx, rng)
        grid = s.mapper.grid.grid
        e = s.planner.params.edge_reach * (1.0 + 1e-9)
        grown = grid.region_mask(((1.0 - e, 1.0 - e), (5.0 + e, 5.0 + e)))
        # with edge_reach > 0 some candidate puts the robot on the region's (downwind) edge
        x_far = grid.x_centers()[grown.any(axis=1)].max()
        assert (x_far >= 5.0) == (e > 0)
