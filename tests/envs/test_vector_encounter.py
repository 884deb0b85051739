"""The batched encounter-rate environment against the single environments, and its contract."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from gymnasium.vector import AutoresetMode

from odorloc.core.errors import ConfigError
from odorloc.envs.gym_env import SearchEnv
from odorloc.envs.parallel import ParallelSearchEnv
from odorloc.envs.vector_encounter import EncounterVectorEnv
from odorloc.models.vergassola import vergassola_rate
from odorloc.scenarios import get_scenario

TEAM = get_scenario("muc-osl-3d")


def _solo(**over: object) -> object:
    """One UAV of the rate world, the source drawn anew for every episode."""
    base = {
        "agents.starts": [[50.0, 8.0, 10.0]],
        "world.source_draw": {
            "type": "uniform",
            "region": [[5.0, 25.0, 5.0], [95.0, 55.0, 25.0]],
            "min_start_distance": 10.0,
            "rates": [2.0, 6.0],
        },
        "limits.time": 40.0,
    }
    base.update(over)
    return TEAM.with_overrides(base)


def _play_single(scenario, kw: dict, root: int, episode: int, actions: list) -> list:
    """The first observations, then (observations, per-agent rewards, terminated, truncated)
    of each step of the single environment's episode ``episode`` under ``actions``."""
    n = len(scenario.agents.starts)
    out = []
    if n == 1:
        env = SearchEnv(scenario, **kw)
        o, _ = env.reset(seed=root, options={"episode": episode})
        out.append(o[None])
        for a in actions:
            o, r, te, tr, _ = env.step(a)
            out.append((o[None], np.array([r]), te, tr))
            if te or tr:
                break
        return out
    env = ParallelSearchEnv(scenario, **kw)
    o, _ = env.reset(seed=root, options={"episode": episode})
    names = [f"agent_{k}" for k in range(n)]
    out.append(np.array([o[x] for x in names]))
    for a in actions:
        o, r, te, tr, _ = env.step({f"agent_{k}": a[k] for k in range(n)})
        out.append(
            (np.array([o[x] for x in names]), np.array([r[x] for x in names]), te[names[0]],
             tr[names[0]])
        )  # fmt: skip
        if te[names[0]] or tr[names[0]]:
            break
    return out


CASES = {
    # the team world, one UAV starting 3 m downwind of the source, the axis moves: ends by
    # reaching it and by the time limit
    "team-axis": (
        TEAM.with_overrides(
            {
                "agents.starts": [[10.0, 27.0, 25.0], [30.0, 10.0, 5.0], [60.0, 10.0, 5.0]],
                "limits.time": 45.0,
            }
        ),
        {"action": {"kind": "discrete", "declare": "none"}},
        120,
    ),
    # one UAV, velocities and declarations, sources and rates drawn, a short time limit
    "solo-velocity": (_solo(), {"action": {"kind": "velocity", "declare": "position"}}, 90),
    # one UAV with a small energy budget and the 26 directions: ends by exhaustion
    "solo-energy": (
        _solo(**{"platform.energy_limit": 20000.0, "limits.time": 200.0}),
        {"action": {"kind": "discrete", "moves": "all", "step": 2.5}},
        60,
    ),
    # a team with a short radio range (messages heard only sometimes) and the stuck rule
    "team-radio-stuck": (
        TEAM.with_overrides({"agents.comm_radius": 22.0, "task.stuck_limit": 3}),
        {"action": {"kind": "discrete", "declare": "none"}},
        60,
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_sub_env_i_is_episode_i_of_the_batch(case: str) -> None:
    """Observations, per-agent rewards and ends of every episode a sub-environment plays equal
    the single environment's episode of that index, restarted episodes included."""
    scenario, kw, steps = CASES[case]
    b, root = 3, 5
    v = EncounterVectorEnv(scenario, num_envs=b, **kw)
    n = v.n_agents
    obs, info = v.reset(seed=root)
    obs = obs.reshape(b, n, -1)
    np.testing.assert_array_equal(info["episode"], np.arange(b))
    v.action_space.seed(3)
    if "declare" in kw["action"] and kw["action"]["kind"] == "velocity":
        # declarations now and then, not every step
        acts = [v.action_space.sample() for _ in range(steps)]
        rare = np.random.default_rng(8)
        for a in acts:
            a[..., -1] = np.where(rare.random(a.shape[0]) < 0.9, -1.0, 1.0)
    else:
        acts = [v.action_space.sample() for _ in range(steps)]
    played: dict[int, list] = {}
    first: dict[int, np.ndarray] = {}
    statuses: set[str] = set()
    current = {i: int(v.episodes[i]) for i in range(b)}
    for i in range(b):
        played[current[i]] = []
        first[current[i]] = obs[i]
    for a in acts:
        o, r, te, tr, info = v.step(a)
        agent_r = info["agent_rewards"].reshape(b, n)
        for i in range(b):
            ended = bool(te[i] or tr[i])
            last = info["final_obs"][i] if ended else o[i]
            played[current[i]].append((last.reshape(n, -1), agent_r[i], te[i], tr[i], a[i]))
            if ended:
                current[i] = int(v.episodes[i])
                played[current[i]] = []
                first[current[i]] = o[i].reshape(n, -1)
        np.testing.assert_allclose(r, agent_r.sum(axis=1))
        if "final_status" in info:
            statuses.update(info["final_status"][te | tr])
    ends = set()
    for ep, rows in played.items():
        if not rows:
            continue
        start, *single = _play_single(scenario, kw, root, ep, [x[4] for x in rows])
        np.testing.assert_array_equal(first[ep], start)
        assert len(single) == len(rows), (case, ep)
        for (o, rw, te, tr, _), (o1, r1, te1, tr1) in zip(rows, single, strict=True):
            np.testing.assert_array_equal(o, o1)
            np.testing.assert_array_equal(rw, r1)
            assert (bool(te), bool(tr)) == (bool(te1), bool(tr1))
        if rows[-1][2] or rows[-1][3]:
            ends.add("terminated" if rows[-1][2] else "truncated")
    assert ends, f"{case}: no episode ended: the restarts went untested"
    want = {
        "team-axis": {"reached", "time_limit"},
        "solo-energy": {"energy"},
        "team-radio-stuck": {"stuck"},
    }.get(case, set())
    assert want <= statuses, statuses


def test_hit_counts_follow_the_rate_model() -> None:
    """UAVs hovering at their starts count hits with the Vergassola rate's Poisson mean (eq. 3):
    the mean over many sub-environments and periods within 4 standard errors."""
    sc = TEAM.with_overrides({"agents.starts": [[12.0, 24.0, 24.0]], "limits.time": 30.0})
    b = 400
    v = EncounterVectorEnv(sc, num_envs=b)
    o, _ = v.reset(seed=1)
    stay = v.single_action_space.n - 1
    col = v.feature_names.index("gas")
    hits = [o[:, col]]
    for _ in range(20):
        o, *_ = v.step(np.full(b, stay))
        hits.append(o[:, col])
    h = np.concatenate(hits).astype(float)
    p = sc.world.plume
    mu = float(
        vergassola_rate(
            np.array([[12.0, 24.0, 24.0]]),
            np.array([sc.world.sources[0].position]),
            np.array([sc.world.sources[0].rate]),
            V=p.V, D=p.D, tau=p.tau, a=p.sensor_radius, direction=[0.0, -1.0, 0.0],
        ).sum()
    )  # fmt: skip
    assert mu > 0.3
    assert abs(h.mean() - mu) < 4 * math.sqrt(mu / h.size)
    assert abs(h.var() - mu) < 0.15 * mu  # Poisson: the variance equals the mean


def test_vector_contract_threads_and_determinism() -> None:
    v = EncounterVectorEnv("muc-osl-3d", num_envs=4)
    many = EncounterVectorEnv("muc-osl-3d", num_envs=4, threads=None)
    assert v.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs, _ = v.reset(seed=2)
    obs2, _ = many.reset(seed=2)
    assert obs in v.observation_space
    assert obs.shape == (4, 3, len(v.feature_names))
    np.testing.assert_array_equal(obs, obs2)
    v.action_space.seed(0)
    seq = [v.action_space.sample() for _ in range(40)]
    first = []
    for a in seq:
        s1, s2 = v.step(a), many.step(a)
        for x, y in zip(s1[:4], s2[:4], strict=True):
            np.testing.assert_array_equal(x, y)
        assert s1[0] in v.observation_space
        first.append(s1)
    v.reset(seed=2)
    for (o, r, *_), a in zip(first, seq, strict=True):
        o2, r2, *_ = v.step(a)
        np.testing.assert_array_equal(o, o2)
        np.testing.assert_array_equal(r, r2)
    # energy, positions and the steps played describe the episodes
    assert np.all(v.energy > 0) and v.positions.shape == (4, 3, 3)
    np.testing.assert_array_equal(v.steps, np.full(4, 40))


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="num_envs"):
        EncounterVectorEnv("muc-osl-3d", num_envs=0)
    with pytest.raises(ConfigError, match=r"world\.plume"):
        EncounterVectorEnv("indoor-ventilated", num_envs=2)
    with pytest.raises(ConfigError, match=r"sensors\.gas\.gain"):
        EncounterVectorEnv(TEAM.with_overrides({"sensors.gas.gain": 3.0}), num_envs=2)
    with pytest.raises(ConfigError, match=r"sensors\.anemometer\.noise_std"):
        EncounterVectorEnv(TEAM.with_overrides({"sensors.anemometer.noise_std": 0.1}), num_envs=2)
    with pytest.raises(ConfigError, match="min_start_distance"):
        EncounterVectorEnv(_solo(**{"world.source_draw.min_start_distance": 1.0}), num_envs=2)
    with pytest.raises(ConfigError, match=r"observation\.belief"):
        EncounterVectorEnv("muc-osl-3d", num_envs=2, observation={"belief": {"type": "col-pf"}})
    v = EncounterVectorEnv("muc-osl-3d", num_envs=2)
    with pytest.raises(RuntimeError, match="reset"):
        v.step(np.zeros((2, 3), np.int64))
    v.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        v.step(np.full((2, 3), 7))
    with pytest.raises(ValueError, match="actions"):
        v.step(np.zeros(2, np.int64))
    w = EncounterVectorEnv(_solo(), num_envs=2, action={"kind": "velocity"})
    w.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        w.step(np.full((2, 4), np.nan))
