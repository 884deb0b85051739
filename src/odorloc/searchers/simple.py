"""Simple searchers that exercise the whole loop and serve as baselines.

- :class:`RandomWalkSearcher`: correlated random walk.
- :class:`ZigzagSearcher`: Z-shaped exploration at a fixed angle to the measured wind, turning at
  walls and obstacles (indoor PF paper, Fig. 1).
- :class:`RectangularWaveSearcher`: boustrophedon coverage with a given lane spacing, repeated
  rounds (D-S paper baseline).
- :class:`PassiveSearcher`: stays put and monitors (plume finding by passive monitoring).

None of them declares a source, except :class:`RectangularWaveSearcher` and
:class:`PassiveSearcher` optionally (``declare_at_max``): they then declare the position of their
strongest reading when they finish, which makes them honest lower baselines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.errors import ConfigError
from odorloc.params import Params, Positive
from odorloc.registry import register
from odorloc.searchers.base import (
    Action,
    Command,
    Declaration,
    Observation,
    SearchContext,
    Searcher,
)
from odorloc.world.arena import Arena


def rotate2(v: np.ndarray, angle: float) -> np.ndarray:
    """Rotate the first two components of ``v`` by ``angle`` rad (counter-clockwise)."""
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(v, float)
    out[0], out[1] = c * v[0] - s * v[1], s * v[0] + c * v[1]
    return out


def free_step(arena: Arena, pos: np.ndarray, direction: np.ndarray, length: float) -> bool:
    """``True`` when moving ``length`` metres from ``pos`` along ``direction`` stays free."""
    n = float(np.linalg.norm(direction))
    if n == 0:
        return True
    return bool(arena.segment_free(pos, pos + direction / n * length)[0])


class _MaxTracker:
    """Remembers the position of the strongest gas reading."""

    def __init__(self) -> None:
        self.best = -math.inf
        self.pos: np.ndarray | None = None

    def update(self, o: Observation) -> None:
        if o.gas > self.best:
            self.best, self.pos = o.gas, o.position.copy()


# ---------------------------------------------------------------------- random walk
class RandomWalkParams(Params):
    """Correlated random walk: speed fraction of the platform limit and heading noise."""

    speed_fraction: float = Field(1.0, gt=0, le=1)
    turn_std_deg: float = Field(30.0, ge=0)


@register("searcher", "random-walk", RandomWalkParams, "correlated random walk")
class RandomWalkSearcher(Searcher):
    """Each agent keeps its heading plus Gaussian turns; blocked headings are redrawn."""

    def __init__(self, params: RandomWalkParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.headings = rng.uniform(-math.pi, math.pi, ctx.n_agents)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        ctx = self.ctx
        speed = ctx.max_speed * self.params.speed_fraction
        cmds = []
        for o in observations:
            h = self.headings[o.agent] + rng.normal(0.0, math.radians(self.params.turn_std_deg))
            for _ in range(16):
                d = np.zeros(ctx.arena.dim)
                d[0], d[1] = math.cos(h), math.sin(h)
                if free_step(ctx.arena, o.position, d, speed * ctx.dt):
                    break
                h = rng.uniform(-math.pi, math.pi)
            self.headings[o.agent] = h
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
    wind_average: int = Field(10, ge=1)
    speed_fraction: float = Field(1.0, gt=0, le=1)
    lookahead: Positive = 1.0


def zigzag_leg(
    arena: Arena,
    pos: np.ndarray,
    up: np.ndarray,
    angle: float,
    side: float,
    along: float,
    look: float,
) -> tuple[np.ndarray, float, float] | None:
    """The next free zigzag leg direction.

    Legs run at ``angle`` (rad) either side of the upwind unit vector ``up``; ``side`` (+-1)
    picks the side and ``along`` (+1 upwind, -1 downwind) the along-wind progress. The current
    leg is kept while ``look`` metres ahead are free; otherwise the mirror leg (zig <-> zag),
    then the two legs with reversed along-wind progress are tried.

    Returns
    -------
    (direction (d,) unit ndarray, side, along), or ``None`` when all four legs are blocked.
    """
    for sg, al in ((side, along), (-side, along), (-side, -along), (side, -along)):
        # A downwind leg mirrors the upwind one, so the Z keeps drifting crosswind.
        d = rotate2(up, sg * (angle if al > 0 else math.pi - angle))
        if free_step(arena, pos, d, look):
            return d, sg, al
    return None


class ZigzagPlanner:
    """The zigzag motion rule on its own, reusable by searchers before their first detection.

    Legs run at ``angle_deg`` either side of upwind. A blocked leg is turned into the mirror
    leg (zig <-> zag); when that is blocked too (the robot reached the upwind or downwind wall),
    the along-wind progress reverses, so the robot sweeps the room back and forth in a Z pattern.
    """

    def __init__(self, params: ZigzagParams, n_agents: int) -> None:
        self.params = params
        self.sign = np.ones(n_agents)  # +1 / -1: which side of the wind the leg points to
        self.along = np.ones(n_agents)  # +1 upwind legs, -1 downwind legs
        self.winds: list[list[np.ndarray]] = [[] for _ in range(n_agents)]

    def upwind(self, agent: int, wind: np.ndarray) -> np.ndarray:
        """Unit upwind direction from the running average of the anemometer (``(d,)``)."""
        buf = self.winds[agent]
        buf.append(np.asarray(wind, float))
        del buf[: -self.params.wind_average]
        mean = np.mean(buf, axis=0)
        n = float(np.linalg.norm(mean[:2]))
        u = np.zeros_like(mean)
        if n < 1e-9:
            u[0] = -1.0
        else:
            u[:2] = -mean[:2] / n
        return u

    def command(self, ctx: SearchContext, o: Observation) -> Command:
        """Velocity command for agent ``o.agent`` this step."""
        k = o.agent
        speed = ctx.max_speed * self.params.speed_fraction
        look = max(speed * self.params.lookahead, 1.5 * ctx.arena.resolution)
        up = self.upwind(k, o.wind)
        leg = zigzag_leg(
            ctx.arena,
            o.position,
            up,
            math.radians(self.params.angle_deg),
            self.sign[k],
            self.along[k],
            look,
        )
        if leg is not None:
            d, self.sign[k], self.along[k] = leg
            return Command.velocity(d * speed)
        # Boxed in (a narrow gap): any free direction, checked at a shorter range.
        for ang in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False):
            d = rotate2(up, ang)
            if free_step(ctx.arena, o.position, d, speed * ctx.dt):
                return Command.velocity(d * speed)
        return Command.hold()


@register("searcher", "zigzag", ZigzagParams, "Z-shaped exploration at an angle to the wind")
class ZigzagSearcher(Searcher):
    """Zigzag exploration (indoor PF paper, Fig. 1); never declares."""

    def __init__(self, params: ZigzagParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.planner = ZigzagPlanner(self.params, ctx.n_agents)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        return Action([self.planner.command(self.ctx, o) for o in observations])


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
        Area to cover; defaults to ``ctx.info["search_region"]`` or the arena bounds.
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
    rounds: int = Field(1, ge=1)
    margin: float = Field(0.0, ge=0)
    declare_at_max: bool = False


def rectangular_wave(
    lower: Sequence[float],
    upper: Sequence[float],
    spacing: float,
    along: str,
    start: Sequence[float] | None = None,
) -> np.ndarray:
    """Waypoints of one boustrophedon pass, ``(W, 2)`` metres.

    Lanes are ``spacing`` apart across the region; the pass starts at the corner nearest to
    ``start`` when given.
    """
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    across = 0 if along == "y" else 1
    long = 1 - across
    n_lanes = math.floor((hi[across] - lo[across]) / spacing + 1e-9) + 1
    lanes = lo[across] + spacing * np.arange(n_lanes)
    if start is not None and abs(start[across] - hi[across]) < abs(start[across] - lo[across]):
        lanes = lanes[::-1]
    first_at_hi = start is not None and abs(start[long] - hi[long]) < abs(start[long] - lo[long])
    pts = []
    for i, c in enumerate(lanes):
        ends = [lo[long], hi[long]]
        if (i % 2 == 1) != first_at_hi:
            ends = ends[::-1]
        for e in ends:
            p = np.zeros(2)
            p[across], p[long] = c, e
            pts.append(p)
    return np.array(pts)


@register("searcher", "rectangular-wave", RectangularWaveParams, "boustrophedon lane coverage")
class RectangularWaveSearcher(Searcher):
    """Follows a predefined rectangular-wave path for ``rounds`` passes, then stops."""

    def __init__(self, params: RectangularWaveParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        if p.region is not None:
            lo, hi = np.asarray(p.region[0], float), np.asarray(p.region[1], float)
        elif "search_region" in ctx.info:
            reg = ctx.info["search_region"]
            lo, hi = np.asarray(reg[0], float), np.asarray(reg[1], float)
        else:
            lo, hi = ctx.arena.lo[:2], ctx.arena.hi[:2]
        if np.any(hi - lo <= 2 * p.margin):
            raise ConfigError("searcher.margin", "leaves no area to cover")
        lo, hi = lo + p.margin, hi - p.margin
        paths = []
        start = ctx.start[0, :2]
        for r in range(p.rounds):
            wp = rectangular_wave(lo, hi, p.lane_spacing, p.lanes_along, start)
            if r % 2 == 1:
                wp = wp[::-1]
            paths.append(wp)
        self.waypoints = np.concatenate(paths)
        if ctx.arena.dim == 3:
            z = np.full((len(self.waypoints), 1), ctx.start[0, 2])
            self.waypoints = np.hstack([self.waypoints, z])
        self.index = [0] * ctx.n_agents
        self.started = [False] * ctx.n_agents
        self.tracker = _MaxTracker()

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        cmds: list[Command | None] = []
        done = True
        for o in observations:
            self.tracker.update(o)
            i = self.index[o.agent]
            if not self.started[o.agent] or o.ready:
                if self.started[o.agent]:
                    i += 1
                self.started[o.agent] = True
                self.index[o.agent] = i
                if i < len(self.waypoints):
                    cmds.append(Command.waypoint(self.waypoints[i]))
                    done = False
                else:
                    cmds.append(Command.hold())
            else:
                cmds.append(None)
                done = False
        decl = None
        if done and self.params.declare_at_max and self.tracker.pos is not None:
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
    """Stays put; records when the plume first arrives."""

    def __init__(self, params: PassiveParams) -> None:
        self.params = params

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.arrival = math.nan

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        decl = None
        for o in observations:
            if o.detection and math.isnan(self.arrival):
                self.arrival = o.t
                if self.params.declare_on_detection:
                    decl = Declaration(o.position[None, :], confidence=0.0)
        return Action([Command.hold() for _ in observations], declaration=decl)

    def diagnostics(self) -> dict[str, float]:
        return {"arrival": self.arrival}
