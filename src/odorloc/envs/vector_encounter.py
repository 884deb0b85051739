"""Batched environments for the 3-D encounter-rate world: ``B`` episodes of a UAV (or a UAV team)
searching a Vergassola rate plume, stepped at once as arrays.

:class:`EncounterVectorEnv` is a :class:`gymnasium.vector.VectorEnv` for scenarios like
``muc-osl-3d``: a 3-D ``vergassola`` plume in a ``uniform`` wind with constant releases, an
``encounter`` hit counter and a noiseless anemometer on every agent, ``uav`` platforms (point
bodies) in an arena without obstacles, fixed sources or sources drawn by ``source_draw:
uniform``. One :meth:`~EncounterVectorEnv.step` decodes every action, moves every UAV through
the paper's turn / fly / hover phases with their energy (:class:`~odorloc.platforms.uav.UAV`),
delivers every team message within the communication radius, draws every hit count, writes
every observation and restarts every ended episode in one compiled call.

Episodes are those of the engine, exactly as in :class:`~odorloc.envs.vector.LatticeVectorEnv`:
``reset(seed=R)`` starts episode ``i`` of root ``R`` in sub-environment ``i``; a sub-environment
whose episode ended starts the next episode not yet used (``B``, ``B + 1``, ... in the order of
the sub-environments that ended). Sub-environment ``i``'s first episode is episode ``i`` of
``odorloc batch -s SCENARIO --seed R``, of :class:`~odorloc.envs.gym_env.SearchEnv` (one agent)
and of :class:`~odorloc.envs.parallel.ParallelSearchEnv` (teams) reset with
``options={"episode": i}``: the sources from the world stream as the engine draws them, each
hit count from the sensor stream as NumPy's Poisson sampler draws it (the multiplication
method, used below a mean of 10 hits; a scenario whose mean could reach 10 is refused), in the
engine's order (agent after agent, every control period).

The UAV's arithmetic is the platform's, operation by operation; vector lengths and dot products
use fused multiply-adds as NumPy's dot product does on machines with FMA (so positions match to
the bit there). The plume's exponentials come from the C library, NumPy's vectorised ones can
differ in the last bit: a hit count differs only when a uniform draw falls within that bit.

Spaces (one agent: the single environment's; a team of ``n``: one row per agent):

- observation: :mod:`odorloc.searchers.policy_io`'s vector (``gas``, ``detection``, ``wind``,
  ``position``, ``heading``, ``time`` and, for teams, the ``neighbours`` block: what each
  agent heard one control period earlier), ``(F,)`` or ``(n, F)`` per sub-environment,
  ``float32``, clipped to the same bounds; names in :attr:`EncounterVectorEnv.feature_names`;
- action: :class:`~odorloc.searchers.policy_io.ActionParams` (``discrete``: an index per agent,
  ``Discrete(K)`` or ``MultiDiscrete([K] * n)``; ``velocity``: ``Box(-1, 1, (A,))`` or
  ``(n, A)``); ``declare: position`` adds the declaring index / component
  (``declare: belief`` needs an estimator and is refused);
- reward: :class:`~odorloc.envs.core.RewardParams` per agent as the single environments credit
  it (``info["agent_rewards"]``, ``(B, n)``); the vector reward is their sum over the team;
- ``terminated``: ``task.end`` (reaching a source, or a declaration); ``truncated``: the time
  limit, an energy limit or ``task.stuck_limit``. Auto-reset ``SAME_STEP`` (the ended
  episode's last observation in ``info["final_obs"]``, ``info["_final_obs"]`` marking which).

With ``threads > 1`` the sub-environments are stepped on numba's threads and restarted in order
afterwards: the same episodes, the same numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit, prange, set_threads
from odorloc.core.pcg import pcg_double, pcg_poisson_mult
from odorloc.envs.core import EnvCore, RewardParams, validated
from odorloc.envs.vector import EpisodeRoots, _renamed, episode_streams
from odorloc.geometry.vectors import wrap_angle
from odorloc.models.vergassola import unit_direction
from odorloc.scenarios import Scenario

__all__ = ["EncounterVectorEnv"]

_EPS = 1e-12  # the UAV's tolerance (odorloc.platforms.uav)

# float state of one agent (one row of ``fs``)
_POS, _VEL, _HEAD, _PATH, _LDIR, _TURN, _HOVER, _SPEED, _VDIR, _TARGET = (
    0, 3, 6, 7, 8, 11, 12, 13, 14, 17
)  # fmt: skip
_E = 20  # energy: fly, hover, turn, idle, compute, comm (J)
_T = 26  # time: fly, hover, turn, idle (s)
_WIND = 30  # the anemometer's reading (m/s)
_NF = 33
# integer state of one agent (one row of ``js``)
_HAS_LDIR, _FLYING, _PENDING, _HAS_VDIR, _EXHAUSTED, _NTURNS, _NHOVERS = 0, 1, 2, 3, 4, 5, 6
_BLOCKED, _COLLIDED, _HITS, _BACK = 7, 8, 9, 10
_NJ = 11
# UAV parameters (``prm``)
(_P_SPEED, _P_HOVER_T, _P_TURN_T, _P_TURN_A, _P_FLY_W, _P_HOVER_W, _P_TURN_J, _P_IDLE_W,
 _P_LIMIT, _P_TX_W, _P_TX_RATE) = range(11)  # fmt: skip
# per-sub-environment status after a step
RUNNING, REACHED, TIME_LIMIT, STUCK, ENERGY, DECLARED = 0, 1, 2, 3, 4, 5


# ---------------------------------------------------------------------- arithmetic
def _fma_py(a: float, b: float, c: float) -> float:  # pragma: no cover - without numba only
    from fractions import Fraction

    return float(Fraction(a) * Fraction(b) + Fraction(c))


if HAVE_NUMBA:
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def _fma(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
        """``a b + c`` rounded once (LLVM's ``fma``)."""
        sig = types.float64(types.float64, types.float64, types.float64)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            dbl = ir.DoubleType()
            fnty = ir.FunctionType(dbl, [dbl, dbl, dbl])
            fn = builder.module.declare_intrinsic("llvm.fma", [dbl], fnty)
            return builder.call(fn, args)

        return sig, codegen
else:  # pragma: no cover
    _fma = _fma_py


def _dot3(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> float:
    """``a . b`` as NumPy's dot product of two 3-vectors computes it where the CPU fuses
    multiply-adds."""
    return _fma(a2, b2, _fma(a1, b1, a0 * b0))


def _poisson(st: np.ndarray, mu: float) -> int:
    """NumPy's Poisson draw for a mean ``mu`` below 10 (0 without a draw at ``mu = 0``; the
    multiplication method otherwise) from the PCG64 stream ``st``."""
    if mu == 0.0:
        return 0
    return pcg_poisson_mult(st, math.exp(-mu))


# ---------------------------------------------------------------------- the UAV
def _energy(f: np.ndarray) -> float:
    """The platform's energy (its components summed in their order), J."""
    return f[_E] + f[_E + 1] + f[_E + 2] + f[_E + 3] + f[_E + 4] + f[_E + 5]


def _exhaust(f: np.ndarray, j: np.ndarray) -> None:
    j[_EXHAUSTED] = 1
    f[_TURN] = 0.0
    j[_FLYING] = 0
    f[_HOVER] = 0.0
    j[_PENDING] = 0
    f[_SPEED] = 0.0


def _charge(
    f: np.ndarray, j: np.ndarray, prm: np.ndarray, key: int, power: float, t: float
) -> float:
    """Charge ``power`` W for ``t`` s to energy ``key`` (0-3: with its time) within the
    budget; the time granted."""
    if t <= 0.0:
        return 0.0
    room = prm[_P_LIMIT] - _energy(f)
    if power > 0.0 and power * t > room:
        t = max(room, 0.0) / power
        _exhaust(f, j)
    f[_E + key] += power * t
    if key < 4:
        f[_T + key] += t
    return t


def _affordable(f: np.ndarray, prm: np.ndarray, power: float, t: float) -> float:
    room = prm[_P_LIMIT] - _energy(f)
    if power > 0.0 and power * t > room:
        return max(room, 0.0) / power
    return t


def _charge_lump(f: np.ndarray, j: np.ndarray, prm: np.ndarray, key: int, joules: float) -> bool:
    room = prm[_P_LIMIT] - _energy(f)
    if joules > room:
        f[_E + key] += max(room, 0.0)
        _exhaust(f, j)
        return False
    f[_E + key] += joules
    return True


def _translate(
    f: np.ndarray, j: np.ndarray, e0: float, e1: float, e2: float, lo: np.ndarray, hi: np.ndarray
) -> None:
    """Move straight towards ``e`` as far as the arena's box allows (a point body)."""
    p0, p1, p2 = f[_POS], f[_POS + 1], f[_POS + 2]
    if e0 == p0 and e1 == p1 and e2 == p2:
        return
    s = 1.0
    for a0, b, lo_, hi_ in ((p0, e0, lo[0], hi[0]), (p1, e1, lo[1], hi[1]), (p2, e2, lo[2], hi[2])):
        d = b - a0
        if d > 0.0 and b > hi_:
            s = min(s, (hi_ - a0) / d)
        elif d < 0.0 and b < lo_:
            s = min(s, (lo_ - a0) / d)
    s = max(s, 0.0)
    if s < 1.0:
        n0 = min(max(p0 + s * (e0 - p0), min(lo[0], p0)), max(hi[0], p0))
        n1 = min(max(p1 + s * (e1 - p1), min(lo[1], p1)), max(hi[1], p1))
        n2 = min(max(p2 + s * (e2 - p2), min(lo[2], p2)), max(hi[2], p2))
        j[_COLLIDED] += 1
        j[_BLOCKED] = 1
    else:
        n0, n1, n2 = e0, e1, e2
    d0, d1, d2 = n0 - p0, n1 - p1, n2 - p2
    f[_PATH] += math.sqrt(_dot3(d0, d1, d2, d0, d1, d2))
    f[_POS], f[_POS + 1], f[_POS + 2] = n0, n1, n2


def _fly(
    f: np.ndarray,
    j: np.ndarray,
    prm: np.ndarray,
    e0: float,
    e1: float,
    e2: float,
    speed: float,
    lo: np.ndarray,
    hi: np.ndarray,
) -> float:
    """Fly towards ``e`` at ``speed`` (charged at the flying power, eq. 4); metres flown."""
    s0, s1, s2 = f[_POS], f[_POS + 1], f[_POS + 2]
    _translate(f, j, e0, e1, e2, lo, hi)
    d0, d1, d2 = f[_POS] - s0, f[_POS + 1] - s1, f[_POS + 2] - s2
    moved = math.sqrt(_dot3(d0, d1, d2, d0, d1, d2))
    _charge(f, j, prm, 0, prm[_P_FLY_W], moved / speed)
    return moved


def _set_direction(
    f: np.ndarray, j: np.ndarray, prm: np.ndarray, u0: float, u1: float, u2: float
) -> None:
    """Adopt the flight direction ``u`` (a turning point when it changes by more than the
    turn angle, eq. 6)."""
    if j[_HAS_LDIR]:
        c = _dot3(f[_LDIR], f[_LDIR + 1], f[_LDIR + 2], u0, u1, u2)
        c = min(max(c, -1.0), 1.0)
        if math.acos(c) > prm[_P_TURN_A]:
            j[_NTURNS] += 1
            f[_TURN] = prm[_P_TURN_T]
            if not _charge_lump(f, j, prm, 2, prm[_P_TURN_J]):
                return
    f[_LDIR], f[_LDIR + 1], f[_LDIR + 2] = u0, u1, u2
    j[_HAS_LDIR] = 1
    if math.hypot(u0, u1) > _EPS:
        f[_HEAD] = math.atan2(u1, u0)


def _uav_apply(
    f: np.ndarray,
    j: np.ndarray,
    prm: np.ndarray,
    kind: int,
    v0: float,
    v1: float,
    v2: float,
    dt: float,
    lo: np.ndarray,
    hi: np.ndarray,
) -> None:
    """One control period of a UAV under a new command: ``kind`` 1 velocity ``v`` (m/s),
    2 move by ``v`` (m), 3 hold (:class:`~odorloc.platforms.uav.UAV`)."""
    s0, s1, s2 = f[_POS], f[_POS + 1], f[_POS + 2]
    if kind == 2:
        f[_TARGET], f[_TARGET + 1], f[_TARGET + 2] = s0 + v0, s1 + v1, s2 + v2
    # the new command starts
    if not j[_EXHAUSTED]:
        j[_FLYING] = 0
        f[_HOVER] = 0.0
        j[_PENDING] = 0
        f[_SPEED] = 0.0
        if kind == 3:
            f[_TURN] = 0.0
        elif kind == 1:
            s = math.sqrt(_dot3(v0, v1, v2, v0, v1, v2))
            if s > _EPS:
                f[_SPEED] = min(s, prm[_P_SPEED])
                f[_VDIR], f[_VDIR + 1], f[_VDIR + 2] = v0 / s, v1 / s, v2 / s
                j[_HAS_VDIR] = 1
                _set_direction(f, j, prm, f[_VDIR], f[_VDIR + 1], f[_VDIR + 2])
            else:
                f[_TURN] = 0.0
        else:
            d0, d1, d2 = f[_TARGET] - s0, f[_TARGET + 1] - s1, f[_TARGET + 2] - s2
            dist = math.sqrt(_dot3(d0, d1, d2, d0, d1, d2))
            if dist > _EPS:
                _set_direction(f, j, prm, d0 / dist, d1 / dist, d2 / dist)
                j[_FLYING] = 0 if j[_EXHAUSTED] else 1
            else:
                f[_TURN] = 0.0
            if not j[_EXHAUSTED]:
                j[_PENDING] = 1
                f[_HOVER] = prm[_P_HOVER_T]
    j[_BLOCKED] = 0
    # the period: turn, fly (velocity or towards the target), hover, idle
    if not j[_EXHAUSTED]:
        budget = dt
        if f[_TURN] > 0.0:
            t = min(budget, f[_TURN])
            f[_TURN] -= t
            if f[_TURN] <= _EPS:
                f[_TURN] = 0.0
            f[_T + 2] += t
            budget -= t
        if budget > _EPS and f[_SPEED] > 0.0 and j[_HAS_VDIR]:
            want = budget
            speed = f[_SPEED]
            t = _affordable(f, prm, prm[_P_FLY_W], want)
            st = speed * t
            p0, p1, p2 = f[_POS], f[_POS + 1], f[_POS + 2]
            e0 = p0 + f[_VDIR] * st
            e1 = p1 + f[_VDIR + 1] * st
            e2 = p2 + f[_VDIR + 2] * st
            moved = _fly(f, j, prm, e0, e1, e2, speed, lo, hi)
            budget -= moved / speed
            if t < want:
                _exhaust(f, j)
        if budget > _EPS and j[_FLYING]:
            speed = prm[_P_SPEED]
            p0, p1, p2 = f[_POS], f[_POS + 1], f[_POS + 2]
            d0, d1, d2 = f[_TARGET] - p0, f[_TARGET + 1] - p1, f[_TARGET + 2] - p2
            dist = math.sqrt(_dot3(d0, d1, d2, d0, d1, d2))
            need = dist / speed
            want = min(budget, need)
            t = _affordable(f, prm, prm[_P_FLY_W], want)
            if t >= need:
                e0, e1, e2 = f[_TARGET], f[_TARGET + 1], f[_TARGET + 2]
            else:
                k = speed * t / dist
                e0, e1, e2 = p0 + d0 * k, p1 + d1 * k, p2 + d2 * k
            moved = _fly(f, j, prm, e0, e1, e2, speed, lo, hi)
            budget -= moved / speed
            if t < want:
                _exhaust(f, j)
            if t >= need or j[_BLOCKED]:
                j[_FLYING] = 0
        if not j[_FLYING] and j[_PENDING] and not j[_EXHAUSTED]:
            j[_NHOVERS] += 1
            j[_PENDING] = 0
        if budget > _EPS and not j[_FLYING] and f[_HOVER] > 0.0:
            t = _charge(f, j, prm, 1, prm[_P_HOVER_W], min(budget, f[_HOVER]))
            f[_HOVER] -= t
            if f[_HOVER] <= _EPS:
                f[_HOVER] = 0.0
            budget -= t
        if budget > _EPS and not j[_EXHAUSTED]:
            _charge(f, j, prm, 3, prm[_P_IDLE_W], budget)
    f[_VEL] = (f[_POS] - s0) / dt
    f[_VEL + 1] = (f[_POS + 1] - s1) / dt
    f[_VEL + 2] = (f[_POS + 2] - s2) / dt


# ---------------------------------------------------------------------- the world
def _rate(x0: float, x1: float, x2: float, src: np.ndarray, aq: np.ndarray, w: np.ndarray) -> float:
    """The plume's encounter rate at ``x`` summed over the sources (1/s; the Vergassola rate of
    :class:`~odorloc.plume.vergassola.VergassolaPlume`, eqs. 1-3). ``w``: the wind direction
    ``e`` (3), ``V / 2 D``, ``1 / lambda``, ``a``."""
    a = w[5]
    a2 = a * a
    xe = x0 * w[0] + x1 * w[1] + x2 * w[2]
    total = 0.0
    for s in range(src.shape[0]):
        d0, d1, d2 = x0 - src[s, 0], x1 - src[s, 1], x2 - src[s, 2]
        r2 = d0 * d0 + d1 * d1 + d2 * d2
        r = math.sqrt(r2 if r2 >= a2 else a2)
        se = src[s, 0] * w[0] + src[s, 1] * w[1] + src[s, 2] * w[2]
        expo = (xe - se) * w[3]
        expo -= r * w[4]
        total += (aq[s] * math.exp(expo)) / r
    return total


def _observe(
    i: int,
    fs: np.ndarray,
    js: np.ndarray,
    src: np.ndarray,
    aq: np.ndarray,
    w: np.ndarray,
    air: np.ndarray,
    gain_dt: np.ndarray,
    sense: np.ndarray,
) -> None:
    """Every agent's hit count (agent after agent from the sensor stream) and wind reading."""
    for k in range(fs.shape[1]):
        f = fs[i, k]
        r = _rate(f[_POS], f[_POS + 1], f[_POS + 2], src[i], aq[i], w)
        js[i, k, _HITS] = _poisson(sense[i], gain_dt[0] * r * gain_dt[1])
        for a in range(3):
            # the anemometer reads the air relative to the platform, then adds the platform back
            f[_WIND + a] = (air[a] - f[_VEL + a]) + f[_VEL + a]


def _first_within(i: int, fs: np.ndarray, src: np.ndarray, radius: float) -> int:
    """The first agent (agent-major, then source) within ``radius`` of a source, or -1."""
    for k in range(fs.shape[1]):
        for s in range(src.shape[1]):
            acc = 0.0
            for a in range(3):
                d = fs[i, k, _POS + a] - src[i, s, a]
                acc += d * d
            if math.sqrt(acc) <= radius:
                return k
    return -1


def _start(
    i: int,
    episode: int,
    words: np.ndarray,
    n_root: int,
    starts: np.ndarray,
    heading: float,
    src0: np.ndarray,
    rate0: np.ndarray,
    draw: np.ndarray,
    a: float,
    src: np.ndarray,
    aq: np.ndarray,
    fs: np.ndarray,
    js: np.ndarray,
    found: np.ndarray,
    flags: np.ndarray,
    sense: np.ndarray,
    epi: np.ndarray,
) -> None:
    """Start ``episode`` in sub-environment ``i``: its streams (the world and sensor streams of
    :func:`~odorloc.core.seeds.episode_generators` of its world seed), its sources, every UAV at
    its start. ``draw``: 0 fixed sources; else the uniform draw's box (6), least start distance,
    least separation, tries, rate law (0 none, 1 uniform, 2 log-uniform) and its bounds."""
    world = np.empty(4, np.uint64)
    episode_streams(words, n_root, episode, world, sense[i])
    n_src = src0.shape[0]
    if draw[0] == 0.0:
        src[i] = src0
        for s in range(n_src):
            aq[i, s] = a * rate0[s]
    elif not _draw_sources(i, world, starts, src0, rate0, draw, a, src, aq):
        episode = -1 - episode  # no place for the sources: refused by the environment
    for k in range(fs.shape[1]):
        f = fs[i, k]
        f[:] = 0.0
        js[i, k, :] = 0
        for c in range(3):
            f[_POS + c] = starts[k, c]
        f[_HEAD] = heading
    found[i] = False
    flags[i, :] = 0
    epi[i] = episode


def _draw_sources(
    i: int,
    world: np.ndarray,
    starts: np.ndarray,
    src0: np.ndarray,
    rate0: np.ndarray,
    draw: np.ndarray,
    a: float,
    src: np.ndarray,
    aq: np.ndarray,
) -> bool:
    """:class:`~odorloc.plume.source_draw.UniformSourceDraw` from the world stream: candidates
    ``lo + u (hi - lo)`` in the box, kept when far enough from every start and source, then the
    rates; ``False`` when the tries ran out."""
    n_src = src0.shape[0]
    got = 0
    tries = int(draw[9])
    c = np.empty(3)
    for _ in range(tries):
        for ax in range(3):
            c[ax] = draw[1 + ax] + pcg_double(world) * (draw[4 + ax] - draw[1 + ax])
        ok = True
        for ax in range(3):
            if not (draw[1 + ax] <= c[ax] <= draw[4 + ax]):
                ok = False
        if ok and starts.shape[0] > 0:
            best = math.inf
            for k in range(starts.shape[0]):
                acc = 0.0
                for ax in range(3):
                    d = starts[k, ax] - c[ax]
                    acc += d * d
                best = min(best, math.sqrt(acc))
            ok = not best < draw[7]
        if ok and got > 0:
            best = math.inf
            for s in range(got):
                acc = 0.0
                for ax in range(3):
                    d = src[i, s, ax] - c[ax]
                    acc += d * d
                best = min(best, math.sqrt(acc))
            ok = not best < draw[8]
        if ok:
            src[i, got] = c
            got += 1
            if got == n_src:
                break
    if got < n_src:
        return False
    law = draw[10]
    for s in range(n_src):
        if law == 0.0:
            q = rate0[s]
        else:
            lo, hi = draw[11], draw[12]
            q = lo + (hi - lo) * pcg_double(world)
            if law == 2.0:
                q = math.exp(q)
        aq[i, s] = a * q
    return True


def _features(
    i: int,
    fs: np.ndarray,
    js: np.ndarray,
    heard: np.ndarray,
    sent: np.ndarray,
    t: float,
    threshold: int,
    cols: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    out: np.ndarray,
) -> None:
    """Every agent's observation row (:mod:`odorloc.searchers.policy_io`'s layout): ``cols``
    gives the column of gas, detection, wind (3), position (3), heading, time (-1: not
    observed) and of the neighbour block (-1: none)."""
    n = fs.shape[1]
    for k in range(n):
        f = fs[i, k]
        row = out[k]
        row[:] = 0.0
        hits = js[i, k, _HITS]
        if cols[0] >= 0:
            row[cols[0]] = np.float32(float(hits))
        if cols[1] >= 0:
            row[cols[1]] = 1.0 if hits >= threshold else 0.0
        for a in range(3):
            if cols[2] >= 0:
                row[cols[2] + a] = np.float32(f[_WIND + a])
            if cols[3] >= 0:
                row[cols[3] + a] = np.float32(f[_POS + a])
        if cols[4] >= 0:
            row[cols[4]] = np.float32(f[_HEAD])
        if cols[5] >= 0:
            row[cols[5]] = np.float32(t)
        if cols[6] >= 0:
            c = cols[6]
            for s in range(n):
                if s == k:
                    continue
                if heard[i, k, s]:
                    row[c] = 1.0
                    for a in range(3):
                        row[c + 1 + a] = np.float32(sent[i, s, a] - f[_POS + a])
                    row[c + 4] = np.float32(sent[i, s, 3])
                    row[c + 5] = np.float32(sent[i, s, 4])
                c += 6
        for c in range(row.shape[0]):
            row[c] = max(min(row[c], high[c]), low[c])


def _step_one(
    i: int,
    disc: np.ndarray,
    vel: np.ndarray,
    kind: int,
    moves: np.ndarray,
    step_len: np.ndarray,
    can_declare: int,
    prm: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    T: float,
    n_steps: int,
    end_rule: int,
    reach_r: float,
    success_r: float,
    stuck: int,
    e_limit: float,
    comm_r: float,
    msg_bytes: int,
    threshold: int,
    src: np.ndarray,
    aq: np.ndarray,
    w: np.ndarray,
    air: np.ndarray,
    gain_dt: np.ndarray,
    rw: np.ndarray,
    fs: np.ndarray,
    js: np.ndarray,
    heard: np.ndarray,
    sent: np.ndarray,
    found: np.ndarray,
    flags: np.ndarray,
    steps: np.ndarray,
    recent: np.ndarray,
    sense: np.ndarray,
    bytes_: np.ndarray,
    reward: np.ndarray,
) -> int:
    """One control period of sub-environment ``i`` (the engine's step, in its order); its
    status (``RUNNING`` ... ``DECLARED``). ``rw``: the rewards step, found, wrong, reach.
    ``flags``: reached, declared, number of recent position sets (the stuck rule)."""
    n = fs.shape[1]
    n_src = src.shape[1]
    for k in range(n):
        reward[i, k] = rw[0]
    # declarations, agent after agent, at the agent's position
    if can_declare:
        for k in range(n):
            dec = disc[i, k] == moves.shape[0] if kind == 0 else vel[i, k, 3] > 0.0
            if not dec:
                continue
            flags[i, 1] = 1
            near = math.inf
            for s in range(n_src):
                acc = 0.0
                for a in range(3):
                    d = fs[i, k, _POS + a] - src[i, s, a]
                    acc += d * d
                dist = math.sqrt(acc)
                near = min(near, dist)
                if dist <= success_r and not found[i, s]:
                    found[i, s] = True
                    reward[i, k] += rw[1]
            if near > success_r:
                reward[i, k] += rw[2]
        if end_rule == 1 and flags[i, 1]:
            return DECLARED
    if steps[i] == n_steps:
        return TIME_LIMIT
    for k in range(n):
        if js[i, k, _EXHAUSTED]:
            return ENERGY
    # every agent broadcasts its position and reading to the agents within the radius; they
    # hear it with their next observation
    if msg_bytes > 0:
        r2 = comm_r * comm_r
        for k in range(n):
            for a in range(3):
                sent[i, k, a] = fs[i, k, _POS + a]
            sent[i, k, 3] = float(js[i, k, _HITS])
            sent[i, k, 4] = 1.0 if js[i, k, _HITS] >= threshold else 0.0
        for k in range(n):
            for m in range(n):
                if m == k:
                    heard[i, k, m] = False
                    continue
                acc = 0.0
                for a in range(3):
                    d = fs[i, k, _POS + a] - fs[i, m, _POS + a]
                    acc += d * d
                heard[i, k, m] = comm_r > 0.0 and acc <= r2
    for k in range(n):
        f = fs[i, k]
        jk = js[i, k]
        if msg_bytes > 0:
            to = 0
            for m in range(n):
                if heard[i, m, k]:
                    to += 1
            nbytes = msg_bytes * to
            bytes_[i] += nbytes
            if nbytes:
                _charge_lump(f, jk, prm, 5, prm[_P_TX_W] * 8.0 * nbytes / prm[_P_TX_RATE])
        if kind == 0:
            a = disc[i, k]
            if a == moves.shape[0]:
                _uav_apply(f, jk, prm, 3, 0.0, 0.0, 0.0, T, lo, hi)
            else:
                m0, m1, m2 = moves[a, 0], moves[a, 1], moves[a, 2]
                if m0 == 0.0 and m1 == 0.0 and m2 == 0.0:
                    _uav_apply(f, jk, prm, 3, 0.0, 0.0, 0.0, T, lo, hi)
                else:
                    sl = step_len[k]
                    _uav_apply(f, jk, prm, 2, m0 * sl, m1 * sl, m2 * sl, T, lo, hi)
        else:
            vm = prm[_P_SPEED]
            v0 = min(max(vel[i, k, 0], -1.0), 1.0) * vm
            v1 = min(max(vel[i, k, 1], -1.0), 1.0) * vm
            v2 = min(max(vel[i, k, 2], -1.0), 1.0) * vm
            _uav_apply(f, jk, prm, 1, v0, v1, v2, T, lo, hi)
    total = 0.0
    for k in range(n):
        total += _energy(fs[i, k])
    if total > e_limit:
        return ENERGY
    steps[i] += 1
    _observe(i, fs, js, src, aq, w, air, gain_dt, sense)
    if reach_r >= 0.0 and not flags[i, 0]:
        k = _first_within(i, fs, src, reach_r)
        if k >= 0:
            flags[i, 0] = 1
            reward[i, k] += rw[3]
            if end_rule == 2:
                return REACHED
    if stuck >= 0:
        if flags[i, 2] == 2:
            for k in range(n):
                back = True
                for a in range(3):
                    if abs(fs[i, k, _POS + a] - recent[i, 0, k, a]) > 1e-9:
                        back = False
                js[i, k, _BACK] = js[i, k, _BACK] + 1 if back else 0
        recent[i, 0] = recent[i, 1]
        for k in range(n):
            for a in range(3):
                recent[i, 1, k, a] = fs[i, k, _POS + a]
        flags[i, 2] = min(flags[i, 2] + 1, 2)
        every = True
        for k in range(n):
            if js[i, k, _BACK] <= stuck:
                every = False
        if every and steps[i] < n_steps:
            return STUCK
    return RUNNING


def _restart(
    i: int,
    episode: int,
    words: np.ndarray,
    n_root: int,
    starts: np.ndarray,
    heading: float,
    src0: np.ndarray,
    rate0: np.ndarray,
    draw: np.ndarray,
    w: np.ndarray,
    air: np.ndarray,
    gain_dt: np.ndarray,
    threshold: int,
    cols: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    src: np.ndarray,
    aq: np.ndarray,
    fs: np.ndarray,
    js: np.ndarray,
    heard: np.ndarray,
    sent: np.ndarray,
    found: np.ndarray,
    flags: np.ndarray,
    steps: np.ndarray,
    recent: np.ndarray,
    sense: np.ndarray,
    bytes_: np.ndarray,
    epi: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Start ``episode`` in sub-environment ``i`` and write its first observation."""
    _start(
        i, episode, words, n_root, starts, heading, src0, rate0, draw, w[5], src, aq, fs, js,
        found, flags, sense, epi,
    )  # fmt: skip
    heard[i] = False
    steps[i] = 0
    bytes_[i] = 0
    _observe(i, fs, js, src, aq, w, air, gain_dt, sense)
    for k in range(fs.shape[1]):
        for a in range(3):
            recent[i, 1, k, a] = fs[i, k, _POS + a]
    flags[i, 2] = 1
    _features(i, fs, js, heard, sent, 0.0, threshold, cols, low, high, obs[i])


def _batch_step(
    disc: np.ndarray,
    vel: np.ndarray,
    nxt: int,
    kind: int,
    moves: np.ndarray,
    step_len: np.ndarray,
    can_declare: int,
    prm: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    T: float,
    n_steps: int,
    end_rule: int,
    reach_r: float,
    success_r: float,
    stuck: int,
    e_limit: float,
    comm_r: float,
    msg_bytes: int,
    rw: np.ndarray,
    words: np.ndarray,
    n_root: int,
    starts: np.ndarray,
    heading: float,
    src0: np.ndarray,
    rate0: np.ndarray,
    draw: np.ndarray,
    w: np.ndarray,
    air: np.ndarray,
    gain_dt: np.ndarray,
    threshold: int,
    cols: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    src: np.ndarray,
    aq: np.ndarray,
    fs: np.ndarray,
    js: np.ndarray,
    heard: np.ndarray,
    sent: np.ndarray,
    found: np.ndarray,
    flags: np.ndarray,
    steps: np.ndarray,
    recent: np.ndarray,
    sense: np.ndarray,
    bytes_: np.ndarray,
    epi: np.ndarray,
    status: np.ndarray,
    reward: np.ndarray,
    obs: np.ndarray,
    final: np.ndarray,
    final_epi: np.ndarray,
) -> int:
    """One step of every sub-environment; ended ones start episodes ``nxt, nxt + 1, ...`` in
    order. Returns the next unused episode."""
    nb = fs.shape[0]
    for i in prange(nb):
        status[i] = _step_one(
            i, disc, vel, kind, moves, step_len, can_declare, prm, lo, hi, T, n_steps, end_rule,
            reach_r, success_r, stuck, e_limit, comm_r, msg_bytes, threshold, src, aq, w, air,
            gain_dt, rw, fs, js, heard, sent, found, flags, steps, recent, sense, bytes_, reward,
        )  # fmt: skip
        final_epi[i] = epi[i]
        if status[i] == RUNNING:
            _features(i, fs, js, heard, sent, steps[i] * T, threshold, cols, low, high, obs[i])
    for i in range(nb):
        if status[i] != RUNNING:
            if status[i] == REACHED or status[i] == STUCK:
                _features(
                    i, fs, js, heard, sent, steps[i] * T, threshold, cols, low, high, final[i]
                )  # fmt: skip
            else:
                # ended before observing anew: the last observation is the one returned before
                final[i] = obs[i]
            _restart(
                i, nxt, words, n_root, starts, heading, src0, rate0, draw, w, air, gain_dt,
                threshold, cols, low, high, src, aq, fs, js, heard, sent, found, flags, steps,
                recent, sense, bytes_, epi, obs,
            )  # fmt: skip
            nxt += 1
    return nxt


_dot3 = jit(_dot3)
_poisson = jit(_poisson)
_energy = jit(_energy)
_exhaust = jit(_exhaust)
_charge = jit(_charge)
_affordable = jit(_affordable)
_charge_lump = jit(_charge_lump)
_translate = jit(_translate)
_fly = jit(_fly)
_set_direction = jit(_set_direction)
_uav_apply = jit(_uav_apply)
_rate = jit(_rate)
_observe = jit(_observe)
_first_within = jit(_first_within)
_draw_sources = jit(_draw_sources)
_start = jit(_start)
_features = jit(_features)
_step_one = jit(_step_one)
_restart = jit(_restart)
_batch_step_threads = jit(_renamed(_batch_step, "_batch_step_threads"), parallel=True)
_batch_step = jit(_batch_step)


# ---------------------------------------------------------------------- the environment
_END_RULES = {"limits": 0, "first_declaration": 1, "all_groups": 1, "reach": 2}
_STATUS = ("running", "reached", "time_limit", "stuck", "energy", "declared")


def _refuse(field: str, problem: str) -> ConfigError:
    return ConfigError(field, f"{problem} (the batched encounter-rate environment)")


class _World:
    """What an encounter-rate scenario fixes for every episode, checked once from its built
    parts (:class:`~odorloc.envs.core.EnvCore`'s)."""

    def __init__(self, core: EnvCore) -> None:
        from odorloc.platforms.uav import UAV
        from odorloc.plume.source_draw import UniformSourceDraw
        from odorloc.plume.vergassola import VergassolaPlume
        from odorloc.sensors.anemometer import Anemometer
        from odorloc.sensors.encounter import EncounterSensor
        from odorloc.wind.uniform import UniformWind

        sc = core.scenario
        ep = core.episode
        b = ep.built
        world = b.world
        self.n = core.n_agents
        plume = world.plume
        if not isinstance(plume, VergassolaPlume):
            raise _refuse("world.plume", f"must be 'vergassola', got {sc.world.plume.type!r}")
        if world.arena.dim != 3:
            raise _refuse("world.arena", "must be 3-D")
        if world.arena.occ is not None:
            raise _refuse("world.arena.obstacles", "must be empty")
        if not isinstance(world.wind, UniformWind):
            raise _refuse("world.wind", f"must be 'uniform', got {sc.world.wind.type!r}")
        if any(s.modulation.kind != "constant" for s in sc.world.sources):
            raise _refuse("world.sources", "releases must be constant")
        self.draw = np.zeros(13)
        draw_ref = sc.world.source_draw
        rate_hi = [float(s.rate) for s in sc.world.sources]
        if draw_ref is not None:
            drawer = draw_ref.build("source_draw", field="world.source_draw")
            if not isinstance(drawer, UniformSourceDraw):
                raise _refuse("world.source_draw", "must be 'uniform' or none")
            p = drawer.params
            lo, hi = world.arena.lo.copy(), world.arena.hi.copy()
            if p.region is not None:
                rlo, rhi = np.asarray(p.region[0], float), np.asarray(p.region[1], float)
                lo[: len(rlo)], hi[: len(rhi)] = rlo, rhi
            self.draw[0] = 1.0
            self.draw[1:4], self.draw[4:7] = lo, hi
            self.draw[7:10] = p.min_start_distance, p.min_separation, p.max_tries
            if p.rates is not None:
                self.draw[10] = 1.0 if p.rate_law == "uniform" else 2.0
                bounds = np.asarray(p.rates, float)
                # NumPy's logarithms of the bounds, as the draw takes them
                self.draw[11:13] = bounds if p.rate_law == "uniform" else np.log(bounds)
                rate_hi = [float(p.rates[1])] * len(rate_hi)
            reach = sc.task.reach_radius
            if reach is not None and not p.min_start_distance > reach:
                raise _refuse(
                    "world.source_draw.min_start_distance",
                    f"must exceed task.reach_radius ({reach} m): an episode could be over at reset",
                )
        self.src0 = np.asarray(plume.source_positions, float).reshape(-1, 3).copy()
        self.rate0 = np.asarray(plume.source_rates(), float).copy()
        starts = np.asarray(sc.agents.starts, float)
        self.starts = np.ascontiguousarray(starts)
        if draw_ref is None and sc.task.reach_radius is not None:
            d = np.linalg.norm(starts[:, None, :] - self.src0[None], axis=2)
            if np.any(d <= sc.task.reach_radius):
                raise _refuse("task.reach_radius", "an agent starts within it of a source")
        gas = b.gas_sensors
        if not all(isinstance(g, EncounterSensor) for g in gas):
            raise _refuse("sensors.gas", "must be 'encounter'")
        gains = {float(g.params.gain) for g in gas}
        thresholds = {int(g.params.threshold) for g in gas}
        if len(gains) != 1 or len(thresholds) != 1:
            raise _refuse("sensors.gas", "every agent's counter must be alike")
        if not all(isinstance(a, Anemometer) and a.params.noise_std == 0 for a in b.anemometers):
            raise _refuse("sensors.anemometer.noise_std", "must be 0 (a noiseless anemometer)")
        pls = b.platforms
        if not all(type(p) is UAV for p in pls):
            raise _refuse("platform", f"must be 'uav', got {sc.platform.type!r}")
        if len({p.params for p in pls}) != 1:
            raise _refuse("platform", "every agent's UAV must be alike")
        up = pls[0].params
        if up.radius != 0:
            raise _refuse("platform.radius", "must be 0 (point bodies)")
        self.prm = np.array(
            [
                up.speed, up.hover_time, up.turn_time, up.turn_angle, up.fly_power,
                up.hover_power, up.turn_energy, up.idle_power, up.energy_limit,
                up.transmit_power, up.transmit_rate,
            ],
            float,
        )  # fmt: skip
        if sc.task.end == "all_groups" and sc.agents.groups:
            raise _refuse("task.end", "'all_groups' with groups is not supported")
        self.end_rule = _END_RULES[sc.task.end]
        self.T = float(sc.limits.control_dt)
        self.n_steps = int(ep.n_steps)
        self.gain_dt = np.array([gains.pop(), self.T])
        self.threshold = thresholds.pop()
        # the most hits a period can hold: the rate is at most a Q / max(r, a) <= Q per source
        most = self.gain_dt[0] * sum(rate_hi) * self.T
        if not most < 10.0:
            raise _refuse(
                "sensors.gas.gain",
                f"a period's mean hit count can reach {most:g}: the Poisson draws follow NumPy "
                "below a mean of 10 only",
            )
        pp = plume.params
        e = unit_direction(plume.direction, 3)
        self.w = np.array(
            [e[0], e[1], e[2], plume.V / (2.0 * pp.D), 1.0 / plume.length, pp.sensor_radius]
        )
        self.air = np.asarray(world.wind.mean_velocity(), float).copy()
        self.heading = wrap_angle(float(sc.agents.heading))
        self.lo = world.arena.lo.astype(float).copy()
        self.hi = world.arena.hi.astype(float).copy()
        self.reach = -1.0 if sc.task.reach_radius is None else float(sc.task.reach_radius)
        self.success = float(sc.task.success_radius)
        self.stuck = -1 if sc.task.stuck_limit is None else int(sc.task.stuck_limit)
        self.e_limit = float(sc.limits.energy)
        self.comm = float(sc.agents.comm_radius)


class EncounterVectorEnv(EpisodeRoots, VectorEnv):
    """``num_envs`` episodes of a 3-D encounter-rate scenario stepped as arrays (module
    docstring).

    Parameters
    ----------
    scenario : str, path or Scenario
        An encounter-rate UAV scenario, one agent or a team (default ``muc-osl-3d``).
    num_envs : int
        ``B``, at least 1.
    observation, action, reward : dict, optional
        As for :class:`~odorloc.envs.gym_env.SearchEnv` (no ``observation.belief``). The
        default action is ``{"kind": "discrete", "declare": "none"}`` (the six axis moves and
        staying).
    world_key : str, optional
        World key of the seed derivation (default: the scenario's own name).
    threads : int, optional
        Threads that step the sub-environments (default 1; ``None``: every thread numba was
        given). Episodes and numbers do not depend on it.
    """

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        scenario: str | Path | Scenario = "muc-osl-3d",
        num_envs: int = 64,
        observation: dict[str, Any] | None = None,
        action: dict[str, Any] | None = None,
        reward: dict[str, Any] | None = None,
        world_key: str | None = None,
        threads: int | None = 1,
    ) -> None:
        self.threads = self._checked_sizes(num_envs, threads)
        if action is None:
            action = {"kind": "discrete", "declare": "none"}
        if isinstance(observation, dict) and observation.get("belief") is not None:
            raise _refuse("observation.belief", "is not supported")
        core = EnvCore(scenario, observation, action, reward, world_key=world_key, trails=False)
        if core.act_params.declare == "belief":
            raise _refuse("action.declare", "'belief' is not supported")
        self.scenario = core.scenario
        self.world_key = core.world_key
        self.reward_params: RewardParams = validated(RewardParams, reward, "reward")
        wd = _World(core)
        self.world = wd
        io = core.io
        self.n_agents = n = wd.n
        self.num_envs = nb = num_envs
        self.feature_names: list[str] = list(io.feature_names)
        low, high = io.observation_bounds()
        self._low, self._high = low, high
        cols = np.full(7, -1, np.int64)
        first = ("gas", "detection", "wind_x", "position_x", "heading", "time", "nb0_heard")
        for c, name in enumerate(first):
            if name in self.feature_names:
                cols[c] = self.feature_names.index(name)
        self._cols = cols
        self._kind = 0 if core.act_params.kind == "discrete" else 1
        self._moves = np.ascontiguousarray(io.moves if self._kind == 0 else np.zeros((0, 3)))
        self._can_declare = int(io.can_declare)
        self._n_actions = io.n_discrete if self._kind == 0 else io.action_size
        step = core.act_params.step
        self._step_len = np.array(
            [float(step) if step is not None else float(v) * io.ctx.dt for v in io.ctx.speed_limits]
        )
        self._msg_bytes = 8 * (3 + 2) if io.others > 0 else 0
        f = io.size
        one_obs = spaces.Box(low, high, (f,), np.float32)
        if n == 1:
            self.single_observation_space = one_obs
            self.single_action_space = (
                spaces.Discrete(self._n_actions)
                if self._kind == 0
                else spaces.Box(-1.0, 1.0, (self._n_actions,), np.float32)
            )
        else:
            self.single_observation_space = spaces.Box(
                np.tile(low, (n, 1)), np.tile(high, (n, 1)), (n, f), np.float32
            )
            self.single_action_space = (
                spaces.MultiDiscrete(np.full(n, self._n_actions))
                if self._kind == 0
                else spaces.Box(-1.0, 1.0, (n, self._n_actions), np.float32)
            )
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, nb)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, nb)
        s = len(wd.src0)
        self._src = np.zeros((nb, s, 3))
        self._aq = np.zeros((nb, s))
        self._fs = np.zeros((nb, n, _NF))
        self._js = np.zeros((nb, n, _NJ), np.int64)
        self._heard = np.zeros((nb, n, n), bool)
        self._sent = np.zeros((nb, n, 5))
        self._found = np.zeros((nb, s), bool)
        self._flags = np.zeros((nb, 3), np.int64)
        self._steps = np.zeros(nb, np.int64)
        self._recent = np.zeros((nb, 2, n, 3))
        self._sense = np.zeros((nb, 4), np.uint64)
        self._bytes = np.zeros(nb, np.int64)
        self._episode = np.full(nb, -1, np.int64)
        self._status = np.zeros(nb, np.int64)
        self._reward = np.zeros((nb, n))
        self._obs = np.zeros((nb, n, f), np.float32)
        self._final = np.zeros((nb, n, f), np.float32)
        self._final_episode = np.full(nb, -1, np.int64)
        self._disc0 = np.zeros((nb, n), np.int64)
        self._vel0 = np.zeros((nb, n, max(self._n_actions, 1)))
        rp = self.reward_params
        self._rw = np.array([rp.step, rp.found, rp.wrong, rp.reach], float)
        self._words = np.zeros(13, np.uint64)
        self._n_root = 0
        self.root: int | None = None
        self._next = 0

    # ------------------------------------------------------------------ state
    @property
    def episodes(self) -> np.ndarray:
        """The episode index each sub-environment is playing, ``(B,)``."""
        return self._episode.copy()

    @property
    def positions(self) -> np.ndarray:
        """Every agent's position, ``(B, n, 3)`` metres."""
        return self._fs[:, :, _POS : _POS + 3].copy()

    @property
    def sources(self) -> np.ndarray:
        """Every sub-environment's source positions, ``(B, S, 3)`` metres."""
        return self._src.copy()

    @property
    def energy(self) -> np.ndarray:
        """Energy each UAV has used in its episode, ``(B, n)`` J (eq. 9 of the multi-UAV paper:
        movement, computation, radio)."""
        return self._fs[:, :, _E : _E + 6].sum(axis=2)

    @property
    def steps(self) -> np.ndarray:
        """Control periods played in each sub-environment's episode, ``(B,)``."""
        return self._steps.copy()

    def _common(self) -> tuple[Any, ...]:
        wd = self.world
        return (
            self._words, self._n_root, wd.starts, wd.heading, wd.src0, wd.rate0, wd.draw, wd.w,
            wd.air, wd.gain_dt, wd.threshold, self._cols, self._low, self._high,
        )  # fmt: skip

    def _state(self) -> tuple[np.ndarray, ...]:
        return (
            self._src, self._aq, self._fs, self._js, self._heard, self._sent, self._found,
            self._flags, self._steps, self._recent, self._sense, self._bytes, self._episode,
        )  # fmt: skip

    def _check_draws(self) -> None:
        bad = self._episode < 0
        if bad.any():
            ep = -1 - int(self._episode[bad][0])
            raise ConfigError(
                "world.source_draw",
                f"found no place for the sources of episode {ep} in "
                f"{int(self.world.draw[9])} tries",
            )

    def _view(self, a: np.ndarray) -> np.ndarray:
        return a[:, 0] if self.n_agents == 1 else a

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start episodes ``0 .. B-1`` of root ``seed`` (of a new root drawn from the
        environment's own generator when no seed was ever given)."""
        self._set_root(seed)
        for i in range(self.num_envs):
            _restart(i, i, *self._common(), *self._state(), self._obs)
        self._check_draws()
        self._next = self.num_envs
        return self._view(self._obs).copy(), {"episode": self._episode.copy()}

    def _actions(self, actions: Any) -> tuple[np.ndarray, np.ndarray]:
        """The kernels' action arrays; :class:`ValueError` naming what is wrong."""
        nb, n = self.num_envs, self.n_agents
        a = np.asarray(actions)
        if self._kind == 0:
            want = (nb,) if n == 1 else (nb, n)
            if a.shape != want or a.dtype.kind not in "iu":
                raise ValueError(f"actions must be integers of shape {want}, got {a!r}")
            if a.size and (a.min() < 0 or a.max() >= self._n_actions):
                raise ValueError(f"actions must lie in [0, {self._n_actions})")
            return np.ascontiguousarray(a.reshape(nb, n), np.int64), self._vel0
        want = (nb, self._n_actions) if n == 1 else (nb, n, self._n_actions)
        if a.shape != want or a.dtype.kind not in "fiu":
            raise ValueError(f"actions must be numbers of shape {want}, got {a!r}")
        a = np.ascontiguousarray(a.reshape(nb, n, self._n_actions), float)
        if not np.isfinite(a).all():
            raise ValueError("actions must be finite")
        return self._disc0, a

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-environment; ended episodes restart at once (``SAME_STEP``)."""
        if self.root is None:
            raise RuntimeError("call reset() before step()")
        disc, vel = self._actions(actions)
        wd = self.world
        kernel = _batch_step
        if self.threads > 1:
            kernel = _batch_step_threads
            set_threads(self.threads)
        nxt = kernel(
            disc, vel, self._next, self._kind, self._moves, self._step_len, self._can_declare,
            wd.prm, wd.lo, wd.hi, wd.T, wd.n_steps, wd.end_rule, wd.reach, wd.success, wd.stuck,
            wd.e_limit, wd.comm, self._msg_bytes, self._rw, *self._common(), *self._state(),
            self._status, self._reward, self._obs, self._final, self._final_episode,
        )  # fmt: skip
        info: dict[str, Any] = {"agent_rewards": self._view(self._reward).copy()}
        status = self._status
        term = (status == REACHED) | (status == DECLARED)
        trunc = (status != RUNNING) & ~term
        if nxt > self._next:  # some episodes ended (and the next ones started)
            self._check_draws()
            ended = term | trunc
            final = np.zeros_like(self._obs)
            final[ended] = self._final[ended]
            info["final_obs"] = self._view(final)
            info["_final_obs"] = ended
            info["final_episode"] = self._final_episode.copy()
            info["final_status"] = np.array([_STATUS[s] for s in status], dtype=object)
        self._next = nxt
        return (
            self._view(self._obs).copy(),
            self._reward.sum(axis=1),
            term,
            trunc,
            info,
        )
