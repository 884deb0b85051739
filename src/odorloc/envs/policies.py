"""Registered searchers as policies of the environments.

:class:`SearcherPolicy` drives a :class:`~odorloc.envs.gym_env.SearchEnv` or a
:class:`~odorloc.envs.parallel.ParallelSearchEnv` with any registered searcher: at each step it
reads the episode's own observations (richer than the feature vector: the searcher sees what it
sees in ``odorloc run``) and returns a native :class:`~odorloc.core.types.Action`, which both
environments accept. With the same seed an environment driven this way follows exactly the
trajectory of ``odorloc run SCENARIO --searcher NAME --seed R --episode I``::

    env = gym.make("odorloc/Search-v0", scenario="indoor-ventilated")
    policy = SearcherPolicy("pf-entropy")
    obs, info = env.reset(seed=0, options={"episode": 3})
    policy.reset(env)
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        done = terminated or truncated
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from odorloc.core import registry
from odorloc.core.types import Action
from odorloc.searchers.base import Searcher

__all__ = ["SearcherPolicy"]


class SearcherPolicy:
    """A registered searcher as a policy of an odorloc environment.

    Parameters
    ----------
    name : str
        Searcher registry name (or ``"package.module:Class"``).
    params : dict, optional
        The searcher's parameters (validated like a scenario's ``searcher`` block).
    """

    def __init__(self, name: str, params: Mapping[str, Any] | None = None) -> None:
        self.name = name
        self._ref = registry.ComponentRef(type=name, **dict(params or {}))
        self.searcher: Searcher = self._ref.build("searcher", field="searcher")
        self._env: Any = None

    def reset(self, env: Any) -> None:
        """Bind to ``env`` (after its ``reset``): the searcher gets the episode's context and
        searcher stream, as in :func:`~odorloc.engine.episode.run_episode`.

        A searcher that drives fewer agents than the environment has runs inside a
        ``per-agent`` team (one instance per agent), as the builder asks of scenarios.
        """
        self._env = env.unwrapped
        ep = self._env.episode
        limit = type(self.searcher).max_agents
        if limit is not None and ep.n_agents > limit:
            team = registry.ComponentRef(type="per-agent", member=self._ref.model_dump())
            self.searcher = team.build("searcher", field="searcher")
        self.searcher.reset(ep.context, ep.agent_rng)

    def __call__(self, observation: Any = None, info: Any = None) -> Action:
        """The searcher's action for the environment's current step (arguments unused)."""
        if self._env is None:
            raise RuntimeError("call policy.reset(env) after env.reset()")
        ep = self._env.episode
        return self.searcher.act(ep.observations, ep.agent_rng)
