"""The multi-UAV evaluation: sweep settings, the filament world, the PID counts, the statistics
and the verdicts on the paper's statements."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.experiments.claims import Cells, Points
from odorloc.experiments.runner import cell_scenario
from odorloc.experiments.sweep import expand_cells, load_sweep, make_task
from odorloc.papers.muc_osl.claims import evaluate_claims
from odorloc.papers.muc_osl.reproduction import COLUMNS
from odorloc.papers.muc_osl.sweeps import (
    ALGORITHMS,
    DEFAULT,
    FIG9_VALUES,
    NO_ENV_PU,
    NO_ENV_PU_PARAMS,
    SWEEPS,
    Setting,
    ablation_files,
    cell_of,
    fig9_settings,
    source_position,
    sweep_files,
)
from odorloc.plume.filament import FilamentParams
from odorloc.scenarios import Scenario, get_scenario
from odorloc.sensors.pid import PIDCountParams, PIDCountSensor, hits_from_concentration

# ----------------------------------------------------------------------------- settings


def test_sweeps_are_the_papers() -> None:
    by = {s.key: s for s in SWEEPS}
    assert [s.figure for s in SWEEPS] == ["Fig. 4", "Fig. 5", "Fig. 6", "Fig. 7"]
    assert by["area"].values == ((60, 60, 30), (100, 60, 30), (100, 100, 50), (100, 200, 50))
    assert by["uavs"].values == tuple(range(1, 9))
    assert by["radius"].values == (0, 5, 10, 15, 20, 25, 30)
    assert by["radius"].base.n_uavs == 4
    assert by["particles"].values == tuple(range(20, 221, 20))
    assert Setting((100.0, 60.0, 30.0), 3, 30.0, 100) == DEFAULT


def test_source_keeps_the_defaults_place_in_every_area() -> None:
    assert source_position((100, 60, 30)) == (10.0, 30.0, 25.0)
    assert source_position((60, 60, 30)) == (6.0, 30.0, 25.0)
    x, y, z = source_position((100, 200, 50))
    assert (x, y) == (10.0, 100.0) and z == pytest.approx(125 / 3, abs=1e-6)


def test_every_setting_gives_a_valid_world() -> None:
    """Area, source, starts and radius land in the scenario; starts and source are inside."""
    for sw in SWEEPS:
        for s in sw.settings():
            sc = cell_scenario({"scenario": "muc-osl-3d", "scenario_params": s.world().params})
            hi = np.asarray(sc.world.arena.upper)
            src = np.asarray(sc.world.sources[0].position)
            starts = np.asarray(sc.agents.starts)
            assert tuple(hi) == tuple(s.area)
            assert np.allclose(src, source_position(s.area))
            assert len(starts) == s.n_uavs and sc.agents.comm_radius == s.radius
            assert np.all(starts > 0) and np.all(starts < hi) and np.all(src < hi)
            assert len({tuple(p) for p in starts}) == s.n_uavs


def test_world_keys_and_common_random_numbers() -> None:
    """The default world is the scenario's own name; particle counts share the default world,
    so every algorithm and count gets the same seeds as ``odorloc run muc-osl-3d``."""
    assert cell_of("muc-osl-3d", DEFAULT, "col-inf") == ("muc-osl-3d", "col-inf")
    s = Setting(n_uavs=4, radius=0.0)
    assert cell_of("muc-osl-3d", s, "muc-osl")[0] == "muc-osl-3d[radius=0,uavs=4]"
    n20 = Setting(n_particles=20)
    assert cell_of("muc-osl-3d", n20, "adap-pp") == ("muc-osl-3d", "adap-pp[N=20]")
    files = sweep_files("muc-osl-3d", SWEEPS, 3, 2024)
    main, parts = load_sweep(files[""]), load_sweep(files["particles"])
    cells = expand_cells(main) + expand_cells(parts)
    # every point's world x the four and the two printed presets; the particle counts on the
    # default world
    assert len(expand_cells(main)) == 17 * 6 and len(expand_cells(parts)) == 10 * 6
    assert len({c.cell_id for c in cells}) == len(cells)
    seeds = {
        c.cell_id: make_task(main if c in expand_cells(main) else parts, c, 2).world_seed
        for c in cells
        if c.world_key == "muc-osl-3d"
    }
    assert len(seeds) == 6 + 60 and len(set(seeds.values())) == 1
    assert set(seeds.values()) == {episode_seeds(2024, "muc-osl-3d", 2)[0]}
    # the radius-30 point of Fig. 6 is the 4-UAV point of Fig. 5
    worlds = [c.world_key for c in expand_cells(main)]
    assert worlds.count("muc-osl-3d[uavs=4]") == 6


def test_particle_counts_are_searcher_parameters() -> None:
    files = sweep_files("muc-osl-3d", SWEEPS, 1, 0)
    se = {s["label"]: s for s in files["particles"]["searchers"]}
    assert se["muc-osl[N=20]"]["params"] == {"estimator": {"type": "col-pf", "n_particles": 20}}
    # a preset's own estimator settings are kept: the printed reading stays printed
    printed = se["muc-osl-printed[N=20]"]["params"]["estimator"]
    assert printed == {"type": "col-pf", "pugl_move": "printed", "n_particles": 20}
    assert se["col-inf[N=220]"]["params"]["estimator"]["type"] == "standard-pf"
    assert "muc-osl[N=100]" not in se
    sc = cell_scenario(
        {
            "scenario": "muc-osl-3d",
            "searcher": "adap-pp",
            "searcher_params": se["adap-pp[N=40]"]["params"],
        }
    )
    assert sc.searcher.values["estimator"] == {"type": "standard-pf", "n_particles": 40}


def test_fig9_settings_are_subsets() -> None:
    for full, sub in zip(SWEEPS, fig9_settings(), strict=True):
        assert set(sub.values) <= set(full.values)
        assert sub.values == FIG9_VALUES[full.key]


# ----------------------------------------------------------------------------- filament world


def test_filament_world_has_the_papers_gaden_parameters() -> None:
    sc = get_scenario("muc-osl-filament-3d")
    p = sc.world.plume.params("plume")
    ref = FilamentParams.from_gaden(
        initial_std_cm=50.0, growth_gamma_cm2=50.0, noise_std_m=0.5, ppm_center=100.0,
        time_step=0.5,
    )  # fmt: skip
    for k in ("sigma0", "gamma", "noise_std", "amount"):
        assert getattr(p, k) == pytest.approx(getattr(ref, k), rel=1e-12), k
    assert sc.world.sources[0].rate == 50.0 and sc.world.dt == 0.5
    # a new filament peaks at 100 ppm at its centre
    peak = p.amount / (2 * math.pi * p.sigma0**2) ** 1.5
    assert peak == pytest.approx(100.0)
    w = sc.world.wind.params("wind")
    assert w.speed == 1.0 and w.direction == -90.0 and w.noise_std > 0  # towards -y, varying
    base = get_scenario("muc-osl-3d")
    assert sc.agents.starts == base.agents.starts and sc.task == base.task
    assert sc.world.sources[0].position == base.world.sources[0].position
    assert (
        sc.sensors.gas.type == "pid-count"
        and sc.sensors.anemometer.params("anemometer").noise_std > 0
    )


def test_filament_plume_reaches_the_start_edge_and_is_intermittent() -> None:
    """After the warm-up the plume is 20 m downwind at the source height, patchy, and absent
    at the UAVs' start height."""
    from odorloc.engine.episode import prepare_world

    sc = get_scenario("muc-osl-filament-3d")
    world, rng, _ = prepare_world(sc, 7)
    pts = np.array([[10.0, 10.0, 25.0], [10.0, 10.0, 5.0]])
    c = []
    for _ in range(120):
        world.step(0.5, rng)
        c.append(world.plume.concentration(pts))
    c = np.array(c)
    assert 0.2 < np.mean(c[:, 0] >= 100.0) < 0.95
    assert np.max(c[:, 1]) < 1.0


# ----------------------------------------------------------------------------- PID counts


def test_hits_floor_the_concentration_per_hit() -> None:
    c = np.array([-5.0, 0.0, 99.9, 100.0, 199.99, 200.0, 250.0, 1e4])
    np.testing.assert_array_equal(hits_from_concentration(c, 100.0), [0, 0, 0, 1, 1, 2, 2, 100])
    np.testing.assert_array_equal(hits_from_concentration(c, 100.0, max_hits=5)[-1], 5)


class _Constant:
    """A plume stand-in with a set concentration."""

    dim = 3

    def __init__(self) -> None:
        self.c = 0.0

    def concentration(self, points: np.ndarray) -> np.ndarray:
        return np.full(len(points), self.c)


def test_pid_counts_follow_the_pid_response() -> None:
    """A step of 450 ppm seen through a 1 s lag, read every second: the count follows
    ``floor(450 (1 - exp(-k)) / 100)``; the raw value is the true concentration."""
    s = PIDCountSensor(PIDCountParams(tau=1.0, start="zero"))
    s.reset()
    plume, rng = _Constant(), np.random.default_rng(0)
    plume.c = 450.0
    got = [s.measure(plume, np.zeros(3), 1.0, rng) for _ in range(5)]
    want = [math.floor(450 * (1 - math.exp(-(k + 1))) / 100) for k in range(5)]
    assert [r.value for r in got] == want
    assert all(r.raw == 450.0 for r in got)
    assert [r.detection for r in got] == [v >= 1 for v in want]
    assert s.info.unit == "hits" and s.info.threshold == 1.0


def test_pid_noise_is_seeded_and_bad_settings_are_named() -> None:
    plume = _Constant()
    plume.c = 150.0

    def roll() -> list[float]:
        s = PIDCountSensor(PIDCountParams(noise_std=60.0))
        rng = np.random.default_rng(3)
        return [s.measure(plume, np.zeros(3), 1.0, rng).value for _ in range(50)]

    a = roll()
    assert a == roll() and len(set(a)) > 1
    data = get_scenario("muc-osl-filament-3d").to_dict()
    data["sensors"]["gas"]["ppm_per_hit"] = 0.0
    with pytest.raises(ConfigError, match=r"sensors\.gas\.ppm_per_hit"):
        Scenario.from_dict(data)


# ----------------------------------------------------------------------------- statistics


def _rows(world: str, label: str, success: list[bool], time: list[float]) -> pd.DataFrame:
    n = len(success)
    return pd.DataFrame(
        {
            "world_key": world,
            "searcher": label,
            "episode": np.arange(n),
            "status": "ok",
            "success": success,
            "reach_fly_hover_turn_time": time,
            "team_movement_energy": np.full(n, 1000.0 if label != "muc-osl" else 900.0),
            "team_hover_time": np.full(n, 100.0 if label != "muc-osl" else 80.0),
            "team_turn_time": np.full(n, 100.0 if label != "muc-osl" else 80.0),
            "path_length": np.full(n, 500.0),
        }
    )


def _world(good: str, n: int = 30) -> pd.DataFrame:
    """Every algorithm at every point of the UAV sweep: ``good`` always succeeds (faster with
    more UAVs), the others succeed in a third of the episodes."""
    frames = []
    uavs = next(s for s in SWEEPS if s.key == "uavs")
    for v in uavs.values:
        for a in ALGORITHMS:
            world, label = cell_of("muc-osl-3d", uavs.setting(v), a)
            if a == good:
                frames.append(_rows(world, label, [True] * n, [600.0 - 50 * v] * n))
            else:
                ok = [i % 3 == 0 for i in range(n)]
                frames.append(_rows(world, label, ok, [700.0 if s else 1200.0 for s in ok]))
    return pd.concat(frames, ignore_index=True)


def _points(df: pd.DataFrame) -> Points:
    return Points(Cells(df, COLUMNS), lambda s, a: cell_of("muc-osl-3d", s, a))


def test_claims_held_and_not_held_on_made_up_episodes() -> None:
    uavs = [s for s in SWEEPS if s.key == "uavs"]
    held = {c.statement: c for c in evaluate_claims(_points(_world("muc-osl")), uavs)}
    assert held["MUC-OSL: the highest SR at every point"].verdict == "held"
    assert held["MUC-OSL: the lowest MST at every point"].verdict == "held"
    assert held["MUC-OSL: movement energy E_M below Col-Inf's"].verdict == "held"
    assert "-10.0 [-10.0, -10.0] %" in held["MUC-OSL: movement energy E_M below Col-Inf's"].ours
    # no ablation episodes: no ablation statements
    assert not any(k.startswith("MUC-OSL without eq. 16") for k in held)
    # the baselines' success does not change with the team size: not a rise for all four
    assert held["SR rises with more UAVs (all 4)"].verdict == "undecided"
    lost = {c.statement: c for c in evaluate_claims(_points(_world("col-inf")), uavs)}
    assert lost["MUC-OSL: the highest SR at every point"].verdict == "not held"
    assert lost["MUC-OSL: the lowest MST at every point"].verdict == "not held"


def test_claims_of_the_ablation_at_the_default_point() -> None:
    """MUC-OSL without eq. 16 is judged like MUC-OSL, at the default point where it runs."""
    uavs = [s for s in SWEEPS if s.key == "uavs"]
    world, label = cell_of("muc-osl-3d", DEFAULT, NO_ENV_PU)
    assert label == NO_ENV_PU
    ablation = _rows(world, label, [True] * 30, [300.0] * 30)
    ablation["team_movement_energy"] = 800.0
    ablation["team_hover_time"] = ablation["team_turn_time"] = 60.0
    # the baselines succeed in a third of the episodes (MUC-OSL always: it does not matter)
    cells = _points(pd.concat([_world("muc-osl"), ablation], ignore_index=True))
    c = {c.statement: c for c in evaluate_claims(cells, uavs)}
    assert c["MUC-OSL without eq. 16: the highest SR (default point)"].verdict == "held"
    assert c["MUC-OSL without eq. 16: the lowest MST (default point)"].verdict == "held"
    energy = c["MUC-OSL without eq. 16: movement energy E_M below Col-Inf's"]
    assert energy.verdict == "held" and "-20.0 [-20.0, -20.0] %" in energy.ours
    # MUC-OSL (450 s at 3 UAVs) is 150 s slower than without eq. 16: PUGL did not speed it up
    eq16 = c["MUC-OSL: eq. 16 shortens the search (against MUC-OSL without eq. 16)"]
    assert eq16.verdict == "not held"
    assert eq16.ours == "at the default point, minus without eq. 16: SR +0 [+0, +0] pts; " + (
        "MST +150 [+150, +150] s"
    )


def test_claims_of_the_ablation_at_every_point() -> None:
    """With the ablation at every point it is judged there, and eq. 16 paired over them all."""
    uavs = [s for s in SWEEPS if s.key == "uavs"]
    sweep = uavs[0]
    frames = [_world("muc-osl")]
    for v in sweep.values:
        world, label = cell_of("muc-osl-3d", sweep.setting(v), NO_ENV_PU)
        # without eq. 16: always succeeds, 100 s slower than MUC-OSL at every team size
        frames.append(_rows(world, label, [True] * 30, [700.0 - 50 * v] * 30))
    c = {c.statement: c for c in evaluate_claims(_points(pd.concat(frames)), uavs)}
    # against the baselines, which succeed in a third of the episodes
    assert c["MUC-OSL without eq. 16: the highest SR at every point"].verdict == "held"
    assert c["MUC-OSL without eq. 16: the lowest MST at every point"].verdict == "held"
    eq16 = c["MUC-OSL: eq. 16 shortens the search (against MUC-OSL without eq. 16)"]
    assert eq16.verdict == "held" and eq16.ours.startswith("mean over 8 points")
    assert "MST -100 [-100, -100] s" in eq16.ours
    # only where the ablation ran: the default point alone when it runs there only
    partial = _world("muc-osl")
    world, label = cell_of("muc-osl-3d", DEFAULT, NO_ENV_PU)
    partial = pd.concat([partial, _rows(world, label, [True] * 30, [550.0] * 30)])
    c = {c.statement: c for c in evaluate_claims(_points(partial), uavs)}
    assert "MUC-OSL without eq. 16: the lowest MST (default point)" in c
    assert c["MUC-OSL: eq. 16 shortens the search (against MUC-OSL without eq. 16)"].verdict == (
        "held"
    )


def test_ablation_files_cover_every_other_point_with_common_random_numbers() -> None:
    """MUC-OSL without eq. 16 at every point but the default one (which the main parts hold),
    in the same worlds as the algorithms there, with its particle counts on the default world."""
    main = sweep_files("muc-osl-3d", SWEEPS, 3, 2024, extra_searchers=[{"name": "muc-osl",
                       "label": NO_ENV_PU, "params": NO_ENV_PU_PARAMS}])  # fmt: skip
    files = ablation_files("muc-osl-3d", SWEEPS, 3, 2024)
    assert list(files) == ["ablation", "ablation-particles"]

    def cells(*parts: dict) -> dict:
        specs = [load_sweep(f) for f in parts]
        return {c.cell_id: (spec, c) for spec in specs for c in expand_cells(spec)}

    ours, theirs = cells(*files.values()), cells(main[""], main["particles"])
    # 16 worlds and 10 particle counts, none the main parts hold
    assert len(ours) == 26 and not set(ours) & set(theirs)
    every = {
        "/".join(cell_of("muc-osl-3d", st, NO_ENV_PU)) for sw in SWEEPS for st in sw.settings()
    }
    assert set(ours) | {f"muc-osl-3d/{NO_ENV_PU}"} == every
    # the same world episode by episode as every algorithm at its point
    for spec, c in ours.values():
        t_spec, twin = next(v for v in theirs.values() if v[1].world_key == c.world_key)
        assert make_task(spec, c, 1).world_seed == make_task(t_spec, twin, 1).world_seed
    se = {x["label"]: x["params"] for x in files["ablation-particles"]["searchers"]}
    assert se["muc-osl-no-env-pu[N=40]"] == {
        "estimator": {"type": "col-pf", "env_pu": "off", "n_particles": 40}
    }
    # the default point alone: nothing to add
    only = [replace(sw, values=(v,)) for sw in SWEEPS for v in sw.values
            if sw.setting(v) == DEFAULT]  # fmt: skip
    assert ablation_files("muc-osl-3d", only, 3, 2024) == {}


def test_recorded_filament_flow_replays_the_layered_wind_and_the_plume() -> None:
    """The 3-D Farrell wind is recorded on its node grid in two layers: the replay gives the
    live wind at any point and height, and the live plume's concentration at the frame times."""
    from odorloc.engine.episode import prepare_world
    from odorloc.engine.replay import record_flow
    from odorloc.world.world import World

    sc = get_scenario("muc-osl-filament-3d").with_overrides({"limits.time": 5.0})
    movie = record_flow(sc, 11)
    assert movie.wind.shape == (6, 15, 15, 2, 3)
    live, rng, _ = prepare_world(sc, 11)
    replay = World.replay(movie)
    pts = np.random.default_rng(0).uniform([0, 0, 0], [100, 60, 30], (50, 3))
    for _ in range(5):
        for _ in range(2):
            live.step(0.5, rng)
        replay.step(1.0, rng)
        np.testing.assert_allclose(replay.wind.velocity(pts), live.wind.velocity(pts), atol=1e-12)
        np.testing.assert_array_equal(
            replay.plume.concentration(pts), live.plume.concentration(pts)
        )
