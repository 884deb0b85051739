"""Bayesian source-term estimation: a resample-move particle filter over ``theta``.

The estimator (registry ``estimator/ste-pf``) keeps ``N`` particles over the source term
``theta`` (position, release rate and, when asked, wind speed and direction, a dispersion factor,
a background, several sources: :mod:`odorloc.models.source_term`) and every reading so far.

Each reading ``y_t`` multiplies the weights by its likelihood ``p(y_t | theta)`` (the model's
law: censored Gaussian readings, detections or Poisson counts). The posterior of a static
parameter degenerates under plain importance sampling, so

- **resample-move** (Gilks & Berzuini 2001): when the effective sample size
  ``ESS = 1 / sum w^2`` falls below ``resample_threshold N`` the particles are resampled
  (systematic) and every particle takes ``mcmc_steps`` Metropolis-Hastings steps that leave the
  *current* posterior ``p(theta | y_1:t)`` invariant, judged by the likelihood of the whole
  history: a proposal ``theta'`` is accepted with probability
  ``min(1, p(theta') p(y_1:t | theta') / (p(theta) p(y_1:t | theta)))``;
- the proposal is a Gaussian random walk whose covariance is the particle cloud's own,
  scaled by ``c``: ``theta' = theta + c L xi``, ``L L^T = Cov(theta)``, ``c`` starting at
  ``2.38 / sqrt(P)`` (Roberts, Gelman & Gilks 1997) and adapted after every sweep towards the
  acceptance rate ``target_acceptance`` (``log c += gain (accepted - target)``; each sweep
  uses one fixed ``c``, so it is a valid MH kernel);
- **likelihood tempering / progressive correction** (Oudjane & Musso 2000; Jasra et al.
  2011): a reading that would collapse the ESS (the first detections) is brought in by steps
  ``0 = phi_0 < phi_1 < ... < 1``, each chosen by bisection so that reweighting by
  ``p(y_t | theta)^(phi_j - phi_{j-1})`` keeps ``ESS >= tempering_ess N``; after each step the
  particles are resampled and moved under ``p(theta) p(y_1:t-1 | theta) p(y_t | theta)^phi_j``;
- **several sources**: ``max_sources`` slots with activity flags; besides the random walk
  (of one slot per particle and step, and the shared components), a birth/death move flips
  one slot (Carlin & Chib 1995, a product space in which an empty slot keeps parameters drawn
  from its prior; the new source of a birth is drawn from the prior, which cancels its prior
  density in the acceptance ratio ``p(a') p(y | theta') / (p(a) p(y | theta))``), and empty
  slots are redrawn from the prior after each step.

Outputs: the posterior mean and covariance, the 95 % credible region of the position and the
rate interval (:class:`~odorloc.inference.source_terms.belief.CredibleRegion`), the ESS, and
the convergence test ``sqrt(trace Cov(position)) < convergence_radius`` (several sources: the
most probable count has probability >= 1/2 and each of its sources spreads less than that).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Observation, Region, SearchContext
from odorloc.geometry.regions import check_region, narrow_box, task_region
from odorloc.inference.estimator import Estimator
from odorloc.inference.particles.resampling import systematic
from odorloc.inference.source_terms.belief import SourceTermBelief
from odorloc.inference.source_terms.multi import ExtractedSources, extract_sources
from odorloc.inference.source_terms.priors import (
    BackgroundPrior,
    DirectionPrior,
    FactorPrior,
    LogUniformPrior,
    RatePrior,
    SourceTermPrior,
    SpeedPrior,
    count_prior,
    wrap_angle,
)
from odorloc.inference.weights import normalise_log_weights
from odorloc.models.base import MeasurementModel
from odorloc.models.source_term import SourceTermModel, SourceTerms, ThetaLayout
from odorloc.sensors.preprocessing import WindAverage

__all__ = ["SourceTermEstimator", "SourceTermParams"]


class SourceTermParams(Params):
    """Parameters of :class:`SourceTermEstimator` (see the module docstring).

    Attributes
    ----------
    n_particles : int
        Particles ``N`` of the posterior over source terms (fixed for the episode).
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Box of the position prior (default: the task's search region, else the arena; a
        2-component box in 3-D keeps the arena's height).
    rate : prior
        Release-rate prior (log-uniform or uniform), in the model's rate unit.
    wind_speed, wind_direction, dispersion, background : prior, optional
        Estimate these components under these priors (``None``: use the measured wind, a
        dispersion factor of 1 and the model's background).
    max_sources, min_sources : int
        Source slots and the fewest active sources.
    source_count : {"uniform", "poisson"}
        Prior of the number of sources on ``[min_sources, max_sources]``.
    source_count_mean : float
        Mean of the Poisson count prior.
    resample_threshold : float
        Resample (and move) when ``ESS < resample_threshold N``.
    mcmc_steps : int
        Metropolis-Hastings steps per resampling.
    target_acceptance : float
        Acceptance rate the random-walk scale is adapted to.
    adapt_gain : float
        Step of the scale's adaptation, ``log c += adapt_gain (rate - target)``.
    tempering : bool
        Bring readings that would collapse the ESS in by tempered steps.
    tempering_ess : float
        ESS fraction each tempered step keeps.
    max_stages : int
        Most tempered steps per reading (the last one takes what remains).
    convergence_radius : float, metres
        :meth:`SourceTermEstimator.converged` when ``sqrt(trace Cov(position))`` is below it.
    credible_level : float
        Level of the credible region reported.
    wind_average : int
        Anemometer readings averaged into the measured wind of a reading.
    exposure : float, s, optional
        Exposure of a reading (counts); default the control period.
    snapshot_particles : int
        Particles kept in a recorded belief snapshot.
    """

    n_particles: int = Field(5000, ge=10, le=1_000_000)
    region: Region | None = None
    rate: RatePrior = LogUniformPrior(low=0.1, high=100.0)
    wind_speed: SpeedPrior | None = None
    wind_direction: DirectionPrior | None = None
    dispersion: FactorPrior | None = None
    background: BackgroundPrior | None = None
    max_sources: int = Field(1, ge=1, le=8)
    min_sources: int = Field(1, ge=0, le=8)
    source_count: Literal["uniform", "poisson"] = "uniform"
    source_count_mean: Positive = 1.0
    resample_threshold: float = Field(0.5, gt=0.0, le=1.0)
    mcmc_steps: int = Field(6, ge=0, le=100)
    target_acceptance: float = Field(0.25, gt=0.0, lt=1.0)
    adapt_gain: Positive = 1.0
    tempering: bool = True
    tempering_ess: float = Field(0.5, gt=0.0, lt=1.0)
    max_stages: int = Field(20, ge=1, le=1000)
    convergence_radius: Positive = 1.0
    credible_level: float = Field(0.95, gt=0.0, lt=1.0)
    wind_average: int = Field(10, ge=1, le=10_000)
    exposure: Positive | None = None
    snapshot_particles: int = Field(2000, ge=10, le=1_000_000)

    @model_validator(mode="after")
    def _counts(self) -> SourceTermParams:
        if self.min_sources > self.max_sources:
            raise ValueError(f"min_sources ({self.min_sources}) exceeds max_sources")
        if self.region is not None:
            check_region(self.region, "region")
        return self


def _ess_fraction(log_w: np.ndarray) -> float:
    w = normalise_log_weights(log_w)[1]
    # an element-wise sum, not BLAS: a threaded dot product waits for cores on a busy machine
    return float(1.0 / (len(w) * (w * w).sum()))


@register("estimator", "ste-pf", SourceTermParams, "source-term particle filter, resample-move")
class SourceTermEstimator(Estimator):
    """Resample-move particle filter over source terms (see the module docstring).

    ``reset`` needs a :class:`~odorloc.models.source_term.SourceTermModel`. Particles are
    drawn from the prior at the first reading (a ``"measured"`` wind prior is centred on it).
    """

    params: SourceTermParams
    Params = SourceTermParams
    #: an offline replay's model (a steady Gaussian plume with Pasquill-Gifford dispersion)
    default_model: ClassVar[Mapping[str, Any] | None] = {"type": "ste-gaussian"}

    def __init__(self, params: SourceTermParams | None = None) -> None:
        super().__init__(params or SourceTermParams())

    # ------------------------------------------------------------------ episode
    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        if not isinstance(model, SourceTermModel):
            raise ConfigError(
                "model",
                "the source-term estimator needs a source-term model "
                "(ste-gaussian, ste-vergassola or ste-adapter)",
            )
        p = self.params
        self.ctx = ctx
        self.rng = rng
        self.model = model.with_sensor(ctx.sensor)
        self.layout = ThetaLayout(
            ctx.dim,
            p.max_sources,
            speed=p.wind_speed is not None,
            direction=p.wind_direction is not None,
            dispersion=p.dispersion is not None,
            background=p.background is not None,
        )
        self.model.check_layout(self.layout)
        self.lower, self.upper = self._box(ctx)
        self.counts = count_prior(p.min_sources, p.max_sources, p.source_count, p.source_count_mean)
        self.dt = p.exposure if p.exposure is not None else float(ctx.dt)
        self.prior: SourceTermPrior | None = None
        self.theta = np.zeros((0, self.layout.n_columns))
        self.logw = np.zeros(0)
        self.ll = np.zeros(0)
        d = ctx.dim
        self._z = np.zeros(64)
        self._s = np.zeros((64, d))
        self._w = np.zeros((64, d))
        self._t = np.zeros(64)
        self.n_read = 0
        self._winds = WindAverage(p.wind_average)
        self.scale = 2.38 / math.sqrt(self._moved_dimension())
        self.n_moves = 0
        self.n_resamples = 0
        self.tempered = 0
        self.last_stages = 0
        self.last_acceptance = math.nan
        self._acc_sum = 0.0
        self._acc_n = 0
        self._belief: SourceTermBelief | None = None

    def _box(self, ctx: SearchContext) -> tuple[np.ndarray, np.ndarray]:
        if self.params.region is not None:
            region, field = check_region(self.params.region, "estimator.region"), "estimator.region"
        else:
            region, field = task_region(ctx), "task.region"
        return narrow_box(ctx.arena.lo, ctx.arena.hi, region, field)

    def _moved_dimension(self) -> int:
        lay = self.layout
        shared = lay.n_columns - lay.slots * lay.block - (lay.slots if lay.slots > 1 else 0)
        return lay.block + shared

    def _start(self, wind: np.ndarray) -> None:
        p = self.params
        self.prior = SourceTermPrior(
            self.layout,
            self.lower,
            self.upper,
            self.ctx.arena,
            p.rate,
            p.wind_speed,
            p.wind_direction,
            p.dispersion,
            p.background,
            self.counts,
            wind,
        )
        self.theta = self.prior.sample(p.n_particles, self.rng)
        self.logw = np.full(p.n_particles, -math.log(p.n_particles))
        self.ll = np.zeros(p.n_particles)

    # ------------------------------------------------------------------ readings
    def _append(self, z: float, pos: np.ndarray, wind: np.ndarray) -> None:
        if self.n_read == len(self._z):
            grow = 2 * len(self._z)
            self._z = np.resize(self._z, grow)
            self._t = np.resize(self._t, grow)
            self._s = np.vstack([self._s, np.zeros_like(self._s)])
            self._w = np.vstack([self._w, np.zeros_like(self._w)])
        i = self.n_read
        self._z[i], self._s[i], self._w[i], self._t[i] = z, pos, wind, self.dt
        self.n_read += 1

    def _loglik(self, sl: slice, theta: np.ndarray) -> np.ndarray:
        """Log-likelihood of the readings ``sl`` for ``theta`` rows, ``(n,)``."""
        if sl.stop - sl.start <= 0 or len(theta) == 0:
            return np.zeros(len(theta))
        return self.model.log_likelihood_sum(
            self._z[sl], self._s[sl], SourceTerms(theta, self.layout), self._w[sl], self._t[sl]
        )

    def conditions(self) -> dict[str, Any]:
        """Conditions of the next reading for a planner: the measured mean ``wind`` and ``dt``."""
        d = self.ctx.dim
        wind = self._winds.mean if self.n_read else np.zeros(d)
        return {"wind": wind, "dt": self.dt}

    def update(self, observation: Observation) -> None:
        """Fold in one reading (module docstring)."""
        o = observation
        d = self.ctx.dim
        pos = np.asarray(o.position, float).reshape(-1)
        if pos.shape != (d,) or not np.all(np.isfinite(pos)):
            raise ConfigError("position", f"needs {d} finite components, got {pos.tolist()}")
        w = np.asarray(o.wind, float).reshape(-1)
        if w.shape != (d,) or not np.all(np.isfinite(w)):
            raise ConfigError("wind", f"needs {d} finite components, got {w.tolist()}")
        z = float(self.model.reading(o))
        if not math.isfinite(z):
            raise ConfigError("reading", f"must be finite, got {z}")
        wind = self._winds.add(w)
        if self.prior is None:
            self._start(wind)
        self._append(z, pos, wind)
        last = slice(self.n_read - 1, self.n_read)
        self._assimilate(self._loglik(last, self.theta))
        self._belief = None

    # ------------------------------------------------------------------ the filter
    def _assimilate(self, ll_new: np.ndarray) -> None:
        p = self.params
        lw = self.logw
        phi, stages = 0.0, 0
        while True:
            rest = 1.0 - phi
            stages += 1
            delta = rest
            if (
                p.tempering
                and stages < p.max_stages
                and _ess_fraction(lw + rest * ll_new) < p.tempering_ess
            ):
                delta = self._bisect(lw, ll_new, rest, p.tempering_ess)
            lw = lw + delta * ll_new
            phi = phi + delta if delta < rest else 1.0
            if phi >= 1.0:
                break
            # an intermediate step: resample, then move under the tempered posterior
            self.logw = lw
            (ll_new,) = self._resample(ll_new)
            lw = self.logw
            ll_new = self._move(phi, ll_new)
        self.logw = normalise_log_weights(lw)[0]
        self.ll = self.ll + ll_new
        self.last_stages = stages
        self.tempered += stages - 1
        if _ess_fraction(self.logw) < p.resample_threshold:
            self._resample()
            self._move(1.0, None)

    @staticmethod
    def _bisect(lw: np.ndarray, ll: np.ndarray, rest: float, target: float) -> float:
        """The largest step in ``(0, rest]`` that keeps the ESS fraction at ``target``."""
        lo, hi = 0.0, rest
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            if _ess_fraction(lw + mid * ll) >= target:
                lo = mid
            else:
                hi = mid
        return max(lo, 1e-4 * rest)

    def _resample(self, *extra: np.ndarray) -> tuple[np.ndarray, ...]:
        n = len(self.theta)
        idx = systematic(normalise_log_weights(self.logw)[1], n, self.rng)
        self.theta = self.theta[idx]
        self.ll = self.ll[idx]
        self.logw = np.full(n, -math.log(n))
        self.n_resamples += 1
        return tuple(e[idx] for e in extra)

    def _proposal_factors(self) -> tuple[np.ndarray, np.ndarray | None]:
        """Cholesky factors of the random walk: the slot block ``(b, b)`` and the shared
        components ``(g, g)`` (``None`` without any)."""
        lay, th = self.layout, self.theta
        act = SourceTerms(th, lay).active
        blocks = [
            th[act[:, k]][:, [*range(k * lay.block, (k + 1) * lay.block)]] for k in range(lay.slots)
        ]
        pooled = np.vstack(blocks) if blocks else np.zeros((0, lay.block))
        if len(pooled) < 2:
            pooled = th[:, : lay.block]
        shared = [c for c in range(lay.n_columns) if c >= lay.slots * lay.block]
        shared = [c for c in shared if not (0 <= c - lay.active_start < lay.slots)]

        def factor(x: np.ndarray) -> np.ndarray:
            cov = np.atleast_2d(np.cov(x.T)) if len(x) > 1 else np.eye(x.shape[1])
            jitter = 1e-10 + 1e-6 * float(np.trace(cov)) / len(cov)
            return np.linalg.cholesky(cov + jitter * np.eye(len(cov)))

        return factor(pooled), (factor(th[:, shared]) if shared else None)

    def _move(self, phi: float, ll_new: np.ndarray | None) -> np.ndarray | None:
        """``mcmc_steps`` MH sweeps under ``prior x L(history) x L(last)^phi``; ``ll_new`` is
        the last reading's log-likelihood when it is tempered (``None``: the whole history at
        full weight)."""
        p = self.params
        if p.mcmc_steps == 0:
            return ll_new
        assert self.prior is not None
        lay, n = self.layout, len(self.theta)
        t = self.n_read
        hist = slice(0, t - 1) if ll_new is not None else slice(0, t)
        last = slice(t - 1, t)
        lp = self.prior.log_density(self.theta)
        lb, lg = self._proposal_factors()
        shared = [
            c
            for c in range(lay.slots * lay.block, lay.n_columns)
            if not (0 <= c - lay.active_start < lay.slots)
        ]
        dir_col = lay.column("direction")
        for _ in range(p.mcmc_steps):
            prop = self.theta.copy()
            slot = self.rng.integers(lay.slots, size=n) if lay.slots > 1 else np.zeros(n, int)
            xi = self.rng.standard_normal((n, lay.block)) @ lb.T * self.scale
            for k in range(lay.slots):
                rows = slot == k
                prop[rows, k * lay.block : (k + 1) * lay.block] += xi[rows]
            if lg is not None:
                prop[:, shared] += self.rng.standard_normal((n, len(shared))) @ lg.T * self.scale
            if dir_col >= 0:
                prop[:, dir_col] = wrap_angle(prop[:, dir_col])
            lp_new = self.prior.log_density(prop)
            ll_h, ll_l = self._evaluate(prop, lp_new, hist, last if ll_new is not None else None)
            accepted = self._accept(lp_new, ll_h, ll_l, lp, ll_new, phi)
            self.theta[accepted] = prop[accepted]
            lp[accepted] = lp_new[accepted]
            self.ll[accepted] = ll_h[accepted]
            if ll_new is not None:
                ll_new[accepted] = ll_l[accepted]
            rate = float(accepted.mean())
            self.last_acceptance = rate
            self._acc_sum += rate
            self._acc_n += 1
            self.scale = float(
                np.clip(
                    self.scale * math.exp(p.adapt_gain * (rate - p.target_acceptance)), 1e-3, 10.0
                )
            )
            if lay.slots > 1:
                self._birth_death(lp, phi, ll_new, hist, last)
        self.n_moves += 1
        return ll_new

    def _evaluate(
        self, prop: np.ndarray, lp_new: np.ndarray, hist: slice, last: slice | None
    ) -> tuple[np.ndarray, np.ndarray]:
        ok = np.isfinite(lp_new)
        ll_h = np.full(len(prop), -np.inf)
        ll_l = np.zeros(len(prop))
        if ok.any():
            sub = prop[ok]
            ll_h[ok] = self._loglik(hist, sub)
            if last is not None:
                ll_l[ok] = self._loglik(last, sub)
        return ll_h, ll_l

    def _accept(
        self,
        lp_new: np.ndarray,
        ll_h: np.ndarray,
        ll_l: np.ndarray,
        lp: np.ndarray,
        ll_new: np.ndarray | None,
        phi: float,
    ) -> np.ndarray:
        """MH decisions ``log u < log target(new) - log target(old)`` (``lp_new``, ``lp``: the
        log prior parts)."""
        new = lp_new + ll_h
        old = lp + self.ll
        if ll_new is not None:
            new = new + phi * ll_l
            old = old + phi * ll_new
        u = np.log(self.rng.random(len(new)))
        with np.errstate(invalid="ignore"):
            log_alpha = new - old
        # an impossible current state takes any possible proposal
        log_alpha = np.where(np.isneginf(old) & np.isfinite(new), np.inf, log_alpha)
        return np.isfinite(new) & (u < log_alpha)

    def _birth_death(
        self,
        lp: np.ndarray,
        phi: float,
        ll_new: np.ndarray | None,
        hist: slice,
        last: slice,
    ) -> None:
        """One birth/death proposal per particle, then empty slots redrawn from the prior."""
        assert self.prior is not None
        lay, n, rng = self.layout, len(self.theta), self.rng
        a0 = lay.active_start
        flags = self.theta[:, a0 : a0 + lay.slots] > 0.5
        count = flags.sum(axis=1)
        k = rng.integers(lay.slots, size=n)
        born = ~flags[np.arange(n), k]
        new_count = count + np.where(born, 1, -1)
        valid = (new_count >= self.params.min_sources) & (new_count <= lay.slots)
        prop = self.theta.copy()
        prop[np.arange(n), a0 + k] = born.astype(float)
        for j in range(lay.slots):
            self.prior.redraw_slot(prop, np.flatnonzero(k == j), j, rng)
        lp_new = np.where(valid, self.prior.log_density(prop), -np.inf)
        ll_h, ll_l = self._evaluate(prop, lp_new, hist, last if ll_new is not None else None)
        # the slot's prior density cancels with its proposal: only the flags' prior remains
        pat = self.prior.log_pattern
        with np.errstate(invalid="ignore"):
            extra = np.where(valid, pat[np.clip(new_count, 0, lay.slots)] - pat[count], -np.inf)
        accepted = self._accept(np.where(valid, lp + extra, -np.inf), ll_h, ll_l, lp, ll_new, phi)
        self.theta[accepted] = prop[accepted]
        self.ll[accepted] = ll_h[accepted]
        if ll_new is not None:
            ll_new[accepted] = ll_l[accepted]
        lp[accepted] = lp_new[accepted]
        flags = self.theta[:, a0 : a0 + lay.slots] > 0.5
        for j in range(lay.slots):
            empty = np.flatnonzero(~flags[:, j])
            self.prior.redraw_slot(self.theta, empty, j, rng)
        lp[:] = self.prior.log_density(self.theta)

    # ------------------------------------------------------------------ outputs
    def belief(self) -> SourceTermBelief | None:
        """The particles (``None`` before the first reading)."""
        if self.n_read == 0:
            return None
        if self._belief is None:
            self._belief = SourceTermBelief.of(
                self.theta, self.logw, self.layout, self.params.snapshot_particles
            )
        return self._belief

    def sources(self) -> ExtractedSources | None:
        """The sources read from the posterior (several slots), ``None`` before a reading."""
        b = self.belief()
        if b is None:
            return None
        return extract_sources(b.terms, b.weights)

    def estimate(self) -> np.ndarray:
        """Posterior mean position ``(1, d)``; several slots: the extracted sources ``(K, d)``."""
        b = self.belief()
        if b is None:
            return np.zeros((0, self.ctx.dim))
        if self.layout.slots > 1:
            s = self.sources()
            assert s is not None
            return s.positions
        return b.mean[None, :]

    def spread(self) -> float:
        """``sqrt(trace Cov(position))``, metres (first slot; ``inf`` before a reading)."""
        b = self.belief()
        if b is None:
            return math.inf
        # trace of the weighted covariance, element-wise (no BLAS call on every step)
        w = b.weights[:, None]
        m = (w * b.positions).sum(axis=0)
        return float(math.sqrt(max(float((w * (b.positions - m) ** 2).sum()), 0.0)))

    def converged(self) -> bool:
        """The convergence test of the module docstring."""
        b = self.belief()
        if b is None:
            return False
        r = self.params.convergence_radius
        if self.layout.slots == 1:
            return self.spread() < r
        s = self.sources()
        assert s is not None
        return bool(s.count > 0 and s.count_probability[s.count] >= 0.5 and np.all(s.spreads < r))

    def diagnostics(self) -> dict[str, float]:
        """ESS, spread (m), posterior rate and its log-sd, acceptance, tempered steps."""
        b = self.belief()
        if b is None:
            return {}
        lq = b.theta[:, self.layout.log_rate_column(0)]
        m = float(b.weights @ lq)
        sd = float(np.sqrt(max(b.weights @ (lq - m) ** 2, 0.0)))
        out = {
            "ess": b.ess,
            "spread": self.spread(),
            "rate": math.exp(m),
            "log_rate_sd": sd,
            "acceptance": self.last_acceptance,
            "stages": float(self.last_stages),
        }
        if self.layout.slots > 1:
            out["n_sources"] = float(b.weights @ SourceTerms(b.theta, self.layout).active.sum(1))
        return out

    def final_metrics(self) -> dict[str, Any]:
        """Posterior summary columns (the same keys every time; NaN where not applicable)."""
        nan = math.nan
        out: dict[str, Any] = {
            k: nan
            for k in (
                "est_x",
                "est_y",
                "est_z",
                "est_rate",
                "rate_lo",
                "rate_hi",
                "spread",
                "region_radius",
                "est_wind_speed",
                "est_wind_dir_deg",
                "est_dispersion",
                "est_sources",
                "ess_final",
                "acceptance",
            )
        }
        out.update(
            readings=float(self.n_read),
            resample_moves=float(self.n_moves),
            tempered_steps=float(self.tempered),
        )
        b = self.belief()
        if b is None:
            return out
        est = self.estimate()
        if len(est):
            for a, v in zip("xyz", est[0], strict=False):
                out[f"est_{a}"] = float(v)
        m = b.theta_mean()
        lay = self.layout
        out["est_rate"] = float(np.exp(b.weights @ b.theta[:, lay.log_rate_column(0)]))
        region = b.credible_region(self.params.credible_level)
        out["rate_lo"], out["rate_hi"] = (float(v) for v in region.rate)
        out["region_radius"] = region.radius
        out["spread"] = self.spread()
        for key, name, f in (
            ("est_wind_speed", "speed", float),
            ("est_wind_dir_deg", "direction", math.degrees),
            ("est_dispersion", "log_dispersion", math.exp),
        ):
            c = lay.column(name)
            if c >= 0:
                out[key] = f(float(m[c]))
        if lay.slots > 1:
            s = self.sources()
            assert s is not None
            out["est_sources"] = float(s.count)
        else:
            out["est_sources"] = 1.0
        out["ess_final"] = b.ess
        if self._acc_n:
            out["acceptance"] = self._acc_sum / self._acc_n
        return out
