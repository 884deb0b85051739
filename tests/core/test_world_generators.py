"""``world_generators`` gives exactly the world and sensor streams of ``episode_generators``."""

from __future__ import annotations

import numpy as np

from odorloc.core.seeds import episode_generators, episode_seeds, world_generators


def test_world_generators_are_the_episode_streams() -> None:
    for episode in (0, 7):
        ws, ags = episode_seeds(123, "lattice-isotropic-2d", episode)
        world, sensors, _ = episode_generators(ws, ags)
        w2, s2 = world_generators(ws)
        np.testing.assert_array_equal(world.random(5), w2.random(5))
        np.testing.assert_array_equal(sensors.poisson(1.3, 50), s2.poisson(1.3, 50))
