"""Episode engine: determinism, common random numbers, termination, metrics, recording."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import filament_scenario_dict, small_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.core.types import Action, Command, Declaration
from odorloc.engine.episode import run_episode, score_declaration
from odorloc.experiments.runner import run_cell_episode
from odorloc.scenarios import Scenario
from odorloc.searchers.base import Searcher


def _rows_equal(a: dict, b: dict) -> bool:
    skip = {"wall_time", "wall_per_step_ms", "searcher_fraction", "world_fraction"}
    for k in a:
        if k in skip:
            continue
        x, y = a[k], b[k]
        if isinstance(x, float) and math.isnan(x):
            if not (isinstance(y, float) and math.isnan(y)):
                return False
        elif x != y:
            return False
    return True


@pytest.mark.parametrize("searcher", ["zigzag", "random-walk", "rectangular-wave", "passive"])
def test_full_short_episode_each_simple_searcher(searcher: str) -> None:
    sc = Scenario.from_dict(filament_scenario_dict(searcher))
    res = run_episode(sc, *episode_seeds(3, "test-room", 0))
    m = res.metrics
    assert m["termination"] in ("time_limit", "declared")
    assert m["search_time"] == pytest.approx(30.0) or m["declared"]
    rec = res.recording
    assert rec is not None
    assert rec.positions.shape[1:] == (1, 2)
    # The robot never leaves the arena.
    assert np.all(sc.world.arena.lower <= rec.positions.min(axis=(0, 1)) + 1e-9)
    assert np.all(rec.positions.max(axis=(0, 1)) <= np.asarray(sc.world.arena.upper) + 1e-9)
    # Path length equals the summed step lengths (no teleporting).
    steps = np.linalg.norm(np.diff(rec.positions[:, 0], axis=0), axis=1).sum()
    assert m["path_length"] == pytest.approx(steps, rel=1e-6, abs=1e-9)
    if searcher == "passive":
        assert m["path_length"] == 0.0
    else:
        assert m["path_length"] > 1.0


def test_same_seed_identical_rows_and_recordings() -> None:
    sc = Scenario.from_dict(filament_scenario_dict("random-walk"))
    a = run_episode(sc, 11, 12)
    b = run_episode(sc, 11, 12)
    assert _rows_equal(a.metrics, b.metrics)
    assert np.array_equal(a.recording.positions, b.recording.positions)
    assert np.array_equal(a.recording.gas, b.recording.gas)
    c = run_episode(sc, 11, 13)  # other agent seed: another walk
    assert not np.array_equal(a.recording.positions, c.recording.positions)


def test_common_random_numbers_same_plume_for_every_searcher() -> None:
    """Episode i gives the same plume realisation whatever the searcher does."""
    frames = []
    for searcher in ("zigzag", "passive", "random-walk"):
        sc = Scenario.from_dict(filament_scenario_dict(searcher))
        w, a = episode_seeds(5, "test-room", 2)
        frames.append(run_episode(sc, w, a).recording.plume_frames)
    assert np.array_equal(frames[0], frames[1])
    assert np.array_equal(frames[0], frames[2])
    other = run_episode(
        Scenario.from_dict(filament_scenario_dict("passive")), *episode_seeds(5, "test-room", 3)
    )
    assert not np.array_equal(frames[0], other.recording.plume_frames)


class _DeclareAt(Searcher):
    def __init__(self, where, after: int = 3) -> None:
        self.where = np.asarray(where, float)
        self.after = after

    def act(self, observations, rng):
        self.n = getattr(self, "n", 0) + 1
        decl = Declaration(self.where) if self.n > self.after else None
        return Action([Command.hold()], declaration=decl)


def test_declaration_terminates_and_is_scored() -> None:
    from odorloc.scenarios.build import build

    sc = Scenario.from_dict(small_scenario_dict("passive"))
    b = build(sc)
    b.searcher = _DeclareAt([[1.3, 2.5]], after=3)
    res = run_episode(sc, 1, 2, built=b)
    m = res.metrics
    assert m["termination"] == "declared" and m["success"]
    assert m["search_time"] == pytest.approx(1.5)
    assert m["loc_error"] == pytest.approx(0.3)
    b = build(sc)
    b.searcher = _DeclareAt([[3.0, 2.5]], after=0)
    m = run_episode(sc, 1, 2, built=b).metrics
    assert not m["success"] and m["loc_error"] == pytest.approx(2.0)


def test_score_declaration_multi_source() -> None:
    src = np.array([[0.0, 0.0], [4.0, 0.0]])
    ok, err, found, false = score_declaration(np.array([[0.2, 0.0], [9.0, 9.0]]), src, 0.5)
    assert not ok and found == 1 and false == 1
    # Source 2 at (4, 0): the nearest declaration is (0.2, 0), 3.8 m away.
    assert err == pytest.approx((0.2 + 3.8) / 2)
    ok, _, found, false = score_declaration(np.array([[0.2, 0.0], [4.0, 0.3]]), src, 0.5)
    assert ok and found == 2 and false == 0


def test_failing_episode_becomes_error_row() -> None:
    cell = {"scenario": "no-such-scenario"}
    row = run_cell_episode(cell, 1, 2)
    assert row["status"] == "error" and "no-such-scenario" in row["error"]
    assert row["success"] is False


def test_recording_roundtrip(tmp_path) -> None:
    from odorloc.engine.recorder import Recording

    sc = Scenario.from_dict(filament_scenario_dict("zigzag"))
    rec = run_episode(sc, 1, 2).recording
    path = rec.save(tmp_path / "r.npz")
    back = Recording.load(path)
    assert np.array_equal(back.positions, rec.positions)
    assert np.array_equal(back.plume_frames, rec.plume_frames)
    assert back.meta["scenario"] == "test-room"


# ---------------------------------------------------------------------- the stepping episode
def test_stepping_episode_equals_the_driver() -> None:
    """Episode.reset/step driven by hand gives the same row as run_episode."""
    from odorloc.engine.episode import Episode

    sc = Scenario.from_dict(filament_scenario_dict("zigzag"))
    ref = run_episode(sc, 4, 5)
    ep = Episode(sc)
    obs = ep.reset(4, 5)
    s = ep.built.searcher
    s.reset(ep.context, ep.agent_rng)
    n = 0
    while not ep.done:
        res = ep.step(s.act(obs, ep.agent_rng), s)
        obs = res.observations
        n += 1
    assert res.done and res.truncated and res.termination == "time_limit"
    assert res.events[-1].kind == "end"
    got = ep.result(s.final_metrics())
    assert _rows_equal(ref.metrics, got.metrics)
    assert n == got.metrics["steps"] + 1
    with pytest.raises(RuntimeError, match="over"):
        ep.step(s.act(obs, ep.agent_rng))


class _Script(Searcher):
    """Holds still; declares the scripted positions at the scripted steps, tagged by group."""

    def __init__(self, script: dict[int, tuple[list, int | None]]) -> None:
        self.script = script

    def act(self, observations, rng):
        self.k = getattr(self, "k", -1) + 1
        decl = None
        if self.k in self.script:
            pos, group = self.script[self.k]
            decl = Declaration(np.asarray(pos, float), group=group)
        return Action([Command.hold() for _ in observations], declaration=decl)


def _two_source_scenario(end: str, **task) -> Scenario:
    d = small_scenario_dict("passive")
    d["world"]["sources"] = [{"position": [1.0, 2.5]}, {"position": [3.0, 1.0]}]
    d["agents"] = {
        "starts": [[8.0, 2.0], [8.0, 3.0]],
        "groups": [{"name": "A", "agents": [0]}, {"name": "B", "agents": [1]}],
    }
    d["task"] = {"end": end, "success_radius": 0.5, **task}
    return Scenario.from_dict(d)


def test_partial_declarations_find_sources_one_by_one_until_every_group_declared() -> None:
    sc = _two_source_scenario("all_groups")
    s = _Script({2: ([[1.1, 2.5]], 0), 6: ([[3.0, 1.2]], 1)})
    res = run_episode(sc, 1, 2, searcher=s)
    m = res.metrics
    assert m["termination"] == "declared" and m["search_time"] == pytest.approx(3.0)
    assert m["found_time_0"] == pytest.approx(1.0) and m["found_time_1"] == pytest.approx(3.0)
    assert m["success"] and m["sources_found"] == 2 and m["declarations"] == 2
    kinds = [e.kind for e in res.events]
    assert kinds.count("declaration") == 2 and kinds.count("source_found") == 2
    assert [e.group for e in res.events if e.kind == "declaration"] == [0, 1]
    # The first declaration alone ends a "first_declaration" episode (one source found).
    first = run_episode(_two_source_scenario("first_declaration"), 1, 2, searcher=_Script(s.script))
    assert first.metrics["search_time"] == pytest.approx(1.0) and not first.metrics["success"]
    assert first.metrics["sources_found"] == 1 and np.isnan(first.metrics["found_time_1"])


def test_limits_rule_keeps_going_after_declarations() -> None:
    sc = _two_source_scenario("limits")
    res = run_episode(sc, 1, 2, searcher=_Script({1: ([[1.0, 2.5], [3.0, 1.0]], None)}))
    m = res.metrics
    assert m["termination"] == "time_limit" and m["search_time"] == pytest.approx(30.0)
    assert m["declared"] and m["success"]


def test_reach_rule_ends_when_an_agent_comes_close() -> None:
    d = small_scenario_dict("zigzag")
    d["agents"]["starts"] = [[3.0, 2.5]]
    d["task"] = {"end": "reach", "reach_radius": 1.2}
    sc = Scenario.from_dict(d)
    res = run_episode(sc, 1, 2)
    m = res.metrics
    assert m["termination"] == "reached" and m["success"]
    assert m["reach_time"] == m["search_time"]
    with pytest.raises(ConfigError, match="reach_radius"):
        Scenario.from_dict({**d, "task": {"end": "reach"}})
    # Driven by hand: before the last move the robot is outside the radius, after it inside,
    # and the episode ends at that step's time (the recording ends where the robot stopped).
    from odorloc.engine.episode import Episode

    ep = Episode(sc)
    obs = ep.reset(1, 2)
    s = ep.built.searcher
    s.reset(ep.context, ep.agent_rng)
    src = np.array([1.0, 2.5])
    before = np.inf
    while not ep.done:
        before = float(np.linalg.norm(ep.platforms[0].position - src))
        step = ep.step(s.act(obs, ep.agent_rng), s)
        obs = step.observations
    assert before > 1.2 >= float(np.linalg.norm(ep.platforms[0].position - src))
    assert step.termination == "reached" and step.t == m["search_time"]
    assert np.linalg.norm(res.recording.positions[-1, 0] - src) <= 1.2
    assert np.linalg.norm(res.recording.positions[-2, 0] - src) > 1.2
    assert res.recording.t[-1] == m["search_time"]
    # An agent that starts within the radius of the fixed source would end the episode, a
    # success, before its first step: refused, naming the radius and the start.
    d["agents"]["starts"] = [[1.5, 2.5]]
    with pytest.raises(
        ConfigError, match=r"task\.reach_radius: agents\.starts\[0\] \(1\.5, 2\.5\)"
    ):
        run_episode(Scenario.from_dict(d), 1, 2, record=True)


def test_time_limit_shorter_than_a_period_is_refused() -> None:
    d = small_scenario_dict("zigzag")
    d["limits"] = {"control_dt": 0.5, "time": 0.2}
    with pytest.raises(ConfigError, match=r"limits\.time"):
        run_episode(Scenario.from_dict(d), 1, 2)


def test_computation_and_radio_are_charged_to_uavs() -> None:
    """A searcher's reported bits are charged by eq. 7 and its messages by eq. 8."""

    class _Thinker(Searcher):
        def act(self, observations, rng):
            return Action(
                [Command.hold() for _ in observations],
                messages={0: {"fit": np.zeros(12)}},
                compute_bits={0: 1e6, 1: 2e6},
            )

    d = small_scenario_dict("passive")
    d["world"] = {
        **d["world"],
        "arena": {"lower": [0, 0, 0], "upper": [10, 5, 5], "resolution": 0.5},
    }
    d["world"]["sources"] = [{"position": [1.0, 2.5, 2.0]}]
    d["world"]["wind"] = {"type": "uniform", "velocity": [0.5, 0.0, 0.0]}
    d["platform"] = {"type": "uav"}
    d["agents"] = {"starts": [[8.0, 2.0, 2.0], [8.0, 3.0, 2.0]], "comm_radius": 5.0}
    d["limits"]["time"] = 5.0
    res = run_episode(Scenario.from_dict(d), 1, 2, searcher=_Thinker())
    m = res.metrics
    steps = m["steps"]
    # eq. 7: gamma_c C f_c^2 N_c = 1e-28 * 1000 * 1e18 = 1e-7 J per bit
    assert m["energy_compute"] == pytest.approx(steps * 3e6 * 1e-7)
    # eq. 8: P_T N_d / r_T = 0.1 W * (8 * 96 bits) / 1e6 bit/s per delivery (one recipient)
    assert m["bytes"] == steps * 96
    assert m["energy_comm"] == pytest.approx(steps * 0.1 * 8 * 96 / 1e6)


def test_run_episode_i_is_batch_episode_i(tmp_path) -> None:
    """`odorloc run S --seed R --episode I` and episode I of `odorloc batch -s S --seed R`."""
    from typer.testing import CliRunner

    from odorloc.cli import app
    from odorloc.engine.recorder import Recording
    from odorloc.experiments.sweep import run_sweep

    spec = {
        "name": "same",
        "seed": 17,
        "episodes": 3,
        # zigzag never declares: the room's episodes end at the limits
        "scenarios": [
            {"name": "indoor-ventilated", "params": {"limits.time": 20.0, "task.end": "limits"}}
        ],
        "searchers": [{"name": "zigzag"}],
    }
    df = run_sweep(spec, tmp_path / "s.sqlite", workers=1, progress=False)
    row = df[df.episode == 2].iloc[0]
    out = tmp_path / "run"
    sc_file = tmp_path / "room.yaml"  # keeps the name indoor-ventilated, hence its seeds
    from odorloc.scenarios import get_scenario

    get_scenario("indoor-ventilated").with_overrides(
        {"limits.time": 20.0, "task.end": "limits", "searcher": {"type": "zigzag"}}
    ).to_yaml(sc_file)
    args = ["run", str(sc_file), "--seed", "17", "--episode", "2", "--no-animation"]
    r = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert r.exit_code == 0, r.output
    rec = Recording.load(out / "recording.npz")
    assert rec.meta["path_length"] == row.path_length

    assert (int(row.world_seed), int(row.agent_seed)) == episode_seeds(17, "indoor-ventilated", 2)
    short = run_episode(
        get_scenario("indoor-ventilated").with_overrides(
            {"limits.time": 20.0, "searcher": {"type": "zigzag"}}
        ),
        int(row.world_seed),
        int(row.agent_seed),
    )
    assert short.metrics["path_length"] == pytest.approx(row.path_length, rel=0, abs=0)
    np.testing.assert_array_equal(rec.positions, short.recording.positions)


def test_source_draw_gives_every_searcher_of_an_episode_the_same_sources() -> None:
    d = filament_scenario_dict("passive")
    d["world"]["source_draw"] = {
        "type": "uniform",
        "region": [[0.5, 0.5], [4.0, 4.5]],
        "min_start_distance": 4.0,
    }
    d["limits"]["time"] = 5.0
    sc = Scenario.from_dict(d)
    a = run_episode(sc, 1, 2)
    b = run_episode(sc.with_overrides({"searcher": {"type": "zigzag"}}), 1, 9)
    c = run_episode(sc, 3, 2)
    np.testing.assert_array_equal(a.sources, b.sources)
    assert not np.array_equal(a.sources, c.sources)
    assert np.all(a.sources[0] >= [0.5, 0.5]) and np.all(a.sources[0] <= [4.0, 4.5])
    assert np.linalg.norm(a.sources[0] - [8.0, 2.0]) >= 4.0
    np.testing.assert_array_equal(a.recording.sources, a.sources)
    d["world"]["source_draw"] = {"type": "uniform", "min_start_distance": 100.0, "max_tries": 50}
    with pytest.raises(ConfigError, match="source_draw"):
        run_episode(Scenario.from_dict(d), 1, 2)
    d["world"]["source_draw"] = {"type": "uniform", "min_separation": -1.0}
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(d)
    assert ei.value.field == "world.source_draw.min_separation"
