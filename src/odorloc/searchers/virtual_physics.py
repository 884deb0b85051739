"""Virtual-physics formation search: one group of robots around a virtual robot (one formation).

The method of the virtual-physics paper (``shared/papers/virtual-physics-multi-group.txt``,
Sec. 2.2) as a recipe of reusable parts. This searcher drives the robots it is given as one
formation; two formations searching two sources run in a ``per-group`` team
(:class:`~odorloc.searchers.team.PerGroupTeam`), one instance per group, and the groups know of
each other only what they broadcast.

Each control step (one step of eqs. 7-8):

1. **Listen**: messages from other groups carry their virtual robot (``vr``, metres) and whether
   they have located a source (``declared``). Only the groups heard this period count as where
   they are (see below for those out of communication range).
2. **Declare** (Sec. 2.2.3, :class:`~odorloc.behaviours.formation.FluxDeclaration`): the total
   mass flux ``sum_k rho_k v_k . n_k`` through the formation (:func:`~odorloc.behaviours.taxis.
   mass_flux`, normals from the virtual robot) has exceeded ``phi_T`` for ``n_s`` consecutive
   steps while the robots surround the virtual robot; the group declares the virtual robot's
   position, stops and keeps broadcasting it.
3. **Goal force** ``F(VG)`` of the virtual robot (:mod:`odorloc.behaviours.taxis`):
   ``chemotaxis`` (eq. 3, towards the robot with the highest reading), ``anemotaxis`` (eq. 4,
   upwind of the mean wind when every robot reads above ``rho_T``) or ``fluxotaxis`` (eqs. 5-6,
   towards the robot with the most negative flux when every robot reads above ``rho_T``). When
   only part of the formation reads above ``rho_T``, anemotaxis and fluxotaxis re-centre the
   formation on its strongest robot (``outside="chemotaxis"``: the paper's "move the lattice
   upstream while keeping the robots inside the plume", Sec. 2.2.2.1) or wait
   (``outside="wait"``, the rules read literally). When no rule applies the virtual robot
   waits where it is: that is the paper's plume finding by passive monitoring (Sec. 2.2.1)
   before the plume has reached the group, and the same waiting when the plume has swung
   away.
4. **Between groups** (:mod:`odorloc.behaviours.groups`): repulsion from virtual robots closer
   than ``repulsion_range`` (``5 r``), ``F' = F + f_v`` (eqs. 9-10), normalised; the forbidden
   circle of radius ``r_T`` around every group that has declared (eq. 11), bypassed by the rotary
   force (eqs. 12-16). Each is a switch (``repulsion``, ``forbidden_area``, ``rotary``).
5. **Move**: the virtual robot steps ``s1`` along the result (eq. 7), the robots step at most
   ``s2`` along their virtual structure forces (eqs. 1-2, 8;
   :func:`~odorloc.behaviours.formation.structure_step`) as ``move`` commands.

Choices where the paper is silent (all parameters):

- ``k_s = 1e5``: a ring stiff enough that six unit charges with ``k_r = 5`` settle on a hexagon
  of radius ``1.018 r`` (:func:`~odorloc.behaviours.formation.equilibrium_radius`).
- ``follow=True``: the robots are carried with their virtual robot's step and correct the shape
  with the rest of their ``s2`` step; eq. 8 taken literally (``follow=False``) lets the robots of
  a moving formation bunch up behind the virtual robot.
- ``k_c``: Table 1 lists ``k_c = 0.0001`` but no equation uses it; here it is the plume-contact
  level: readings below it count as no odor for chemotaxis (a numerical plume is positive far
  into its tails, and chasing differences of 1e-9 is not following a plume).
- ``r_T = 1.5 m`` (``5 r``): the formation of the other group (radius ``r``) then keeps more
  than ``3 r`` from the located group's robots, and a source 2.83 m from the located one stays
  reachable.
- "Surround" in the declaration is a formation check: every robot within ``r (1 +- 0.5)`` of the
  virtual robot and no angular gap of ``pi`` or more between them.
- Repulsion and the goal force are normalised together (eq. 10 then the unit vector), so the
  virtual robot always steps ``s1`` and its robots can follow.
- Groups out of communication range (``agents.comm_radius``): the paper does not limit the
  range. Here a searching group that was not heard this period is forgotten -- it moves on
  unseen, and a position from periods ago would repel this group from an empty spot (eq. 9
  takes the virtual robots where they are). A group that has located a source stops (Sec.
  2.2.2), so the position it declared stays true: it is kept once heard, with its forbidden
  circle and the rotary sense chosen around it (eqs. 11-16).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from odorloc.behaviours.formation import (
    FluxDeclaration,
    StepRule,
    formation_shape,
    structure_step,
)
from odorloc.behaviours.groups import Bypass, repulsion
from odorloc.behaviours.taxis import anemotaxis, chemotaxis, fluxotaxis, mass_flux
from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import (
    Action,
    Command,
    Declaration,
    Observation,
    Payload,
    SearchContext,
    frozen_array,
)
from odorloc.searchers.base import Searcher

__all__ = ["GroupMessage", "VirtualPhysicsParams", "VirtualPhysicsSearcher"]

Rule = Literal["chemotaxis", "anemotaxis", "fluxotaxis"]
_EPS = 1e-12


@dataclass(frozen=True, eq=False)
class GroupMessage(Payload):
    """What a group tells the others: its virtual robot ``vr`` (``(2,)``, metres, two float64)
    and whether it has declared (one byte): 17 bytes."""

    vr: np.ndarray
    declared: bool

    def __post_init__(self) -> None:
        object.__setattr__(self, "vr", frozen_array(np.ravel(self.vr)[:2]))
        object.__setattr__(self, "declared", bool(self.declared))

    @property
    def nbytes(self) -> int:
        return int(self.vr.nbytes) + 1


class VirtualPhysicsParams(Params):
    """Parameters of :class:`VirtualPhysicsSearcher` (Table 1 of the paper as defaults).

    Attributes
    ----------
    rule : {"chemotaxis", "anemotaxis", "fluxotaxis"}
        Goal force of the virtual robot (eqs. 3, 4, 5-6).
    outside : {"chemotaxis", "wait"}
        What anemotaxis and fluxotaxis do when some robots read ``rho_T`` or less: move towards
        the strongest robot (keep the formation in the plume), or wait.
    radius : float, metres
        Ring radius ``r`` of the formation.
    k_r, k_s : float
        Gains of the charge and ring terms of the structure force (eq. 1).
    s1, s2 : float, metres
        Step of the virtual robot (eq. 7) and longest step of a robot (eq. 8); ``s1 < s2``.
        A robot's step is also capped at what its platform covers in one control period
        (speed limit x control period), which must exceed ``s1`` as well.
    k_c : float
        Plume-contact level (reading units): lower readings count as no odor in chemotaxis.
    rho_T : float
        Concentration every robot must exceed for anemotaxis and fluxotaxis (reading units;
        kg/m^3 in the paper).
    phi_T : float
        Total mass flux threshold of the declaration (readings x m/s; kg/m^2 s).
    n_s : int
        Consecutive steps above ``phi_T`` needed to declare.
    step_rule : {"capped", "fixed"}
        Robots' step length: the best of ``s2, s2/2, ...`` along the force, or always ``s2``
        (see :mod:`odorloc.behaviours.formation`).
    follow : bool
        Carry the robots with the virtual robot's step (see the module docstring).
    repulsion : bool
        Repulsion between virtual robots (eqs. 9-10).
    repulsion_range : float, metres, optional
        Range of the repulsion (default ``5 r``).
    forbidden_area : bool
        Close the circle of radius ``r_T`` around every group that has declared (eq. 11).
    rotary : bool
        Go around a forbidden circle by the rotary force (eqs. 12-16); without it a step into
        the circle is refused. Needs ``forbidden_area``.
    r_T : float, metres
        Radius of the forbidden circle (``> radius``).
    surround_tolerance : float
        Relative band around ``radius`` in which every robot must be for the formation to
        surround its centre (declaration).
    """

    rule: Rule = "chemotaxis"
    outside: Literal["wait", "chemotaxis"] = "chemotaxis"
    radius: Positive = 0.3
    k_r: Positive = 5.0
    k_s: Positive = 1.0e5
    s1: Positive = 0.06
    s2: Positive = Field(0.12, validate_default=True)
    k_c: NonNegative = 1.0e-4
    rho_T: NonNegative = 0.005
    phi_T: Finite = 0.05
    n_s: int = Field(10, ge=1, le=1_000_000)
    step_rule: StepRule = "capped"
    follow: bool = True
    repulsion: bool = True
    repulsion_range: Positive | None = None
    forbidden_area: bool = True
    rotary: bool = Field(True, validate_default=True)
    r_T: Positive = Field(1.5, validate_default=True)
    surround_tolerance: float = Field(0.5, gt=0.0, lt=1.0)

    @field_validator("s2")
    @classmethod
    def _s2_above_s1(cls, v: float, info: ValidationInfo) -> float:
        s1 = info.data.get("s1")
        if s1 is not None and not s1 < v:
            raise ValueError(f"must exceed s1 ({s1}) so that the robots can follow")
        return v

    @field_validator("r_T")
    @classmethod
    def _r_t_above_radius(cls, v: float, info: ValidationInfo) -> float:
        r = info.data.get("radius")
        if r is not None and not v > r:
            raise ValueError(f"must exceed the ring radius ({r})")
        return v

    @field_validator("rotary")
    @classmethod
    def _rotary_needs_area(cls, v: bool, info: ValidationInfo) -> bool:
        if v and info.data.get("forbidden_area") is False:
            raise ValueError("needs forbidden_area (the rotary force goes around it)")
        return v

    @property
    def reach(self) -> float:
        """Range of the repulsion, metres."""
        return self.repulsion_range if self.repulsion_range is not None else 5.0 * self.radius


@register("searcher", "virtual-physics", VirtualPhysicsParams, "virtual-physics formation")
class VirtualPhysicsSearcher(Searcher):
    """One formation of the virtual-physics paper (see the module docstring)."""

    params: VirtualPhysicsParams
    dims = (2,)
    # the declaration needs the robots around the virtual robot (Sec. 2.2.3): three at least
    min_agents = 3

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        self.vr = ctx.start[:, :2].mean(axis=0)
        self.sender = ctx.agent_ids[0]
        self.own = set(ctx.agent_ids)
        # A robot cannot step farther than its platform goes in one period.
        reach = float(ctx.speed_limits.min()) * ctx.dt
        if not reach > p.s1:
            # s2 clipped to s1 or below leaves the robots behind their virtual robot at every
            # step: the formation falls apart while the search carries on (Sec. 2.2.2.1 asks
            # for s1 < s2 so that the robots can follow).
            raise ConfigError(
                "limits.control_dt",
                f"the robots reach {reach:g} m per control period (platform speed x "
                f"control_dt), not more than the virtual robot's step s1 = {p.s1:g} m: the "
                "formation cannot follow it",
            )
        self.s2 = min(p.s2, reach)
        self.flux = FluxDeclaration(p.phi_T, p.n_s)
        self.bypass = Bypass(p.r_T, rotary=p.rotary)
        self.heard: dict[int, tuple[np.ndarray, bool]] = {}
        self.declared_at: np.ndarray | None = None
        self.declared_time = math.nan
        self.plume_time = math.nan
        self.total_flux = math.nan
        self.counts = {"rotary": 0, "blocked": 0, "repelled": 0, "goal": 0}
        self._last = {"rotary": 0.0, "repelled": 0.0}

    # ------------------------------------------------------------------ parts
    def _listen(self, observations: Sequence[Observation]) -> None:
        # a located group has stopped where it declared; any other moves on unheard
        self.heard = {s: h for s, h in self.heard.items() if h[1]}
        seen: set[int] = set()
        for o in observations:
            for m in o.messages:
                # every robot in range hears the same broadcast: read it once
                if m.sender in seen or m.sender in self.own:
                    continue
                if not isinstance(m.payload, GroupMessage):
                    continue
                seen.add(m.sender)
                self.heard[int(m.sender)] = (m.payload.vr.copy(), m.payload.declared)

    def _goal(self, x: np.ndarray, gas: np.ndarray, wind: np.ndarray) -> np.ndarray | None:
        p = self.params
        if p.rule == "chemotaxis":
            return chemotaxis(self.vr, x, np.where(gas >= p.k_c, gas, 0.0))
        if p.rule == "anemotaxis":
            goal = anemotaxis(wind, gas, p.rho_T)
        else:
            goal = fluxotaxis(self.vr, x, gas, wind, p.rho_T)
        if goal is None and p.outside == "chemotaxis" and not np.all(gas > p.rho_T):
            goal = chemotaxis(self.vr, x, np.where(gas >= p.k_c, gas, 0.0))
        return goal

    def _message(self) -> dict[int, GroupMessage]:
        return {self.sender: GroupMessage(self.vr, self.declared_at is not None)}

    # ------------------------------------------------------------------ step
    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        p, ctx = self.params, self.ctx
        self._last = {"rotary": 0.0, "repelled": 0.0}
        self._listen(observations)
        n = len(observations)
        if self.declared_at is not None:
            return Action([Command.hold()] * n, messages=self._message())
        x = np.array([o.position[:2] for o in observations])
        gas = np.array([o.gas for o in observations], float)
        wind = np.array([o.wind[:2] for o in observations], float)
        t = float(observations[0].t)
        if math.isnan(self.plume_time) and np.any(gas >= p.k_c):
            self.plume_time = t
        _, self.total_flux = mass_flux(self.vr, x, gas, wind)
        # the shape matters only when the flux is high enough to count
        surrounds = self.total_flux > p.phi_T and formation_shape(x, self.vr).surrounds(
            p.radius, p.surround_tolerance
        )
        if self.flux.update(self.total_flux, surrounds):
            self.declared_at = self.vr.copy()
            self.declared_time = t
            decl = Declaration(self.vr[None, :].copy(), 1.0, agent=self.sender)
            return Action([Command.hold()] * n, messages=self._message(), declaration=decl)
        goal = self._goal(x, gas, wind)
        force = np.zeros(2) if goal is None else np.asarray(goal, float)
        if p.repulsion:
            others = [v for v, _ in self.heard.values()]
            fv = repulsion(self.vr, np.reshape(others, (-1, 2)), p.reach)
            if np.any(fv != 0.0):
                force = force + fv  # eq. 10
                self._last["repelled"] = 1.0
                self.counts["repelled"] += 1
        norm = float(np.linalg.norm(force))
        heading = force / norm if norm > _EPS else None
        located = {s: v for s, (v, d) in self.heard.items() if d} if p.forbidden_area else {}
        direction, reason = self.bypass.steer(self.vr, heading, located, p.s1)
        if reason in self.counts:
            self.counts[reason] += 1
        self._last["rotary"] = 1.0 if reason == "rotary" else 0.0
        new = self.vr if direction is None else self.vr + p.s1 * direction
        new = self._keep_inside(new)
        delta = new - self.vr
        self.vr = new
        disp = structure_step(
            x,
            new,
            p.radius,
            p.k_r,
            p.k_s,
            self.s2,
            p.step_rule,
            carry=delta if p.follow else None,
        )
        if ctx.dim > 2:
            disp = np.hstack([disp, np.zeros((n, ctx.dim - 2))])
        cmds: list[Command | None] = [Command("move", d) for d in disp]
        return Action(cmds, messages=self._message())

    def _keep_inside(self, point: np.ndarray) -> np.ndarray:
        """The virtual robot stays where its whole formation fits inside the arena, off
        obstacles (a refused step keeps it in place)."""
        arena = self.ctx.arena
        margin = self.params.radius * 1.5
        lo, hi = arena.lo[:2] + margin, arena.hi[:2] - margin
        q = np.clip(point, lo, np.maximum(hi, lo))
        if arena.occ is not None:
            full = np.zeros(arena.dim)
            full[:2] = q
            if not arena.is_free(full)[0]:
                return self.vr
        return q

    # ------------------------------------------------------------------ reporting
    def diagnostics(self) -> dict[str, float]:
        return {
            "vr_x": float(self.vr[0]),
            "vr_y": float(self.vr[1]),
            "total_flux": float(self.total_flux),
            "flux_count": float(self.flux.count),
            "rotary": self._last["rotary"],
            "repelled": self._last["repelled"],
            "declared": float(self.declared_at is not None),
        }

    def final_metrics(self) -> dict[str, Any]:
        d = self.declared_at
        return {
            "plume_time": float(self.plume_time),
            "declared_time": float(self.declared_time),
            "declared_x": math.nan if d is None else float(d[0]),
            "declared_y": math.nan if d is None else float(d[1]),
            "rotary_steps": int(self.counts["rotary"]),
            "blocked_steps": int(self.counts["blocked"]),
            "repelled_steps": int(self.counts["repelled"]),
        }
