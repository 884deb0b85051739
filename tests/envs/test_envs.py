"""Gymnasium and PettingZoo environments: API conformance on every built-in scenario, seeds that
reach episode i of a batch, the communication radius, rewards, vector environments, searchers as
policies and policies as searchers."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
pytest.importorskip("pettingzoo")

from gymnasium.utils.env_checker import check_env  # noqa: E402
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

import odorloc.envs  # noqa: E402
from odorloc import checks  # noqa: E402
from odorloc.cli import app  # noqa: E402
from odorloc.core.errors import ConfigError  # noqa: E402
from odorloc.core.seeds import episode_seeds  # noqa: E402
from odorloc.core.types import Action, Command, Declaration  # noqa: E402
from odorloc.engine.episode import run_episode  # noqa: E402
from odorloc.engine.recorder import Recording  # noqa: E402
from odorloc.envs import SearchEnv, SearcherPolicy, parallel_env  # noqa: E402
from odorloc.scenarios import builtin_names, get_scenario  # noqa: E402
from odorloc.searchers.policy import upwind_surge  # noqa: E402

SINGLE = [n for n in builtin_names() if len(get_scenario(n).agents.starts) == 1]
TEAMS = [n for n in builtin_names() if len(get_scenario(n).agents.starts) > 1]
POLICY_OBS = {"features": ["detection", "wind", "time"], "neighbours": False}


def _quiet_check(env) -> None:
    with warnings.catch_warnings():
        # unbounded gas and wind readings: Gymnasium warns about infinite Box bounds
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env)


def small(time: float = 20.0, **over) -> object:
    sc = checks.small_scenario({"type": "zigzag"}, 2, 1, time)
    return sc.with_overrides(over) if over else sc


# ---------------------------------------------------------------------- Gymnasium
@pytest.mark.parametrize("name", SINGLE)
@pytest.mark.parametrize("kind", ["velocity", "discrete"])
def test_check_env_on_every_single_agent_scenario(name: str, kind: str) -> None:
    env = gym.make(
        "odorloc/Search-v0", scenario=name, action={"kind": kind}, render_mode="rgb_array"
    )
    _quiet_check(env.unwrapped)
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3


def test_check_env_3d_and_belief_feature() -> None:
    sc = checks.small_scenario({"type": "zigzag"}, 3, 1, 10.0)
    _quiet_check(SearchEnv(sc, render_mode="rgb_array"))
    # one UAV of the multi-UAV scenario: encounter sensor, Vergassola plume, energy model
    uav = get_scenario("muc-osl-3d").with_overrides({"agents.starts": [[10.0, 10.0, 5.0]]})
    _quiet_check(SearchEnv(uav, action={"kind": "discrete", "moves": "all"}))
    env = SearchEnv(
        small(),
        observation={"belief": {"type": "pf-entropy", "estimator": {"n_particles": 200}}},
        action={"declare": "belief"},
    )
    _quiet_check(env)
    obs, _ = env.reset(seed=3)
    names = env.feature_names
    assert names[-6:] == [
        "belief_valid",
        "belief_mean_x",
        "belief_mean_y",
        "belief_std_x",
        "belief_std_y",
        "belief_entropy",
    ]
    seen_valid = False
    for _ in range(40):
        obs, *_rest = env.step(np.array([-1.0, 0.0, -1.0], np.float32))
        assert np.all(np.isfinite(obs))
        seen_valid |= bool(obs[names.index("belief_valid")] == 1.0)
        if _rest[1] or _rest[2]:
            break
    # the robot drives upwind through the plume: the filter starts at the first detection
    assert seen_valid


def test_observation_layout_and_bounds() -> None:
    env = SearchEnv("indoor-ventilated")
    obs, info = env.reset(seed=0)
    names = env.feature_names
    assert names == [
        "gas",
        "detection",
        "wind_x",
        "wind_y",
        "position_x",
        "position_y",
        "heading",
        "time",
    ]
    assert obs.dtype == np.float32 and obs.shape == (8,)
    np.testing.assert_allclose(obs[4:6], [2.15, 3.60], atol=1e-6)
    assert obs[7] == 0.0 and info["episode"] == 0
    assert env.observation_space.high[7] == 600.0
    assert env.action_space.shape == (3,)


def test_seed_reaches_episode_i_and_matches_odorloc_run(tmp_path) -> None:
    env = SearchEnv("indoor-ventilated", record=True)
    policy = SearcherPolicy("zigzag")
    obs, info = env.reset(seed=5, options={"episode": 2})
    assert (info["world_seed"], info["agent_seed"]) == episode_seeds(5, "indoor-ventilated", 2)
    policy.reset(env)
    positions = [obs[4:6].astype(float)]
    done = False
    steps = 0
    while not done and steps < 120:
        obs, _, term, trunc, _ = env.step(policy(obs, info))
        positions.append(obs[4:6].astype(float))
        done = term or trunc
        steps += 1
    out = tmp_path / "run"
    # the room with zigzag, which never declares, ending at the limits; the file keeps the
    # scenario's name, hence its seeds
    room = tmp_path / "room.yaml"
    get_scenario("indoor-ventilated").with_overrides(
        {"task.end": "limits", "searcher": {"type": "zigzag"}}
    ).to_yaml(room)
    args = ["run", str(room), "--seed", "5", "--episode", "2", "--no-animation"]
    r = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert r.exit_code == 0, r.output
    rec = Recording.load(out / "recording.npz")
    ref = rec.positions[: len(positions), 0, :]
    np.testing.assert_allclose(np.array(positions), ref, atol=1e-5)  # float32 observations
    # and the native positions agree exactly
    np.testing.assert_array_equal(env.episode.observations[0].position, rec.positions[steps, 0])


def test_reset_without_seed_continues_the_batch() -> None:
    env = SearchEnv(small())
    _, i0 = env.reset(seed=11)
    _, i1 = env.reset()
    _, i2 = env.reset(options={"episode": 0})
    assert (i0["episode"], i1["episode"], i2["episode"]) == (0, 1, 0)
    assert (i1["world_seed"], i1["agent_seed"]) == episode_seeds(11, small().name, 1)
    assert i2["world_seed"] == i0["world_seed"]


def test_same_seed_same_trajectory() -> None:
    def roll() -> np.ndarray:
        env = SearchEnv(small(), action={"kind": "discrete", "moves": "all"})
        env.action_space.seed(4)
        out = [env.reset(seed=9)[0]]
        for _ in range(30):
            o, _, te, tr, _ = env.step(env.action_space.sample())
            out.append(o)
            if te or tr:
                break
        return np.array(out)

    np.testing.assert_array_equal(roll(), roll())


def test_rewards_for_steps_declarations_and_reaching() -> None:
    env = SearchEnv(small(), reward={"step": -1.0, "found": 10.0, "wrong": -7.0})
    env.reset(seed=1)
    src = env.episode.sources[0]
    _, r, term, _, _ = env.step(np.array([0.0, 0.0, -1.0], np.float32))
    assert r == -1.0 and not term
    wrong = Action([Command.hold()], declaration=Declaration([[9.0, 5.0]], agent=0))
    _, r, term, trunc, info = env.step(wrong)
    assert r == -8.0 and term and not trunc and info["termination"] == "declared"
    env.reset(seed=1)
    _, r, term, _, _ = env.step(Action([Command.hold()], declaration=Declaration([src])))
    assert r == 9.0 and term
    reach = small(**{"task.end": "reach", "task.reach_radius": 6.45})
    env = SearchEnv(reach, reward={"reach": 5.0})
    env.reset(seed=1)
    _, r, term, _, info = env.step(np.array([-1.0, 0.0, -1.0], np.float32))
    assert term and info["termination"] == "reached" and r == 4.0


def test_truncated_on_time_limit() -> None:
    env = SearchEnv(small(time=2.0), action={"declare": "none"})
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, np.float32))[2:4] for _ in range(5)]
    assert flags[-1] == (False, True) and all(f == (False, False) for f in flags[:-1])
    with pytest.raises(RuntimeError, match="over"):
        env.step(np.zeros(2, np.float32))


def test_discrete_moves_go_one_step() -> None:
    env = SearchEnv(small(), action={"kind": "discrete", "declare": "none"})
    assert env.action_space.n == 5  # -x, +x, -y, +y, stay
    obs, _ = env.reset(seed=0)
    p0 = obs[4:6].copy()
    obs, *_ = env.step(0)
    np.testing.assert_allclose(obs[4:6] - p0, [-0.25, 0.0], atol=1e-6)  # 0.5 m/s x 0.5 s
    obs2, *_ = env.step(4)
    np.testing.assert_allclose(obs2[4:6], obs[4:6])


def test_bad_input_is_named() -> None:
    with pytest.raises(ConfigError, match="scenario"):
        SearchEnv("no-such-scenario")
    with pytest.raises(ConfigError, match="PettingZoo"):
        SearchEnv("muc-osl-3d")
    with pytest.raises(ConfigError) as ei:
        SearchEnv(small(), action={"kind": "joystick"})
    assert ei.value.field == "action.kind"
    with pytest.raises(ConfigError) as ei:
        SearchEnv(small(), observation={"features": ["smell"]})
    assert ei.value.field.startswith("observation.features")
    with pytest.raises(ConfigError, match="belief"):
        SearchEnv(small(), action={"declare": "belief"})
    with pytest.raises(ConfigError) as ei:
        SearchEnv(small(), reward={"bonus": 1})
    assert ei.value.field == "reward.bonus"
    env = SearchEnv(small())
    with pytest.raises(ConfigError, match=r"options\.episode"):
        env.reset(seed=0, options={"episode": -1})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="velocity action"):
        env.step(np.array([np.nan, 0.0, 0.0]))
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ConfigError) as ei:
            SearchEnv(small(), reward={"step": bad})
        assert ei.value.field == "reward.step"
    with pytest.raises(ConfigError, match="world_key"):
        SearchEnv(small(), world_key=5)
    with pytest.raises(ConfigError, match="team_reward"):
        parallel_env(scenario="muc-osl-3d", team_reward="no")


def test_use_before_reset_is_refused() -> None:
    env = SearchEnv(small(), render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(3, np.float32))
    with pytest.raises(RuntimeError, match="reset"):
        env.render()
    team = parallel_env(scenario="muc-osl-3d")
    for call in (team.state, lambda: team.step({})):
        with pytest.raises(RuntimeError, match="reset"):
            call()


def test_an_episode_over_at_reset_is_refused() -> None:
    # every start lies within 50 m of the (fixed) source of this small world: refused with
    # the scenario, before any episode
    with pytest.raises(ConfigError) as ei:
        SearchEnv(small(**{"task.end": "reach", "task.reach_radius": 50.0})).reset(seed=0)
    assert ei.value.field == "task.reach_radius"


def test_spaces_do_not_keep_the_env_alive() -> None:
    import gc
    import weakref

    env = parallel_env(scenario="muc-osl-3d")
    assert env.observation_space("agent_0") is env.observation_space("agent_0")
    assert env.action_space("agent_1") is env.action_space("agent_1")
    ref = weakref.ref(env)
    del env
    gc.collect()
    assert ref() is None


def test_vector_envs_run_8_copies() -> None:
    def make() -> object:
        return gym.make("odorloc/Search-v0", scenario=small(), action={"declare": "none"})

    runs = []
    for cls in (gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv):
        venv = cls([make] * 8)
        obs, _ = venv.reset(seed=list(range(8)))
        assert obs.shape == (8, 8)
        actions = np.random.default_rng(3).uniform(-1.0, 1.0, (5, *venv.action_space.shape))
        seen = [obs]
        for act in actions.astype(venv.action_space.dtype):
            obs, rew, _term, _trunc, _ = venv.step(act)
            seen.append(obs)
        assert obs.shape == (8, 8) and rew.shape == (8,) and np.all(rew == -1.0)
        # different seeds, different worlds
        assert len({tuple(o) for o in obs}) > 1
        runs.append(np.stack(seen))
        venv.close()
    # the same seeds and actions give the same observations, in one process or in eight
    np.testing.assert_array_equal(runs[0], runs[1])


# ---------------------------------------------------------------------- PettingZoo
@pytest.mark.parametrize("name", TEAMS)
def test_pettingzoo_api_and_seed_tests(name: str) -> None:
    parallel_api_test(parallel_env(scenario=name, action={"declare": "none"}), num_cycles=25)
    parallel_seed_test(lambda: parallel_env(scenario=name, action={"declare": "none"}), 10)
    env = parallel_env(scenario=name, action={"kind": "discrete"}, render_mode="rgb_array")
    _obs, _ = env.reset(seed=2)
    assert env.state().shape == env.state_space.shape
    assert env.state_space.contains(env.state())
    assert env.render().ndim == 3


def test_messages_only_from_neighbours() -> None:
    # muc-osl-3d: UAVs at x = 10, 30, 60 m, radius 30 m: 0-1 and 1-2 hear each other, 0-2 not
    env = parallel_env(scenario="muc-osl-3d", action={"declare": "none"})
    obs, _ = env.reset(seed=0)
    names = env.feature_names
    h0, h1 = names.index("nb0_heard"), names.index("nb1_heard")
    assert all(o[h0] == 0 and o[h1] == 0 for o in obs.values())  # nothing sent yet
    hold = {a: np.zeros(3, np.float32) for a in env.agents}
    obs, *_ = env.step(hold)
    assert (obs["agent_0"][h0], obs["agent_0"][h1]) == (1.0, 0.0)
    assert (obs["agent_1"][h0], obs["agent_1"][h1]) == (1.0, 1.0)
    assert (obs["agent_2"][h0], obs["agent_2"][h1]) == (0.0, 1.0)
    rel = names.index("nb0_rel_x")
    assert obs["agent_0"][rel] == pytest.approx(20.0)  # agent 1 seen from agent 0


def test_broadcast_readings_are_charged_as_their_numbers() -> None:
    """Each agent's broadcast is d + 2 float64 numbers (what a dict of its position, reading and
    detection would count), read-only, and what neighbours decode is what was sent."""
    from odorloc.platforms.team import CommGraph, message_nbytes
    from odorloc.searchers.policy_io import ReadingMessage

    env = parallel_env(scenario="muc-osl-3d", action={"declare": "none"})
    env.reset(seed=1)
    obs = env.episode.observations
    msgs = env.core.io.broadcasts(obs)
    for o in obs:
        m = msgs[o.agent]
        assert isinstance(m, ReadingMessage)
        as_dict = {
            "position": np.asarray(o.position, float),
            "gas": np.array([float(o.gas)]),
            "detection": np.array([1.0 if o.detection else 0.0]),
        }
        assert m.nbytes == message_nbytes(as_dict) == 8 * (len(o.position) + 2)
        assert not m.position.flags.writeable
        np.testing.assert_array_equal(m.position, o.position)
    # the radio counts them once per recipient: links 0-1 and 1-2 (radius 30 m), both ways
    graph = CommGraph(30.0)
    inbox, nbytes = graph.deliver(np.array([o.position for o in obs]), msgs)
    assert nbytes == 4 * 8 * 5
    assert [m.sender for m in inbox[1]] == [0, 2]


@pytest.mark.parametrize("declare", ["none", "position"])
def test_actions_decoded_together_as_one_by_one(declare: str) -> None:
    """The team's velocity actions decoded as one array give each agent's command and
    declaration exactly as decoding them one by one; a bad action is named as before."""
    env = parallel_env(scenario="muc-osl-3d", action={"declare": declare})
    env.reset(seed=3)
    io, obs = env.core.io, env.episode.observations
    rng = np.random.default_rng(0)
    for _ in range(5):
        acts = {k: rng.uniform(-2, 2, io.action_size).astype(np.float32) for k in range(3)}
        cmds, decls = io.decode_many(acts, obs)
        singles = [io.decode(k, acts[k], obs[k]) for k in range(3)]
        for k, (cmd, _) in enumerate(singles):
            assert cmds[k].kind == cmd.kind
            np.testing.assert_array_equal(cmds[k].value, cmd.value)
        expected = [d for _, d in singles if d is not None]
        assert [d.agent for d in decls] == [d.agent for d in expected]
        for d, e in zip(decls, expected, strict=True):
            np.testing.assert_array_equal(d.positions, e.positions)
    bad = {0: np.zeros(io.action_size), 1: np.full(io.action_size, np.nan), 2: np.zeros(1)}
    with pytest.raises(ValueError, match="finite numbers"):
        io.decode_many(bad, obs)


def test_team_reward_and_declaring_agent_credit() -> None:
    sc = checks.small_scenario({"type": "zigzag"}, 2, 3, 20.0)
    sc = sc.with_overrides({"task.end": "limits"})
    env = parallel_env(scenario=sc, reward={"wrong": -5.0})
    env.reset(seed=0)
    acts = {a: np.array([0.0, 0.0, -1.0], np.float32) for a in env.agents}
    acts["agent_2"] = np.array([0.0, 0.0, 1.0], np.float32)  # declares where it stands
    _, rew, *_ = env.step(acts)
    assert rew == {"agent_0": -1.0, "agent_1": -1.0, "agent_2": -6.0}
    env = parallel_env(scenario=sc, reward={"wrong": -5.0}, team_reward=True)
    env.reset(seed=0)
    _, rew, *_ = env.step(acts)
    assert set(rew.values()) == {-8.0}


# ---------------------------------------------------------------------- policies
def test_policy_searcher_runs_what_the_env_runs() -> None:
    sc = small(time=30.0)
    env = SearchEnv(sc, observation=POLICY_OBS, record=True)
    obs, _ = env.reset(seed=7, options={"episode": 1})
    traj = [env.episode.observations[0].position]
    done = False
    while not done:
        obs, _, te, tr, _ = env.step(upwind_surge(obs))
        traj.append(env.episode.observations[0].position)
        done = te or tr
    spec = {"type": "policy", "callable": "odorloc.searchers.policy:upwind_surge"}
    sc2 = sc.model_copy(update={"searcher": odorloc.scenarios.Component(**spec)})
    res = run_episode(sc2, *episode_seeds(7, sc.name, 1), record=True)
    # the last step ends the episode at the time limit without moving: its position repeats
    np.testing.assert_array_equal(res.recording.positions[:, 0], np.array(traj[:-1]))


def test_policy_searcher_in_a_sweep_with_common_random_numbers(tmp_path) -> None:
    from odorloc.experiments.sweep import run_sweep

    sc = small(time=15.0, **{"task.end": "limits"})  # zigzag never declares
    f = tmp_path / "s.yaml"
    sc.to_yaml(f)
    spec = {
        "name": "policy-vs-zigzag",
        "seed": 3,
        "episodes": 3,
        "scenarios": [{"name": str(f)}],
        "searchers": [
            {"name": "zigzag"},
            {"name": "policy", "params": {"callable": "odorloc.searchers.policy:upwind_surge"}},
        ],
    }
    df = run_sweep(spec, tmp_path / "r.sqlite", workers=1, progress=False)
    assert set(df["status"]) == {"ok"}
    by = df.pivot(index="episode", columns="searcher", values="world_seed")
    assert (by.iloc[:, 0] == by.iloc[:, 1]).all()  # the same worlds for both


def test_policy_searcher_bad_callable_is_named() -> None:
    with pytest.raises(ConfigError) as ei:
        checks.small_scenario({"type": "policy", "callable": "nowhere.module:f"})
    assert ei.value.field == "searcher.callable"
    with pytest.raises(ConfigError) as ei:
        checks.small_scenario({"type": "policy", "callable": "numpy"})
    assert ei.value.field == "searcher.callable"
    bad = checks.small_scenario({"type": "policy", "callable": "numpy:zeros_like"})
    with pytest.raises(RuntimeError, match="velocity action must be 3"):
        run_episode(bad, 1, 2)


def test_searcher_policy_drives_a_team() -> None:
    env = parallel_env(scenario="muc-osl-3d")
    policy = SearcherPolicy("rectangular-wave", {"lane_spacing": 10.0})
    env.reset(seed=0)
    policy.reset(env)
    for _ in range(20):
        _obs, *_ = env.step(policy())
    p = [env.episode.observations[k].position for k in range(3)]
    assert not np.allclose(p[0], [10.0, 10.0, 5.0])
    # a single-agent searcher runs as a per-agent team, as in a scenario
    env = parallel_env(scenario="muc-osl-3d")
    env.reset(seed=0)
    single = SearcherPolicy("pf-entropy")
    single.reset(env)
    assert type(single.searcher).__name__ == "PerAgentTeam"
    env.step(single())


def test_linear_policy_round_trip_and_bad_weights(tmp_path) -> None:
    from odorloc.searchers.policy import LinearPolicy

    w = np.array([[0.0, 1.0, 0.0], [0.5, 0.0, -1.0]])
    pol = LinearPolicy(w, np.zeros(2), np.ones(2), "discrete")
    assert pol(np.array([2.0, 0.0])) == 0 and pol(np.array([0.0, -1.0])) == 1
    back = LinearPolicy.load(pol.save(tmp_path / "p.npz"))
    np.testing.assert_array_equal(back.weights, w)
    with pytest.raises(ValueError, match="do not fit"):
        LinearPolicy(w, np.zeros(3), np.ones(3))
    spec = {
        "type": "policy",
        "callable": "odorloc.searchers.policy:linear",
        "args": {"weights": str(tmp_path / "missing.npz")},
    }
    with pytest.raises(ConfigError) as ei:
        from odorloc.scenarios.build import build

        build(checks.small_scenario(spec))
    assert ei.value.field == "searcher.args" and "missing.npz" in ei.value.problem
