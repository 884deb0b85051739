"""Per-agent particle estimators that talk to their neighbours (registry family ``team_estimator``).

One instance runs on each UAV of a team. Every iteration (a measurement at a hover point) it
takes the UAV's own :class:`Measurement` and the messages its neighbours sent since the last
iteration, updates its particles and says what to broadcast next (:meth:`TeamEstimator.message`;
the episode delivers it within the communication radius and counts its bytes).

- :class:`ColPFEstimator` (``col-pf``): the collaborative particle filter of the multi-UAV paper
  (MUC-OSL, Algorithm 1): Col-PF weights with confidence factors (eqs. 10-14), low-variance
  resampling, PUGL position update (eqs. 15-17), adaptive particle count (eq. 18), Gaussian fit
  (eqs. 19-20). Its message is the fit plus the measurement the neighbours' likelihood needs.
- :class:`StandardPFEstimator` (``standard-pf``): the same filter without Col-PF weighting, PUGL
  or adaptive count, the estimator of the paper's baselines Col-Inf and Adap-PP. By default it
  collaborates as in collaborative infotaxis with shared particles: it broadcasts its whole
  particle set (positions and weights, ``4N`` numbers in 3-D); a UAV pools its own weighted set
  with the sets it received (every set carries the same share of the mass: a linear opinion pool
  of the team's posteriors), weighs the pool by its own measurement and resamples it back to
  ``N``. ``share: measurements`` instead shares measurements and multiplies in the neighbours'
  likelihoods unweighted (eq. 11 with ``beta = 1``); ``share: none`` does not collaborate.

Both start from particles drawn uniformly over the search region (the arena when the task
names none) and use the measurement model they are given (the UAV's, e.g. the Vergassola
Poisson model, eqs. 1-3).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Payload, SearchContext
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.particles.adaptive_count import CueDistanceCount, spacing_minimum
from odorloc.inference.particles.collaborative import (
    MeasurementMessage,
    NeighbourFit,
    ParticleSetMessage,
    TeamMessage,
    collaborative_log_likelihood,
    confidence_factors,
    fit_payload,
    read_fit_payload,
)
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.filter import ParticleFilter
from odorloc.inference.particles.init import sample_free_uniform
from odorloc.inference.particles.pugl import (
    col_position_update,
    env_position_update,
    gbest,
    moved_count,
)
from odorloc.inference.particles.resampling import Resampler
from odorloc.inference.weights import normalise_log_weights
from odorloc.models.base import MeasurementModel

__all__ = [
    "ColPFEstimator",
    "ColPFParams",
    "Measurement",
    "StandardPFEstimator",
    "StandardPFParams",
    "TeamEstimator",
]


@dataclass(frozen=True)
class Measurement:
    """One measurement of a UAV at a hover point.

    Attributes
    ----------
    count : float
        Encounters counted (a non-negative integer for a Poisson model).
    position : (d,) ndarray, metres
    dt : float, seconds
        Exposure of the count.
    k : int
        Iteration number of this measurement (1 for the first).
    direction : (d,) ndarray, optional
        Unit vector the wind blows towards (measured); ``None``: the model's own.
    """

    count: float
    position: np.ndarray
    dt: float
    k: int
    direction: np.ndarray | None = None

    def conditions(self) -> dict[str, Any]:
        """The measurement-model conditions of this measurement."""
        out: dict[str, Any] = {"dt": self.dt}
        if self.direction is not None:
            out["direction"] = self.direction
        return out


class TeamEstimator(ABC):
    """Base class of the per-agent estimators (see the module docstring).

    After :meth:`reset`, :attr:`pf` is the agent's :class:`ParticleFilter`; :attr:`processed`
    is the count of numbers the last :meth:`update` processed (the computation measure of eq. 7).
    """

    params: Params
    Params: ClassVar[type[Params]]

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else type(self).Params()

    # ----------------------------------------------------------------- lifecycle
    def reset(
        self,
        ctx: SearchContext,
        model: MeasurementModel,
        rng: np.random.Generator,
        n: int | None = None,
    ) -> None:
        """Draw ``n`` (default: the configured count) particles uniformly over the search region."""
        self.ctx = ctx
        self.model = model
        self.constraint = ArenaConstraint(ctx.arena)
        count = self.initial_count() if n is None else int(n)
        self.pf = ParticleFilter(
            _uniform_particles(ctx, count, rng),
            resampler=self._resampler(),
            resample_threshold=float(self.params.resample_threshold),  # type: ignore[attr-defined]
            constraint=self.constraint,
        )
        self.cue_iterations: list[int] = []
        self.processed = 0.0
        self.last: Measurement | None = None

    def initial_count(self) -> int:
        """Particles at the start."""
        return int(self.params.n_particles)  # type: ignore[attr-defined]

    def _resampler(self) -> Resampler:
        ref: ComponentRef = self.params.resampler  # type: ignore[attr-defined]
        return ref.build("resampler", field="resampler")

    @abstractmethod
    def update(
        self, m: Measurement, inbox: Mapping[int, Payload], rng: np.random.Generator
    ) -> None:
        """One iteration with the own measurement ``m`` and the neighbours' latest messages."""

    @abstractmethod
    def message(self) -> TeamMessage | None:
        """The payload to broadcast after the last update (``None``: say nothing)."""

    # ----------------------------------------------------------------- reading
    @property
    def cue_captured(self) -> bool:
        """``True`` once any measurement was non-zero."""
        return bool(self.cue_iterations)

    def belief(self) -> ParticleBelief:
        """The particle set."""
        return self.pf.belief()

    def estimate(self) -> np.ndarray:
        """Weighted mean of the particles, ``(d,)`` metres."""
        return self.pf.estimate()

    def spread(self) -> float:
        """RMS distance of the particles from their mean, metres."""
        return self.pf.spread("radius")

    def _own_log_likelihood(self, m: Measurement, positions: np.ndarray) -> np.ndarray:
        return self.model.log_likelihood(m.count, m.position, positions, **m.conditions())

    def _record_cue(self, m: Measurement) -> None:
        self.last = m
        if m.count > 0:
            self.cue_iterations.append(m.k)


def _uniform_particles(ctx: SearchContext, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points uniform over the task region (within the arena), else the free space."""
    arena = ctx.arena
    region = ctx.search_region
    if region is None:
        return sample_free_uniform(arena, n, rng)
    d = arena.dim
    lo = np.array(arena.lower, float)
    hi = np.array(arena.upper, float)
    k = len(region[0])
    lo[:k] = np.maximum(lo[:k], region[0])
    hi[:k] = np.minimum(hi[:k], region[1])
    out = np.zeros((0, d))
    for _ in range(100):
        if len(out) >= n:
            break
        cand = lo + rng.random((max(2 * (n - len(out)), 16), d)) * (hi - lo)
        out = np.concatenate([out, cand[arena.is_free(cand)]], axis=0)
    if len(out) < n:
        return sample_free_uniform(arena, n, rng)
    return out[:n]


def _default_resampler() -> ComponentRef:
    return ComponentRef(type="low-variance", jitter_std=1.0)


class _FilterParams(Params):
    """Settings both estimators share.

    Parameters
    ----------
    n_particles : int
        Particles at the start (paper: N = 100).
    resampler : dict
        Resampler from the registry (paper: low-variance sampling). The default roughens the
        copies with a 1 m Gaussian jitter (half a lattice cell; about the plume's correlation
        length): copies of the hypotheses of a static source would otherwise collapse onto a
        few points. Both filters get the same. ``{type: regularised}`` scales the move to the
        cloud instead (:mod:`~odorloc.inference.particles.regularised`).
    resample_threshold : float
        Resample when ``N_eff < resample_threshold * N``.
    """

    n_particles: int = Field(100, ge=2, le=100_000)
    resampler: Ref("resampler") = Field(default_factory=_default_resampler)
    resample_threshold: float = Field(0.5, ge=0.0, le=1.0)


class ColPFParams(_FilterParams):
    """Parameters of :class:`ColPFEstimator` (defaults: the multi-UAV paper's Table 1).

    Parameters
    ----------
    n_min : int or None
        Lower bound of the count (paper: 20); ``None`` derives it from the spacing
        ``g = 2 sqrt(D tau)`` of the model (:func:`spacing_minimum`; 23 in 100 x 60 x 30 m).
    n_max : int
        Upper bound of the count (paper: 160).
    k_max : int
        Maximum iteration number of eq. 15 (paper: 800).
    gamma1, gamma2 : float
        Exponents of eq. 15 (paper: 1.8, 4).
    weighting : {"confidence", "equal"}
        Neighbours' likelihoods raised to ``beta_ij = exp(-KL)`` (eq. 13) or to 1 (ablation).
    env_pu : {"invariant", "literal", "off"}
        Reading of eq. 16 (see :mod:`~odorloc.inference.particles.pugl`), or no env-pu.
    env_pu_from : {"start", "first_cue"}
        Apply env-pu from the first iteration (the paper) or only once the UAV has captured a
        cue (an ablation: before any cue the upwind moves have nothing to correct them).
    env_step : float, metres
        Largest upwind step of the ``"invariant"`` reading. The paper gives none; the default is
        one plume correlation length ``lambda`` of its model (1.96 m for Q = 5, V = 1, D = 1,
        tau = 100), rounded to 2 m.
    col_pu : bool
        Move the selected particles of a not yet cue-captured UAV towards ``gbest`` (eq. 17).
    adaptive_count : bool
        Adapt the particle count by eq. 18; otherwise keep ``n_particles``.
    count_reading : {"proportional", "literal"}
        Reading of eq. 18 (see :mod:`~odorloc.inference.particles.adaptive_count`).
    delta_c : int
        ``Delta_c`` of the cue-capture frequency (not given in the paper).
    """

    n_min: int | None = Field(20, ge=1, le=10_000_000)
    n_max: int = Field(160, ge=1, le=10_000_000)
    k_max: int = Field(800, ge=1, le=1_000_000)
    gamma1: Positive = 1.8
    gamma2: Positive = 4.0
    weighting: Literal["confidence", "equal"] = "confidence"
    env_pu: Literal["invariant", "literal", "off"] = "invariant"
    env_pu_from: Literal["start", "first_cue"] = "start"
    env_step: NonNegative = 2.0
    col_pu: bool = True
    adaptive_count: bool = True
    count_reading: Literal["proportional", "literal"] = "proportional"
    delta_c: int = Field(3, ge=1, le=1_000_000)

    @model_validator(mode="after")
    def _bounds(self) -> ColPFParams:
        if self.n_min is not None and self.n_min > self.n_max:
            raise ValueError("n_min must not exceed n_max")
        return self


@register("team_estimator", "col-pf", ColPFParams, "collaborative particle filter (MUC-OSL)")
class ColPFEstimator(TeamEstimator):
    """Col-PF (Algorithm 1 of the multi-UAV paper); see the module docstring.

    Each iteration ``k``:

    1. ``beta_ij`` (eq. 10) between the UAV's fit of the previous iteration and each
       neighbour's latest fit (received since the last iteration);
    2. weights times the own likelihood and the neighbours' likelihoods to the power ``beta``
       (eq. 13), normalised (eq. 14);
    3. low-variance resampling when ``N_eff < threshold N``, or to the count eq. 18 chose last
       time;
    4. PUGL on ``N_s`` random particles (eq. 15): env-pu upwind (eq. 16), then, while the UAV
       has captured no cue, col-pu towards ``gbest`` of its cue-captured neighbours (eq. 17);
    5. the next particle count (eq. 18);
    6. the Gaussian fit (eqs. 19-20) for the message.
    """

    params: ColPFParams
    Params = ColPFParams

    def reset(
        self,
        ctx: SearchContext,
        model: MeasurementModel,
        rng: np.random.Generator,
        n: int | None = None,
    ) -> None:
        super().reset(ctx, model, rng, n)
        p = self.params
        n_min = p.n_min
        if n_min is None:
            mp = getattr(model, "params", None)
            d_, tau = getattr(mp, "D", None), getattr(mp, "tau", None)
            if d_ is None or tau is None:
                raise ConfigError("n_min", "needs a model with D and tau to derive it")
            lo, hi = np.asarray(ctx.arena.lower), np.asarray(ctx.arena.upper)
            n_min = min(spacing_minimum(float(np.prod(hi - lo)), d_, tau), p.n_max)
        self.counter = CueDistanceCount(p.n_particles, n_min, p.n_max, p.delta_c, p.count_reading)
        start = self.counter.start(float(np.linalg.norm(ctx.start[0] - self.pf.estimate())))
        self.target_n = start if p.adaptive_count else self.pf.n
        self.fit = self.pf.gaussian()
        self.betas: dict[int, float] = {}
        self.n_moved = 0

    def update(
        self, m: Measurement, inbox: Mapping[int, Payload], rng: np.random.Generator
    ) -> None:
        p = self.params
        pf = self.pf
        self._record_cue(m)
        fits = [read_fit_payload(s, inbox[s]) for s in sorted(inbox)]
        mean_i, cov_i = self.fit
        if p.weighting == "confidence":
            d = len(mean_i)
            betas = confidence_factors(
                mean_i,
                cov_i,
                np.array([f.mean for f in fits]).reshape(len(fits), d),
                np.array([f.cov for f in fits]).reshape(len(fits), d, d),
            )
        else:
            betas = np.ones(len(fits))
        self.betas = {f.sender: float(b) for f, b in zip(fits, betas, strict=True)}
        # the own reading and every neighbour's, each against every particle: (1 + H, N)
        counts = [m.count, *(f.count for f in fits)]
        where = np.array([m.position, *(f.position for f in fits)])
        rows = self.model.log_likelihood_rows(counts, where, pf.positions, **m.conditions())
        pf.update(collaborative_log_likelihood(rows[0], rows[1:], betas))
        evaluated = pf.n * (1 + len(fits))
        pf.resample_if_needed(rng, n=self.target_n)
        self.n_moved = self._pugl(m, fits, betas, rng)
        d = pf.positions.shape[1]
        if p.adaptive_count:
            dist = float(np.linalg.norm(m.position - pf.estimate()))
            self.target_n = self.counter.next(pf.n, self.cue_iterations, m.k, dist)
        self.fit = pf.gaussian()
        received = sum(f.mean.size + f.cov.size + f.position.size + 2 for f in fits)
        self.processed = float(evaluated * (d + 1) + self.n_moved * d + received)

    def _pugl(
        self,
        m: Measurement,
        fits: list[NeighbourFit],
        betas: np.ndarray,
        rng: np.random.Generator,
    ) -> int:
        """PUGL (eqs. 15-17) on ``N_s`` random particles; returns ``N_s``."""
        p = self.params
        pf = self.pf
        n_s = moved_count(pf.n, m.k, p.k_max, p.gamma1, p.gamma2)
        if n_s == 0:
            return 0
        sel = rng.choice(pf.n, size=n_s, replace=False)
        x = pf.positions
        env = p.env_pu != "off" and (p.env_pu_from == "start" or self.cue_captured)
        if env and m.direction is not None:
            x = env_position_update(
                x,
                sel,
                -np.asarray(m.direction, float),
                rng,
                step=p.env_step,
                reading=p.env_pu,
                constraint=self.constraint,
            )
        if p.col_pu and not self.cue_captured:
            cued = [(f.mean, b) for f, b in zip(fits, betas, strict=True) if f.cue_captured]
            if cued:
                g = gbest(np.array([c[0] for c in cued]), np.array([c[1] for c in cued]))
                if g is not None:
                    x = col_position_update(x, sel, g, rng, self.constraint)
        pf.replace(x, pf.log_weights)
        return n_s

    def message(self) -> TeamMessage | None:
        """The fit (eqs. 19-20) and the last measurement with its position and the cue flag."""
        if self.last is None:
            return None
        mean, cov = self.fit
        return fit_payload(mean, cov, self.last.count, self.last.position, self.cue_captured)


class StandardPFParams(_FilterParams):
    """Parameters of :class:`StandardPFEstimator`.

    Parameters
    ----------
    share : {"particles", "measurements", "none"}
        What the UAV shares with its neighbours (see the module docstring): its particle set
        (collaborative infotaxis with shared particles, the paper's ``4N``), its measurement, or
        nothing.
    """

    share: Literal["particles", "measurements", "none"] = "particles"


@register("team_estimator", "standard-pf", StandardPFParams, "particle filter of the baselines")
class StandardPFEstimator(TeamEstimator):
    """A particle filter with a fixed count and low-variance resampling; see the module
    docstring for how it collaborates."""

    params: StandardPFParams
    Params = StandardPFParams

    def update(
        self, m: Measurement, inbox: Mapping[int, Payload], rng: np.random.Generator
    ) -> None:
        p = self.params
        pf = self.pf
        self._record_cue(m)
        received = 0
        d = pf.positions.shape[1]
        if p.share == "particles":
            sets = [_read_particles(s, inbox[s], d) for s in sorted(inbox)]
            if sets:
                share = -math.log(1 + len(sets))
                pos = [pf.positions, *(s[0] for s in sets)]
                lw = [pf.log_weights + share, *(s[1] + share for s in sets)]
                pf.replace(np.concatenate(pos), np.concatenate(lw))
                received = sum(s[0].size + s[1].size for s in sets)
        ll = self._own_log_likelihood(m, pf.positions)
        evaluated = pf.n
        if p.share == "measurements":
            cond = m.conditions()
            for s in sorted(inbox):
                got = inbox[s]
                if not isinstance(got, MeasurementMessage) or got.position.size != d:
                    raise ConfigError("message", f"agent {s} sent no measurement")
                ll = ll + self.model.log_likelihood(got.count, got.position, pf.positions, **cond)
                evaluated += pf.n
                received += got.position.size + 2
        pf.update(ll)
        pf.resample_if_needed(rng, n=p.n_particles)
        self.processed = float(evaluated * (d + 1) + received)

    def message(self) -> TeamMessage | None:
        """Positions and weights of every particle, the measurement, or nothing (``share``)."""
        p = self.params
        if p.share == "particles":
            return ParticleSetMessage(self.pf.positions, self.pf.weights)
        if p.share == "measurements" and self.last is not None:
            last = self.last
            return MeasurementMessage(last.count, last.position, self.cue_captured)
        return None


def _read_particles(sender: int, payload: Payload, d: int) -> tuple[np.ndarray, np.ndarray]:
    """A neighbour's particle set: positions ``(N, d)`` and normalised log-weights ``(N,)``."""
    if not isinstance(payload, ParticleSetMessage):
        raise ConfigError("message", f"agent {sender} sent no particle set")
    x = np.asarray(payload.positions, float).reshape(-1, d)
    w = np.asarray(payload.weights, float).reshape(-1)
    if len(w) != len(x) or len(w) == 0:
        raise ConfigError("message", f"agent {sender}: {len(x)} positions, {len(w)} weights")
    with np.errstate(divide="ignore"):
        lw = np.log(w)
    return x, normalise_log_weights(lw)[0]
