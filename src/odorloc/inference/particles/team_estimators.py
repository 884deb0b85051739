"""Per-agent particle estimators that talk to their neighbours (registry family ``team_estimator``).

One instance runs on each UAV of a team. Every iteration (a measurement at a hover point) it
takes the UAV's own :class:`Measurement` and the messages its neighbours sent since the last
iteration, updates its particles and says what to broadcast next (:meth:`TeamEstimator.message`;
the episode delivers it within the communication radius and counts its bytes).

- :class:`ColPFEstimator` (``col-pf``): the collaborative particle filter of the multi-UAV paper
  (MUC-OSL, Algorithm 1): Col-PF weights with confidence factors (eqs. 10-14), low-variance
  resampling, PUGL position update (eqs. 15-17), adaptive particle count (eq. 18), Gaussian fit
  (eqs. 19-20). Its message is the fit plus the measurement the neighbours' likelihood needs,
  with that measurement's conditions. It keeps a measurement history
  (:class:`~odorloc.inference.particles.history.MeasurementHistory`: its own readings and the
  neighbours', each with its exponent), against which PUGL's moves are judged when they are
  reversible (``pugl_move: reversible``, the default; ``printed`` moves as the paper prints it,
  see :mod:`~odorloc.inference.particles.pugl`).
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
from odorloc.inference.particles import colpf_kernels
from odorloc.inference.particles.adaptive_count import CueDistanceCount, spacing_minimum
from odorloc.inference.particles.collaborative import (
    MeasurementMessage,
    NeighbourFit,
    ParticleSetMessage,
    TeamMessage,
    confidence_factors,
    fit_payload,
    read_fit_payload,
    read_measurement_payload,
    reading_conditions,
)
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.filter import ParticleFilter
from odorloc.inference.particles.history import MeasurementHistory
from odorloc.inference.particles.init import sample_free_uniform
from odorloc.inference.particles.pugl import (
    PriorSupport,
    col_position_update,
    env_position_update,
    gbest,
    gbest_gaussian,
    moved_count,
    reversible_col_move,
    reversible_env_move,
)
from odorloc.inference.particles.resampling import Resampler, SystematicResampler
from odorloc.inference.weights import normalise_checked_log_weights, normalise_log_weights
from odorloc.models.base import MeasurementModel

#: Added to the diagonals of both fits in eq. 10's divergence (m^2), as
#: :func:`~odorloc.inference.weights.kl_gaussians` does by default.
KL_JITTER = 1e-9

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
        return reading_conditions(self.dt, self.direction)


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
    def acceptance(self) -> dict[str, float]:
        """Share of the Markov moves accepted so far, per kind (none by default)."""
        return {}

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
    pugl_move : {"reversible", "printed"}
        PUGL's moves as Metropolis-Hastings moves judged by the measurement history
        (``reversible``: eq. 16's step upwind or downwind, eq. 17 as an independence proposal
        around ``gbest``), or as printed (moved particles keep their weights, unjudged, and are
        projected back into the arena); see :mod:`~odorloc.inference.particles.pugl`.
        ``reversible`` takes eq. 16's invariant reading (``env_pu: literal`` has no reversible
        form).
    history : int or None
        Readings (own and received) the measurement history keeps, the latest; ``None`` keeps
        the whole episode. The reversible moves are judged by what it holds.
    col_floor : float, metres
        Standard deviation added on every axis of the reversible col-pu proposal
        (:func:`~odorloc.inference.particles.pugl.gbest_gaussian`).
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
    pugl_move: Literal["reversible", "printed"] = "reversible"
    history: int | None = Field(None, ge=1, le=100_000_000)
    col_floor: NonNegative = 1.0

    @model_validator(mode="after")
    def _bounds(self) -> ColPFParams:
        if self.n_min is not None and self.n_min > self.n_max:
            raise ValueError("n_min must not exceed n_max")
        if self.pugl_move == "reversible" and self.env_pu == "literal":
            raise ValueError(
                "env_pu: literal has no reversible form (its step scales with the coordinates); "
                "use pugl_move: printed with it"
            )
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
        self.history = MeasurementHistory(ctx.dim, p.history)
        self.support = PriorSupport(ctx.arena, ctx.search_region)
        #: proposals and acceptances of the reversible moves so far, per kind
        self.moves = {"env": [0, 0], "col": [0, 0]}
        self._compiled = self._compiled_setup(ctx, model)
        # the compiled path's history log-likelihood of every particle: (positions, values,
        # history version, particle-set version) while the particles have not moved and no
        # reading dropped out
        self._known: tuple[np.ndarray, np.ndarray, int, int] | None = None
        # the compiled path: the weights are a resampling's uniform ones (this iteration)
        self._uniform = False

    def _compiled_setup(self, ctx: SearchContext, model: MeasurementModel) -> tuple | None:
        """The model's constants and the prior's support box for the compiled path
        (:mod:`~odorloc.inference.particles.colpf_kernels`), or ``None``: that path needs a
        3-D model with compiled kernels (``kernel_constants``) and an arena without
        obstacles (its free space a box)."""
        get = getattr(model, "kernel_constants", None)
        consts = get() if callable(get) else None
        if consts is None or ctx.dim != 3 or ctx.arena.occ is not None:
            return None
        lo = np.array(ctx.arena.lo, float)
        hi = np.array(ctx.arena.hi, float)
        arena_lo, arena_hi = lo.copy(), hi.copy()
        region = ctx.search_region
        if region is not None:
            k = len(region[0])
            lo[:k] = np.maximum(lo[:k], np.asarray(region[0], float))
            hi[:k] = np.minimum(hi[:k], np.asarray(region[1], float))
        # the prior's support (PUGL), then the arena's bounds (the resampler's constraint)
        return (*consts, lo, hi, arena_lo, arena_hi)

    def update(
        self, m: Measurement, inbox: Mapping[int, Payload], rng: np.random.Generator
    ) -> None:
        p = self.params
        pf = self.pf
        self._record_cue(m)
        fits = [read_fit_payload(s, inbox[s]) for s in sorted(inbox)]
        mean_i, cov_i = self.fit
        if not fits:
            # nothing received (most iterations): no factors to take
            betas = _NO_BETAS
        elif p.weighting == "confidence":
            d = len(mean_i)
            means = np.array([f.mean for f in fits]).reshape(len(fits), d)
            covs = np.array([f.cov for f in fits]).reshape(len(fits), d, d)
            betas = None
            if self._compiled is not None:
                kl, ok = colpf_kernels.kl_divergences(mean_i, cov_i, means, covs, KL_JITTER)
                # KL >= 0 in exact arithmetic; round-off may leave -1e-12 (eq. 10)
                betas = np.exp(-np.maximum(kl, 0.0)) if ok else None
            if betas is None:
                # the NumPy factors, which also say what is wrong with a covariance
                betas = confidence_factors(mean_i, cov_i, means, covs)
        else:
            betas = np.ones(len(fits))
        self.betas = {f.sender: float(b) for f, b in zip(fits, betas, strict=True)}
        # this iteration's readings, each under its own conditions and with its exponent (1 for
        # the own reading, beta for a neighbour's): eq. 13 in log space
        readings = [
            (m.count, m.position, m.dt, m.direction, 1.0),
            *(
                (f.count, f.position, f.dt, f.direction, float(b))
                for f, b in zip(fits, betas, strict=True)
            ),
        ]
        if self._compiled is None:
            ll = _readings_log_likelihood(self.model, readings, pf.positions)
            pf.update(ll)
            for reading in readings:
                self.history.append(*reading)
        else:
            # the history checks each reading as it takes it; the kernel trusts them
            before = self.history.version
            for reading in readings:
                self.history.append(*reading)
            ll = self._compiled_log_likelihood(readings, pf.positions)
            pf.update(ll)
            known = None if self.history.dropped else self._known_at(before)
            # the history's log-likelihood grows by this iteration's readings (eq. 13)
            self._known = (
                None
                if known is None
                else (pf.positions, known + ll, self.history.version, pf.version)
            )
            self._uniform = False
        evaluated = pf.n * len(readings)
        if self._compiled is not None and type(pf.resampler) is SystematicResampler:
            self._compiled_resample(rng)
        else:
            pf.resample_if_needed(rng, n=self.target_n)
        if p.pugl_move == "reversible":
            self.n_moved, judged = self._pugl_reversible(m, fits, betas, rng)
        else:
            self.n_moved, judged = self._pugl(m, fits, betas, rng), 0
        d = pf.positions.shape[1]
        if p.adaptive_count:
            # numpy.linalg.norm of a vector is sqrt(v . v): called directly
            gap = m.position - pf.estimate()
            dist = math.sqrt(float(gap.dot(gap)))
            self.target_n = self.counter.next(pf.n, self.cue_iterations, m.k, dist)
        if self._compiled is not None:
            self.fit = colpf_kernels.weighted_fit(pf.positions, pf.weights)
        else:
            self.fit = pf.gaussian()
        received = sum(f.mean.size + f.cov.size + f.position.size + 2 for f in fits)
        self.processed = float(
            (evaluated + judged * len(self.history)) * (d + 1) + self.n_moved * d + received
        )

    def _pugl(
        self,
        m: Measurement,
        fits: list[NeighbourFit],
        betas: np.ndarray,
        rng: np.random.Generator,
    ) -> int:
        """PUGL (eqs. 15-17) as printed on ``N_s`` random particles; returns ``N_s``."""
        p = self.params
        pf = self.pf
        n_s = moved_count(pf.n, m.k, p.k_max, p.gamma1, p.gamma2)
        if n_s == 0:
            return 0
        sel = rng.choice(pf.n, size=n_s, replace=False)
        x = pf.positions
        if self._env_applies(m):
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

    def _env_applies(self, m: Measurement) -> bool:
        p = self.params
        env = p.env_pu != "off" and (p.env_pu_from == "start" or self.cue_captured)
        # env-pu needs the wind it moves against: the UAV's measured direction
        return env and m.direction is not None

    def _pugl_reversible(
        self,
        m: Measurement,
        fits: list[NeighbourFit],
        betas: np.ndarray,
        rng: np.random.Generator,
    ) -> tuple[int, int]:
        """PUGL (eqs. 15-17) as reversible Metropolis-Hastings moves of ``N_s`` random
        particles, judged by the measurement history; returns ``N_s`` and the number of
        history evaluations."""
        p = self.params
        pf = self.pf
        n_s = moved_count(pf.n, m.k, p.k_max, p.gamma1, p.gamma2)
        if n_s == 0:
            return 0, 0
        sel = rng.choice(pf.n, size=n_s, replace=False)
        env = self._env_applies(m)
        proposal = None
        if p.col_pu and not self.cue_captured:
            cued = [(f, b) for f, b in zip(fits, betas, strict=True) if f.cue_captured]
            if cued:
                proposal = gbest_gaussian(
                    np.array([f.mean for f, _ in cued]),
                    np.array([f.cov for f, _ in cued]),
                    np.array([b for _, b in cued]),
                    p.col_floor,
                )
        if not env and proposal is None:
            return n_s, 0
        if self._compiled is not None:
            return n_s, self._compiled_moves(m, sel, env, proposal, rng)

        def target(points: np.ndarray) -> np.ndarray:
            return self.history.log_likelihood(self.model, points)

        x = pf.positions.copy()
        xs = x[sel]
        ll = target(xs)
        judged = n_s
        if env:
            res = reversible_env_move(
                xs, ll, -np.asarray(m.direction, float), p.env_step, rng, target, self.support
            )
            xs, ll, judged = res.positions, res.log_likelihood, judged + res.evaluated
            self.moves["env"][0] += n_s
            self.moves["env"][1] += int(res.accepted.sum())
        if proposal is not None:
            res = reversible_col_move(xs, ll, *proposal, rng, target, self.support)
            xs, judged = res.positions, judged + res.evaluated
            self.moves["col"][0] += n_s
            self.moves["col"][1] += int(res.accepted.sum())
        x[sel] = xs
        pf.replace(x, pf.log_weights)
        return n_s, judged

    def _known_at(self, version: int) -> np.ndarray | None:
        """The kept history log-likelihood of every particle, ``(N,)``, if it was taken at
        history ``version`` and the particles have not moved since; else ``None``."""
        known = self._known
        if known is None or known[2] != version:
            return None
        pf = self.pf
        # an unchanged set, or one replaced by the same positions
        if known[3] == pf.version or _same(known[0], pf.positions):
            return known[1]
        return None

    def _compiled_resample(self, rng: np.random.Generator) -> None:
        """``pf.resample_if_needed(rng, n=target_n)`` with the low-variance resampler in one
        compiled pass (:func:`~odorloc.inference.particles.colpf_kernels.resample_systematic`),
        drawing the offset and then the roughening as the resampler does."""
        pf = self.pf
        target = int(self.target_n)
        if target == pf.n and not pf.needs_resampling():
            return
        if target < 1:
            raise ConfigError("n", f"the target particle count must be >= 1, got {target}")
        d = pf.positions.shape[1]
        u0 = rng.random()
        std = float(pf.resampler.params.jitter_std)  # type: ignore[union-attr]
        noise = rng.normal(0.0, std, size=(target, d)) if std > 0 else np.zeros((0, d))
        # the weights as the resampler reads them: from the log-weights (the filter's, whose
        # maximum is finite)
        w = normalise_checked_log_weights(pf.log_weights)[1]
        lo, hi = self._compiled[7], self._compiled[8]
        x = colpf_kernels.resample_systematic(pf.positions, w, target, u0, noise, lo, hi)
        # copies of checked particles moved by finite noise and clipped into the arena: finite
        # by construction. The uniform weights as replace() would normalise them, bit for bit:
        # the shifted log-weights are 0, their exponentials 1, their sum ``target``.
        pf.adopt(
            x,
            np.full(target, 0.0 - math.log(target)),
            np.full(target, 1.0 / target),
            resampled=True,
        )
        self._uniform = True

    def _compiled_log_likelihood(self, readings: list[Reading], x: np.ndarray) -> np.ndarray:
        """:func:`_readings_log_likelihood` in one compiled pass of ``readings``, the history's
        latest (appended and checked just before)."""
        aq, adv, inv_lam, a2, default = self._compiled[:5]
        k = len(readings)
        if k <= len(self.history):
            # the history holds them as the arrays below would (numbers made float, no
            # direction a NaN row): read them there
            counts, where, dts, dirs, exps = self.history.latest(k)
        else:
            # a history bounded below one iteration's readings
            d = x.shape[1]
            nan = np.full(d, np.nan)
            where = np.array([r[1] for r in readings], float).reshape(k, d)
            dirs = np.array([nan if r[3] is None else r[3] for r in readings], float)
            counts = np.array([r[0] for r in readings], float)
            dts = np.array([r[2] for r in readings], float)
            exps = np.array([r[4] for r in readings], float)
        return colpf_kernels.readings_log_likelihood(
            # a writable copy: the kernel is compiled for one array type
            np.array(x, float, order="C"),
            where,
            dirs,
            counts,
            dts,
            exps,
            default,
            aq,
            adv,
            inv_lam,
            a2,
        )

    def _compiled_moves(
        self,
        m: Measurement,
        sel: np.ndarray,
        env: bool,
        proposal: tuple[np.ndarray, np.ndarray] | None,
        rng: np.random.Generator,
    ) -> int:
        """:meth:`_pugl_reversible`'s moves in one compiled pass
        (:func:`~odorloc.inference.particles.colpf_kernels.reversible_moves`); the random
        numbers drawn here with the calls, in the order, of
        :func:`~odorloc.inference.particles.pugl.reversible_env_move` and
        :func:`~odorloc.inference.particles.pugl.reversible_col_move`. Returns the history
        evaluations."""
        p = self.params
        pf = self.pf
        aq, adv, inv_lam, a2, default, lo, hi = self._compiled[:7]
        n_s = len(sel)
        x = pf.positions
        d = x.shape[1]
        up = _NO_WIND
        # the kernel's arguments of a move not proposed (read, never written)
        env_draws, centre, chol, normals, uniforms = _NO_MOVE
        env_on = False
        if env:
            self.moves["env"][0] += n_s
            # against the wind's horizontal part (env_applies: a measured direction)
            ux, uy = -float(m.direction[0]), -float(m.direction[1])  # type: ignore[index]
            norm = math.hypot(ux, uy)
            # no horizontal wind: no env-pu proposal (and no draws), as the NumPy move
            if norm >= 1e-12:
                up = np.array([ux / norm, uy / norm, 0.0])
                env_on = True
                env_draws = rng.random((n_s, 3))
        if proposal is not None:
            self.moves["col"][0] += n_s
            centre = np.asarray(proposal[0], float)
            try:
                chol = np.linalg.cholesky(np.asarray(proposal[1], float))
            except np.linalg.LinAlgError:
                raise ConfigError(
                    "cov", "the col-pu proposal needs a positive definite covariance"
                ) from None
            normals = rng.standard_normal((n_s, d))
            uniforms = rng.random(n_s)
        counts, where, dts, dirs, exps = self.history.held()
        known = self._known_at(self.history.version)
        # without a kept evaluation the kernel evaluates every particle once: kept for the next
        # iterations while they stay put
        x, ll, env_acc, col_acc, evaluated = colpf_kernels.reversible_moves_of_set(
            x,
            sel,
            _NO_LL if known is None else known,
            known is not None,
            where,
            dirs,
            counts,
            dts,
            exps,
            default,
            aq,
            adv,
            inv_lam,
            a2,
            lo,
            hi,
            env_on,
            up,
            float(p.env_step),
            env_draws,
            proposal is not None,
            centre,
            chol,
            normals,
            uniforms,
        )
        self.moves["env"][1] += int(env_acc)
        self.moves["col"][1] += int(col_acc)
        # the moved particles lie in the prior's support (a proposal outside is rejected), the
        # others where they were: finite by construction. The weights as replace() would
        # renormalise them: unchanged if uniform (a resampling's), else the same arithmetic.
        if self._uniform:
            pf.adopt(x)
        else:
            pf.adopt(x, *normalise_checked_log_weights(pf.log_weights))
        self._known = (x, ll, self.history.version, pf.version)
        # the work of eq. 7 as the NumPy path counts it: the selected particles, then every
        # proposal in the support
        return n_s + int(evaluated)

    def acceptance(self) -> dict[str, float]:
        """Share of the reversible moves accepted so far, per kind (NaN before any)."""
        return {k: (a / n if n else math.nan) for k, (n, a) in self.moves.items()}

    def message(self) -> TeamMessage | None:
        """The fit (eqs. 19-20) and the last measurement with its position, the cue flag and
        its conditions (exposure, wind direction)."""
        if self.last is None:
            return None
        mean, cov = self.fit
        last = self.last
        return fit_payload(
            mean, cov, last.count, last.position, self.cue_captured, last.dt, last.direction
        )


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
        if p.share == "measurements":
            # the own reading and every neighbour's, each under its own conditions, unweighted
            # (eq. 11 with beta = 1)
            readings = [(m.count, m.position, m.dt, m.direction, 1.0)]
            for s in sorted(inbox):
                got = read_measurement_payload(s, inbox[s], d)
                readings.append((got.count, got.position, got.dt, got.direction, 1.0))
                received += got.numbers
            ll = _readings_log_likelihood(self.model, readings, pf.positions)
            evaluated = pf.n * len(readings)
        else:
            ll = self._own_log_likelihood(m, pf.positions)
            evaluated = pf.n
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
            return MeasurementMessage(
                last.count, last.position, self.cue_captured, last.dt, last.direction
            )
        return None


#: the compiled moves' arguments of a move not proposed (3-D): env-pu draws, the col-pu centre,
#: Cholesky factor, normals and uniforms
_NO_MOVE = (np.zeros((0, 3)), np.zeros(3), np.eye(3), np.zeros((0, 3)), np.zeros(0))
#: the compiled moves' kept log-likelihoods when none are kept, and their upwind direction
#: without env-pu (read, never written)
_NO_LL = np.zeros(0)
_NO_WIND = np.zeros(3)
#: the confidence factors of an iteration without messages
_NO_BETAS = np.zeros(0)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """``numpy.array_equal`` of two finite arrays, without its conversions."""
    return a.shape == b.shape and bool((a == b).all())


Reading = tuple[float, np.ndarray, float, "np.ndarray | None", float]
"""``(count, position, dt, direction, exponent)`` of one reading."""


def _readings_log_likelihood(
    model: MeasurementModel, readings: list[Reading], positions: np.ndarray
) -> np.ndarray:
    """``sum_k e_k log p(z_k | x_n)`` of readings each under its own conditions, ``(N,)``."""
    d = positions.shape[1]
    counts = np.array([r[0] for r in readings], float)
    where = np.array([r[1] for r in readings], float).reshape(len(readings), d)
    dts = np.array([r[2] for r in readings], float)
    exps = np.array([r[4] for r in readings], float)
    record: dict[str, np.ndarray] = {"dt": dts}
    if any(r[3] is not None for r in readings):
        record["direction"] = np.array(
            [np.full(d, np.nan) if r[3] is None else r[3] for r in readings], float
        )
    return model.weighted_log_likelihood(counts, where, positions, exps, record)


def _read_particles(sender: int, payload: Payload, d: int) -> tuple[np.ndarray, np.ndarray]:
    """A neighbour's particle set: positions ``(N, d)`` and normalised log-weights ``(N,)``."""
    if not isinstance(payload, ParticleSetMessage):
        raise ConfigError("message", f"agent {sender} sent no particle set")
    x = np.asarray(payload.positions, float)
    w = np.asarray(payload.weights, float).reshape(-1)
    if x.size % d:
        raise ConfigError("message", f"agent {sender}: {x.size} coordinates for {d}-D particles")
    x = x.reshape(-1, d)
    if len(w) != len(x) or len(w) == 0:
        raise ConfigError("message", f"agent {sender}: {len(x)} positions, {len(w)} weights")
    with np.errstate(divide="ignore"):
        lw = np.log(w)
    return x, normalise_log_weights(lw)[0]
