"""The multi-UAV paper in odorloc: scenario, the four team compositions, accounting, episodes."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import Episode, run_episode
from odorloc.experiments.sweep import load_sweep
from odorloc.inference.particles.regularised import RegularisedResampler, silverman_bandwidth
from odorloc.models.vergassola import correlation_length
from odorloc.papers.muc_osl.placement import PAPER_STARTS, uav_starts
from odorloc.papers.muc_osl.reproduction import NO_ENV_PU_PARAMS, add_uav_search_time
from odorloc.papers.muc_osl.sweeps import NO_ENV_PU
from odorloc.scenarios import Scenario, get_scenario
from odorloc.scenarios.build import build
from odorloc.searchers.uav_team import SENSOR_RADIUS, UAVPlannerMember, default_model

ALGORITHMS = ("muc-osl", "col-inf", "col-pf", "adap-pp")


def _scenario(searcher: dict, **overrides: object) -> Scenario:
    return get_scenario("muc-osl-3d").with_overrides({"searcher": searcher, **overrides})


def test_the_start_corner_is_downwind_of_the_source() -> None:
    sc = get_scenario("muc-osl-3d")
    b = build(sc)
    src = np.asarray(sc.world.sources[0].position)
    wind = np.asarray(sc.world.wind.params("wind").velocity)
    np.testing.assert_allclose(src, [10.0, 30.0, 25.0])
    assert wind[1] < 0 and wind[0] == wind[2] == 0  # towards -y, as eq. 1 has it
    for start in sc.agents.starts:
        assert float(np.dot(np.asarray(start) - src, wind)) > 0  # on the side it blows to
    # eq. 1: the rate 20 m downwind of the source is far above the rate 20 m upwind
    plume = b.world.plume
    b.world.reset(np.random.default_rng(0))
    down, up = plume.encounter_rate(np.array([[10.0, 10.0, 25.0], [10.0, 50.0, 25.0]]))
    assert down > 1e3 * up
    a = SENSOR_RADIUS
    assert down == pytest.approx(a * 5.0 / 20.0 * math.exp(10.0 - 20.0 / plume.length), rel=1e-9)


@pytest.mark.parametrize("name", ALGORITHMS)
def test_the_searchers_model_is_the_worlds_rate_model(name: str) -> None:
    """The four teams believe the rate model the world runs: Q, V, D, tau and the sensor
    radius (which the paper leaves open and the scenario calibrates) all agree."""
    sc = _scenario({"type": name})
    ep = Episode(sc, record=False)
    ep.reset(1, 2)
    searcher = ep.built.searcher
    searcher.reset(ep.context, ep.agent_rng)
    plume = ep.world.plume
    world = plume.params
    source = plume.source_positions
    np.testing.assert_array_equal(source, [sc.world.sources[0].position])
    # downwind on the axis, off the axis, upwind and near the source: the rate's every regime
    points = np.array(
        [[10.0, 10.0, 25.0], [14.0, 16.0, 22.0], [10.0, 45.0, 25.0], [11.0, 29.0, 26.0]]
    )
    truth = plume.encounter_rate(points)
    assert np.all(truth > 0)
    members = searcher.members
    assert len(members) == len(sc.agents.starts)
    for member in members:
        model = member.model
        np.testing.assert_allclose(model.rate(points, source)[:, 0], truth, rtol=1e-12, atol=0)
        p = model.params
        assert p.sensor_radius == world.sensor_radius == SENSOR_RADIUS
        assert (p.V, p.D, p.tau) == (plume.V, world.D, world.tau)
        assert plume.sources[0].rate == p.Q


def test_default_model_fits_the_dimension() -> None:
    """3-D takes the calibrated radius; 2-D keeps a below lambda (about 1.96 m), where the 2-D
    rate of eq. 3 is defined, so the members run in 2-D worlds with their defaults."""
    three = default_model(3).params("model")
    two = default_model(2).params("model")
    assert three.sensor_radius == SENSOR_RADIUS
    lam = correlation_length(two.V, two.D, two.tau)
    assert two.sensor_radius < lam < SENSOR_RADIUS
    assert (two.Q, two.V, two.D, two.tau) == (three.Q, three.V, three.D, three.tau)


def test_uav_placement_rule() -> None:
    assert [tuple(p) for p in uav_starts(3)] == list(PAPER_STARTS)
    assert get_scenario("muc-osl-3d").agents.starts == [tuple(p) for p in uav_starts(3)]
    eight = uav_starts(8)
    assert [p[0] for p in eight] == [10.0, 30.0, 60.0, 20.0, 40.0, 50.0, 70.0, 80.0]
    assert all(p[1:] == [10.0, 5.0] for p in eight)
    for n in range(1, 9):
        assert uav_starts(n) == eight[:n]
    with pytest.raises(ConfigError, match="n_uavs"):
        uav_starts(0)
    with pytest.raises(ConfigError, match="n_uavs"):
        uav_starts(20, width=60.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"width": 8.0}, "width"),  # no multiple of 10 m inside: the lone UAV sat on x = 0
        ({"width": 10.0}, "width"),
        ({"width": math.nan}, "width"),
        ({"width": math.inf}, "width"),
        ({"y": 70.0}, "y"),  # beyond the 60 m depth
        ({"y": -1.0}, "y"),
        ({"z": 35.0}, "z"),  # above the 30 m ceiling
        ({"z": math.nan}, "z"),
        ({"y": 80.0, "depth": 60.0}, "y"),
        ({"depth": 0.0}, "depth"),
        ({"height": -5.0}, "height"),
    ],
)
def test_uav_placement_refuses_starts_outside_the_arena(kwargs: dict, field: str) -> None:
    with pytest.raises(ConfigError, match=f"^{field}: "):
        uav_starts(1, **kwargs)


def test_uav_placement_inside_a_small_or_deep_arena() -> None:
    # the smallest width with an inner start: the first UAV is inside, the walls come last
    assert [p[0] for p in uav_starts(3, width=15.0)] == [10.0, 0.0, 15.0]
    assert uav_starts(2, width=100.0, y=150.0, z=40.0, depth=200.0, height=50.0) == [
        [10.0, 150.0, 40.0],
        [30.0, 150.0, 40.0],
    ]
    with pytest.raises(ConfigError, match=r"^n_uavs: "):
        uav_starts(2.0)  # type: ignore[arg-type]


def test_presets_are_compositions_of_the_same_member() -> None:
    """``muc-osl`` is the per-agent team of ``uav-pf`` members with Col-PF x Adap-PP."""
    limits = {"limits.time": 60.0}
    preset = run_episode(_scenario({"type": "muc-osl"}, **limits), 11, 12, record=True)
    member = {
        "type": "uav-pf",
        "estimator": {"type": "col-pf"},
        "planner": {"type": "adap-pp"},
    }
    team = run_episode(
        _scenario({"type": "per-agent", "member": member}, **limits), 11, 12, record=True
    )
    np.testing.assert_array_equal(preset.recording.positions, team.recording.positions)
    assert preset.metrics["bytes"] == team.metrics["bytes"]
    # and col-pf with the adaptive planner is MUC-OSL again
    again = run_episode(
        _scenario({"type": "col-pf", "planner": {"type": "adap-pp"}}, **limits),
        11,
        12,
        record=True,
    )
    np.testing.assert_array_equal(preset.recording.positions, again.recording.positions)


@pytest.mark.parametrize("name", ALGORITHMS)
def test_each_preset_names_its_parts(name: str) -> None:
    b = build(_scenario({"type": name}))
    ep = Episode(_scenario({"type": name}), built=b, record=False)
    ep.reset(1, 2)
    b.searcher.reset(ep.context, ep.agent_rng)
    members = b.searcher.members
    assert len(members) == 3 and all(isinstance(m, UAVPlannerMember) for m in members)
    est = {
        "muc-osl": "col-pf",
        "col-inf": "standard-pf",
        "col-pf": "col-pf",
        "adap-pp": "standard-pf",
    }[name]
    plan = {
        "muc-osl": "adap-pp",
        "col-inf": "fixed-step-infotaxis",
        "col-pf": "fixed-step-infotaxis",
        "adap-pp": "adap-pp",
    }[name]
    assert members[0].params.estimator.type == est
    assert members[0].params.planner.type == plan


def test_bytes_counted_equal_payload_sizes_times_recipients() -> None:
    for name, per_message in (("muc-osl", 17 * 8), ("col-inf", 4 * 100 * 8)):
        sc = _scenario({"type": name}, **{"limits.time": 80.0, "agents.comm_radius": 25.0})
        ep = Episode(sc, record=False)
        obs = ep.reset(3, 4)
        s = ep.built.searcher
        s.reset(ep.context, ep.agent_rng)
        expected = 0
        sizes = set()
        while not ep.done:
            action = s.act(obs, ep.agent_rng)
            pos = np.array([p.position for p in ep.platforms])
            res = ep.step(action, s)
            delivered = not res.done or res.termination == "reached"
            if not delivered:
                continue
            for sender, payload in action.messages.items():
                size = payload.nbytes
                sizes.add(size)
                d = np.linalg.norm(pos - pos[sender], axis=1)
                expected += size * int(np.sum((d <= 25.0) & (np.arange(len(pos)) != sender)))
            obs = res.observations
        m = ep.result(s.final_metrics(), agents=s.agent_metrics()).metrics
        assert m["bytes"] == expected > 0
        assert sizes == {per_message}
        assert {a["numbers_per_message"] for a in m.agents.values()} == {per_message / 8}
        assert m["energy_comm"] > 0 and m["energy_compute"] > 0


#: Starts inside the plume, 14-18 m downwind of the source.
IN_PLUME = [[10.0, 16.0, 25.0], [14.0, 12.0, 23.0], [6.0, 12.0, 27.0]]


@pytest.mark.parametrize("name", ALGORITHMS)
def test_a_seeded_episode_of_each_algorithm_finds_the_source(name: str) -> None:
    """End to end: estimator, planner, messages, UAV timing and the reach rule together.

    One fixed episode (root seed 0, episode 7) from starts inside the plume. Episodes 0-9 of
    that seed succeed 10/10 for Col-Inf and Adap-PP but only 4/10 and 5/10 for MUC-OSL and
    Col-PF (eq. 16's upwind moves, see the reproduction); episode 7 is one all four find. The
    success rates over many episodes from the paper's starts are the reproduction's business.
    """
    sc = _scenario({"type": name}, **{"agents.starts": IN_PLUME, "limits.time": 400.0})
    res = run_episode(sc, *episode_seeds(0, "muc-osl-3d", 7))
    m = res.metrics
    assert m["termination"] == "reached" and m["success"]
    src = np.asarray(sc.world.sources[0].position)
    reached = [e for e in res.events if e.kind == "source_reached"]
    assert len(reached) == 1 and np.linalg.norm(reached[0].position - src) <= 2.0
    assert m["reach_agent"] == reached[0].agent


def test_search_time_is_the_busy_time_of_the_first_uav_to_reach() -> None:
    sc = _scenario({"type": "muc-osl"}, **{"agents.starts": IN_PLUME, "limits.time": 400.0})
    res = run_episode(sc, *episode_seeds(0, "muc-osl-3d", 1))
    m = res.metrics
    assert m["termination"] == "reached" and m["success"]
    busy = m["reach_fly_time"] + m["reach_hover_time"] + m["reach_turn_time"]
    assert 0 < busy <= m["search_time"] + 1e-9
    assert m["search_time"] - busy == pytest.approx(m["reach_idle_time"], abs=1e-6)
    assert m["team_hover_time"] >= m["reach_hover_time"]
    row = add_uav_search_time(__import__("pandas").DataFrame([m]))
    assert row["uav_search_time"].iloc[0] == pytest.approx(busy)
    move = (m["energy_fly"] + m["energy_hover"] + m["energy_turn"]) / 1e3
    assert row["movement_kj"].iloc[0] == pytest.approx(move)
    # eqs. 4-6 with the paper's powers: E_M from the team's time totals
    expected = 0.663 * m["team_fly_time"] + 0.47 * m["team_hover_time"] + 3.415 * m["team_n_turns"]
    assert move == pytest.approx(expected, rel=1e-9)


def test_a_uav_team_episode_is_deterministic_per_seed() -> None:
    sc = _scenario({"type": "muc-osl"}, **{"limits.time": 120.0})
    a = run_episode(sc, 5, 6, record=True)
    b = run_episode(sc, 5, 6, record=True)
    np.testing.assert_array_equal(a.recording.positions, b.recording.positions)
    for k in ("bytes", "energy"):
        assert a.metrics[k] == b.metrics[k]
    for k in ("cues", "iterations", "particles_mean"):
        assert [v[k] for v in a.metrics.agents.values()] == [
            v[k] for v in b.metrics.agents.values()
        ]


def test_bad_parts_are_named() -> None:
    with pytest.raises(ConfigError) as e:
        _scenario({"type": "muc-osl", "estimator": {"type": "kalman"}})
    assert e.value.field == "searcher.estimator.type"
    with pytest.raises(ConfigError) as e:
        _scenario({"type": "muc-osl", "planner": {"type": "adap-pp", "h1_scale": -1.0}})
    assert e.value.field == "searcher.planner.h1_scale"
    with pytest.raises(ConfigError) as e:
        _scenario({"type": "col-inf", "estimator": {"type": "col-pf", "n_min": 200}})
    assert e.value.field.startswith("searcher.estimator")


def test_regularised_resampler_moves_copies_by_the_cloud_spread() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(0.0, [10.0, 1.0, 0.1], (4000, 3))
    lw = np.full(4000, -math.log(4000))
    out, _ = RegularisedResampler().resample(x, lw, np.random.default_rng(1), n=4000)
    h = silverman_bandwidth(4000, 3)
    # Equal weights: the systematic selection keeps every particle once, in order, so
    # out - x is the kernel move alone. Its spread is h times the cloud's along each (here
    # principal) axis, floored at min_std = 0.1 m; a relative standard error of about
    # 1 / sqrt(2 * 4000) = 1.1 % allows 4 %.
    move = out - x
    np.testing.assert_allclose(move.std(axis=0)[:2], h * x.std(axis=0)[:2], rtol=0.04)
    assert move.std(axis=0)[2] == pytest.approx(0.1, rel=0.04)  # h * 0.1 m is below the floor
    np.testing.assert_array_less(np.abs(move.mean(axis=0)), 4 * move.std(axis=0) / math.sqrt(4000))


EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


def test_the_sensor_radius_example_prints_col_inf_beside_table_2() -> None:
    r = subprocess.run(
        [sys.executable, str(EXAMPLES / "muc_osl_sensor_radius.py"), "--radii", "3.5",
         "--episodes", "2", "--workers", "1"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("Col-Inf on muc-osl-3d, 2 episodes")
    row = lines[2].split()
    assert row[0] == "3.5" and len(row) == 8  # a, success (two tokens), MST, hover .. E_M
    assert lines[3].split() == ["paper", "-", "-", "261", "223", "893", "1476"]


def test_the_default_point_sweep_file_runs_the_four_and_the_ablation() -> None:
    spec = load_sweep(EXAMPLES / "sweep-muc-osl-default.yaml")
    assert [s.name for s in spec.scenarios] == ["muc-osl-3d"]
    assert [s.display for s in spec.searchers] == [*ALGORITHMS, NO_ENV_PU]
    assert spec.searchers[-1].params == NO_ENV_PU_PARAMS
