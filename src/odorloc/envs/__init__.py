"""Gymnasium and PettingZoo environments over odorloc scenarios (extra ``odorloc[rl]``).

Importing this package registers ``odorloc/Search-v0`` with Gymnasium::

    import gymnasium as gym
    import odorloc.envs

    env = gym.make("odorloc/Search-v0", scenario="indoor-ventilated")

- :class:`SearchEnv` (:mod:`.gym_env`): any single-agent scenario;
- :class:`ParallelSearchEnv` / :func:`parallel_env` (:mod:`.parallel`): team scenarios;
- :class:`SearcherPolicy` (:mod:`.policies`): any registered searcher as a policy; the ``policy``
  searcher (:mod:`odorloc.searchers.policy`) is the other way round.
"""

from __future__ import annotations

import gymnasium as gym

from odorloc.envs.core import RewardParams
from odorloc.envs.gym_env import SearchEnv
from odorloc.envs.parallel import ParallelSearchEnv, parallel_env
from odorloc.envs.policies import SearcherPolicy

__all__ = [
    "ENV_ID",
    "ParallelSearchEnv",
    "RewardParams",
    "SearchEnv",
    "SearcherPolicy",
    "parallel_env",
]

ENV_ID = "odorloc/Search-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="odorloc.envs.gym_env:SearchEnv", disable_env_checker=False)
