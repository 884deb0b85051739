"""UAV teams that estimate with particles and plan on a lattice: MUC-OSL and its baselines.

One member (``uav-pf``, :class:`UAVPlannerMember`) runs on each UAV of a ``per-agent`` team and
composes three parts named in its parameters:

- ``model``: the measurement model (registry family ``model``; default the Vergassola Poisson
  encounter model with the multi-UAV paper's Q = 5, V = 1 m/s, D = 1, tau = 100, eqs. 1-3, and
  in 3-D the sensor radius :data:`SENSOR_RADIUS` of the ``muc-osl-3d`` world, see
  :func:`default_model`);
- ``estimator``: a per-agent particle estimator (family ``team_estimator``: ``col-pf`` or
  ``standard-pf``, :mod:`odorloc.inference.particles.team_estimators`);
- ``planner``: a lattice step planner (family ``step_planner``: ``adap-pp`` or
  ``fixed-step-infotaxis``, :mod:`odorloc.planning.steps`).

Each iteration (Algorithm 3 of the paper) happens when the UAV is ready, i.e. has finished the
hover of its last move (the UAV platform turns, flies and hovers 1 s to measure): the count of
encounters of that hover is the measurement ``d_k`` (readings taken in flight are not used); the
estimator updates with it and with the messages received from neighbours since the last
iteration; the UAV broadcasts the estimator's message; then either it declares and approaches, or
the planner picks the next hover point, flown to as one ``move`` (turn, fly, hover). Each
iteration charges the computation it did (``Action.compute_bits``: 64 bits per processed number,
eq. 7).

Declaration: when the particles' RMS distance from their mean (``sqrt(tr Sigma)``) is at most
``declare_spread`` the UAV declares its estimate (once) and flies to it; it keeps measuring and
updating there, and goes back to planning if the spread grows again. The paper declares "when
the uncertainty on the source parameter estimation goes below a certain threshold" without a
value.

The four algorithms of the paper are compositions of these parts, registered as team presets
(each UAV a member with those parameters; every parameter of the member can be set on the preset):

===============  ===================================  =======================
name             estimator                            planner
===============  ===================================  =======================
muc-osl          col-pf (reversible PUGL moves)       adap-pp
col-inf          standard-pf                          fixed-step-infotaxis
col-pf           col-pf (reversible PUGL moves)       fixed-step-infotaxis
adap-pp          standard-pf                          adap-pp
muc-osl-printed  col-pf, ``pugl_move: printed``       adap-pp
col-pf-printed   col-pf, ``pugl_move: printed``       fixed-step-infotaxis
===============  ===================================  =======================

``muc-osl`` and ``col-pf`` judge PUGL's particle moves (eqs. 16-17) by the measurement history as
reversible Metropolis-Hastings moves, which keeps the filter's posterior; the ``-printed`` presets
move the particles as the paper prints it (unjudged, weights kept), which drifts the belief
upwind (:mod:`odorloc.inference.particles.pugl` says why).

``{type: col-pf, planner: {type: adap-pp}}`` is therefore MUC-OSL again, and
``{type: per-agent, member: {type: uav-pf, estimator: {type: col-pf}}}`` the same team written
out.

Readings: a sensor counting encounters (unit ``hits``) gives the count itself; any other sensor
gives 1 for a detection and 0 otherwise. The wind direction is the mean of the UAV's anemometer
readings (``wind: measured``) or the model's own (``wind: model``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.inference.particles.team_estimators import Measurement, TeamEstimator
from odorloc.planning.base import Pose
from odorloc.planning.steps import StepPlanner
from odorloc.searchers.base import Searcher
from odorloc.searchers.team import PerAgentTeam, TeamParams

__all__ = [
    "SENSOR_RADIUS",
    "ColInfParams",
    "ColPFSearchParams",
    "UAVBelief",
    "UAVPlannerMember",
    "UAVSearchParams",
    "default_model",
]

#: Bits per processed number (float64) in the computation energy of eq. 7.
BITS_PER_NUMBER = 64

#: Sensor radius ``a`` (metres) of the default model, the same as the ``muc-osl-3d`` world's.
#: The paper gives no ``a`` (eq. 1 fixes only ``a Q``); this is the radius at which the baseline
#: Col-Inf flies the paper's Table 2 (``examples/muc_osl_sensor_radius.py``).
SENSOR_RADIUS = 3.5


def default_model(dim: int) -> ComponentRef:
    """The measurement model a member uses when its ``model`` is not given.

    The Vergassola model with the paper's table; ``sensor_radius`` :data:`SENSOR_RADIUS` in 3-D
    and the model's own 1 m in 2-D, where the rate (eq. 3) needs ``a`` below ``lambda``
    (about 1.96 m with the paper's V, D and tau).
    """
    if dim == 3:
        return ComponentRef(type="vergassola", sensor_radius=SENSOR_RADIUS)
    return ComponentRef(type="vergassola")


class UAVSearchParams(Params):
    """Parameters of :class:`UAVPlannerMember` (and of every team preset built on it).

    Parameters
    ----------
    model : dict or None
        Measurement model, ``{type: vergassola, ...}``. ``None`` (the default) takes
        :func:`default_model` of the world's dimension: the multi-UAV paper's table with
        ``sensor_radius`` :data:`SENSOR_RADIUS` in 3-D. A ``model`` given here replaces the
        default whole: give its ``sensor_radius`` too.
    estimator : dict
        Per-agent estimator, ``{type: col-pf | standard-pf, ...}``.
    planner : dict
        Step planner, ``{type: adap-pp | fixed-step-infotaxis, ...}``.
    declare_spread : float, metres
        Declare (and approach the estimate) when the RMS particle distance from the estimate is
        at most this (a cell and a half of the 2 m lattice by default).
    k_max : int
        Maximum iteration number (paper: 800); the UAV then hovers where it is.
    wind : {"measured", "model"}
        Wind direction of the model and of env-pu: the mean anemometer reading, or the model's.
    """

    model: Ref("model") | None = None
    estimator: Ref("team_estimator") = Field(default_factory=lambda: ComponentRef(type="col-pf"))
    planner: Ref("step_planner") = Field(default_factory=lambda: ComponentRef(type="adap-pp"))
    declare_spread: Positive = 3.0
    k_max: int = Field(800, ge=1, le=1_000_000)
    wind: Literal["measured", "model"] = "measured"


class UAVBelief:
    """A member's belief for recording: particles, weights, estimate and its cue points."""

    def __init__(self, estimator: TeamEstimator, cues: np.ndarray) -> None:
        b = estimator.belief()
        self.positions = b.positions
        self.weights = b.weights
        self.estimate = b.mean
        self.cues = cues

    def snapshot(self) -> dict[str, np.ndarray]:
        """``positions (N, d)``, ``weights (N,)``, ``estimate (d,)``, ``cues (C, d)``."""
        return {
            "positions": self.positions.copy(),
            "weights": self.weights.copy(),
            "estimate": self.estimate.copy(),
            "cues": self.cues.copy(),
        }


@register("searcher", "uav-pf", UAVSearchParams, "one UAV: particle estimator x step planner")
class UAVPlannerMember(Searcher):
    """One UAV of a team: estimator x planner over a measurement model (module docstring)."""

    params: UAVSearchParams
    max_agents: ClassVar[int | None] = 1

    def __init__(self, params: UAVSearchParams | None = None) -> None:
        super().__init__(params or UAVSearchParams())

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        ref = p.model if p.model is not None else default_model(ctx.dim)
        self.model = ref.build("model", field="searcher.model")
        self.estimator: TeamEstimator = p.estimator.build(
            "team_estimator", field="searcher.estimator"
        )
        self.planner: StepPlanner = p.planner.build("step_planner", field="searcher.planner")
        self.estimator.reset(ctx, self.model, rng)
        self.planner.reset(ctx, self.model)
        self.k = 0
        self._inbox: dict[int, Mapping[str, np.ndarray]] = {}
        self._cues: list[np.ndarray] = []
        self._l_max = 1
        self._wind_sum = np.zeros(ctx.dim)
        self._wind_n = 0
        self._declared = False
        self._stopped = False
        self._approaching = False
        self._sent = 0
        self._numbers_sent = 0
        self._counts: list[int] = []
        self._lengths: list[int] = []
        self._bits = 0.0
        self._hits = ctx.sensor.unit == "hits"

    # ----------------------------------------------------------------- one step
    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        for msg in o.messages:
            self._inbox[int(msg.sender)] = msg.payload
        self._wind_sum += np.asarray(o.wind, float)
        self._wind_n += 1
        if not o.ready or self._stopped:
            return Action([None])
        if self.k >= self.params.k_max:
            self._stopped = True
            return Action([Command.hold()])
        self.k += 1
        pos = np.asarray(o.position, float)
        count = float(round(o.gas)) if self._hits else float(o.detection)
        count = max(count, 0.0)
        direction = self._wind_direction()
        m = Measurement(count, pos, self.ctx.dt, self.k, direction)
        est = self.estimator
        est.update(m, self._inbox, rng)
        self._inbox = {}
        self.planner.record(pos)
        if count > 0:
            self._cues.append(pos)
        self._counts.append(est.pf.n)
        payload = est.message()
        messages = {o.agent: payload} if payload is not None else {}
        if payload is not None:
            self._sent += 1
            self._numbers_sent += payload.numbers
        declaration = None
        estimate = est.estimate()
        work = 0
        if est.spread() <= self.params.declare_spread:
            if not self._declared:
                declaration = Declaration(estimate[None, :], agent=o.agent)
                self._declared = True
            self._approaching = True
            command = self._approach(pos, estimate)
        else:
            self._approaching = False
            plan = self.planner.plan(est.belief(), Pose(pos, conditions=m.conditions()), rng)
            work = plan.work
            self._l_max = int((plan.extra or {}).get("l_max", 1))
            if plan.target is None:
                command = Command.move(np.zeros(self.ctx.dim))
            else:
                command = Command.move(plan.target - pos)
                self._lengths.append(int((plan.extra or {}).get("length", 1)))
        bits = BITS_PER_NUMBER * (est.processed + work)
        self._bits += bits
        return Action(
            [command],
            messages=messages,
            declaration=declaration,
            compute_bits={o.agent: bits},
        )

    def _wind_direction(self) -> np.ndarray | None:
        if self.params.wind == "model" or self._wind_n == 0:
            return None
        mean = self._wind_sum / self._wind_n
        # numpy.linalg.norm of a vector is sqrt(v . v): called directly (every iteration)
        n = math.sqrt(float(mean.dot(mean)))
        return mean / n if n > 1e-9 else None

    def _approach(self, pos: np.ndarray, estimate: np.ndarray) -> Command:
        """Fly to the estimate (kept inside the arena), or hover there to measure again."""
        goal = self.ctx.arena.clip(estimate[None, :])[0]
        if float(np.linalg.norm(goal - pos)) < 1e-6:
            return Command.move(np.zeros(self.ctx.dim))
        return Command.move(goal - pos)

    # ----------------------------------------------------------------- reporting
    def belief(self) -> UAVBelief:
        """Particles, weights, estimate and the points where this UAV captured cues."""
        cues = np.array(self._cues) if self._cues else np.zeros((0, self.ctx.dim))
        return UAVBelief(self.estimator, cues)

    def diagnostics(self) -> dict[str, float]:
        """``spread`` (m), ``n_particles``, ``ess``, ``entropy`` (weights, nats), ``iteration``
        and the estimate (the particles' weighted mean) ``estimate_x``, ``_y`` (, ``_z``), m."""
        b = self.estimator.belief()
        out = {
            "spread": self.estimator.spread(),
            "n_particles": float(self.estimator.pf.n),
            "ess": b.ess,
            "entropy": b.entropy,
            "iteration": float(self.k),
        }
        for axis, v in zip("xyz", b.mean.tolist(), strict=False):
            out[f"estimate_{axis}"] = v
        return out

    def final_metrics(self) -> dict[str, Any]:
        """Per-UAV columns: iterations, cues, particle counts, messages, steps, computation."""
        est = self.estimator
        return {
            "iterations": self.k,
            "cues": len(self._cues),
            "first_cue_iteration": est.cue_iterations[0] if est.cue_iterations else -1,
            "particles_mean": float(np.mean(self._counts)) if self._counts else math.nan,
            "particles_final": est.pf.n,
            "messages_sent": self._sent,
            "numbers_per_message": self._numbers_sent / self._sent if self._sent else 0.0,
            "step_mean": float(np.mean(self._lengths)) if self._lengths else math.nan,
            "l_max": self._l_max,
            "compute_bits": self._bits,
            "declared_uav": self._declared,
            "final_spread": est.spread(),
            **{f"accept_{k}": v for k, v in est.acceptance().items()},
        }


# --------------------------------------------------------------------------- presets
class ColInfParams(UAVSearchParams):
    """Col-Inf: the standard filter (shared particles) and fixed-step infotaxis."""

    estimator: Ref("team_estimator") = Field(
        default_factory=lambda: ComponentRef(type="standard-pf")
    )
    planner: Ref("step_planner") = Field(
        default_factory=lambda: ComponentRef(type="fixed-step-infotaxis")
    )


class ColPFSearchParams(UAVSearchParams):
    """Col-PF: the collaborative filter and fixed-step infotaxis."""

    planner: Ref("step_planner") = Field(
        default_factory=lambda: ComponentRef(type="fixed-step-infotaxis")
    )


def _printed_colpf() -> ComponentRef:
    return ComponentRef(type="col-pf", pugl_move="printed")


class MucOslPrintedParams(UAVSearchParams):
    """MUC-OSL with PUGL's moves as printed (unjudged)."""

    estimator: Ref("team_estimator") = Field(default_factory=_printed_colpf)


class ColPFPrintedParams(ColPFSearchParams):
    """Col-PF with PUGL's moves as printed (unjudged) and fixed-step infotaxis."""

    estimator: Ref("team_estimator") = Field(default_factory=_printed_colpf)


class AdapPPParams(UAVSearchParams):
    """Adap-PP: the standard filter (shared particles) and adaptive path planning."""

    estimator: Ref("team_estimator") = Field(
        default_factory=lambda: ComponentRef(type="standard-pf")
    )


class _UAVTeam(PerAgentTeam):
    """A ``per-agent`` team of :class:`UAVPlannerMember` with the preset's parameters."""

    Params: ClassVar[type[UAVSearchParams]] = UAVSearchParams

    def __init__(self, params: UAVSearchParams | None = None) -> None:
        preset = params if params is not None else type(self).Params()
        self.preset = preset
        member = ComponentRef(type="uav-pf", **preset.model_dump(mode="python"))
        super().__init__(TeamParams(member=member))


@register("searcher", "muc-osl", UAVSearchParams, "MUC-OSL: Col-PF x Adap-PP per UAV")
class MucOslTeam(_UAVTeam):
    """MUC-OSL (multi-UAV paper): Col-PF estimation and Adap-PP planning on every UAV."""

    Params = UAVSearchParams


@register("searcher", "col-inf", ColInfParams, "Col-Inf: standard PF x fixed-step infotaxis")
class ColInfTeam(_UAVTeam):
    """Col-Inf baseline: standard filter sharing particles, fixed-step infotaxis."""

    Params = ColInfParams


@register("searcher", "col-pf", ColPFSearchParams, "Col-PF x fixed-step infotaxis per UAV")
class ColPFTeam(_UAVTeam):
    """Col-PF baseline: collaborative filter, fixed-step infotaxis."""

    Params = ColPFSearchParams


@register("searcher", "adap-pp", AdapPPParams, "standard PF x Adap-PP per UAV")
class AdapPPTeam(_UAVTeam):
    """Adap-PP baseline: standard filter sharing particles, adaptive path planning."""

    Params = AdapPPParams


@register(
    "searcher", "muc-osl-printed", MucOslPrintedParams, "MUC-OSL with PUGL's moves as printed"
)
class MucOslPrintedTeam(_UAVTeam):
    """MUC-OSL with the paper's PUGL moves as printed: unjudged, the weights kept."""

    Params = MucOslPrintedParams


@register("searcher", "col-pf-printed", ColPFPrintedParams, "Col-PF with PUGL's moves as printed")
class ColPFPrintedTeam(_UAVTeam):
    """Col-PF baseline with the paper's PUGL moves as printed."""

    Params = ColPFPrintedParams
