"""The one seed derivation of odorloc.

An experiment has a *root seed*. Episode ``i`` of a *world key* (a scenario and its overrides, as
named in a sweep) gets two integer seeds from it, :func:`episode_seeds`: the ``world_seed`` drives
the wind, the plume and the sensor noise, the ``agent_seed`` drives the searcher. Neither depends
on the searcher, so episode ``i`` of every searcher faces the same world (common random numbers),
and ``odorloc run SCENARIO --seed ROOT --episode I`` replays episode ``I`` of a batch exactly.

:func:`episode_generators` turns the two seeds into the independent generators an episode uses.
"""

from __future__ import annotations

import hashlib

import numpy as np

from odorloc.core.errors import ConfigError

__all__ = [
    "MAX_SEED",
    "check_seed",
    "episode_generators",
    "episode_seeds",
    "stream_words",
    "world_generators",
]

MAX_SEED = 2**63
"""Seeds are integers in ``[0, MAX_SEED)``."""


def check_seed(seed: object, field: str = "seed") -> int:
    """``seed`` as an int; :class:`ConfigError` naming ``field`` unless it is in ``[0, 2**63)``."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise ConfigError(field, f"must be an integer, got {seed!r}")
    s = int(seed)
    if not 0 <= s < MAX_SEED:
        raise ConfigError(field, f"must lie in [0, 2**63), got {s}")
    return s


def _key_words(key: str) -> tuple[int, ...]:
    """A string as eight 32-bit words (a SeedSequence spawn key must be integers)."""
    digest = hashlib.sha256(key.encode()).digest()
    return tuple(int.from_bytes(digest[i : i + 4], "little") for i in range(0, 32, 4))


def stream_words(root: int, world_key: str, stream: int) -> tuple[list[int], int]:
    """The 32-bit words :func:`episode_seeds` feeds ``SeedSequence`` for ``stream`` (0 world,
    1 agent), the episode index left out, and how many of them are the root's.

    For a caller that derives many episodes' seeds in compiled code
    (:mod:`odorloc.core.pcg`): the root's little-endian words, then the spawn key
    ``(stream, *words(world_key))``; the episode index's words come last.
    """
    check_seed(root, "seed")
    r = int(root)
    run = [r & 0xFFFFFFFF] + ([r >> 32] if r >> 32 else [])
    return [*run, int(stream), *_key_words(world_key)], len(run)


def episode_seeds(root: int, world_key: str, episode: int) -> tuple[int, int]:
    """``(world_seed, agent_seed)`` of episode ``episode`` of ``world_key`` under ``root``.

    Both come from ``SeedSequence(root, spawn_key=(stream, *words(world_key), episode))`` and are
    non-negative ints below ``2**63``.

    Parameters
    ----------
    root : int
        Root seed of the experiment, in ``[0, 2**63)``.
    world_key : str
        The scenario part of a sweep cell (its label and swept overrides, e.g.
        ``"indoor-ventilated[start_index=2]"``); for a single run, the scenario name.
    episode : int
        Episode index, >= 0.
    """
    check_seed(root, "seed")
    if episode < 0:
        raise ConfigError("episode", f"must be >= 0, got {episode}")
    words = _key_words(world_key)
    out = []
    for stream in (0, 1):
        ss = np.random.SeedSequence(int(root), spawn_key=(stream, *words, int(episode)))
        hi, lo = (int(x) for x in ss.generate_state(2, np.uint32))
        out.append(((hi << 32) | lo) >> 1)
    return out[0], out[1]


def episode_generators(
    world_seed: int, agent_seed: int
) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """Independent generators ``(world, sensors, searcher)`` from the two episode seeds.

    The world and sensor streams both derive from ``world_seed`` (so a recorded flow and its
    sensor noise are fixed by the world seed alone); the searcher's from ``agent_seed``.
    """
    world, sensors = world_generators(world_seed)
    a_ss = np.random.SeedSequence(int(agent_seed))
    return world, sensors, np.random.Generator(np.random.PCG64(a_ss))


def world_generators(world_seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """The ``(world, sensors)`` generators of :func:`episode_generators` alone (for a caller
    that starts many episodes and drives no searcher)."""
    w_ss, s_ss = np.random.SeedSequence(int(world_seed)).spawn(2)
    return np.random.Generator(np.random.PCG64(w_ss)), np.random.Generator(np.random.PCG64(s_ss))
