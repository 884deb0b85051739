"""PettingZoo ``ParallelEnv`` for team scenarios (the UAV team, the two groups, any other).

::

    from odorloc.envs import parallel_env

    env = parallel_env(scenario="muc-osl-3d")
    obs, infos = env.reset(seed=0)
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        obs, rewards, terminations, truncations, infos = env.step(actions)

Agents are ``agent_0 .. agent_{n-1}`` (the scenario's agent ids). Each has the observation of
:mod:`odorloc.searchers.policy_io` with the ``neighbours`` block: the messages that reached it
through the episode's radio, i.e. only from agents within the scenario's communication radius
(every agent broadcasts its position and reading each step; bytes are accounted and, for
platforms with an energy model, charged). ``state()`` is every agent's own features (without the
neighbour block) and the time, for centralised critics. Rewards follow
:class:`~odorloc.envs.core.RewardParams` per agent (a declaration or a reach is credited to the
agent that made it); with ``team_reward`` every agent receives the team's sum. The episode ends
for all agents at once (the scenario's ``task.end`` rule or its limits).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from odorloc.core.errors import ConfigError
from odorloc.core.types import Action
from odorloc.envs.core import core_for
from odorloc.scenarios import Scenario

__all__ = ["ParallelSearchEnv", "parallel_env"]


class ParallelSearchEnv(ParallelEnv):
    """A team scenario as a PettingZoo parallel environment (see the module docstring).

    Parameters
    ----------
    scenario : str, path or Scenario
    observation, action, reward : dict, optional
        As for :class:`~odorloc.envs.gym_env.SearchEnv`.
    team_reward : bool
        Give every agent the sum of all agents' rewards.
    render_mode : {"rgb_array"}, optional
    record : bool
    world_key : str, optional
    """

    metadata: ClassVar[dict[str, Any]] = {
        "name": "odorloc_search_v0",
        "render_modes": ["rgb_array"],
        "render_fps": 10,
    }

    def __init__(
        self,
        scenario: str | Path | Scenario = "muc-osl-3d",
        observation: dict[str, Any] | None = None,
        action: dict[str, Any] | None = None,
        reward: dict[str, Any] | None = None,
        team_reward: bool = False,
        render_mode: str | None = None,
        record: bool = False,
        world_key: str | None = None,
    ) -> None:
        self.core = core_for(
            self.metadata, render_mode, scenario, observation, action, reward, record, world_key
        )
        if not isinstance(team_reward, bool):
            raise ConfigError("team_reward", f"must be true or false, got {team_reward!r}")
        self.render_mode = render_mode
        self.team_reward = team_reward
        n = self.core.n_agents
        self.possible_agents = [f"agent_{k}" for k in range(n)]
        self.agents: list[str] = []
        self._index = {a: k for k, a in enumerate(self.possible_agents)}
        low, high = self.core.observation_bounds
        self._obs_space = spaces.Box(low, high, dtype=np.float32)
        io = self.core.io
        self._own = io.size - io.others * (io.dim + 3)
        self._act_spaces = {
            a: (
                spaces.Discrete(io.n_discrete)
                if self.core.act_params.kind == "discrete"
                else spaces.Box(-1.0, 1.0, (io.action_size,), dtype=np.float32)
            )
            for a in self.possible_agents
        }
        self._obs_spaces = {
            a: spaces.Box(low, high, dtype=np.float32) for a in self.possible_agents
        }
        t_max = np.float32(self.core.scenario.limits.time)
        self.state_space = spaces.Box(
            np.concatenate([np.tile(low[: self._own], n), [0.0]]).astype(np.float32),
            np.concatenate([np.tile(high[: self._own], n), [t_max]]).astype(np.float32),
            dtype=np.float32,
        )
        self._last = np.zeros((n, io.size), np.float32)
        self._rng = np.random.default_rng()

    def observation_space(self, agent: str) -> spaces.Space:
        # the same space object on every call (PettingZoo's expectation)
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        return self._act_spaces[agent]

    @property
    def episode(self) -> Any:
        """The stepping :class:`~odorloc.engine.episode.Episode` underneath."""
        return self.core.episode

    @property
    def feature_names(self) -> list[str]:
        """Names of one agent's observation vector components."""
        return self.core.feature_names

    @property
    def agent_rng(self) -> np.random.Generator:
        """The episode's searcher stream."""
        return self.core.episode.agent_rng

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        opts = {k: v for k, v in (options or {}).items() if k == "episode"}
        obs = self.core.reset(seed, opts, lambda: self._rng.integers(0, 2**63 - 1, dtype=np.int64))
        self.agents = list(self.possible_agents)
        self._last = obs
        info = self.core.info()
        return (
            {a: obs[k] for k, a in enumerate(self.agents)},
            {a: dict(info) for a in self.agents},
        )

    def step(self, actions: dict[str, Any] | Action) -> tuple[dict, dict, dict, dict, dict]:
        self.core.require_reset()
        if not self.agents:
            raise RuntimeError("the episode is over; call reset()")
        if isinstance(actions, Action):
            act = actions
        else:
            unknown = set(actions) - set(self.agents)
            if unknown:
                raise ConfigError("actions", f"unknown or finished agent(s) {sorted(unknown)}")
            act = self.core.action_for({self._index[a]: v for a, v in actions.items()})
        obs, rewards, res = self.core.step(act)
        self._last = obs
        if self.team_reward:
            rewards = np.full_like(rewards, rewards.sum())
        info = self.core.info(res)
        agents = self.agents
        out = (
            {a: obs[self._index[a]] for a in agents},
            {a: float(rewards[self._index[a]]) for a in agents},
            dict.fromkeys(agents, bool(res.terminated)),
            dict.fromkeys(agents, bool(res.truncated)),
            {a: dict(info) for a in agents},
        )
        if res.done:
            self.agents = []
        return out

    def state(self) -> np.ndarray:
        """Every agent's own features (no neighbour block) and the time, ``float32``."""
        self.core.require_reset()
        own = self._last[:, : self._own].reshape(-1)
        t = np.float32(min(self.core.episode.t, self.core.scenario.limits.time))
        return np.concatenate([own, [t]]).astype(np.float32)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        return self.core.render()

    def close(self) -> None:
        pass


def parallel_env(**kwargs: Any) -> ParallelSearchEnv:
    """A :class:`ParallelSearchEnv` (PettingZoo's constructor convention)."""
    return ParallelSearchEnv(**kwargs)
