"""Forces between groups of a virtual-physics search: repulsion, forbidden areas, rotary bypass.

The virtual-physics paper (``shared/papers/virtual-physics-multi-group.txt``, Sec. 2.2.2.2)
coordinates groups through their virtual robots only:

- **repulsion** (eqs. 9-10): a virtual robot closer than ``5 r`` to another group's is pushed
  away from it by a unit force, added to its goal force, ``F' = F + f_v``;
- **forbidden area** (eq. 11): once a group has located a source, the circle of radius ``r_T``
  around its virtual robot is closed to the other groups;
- **rotary force** (eqs. 12-16): a group whose goal force would take its virtual robot into a
  forbidden circle goes around it instead, along the tangent ``(y2 - y1, -(x2 - x1))``
  (clockwise, eq. 14) or its opposite (counter-clockwise, eq. 15), normalised (eq. 16). The
  sense follows eq. 13: clockwise when ``theta_1 <= theta_2``, with ``theta_1`` the direction from
  the group's virtual robot to the located group's and ``theta_2`` that of its goal force -- the
  group turns to the side its goal force already leans to. "Once the virtual robot of group 2
  chose a rotary method (clockwise or counter clockwise), it should keep on until it escaped
  from source 1", which reads two ways (:class:`Bypass`, ``escape``): escaped when the goal force
  no longer points towards the located group (``"goal-away"``: ``|theta_1 - theta_2| >= pi/2``,
  where the paper lets the ordinary goal force take it away), or as soon as a step along the
  goal force no longer enters the forbidden circle (``"clear"``: the group has got round it),
  the chosen sense then kept for every later approach to the same circle.

Angles are compared on the circle (``theta_2 - theta_1`` wrapped to ``(-pi, pi]``), which is the
paper's comparison wherever the two angles do not straddle the x axis.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.geometry.vectors import wrap_angle

__all__ = [
    "Bypass",
    "Escape",
    "Sense",
    "in_forbidden_area",
    "repulsion",
    "rotary_force",
    "rotary_sense",
]

FloatArray = NDArray[np.float64]
Sense = Literal["cw", "ccw"]
Escape = Literal["goal-away", "clear"]
_EPS = 1e-12


def _unit(v: np.ndarray) -> FloatArray | None:
    n = float(np.linalg.norm(v))
    return None if n <= _EPS else v / n


def repulsion(own: ArrayLike, others: ArrayLike, reach: float) -> FloatArray:
    """Sum of unit pushes away from every other virtual robot closer than ``reach`` (eq. 9).

    Parameters
    ----------
    own : (d,) array_like, metres
        This group's virtual robot.
    others : (M, d) array_like, metres
        The other groups' virtual robots (``M`` may be 0).
    reach : float, metres
        Range of the repulsion (``5 r`` in the paper); strictly closer robots repel.

    Returns
    -------
    (d,) ndarray
        ``sum (x_own - x_j) / |x_own - x_j|`` over the others within ``reach`` (zero when none;
        a robot at exactly the same point exerts no force, its direction being undefined).
    """
    x = np.asarray(own, float)
    o = np.asarray(others, float).reshape(-1, x.size)
    rel = x - o
    dist = np.linalg.norm(rel, axis=1)
    near = (dist < reach) & (dist > _EPS)
    if not near.any():
        return np.zeros_like(x)
    return (rel[near] / dist[near, None]).sum(axis=0)


def in_forbidden_area(point: ArrayLike, centre: ArrayLike, r_T: float) -> bool:
    """``True`` when ``point`` lies in the closed circle of radius ``r_T`` around ``centre``
    (eq. 11)."""
    p = np.asarray(point, float)[:2]
    c = np.asarray(centre, float)[:2]
    return bool(np.sum((p - c) ** 2) <= r_T * r_T)


def rotary_force(own: ArrayLike, located: ArrayLike, sense: Sense) -> FloatArray:
    """Unit rotary force of a virtual robot at ``own`` around one at ``located`` (eqs. 14-16).

    ``cw``: ``(y2 - y1, -(x2 - x1))`` normalised, which moves ``own`` clockwise around
    ``located``; ``ccw``: its opposite. In 3-D the force is horizontal.
    """
    x = np.asarray(own, float)
    c = np.asarray(located, float)
    dx, dy = float(x[0] - c[0]), float(x[1] - c[1])
    f = np.zeros_like(x)
    f[0], f[1] = (dy, -dx) if sense == "cw" else (-dy, dx)
    u = _unit(f)
    return np.zeros_like(x) if u is None else u


def _angles(own: np.ndarray, located: np.ndarray, goal: np.ndarray) -> float:
    """``theta_2 - theta_1`` wrapped to ``(-pi, pi]`` (see the module docstring)."""
    rel = located - own
    theta1 = math.atan2(float(rel[1]), float(rel[0]))
    theta2 = math.atan2(float(goal[1]), float(goal[0]))
    return wrap_angle(theta2 - theta1)


def rotary_sense(own: ArrayLike, located: ArrayLike, goal: ArrayLike) -> Sense:
    """Eq. 13: clockwise when ``theta_1 <= theta_2``, else counter-clockwise."""
    x, c, g = (np.asarray(v, float) for v in (own, located, goal))
    return "cw" if _angles(x, c, g) >= 0.0 else "ccw"


class Bypass:
    """One group's handling of the forbidden areas of located groups (eqs. 11-16).

    Parameters
    ----------
    r_T : float, metres
        Radius of a forbidden circle.
    rotary : bool
        Go around a forbidden circle by the rotary force; ``False``: a step into it is refused
        (the virtual robot waits where it is).
    release : float, metres
        An engaged group farther than this from the located group counts as escaped (a guard
        for groups pushed away by other forces; default ``2 r_T``); with ``escape="clear"`` the
        remembered sense is forgotten there too.
    escape : {"goal-away", "clear"}
        When the group has escaped (see the module docstring).

    Attributes
    ----------
    engaged : dict of int to str
        The rotary sense chosen for each located group the group is going around.
    """

    def __init__(
        self,
        r_T: float,
        rotary: bool = True,
        release: float | None = None,
        escape: Escape = "goal-away",
    ) -> None:
        self.r_T = float(r_T)
        self.rotary = bool(rotary)
        self.release = 2.0 * self.r_T if release is None else float(release)
        self.escape: Escape = escape
        self.engaged: dict[int, Sense] = {}
        self._kept: dict[int, Sense] = {}

    def reset(self) -> None:
        """Forget every engagement."""
        self.engaged = {}
        self._kept = {}

    def steer(
        self,
        own: ArrayLike,
        goal: ArrayLike | None,
        located: Mapping[int, ArrayLike],
        step: float,
    ) -> tuple[FloatArray | None, str]:
        """The direction to step this period, and why.

        Parameters
        ----------
        own : (d,) array_like, metres
            This group's virtual robot.
        goal : (d,) array_like or None
            Its unit goal force ``F'(VG)`` (``None``: no goal force, the group waits).
        located : dict of int to (d,) array_like
            Virtual robots of the groups that have located a source, by an id of the group.
        step : float, metres
            Length of the coming step (``s1``).

        Returns
        -------
        direction : (d,) ndarray or None
            Unit direction, or ``None`` to stay.
        reason : str
            ``"goal"``, ``"rotary"``, ``"blocked"`` (a step into a forbidden circle refused) or
            ``"idle"`` (no goal force).
        """
        x = np.asarray(own, float)
        for gid in list(self.engaged):
            if gid not in located:
                del self.engaged[gid]
        if goal is None:
            return None, "idle"
        g = np.asarray(goal, float)
        # Nearest located groups first: the closest circle is the one in the way.
        order = sorted(located, key=lambda k: float(np.linalg.norm(np.asarray(located[k]) - x)))
        for gid in order:
            c = np.asarray(located[gid], float)
            dist = float(np.linalg.norm(c[:2] - x[:2]))
            if dist > self.release:
                self._kept.pop(gid, None)
            towards = abs(_angles(x, c, g)) < 0.5 * math.pi
            blocked = towards and in_forbidden_area(x + step * g, c, self.r_T)
            if gid in self.engaged:
                held = blocked if self.escape == "clear" else towards
                if held and dist <= self.release:
                    return rotary_force(x, c, self.engaged[gid]), "rotary"
                del self.engaged[gid]  # escaped
            if blocked:
                if not self.rotary:
                    return None, "blocked"
                sense = self._kept.get(gid) or rotary_sense(x, c, g)
                if self.escape == "clear":
                    self._kept[gid] = sense
                self.engaged[gid] = sense
                return rotary_force(x, c, sense), "rotary"
        return g, "goal"
