"""The batched lattice environment against the single environment, and the vector contract."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from gymnasium.vector import AutoresetMode

from odorloc.core.errors import ConfigError
from odorloc.envs.gym_env import SearchEnv
from odorloc.envs.vector import LatticeVectorEnv


def _single_trajectory(scenario: str, root: int, episode: int, actions: np.ndarray) -> list:
    """(cell, hit class, reward, terminated, truncated) per step of the single environment."""
    env = SearchEnv(scenario, action={"kind": "discrete", "declare": "none"})
    env.reset(seed=root, options={"episode": episode})
    ep = env.unwrapped.core.episode
    out = []
    for a in actions:
        _, r, te, tr, _ = env.step(int(a))
        o = ep.observations[0]
        cell = tuple(int(v) for v in np.floor(o.position))
        out.append((cell, int(o.gas), r, bool(te), bool(tr)))
        if te or tr:
            break
    return out


@pytest.mark.parametrize(
    ("scenario", "steps"), [("lattice-isotropic-2d", 700), ("lattice-isotropic-3d", 40)]
)
def test_sub_env_i_is_episode_i_of_the_batch(scenario: str, steps: int) -> None:
    """Positions, hits, rewards and ends of every sub-environment equal the single
    environment's episode ``i`` of the same root; a sub-environment that ended plays the next
    unused episode."""
    b, root = 3, 11
    v = LatticeVectorEnv(scenario, num_envs=b)
    v.reset(seed=root)
    z = v.problem.z
    rng = np.random.default_rng(4)
    acts = rng.integers(0, 2 * v.problem.dim, size=(steps, b))
    rows: dict[int, list] = {i: [] for i in range(b)}
    episode = v.episodes
    np.testing.assert_array_equal(episode, np.arange(b))
    restarted: dict[int, int] = {}
    for t in range(steps):
        cells_before = v.positions
        obs, r, te, tr, info = v.step(acts[t])
        for i in range(b):
            if i in restarted:
                continue
            ended = bool(te[i] or tr[i])
            last = info["final_obs"][i] if ended else obs[i]
            hit = int(np.argmax(last[v.problem.dim : v.problem.dim + z]))
            cell = None if ended else tuple(int(c) for c in v.positions[i])
            rows[i].append((cell, hit, float(r[i]), bool(te[i]), bool(tr[i]), cells_before[i]))
            if ended:
                restarted[i] = int(v.episodes[i])
    for i in range(b):
        single = _single_trajectory(scenario, root, i, acts[: len(rows[i]), i])
        assert len(single) == len(rows[i])
        for (cell, hit, r, te, tr, _), (cell1, g, r1, te1, tr1) in zip(
            rows[i], single, strict=True
        ):
            assert (r, te, tr) == (r1, te1, tr1)
            if cell is not None:
                assert cell == cell1
                assert hit == min(g, z - 1)
    # the ended sub-environments went on with episodes not yet played (b, b + 1, ...)
    nxt = list(restarted.values())
    assert len(set(nxt)) == len(nxt) and all(e >= b for e in nxt)


def test_vector_contract_and_determinism() -> None:
    v = LatticeVectorEnv("lattice-isotropic-2d", num_envs=5)
    assert v.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs, _ = v.reset(seed=3)
    assert obs in v.observation_space
    v.action_space.seed(0)
    seq = [v.action_space.sample() for _ in range(50)]
    first = [v.step(a) for a in seq]
    for o, r, te, tr, _ in first:
        assert o in v.observation_space
        assert r.shape == te.shape == tr.shape == (5,)
        assert not np.any(te & tr)
    obs2, _ = v.reset(seed=3)
    np.testing.assert_array_equal(obs, obs2)
    for (o, r, *_), a in zip(first, seq, strict=True):
        o2, r2, *_ = v.step(a)
        np.testing.assert_array_equal(o, o2)
        np.testing.assert_array_equal(r, r2)
    # beliefs are distributions over the grid, and the features describe them
    bel = v.belief
    np.testing.assert_allclose(bel.reshape(5, -1).sum(axis=1), 1.0, rtol=1e-12)
    n = bel.shape[1]
    grid = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    mean = np.einsum("bij,aij->ba", bel, grid)
    names = v.feature_names
    cols = [names.index("mean_offset_x"), names.index("mean_offset_y")]
    np.testing.assert_allclose(o[:, cols], (mean - v.positions) / n, atol=1e-6)
    cells = v.positions
    left = [bel[i, c[0] - 1, c[1]] if c[0] > 0 else 0.0 for i, c in enumerate(cells)]
    np.testing.assert_allclose(o[:, names.index("belief_-x")], left, atol=1e-7)


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="num_envs"):
        LatticeVectorEnv("lattice-isotropic-2d", num_envs=0)
    with pytest.raises(ConfigError, match=r"world\.plume"):
        LatticeVectorEnv("indoor-ventilated", num_envs=2)
    v = LatticeVectorEnv("lattice-isotropic-2d", num_envs=2)
    with pytest.raises(RuntimeError, match="reset"):
        v.step(np.zeros(2, np.int64))
    v.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        v.step(np.array([0, 4]))
    with pytest.raises(ValueError, match="actions"):
        v.step(np.zeros(3, np.int64))


def test_threads_give_the_same_numbers() -> None:
    """Stepping on every thread gives the single thread's observations, rewards and episodes
    (seeded alike), through several restarts."""
    one = LatticeVectorEnv("lattice-isotropic-2d", num_envs=7)
    many = LatticeVectorEnv("lattice-isotropic-2d", num_envs=7, threads=None)
    o1, _ = one.reset(seed=5)
    o2, _ = many.reset(seed=5)
    np.testing.assert_array_equal(o1, o2)
    acts = np.random.default_rng(1).integers(0, 4, size=(300, 7))
    for a in acts:
        s1, s2 = one.step(a), many.step(a)
        for x, y in zip(s1[:4], s2[:4], strict=True):
            np.testing.assert_array_equal(x, y)
        assert s1[4].keys() == s2[4].keys()
    np.testing.assert_array_equal(one.episodes, many.episodes)
    assert one.episodes.max() >= 7  # some sub-environments restarted
    np.testing.assert_array_equal(one.belief, many.belief)


def test_restarted_episodes_start_as_the_single_env() -> None:
    """Episodes played after an auto-reset start as the single environment's episode of that
    index: the same source cell, the same start cell and the same first hit class."""
    v = LatticeVectorEnv("lattice-isotropic-2d", num_envs=2)
    v.reset(seed=9)
    z, d = v.problem.z, v.problem.dim
    acts = np.random.default_rng(2).integers(0, 4, size=(3000, 2))
    seen: set[int] = set()
    for a in acts:
        obs, _, te, tr, _ = v.step(a)
        for i in np.flatnonzero(te | tr):
            ep = int(v.episodes[i])
            seen.add(ep)
            single = SearchEnv(
                "lattice-isotropic-2d", action={"kind": "discrete", "declare": "none"}
            )
            single.reset(seed=9, options={"episode": ep})
            core = single.unwrapped.core.episode
            plume = core.world.plume
            src = plume.arena.grid.index(plume.sources[0].position)[0]
            assert tuple(v.sources[i]) == tuple(int(c) for c in src)
            o = core.observations[0]
            assert tuple(v.positions[i]) == tuple(int(c) for c in np.floor(o.position))
            assert int(np.argmax(obs[i, d : d + z])) == min(int(o.gas), z - 1)
        if len(seen) >= 4:
            break
    assert len(seen) >= 4


def test_bad_threads() -> None:
    with pytest.raises(ConfigError, match="threads"):
        LatticeVectorEnv("lattice-isotropic-2d", num_envs=2, threads=0)
