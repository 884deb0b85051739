"""A multirotor UAV with the time and energy model of the multi-UAV paper (MUC-OSL).

Kinematics (Sect. 5 of the paper): the UAV flies at a fixed speed (1 m/s), hovers a fixed time at
each measurement point (1 s) and spends a fixed time at each turning point (1 s), "slowing down in
one direction and speeding up in another without rotating the fuselage".

Energy (eqs. 4-9, multi-UAV paper), defaults measured on a DJI Matrice 100 (cited there):

- flying, eq. (4): ``E_f = P_f * l / v`` with ``P_f = 663 W`` (0.663 kJ/s);
- hovering, eq. (5): ``E_h = P_h * n_h * t_h`` with ``P_h = 470 W`` (0.47 kJ/s). The printed
  eq. (5) reads ``P_f n_h t_h``, a typo: its own left side is ``P_h T_h`` and the text defines
  ``P_h`` as the hovering power, so ``P_h`` is used;
- turning, eq. (6): ``E_b = n_b * e_b`` with ``e_b = 3415 J`` whatever the angle;
- computation, eq. (7): ``E_C = gamma_c * C * f_c**2 * N_c`` for ``N_c`` processed bits;
- communication, eq. (8): ``E_T = P_T * N_d / r_T`` for ``N_d`` transmitted bits;
- total, eq. (9): ``E = E_M + E_C + E_T`` with ``E_M = E_f + E_h + E_b``, subject to
  ``E <= E_max`` (``energy_limit``).

The paper gives no values for ``gamma_c, C, f_c, P_T, r_T``; the defaults are common values of
the mobile-edge-computing literature it cites (``gamma_c = 1e-28``, ``C = 1000`` cycles/bit,
``f_c = 1 GHz``, i.e. 0.1 uJ per processed bit; ``P_T = 0.1 W``, ``r_T = 1 Mbit/s``, i.e. 0.1 uJ
per sent bit). Both are negligible next to movement energy, as in the paper. Data amounts are
counted in bits, ``8 * nbytes``.
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from pydantic import AfterValidator

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Command
from odorloc.geometry.arena import Arena
from odorloc.platforms.base import Platform

_EPS = 1e-12


def _norm(v: np.ndarray) -> float:
    """``numpy.linalg.norm`` of a vector (``sqrt(v . v)``, the same float) without its overhead."""
    return math.sqrt(float(v.dot(v)))


def _positive_or_inf(v: float) -> float:
    if math.isnan(v) or v <= 0:
        raise ValueError("must be a number > 0 (inf for no limit)")
    return v


def _turn_angle(v: float) -> float:
    if not (math.isfinite(v) and 0 <= v < math.pi):
        raise ValueError("must be an angle in [0, pi) rad")
    return v


class UAVParams(Params):
    """Parameters of :class:`UAV` (defaults: DJI Matrice 100 values of the multi-UAV paper).

    speed : float, m/s
        Flying speed ``v`` (also the limit for velocity commands).
    hover_time : float, s
        Hover time ``t_h`` at each waypoint/move target (the measurement point).
    turn_time : float, s
        Time spent at each turning point.
    turn_angle : float, rad
        A new flight direction deviating from the previous one by more than this is a turning
        point. The paper counts every direction change whatever its angle; the small default
        (1 degree) only absorbs rounding.
    fly_power, hover_power : float, W
        ``P_f`` (eq. 4) and ``P_h`` (eq. 5).
    turn_energy : float, J
        ``e_b`` per turning point (eq. 6).
    idle_power : float, W
        Power while waiting with nothing to do (after a hover, or under ``hold``). The paper
        charges only hover points (eq. 5), hence 0; set it to ``hover_power`` to charge an airborne
        UAV for waiting too.
    capacitance, cycles_per_bit, cpu_frequency : float
        ``gamma_c`` (effective switched capacitance), ``C`` (CPU cycles per bit) and ``f_c`` (Hz)
        of eq. (7).
    transmit_power : float, W
        ``P_T`` of eq. (8).
    transmit_rate : float, bit/s
        ``r_T`` of eq. (8).
    energy_limit : float, J
        ``E_max`` of eq. (9); ``inf`` for none. A UAV that reaches it stops (``exhausted``).
    radius : float, metres
        Body radius for collision checks (0 = point).
    """

    speed: Positive = 1.0
    hover_time: NonNegative = 1.0
    turn_time: NonNegative = 1.0
    turn_angle: Annotated[float, AfterValidator(_turn_angle)] = math.radians(1.0)
    fly_power: NonNegative = 663.0
    hover_power: NonNegative = 470.0
    turn_energy: NonNegative = 3415.0
    idle_power: NonNegative = 0.0
    capacitance: NonNegative = 1e-28
    cycles_per_bit: NonNegative = 1000.0
    cpu_frequency: NonNegative = 1e9
    transmit_power: NonNegative = 0.1
    transmit_rate: Positive = 1e6
    energy_limit: Annotated[float, AfterValidator(_positive_or_inf)] = math.inf
    radius: NonNegative = 0.0


def movement_energy(params: UAVParams, distance: float, n_hovers: float, n_turns: float) -> float:
    """Movement energy ``E_M = E_f + E_h + E_b`` of a flight plan, J (eqs. 4-6, multi-UAV paper).

    Parameters
    ----------
    params : UAVParams
    distance : float
        Flown distance ``l``, metres.
    n_hovers : float
        Number of hover points ``n_h`` (each lasting ``hover_time``).
    n_turns : float
        Number of turning points ``n_b``.

    Returns
    -------
    float
        ``E_M``, J.

    Raises
    ------
    ConfigError
        When ``distance``, ``n_hovers`` or ``n_turns`` is negative or not finite (a negative
        count would subtract energy and a NaN would pass into every total built on it).
    """
    for name, v in (("distance", distance), ("n_hovers", n_hovers), ("n_turns", n_turns)):
        if not (math.isfinite(v) and v >= 0):
            raise ConfigError(name, f"must be a finite number >= 0, got {v}")
    e_f = params.fly_power * distance / params.speed  # eq. (4)
    e_h = params.hover_power * n_hovers * params.hover_time  # eq. (5), P_h (see module doc)
    e_b = n_turns * params.turn_energy  # eq. (6)
    return float(e_f + e_h + e_b)


@register("platform", "uav", UAVParams, "multirotor UAV with hover/turn/fly time and energy")
class UAV(Platform):
    """A multirotor UAV in 3D (or 2D) with the multi-UAV paper's timing and energy model.

    A ``waypoint`` or ``move`` is executed as *turn* (if the flight direction changes) ->
    *fly* (straight, at ``speed``) -> *hover* (``hover_time`` at the target); the phases use up
    control periods in order, spanning as many periods as needed, and the UAV is ``ready`` once
    the hover is over. A target equal to the current position is a hover only.

    A *turning point* is a flight whose direction deviates from the previous flight direction by
    more than ``turn_angle``; it costs ``turn_time`` seconds and ``turn_energy`` J (charged when
    the turn starts). The first flight after :meth:`reset` is not a turn (the UAV starts from a
    hover with no direction of motion); hovering does not forget the direction, so continuing
    straight on after a hover is not a turn either.

    A ``velocity`` command flies with the given velocity (norm clipped to ``speed``) for as long
    as it stays in force, after a turn if its direction changed; flying time is charged at
    ``fly_power``, which equals eq. (4) at full speed. A zero velocity or ``hold`` means waiting
    (``idle_power``). A new command pre-empts the current one; a turn in progress keeps running
    when the new command flies in the same direction.

    Blocked by an obstacle, the UAV stops there, hovers (the measurement at the reached point) and
    becomes ready; under a velocity command it waits out the rest of the period (idle). Only the
    distance actually flown is charged. Once the energy budget is spent it stops for good
    (``exhausted``).
    """

    params: UAVParams

    def __init__(self, params: UAVParams | None = None) -> None:
        super().__init__(params if params is not None else UAVParams())
        self.radius = float(self.params.radius)
        self._reset_state()

    def _reset_state(self) -> None:
        self._last_dir: np.ndarray | None = None
        self._turn_left = 0.0
        self._flying = False
        self._hover_left = 0.0
        self._hover_pending = False  # arrival at a hover point not yet counted
        self._speed = 0.0  # speed of the velocity command in force, m/s
        self._vdir: np.ndarray | None = None
        self._exhausted = False
        self._e = dict.fromkeys(("fly", "hover", "turn", "idle", "compute", "comm"), 0.0)
        self._t = dict.fromkeys(("fly", "hover", "turn", "idle"), 0.0)
        self._n_turns = 0
        self._n_hovers = 0

    # ------------------------------------------------------------------ energy
    def _charge(self, key: str, power: float, t: float) -> float:
        """Charge ``power`` W for ``t`` s to ``key`` within the budget; return the time granted."""
        if t <= 0.0:
            return 0.0
        room = self.params.energy_limit - self.energy
        if power > 0.0 and power * t > room:
            t = max(room, 0.0) / power
            self._exhaust()
        self._e[key] += power * t
        if key in self._t:
            self._t[key] += t
        return t

    def _affordable(self, power: float, t: float) -> float:
        """The part of ``t`` seconds at ``power`` W that the remaining budget covers."""
        room = self.params.energy_limit - self.energy
        if power > 0.0 and power * t > room:
            return max(room, 0.0) / power
        return t

    def _fly(self, end: np.ndarray, speed: float, arena: Arena) -> float:
        """Fly straight towards ``end`` at ``speed`` (stopping at obstacles); return metres flown.

        The flown time is charged at ``fly_power``, i.e. ``P_f * l / v`` (eq. 4).
        """
        start = self._require_reset().copy()
        self._translate(end, arena)
        moved = _norm(self._require_reset() - start)
        self._charge("fly", self.params.fly_power, moved / speed)
        return moved

    def _charge_lump(self, key: str, joules: float) -> bool:
        """Charge a lump of energy; ``False`` (and exhausted) if the budget cannot cover it."""
        room = self.params.energy_limit - self.energy
        if joules > room:
            self._e[key] += max(room, 0.0)
            self._exhaust()
            return False
        self._e[key] += joules
        return True

    def _exhaust(self) -> None:
        self._exhausted = True
        self._turn_left = 0.0
        self._flying = False
        self._hover_left = 0.0
        self._hover_pending = False
        self._speed = 0.0

    def charge_comm(self, nbytes: float) -> float:
        """Charge transmitting ``nbytes`` bytes to neighbours, ``P_T * N_d / r_T`` (eq. 8).

        ``N_d = 8 * nbytes`` bits; pass the bytes sent to *each* recipient summed over
        recipients (unicast accounting, as :class:`~odorloc.platforms.team.CommGraph` counts).

        Returns
        -------
        float
            The energy charged, J.
        """
        if not (math.isfinite(nbytes) and nbytes >= 0):
            raise ConfigError("nbytes", f"must be a finite number >= 0, got {nbytes}")
        before = self._e["comm"]
        self._charge_lump(
            "comm", self.params.transmit_power * 8.0 * nbytes / self.params.transmit_rate
        )
        return self._e["comm"] - before

    def charge_compute(self, nbits: float) -> float:
        """Charge processing ``nbits`` bits, ``gamma_c * C * f_c**2 * N_c`` (eq. 7).

        The paper measures computation by the number of processed bits ``N_c``, not by time;
        :meth:`charge_compute_time` converts CPU seconds.

        Returns
        -------
        float
            The energy charged, J.
        """
        if not (math.isfinite(nbits) and nbits >= 0):
            raise ConfigError("nbits", f"must be a finite number >= 0, got {nbits}")
        p = self.params
        before = self._e["compute"]
        self._charge_lump("compute", p.capacitance * p.cycles_per_bit * p.cpu_frequency**2 * nbits)
        return self._e["compute"] - before

    def charge_compute_time(self, seconds: float) -> float:
        """Charge ``seconds`` of CPU time: ``f_c * seconds / C`` bits through eq. (7).

        Equivalent to a CPU power of ``gamma_c * f_c**3`` W. Returns the energy charged, J.
        """
        if not (math.isfinite(seconds) and seconds >= 0):
            raise ConfigError("seconds", f"must be a finite number >= 0, got {seconds}")
        p = self.params
        if p.cycles_per_bit == 0:
            return 0.0
        return self.charge_compute(p.cpu_frequency * seconds / p.cycles_per_bit)

    def energy_breakdown(self) -> dict[str, float]:
        """Energy used per component, J: ``fly, hover, turn, idle, compute, comm``."""
        return dict(self._e)

    @property
    def energy(self) -> float:
        """Energy used since :meth:`reset`, J (the sum of :meth:`energy_breakdown`)."""
        return float(sum(self._e.values()))

    @property
    def movement_energy(self) -> float:
        """``E_M = E_f + E_h + E_b``, J (eqs. 4-6)."""
        return self._e["fly"] + self._e["hover"] + self._e["turn"]

    @property
    def exhausted(self) -> bool:
        """``True`` once the energy limit ``E_max`` (eq. 9) is reached."""
        return self._exhausted

    @property
    def stats(self) -> dict[str, float]:
        """Time, counts and movement energy since reset: ``fly_time, hover_time, turn_time,
        idle_time`` (s), ``fly_hover_turn_time`` (s: their sum without the idle time, the
        multi-UAV paper's search time of a UAV, Sect. VI.1), ``n_turns, n_hovers``,
        ``distance`` (m) and ``movement_energy`` (J: ``E_M`` of eqs. 4-6, radio and computation
        apart).

        An episode row carries each as ``team_<key>`` (summed over the UAVs) and, with a reach
        radius, ``reach_<key>`` of the first UAV to reach the source at that moment: so
        ``reach_fly_hover_turn_time`` is the paper's search time, while the row's
        ``search_time`` is the simulated time at which the episode ended.
        """
        t = self._t
        return {
            "fly_time": t["fly"],
            "hover_time": t["hover"],
            "turn_time": t["turn"],
            "idle_time": t["idle"],
            "fly_hover_turn_time": t["fly"] + t["hover"] + t["turn"],
            "n_turns": float(self._n_turns),
            "n_hovers": float(self._n_hovers),
            "distance": self.path_length,
            "movement_energy": self.movement_energy,
        }

    # ------------------------------------------------------------------ kinematics
    @property
    def speed_limit(self) -> float:
        """Flying speed, m/s."""
        return float(self.params.speed)

    @property
    def ready(self) -> bool:
        """``True`` when no turn, flight or hover of a waypoint/move is pending."""
        cmd = self._command
        if cmd is None or cmd.kind in ("velocity", "hold") or self._exhausted:
            return True
        return not (self._flying or self._hover_left > 0.0 or self._turn_left > 0.0)

    def _set_direction(self, u: np.ndarray) -> None:
        """Adopt flight direction ``u`` (unit), starting a turn if it changes enough."""
        prev = self._last_dir
        if prev is not None:
            cos = float(np.clip(np.dot(prev, u), -1.0, 1.0))
            if math.acos(cos) > self.params.turn_angle:
                self._n_turns += 1
                self._turn_left = float(self.params.turn_time)
                if not self._charge_lump("turn", float(self.params.turn_energy)):
                    return
        self._last_dir = u
        if math.hypot(u[0], u[1]) > _EPS:
            self._heading = math.atan2(u[1], u[0])

    def _start(self, command: Command) -> None:
        if self._exhausted:
            return
        self._flying = False
        self._hover_left = 0.0
        self._hover_pending = False
        self._speed = 0.0
        if command.kind == "hold":
            self._turn_left = 0.0
            return
        if command.kind == "velocity":
            s = _norm(command.value)
            if s > _EPS:
                self._speed = min(s, self.speed_limit)
                self._vdir = command.value / s
                self._set_direction(self._vdir)
            else:
                self._turn_left = 0.0
            return
        assert self._target is not None
        d = self._target - self._require_reset()
        dist = _norm(d)
        if dist > _EPS:
            self._set_direction(d / dist)
            self._flying = not self._exhausted
        else:
            self._turn_left = 0.0
        if not self._exhausted:
            self._hover_pending = True
            self._hover_left = float(self.params.hover_time)

    def _advance(self, dt: float, arena: Arena) -> None:
        if self._exhausted:
            return
        p = self.params
        budget = dt
        if self._turn_left > 0.0:
            t = min(budget, self._turn_left)
            self._turn_left -= t
            if self._turn_left <= _EPS:
                self._turn_left = 0.0
            self._t["turn"] += t
            budget -= t
        if budget > _EPS and self._speed > 0.0 and self._vdir is not None:
            want, speed = budget, self._speed
            t = self._affordable(p.fly_power, want)
            moved = self._fly(self._pos + self._vdir * (speed * t), speed, arena)
            budget -= moved / speed
            if t < want:
                self._exhaust()
        if budget > _EPS and self._flying:
            pos = self._require_reset()
            assert self._target is not None
            d = self._target - pos
            dist = _norm(d)
            need = dist / p.speed
            want = min(budget, need)
            t = self._affordable(p.fly_power, want)
            end = self._target.copy() if t >= need else pos + d * (p.speed * t / dist)
            moved = self._fly(end, p.speed, arena)
            budget -= moved / p.speed
            if t < want:
                self._exhaust()
            if t >= need or self._blocked:
                self._flying = False
        if not self._flying and self._hover_pending and not self._exhausted:
            self._n_hovers += 1
            self._hover_pending = False
        if budget > _EPS and not self._flying and self._hover_left > 0.0:
            t = self._charge("hover", p.hover_power, min(budget, self._hover_left))
            self._hover_left -= t
            if self._hover_left <= _EPS:
                self._hover_left = 0.0
            budget -= t
        if budget > _EPS and not self._exhausted:
            self._charge("idle", p.idle_power, budget)
