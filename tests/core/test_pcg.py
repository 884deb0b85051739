"""The compiled seed derivation and PCG64 stream against NumPy's own classes, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.pcg import int_words, pcg_double, pcg_seed, seed_words, ss_state
from odorloc.core.seeds import episode_seeds, stream_words

ROOTS = [0, 1, 11, 2**32 - 1, 2**32, 123456789012345, 2**63 - 1]
EPISODES = [0, 1, 4095, 2**32 - 1, 2**32 + 5]


@pytest.mark.parametrize("root", ROOTS)
def test_episode_seeds_from_the_words(root: int) -> None:
    for key in ("lattice-isotropic-2d", "indoor-ventilated[start_index=2]"):
        for ep in EPISODES:
            ref = episode_seeds(root, key, ep)
            for stream in (0, 1):
                words, n_root = stream_words(root, key, stream)
                w = np.array([*words, *int_words(ep)], np.uint64)
                assert int(seed_words(w, n_root)) == ref[stream]


@pytest.mark.parametrize("seed", [0, 7, 2**32 - 1, 2**32, 2**62 + 12345, 2**63 - 1])
def test_pcg64_streams_equal_numpy(seed: int) -> None:
    """The world/sensor generators of a world seed: same state, same 500 uniform numbers."""
    children = np.random.SeedSequence(seed).spawn(2)
    for child, ss in enumerate(children):
        g = np.random.Generator(np.random.PCG64(ss))
        st = np.zeros(4, np.uint64)
        w = int_words(seed)
        pcg_seed(np.array([*w, child], np.uint64), len(w), st)
        ref = g.bit_generator.state["state"]
        assert (int(st[0]) << 64) | int(st[1]) == ref["state"]
        assert (int(st[2]) << 64) | int(st[3]) == ref["inc"]
        expected = g.random(500)
        got = np.array([pcg_double(st) for _ in range(500)])
        np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("entropy", [0, 5, 2**200 + 3])
def test_seed_sequence_without_spawn_key(entropy: int) -> None:
    w = int_words(entropy)
    out = np.zeros(9, np.uint64)
    ss_state(np.array(w, np.uint64), len(w), 9, out)
    ref = np.random.SeedSequence(entropy).generate_state(9)
    np.testing.assert_array_equal(out.astype(np.uint32), ref)


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        int_words(-1)
    with pytest.raises(ConfigError, match="seed"):
        stream_words(-3, "x", 0)
