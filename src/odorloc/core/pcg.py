"""NumPy's seed derivation and PCG64 stream as compiled kernels, bit for bit.

A batched environment starts thousands of episodes per second, each from the generators the
engine gives it (:func:`~odorloc.core.seeds.episode_seeds`,
:func:`~odorloc.core.seeds.world_generators`). Building a ``SeedSequence`` and a
``Generator`` per episode costs about a tenth of a millisecond in Python, as much as the
episode's own steps. These kernels compute the same numbers inside compiled loops:

- :func:`seed_words` / :func:`ss_state`: ``numpy.random.SeedSequence`` (pool of four 32-bit
  words; its ``hashmix`` / ``mix`` hashing, ``generate_state``) over an entropy given as 32-bit
  words (an integer as its little-endian words, a spawn key appended after the entropy padded to
  the pool size, as NumPy assembles it);
- :func:`pcg_seed`: ``numpy.random.PCG64`` seeded from four 64-bit state words (128-bit LCG,
  multiplier ``0x2360ED051FC65DA44385DF649FCCF645``, output XSL-RR);
- :func:`pcg_double`: ``Generator.random()`` (53 high bits of the next output over ``2**53``).

A PCG64 state is a ``(4,)`` uint64 array ``(state_high, state_low, inc_high, inc_low)``.
Every kernel is tested equal to NumPy's own classes (``tests/core/test_pcg.py``).
"""

from __future__ import annotations

import numpy as np

from odorloc.core.jit import jit

__all__ = ["int_words", "pcg_double", "pcg_poisson_mult", "pcg_seed", "seed_words", "ss_state"]

_M32 = np.uint64(0xFFFFFFFF)
_INIT_A = np.uint64(0x43B0D7E5)
_MULT_A = np.uint64(0x931E8875)
_INIT_B = np.uint64(0x8B51F9DD)
_MULT_B = np.uint64(0x58F38DED)
_MIX_L = np.uint64(0xCA01F9DD)
_MIX_R = np.uint64(0x4973F715)
_S16 = np.uint64(16)
_S32 = np.uint64(32)
_MUL_HI = np.uint64(0x2360ED051FC65DA4)
_MUL_LO = np.uint64(0x4385DF649FCCF645)
_POOL = 4


def int_words(n: int) -> list[int]:
    """A non-negative integer as NumPy's SeedSequence reads it: little-endian 32-bit words
    (``[0]`` for 0)."""
    if n < 0:
        raise ValueError("entropy must be non-negative")
    out = [n & 0xFFFFFFFF]
    n >>= 32
    while n:
        out.append(n & 0xFFFFFFFF)
        n >>= 32
    return out


# ---------------------------------------------------------------------- SeedSequence
def _hashmix(value: np.uint64, hc: np.ndarray) -> np.uint64:
    value = (value ^ hc[0]) & _M32
    hc[0] = (hc[0] * _MULT_A) & _M32
    value = (value * hc[0]) & _M32
    return value ^ (value >> _S16)


def _mix(x: np.uint64, y: np.uint64) -> np.uint64:
    r = (_MIX_L * x - _MIX_R * y) & _M32
    return r ^ (r >> _S16)


def ss_state(words: np.ndarray, n_run: int, n_out: int, out: np.ndarray) -> None:
    """``SeedSequence(...).generate_state(n_out, uint32)`` into ``out[:n_out]`` (uint64 holding
    32-bit words).

    ``words`` ``(n,)`` uint64: the entropy's ``n_run`` words, then the spawn key's words. With a
    spawn key, the entropy is padded with zeros to the pool size first (as NumPy does).
    """
    n_key = words.shape[0] - n_run
    n_ent = n_run
    if n_key > 0 and n_run < _POOL:
        n_ent = _POOL
    total = n_ent + n_key
    ent = np.zeros(total, np.uint64)
    for i in range(n_run):
        ent[i] = words[i]
    for i in range(n_key):
        ent[n_ent + i] = words[n_run + i]
    hc = np.empty(1, np.uint64)
    hc[0] = _INIT_A
    pool = np.empty(_POOL, np.uint64)
    for i in range(_POOL):
        pool[i] = _hashmix(ent[i] if i < total else np.uint64(0), hc)
    for s in range(_POOL):
        for d in range(_POOL):
            if s != d:
                pool[d] = _mix(pool[d], _hashmix(pool[s], hc))
    for s in range(_POOL, total):
        for d in range(_POOL):
            pool[d] = _mix(pool[d], _hashmix(ent[s], hc))
    h = _INIT_B
    for i in range(n_out):
        v = pool[i % _POOL] ^ h
        h = (h * _MULT_B) & _M32
        v = (v * h) & _M32
        out[i] = v ^ (v >> _S16)


def seed_words(words: np.ndarray, n_run: int) -> np.uint64:
    """The 63-bit seed :func:`~odorloc.core.seeds.episode_seeds` derives: the first two words
    of the state, high word first, shifted right by one."""
    st = np.empty(2, np.uint64)
    ss_state(words, n_run, 2, st)
    return ((st[0] << _S32) | st[1]) >> np.uint64(1)


# ---------------------------------------------------------------------- PCG64
def _mulhi(a: np.uint64, b: np.uint64) -> np.uint64:
    a0 = a & _M32
    a1 = a >> _S32
    b0 = b & _M32
    b1 = b >> _S32
    p0 = a0 * b0
    p1 = a0 * b1
    p2 = a1 * b0
    mid = (p0 >> _S32) + (p1 & _M32) + (p2 & _M32)
    return a1 * b1 + (p1 >> _S32) + (p2 >> _S32) + (mid >> _S32)


def _pcg_step(st: np.ndarray) -> None:
    sh = st[0]
    sl = st[1]
    lo = sl * _MUL_LO
    hi = _mulhi(sl, _MUL_LO) + sh * _MUL_LO + sl * _MUL_HI
    lo2 = lo + st[3]
    carry = np.uint64(1) if lo2 < lo else np.uint64(0)
    st[0] = hi + st[2] + carry
    st[1] = lo2


def pcg_seed(words: np.ndarray, n_run: int, st: np.ndarray) -> None:
    """``PCG64(SeedSequence(...))``'s state into ``st`` ``(4,)`` uint64 (``words`` and
    ``n_run`` as in :func:`ss_state`)."""
    w = np.empty(8, np.uint64)
    ss_state(words, n_run, 8, w)
    seed_hi = w[0] | (w[1] << _S32)
    seed_lo = w[2] | (w[3] << _S32)
    inc_hi = w[4] | (w[5] << _S32)
    inc_lo = w[6] | (w[7] << _S32)
    st[0] = np.uint64(0)
    st[1] = np.uint64(0)
    st[2] = (inc_hi << np.uint64(1)) | (inc_lo >> np.uint64(63))
    st[3] = (inc_lo << np.uint64(1)) | np.uint64(1)
    _pcg_step(st)
    lo = st[1] + seed_lo
    carry = np.uint64(1) if lo < st[1] else np.uint64(0)
    st[0] = st[0] + seed_hi + carry
    st[1] = lo
    _pcg_step(st)


def pcg_double(st: np.ndarray) -> float:
    """The next ``Generator.random()`` of the stream ``st`` (advanced in place)."""
    _pcg_step(st)
    hi = st[0]
    x = hi ^ st[1]
    rot = hi >> np.uint64(58)
    out = (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63)))
    return float(out >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def pcg_poisson_mult(st: np.ndarray, enlam: float) -> int:
    """NumPy's Poisson draw by multiplication (``Generator.poisson`` below a mean of 10;
    ``enlam = exp(-mean)``) from the stream ``st`` (advanced in place)."""
    x = 0
    prod = 1.0
    while True:
        prod *= pcg_double(st)
        if prod > enlam:
            x += 1
        else:
            return x


_hashmix = jit(_hashmix)
_mix = jit(_mix)
ss_state = jit(ss_state)
seed_words = jit(seed_words)
_mulhi = jit(_mulhi)
_pcg_step = jit(_pcg_step)
pcg_seed = jit(pcg_seed)
pcg_double = jit(pcg_double)
pcg_poisson_mult = jit(pcg_poisson_mult)
