"""Particle resampling: index schemes with a target count, and resamplers built on them.

Schemes
-------
A scheme is ``scheme(weights, M, rng) -> indices``: ``M`` ancestor indices drawn from normalised
``weights`` (``M`` may differ from the number of particles, for adaptive particle counts):

- :func:`systematic`: one uniform offset, ``M`` evenly spaced pointers ``(u + m) / M``. This is
  also the *low-variance sampler* of Thrun, Burgard & Fox (Probabilistic Robotics, table 4.4),
  so ``low-variance`` is registered as another name of the same resampler;
- :func:`stratified`: one uniform pointer inside each of the ``M`` strata;
- :func:`multinomial`: ``M`` independent draws;
- :func:`residual`: ``floor(M w)`` deterministic copies, the rest multinomial on the residuals.

Resamplers
----------
A resampler (registry family ``"resampler"``) is called as
``resample(positions, log_weights, rng, n=None, constraint=None)`` and returns
``(positions, log_weights)`` with uniform weights. The index resamplers copy ancestors chosen by
their scheme and may roughen the copies; :class:`RouletteResampler` is the Russian-roulette
scheme of the indoor PF paper. *When* to resample is a policy of its own (registry family
``resampling_policy``: ``ess``, ``every-step``), not the resampler's.
Degenerate input (every log-weight ``-inf`` or NaN) is read as uniform weights, so no resampler
ever produces NaN.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, NonNegative, Params
from odorloc.core.registry import register
from odorloc.inference.particles.constraints import Constraint, place_admissible
from odorloc.inference.weights import effective_sample_size, normalise_log_weights

__all__ = [
    "EssPolicy",
    "EveryStepPolicy",
    "IndexResampler",
    "MultinomialResampler",
    "Resampler",
    "ResamplingPolicy",
    "ResidualResampler",
    "RouletteParams",
    "RouletteResampler",
    "Scheme",
    "StratifiedResampler",
    "SystematicParams",
    "SystematicResampler",
    "effective_sample_size",
    "multinomial",
    "residual",
    "stratified",
    "systematic",
]

Scheme = Callable[[np.ndarray, int, np.random.Generator], np.ndarray]
"""``scheme(weights (N,), M, rng) -> (M,) int`` ancestor indices."""


def _search_pointers(weights: np.ndarray, pointers: np.ndarray) -> np.ndarray:
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0  # guard against round-off leaving the last pointer past the end
    return np.minimum(np.searchsorted(cdf, pointers, side="right"), len(weights) - 1)


def _check_count(m: int) -> int:
    if int(m) < 1:
        raise ConfigError("n", f"the target particle count must be >= 1, got {m}")
    return int(m)


def systematic(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic (low-variance) pointers ``(u + k) / M``, ``u ~ U(0, 1)``: ``(M,)`` indices."""
    m = _check_count(m)
    return _search_pointers(weights, (rng.random() + np.arange(m)) / m)


def stratified(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """Stratified pointers ``(k + u_k) / M``, ``u_k ~ U(0, 1)``: ``(M,)`` indices."""
    m = _check_count(m)
    return _search_pointers(weights, (rng.random(m) + np.arange(m)) / m)


def multinomial(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """``M`` independent draws proportional to ``weights`` (sorted pointers): ``(M,)``."""
    m = _check_count(m)
    return _search_pointers(weights, np.sort(rng.random(m)))


def residual(weights: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
    """Residual resampling: ``floor(M w_i)`` copies of each, the rest multinomial: ``(M,)``."""
    m = _check_count(m)
    copies = np.floor(m * weights).astype(np.int64)
    det = np.repeat(np.arange(len(weights)), copies)
    left = m - len(det)
    if left == 0:
        return det
    res = m * weights - copies
    res = res / res.sum() if res.sum() > 0 else np.full(len(weights), 1.0 / len(weights))
    return np.concatenate([det, multinomial(res, left, rng)])


def _check_inputs(positions: np.ndarray, log_weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pos = np.asarray(positions, float)
    lw = np.asarray(log_weights, float)
    if pos.ndim != 2:
        raise ConfigError("positions", f"expected shape (N, d), got {pos.shape}")
    if lw.shape != (len(pos),):
        raise ConfigError("log_weights", f"expected shape ({len(pos)},), got {lw.shape}")
    if len(pos) == 0:
        raise ConfigError("positions", "cannot resample an empty particle set")
    return pos, normalise_log_weights(lw)[1]


class Resampler(Configured, ABC):
    """Base class: ``resample(positions, log_weights, rng, n=None, constraint=None)``."""

    def resample(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray,
        rng: np.random.Generator,
        n: int | None = None,
        constraint: Constraint | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Resample a weighted particle set.

        Parameters
        ----------
        positions : (N, d) ndarray
        log_weights : (N,) ndarray
            Normalised or not; all ``-inf`` is read as uniform.
        rng : numpy.random.Generator
        n : int, optional
            Target number of particles (default ``N``; a resampler may treat it as a bound).
        constraint : Constraint, optional
            Keeps moved or spawned particles admissible (e.g. in an arena's free space).

        Returns
        -------
        positions : (M, d) ndarray
            A new array (the input is never modified).
        log_weights : (M,) ndarray
            Uniform, ``-log M``.
        """
        pos, w = _check_inputs(positions, log_weights)
        new_pos = self._resample(
            pos, w, rng, len(pos) if n is None else _check_count(n), constraint
        )
        return new_pos, np.full(len(new_pos), -math.log(len(new_pos)))

    @abstractmethod
    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        n: int,
        constraint: Constraint | None,
    ) -> np.ndarray: ...


class SystematicParams(Params):
    """Settings of an index resampler.

    Parameters
    ----------
    jitter_std : float, metres
        Standard deviation of Gaussian roughening added to the copies (0 = exact copies).
    """

    jitter_std: NonNegative = 0.0


class IndexResampler(Resampler):
    """Copies the ancestors its :attr:`scheme` selects, with optional Gaussian roughening."""

    params: SystematicParams
    Params = SystematicParams
    scheme: ClassVar[Scheme]

    def indices(
        self, weights: np.ndarray, rng: np.random.Generator, n: int | None = None
    ) -> np.ndarray:
        """Ancestor indices ``(n,)`` (default ``n = N``) from normalised ``weights``."""
        return type(self).scheme(weights, len(weights) if n is None else n, rng)

    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        n: int,
        constraint: Constraint | None,
    ) -> np.ndarray:
        out = positions[type(self).scheme(weights, n, rng)]
        std = self.params.jitter_std
        if std > 0:
            # Roughening: the source does not move, so exact copies would never diversify.
            moved = out + rng.normal(0.0, std, size=out.shape)
            out = place_admissible(moved, out, constraint)
        return out


@register("resampler", "systematic", SystematicParams, "systematic resampling")
@register("resampler", "low-variance", SystematicParams, "low-variance sampling (= systematic)")
class SystematicResampler(IndexResampler):
    """Systematic (low-variance) resampling, :func:`systematic`."""

    scheme = staticmethod(systematic)


@register("resampler", "stratified", SystematicParams, "stratified resampling")
class StratifiedResampler(IndexResampler):
    """Stratified resampling, :func:`stratified`."""

    scheme = staticmethod(stratified)


@register("resampler", "multinomial", SystematicParams, "multinomial resampling")
class MultinomialResampler(IndexResampler):
    """Multinomial resampling, :func:`multinomial`."""

    scheme = staticmethod(multinomial)


@register("resampler", "residual", SystematicParams, "residual resampling")
class ResidualResampler(IndexResampler):
    """Residual resampling, :func:`residual`."""

    scheme = staticmethod(residual)


class RouletteParams(Params):
    """Russian-roulette resampling (indoor PF paper, section 2.2, step 3).

    Parameters
    ----------
    survival_floor : float
        A light particle (``w < 1/N``) survives with probability ``max(N w, survival_floor)``;
        the paper's text gives 0.5. Set 0 for the classic roulette ``P = N w``.
    max_children : int
        Cap of children per heavy particle: ``min(floor(N w), max_children)`` (paper: 5).
    child_variance : float, m^2
        Per-axis variance of the Gaussian around a heavy particle (paper: 0.25 m^2).
    count : {"keep", "bounded"}
        ``"keep"``: after the roulette the set is brought back to the target count (the input
        size unless the filter asks for another): surplus particles are dropped uniformly at
        random, missing ones are added as further Gaussian children of parents drawn from all
        particles in proportion to their weight (so mostly heavy ones). ``"bounded"``: the
        count is free to change, as in the paper, but is trimmed/filled the same way into
        ``[min_particles, max_particles]``.
    min_particles, max_particles : int
        Bounds used by ``count="bounded"``.
    max_redraws : int
        Children falling outside the arena or into an obstacle are redrawn up to this many times;
        any still invalid are clipped into the bounds and, if then inadmissible, put on their
        parent.
    """

    survival_floor: float = Field(0.5, ge=0.0, le=1.0)
    max_children: int = Field(5, ge=1, le=10_000)
    child_variance: NonNegative = 0.25
    count: Literal["keep", "bounded"] = "keep"
    min_particles: int = Field(100, ge=1, le=10_000_000)
    max_particles: int = Field(5000, ge=1, le=10_000_000)
    max_redraws: int = Field(5, ge=0, le=1000)

    @model_validator(mode="after")
    def _check(self) -> RouletteParams:
        if self.max_particles < self.min_particles:
            raise ValueError("max_particles must be >= min_particles")
        return self


@register("resampler", "roulette", RouletteParams, "Russian-roulette resampling (indoor PF)")
class RouletteResampler(Resampler):
    """Russian-roulette resampling with Gaussian children (indoor PF paper, section 2.2 (3)).

    With ``N`` particles and normalised weights ``w``:

    - light particles (``w_i < 1/N``) survive in place with probability
      ``max(N w_i, survival_floor)``;
    - heavy particles (``w_j >= 1/N``) are removed and replaced by
      ``min(floor(N w_j), max_children)`` children (paper: 5) drawn from
      ``N(L_j, child_variance I)``;
    - the resulting count is restored (``count="keep"``) or bounded (``count="bounded"``), see
      :class:`RouletteParams`; all weights are then reset to uniform.

    When all weights are equal (e.g. after total underflow) every particle counts as heavy with
    ``floor(N w) = 1``: each is replaced by one jittered child.
    """

    params: RouletteParams
    Params = RouletteParams

    def _children(
        self, parents: np.ndarray, rng: np.random.Generator, constraint: Constraint | None
    ) -> np.ndarray:
        std = math.sqrt(self.params.child_variance)
        kids = parents + rng.normal(0.0, std, size=parents.shape)
        if constraint is not None and std > 0:
            for _ in range(self.params.max_redraws):
                bad = ~constraint.admissible(kids)
                if not bad.any():
                    break
                kids[bad] = parents[bad] + rng.normal(
                    0.0, std, size=(int(bad.sum()), kids.shape[1])
                )
            kids = place_admissible(kids, parents, constraint)
        return kids

    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        n_target: int,
        constraint: Constraint | None,
    ) -> np.ndarray:
        p = self.params
        n = len(weights)
        nw = n * weights
        # Compare N w with 1 rather than w with 1/N: uniform weights then count as heavy exactly.
        heavy = nw >= 1.0 - 1e-9
        survive_prob = np.maximum(nw, p.survival_floor)
        u = rng.random(n)
        survivors = positions[~heavy & (u < survive_prob)]
        counts = np.minimum(np.floor(nw[heavy] + 1e-9).astype(np.int64), p.max_children)
        parents = np.repeat(positions[heavy], counts, axis=0)
        out = np.concatenate([survivors, self._children(parents, rng, constraint)], axis=0)

        if p.count == "keep":
            lo = hi = n_target
        else:
            lo, hi = p.min_particles, p.max_particles
        m = len(out)
        if m > hi:
            out = out[np.sort(rng.choice(m, size=hi, replace=False))]
        elif m < lo:
            extra_parents = positions[_search_pointers(weights, rng.random(lo - m))]
            out = np.concatenate([out, self._children(extra_parents, rng, constraint)], axis=0)
        return out


# ---------------------------------------------------------------------- when to resample
class ResamplingPolicy(Configured, ABC):
    """Base class of the ``resampling_policy`` family: *when* a filter resamples."""

    @abstractmethod
    def due(self, ess: float, n: int) -> bool:
        """Whether a filter of ``n`` particles with effective sample size ``ess`` resamples."""


class EssParams(Params):
    """Settings of :class:`EssPolicy`.

    Attributes
    ----------
    threshold : float
        Resample when ``N_eff < threshold * N`` (indoor PF paper: 0.5, eq. 12).
    """

    threshold: float = Field(0.5, ge=0.0, le=1.0)


@register("resampling_policy", "ess", EssParams, "resample when N_eff < threshold N")
class EssPolicy(ResamplingPolicy):
    """Resample when the effective sample size falls below a fraction of the count (eq. 12)."""

    params: EssParams
    Params = EssParams

    def due(self, ess: float, n: int) -> bool:
        return ess < self.params.threshold * n


class EveryStepParams(Params):
    """The ``every-step`` policy has no settings."""


@register("resampling_policy", "every-step", EveryStepParams, "resample after every update")
class EveryStepPolicy(ResamplingPolicy):
    """Resample after every update (the bootstrap filter)."""

    params: EveryStepParams
    Params = EveryStepParams

    def due(self, ess: float, n: int) -> bool:
        return True
