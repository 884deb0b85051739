"""Wheeled ground robots: holonomic and unicycle (differential-drive) kinematics.

Defaults follow a TurtleBot3 Burger, the robot class of the indoor particle-filter paper: maximum
linear speed 0.22 m/s and maximum turn rate 2.84 rad/s (manufacturer limits), body radius
0.105 m available through ``radius`` (the default 0 treats the robot as a point).
The virtual-physics paper moves robots by fixed steps (0.12 m per step for robots, 0.06 m for the
virtual robot); such step sizes are ``move`` commands here, limited by ``max_speed``.

In a 3D arena a holonomic robot moves freely in 3D; a unicycle moves in the horizontal plane at
its start height (vertical command components are ignored).
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Command
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import wrap_angle
from odorloc.platforms.base import Platform

_EPS = 1e-12


class HolonomicParams(Params):
    """Parameters of :class:`HolonomicRobot`.

    max_speed : float, m/s
        Speed limit; velocity commands are scaled down to it, keeping their direction.
    radius : float, metres
        Body radius for collision checks (0 = point robot).
    energy_per_metre : float, J/m
        Simple locomotion energy model, ``E = energy_per_metre * path_length`` (default 0: none).
    """

    max_speed: Positive = 0.22
    radius: NonNegative = 0.0
    energy_per_metre: NonNegative = 0.0


class UnicycleParams(HolonomicParams):
    """Parameters of :class:`UnicycleRobot`: those of :class:`HolonomicParams` plus

    max_turn_rate : float, rad/s
        Maximum yaw rate (TurtleBot3 Burger: 2.84 rad/s).
    """

    max_turn_rate: Positive = 2.84


class WheeledRobot(Platform):
    """Common part of the wheeled robots: readiness and the per-metre energy model."""

    params: HolonomicParams

    def __init__(self, params: HolonomicParams | None = None) -> None:
        super().__init__(params if params is not None else self._default_params())
        self.radius = float(self.params.radius)
        self._done = True

    @classmethod
    def _default_params(cls) -> HolonomicParams:
        return HolonomicParams()

    def _reset_state(self) -> None:
        self._done = True

    def _start(self, command: Command) -> None:
        self._done = command.kind not in ("waypoint", "move")

    @property
    def ready(self) -> bool:
        """``True`` unless a waypoint/move is still under way."""
        return self._done

    @property
    def speed_limit(self) -> float:
        """Maximum linear speed, m/s."""
        return float(self.params.max_speed)

    def energy_breakdown(self) -> dict[str, float]:
        """``{"move": energy_per_metre * path_length}``, J."""
        return {"move": float(self.params.energy_per_metre) * self.path_length}

    def _face(self, displacement: np.ndarray) -> None:
        # Heading follows the horizontal direction of motion; pure vertical motion keeps it.
        if math.hypot(displacement[0], displacement[1]) > _EPS:
            self._heading = math.atan2(displacement[1], displacement[0])


@register("platform", "holonomic", HolonomicParams, "holonomic wheeled robot (omnidirectional)")
class HolonomicRobot(WheeledRobot):
    """A robot that can move in any direction at up to ``max_speed`` without turning first.

    Velocity commands are clipped to ``max_speed`` in norm (direction kept); waypoints and moves
    are approached in a straight line at ``max_speed``. The heading follows the direction of
    motion.
    """

    def _advance(self, dt: float, arena: Arena) -> None:
        cmd = self._command
        if cmd is None or cmd.kind == "hold":
            return
        pos = self._require_reset()
        vmax = self.speed_limit
        if cmd.kind == "velocity":
            v = cmd.value
            s = float(np.linalg.norm(v))
            if s <= _EPS:
                return
            end = pos + v * (min(s, vmax) / s) * dt
            self._translate(end, arena)
            self._face(end - pos)
            return
        if self._done or self._target is None:
            return
        d = self._target - pos
        dist = float(np.linalg.norm(d))
        if dist <= _EPS:
            self._done = True
            return
        step = vmax * dt
        end = self._target.copy() if step >= dist else pos + d * (step / dist)
        blocked = self._translate(end, arena)
        self._face(d)
        if blocked or step >= dist:
            self._done = True


@register("platform", "unicycle", UnicycleParams, "differential-drive robot (unicycle model)")
class UnicycleRobot(WheeledRobot):
    """A differential-drive robot: speed up to ``max_speed``, yaw rate up to ``max_turn_rate``.

    Execution within a period is *turn, then drive*: the robot first rotates in place at
    ``max_turn_rate`` towards the commanded direction (shortest way; an error of exactly pi turns
    counter-clockwise), then drives straight for the rest of the period. A large direction change
    therefore costs ``|angle| / max_turn_rate`` seconds without translation (e.g. 90 degrees:
    0.553 s at 2.84 rad/s); paths are polylines, which keeps collision checks exact. The robot
    never drives backwards: a ``move`` behind it is a half turn, then forward.

    Velocity commands give the world-frame direction and speed (clipped to ``max_speed``);
    waypoints and moves are driven at ``max_speed``.
    """

    params: UnicycleParams

    @classmethod
    def _default_params(cls) -> UnicycleParams:
        return UnicycleParams()

    def _turn_towards(self, psi: float, dt: float) -> float:
        """Rotate towards heading ``psi`` for at most ``dt`` s; return the time left after it."""
        err = wrap_angle(psi - self._heading)
        if abs(err) <= _EPS:
            self._heading = wrap_angle(psi)
            return dt
        w = float(self.params.max_turn_rate)
        need = abs(err) / w
        if need <= dt:
            self._heading = wrap_angle(psi)
            return dt - need
        self._heading = wrap_angle(self._heading + math.copysign(w * dt, err))
        return 0.0

    def _advance(self, dt: float, arena: Arena) -> None:
        cmd = self._command
        if cmd is None or cmd.kind == "hold":
            return
        pos = self._require_reset()
        if cmd.kind == "velocity":
            vx, vy = float(cmd.value[0]), float(cmd.value[1])
            s = min(math.hypot(vx, vy), self.speed_limit)
            if s <= _EPS:
                return
            left = self._turn_towards(math.atan2(vy, vx), dt)
            if left > 0.0:
                self._translate(pos + self._forward() * (s * left), arena)
            return
        if self._done or self._target is None:
            return
        d = self._target - pos
        if d.size == 3:
            d[2] = 0.0  # planar robot: the target height is ignored
        dist = float(np.linalg.norm(d))
        if dist <= _EPS:
            self._done = True
            return
        left = self._turn_towards(math.atan2(d[1], d[0]), dt)
        if left <= 0.0:
            return
        step = self.speed_limit * left
        end = pos + d if step >= dist else pos + self._forward() * step
        blocked = self._translate(end, arena)
        if blocked or step >= dist:
            self._done = True

    def _forward(self) -> np.ndarray:
        f = np.zeros(self.dim)
        f[0], f[1] = math.cos(self._heading), math.sin(self._heading)
        return f
