"""Simple searchers that exercise the whole loop and serve as baselines.

- :class:`RandomWalkSearcher`: correlated random walk.
- :class:`ZigzagSearcher`: Z-shaped exploration at a fixed angle to the measured wind, turning at
  walls and obstacles (indoor PF paper, Fig. 1).
- :class:`RectangularWaveSearcher`: boustrophedon coverage with a given lane spacing, repeated
  rounds (D-S paper baseline).
- :class:`PassiveSearcher`: stays put and monitors (plume finding by passive monitoring).

None of them declares a source, except :class:`RectangularWaveSearcher` and
:class:`PassiveSearcher` optionally: they then declare the position of their strongest reading
when they finish (or their own position on the first detection), honest lower baselines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import first_free, free_step
from odorloc.behaviours.monitor import MaxTracker, PassiveMonitor
from odorloc.behaviours.zigzag import Zigzag
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.geometry.regions import resolve_region
from odorloc.geometry.vectors import heading_vector, rotate2
from odorloc.planning.coverage import route_around_obstacles, wave_waypoints
from odorloc.searchers.base import Searcher
from odorloc.sensors.preprocessing import WindAverage


# ---------------------------------------------------------------------- random walk
class RandomWalkParams(Params):
    """Correlated random walk: speed fraction of the platform limit and heading noise."""

    speed_fraction: float = Field(1.0, gt=0, le=1)
    turn_std_deg: NonNegative = 30.0


@register("searcher", "random-walk", RandomWalkParams, "correlated random walk")
class RandomWalkSearcher(Searcher):
    """Each agent keeps its heading plus Gaussian turns; blocked headings are redrawn."""

    params: RandomWalkParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.headings = rng.uniform(-math.pi, math.pi, ctx.n_agents)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        ctx = self.ctx
        cmds = []
        for i, o in enumerate(observations):
            speed = float(ctx.speed_limits[i]) * self.params.speed_fraction
            h = self.headings[i] + rng.normal(0.0, math.radians(self.params.turn_std_deg))
            for _ in range(16):
                d = heading_vector(h, ctx.arena.dim)
                if free_step(ctx.arena, o.position, d, speed * ctx.dt):
                    break
                h = rng.uniform(-math.pi, math.pi)
            self.headings[i] = h
            cmds.append(Command.velocity(d * speed))
        return Action(cmds)


# ---------------------------------------------------------------------- zigzag
class ZigzagParams(Params):
    """Z-shaped exploration across the wind.

    Attributes
    ----------
    angle_deg : float
        Angle between each leg and the upwind direction, degrees (90 = pure crosswind).
    wind_average : int
        Number of anemometer readings averaged for the wind direction.
    speed_fraction : float
        Fraction of the platform's speed limit.
    lookahead : float
        Seconds of travel checked for walls/obstacles before a leg is turned.
    """

    angle_deg: float = Field(60.0, gt=0, lt=180)
    wind_average: int = Field(10, ge=1, le=10_000)
    speed_fraction: float = Field(1.0, gt=0, le=1)
    lookahead: Positive = 1.0


@register("searcher", "zigzag", ZigzagParams, "Z-shaped exploration at an angle to the wind")
class ZigzagSearcher(Searcher):
    """Zigzag exploration (indoor PF paper, Fig. 1) with velocity commands; never declares.

    When all four legs are blocked (a narrow gap), any free direction among 16 around the
    upwind direction is taken at one period's range, else the agent holds.
    """

    params: ZigzagParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        self.legs = [Zigzag(math.radians(p.angle_deg)) for _ in range(ctx.n_agents)]
        self.winds = [WindAverage(p.wind_average) for _ in range(ctx.n_agents)]

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        ctx, p = self.ctx, self.params
        cmds = []
        for i, o in enumerate(observations):
            speed = float(ctx.speed_limits[i]) * p.speed_fraction
            look = max(speed * p.lookahead, 1.5 * ctx.arena.resolution)
            self.winds[i].add(o.wind)
            up = self.winds[i].upwind(fallback_heading=math.pi)
            d = self.legs[i].direction(ctx.arena, o.position, up, look, speed * ctx.dt)
            if d is not None:
                cmds.append(Command.velocity(d * speed))
                continue
            fan = np.array([rotate2(up, a) for a in np.linspace(0.0, 2 * math.pi, 16, False)])
            k = first_free(ctx.arena, o.position, fan * (speed * ctx.dt))
            cmds.append(Command.hold() if k is None else Command.velocity(fan[k] * speed))
        return Action(cmds)


# ---------------------------------------------------------------------- rectangular wave
class RectangularWaveParams(Params):
    """Boustrophedon coverage.

    Attributes
    ----------
    lane_spacing : float
        Distance between lanes, metres (2 m in the D-S paper).
    lanes_along : "x" | "y"
        Direction of the long legs.
    region : ((xmin, ymin), (xmax, ymax)), optional
        Area to cover; defaults to the task's search region, else the arena bounds.
    rounds : int
        Number of passes over the region (alternating direction).
    margin : float
        Distance kept from the region's edges, metres.
    declare_at_max : bool
        Declare the position of the strongest reading when the rounds are done.
    """

    lane_spacing: Positive = 2.0
    lanes_along: Literal["x", "y"] = "y"
    region: tuple[tuple[float, float], tuple[float, float]] | None = None
    rounds: int = Field(1, ge=1, le=1000)
    margin: NonNegative = 0.0
    declare_at_max: bool = False


@register("searcher", "rectangular-wave", RectangularWaveParams, "boustrophedon lane coverage")
class RectangularWaveSearcher(Searcher):
    """Follows a predefined rectangular-wave path for ``rounds`` passes, then stops.

    Every agent follows the same lanes (in 3D at the first agent's start height). Lanes that
    obstacles cut are swept on both sides of them, the stretches joined by A* paths
    (:func:`~odorloc.planning.coverage.route_around_obstacles`); each agent's path is routed
    from its own start, since the way into the lanes differs from agent to agent.

    Attributes
    ----------
    waypoints : list of (W_k, d) ndarray
        Each agent's waypoints, metres.
    index : list of int
        Each agent's current (last sent) waypoint; it stays at the last one once that is
        reached, so it is always a valid index into a non-empty path.
    finished : list of bool
        Whether each agent has reached its last waypoint (it then holds).
    """

    params: RectangularWaveParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        region = resolve_region(ctx, p.region)
        # the lanes are flown at the start height: obstacles are those of that layer
        height = float(ctx.start[0, 2]) if ctx.arena.dim == 3 else 0.0
        plane = ctx.arena.horizontal_slice(height)
        corners = wave_waypoints(
            region, p.lane_spacing, p.lanes_along, p.rounds, ctx.start[0, :2], p.margin, "alternate"
        )
        paths = [route_around_obstacles(plane, corners, s[:2]) for s in ctx.start]
        if ctx.arena.dim == 3:
            paths = [np.hstack([w, np.full((len(w), 1), ctx.start[0, 2])]) for w in paths]
        self.waypoints: list[np.ndarray] = paths
        self.index = [0] * ctx.n_agents
        self.started = [False] * ctx.n_agents
        self.finished = [False] * ctx.n_agents
        self.tracker = MaxTracker()

    @property
    def done(self) -> bool:
        """``True`` once every agent has reached its last waypoint."""
        return all(self.finished)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        cmds: list[Command | None] = []
        for k, o in enumerate(observations):
            self.tracker.update(o)
            if not self.finished[k] and (not self.started[k] or o.ready):
                # before the first waypoint is sent, `ready` says nothing about the path
                nxt = self.index[k] + 1 if self.started[k] else 0
                self.started[k] = True
                if nxt < len(self.waypoints[k]):
                    self.index[k] = nxt
                    cmds.append(Command.waypoint(self.waypoints[k][nxt]))
                    continue
                self.finished[k] = True
            cmds.append(Command.hold() if self.finished[k] else None)
        decl = None
        if self.done and self.params.declare_at_max and self.tracker.pos is not None:
            decl = Declaration(self.tracker.pos[None, :], confidence=0.0)
        return Action(cmds, declaration=decl)

    def diagnostics(self) -> dict[str, float]:
        return {"waypoint": float(self.index[0])}


# ---------------------------------------------------------------------- passive
class PassiveParams(Params):
    """Passive monitoring: hold position; optionally declare the own position on detection."""

    declare_on_detection: bool = False


@register("searcher", "passive", PassiveParams, "stay and monitor until the plume arrives")
class PassiveSearcher(Searcher):
    """Stays put; records when the plume first arrives (at any of its agents)."""

    params: PassiveParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.monitor = PassiveMonitor()

    @property
    def arrival(self) -> float:
        """Time of the first detection, seconds (NaN before)."""
        return self.monitor.arrival

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        decl = None
        for o in observations:
            if self.monitor.update(o) and self.params.declare_on_detection:
                decl = Declaration(o.position[None, :], confidence=0.0, agent=o.agent)
        return Action([Command.hold() for _ in observations], declaration=decl)

    def diagnostics(self) -> dict[str, float]:
        return {"arrival": self.arrival}
