"""The neutral interface types every part of odorloc speaks.

A control period (default 0.5 s) flows like this::

    episode --Observation per agent--> searcher --Action--> episode --Command--> platform

An :class:`Action` carries one :class:`Command` per controlled agent, the messages each agent
broadcasts to its neighbours, any :class:`Declaration` of source positions (a searcher may declare
one source for one group and keep going) and the computation work done (charged to platforms with
an energy model). What a searcher may know before the episode starts is a typed
:class:`SearchContext`: agent ids, groups and their start sets, the search region, per-agent speed
limits and the gas sensor's detection threshold with its unit. The episode reports what happened
as :class:`Event` records.

These types depend on nothing but NumPy and the arena, so platforms, searchers, the engine and the
environment adapters can all use them without importing each other.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    from odorloc.geometry.arena import Arena

__all__ = [
    "Action",
    "ArrayPayload",
    "Command",
    "CommandKind",
    "Declaration",
    "Event",
    "EventKind",
    "Group",
    "Message",
    "Observation",
    "Payload",
    "Region",
    "SearchContext",
    "SensorInfo",
    "frozen_array",
]

CommandKind = Literal["velocity", "waypoint", "move", "hold"]

Region = tuple[tuple[float, ...], tuple[float, ...]]
"""An axis-aligned box ``(lower, upper)``, metres (2 or 3 components each)."""


class Payload(ABC):
    """What one agent tells its neighbours: a small frozen dataclass with a declared size.

    Subclasses name their fields (a Gaussian fit's mean and covariance, a group's virtual
    robot) and say how many bytes a radio would send for them (:attr:`nbytes`, charged once per
    recipient: eq. 8 of the multi-UAV paper). Receivers read the fields, never a dict of names.
    Arrays in a payload are read-only copies (:func:`frozen_array`), so a sender changing its
    state later never changes what was sent.
    """

    @property
    @abstractmethod
    def nbytes(self) -> int:
        """Bytes a radio would send for this payload."""


def frozen_array(value: Any, dtype: Any = float) -> np.ndarray:
    """A read-only copy of ``value`` as an array of ``dtype`` (for payload fields)."""
    a = np.array(value, dtype=dtype)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class ArrayPayload(Payload):
    """Named arrays of numbers (a generic payload, e.g. what a learned policy broadcasts);
    its size is the sum of the arrays' ``nbytes``."""

    arrays: Mapping[str, np.ndarray]

    def __post_init__(self) -> None:
        out = {}
        for k, v in self.arrays.items():
            a = np.array(v)
            if a.dtype.hasobject:
                raise ValueError(f"payload field {k!r} is not an array of numbers")
            a.setflags(write=False)
            out[str(k)] = a
        object.__setattr__(self, "arrays", out)

    @property
    def nbytes(self) -> int:
        return int(sum(a.nbytes for a in self.arrays.values()))

    def __getitem__(self, key: str) -> np.ndarray:
        return self.arrays[key]

    def __contains__(self, key: object) -> bool:
        return key in self.arrays


@dataclass(frozen=True, eq=False)
class Message:
    """A payload broadcast by agent ``sender``; ``nbytes`` is charged once per recipient."""

    sender: int
    payload: Payload

    @property
    def nbytes(self) -> int:
        """The payload's declared size in bytes (what a radio would send)."""
        return int(self.payload.nbytes)


@dataclass(frozen=True, eq=False)
class Observation:
    """What one agent senses at one control step.

    Attributes
    ----------
    agent : int
        Agent id (its index in the scenario's ``agents.starts``), the same inside teams.
    t : float
        Time, seconds.
    position : (d,) ndarray, metres
    heading : float
        Heading angle, rad (x axis = 0, counter-clockwise).
    gas : float
        Gas sensor output after its processing, in the unit of
        :attr:`SearchContext.sensor` (concentration reading, or an encounter count).
    detection : bool
        Binarised reading (``gas`` at or above the sensor's threshold).
    wind : (d,) ndarray, m/s
        Anemometer reading of the air velocity, world frame.
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
    """A claim that source(s) lie at ``positions``.

    Attributes
    ----------
    positions : (K, d) ndarray, metres
    confidence : float
        The searcher's own confidence in ``[0, 1]`` (0 marks a fallback guess).
    agent : int, optional
        The declaring agent (teams set it; ``None`` for a central searcher).
    group : int, optional
        The declaring group (grouped teams set it).
    """

    positions: np.ndarray
    confidence: float = 1.0
    agent: int | None = None
    group: int | None = None

    def __post_init__(self) -> None:
        p = np.atleast_2d(np.asarray(self.positions, float))
        object.__setattr__(self, "positions", p)


@dataclass(frozen=True, eq=False, init=False)
class Action:
    """A searcher's answer for one control step.

    Parameters
    ----------
    commands : sequence of Command or None
        One per controlled agent, in the order of :attr:`SearchContext.agent_ids`; ``None``
        keeps the agent's current command.
    messages : dict of int to Payload
        Payload each agent (by id) broadcasts to its neighbours this step.
    declaration : Declaration, optional
        Shorthand for ``declarations=(declaration,)``.
    declarations : tuple of Declaration
        Declarations made this step. Whether one ends the episode is the scenario's rule
        (``task.end``), not the searcher's.
    compute_bits : dict of int to float
        Bits each agent processed this step (computation energy, eq. 7 of the multi-UAV paper).
    """

    commands: Sequence[Command | None]
    messages: Mapping[int, Payload]
    declarations: tuple[Declaration, ...]
    compute_bits: Mapping[int, float]

    def __init__(
        self,
        commands: Sequence[Command | None],
        messages: Mapping[int, Payload] | None = None,
        declaration: Declaration | None = None,
        declarations: Sequence[Declaration] = (),
        compute_bits: Mapping[int, float] | None = None,
    ) -> None:
        decl = tuple(declarations)
        if declaration is not None:
            decl = (*decl, declaration)
        object.__setattr__(self, "commands", commands)
        object.__setattr__(self, "messages", {} if messages is None else messages)
        object.__setattr__(self, "declarations", decl)
        object.__setattr__(self, "compute_bits", {} if compute_bits is None else compute_bits)


EventKind = Literal[
    "first_detection", "declaration", "source_found", "source_reached", "energy", "end"
]


@dataclass(frozen=True, eq=False)
class Event:
    """Something the episode recorded at time ``t``.

    Attributes
    ----------
    t : float, seconds
    kind : str
        ``first_detection`` (an agent's first detection), ``declaration`` (a searcher declared),
        ``source_found`` (a true source got a declared position within the success radius for
        the first time), ``source_reached`` (an agent came within the reach radius of a
        source), ``energy`` (a platform's budget ran out), ``end`` (the episode ended; ``detail``
        names the termination).
    agent, group, source : int, optional
        Who and what the event concerns.
    position : (d,) or (K, d) ndarray, optional, metres
    detail : str
    """

    t: float
    kind: EventKind
    agent: int | None = None
    group: int | None = None
    source: int | None = None
    position: np.ndarray | None = None
    detail: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Plain-data form (JSON serialisable)."""
        return {
            "t": self.t,
            "kind": self.kind,
            "agent": self.agent,
            "group": self.group,
            "source": self.source,
            "position": None if self.position is None else np.asarray(self.position).tolist(),
            "detail": self.detail,
        }


@dataclass(frozen=True)
class SensorInfo:
    """The gas sensor as a searcher may know it.

    Attributes
    ----------
    kind : str
        Registry name of the sensor (``concentration``, ``encounter``, ...).
    threshold : float
        Detection threshold, in ``unit``.
    unit : str
        Unit of readings and threshold (``"reading"``: the concentration sensor's output
        units; ``"hits"``: an encounter count per control period).
    binary : bool
        ``True`` when the reading itself is 0/1 (a binarised sensor).
    """

    kind: str = "concentration"
    threshold: float = 0.0
    unit: str = "reading"
    binary: bool = False


@dataclass(frozen=True)
class Group:
    """A named group of agents (e.g. a formation).

    Attributes
    ----------
    index : int
        Group number (the order of ``agents.groups`` in the scenario).
    name : str
    agents : tuple of int
        Agent ids in the group.
    """

    index: int
    name: str
    agents: tuple[int, ...]


@dataclass(frozen=True, eq=False)
class SearchContext:
    """What a searcher knows before the episode starts.

    Attributes
    ----------
    arena : Arena
        The map (bounds and obstacles), as a robot with a LiDAR map would know it.
    dt : float
        Control period, seconds.
    agent_ids : tuple of int
        The agents this searcher controls; observations and commands follow this order.
    start : (n_agents, d) ndarray, metres
        Start positions of those agents.
    speed_limits : (n_agents,) ndarray, m/s
        Each agent's platform speed limit.
    sensor : SensorInfo
        The gas sensor's kind, detection threshold and unit.
    groups : tuple of Group
        Groups of the scenario that contain controlled agents (empty: no groups).
    start_sets : dict of str to (n_groups, d) ndarray
        Named per-group start points (e.g. the virtual-physics paper's P1..P6).
    start_points : (K, d) ndarray
        Candidate single-agent start points of the scenario (e.g. the indoor paper's five).
    search_region : Region, optional
        The area the task asks to search or map, metres.
    comm_radius : float, metres
        Communication radius of the team (``inf``: everybody hears everybody).
    n_agents_total : int
        Agents in the whole scenario (a team member controls fewer).
    """

    arena: Arena
    dt: float
    agent_ids: tuple[int, ...]
    start: np.ndarray
    speed_limits: np.ndarray
    sensor: SensorInfo = SensorInfo()
    groups: tuple[Group, ...] = ()
    start_sets: Mapping[str, np.ndarray] = field(default_factory=dict)
    start_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    search_region: Region | None = None
    comm_radius: float = math.inf
    n_agents_total: int = 0

    def __post_init__(self) -> None:
        ids = tuple(int(a) for a in self.agent_ids)
        object.__setattr__(self, "agent_ids", ids)
        start = np.atleast_2d(np.asarray(self.start, float))
        if start.shape[0] != len(ids):
            raise ValueError(f"start has {start.shape[0]} rows for {len(ids)} agents")
        object.__setattr__(self, "start", start)
        sl = np.broadcast_to(np.asarray(self.speed_limits, float), (len(ids),)).copy()
        object.__setattr__(self, "speed_limits", sl)
        if self.n_agents_total < len(ids):
            object.__setattr__(self, "n_agents_total", len(ids))

    @property
    def n_agents(self) -> int:
        """Number of agents this searcher controls."""
        return len(self.agent_ids)

    @property
    def dim(self) -> int:
        """Spatial dimension (2 or 3)."""
        return self.arena.dim

    @property
    def max_speed(self) -> float:
        """The slowest controlled agent's speed limit, m/s (the limit of a single agent)."""
        return float(self.speed_limits.min()) if len(self.speed_limits) else 0.0

    @property
    def gas_threshold(self) -> float:
        """The gas sensor's detection threshold (in :attr:`SensorInfo.unit`)."""
        return self.sensor.threshold

    def index(self, agent: int) -> int:
        """Position of agent id ``agent`` in :attr:`agent_ids`."""
        try:
            return self.agent_ids.index(int(agent))
        except ValueError:
            raise KeyError(f"agent {agent} is not controlled here ({self.agent_ids})") from None

    def group_of(self, agent: int) -> Group | None:
        """The group that contains agent ``agent``, or ``None``."""
        for g in self.groups:
            if agent in g.agents:
                return g
        return None

    def subset(self, agent_ids: Sequence[int]) -> SearchContext:
        """The context of a team member controlling only ``agent_ids`` (kept in that order)."""
        rows = [self.index(a) for a in agent_ids]
        keep = set(int(a) for a in agent_ids)
        groups = tuple(g for g in self.groups if keep & set(g.agents))
        return replace(
            self,
            agent_ids=tuple(int(a) for a in agent_ids),
            start=self.start[rows],
            speed_limits=self.speed_limits[rows],
            groups=groups,
            n_agents_total=self.n_agents_total,
        )
