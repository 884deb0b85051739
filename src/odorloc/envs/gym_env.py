"""Gymnasium environment ``odorloc/Search-v0``: one agent searching in any single-agent scenario.

::

    import gymnasium as gym
    import odorloc.envs  # registers the environments

    env = gym.make("odorloc/Search-v0", scenario="indoor-ventilated", render_mode="rgb_array")
    obs, info = env.reset(seed=0)                       # episode 0 of root seed 0
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Observation: a flat ``float32`` vector (:mod:`odorloc.searchers.policy_io`; names in
``env.unwrapped.feature_names``). Action: ``Box(-1, 1, (d [+1],))`` velocities scaled by the
platform's speed limit, or ``Discrete(moves [+1])`` (``action={"kind": "discrete"}``); the
extra component or index declares a source (``action={"declare": "none"}`` removes it).
Reward (:class:`~odorloc.envs.core.RewardParams`): -1 per control period, +100 per true source
found by a declaration or on reaching one, -100 per wrong declaration. ``terminated``: the
scenario's task ended the episode (its ``task.end`` rule: a declaration, or reaching a source);
``truncated``: the time (or energy) limit, or ``task.stuck_limit``. Seeds:
:mod:`odorloc.envs.core`. ``step`` also accepts a native :class:`~odorloc.core.types.Action`
(what :class:`~odorloc.envs.SearcherPolicy` returns).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from odorloc.core.errors import ConfigError
from odorloc.core.types import Action
from odorloc.envs.core import core_for
from odorloc.scenarios import DEFAULT_SCENARIO, Scenario

__all__ = ["SearchEnv"]


class SearchEnv(gym.Env):
    """A single-agent odorloc scenario as a Gymnasium environment (see the module docstring).

    Parameters
    ----------
    scenario : str, path or Scenario
        Built-in scenario name, scenario file or object (one agent; 2-D or 3-D).
    observation, action, reward : dict, optional
        :class:`~odorloc.searchers.policy_io.ObservationParams`,
        :class:`~odorloc.searchers.policy_io.ActionParams`,
        :class:`~odorloc.envs.core.RewardParams` settings.
    render_mode : {"rgb_array"}, optional
    record : bool
        Keep the episode's recording (``env.unwrapped.episode.result().recording``).
    world_key : str, optional
        World key of the seed derivation (default: the scenario's own name).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Path | Scenario = DEFAULT_SCENARIO,
        observation: dict[str, Any] | None = None,
        action: dict[str, Any] | None = None,
        reward: dict[str, Any] | None = None,
        render_mode: str | None = None,
        record: bool = False,
        world_key: str | None = None,
    ) -> None:
        self.core = core_for(
            self.metadata, render_mode, scenario, observation, action, reward, record, world_key
        )
        if self.core.n_agents != 1:
            raise ConfigError(
                "scenario",
                f"{self.core.scenario.name!r} has {self.core.n_agents} agents; use "
                "odorloc.envs.parallel_env (PettingZoo) for teams",
            )
        self.render_mode = render_mode
        low, high = self.core.observation_bounds
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        io = self.core.io
        if self.core.act_params.kind == "discrete":
            self.action_space = spaces.Discrete(io.n_discrete)
        else:
            n = io.action_size
            self.action_space = spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)

    # ------------------------------------------------------------------ API
    @property
    def episode(self) -> Any:
        """The stepping :class:`~odorloc.engine.episode.Episode` underneath."""
        return self.core.episode

    @property
    def feature_names(self) -> list[str]:
        """Names of the observation vector's components."""
        return self.core.feature_names

    @property
    def context(self) -> Any:
        """The :class:`~odorloc.core.types.SearchContext` of the scenario (what a searcher
        knows: arena, speed limits, sensor threshold), available before the first reset."""
        return self.core.io.ctx

    @property
    def agent_rng(self) -> np.random.Generator:
        """The episode's searcher stream (for stochastic policies; what a searcher gets)."""
        return self.core.episode.agent_rng

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        obs = self.core.reset(
            seed, options, lambda: self.np_random.integers(0, 2**63 - 1, dtype=np.int64)
        )
        return obs[0], self.core.info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self.core.require_reset()
        if self.core.episode.done:
            raise RuntimeError("the episode is over; call reset()")
        act = action if isinstance(action, Action) else self.core.action_for({0: action})
        obs, rewards, res = self.core.step(act)
        return obs[0], float(rewards[0]), res.terminated, res.truncated, self.core.info(res)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        return self.core.render()
