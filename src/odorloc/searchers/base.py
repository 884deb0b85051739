"""The searcher interface every published algorithm implements.

Each control period (default 0.5 s) the engine hands the searcher one :class:`Observation` per
agent and expects an :class:`Action`: one :class:`Command` per agent (or ``None`` to keep the
current one), optional messages to broadcast to neighbours within the communication radius, and
optionally a :class:`Declaration` of the source position(s).

Single robots, centrally controlled groups (formations) and teams of agents that each run their
own estimator and talk to neighbours all fit this shape: a centralised searcher uses all
observations at once; a decentralised one (:class:`odorloc.searchers.team.PerAgentTeam`) lets each
agent see only its own observation and the messages it received.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from odorloc.world.arena import Arena

CommandKind = Literal["velocity", "waypoint", "move", "hold"]


@dataclass(frozen=True, eq=False)
class Message:
    """A payload broadcast by agent ``sender``; ``nbytes`` is charged per recipient."""

    sender: int
    payload: dict[str, np.ndarray]

    @property
    def nbytes(self) -> int:
        """Size of the payload's arrays in bytes (what a radio would send)."""
        return int(sum(np.asarray(v).nbytes for v in self.payload.values()))


@dataclass(frozen=True, eq=False)
class Observation:
    """What one agent senses at one control step.

    Attributes
    ----------
    agent : int
        Agent index within the team.
    t : float
        Time, seconds.
    position : (d,) ndarray, metres
    heading : float
        Heading angle, rad (x axis = 0, counter-clockwise).
    gas : float
        Gas sensor output after its processing (concentration units, or encounter count for
        encounter sensors).
    detection : bool
        Binarised gas reading (``gas`` above the sensor threshold, or at least one encounter).
    wind : (d,) ndarray, m/s
        Anemometer reading of the air velocity, in the world frame.
    ready : bool
        ``True`` when the agent has finished its last waypoint/move (and hover); velocity
        commands are always ready.
    messages : tuple of Message
        Messages from neighbours received since the last step.
    energy : float
        Energy used so far, J (0 for platforms without an energy model).
    """

    agent: int
    t: float
    position: np.ndarray
    heading: float
    gas: float
    detection: bool
    wind: np.ndarray
    ready: bool = True
    messages: tuple[Message, ...] = ()
    energy: float = 0.0


@dataclass(frozen=True, eq=False)
class Command:
    """A motion command for one agent.

    ``velocity``: move with ``value`` (m/s, clipped to the platform's limits) for one period.
    ``waypoint``: go to the absolute position ``value`` (m), over as many periods as needed.
    ``move``: go to ``position + value`` (a displacement, m), e.g. one of a discrete move set.
    ``hold``: stay in place (``value`` ignored).
    """

    kind: CommandKind
    value: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @staticmethod
    def velocity(v: Sequence[float] | np.ndarray) -> Command:
        """A velocity command, m/s."""
        return Command("velocity", np.asarray(v, float))

    @staticmethod
    def waypoint(p: Sequence[float] | np.ndarray) -> Command:
        """A waypoint command, absolute position in metres."""
        return Command("waypoint", np.asarray(p, float))

    @staticmethod
    def move(d: Sequence[float] | np.ndarray) -> Command:
        """A relative move, displacement in metres."""
        return Command("move", np.asarray(d, float))

    @staticmethod
    def hold() -> Command:
        """Stay in place."""
        return Command("hold")


@dataclass(frozen=True, eq=False)
class Declaration:
    """The searcher's claim that the source(s) are at ``positions`` (``(K, d)`` metres)."""

    positions: np.ndarray
    confidence: float = 1.0

    def __post_init__(self) -> None:
        p = np.atleast_2d(np.asarray(self.positions, float))
        object.__setattr__(self, "positions", p)


@dataclass(frozen=True, eq=False)
class Action:
    """A searcher's answer for one control step.

    Attributes
    ----------
    commands : sequence of Command or None
        One per agent; ``None`` keeps the agent's current command.
    messages : dict of int to dict of str to ndarray
        Payloads each agent broadcasts to its neighbours this step.
    declaration : Declaration, optional
        Set when the searcher declares; the episode then ends.
    """

    commands: Sequence[Command | None]
    messages: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)
    declaration: Declaration | None = None


@dataclass(frozen=True, eq=False)
class SearchContext:
    """What a searcher knows before the episode starts.

    Attributes
    ----------
    arena : Arena
        The map (bounds and obstacles), as a robot with a LiDAR map would know it.
    dt : float
        Control period, seconds.
    n_agents : int
    start : (n_agents, d) ndarray, metres
    max_speed : float
        Platform speed limit, m/s.
    gas_threshold : float
        The gas sensor's detection threshold (reading units).
    info : dict
        Scenario hints a method may use (e.g. the search-region bounds), documented per scenario.
    """

    arena: Arena
    dt: float
    n_agents: int
    start: np.ndarray
    max_speed: float
    gas_threshold: float = 0.0
    info: dict[str, Any] = field(default_factory=dict)


class Searcher(ABC):
    """Base class of search strategies.

    Subclasses keep their parameters immutable (a :class:`~odorloc.params.Params` in
    ``self.params``) and all evolving state in attributes reset by :meth:`reset`.
    """

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Prepare for a new episode."""
        self.ctx = ctx

    @abstractmethod
    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Choose the next commands from this step's observations (one per agent)."""

    def belief(self) -> Any | None:
        """The current belief (a ParticleBelief, GridBelief, map...) for recording, or ``None``."""
        return None

    def diagnostics(self) -> dict[str, float]:
        """Scalars worth recording each step (entropy, phase code, ...). Default none."""
        return {}
