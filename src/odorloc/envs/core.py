"""The part the Gymnasium and PettingZoo environments share: a stepping episode, the seed
mapping, the policy encoding, the reward and the rendering.

Seeds: ``reset(seed=R)`` starts episode 0 of root seed ``R``; each later ``reset()`` without a
seed starts the next episode of the same root; ``options={"episode": i}`` jumps to episode
``i``. Episode ``i`` of root ``R`` has the world and agent seeds
:func:`~odorloc.core.seeds.episode_seeds` ``(R, world_key, i)``, with the scenario's own name
as the world key (the built-in name or a file's ``name`` field, never the path as typed), so it
is exactly episode ``i`` of ``odorloc batch -s SCENARIO --seed R`` and
``odorloc run SCENARIO --seed R --episode I``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, Params
from odorloc.core.seeds import check_seed, episode_seeds
from odorloc.core.types import Action, Event, Observation
from odorloc.engine.episode import Episode, StepResult
from odorloc.scenarios import Scenario, get_scenario
from odorloc.searchers.policy_io import ActionParams, ObservationParams, PolicyIO
from odorloc.viz.frame import render_rgb

__all__ = ["EnvCore", "RewardParams", "load_scenario", "validated"]


class RewardParams(Params):
    """The reward of one control period (every term is configurable; 0 switches it off).

    Attributes
    ----------
    step : float
        Paid every control period (default -1).
    found : float
        Per true source a declaration finds for the first time (within ``task.success_radius``).
    wrong : float
        Per declaration that lies farther than the success radius from every true source.
    reach : float
        When an agent comes within ``task.reach_radius`` of a source (scenarios with one).
    """

    step: Finite = -1.0
    found: Finite = 100.0
    wrong: Finite = -100.0
    reach: Finite = 100.0


def validated(model: type[Params], value: Any, field: str) -> Any:
    """``value`` (a dict, a model or ``None``) as ``model``; :class:`ConfigError` names ``field``
    when it is invalid."""
    import pydantic

    from odorloc.core.errors import format_validation_error

    if value is None:
        return model()
    if isinstance(value, model):
        return value
    if not isinstance(value, dict):
        raise ConfigError(field, f"must be a mapping, got {type(value).__name__}")
    try:
        return model.model_validate(value)
    except pydantic.ValidationError as err:
        fld, _, problem = format_validation_error(err, prefix=field).partition(": ")
        raise ConfigError(fld, problem) from None


def load_scenario(scenario: str | Path | Scenario) -> tuple[Scenario, str]:
    """``(scenario, world key)``: a built-in name, a file or a :class:`Scenario` object; the
    key is the scenario's own name, never the path a file was given by."""
    sc = scenario if isinstance(scenario, Scenario) else get_scenario(scenario)
    return sc, sc.name


def core_for(
    metadata: dict[str, Any],
    render_mode: str | None,
    scenario: str | Path | Scenario,
    observation: Any,
    action: Any,
    reward: Any,
    record: bool,
    world_key: str | None,
) -> EnvCore:
    """The :class:`EnvCore` of an environment whose ``metadata`` lists its render modes; the
    agents' paths are kept only when the environment renders."""
    if render_mode is not None and render_mode not in metadata["render_modes"]:
        raise ConfigError("render_mode", f"must be one of {metadata['render_modes']}")
    return EnvCore(
        scenario,
        observation,
        action,
        reward,
        record=record,
        world_key=world_key,
        trails=render_mode is not None,
    )


class EnvCore:
    """One episode stepped by an environment (see the module docstring).

    Parameters
    ----------
    scenario : str, path or Scenario
    observation, action, reward : dict or Params, optional
        :class:`ObservationParams`, :class:`ActionParams`, :class:`RewardParams`.
    record : bool
        Keep the episode's recording (``episode.result().recording`` after the end).
    world_key : str, optional
        The world key of the seed derivation (default: the scenario's own name).
    trails : bool
        Keep every agent's path for :meth:`render` (an environment without a render mode
        need not store a position per agent and step).
    """

    def __init__(
        self,
        scenario: str | Path | Scenario,
        observation: Any = None,
        action: Any = None,
        reward: Any = None,
        *,
        record: bool = False,
        world_key: str | None = None,
        trails: bool = True,
    ) -> None:
        self.keep_trails = bool(trails)
        self.scenario, key = load_scenario(scenario)
        if world_key is not None and not isinstance(world_key, str):
            raise ConfigError("world_key", f"must be a string, got {type(world_key).__name__}")
        self.world_key = world_key if world_key is not None else key
        self.obs_params: ObservationParams = validated(
            ObservationParams, observation, "observation"
        )
        self.act_params: ActionParams = validated(ActionParams, action, "action")
        self.reward_params: RewardParams = validated(RewardParams, reward, "reward")
        if self.act_params.declare == "belief" and self.obs_params.belief is None:
            raise ConfigError("action.declare", "'belief' needs observation.belief (an estimator)")
        self.episode = Episode(self.scenario, record=record)
        self.n_agents = self.episode.n_agents
        self.dim = len(self.scenario.world.arena.lower)
        self.root: int | None = None
        self.next_episode = 0
        self.episode_index = -1
        # A throwaway reset gives the context (spaces need the speed limits and bounds) without
        # touching any stream a later reset uses.
        self._layout_io = self._make_io(self._probe_context(), np.random.default_rng(0))
        self.io = self._layout_io
        self._trails: list[list[np.ndarray]] = []

    # ------------------------------------------------------------------ spaces
    def _probe_context(self) -> Any:
        from odorloc.scenarios.build import search_context

        return search_context(self.scenario, self.episode.built)

    def _make_io(self, ctx: Any, rng: np.random.Generator) -> PolicyIO:
        return PolicyIO(ctx, self.obs_params, self.act_params, rng, self.scenario.limits.time)

    @property
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of one agent's observation vector."""
        return self._layout_io.observation_bounds()

    @property
    def feature_names(self) -> list[str]:
        """Names of the observation vector's components."""
        return self._layout_io.feature_names

    # ------------------------------------------------------------------ episode
    def reset(self, seed: int | None, options: dict[str, Any] | None, draw_root: Any) -> np.ndarray:
        """Start an episode; return the observation vectors ``(n_agents, F)``.

        ``draw_root()`` gives a root seed when none was ever given (the environment's own
        ``np_random``).
        """
        opts = dict(options or {})
        if seed is not None:
            self.root = check_seed(int(seed), "seed")
            self.next_episode = 0
        elif self.root is None:
            self.root = int(draw_root())
        i = opts.get("episode", self.next_episode)
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or i < 0:
            raise ConfigError("options.episode", f"must be an integer >= 0, got {i!r}")
        self.episode_index = int(i)
        self.next_episode = self.episode_index + 1
        self.world_seed, self.agent_seed = episode_seeds(
            self.root, self.world_key, self.episode_index
        )
        obs = self.episode.reset(self.world_seed, self.agent_seed)
        if self.episode.done:
            # Gymnasium has no way to hand back an episode that is over before its first step
            raise ConfigError(
                "task.reach_radius",
                f"episode {self.episode_index} is over at reset: an agent starts within "
                f"{self.scenario.task.reach_radius} m of a source",
            )
        # The same stream the ``policy`` searcher gives its estimators (the first child of the
        # agent stream), created apart so the agent stream itself is never touched here.
        belief_rng = np.random.Generator(
            np.random.PCG64(np.random.SeedSequence(self.agent_seed).spawn(1)[0])
        )
        self.io = self._make_io(self.episode.context, belief_rng)
        self.io.update_beliefs(obs)
        self._trails = [[o.position[:2].copy()] for o in obs]
        return self.io.encode(obs)

    @property
    def observations(self) -> list[Observation]:
        """The current observations as odorloc :class:`Observation` objects."""
        return self.episode.observations

    def action_for(self, per_agent: dict[int, Any]) -> Action:
        """The episode action of the given agents' policy actions (others keep their command)."""
        obs = self.episode.observations
        cmds: list[Any] = [None] * self.n_agents
        decoded, decls = self.io.decode_many(per_agent, obs)
        for k, cmd in decoded.items():
            cmds[k] = cmd
        return Action(cmds, messages=self.io.broadcasts(obs), declarations=decls)

    def require_reset(self) -> None:
        """:class:`RuntimeError` unless an episode has been started."""
        if self.episode_index < 0:
            raise RuntimeError("no episode yet: call reset() first")

    def step(self, action: Action) -> tuple[np.ndarray, np.ndarray, StepResult]:
        """Advance one control period: ``(observations (n, F), rewards (n,), step result)``."""
        self.require_reset()
        if action.messages == {} and self.io.others > 0:
            # a native action without messages: the agents still broadcast their readings
            action = Action(
                action.commands,
                messages=self.io.broadcasts(self.episode.observations),
                declarations=action.declarations,
                compute_bits=action.compute_bits,
            )
        res = self.episode.step(action)
        obs = res.observations if res.observations else self.episode.observations
        if not res.done:
            self.io.update_beliefs(obs)
        if self.keep_trails:
            for k, o in enumerate(obs):
                self._trails[k].append(o.position[:2].copy())
        return self.io.encode(obs), self.rewards(res.events), res

    def rewards(self, events: list[Event]) -> np.ndarray:
        """Per-agent reward of one step's events (a declaration by nobody in particular, or a
        team's, is credited to agent 0)."""
        rp = self.reward_params
        r = np.full(self.n_agents, rp.step, float)
        radius = self.scenario.task.success_radius
        sources = self.episode.sources
        for ev in events:
            k = ev.agent if ev.agent is not None and 0 <= ev.agent < self.n_agents else 0
            if ev.kind == "source_found":
                r[k] += rp.found
            elif ev.kind == "source_reached":
                r[k] += rp.reach
            elif ev.kind == "declaration" and ev.position is not None:
                pos = np.atleast_2d(ev.position)
                d = np.linalg.norm(pos[:, None, :] - sources[None, :, :], axis=2).min(axis=1)
                r[k] += rp.wrong * float(np.sum(d > radius))
        return r

    def info(self, res: StepResult | None = None) -> dict[str, Any]:
        """Plain-data step information (time, termination, seeds)."""
        return {
            "t": float(self.episode.t if res is None else res.t),
            "termination": "running" if res is None else res.termination,
            "episode": self.episode_index,
            "world_seed": self.world_seed,
            "agent_seed": self.agent_seed,
        }

    # ------------------------------------------------------------------ rendering
    def render(self, width: int = 480) -> np.ndarray:
        """An RGB frame ``(H, W, 3)`` of the current scene (a horizontal slice in 3-D)."""
        self.require_reset()
        ep = self.episode
        arena = ep.world.arena
        lo, hi = arena.lo, arena.hi
        nx = 120
        ny = max(8, round(nx * (hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-12)))
        xs = lo[0] + (np.arange(nx) + 0.5) * (hi[0] - lo[0]) / nx
        ys = lo[1] + (np.arange(ny) + 0.5) * (hi[1] - lo[1]) / ny
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = [gx.ravel(), gy.ravel()]
        occ = arena.occ
        if arena.dim == 3:
            z = float(ep.observations[0].position[2]) if ep.observations else float(lo[2])
            pts.append(np.full(gx.size, z))
            if occ is not None:
                k = int(arena.cell_index(np.array([[lo[0], lo[1], z]]))[0, 2])
                occ = occ[:, :, k]
        field = ep.world.plume.concentration(np.column_stack(pts)).reshape(nx, ny)
        declared = None
        decl = [e.position for e in ep.events if e.kind == "declaration" and e.position is not None]
        if decl:
            declared = np.vstack([np.atleast_2d(p) for p in decl])
        return render_rgb(
            field,
            (lo[0], hi[0], lo[1], hi[1]),
            occupancy=occ,
            sources=ep.sources,
            trails=[np.array(t) for t in self._trails],
            declared=declared,
            width=width,
        )
