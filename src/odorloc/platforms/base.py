"""The platform interface: how one agent's body executes motion commands.

A platform turns the searcher's :class:`~odorloc.searchers.base.Command` into motion, one control
period at a time, and keeps the agent's kinematic and energy state. One instance per agent;
parameters are an immutable :class:`~odorloc.core.params.Params`, everything that evolves lives in
attributes reset by :meth:`Platform.reset`.

Command semantics shared by every platform
------------------------------------------
``velocity``
    Move with the given world-frame velocity (m/s, clipped to the platform's limits); it stays in
    force (a ``None`` command continues it) until another command arrives. Always ``ready``.
``waypoint``
    Go to an absolute position over as many periods as needed; ``ready`` once reached (and, for
    platforms that hover, once the hover there is done). Re-sending the *same* waypoint while it
    is active or already reached continues it instead of restarting it, so searchers may re-issue
    their target every period; re-sent after it was stopped short by an obstacle, a wall or
    another body (and the platform is ready), it is a new attempt from where the platform stands.
``move``
    Like ``waypoint`` with target ``position + value`` fixed when the command is received; every
    ``move`` command is a new displacement.
``hold``
    Stop where you are.

Collisions: platforms never pass through obstacles or arena walls. A straight motion is cut at the
last free point (:meth:`~odorloc.geometry.arena.Arena.first_hit`); the period counts as one blocked
move (:attr:`Platform.collided`). A waypoint or move that is blocked ends there (the platform
becomes ``ready``), so a searcher waiting on ``ready`` never waits for an unreachable target.
With a body ``radius > 0`` the check also follows points on the body outline (a circle in the
horizontal plane; in 3D also the top and bottom points), spaced at most half an occupancy cell
apart. Outline points that already start inside an obstacle (a start pose touching a wall) do not
constrain that motion, so such a robot can drive away.

Other bodies: :meth:`Platform.apply` may be given the other agents' bodies (centres and radii).
A motion is then also cut where this body (a disc, a ball in 3-D) would first touch one of them
(:func:`body_contact_fraction`); the episode moves its agents one after another against the
others' current positions, so that no body ever enters another's footprint. Bodies that already
overlap (a start pose) may move apart but not closer.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.types import Command
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import wrap_angle

_KINDS = ("velocity", "waypoint", "move", "hold")
_SAME_WAYPOINT_TOL = 1e-9  # metres; a re-sent waypoint closer than this is the same one


@lru_cache(maxsize=64)
def _outline_offsets(dim: int, radius: float, resolution: float) -> np.ndarray:
    """Points on a body outline of ``radius`` relative to its centre, ``(K, dim)`` metres."""
    # Spacing <= half a cell so that no occupied cell fits between two outline points.
    n = max(8, math.ceil(2.0 * math.pi * radius / (0.5 * resolution)))
    a = np.arange(n) * (2.0 * math.pi / n)
    ring = radius * np.column_stack([np.cos(a), np.sin(a)])
    if dim == 2:
        out = ring
    else:
        out = np.vstack(
            [np.column_stack([ring, np.zeros(n)]), [[0.0, 0.0, radius], [0.0, 0.0, -radius]]]
        )
    out.setflags(write=False)
    return out


def _box_fraction(
    start: list[float], end: list[float], lo: list[float], hi: list[float]
) -> float | None:
    """Largest ``s`` in [0, 1] keeping ``start + s (end - start)`` in the box ``[lo, hi]``, or
    ``None`` when ``start`` is outside the box.

    In Python floats (the same IEEE arithmetic as NumPy's, without its overhead on three
    numbers): platforms call this every moving step.
    """
    s = 1.0
    for a0, b, lo_, hi_ in zip(start, end, lo, hi, strict=True):
        if not lo_ <= a0 <= hi_:
            return None
        d = b - a0
        if d > 0.0 and b > hi_:
            s = min(s, (hi_ - a0) / d)
        elif d < 0.0 and b < lo_:
            s = min(s, (lo_ - a0) / d)
    return max(s, 0.0)


def free_fraction(arena: Arena, start: np.ndarray, end: np.ndarray, radius: float = 0.0) -> float:
    """Fraction in [0, 1] of the straight motion ``start -> end`` that a body can travel freely.

    Parameters
    ----------
    arena : Arena
    start, end : (d,) ndarray, metres
        Centre of the body before and after the (unobstructed) motion.
    radius : float, metres
        Body radius; 0 treats the body as a point.

    Returns
    -------
    float
        1.0 when the whole motion is free, else the fraction up to the last free sample
        (:meth:`~odorloc.geometry.arena.Arena.first_hit`; exact in an arena without obstacles).
    """
    if arena.occ is None:
        # An empty box is convex: the free fraction is where the segment meets the (shrunk) walls.
        lo = (arena.lo + radius).tolist()
        hi = (arena.hi - radius).tolist()
        frac = _box_fraction(start.tolist(), end.tolist(), lo, hi)
        if frac is not None:
            return frac
    frac = float(arena.first_hit(start, end)[0])
    if radius > 0.0 and frac > 0.0:
        off = _outline_offsets(arena.dim, float(radius), float(arena.resolution))
        a = start[None, :] + off
        b = end[None, :] + off
        # Outline points starting inside an obstacle would pin the body forever; ignore them.
        ok = arena.is_free(a)
        if ok.any():
            frac = min(frac, float(arena.first_hit(a[ok], b[ok]).min()))
    return frac


def body_contact_fraction(
    start: np.ndarray,
    end: np.ndarray,
    radius: float,
    centres: np.ndarray,
    radii: np.ndarray,
) -> float:
    """Fraction in [0, 1] of the straight motion ``start -> end`` before a body of ``radius``
    touches one of the bodies at ``centres`` ``(M, d)`` with ``radii`` ``(M,)`` (metres).

    Contact is at centre distance ``radius + radii[j]``. A body already touching or overlapping
    another may move away from it (or along it) but not towards it (fraction 0).
    """
    c = np.asarray(centres, float).reshape(-1, start.size)
    if len(c) == 0:
        return 1.0
    d = end - start
    a = float(d @ d)
    if a == 0.0:
        return 1.0
    R = radius + np.asarray(radii, float).reshape(-1)
    rel = start - c  # (M, d)
    dist2 = np.einsum("md,md->m", rel, rel)
    # only bodies within reach of the motion can be touched
    reach = R + math.sqrt(a)
    near = dist2 < reach * reach
    if not near.any():
        return 1.0
    rel, R, dist2 = rel[near], R[near], dist2[near]
    b = 2.0 * (rel @ d)
    cc = dist2 - R * R
    touching = cc <= 0.0
    if np.any(touching & (b < 0.0)):
        return 0.0
    ahead = ~touching & (b < 0.0)
    disc = b * b - 4.0 * a * cc
    hit = ahead & (disc > 0.0)
    if not hit.any():
        return 1.0
    s = (-b[hit] - np.sqrt(disc[hit])) / (2.0 * a)
    s = s[(s >= 0.0) & (s < 1.0)]
    return float(s.min()) if s.size else 1.0


class Platform(ABC):
    """Base class of robot and UAV platforms (one instance per agent).

    Subclasses implement :meth:`_start` (a new command arrived), :meth:`_advance` (execute the
    current command for one period), :attr:`ready` and :attr:`speed_limit`; straight motions go
    through :meth:`_translate`, which handles collisions and the path length.

    Parameters
    ----------
    params : Params
        The platform's immutable parameters.
    """

    params: Params
    #: Body radius used for collision checks, metres (0 = point).
    radius: float = 0.0

    def __init__(self, params: Params) -> None:
        self.params = params
        self._pos: np.ndarray | None = None
        self._heading = 0.0
        self._vel = np.zeros(0)
        self._path = 0.0
        self._collided = 0
        self._blocked = False
        self._stopped_short = False
        self._command: Command | None = None
        self._target: np.ndarray | None = None
        self._checked_arena: Arena | None = None
        self._bodies: tuple[np.ndarray, np.ndarray] | None = None

    # ------------------------------------------------------------------ lifecycle
    def reset(self, position: ArrayLike, heading: float = 0.0) -> None:
        """Place the platform at ``position`` (``(d,)`` metres, d in {2, 3}) facing ``heading``.

        ``heading`` is the angle in the horizontal plane, rad (x axis = 0, counter-clockwise).
        Clears the command, the path length, the collision count and the energy used.
        """
        p = np.array(position, dtype=float)
        if p.ndim != 1 or p.size not in (2, 3):
            raise ConfigError("position", f"expected 2 or 3 coordinates, got shape {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ConfigError("position", "must be finite")
        if not math.isfinite(heading):
            raise ConfigError("heading", "must be finite")
        self._pos = p
        self._heading = wrap_angle(float(heading))
        self._vel = np.zeros_like(p)
        self._path = 0.0
        self._collided = 0
        self._blocked = False
        self._stopped_short = False
        self._command = None
        self._target = None
        self._checked_arena = None
        self._reset_state()

    def _reset_state(self) -> None:  # noqa: B027
        """Clear subclass state at :meth:`reset`; default nothing."""

    def apply(
        self,
        command: Command | None,
        dt: float,
        arena: Arena,
        bodies: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """Execute ``command`` for one control period.

        Parameters
        ----------
        command : Command or None
            The new command; ``None`` continues the current one.
        dt : float
            Control period, seconds.
        arena : Arena
            The map whose walls and obstacles stop the platform.
        bodies : ((M, d) ndarray, (M,) ndarray), optional
            Centres (metres) and radii (metres) of other bodies that stop the platform like
            obstacles do (held still during this period).
        """
        pos = self._require_reset()
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError("dt", f"must be a finite number > 0, got {dt}")
        if arena is not self._checked_arena:
            self._check_arena(arena)
        if command is not None:
            cmd = self._validate(command)
            if not self._continues_current(cmd):
                self._command = cmd
                self._stopped_short = False
                if cmd.kind == "waypoint":
                    self._target = cmd.value.copy()
                elif cmd.kind == "move":
                    self._target = pos + cmd.value
                else:
                    self._target = None
                self._start(cmd)
        start = pos.copy()
        self._blocked = False
        self._bodies = bodies
        try:
            self._advance(float(dt), arena)
        finally:
            self._bodies = None
        if self._blocked:
            self._stopped_short = True
        self._vel = (self._pos - start) / dt

    def _check_arena(self, arena: Arena) -> None:
        pos = self._require_reset()
        if arena.dim != pos.size:
            raise ConfigError(
                "position", f"has {pos.size} coordinates but the arena is {arena.dim}D"
            )
        if not arena.is_free(pos)[0]:
            raise ConfigError(
                "position", f"{pos.tolist()} is outside the arena or inside an obstacle"
            )
        self._checked_arena = arena

    def _validate(self, command: Command) -> Command:
        if command.kind not in _KINDS:
            raise ConfigError("command.kind", f"unknown kind {command.kind!r} (known: {_KINDS})")
        if command.kind == "hold":
            return command
        v = np.asarray(command.value, dtype=float)
        if v.shape != (self.dim,):
            raise ConfigError(
                "command.value", f"{command.kind} needs shape ({self.dim},), got {v.shape}"
            )
        if not np.all(np.isfinite(v)):
            raise ConfigError("command.value", "must be finite")
        return Command(command.kind, v)

    def _continues_current(self, cmd: Command) -> bool:
        cur = self._command
        # A waypoint given up at a block is retried, or a body that has since moved out of the
        # way would keep a searcher that re-issues its target frozen for good.
        return (
            cmd.kind == "waypoint"
            and cur is not None
            and cur.kind == "waypoint"
            and float(np.max(np.abs(cmd.value - cur.value))) <= _SAME_WAYPOINT_TOL
            and not (self._stopped_short and self.ready)
        )

    def _require_reset(self) -> np.ndarray:
        if self._pos is None:
            raise RuntimeError(f"{type(self).__name__}: call reset(position, heading) first")
        return self._pos

    # ------------------------------------------------------------------ subclass hooks
    @abstractmethod
    def _start(self, command: Command) -> None:
        """React to a newly received (validated) command; ``self._target`` is already set."""

    @abstractmethod
    def _advance(self, dt: float, arena: Arena) -> None:
        """Execute the current command for ``dt`` seconds."""

    def _translate(self, end: np.ndarray, arena: Arena) -> bool:
        """Move straight towards ``end`` as far as free space allows; ``True`` if blocked."""
        pos = self._require_reset()
        if end.tolist() == pos.tolist():
            return False
        frac = free_fraction(arena, pos, end, self.radius)
        if self._bodies is not None and frac > 0.0:
            frac = min(frac, body_contact_fraction(pos, end, self.radius, *self._bodies))
        blocked = frac < 1.0
        if not blocked:
            new = end.copy()
        else:
            new = pos + frac * (end - pos)
            if arena.occ is None:
                # Keep rounding from leaving the box, which would pin the body at the wall.
                r = self.radius
                new = np.clip(new, np.minimum(arena.lo + r, pos), np.maximum(arena.hi - r, pos))
        step = new - pos
        # numpy.linalg.norm of a vector is sqrt(v . v); called directly (every moving step)
        self._path += math.sqrt(float(step.dot(step)))
        self._pos = new
        if blocked:
            self._collided += 1
            self._blocked = True
        return blocked

    # ------------------------------------------------------------------ state
    @property
    def dim(self) -> int:
        """Number of spatial dimensions (2 or 3)."""
        return int(self._require_reset().size)

    @property
    def position(self) -> np.ndarray:
        """Current position, ``(d,)`` metres (a copy)."""
        return self._require_reset().copy()

    @property
    def heading(self) -> float:
        """Heading in the horizontal plane, rad in ``(-pi, pi]`` (x axis = 0, counter-clockwise)."""
        return self._heading

    @property
    def velocity(self) -> np.ndarray:
        """Average velocity over the last period, ``(d,)`` m/s."""
        return self._vel.copy()

    @property
    def path_length(self) -> float:
        """Distance travelled since :meth:`reset`, metres."""
        return self._path

    @property
    def collided(self) -> int:
        """Number of periods in which a motion was stopped by an obstacle or wall."""
        return self._collided

    @property
    def blocked(self) -> bool:
        """``True`` when the last period's motion was stopped by an obstacle or wall."""
        return self._blocked

    @property
    def command(self) -> Command | None:
        """The command in force (``None`` before the first one)."""
        return self._command

    @property
    def target(self) -> np.ndarray | None:
        """The current waypoint/move target, ``(d,)`` metres, or ``None``."""
        return None if self._target is None else self._target.copy()

    @property
    def energy(self) -> float:
        """Energy used since :meth:`reset`, J."""
        return float(sum(self.energy_breakdown().values()))

    def energy_breakdown(self) -> dict[str, float]:
        """Energy used per component, J. Default: no energy model."""
        return {}

    @property
    def exhausted(self) -> bool:
        """``True`` once the energy budget is used up (platforms without a budget: never)."""
        return False

    @property
    def stats(self) -> dict[str, float]:
        """Time and count totals since :meth:`reset` (e.g. flying, hovering and turning time
        of a UAV); default none. The episode reports them per team and for the agent that
        reaches a source first."""
        return {}

    def charge_comm(self, nbytes: float) -> float:
        """Charge transmitting ``nbytes`` bytes (summed over recipients); return the J charged.

        Platforms without an energy model charge nothing.
        """
        return 0.0

    def charge_compute(self, nbits: float) -> float:
        """Charge processing ``nbits`` bits; return the J charged (default: nothing)."""
        return 0.0

    @property
    @abstractmethod
    def ready(self) -> bool:
        """``True`` when idle or the current waypoint/move (and any hover) is done."""

    @property
    @abstractmethod
    def speed_limit(self) -> float:
        """Maximum translational speed, m/s."""

    def state(self) -> dict[str, float | np.ndarray]:
        """A snapshot for recording: position, heading, velocity, path length, energy."""
        return {
            "position": self.position,
            "heading": self.heading,
            "velocity": self.velocity,
            "path_length": self.path_length,
            "energy": self.energy,
            "collided": float(self.collided),
        }
