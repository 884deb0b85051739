"""Particle resamplers behind one interface.

Every resampler is called as ``resample(positions, log_weights, rng, arena=None)`` and returns
``(positions, log_weights)`` with uniform, normalised log-weights. Settings are frozen
:class:`~odorloc.params.Params`; a resampler never changes them while running (the threshold that
decides *when* to resample belongs to the filter, not to the resampler).

Members
-------
- :class:`SystematicResampler`: one uniform offset, ``N`` evenly spaced pointers.
- :class:`LowVarianceResampler`: the low-variance sampler of Thrun, Burgard & Fox
  (Probabilistic Robotics, table 4.4). It draws the same pointers as the systematic resampler
  (``r ~ U(0, 1/N)``, ``u_m = r + m/N``), so both give identical output for the same generator;
  it exists under its textbook name because the multi-UAV paper names it.
- :class:`StratifiedResampler`: one uniform draw inside each of the ``N`` strata.
- :class:`MultinomialResampler`: ``N`` independent draws proportional to the weights.
- :class:`RouletteResampler`: the Russian-roulette scheme of the indoor PF paper (section 2.2,
  step 3), with Gaussian children around heavy particles.

Degenerate input: when every log-weight is ``-inf`` (all weights underflowed) or NaN, the weights
are read as uniform (see :func:`~odorloc.inference.belief.normalize_log_weights`), so no resampler
ever produces NaN.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.errors import ConfigError
from odorloc.inference.belief import normalize_log_weights
from odorloc.params import NonNegative, Params
from odorloc.registry import register
from odorloc.world.arena import Arena

__all__ = [
    "LowVarianceParams",
    "LowVarianceResampler",
    "MultinomialParams",
    "MultinomialResampler",
    "Resampler",
    "RouletteParams",
    "RouletteResampler",
    "StratifiedParams",
    "StratifiedResampler",
    "SystematicParams",
    "SystematicResampler",
    "effective_sample_size",
    "make_resampler",
    "place_in_free_space",
]


def effective_sample_size(log_weights: np.ndarray) -> float:
    """Effective sample size ``1 / sum w^2`` of (possibly unnormalised) log-weights.

    Parameters
    ----------
    log_weights : (N,) ndarray

    Returns
    -------
    float
        In ``[1, N]``; ``N`` when all weights underflowed (they are then read as uniform).
    """
    w = np.exp(normalize_log_weights(log_weights))
    return float(1.0 / np.sum(w * w))


def _check_inputs(positions: np.ndarray, log_weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pos = np.asarray(positions, float)
    lw = np.asarray(log_weights, float)
    if pos.ndim != 2:
        raise ConfigError("positions", f"expected shape (N, d), got {pos.shape}")
    if lw.shape != (len(pos),):
        raise ConfigError("log_weights", f"expected shape ({len(pos)},), got {lw.shape}")
    if len(pos) == 0:
        raise ConfigError("positions", "cannot resample an empty particle set")
    return pos, normalize_log_weights(lw)


def _uniform_log_weights(n: int) -> np.ndarray:
    return np.full(n, -math.log(n))


def place_in_free_space(
    points: np.ndarray,
    fallback: np.ndarray,
    arena: Arena | None,
) -> np.ndarray:
    """Move points that are outside ``arena`` or inside an obstacle back into free space.

    Points outside the bounds are first clipped onto the boundary; points that are then still
    not free (inside an obstacle) are replaced by the matching row of ``fallback`` (e.g. the
    parent particle, assumed free).

    Parameters
    ----------
    points, fallback : (Q, d) ndarray, metres
    arena : Arena or None
        ``None`` leaves the points unchanged.

    Returns
    -------
    (Q, d) ndarray, metres
    """
    if arena is None or len(points) == 0:
        return points
    out = arena.clip(points)
    bad = ~arena.is_free(out)
    if bad.any():
        out[bad] = fallback[bad]
    return out


class Resampler(ABC):
    """Base class: ``resample(positions, log_weights, rng, arena=None) -> (positions, log_w)``."""

    params: Params
    #: Parameter model used when the constructor gets ``None``.
    params_model: type[Params]

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else self.params_model()

    def resample(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray,
        rng: np.random.Generator,
        arena: Arena | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Resample a weighted particle set.

        Parameters
        ----------
        positions : (N, d) ndarray, metres
        log_weights : (N,) ndarray
            Log-weights, normalised or not; all ``-inf`` is read as uniform.
        rng : numpy.random.Generator
        arena : Arena, optional
            Used to keep jittered/spawned particles inside free space.

        Returns
        -------
        positions : (M, d) ndarray, metres
            A new array (the input is never modified).
        log_weights : (M,) ndarray
            Uniform, ``-log M``.
        """
        pos, lw = _check_inputs(positions, log_weights)
        new_pos = self._resample(pos, np.exp(lw), rng, arena)
        return new_pos, _uniform_log_weights(len(new_pos))

    @abstractmethod
    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        arena: Arena | None,
    ) -> np.ndarray: ...


class _IndexResampler(Resampler):
    """Resamplers that copy particles by index, with optional Gaussian roughening."""

    params: SystematicParams

    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        arena: Arena | None,
    ) -> np.ndarray:
        idx = self.indices(weights, rng)
        out = positions[idx]
        std = self.params.jitter_std
        if std > 0:
            # Roughening: the source does not move, so exact copies would never diversify.
            moved = out + rng.normal(0.0, std, size=out.shape)
            out = place_in_free_space(moved, out, arena)
        return out

    @abstractmethod
    def indices(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Indices ``(N,)`` of the selected particles, given normalised ``weights``."""


def _search_pointers(weights: np.ndarray, pointers: np.ndarray) -> np.ndarray:
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0  # guard against round-off leaving the last pointer past the end
    return np.minimum(np.searchsorted(cdf, pointers, side="right"), len(weights) - 1)


class SystematicParams(Params):
    """Systematic resampling.

    Parameters
    ----------
    jitter_std : float, metres
        Standard deviation of Gaussian roughening added to the copies (0 = exact copies).
    """

    jitter_std: NonNegative = 0.0


@register("resampler", "systematic", SystematicParams, "systematic resampling")
class SystematicResampler(_IndexResampler):
    """Systematic resampling: pointers ``(u + m) / N`` with a single ``u ~ U(0, 1)``."""

    params_model = SystematicParams

    def indices(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        n = len(weights)
        return _search_pointers(weights, (rng.random() + np.arange(n)) / n)


class LowVarianceParams(SystematicParams):
    """Low-variance sampling (Thrun et al.); same settings as :class:`SystematicParams`."""


@register("resampler", "low-variance", LowVarianceParams, "low-variance sampling (Thrun)")
class LowVarianceResampler(_IndexResampler):
    """Low-variance sampler (Probabilistic Robotics, table 4.4), vectorised.

    Draws ``r ~ U(0, 1/N)`` and selects, for ``m = 0..N-1``, the particle whose cumulative weight
    first exceeds ``U = r + m / N``. Identical pointers to :class:`SystematicResampler`.
    """

    params_model = LowVarianceParams

    def indices(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        n = len(weights)
        r = rng.random() / n
        return _search_pointers(weights, r + np.arange(n) / n)


class StratifiedParams(SystematicParams):
    """Stratified resampling; same settings as :class:`SystematicParams`."""


@register("resampler", "stratified", StratifiedParams, "stratified resampling")
class StratifiedResampler(_IndexResampler):
    """Stratified resampling: one pointer ``(m + u_m) / N`` per stratum, ``u_m ~ U(0, 1)``."""

    params_model = StratifiedParams

    def indices(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        n = len(weights)
        return _search_pointers(weights, (rng.random(n) + np.arange(n)) / n)


class MultinomialParams(SystematicParams):
    """Multinomial resampling; same settings as :class:`SystematicParams`."""


@register("resampler", "multinomial", MultinomialParams, "multinomial resampling")
class MultinomialResampler(_IndexResampler):
    """Multinomial resampling: ``N`` independent draws with probabilities ``w``."""

    params_model = MultinomialParams

    def indices(self, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        n = len(weights)
        return _search_pointers(weights, np.sort(rng.random(n)))


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
        ``"keep"``: after the roulette the set is brought back to the input size ``N`` (surplus
        particles dropped uniformly at random; missing ones drawn as further children of heavy
        particles chosen in proportion to their weight). ``"bounded"``: the count is free to
        change, as in the paper, but is trimmed/filled the same way into
        ``[min_particles, max_particles]``.
    min_particles, max_particles : int
        Bounds used by ``count="bounded"``.
    max_redraws : int
        Children falling outside the arena or into an obstacle are redrawn up to this many times;
        any still invalid are clipped into the bounds and, if then inside an obstacle, put on
        their parent.
    """

    survival_floor: float = Field(0.5, ge=0.0, le=1.0)
    max_children: int = Field(5, ge=1)
    child_variance: NonNegative = 0.25
    count: Literal["keep", "bounded"] = "keep"
    min_particles: int = Field(100, ge=1)
    max_particles: int = Field(5000, ge=1)
    max_redraws: int = Field(5, ge=0)

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
    - heavy particles (``w_j >= 1/N``) are removed and replaced by ``min(floor(N w_j), 5)``
      children drawn from ``N(L_j, child_variance I)``;
    - the resulting count is restored (``count="keep"``) or bounded (``count="bounded"``), see
      :class:`RouletteParams`; all weights are then reset to uniform.

    When all weights are equal (e.g. after total underflow) every particle counts as heavy with
    ``floor(N w) = 1``: each is replaced by one jittered child.
    """

    params: RouletteParams
    params_model = RouletteParams

    def _children(
        self,
        parents: np.ndarray,
        rng: np.random.Generator,
        arena: Arena | None,
    ) -> np.ndarray:
        std = math.sqrt(self.params.child_variance)
        kids = parents + rng.normal(0.0, std, size=parents.shape)
        if arena is not None and std > 0:
            for _ in range(self.params.max_redraws):
                bad = ~arena.is_free(kids)
                if not bad.any():
                    break
                kids[bad] = parents[bad] + rng.normal(
                    0.0, std, size=(int(bad.sum()), kids.shape[1])
                )
            kids = place_in_free_space(kids, parents, arena)
        return kids

    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        arena: Arena | None,
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
        out = np.concatenate([survivors, self._children(parents, rng, arena)], axis=0)

        if p.count == "keep":
            lo = hi = n
        else:
            lo, hi = p.min_particles, p.max_particles
        m = len(out)
        if m > hi:
            out = out[np.sort(rng.choice(m, size=hi, replace=False))]
        elif m < lo:
            extra_parents = positions[_search_pointers(weights, rng.random(lo - m))]
            out = np.concatenate([out, self._children(extra_parents, rng, arena)], axis=0)
        return out


_RESAMPLERS: dict[str, tuple[type[Resampler], type[Params]]] = {
    "systematic": (SystematicResampler, SystematicParams),
    "low-variance": (LowVarianceResampler, LowVarianceParams),
    "stratified": (StratifiedResampler, StratifiedParams),
    "multinomial": (MultinomialResampler, MultinomialParams),
    "roulette": (RouletteResampler, RouletteParams),
}


def make_resampler(name: str, params: Params | None = None) -> Resampler:
    """Build a resampler by name (``"systematic"``, ``"low-variance"``, ``"stratified"``,
    ``"multinomial"``, ``"roulette"``) with ``params`` or its defaults."""
    if name not in _RESAMPLERS:
        known = ", ".join(sorted(_RESAMPLERS))
        raise ConfigError("resampler", f"unknown resampler {name!r} (known: {known})")
    cls, pcls = _RESAMPLERS[name]
    if params is not None and not isinstance(params, pcls):
        raise ConfigError("resampler", f"{name} needs {pcls.__name__}, got {type(params).__name__}")
    return cls(params if params is not None else pcls())
