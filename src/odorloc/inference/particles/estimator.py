"""The single-agent particle filter as an estimator (registry ``estimator``: ``particle-filter``).

A composition of parts, each a ``Ref`` in :class:`ParticleFilterParams`:

- the **reading** (family ``reading``): what an observation's reading is and under which model
  conditions it is read (:mod:`odorloc.inference.readings`);
- the **initialisation** (family ``particle_init``): uniform over the search region at the
  start, or by back-tracking the recorded wind at the first detection
  (:mod:`odorloc.inference.particles.init`);
- the **resampler** (family ``resampler``) and the **resampling policy** (family
  ``resampling_policy``: when to resample);
- the **stopping rule** (family ``stopping_rule``: when the estimate may be declared).

The measurement model is the caller's (:meth:`ParticleFilterEstimator.reset`). Each update (one
control period):

1. the reading part records the observation and gives the model conditions of its reading;
2. before the filter has particles, the initialisation may draw them at this reading;
3. with ``found_radius``, hypotheses within that distance of the agent are ruled out (the
   search would have ended there); if that rules out every particle, fresh ones are drawn away
   from the agent (``redraws``);
4. the weights take the reading's log-likelihood (eq. 4 of the indoor PF paper) and the
   estimate joins the history (every step, or only at detections with ``history_on_detection``);
5. the stopping rule is evaluated once; unless it holds, the policy may resample.

The defaults are the indoor PF paper's (section 2.2): back-tracking initialisation of 1000
particles, the Pang & Farrell detection likelihood over a 10 s wind window, Russian-roulette
resampling when ``N_eff < 0.5 N`` and the dual convergence test.
"""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Observation, SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.estimator import Estimator
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.convergence import StoppingRule
from odorloc.inference.particles.filter import ParticleFilter
from odorloc.inference.particles.init import ParticleInit
from odorloc.inference.particles.resampling import Resampler, ResamplingPolicy
from odorloc.inference.readings import Reading
from odorloc.models.base import MeasurementModel

__all__ = ["ParticleFilterEstimator", "ParticleFilterParams"]


class ParticleFilterParams(Params):
    """Parameters of :class:`ParticleFilterEstimator` (defaults: the indoor PF paper).

    Attributes
    ----------
    n_particles : int
        ``N_s`` (paper: 1000).
    reading : dict
        The reading part, ``{type: wind-window | outcome-class, ...}``.
    init : dict
        The initialisation, ``{type: backtrack | uniform, ...}``.
    resampler : dict
        The resampler, ``{type: roulette | systematic | ..., ...}`` (paper: roulette with
        survival floor 0.5, 5 children, 0.25 m^2).
    resampling : dict
        When to resample, ``{type: ess, threshold: 0.5}`` (eq. 12) or ``{type: every-step}``.
    stopping : dict
        The stopping rule, ``{type: dual-convergence, ...}`` (eqs. 15-16) or
        ``{type: never}``. The default reads ``R_conv = 0.5`` m as a radius (RMS particle
        distance, ``variance: radius``) and takes ``r_err = 0.25`` m, i.e. the 20 estimates must
        fit in a tolerance circle of 0.5 m *diameter*; with the literal reading (trace <= 0.5
        read as a number, all estimates within 0.5 m of their mean) the filter declares while
        its estimate still trails the robot upwind (the indoor reproduction reports both).
    history_on_detection : bool
        Store an estimate only at steps with a detection (the flattened ``{P_j | z_j = 1}`` of
        the paper read literally) instead of at every step.
    found_radius : float or "half-step" or None, metres
        Hypotheses within this distance of the agent are ruled out at every update (a search
        that ends when the source is reached); ``"half-step"``: half the distance one control
        period at the platform's speed limit covers; ``None``: none is ruled out.
    """

    n_particles: int = Field(1000, ge=2, le=10_000_000)
    reading: Ref("reading") = ComponentRef(type="wind-window")
    init: Ref("particle_init") = ComponentRef(type="backtrack")
    resampler: Ref("resampler") = ComponentRef(type="roulette")
    resampling: Ref("resampling_policy") = ComponentRef(type="ess")
    stopping: Ref("stopping_rule") = ComponentRef(
        type="dual-convergence", r_conv=0.5, r_err=0.25, history=20, variance="radius"
    )
    history_on_detection: bool = False
    found_radius: Positive | Literal["half-step"] | None = None


@register(
    "estimator", "particle-filter", ParticleFilterParams, "particle filter (reading x init x ...)"
)
class ParticleFilterEstimator(Estimator):
    """A particle filter over the source position composed of parts (module docstring)."""

    params: ParticleFilterParams
    Params = ParticleFilterParams
    default_model: ClassVar[dict[str, Any] | None] = {
        "type": "pang-farrell",
        "sensor_area": 0.1,
        "min_wind_variance": 0.05,
    }

    def __init__(self, params: ParticleFilterParams | None = None) -> None:
        super().__init__(params or ParticleFilterParams())
        p = self.params
        f = "searcher.estimator"
        self.reading: Reading = p.reading.build("reading", field=f"{f}.reading")
        self.init: ParticleInit = p.init.build("particle_init", field=f"{f}.init")
        self.resampler: Resampler = p.resampler.build("resampler", field=f"{f}.resampler")
        self.policy: ResamplingPolicy = p.resampling.build(
            "resampling_policy", field=f"{f}.resampling"
        )
        self.stopping: StoppingRule = p.stopping.build("stopping_rule", field=f"{f}.stopping")

    # ----------------------------------------------------------------- lifecycle
    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        """A new episode: the particles of a start-time initialisation, else none yet."""
        if model is None:
            raise ConfigError("model", "the particle filter needs a measurement model")
        p = self.params
        self.ctx = ctx
        self.model = model
        self.rng = rng
        self.reading.reset(ctx)
        self.init.reset(ctx, model)
        r = p.found_radius
        self.found_radius = 0.5 * ctx.max_speed * ctx.dt if r == "half-step" else r
        self.pf: ParticleFilter | None = None
        self._initial: ParticleBelief | None = None
        self._converged = False
        self.redraws = 0
        start = self.init.start(p.n_particles, rng)
        if start is not None:
            self._start(start)

    def use_stream(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def _start(self, particles: np.ndarray) -> None:
        self.pf = ParticleFilter(
            particles,
            resampler=self.resampler,
            history=self.stopping.history,
            constraint=ArenaConstraint(self.ctx.arena),
        )
        self._initial = self.pf.belief()

    # ----------------------------------------------------------------- one reading
    def update(self, observation: Observation) -> None:
        """Fold in one reading (see the module docstring for the order of the steps)."""
        o = observation
        cond = self.reading.update(o)
        if self.pf is None:
            drawn = self.init.on_reading(o, cond, self.params.n_particles, self.rng)
            if drawn is None:
                return
            self._start(drawn)
        pf = self.pf
        assert pf is not None
        near = None
        r = self.found_radius
        if r is not None:
            pos = np.asarray(o.position, float)
            near = np.linalg.norm(pf.positions - pos, axis=1) <= r
            if near.all():
                # every hypothesis sat where the agent is: start again away from it
                fresh = self.init.redraw(self.params.n_particles, self.rng)
                fresh = fresh[np.linalg.norm(fresh - pos, axis=1) > r]
                if len(fresh):
                    pf.replace(fresh)
                    self.redraws += 1
                near = np.linalg.norm(pf.positions - pos, axis=1) <= r
        ll = self.reading.log_likelihood(o, self.model, pf.positions, cond)
        if near is not None:
            ll = np.where(near, -np.inf, ll)
        pf.update(ll, record=bool(o.detection) or not self.params.history_on_detection)
        self._converged = self.stopping.converged(pf)
        if not self._converged and self.policy.due(pf.ess, pf.n):
            pf.resample(self.rng)

    # ----------------------------------------------------------------- outputs
    def belief(self) -> ParticleBelief | None:
        """The particle set (``None`` before the initialisation drew it)."""
        if self.pf is None:
            return None
        b = self.pf.belief()
        if self.found_radius is None:
            return b
        return ParticleBelief(b.positions, b.log_weights, float(self.found_radius))

    def initial_belief(self) -> ParticleBelief | None:
        """The particle set as the initialisation drew it (``None`` before)."""
        return self._initial

    def estimate(self) -> np.ndarray:
        """The weighted mean ``(1, d)`` (eq. 14), or ``(0, d)`` before the particles exist."""
        if self.pf is None:
            return np.zeros((0, self.ctx.dim))
        return self.pf.estimate()[None, :]

    def converged(self) -> bool:
        """The stopping rule as evaluated at the last update (before any resampling)."""
        return self._converged

    def conditions(self) -> dict[str, Any]:
        """The conditions of the next reading (:meth:`Reading.next_conditions`)."""
        return self.reading.next_conditions()

    @property
    def n_resamples(self) -> int:
        """Resamplings so far."""
        return 0 if self.pf is None else self.pf.n_resamples

    def diagnostics(self) -> dict[str, float]:
        """``ess``, ``weight_entropy`` (nats), ``n_particles`` and the stopping rule's own
        (e.g. ``spread``); before the particles exist ``ess`` is NaN and the count 0."""
        if self.pf is None:
            return {"ess": float("nan"), "n_particles": 0.0}
        b = self.pf.belief()
        return {
            "ess": b.ess,
            "weight_entropy": b.entropy,
            **self.stopping.diagnostics(self.pf),
            "n_particles": float(self.pf.n),
        }

    def final_metrics(self) -> dict[str, Any]:
        """Resamplings and redraws of the particle set."""
        return {"resamples": float(self.n_resamples), "redraws": float(self.redraws)}
