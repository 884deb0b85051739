"""Batched environments: ``B`` episodes of the lattice problem stepped at once as arrays.

:class:`LatticeVectorEnv` is a :class:`gymnasium.vector.VectorEnv` for the single-agent
lattice scenarios of OTTO's problem (``lattice-isotropic-*``, 2-D or 3-D: a
``lattice-isotropic`` plume with ``start: initial-hit``, a ``lattice`` platform, an
``encounter`` hit counter). One :meth:`~LatticeVectorEnv.step` moves every agent, draws every
hit, updates every belief, writes every observation and restarts every ended episode in one
compiled call, with no Python object per episode.

Episodes are those of the engine. ``reset(seed=R)`` starts episode ``i`` of root ``R`` in
sub-environment ``i``; when a sub-environment's episode ends it starts the next episode not yet
used, ``i + B``, ``i + 2 B``, ... in order of the sub-environments that ended (so sub-environment
``i``'s first episode is exactly episode ``i`` of ``odorloc batch -s SCENARIO --seed R`` and of
``SearchEnv`` reset with ``options={"episode": i}``). Each episode draws from the generators the
engine gives it (:func:`~odorloc.core.seeds.world_generators`, those of
:func:`~odorloc.core.seeds.episode_generators`): the first hit and the source
from the world stream as the plume does, each hit count from the sensor stream as NumPy's
Poisson sampler does (the multiplication method below a mean of 10 hits, which every hit of the
lattice problem lies under: larger means are refused). Starting an episode costs about a
microsecond: the seed derivation and both PCG64 streams are computed in compiled code, bit for
bit as NumPy computes them (:mod:`odorloc.core.pcg`), and what depends only on the scenario
(the start belief of each first hit, its logarithm, entropy and moments) is computed once.

Belief update (the Bayes rule of :mod:`odorloc.planning.lattice_step`, the agent's cell
emptied): one pass over the grid per step. The stored belief is normalised lazily, its mass
kept beside it and divided out in the next pass (and in every observation); as in the reference,
a belief of mass at or below ``1e-10`` is not normalised. The episode's dynamics (cells, hits,
rewards, ends) do not depend on the belief; only the observation does.

Actions: ``Discrete(2 d)`` per sub-environment, the lattice moves ``-x, +x, -y, +y[, -z, +z]``
(a move off the grid leaves the agent where it is). Rewards, termination and truncation are
those of ``SearchEnv`` with ``action={"kind": "discrete", "declare": "none"}``: ``reward.step``
per step, ``reward.reach`` on stepping onto the source (``terminated``); ``truncated`` at the
task's stuck rule or at the time limit (the step after the last allowed move, which does not
move). Auto-reset: ``SAME_STEP`` (the observation returned for an ended episode is the first of
the next; the last one is in ``info["final_obs"]``, with ``info["_final_obs"]`` marking which).

Observation (``float32``, :attr:`LatticeVectorEnv.feature_names`): the agent's cell scaled to
``[0, 1]`` per axis, the last hit class one-hot (``Z`` classes), the belief's Shannon entropy
(bits, over every non-empty cell) over its largest value ``log2(n cells)``, the belief in the
``2 d`` neighbouring cells (0 off the grid), and the belief's mean offset from the agent per
axis over the grid size. ``belief`` (a property) holds every sub-environment's full belief.

With ``threads > 1`` the sub-environments are stepped on numba's threads and restarted in
order afterwards: the same episodes, the same numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import FunctionType
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from odorloc.core.errors import ConfigError
from odorloc.core.jit import jit, prange, set_threads
from odorloc.core.jit import threads as jit_threads
from odorloc.core.pcg import pcg_double, pcg_poisson_mult, pcg_seed, seed_words
from odorloc.core.seeds import check_seed, stream_words
from odorloc.engine.lattice_fused import LatticeProblem
from odorloc.envs.core import RewardParams, load_scenario, validated
from odorloc.scenarios import Scenario

__all__ = ["EpisodeRoots", "LatticeVectorEnv"]

_LOG_FLOOR = -1e300  # log of an empty cell (finite: 0 * floor adds nothing to an entropy)


# ---------------------------------------------------------------------- compiled batch step
def _scale(tot: float) -> float:
    """The factor that turns a stored belief of mass ``tot`` into the belief: ``1 / tot``,
    or 1 when the mass is at or below ``1e-10`` (the reference's normalisation rule)."""
    return 1.0 / tot if tot > 1e-10 else 1.0


def _update(
    u: np.ndarray,
    lu: np.ndarray,
    tot: float,
    ag: np.ndarray,
    prob: np.ndarray,
    logp: np.ndarray,
    half: np.ndarray,
    hit: int,
    mom: np.ndarray,
) -> tuple[float, float]:
    """Bayes update after ``hit`` at ``ag`` in one pass over the grid.

    ``u`` holds the belief times its mass ``tot`` (normalised lazily: the division by the mass
    is folded into the next update), ``lu`` its logarithm floored at ``-1e300`` (so that an
    empty cell adds ``0 * -1e300 = 0`` to the entropy's sum, never a NaN). Returns the new
    mass and the belief's entropy (bits, every non-empty cell); the belief's first moments
    (cells) go to ``mom`` ``(3,)``.
    """
    n0, n1, n2 = u.shape
    c = _scale(tot)
    shift = math.log(c)
    u[ag[0], ag[1], ag[2]] = 0.0
    new = 0.0
    e = 0.0
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    o2 = half[2] - ag[2]
    for i0 in range(n0):
        r0 = i0 - ag[0] + half[0]
        for i1 in range(n1):
            r1 = i1 - ag[1] + half[1]
            p = prob[hit, r0, r1, o2 : o2 + n2]
            lp = logp[hit, r0, r1, o2 : o2 + n2]
            row = u[i0, i1]
            lrow = lu[i0, i1]
            srow = 0.0
            for i2 in range(n2):
                v = row[i2] * c * p[i2]
                row[i2] = v
                lv = max(lrow[i2] + shift + lp[i2], _LOG_FLOOR)
                lrow[i2] = lv
                srow += v
                m2 += v * i2
                e += v * lv
            new += srow
            m0 += srow * i0
            m1 += srow * i1
    lu[ag[0], ag[1], ag[2]] = _LOG_FLOOR
    c = _scale(new)
    mom[0] = m0 * c
    mom[1] = m1 * c
    mom[2] = m2 * c
    # S = -sum (c u)(lu + log c), u summing to `new`
    return new, -(c * e + c * new * math.log(c)) / math.log(2.0)


def episode_streams(
    words: np.ndarray, n_root: int, episode: int, world: np.ndarray, sense: np.ndarray
) -> None:
    """The world and sensor streams (PCG64 states ``(4,)``, into ``world`` and ``sense``) of
    ``episode``: :func:`~odorloc.core.seeds.world_generators` of the world seed of
    :func:`~odorloc.core.seeds.episode_seeds`, as NumPy computes them. ``words`` holds the
    root's ``n_root`` words, the world stream (0) and the key's eight words
    (:func:`~odorloc.core.seeds.stream_words`)."""
    n = n_root + 9
    w = np.empty(n + 2, np.uint64)
    w[:n] = words[:n]
    w[n] = np.uint64(episode & 0xFFFFFFFF)
    if episode >> 32:
        w[n + 1] = np.uint64(episode >> 32)
        n += 2
    else:
        n += 1
    ws = seed_words(w[:n], n_root)
    v = np.empty(3, np.uint64)
    v[0] = ws & np.uint64(0xFFFFFFFF)
    n_ws = 1
    if ws >> np.uint64(32):
        v[1] = ws >> np.uint64(32)
        n_ws = 2
    v[n_ws] = np.uint64(0)
    pcg_seed(v[: n_ws + 1], n_ws, world)
    v[n_ws] = np.uint64(1)
    pcg_seed(v[: n_ws + 1], n_ws, sense)


def _start(
    i: int,
    episode: int,
    words: np.ndarray,
    n_root: int,
    cdf_h0: np.ndarray,
    cdf_b0: np.ndarray,
    b0: np.ndarray,
    logb0: np.ndarray,
    ent0: np.ndarray,
    mom0: np.ndarray,
    tot0: np.ndarray,
    start: np.ndarray,
    dim: int,
    ag: np.ndarray,
    src: np.ndarray,
    prev: np.ndarray,
    back: np.ndarray,
    steps: np.ndarray,
    b: np.ndarray,
    logb: np.ndarray,
    ent: np.ndarray,
    mom: np.ndarray,
    tot: np.ndarray,
    last: np.ndarray,
    sense: np.ndarray,
    epi: np.ndarray,
) -> None:
    """Start ``episode`` in sub-environment ``i`` (module docstring)."""
    world = np.empty(4, np.uint64)
    episode_streams(words, n_root, episode, world, sense[i])
    # the plume's draws: the first hit class, then the source from that hit's start belief
    h0 = np.searchsorted(cdf_h0, pcg_double(world), side="right")
    cell = np.searchsorted(cdf_b0[h0], pcg_double(world), side="right")
    n1 = b.shape[2]
    n2 = b.shape[3]
    src[i, 0] = cell // (n1 * n2)
    src[i, 1] = (cell // n2) % n1
    src[i, 2] = cell % n2
    for a in range(3):
        ag[i, a] = start[a]
        prev[i, a] = start[a]
        mom[i, a] = mom0[h0, a]
    back[i] = 0
    steps[i] = 0
    last[i] = h0
    b[i] = b0[h0]
    logb[i] = logb0[h0]
    ent[i] = ent0[h0]
    tot[i] = tot0[h0]
    epi[i] = episode


def _feature_row(
    i: int,
    ag: np.ndarray,
    b: np.ndarray,
    ent: np.ndarray,
    mom: np.ndarray,
    tot: np.ndarray,
    last: np.ndarray,
    dim: int,
    z: int,
    ent_max: float,
    out: np.ndarray,
) -> None:
    """Sub-environment ``i``'s observation (module docstring) into ``out`` ``(F,)``."""
    shape = b.shape[1:]
    lead = 3 - dim
    c = _scale(tot[i])
    k = 0
    for a in range(dim):
        n = shape[lead + a]
        out[k] = ag[i, lead + a] / max(n - 1, 1)
        k += 1
    for h in range(z):
        out[k] = 1.0 if last[i] == h else 0.0
        k += 1
    out[k] = ent[i] / ent_max
    k += 1
    for a in range(2 * dim):
        axis = lead + a // 2
        c0 = ag[i, 0]
        c1 = ag[i, 1]
        c2 = ag[i, 2]
        step = 1 if a % 2 == 1 else -1
        if axis == 0:
            c0 += step
        elif axis == 1:
            c1 += step
        else:
            c2 += step
        inside = 0 <= c0 < shape[0] and 0 <= c1 < shape[1] and 0 <= c2 < shape[2]
        out[k] = c * b[i, c0, c1, c2] if inside else 0.0
        k += 1
    for a in range(dim):
        out[k] = (mom[i, lead + a] - ag[i, lead + a]) / shape[lead + a]
        k += 1


def _reset_all(
    first: int,
    words: np.ndarray,
    n_root: int,
    cdf_h0: np.ndarray,
    cdf_b0: np.ndarray,
    b0: np.ndarray,
    logb0: np.ndarray,
    ent0: np.ndarray,
    mom0: np.ndarray,
    tot0: np.ndarray,
    start: np.ndarray,
    dim: int,
    z: int,
    ent_max: float,
    ag: np.ndarray,
    src: np.ndarray,
    prev: np.ndarray,
    back: np.ndarray,
    steps: np.ndarray,
    b: np.ndarray,
    logb: np.ndarray,
    ent: np.ndarray,
    mom: np.ndarray,
    tot: np.ndarray,
    last: np.ndarray,
    sense: np.ndarray,
    epi: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Episodes ``first .. first + B - 1`` in sub-environments ``0 .. B - 1``, and their
    observations."""
    for i in range(ag.shape[0]):
        _start(
            i, first + i, words, n_root, cdf_h0, cdf_b0, b0, logb0, ent0, mom0, tot0, start, dim,
            ag, src, prev, back, steps, b, logb, ent, mom, tot, last, sense, epi,
        )  # fmt: skip
        _feature_row(i, ag, b, ent, mom, tot, last, dim, z, ent_max, obs[i])


def _renamed(fn: Any, name: str) -> Any:
    """A copy of the function ``fn`` under another name (its own compiled kernel and cache
    entry)."""
    out = FunctionType(fn.__code__, fn.__globals__, name, fn.__defaults__)
    out.__qualname__ = name
    out.__module__ = fn.__module__
    return out


def _batch_step(
    actions: np.ndarray,
    nxt: int,
    words: np.ndarray,
    n_root: int,
    cdf_h0: np.ndarray,
    cdf_b0: np.ndarray,
    b0: np.ndarray,
    logb0: np.ndarray,
    ent0: np.ndarray,
    mom0: np.ndarray,
    tot0: np.ndarray,
    start: np.ndarray,
    enlam: np.ndarray,
    prob: np.ndarray,
    logp: np.ndarray,
    half: np.ndarray,
    dim: int,
    z: int,
    ent_max: float,
    n_steps: int,
    stuck: int,
    ag: np.ndarray,
    src: np.ndarray,
    prev: np.ndarray,
    back: np.ndarray,
    steps: np.ndarray,
    b: np.ndarray,
    logb: np.ndarray,
    ent: np.ndarray,
    mom: np.ndarray,
    tot: np.ndarray,
    last: np.ndarray,
    sense: np.ndarray,
    epi: np.ndarray,
    status: np.ndarray,
    obs: np.ndarray,
    final: np.ndarray,
    final_epi: np.ndarray,
    r_step: float,
    r_reach: float,
    reward: np.ndarray,
    term: np.ndarray,
    trunc: np.ndarray,
) -> int:
    """One step of every sub-environment (module docstring), their observations into ``obs``,
    rewards into ``reward``, ends into ``term`` / ``trunc``; an ended episode's last
    observation goes to ``final`` and the sub-environment starts episode ``nxt``, ``nxt + 1``,
    ... in order. ``status``: 0 running, 1 reached, 2 time limit, 3 stuck. Returns the next
    unused episode, or -1 (nothing changed) when an action is not a move."""
    nb = actions.shape[0]
    for i in range(nb):
        if actions[i] < 0 or actions[i] >= 2 * dim:
            return -1
    # the episodes are independent: step them on every thread numba was given (the kernel
    # compiled with parallel=True; one thread otherwise), restart them in order afterwards
    for i in prange(nb):
        status[i] = _step_one(
            i, actions[i], enlam, prob, logp, half, dim, z, n_steps, stuck,
            ag, src, prev, back, steps, b, logb, ent, mom, tot, last, sense,
        )  # fmt: skip
        final_epi[i] = epi[i]
        reward[i] = r_step + r_reach if status[i] == 1 else r_step
        term[i] = status[i] == 1
        trunc[i] = status[i] == 2 or status[i] == 3
        if status[i] == 0:
            _feature_row(i, ag, b, ent, mom, tot, last, dim, z, ent_max, obs[i])
    for i in range(nb):
        if status[i] != 0:
            _feature_row(i, ag, b, ent, mom, tot, last, dim, z, ent_max, final[i])
            _start(
                i, nxt, words, n_root, cdf_h0, cdf_b0, b0, logb0, ent0, mom0, tot0, start, dim,
                ag, src, prev, back, steps, b, logb, ent, mom, tot, last, sense, epi,
            )  # fmt: skip
            nxt += 1
            _feature_row(i, ag, b, ent, mom, tot, last, dim, z, ent_max, obs[i])
    return nxt


def _step_one(
    i: int,
    a: int,
    enlam: np.ndarray,
    prob: np.ndarray,
    logp: np.ndarray,
    half: np.ndarray,
    dim: int,
    z: int,
    n_steps: int,
    stuck: int,
    ag: np.ndarray,
    src: np.ndarray,
    prev: np.ndarray,
    back: np.ndarray,
    steps: np.ndarray,
    b: np.ndarray,
    logb: np.ndarray,
    ent: np.ndarray,
    mom: np.ndarray,
    tot: np.ndarray,
    last: np.ndarray,
    sense: np.ndarray,
) -> int:
    """Move, hit and belief update of sub-environment ``i`` after action ``a``; returns its
    status (:func:`_batch_step`)."""
    if steps[i] >= n_steps:
        return 2
    shape = b.shape[1:]
    axis = a // 2 + (3 - dim)
    old0 = ag[i, 0]
    old1 = ag[i, 1]
    old2 = ag[i, 2]
    v = ag[i, axis] + (1 if a % 2 == 1 else -1)
    if 0 <= v < shape[axis]:
        ag[i, axis] = v
    steps[i] += 1
    # the hit count is drawn at every step, on the source cell too (as the engine does)
    r0 = src[i, 0] - ag[i, 0] + half[0]
    r1 = src[i, 1] - ag[i, 1] + half[1]
    r2 = src[i, 2] - ag[i, 2] + half[2]
    el = enlam[r0, r1, r2]
    count = pcg_poisson_mult(sense[i], el) if el < 1.0 else 0
    h = count if count < z - 1 else z - 1
    last[i] = h
    reached = ag[i, 0] == src[i, 0] and ag[i, 1] == src[i, 1] and ag[i, 2] == src[i, 2]
    # the stuck counter: back to the cell of two steps ago
    if steps[i] >= 2:
        if ag[i, 0] == prev[i, 0] and ag[i, 1] == prev[i, 1] and ag[i, 2] == prev[i, 2]:
            back[i] += 1
        else:
            back[i] = 0
    prev[i, 0] = old0
    prev[i, 1] = old1
    prev[i, 2] = old2
    if reached:
        return 1
    tot[i], ent[i] = _update(b[i], logb[i], tot[i], ag[i], prob, logp, half, h, mom[i])
    if stuck >= 0 and back[i] > stuck and steps[i] < n_steps:
        return 3
    return 0


episode_streams = jit(episode_streams)
_scale = jit(_scale)
_update = jit(_update, fastmath={"reassoc", "contract", "arcp", "nsz"})
_start = jit(_start)
_feature_row = jit(_feature_row)
_reset_all = jit(_reset_all)
_step_one = jit(_step_one)
# the same kernel twice: on one thread, and over numba's threads (the ``threads`` option)
_batch_step_threads = jit(_renamed(_batch_step, "_batch_step_threads"), parallel=True)
_batch_step = jit(_batch_step)


# ---------------------------------------------------------------------- the environment
class EpisodeRoots:
    """The root seed of a batched environment's episodes (``reset``'s ``seed``), shared by the
    batched environments: the seed words of the world key in ``_words`` for
    :func:`episode_streams`."""

    root: int | None
    world_key: str
    _words: np.ndarray
    _n_root: int

    @staticmethod
    def _checked_sizes(num_envs: Any, threads: Any) -> int:
        """The thread count (``None``: all of numba's) after checking it and ``num_envs``."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ConfigError("num_envs", f"must be an integer >= 1, got {num_envs!r}")
        most = jit_threads()
        if threads is None:
            threads = most
        if isinstance(threads, bool) or not isinstance(threads, int) or not 1 <= threads <= most:
            raise ConfigError("threads", f"must be an integer in [1, {most}], got {threads!r}")
        return threads

    def _set_root(self, seed: Any) -> None:
        if isinstance(seed, list):
            raise ConfigError("seed", "one root seed for every sub-environment, not a list")
        VectorEnv.reset(self, seed=seed)  # type: ignore[arg-type]
        if seed is not None:
            self.root = check_seed(int(seed), "seed")
        elif self.root is None:
            rng = self.np_random  # type: ignore[attr-defined]
            self.root = int(rng.integers(0, 2**63 - 1, dtype=np.int64))
        words, n_root = stream_words(self.root, self.world_key, 0)
        self._words[:] = 0
        self._words[: len(words)] = words
        self._n_root = n_root


class LatticeVectorEnv(EpisodeRoots, VectorEnv):
    """``num_envs`` episodes of a lattice scenario stepped as arrays (module docstring).

    Parameters
    ----------
    scenario : str, path or Scenario
        A single-agent lattice scenario (default ``lattice-isotropic-2d``).
    num_envs : int
        ``B``, at least 1.
    reward : dict, optional
        :class:`~odorloc.envs.core.RewardParams` (``step`` and ``reach`` apply).
    world_key : str, optional
        World key of the seed derivation (default: the scenario's name as given).
    threads : int, optional
        Threads that step the sub-environments (default 1; ``None``: every thread numba was
        given, :func:`odorloc.core.jit.threads`). Episodes, seeds and observations do not
        depend on it.
    """

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        scenario: str | Path | Scenario = "lattice-isotropic-2d",
        num_envs: int = 64,
        reward: dict[str, Any] | None = None,
        world_key: str | None = None,
        threads: int | None = 1,
    ) -> None:
        self.threads = self._checked_sizes(num_envs, threads)
        sc, key = load_scenario(scenario)
        self.scenario = sc
        self.world_key = world_key or key
        self.reward_params = validated(RewardParams, reward, "reward")
        pr = LatticeProblem(sc)
        self.problem = pr
        k = pr.kernels
        self.num_envs = num_envs
        d, z = pr.dim, pr.z
        self.feature_names = (
            [f"cell_{a}" for a in "xyz"[:d]]
            + [f"hit_{h}" for h in range(z)]
            + ["entropy"]
            + [f"belief_{s}{a}" for a in "xyz"[:d] for s in "-+"]
            + [f"mean_offset_{a}" for a in "xyz"[:d]]
        )
        f = len(self.feature_names)
        lo = np.full(f, -1.0, np.float32)
        lo[: d + z + 1 + 2 * d] = 0.0
        self.single_observation_space = spaces.Box(lo, np.ones(f, np.float32), (f,), np.float32)
        self.single_action_space = spaces.Discrete(2 * d)
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, num_envs
        )
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        nb = num_envs
        self._b = np.zeros((nb, *k.shape))
        self._logb = np.zeros((nb, *k.shape))
        self._ent = np.zeros(nb)
        self._mom = np.zeros((nb, 3))
        self._tot = np.ones(nb)
        self._ag = np.zeros((nb, 3), np.int64)
        self._src = np.zeros((nb, 3), np.int64)
        self._prev = np.zeros((nb, 3), np.int64)
        self._back = np.zeros(nb, np.int64)
        self._steps = np.zeros(nb, np.int64)
        self._last = np.zeros(nb, np.int64)
        self._sense = np.zeros((nb, 4), np.uint64)  # each episode's sensor stream (PCG64)
        self._status = np.zeros(nb, np.int64)
        self._episode = np.full(nb, -1, np.int64)
        self._final_episode = np.full(nb, -1, np.int64)
        self._obs = np.zeros((nb, f), np.float32)
        self._final = np.zeros((nb, f), np.float32)
        self._reward = np.zeros(nb)
        self._term = np.zeros(nb, bool)
        self._trunc = np.zeros(nb, bool)
        self._step_args: tuple[Any, ...] = ()
        self._ent_max = math.log2(math.prod(pr.shape))
        # what depends only on the scenario, once: per first hit class, the start belief (as
        # the kernels hold it), its logarithm, entropy, first moments and the cumulative sum
        # the source is drawn from (zero rows for classes that cannot come first)
        n = math.prod(k.shape)
        self._b0 = np.zeros((z, *k.shape))
        self._logb0 = np.full((z, *k.shape), _LOG_FLOOR)
        self._ent0 = np.zeros(z)
        self._mom0 = np.zeros((z, 3))
        self._tot0 = np.ones(z)
        self._cdf_b0 = np.zeros((z, n))
        grids = np.meshgrid(*[np.arange(m) for m in k.shape], indexing="ij")
        for h, b0 in enumerate(pr.b0):
            if b0 is None:
                continue
            bk = k.as_kernel(b0.copy())
            pos = bk > 0
            self._b0[h] = bk
            self._logb0[h][pos] = np.log(bk[pos])
            self._ent0[h] = -float((bk[pos] * self._logb0[h][pos]).sum()) / math.log(2.0)
            self._tot0[h] = float(bk.sum())
            self._mom0[h] = [float((bk * g).sum()) / self._tot0[h] for g in grids]
            cdf = pr.cdf_b0[h]
            assert cdf is not None
            self._cdf_b0[h] = cdf
        with np.errstate(divide="ignore"):
            self._logp = np.ascontiguousarray(np.maximum(np.log(k.prob), _LOG_FLOOR))
        start = np.zeros(3, np.int64)
        start[3 - d :] = pr.start
        self._start_cell = start
        self._words = np.zeros(13, np.uint64)
        self._n_root = 0
        self.root: int | None = None
        self._next = 0

    # ------------------------------------------------------------------ episodes
    @property
    def belief(self) -> np.ndarray:
        """Every sub-environment's belief, ``(B, *grid shape)`` (a copy)."""
        scale = np.where(self._tot > 1e-10, 1.0 / np.maximum(self._tot, 1e-300), 1.0)
        b = self._b.reshape(self.num_envs, -1) * scale[:, None]
        return b.reshape(self.num_envs, *self.problem.shape)

    @property
    def episodes(self) -> np.ndarray:
        """The episode index each sub-environment is playing, ``(B,)``."""
        return self._episode.copy()

    @property
    def positions(self) -> np.ndarray:
        """Every agent's cell, ``(B, d)`` (grid indices)."""
        return self._ag[:, 3 - self.problem.dim :].copy()

    @property
    def sources(self) -> np.ndarray:
        """Every source's cell, ``(B, d)`` (grid indices)."""
        return self._src[:, 3 - self.problem.dim :].copy()

    def _common(self) -> tuple[Any, ...]:
        """The episode-start arguments of the kernels, in their order."""
        return (
            self._words,
            self._n_root,
            self.problem.cdf_h0,
            self._cdf_b0,
            self._b0,
            self._logb0,
            self._ent0,
            self._mom0,
            self._tot0,
            self._start_cell,
        )

    def _state(self) -> tuple[np.ndarray, ...]:
        """The per-sub-environment arrays of the kernels, in their order."""
        return (
            self._ag,
            self._src,
            self._prev,
            self._back,
            self._steps,
            self._b,
            self._logb,
            self._ent,
            self._mom,
            self._tot,
            self._last,
            self._sense,
            self._episode,
        )

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start episodes ``0 .. B-1`` of root ``seed`` (of a new root drawn from the
        environment's own generator when no seed was ever given)."""
        self._set_root(seed)
        pr = self.problem
        _reset_all(0, *self._common(), pr.dim, pr.z, self._ent_max, *self._state(), self._obs)
        self._next = self.num_envs
        k, rp = pr.kernels, self.reward_params
        # every argument of the step kernel after the actions and the next episode
        self._step_args = (
            *self._common(),
            pr.enlam,
            k.prob,
            self._logp,
            k.half,
            pr.dim,
            pr.z,
            self._ent_max,
            pr.n_steps,
            pr.stuck,
            *self._state(),
            self._status,
            self._obs,
            self._final,
            self._final_episode,
            float(rp.step),
            float(rp.reach),
            self._reward,
            self._term,
            self._trunc,
        )
        return self._obs.copy(), {"episode": self._episode.copy()}

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-environment; ended episodes restart at once (``SAME_STEP``)."""
        if self.root is None:
            raise RuntimeError("call reset() before step()")
        act = np.asarray(actions)
        if act.shape != (self.num_envs,) or act.dtype.kind not in "iu":
            raise ValueError(f"actions must be {self.num_envs} integers, got {act!r}")
        if act.dtype != np.int64:
            act = act.astype(np.int64)
        kernel = _batch_step
        if self.threads > 1:
            kernel = _batch_step_threads
            set_threads(self.threads)
        nxt = kernel(act, self._next, *self._step_args)
        if nxt < 0:
            raise ValueError(f"actions must lie in [0, {2 * self.problem.dim})")
        info: dict[str, Any] = {}
        if nxt > self._next:  # some episodes ended (and the next ones started)
            ended = self._term | self._trunc
            final = np.zeros_like(self._obs)
            final[ended] = self._final[ended]
            info["final_obs"] = final
            info["_final_obs"] = ended
            info["final_episode"] = self._final_episode.copy()
        self._next = nxt
        return (
            self._obs.copy(),
            self._reward.copy(),
            self._term.copy(),
            self._trunc.copy(),
            info,
        )
