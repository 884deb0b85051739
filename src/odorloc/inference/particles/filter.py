"""A state-agnostic particle filter over static source hypotheses.

The filter holds particle positions ``(N, d)`` and normalised log-weights ``(N,)`` and is a
composition of separate parts:

- a **likelihood**: callers pass log-likelihoods ``(N,)`` computed by any measurement model of
  :mod:`odorloc.models` (eq. 4, indoor PF paper: ``W_k ∝ W_{k-1} p(z_k | L)``);
- a **constraint** on admissible hypotheses (:mod:`.constraints`, e.g. an arena's free space);
- a **resampling policy**: a resampler (:mod:`.resampling`, chosen by registry name) and the
  rule of when to use it (``N_eff < threshold * N``, eqs. 12-13), with a target count that may
  differ from the current one (adaptive particle counts);
- a **stopping rule** (e.g. :class:`~odorloc.inference.particles.convergence.DualConvergence`,
  eqs. 15-16), evaluated on the filter and its estimate history (eq. 14).

Nothing here assumes a fixed ``N``.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.particles.constraints import Constraint
from odorloc.inference.particles.convergence import (
    ConvergenceParams,
    ConvergenceStatus,
    DualConvergence,
    StoppingRule,
)
from odorloc.inference.particles.convergence import spread as _spread
from odorloc.inference.particles.resampling import Resampler
from odorloc.inference.weights import gaussian_fit, normalise_log_weights

__all__ = ["ParticleFilter", "StoppingRule"]


def _particle_set(
    positions: np.ndarray, log_weights: np.ndarray | None, dim: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Checked ``(N, d)`` positions and ``(N,)`` log-weights of a new particle set.

    Log-weights may be ``-inf`` (an excluded hypothesis) but neither NaN nor ``+inf``:
    normalisation would otherwise read them as ``-inf`` or as uniform weights, silently.
    """
    pos = np.array(positions, dtype=float)
    if pos.ndim != 2 or len(pos) == 0 or (dim is not None and pos.shape[1] != dim):
        want = "d" if dim is None else str(dim)
        raise ConfigError("positions", f"expected shape (N>=1, {want}), got {pos.shape}")
    # a NaN propagates through max and min, an infinity is one of them: two reductions check
    # every entry without a temporary array (a filter replaces its set at every update)
    if not (math.isfinite(pos.max()) and math.isfinite(pos.min())):
        raise ConfigError("positions", "must be finite")
    lw = np.zeros(len(pos)) if log_weights is None else np.array(log_weights, dtype=float)
    if lw.shape != (len(pos),):
        raise ConfigError("log_weights", f"expected shape ({len(pos)},), got {lw.shape}")
    top = lw.max()
    if top != top or top == math.inf:
        raise ConfigError("log_weights", "must not contain NaN or +inf")
    return pos, lw


class ParticleFilter:
    """Weighted particles over source positions with log-space updates.

    Parameters
    ----------
    positions : (N, d) array_like, metres
        Finite.
    log_weights : (N,) array_like, optional
        Default uniform; ``-inf`` allowed, NaN and ``+inf`` are not.
    resampler : Resampler, optional
        ``None`` disables resampling.
    resample_threshold : float
        Resample when ``N_eff < resample_threshold * N`` (paper: 0.5, eq. 12).
    history : int
        Number of past estimates kept (paper: 20).
    constraint : Constraint, optional
        Admissible hypotheses: the resampler keeps moved or spawned particles admissible, and
        the convergence test requires an admissible estimate.
    """

    def __init__(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray | None = None,
        *,
        resampler: Resampler | None = None,
        resample_threshold: float = 0.5,
        history: int = 20,
        constraint: Constraint | None = None,
    ) -> None:
        if not 0.0 <= resample_threshold <= 1.0:
            raise ConfigError("resample_threshold", "must be in [0, 1]")
        if history < 1:
            raise ConfigError("history", "must be >= 1")
        pos, lw = _particle_set(positions, log_weights)
        self._positions = pos
        self._log_weights, self._weights = normalise_log_weights(lw)
        self.resampler = resampler
        self.resample_threshold = float(resample_threshold)
        self.constraint = constraint
        self._history: deque[np.ndarray] = deque(maxlen=int(history))
        self.n_resamples = 0
        self._version = 0

    # ----------------------------------------------------------------- state
    @property
    def positions(self) -> np.ndarray:
        """``(N, d)`` particle positions, metres (read-only view)."""
        v = self._positions.view()
        v.setflags(write=False)
        return v

    @property
    def log_weights(self) -> np.ndarray:
        """``(N,)`` normalised log-weights (read-only view)."""
        v = self._log_weights.view()
        v.setflags(write=False)
        return v

    @property
    def weights(self) -> np.ndarray:
        """``(N,)`` normalised weights (read-only view)."""
        v = self._weights.view()
        v.setflags(write=False)
        return v

    @property
    def n(self) -> int:
        """Current number of particles."""
        return len(self._positions)

    @property
    def version(self) -> int:
        """Times the particle set was replaced (:meth:`replace`, :meth:`resample`,
        :meth:`adopt`); a weight update does not count. Equal versions mean unchanged
        positions: what a cache of evaluations at the particles is keyed by."""
        return self._version

    @property
    def ess(self) -> float:
        """Effective sample size ``1 / sum w^2`` (eq. 13)."""
        return float(1.0 / np.dot(self._weights, self._weights))

    def belief(self) -> ParticleBelief:
        """A snapshot of the particle set (copies)."""
        return ParticleBelief(self._positions.copy(), self._log_weights.copy())

    def estimate(self) -> np.ndarray:
        """Weighted mean ``P_k = sum_i w_i L^i`` (eq. 14), ``(d,)`` metres."""
        return self._weights @ self._positions

    def gaussian(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean ``(d,)`` and covariance ``(d, d)`` of the particles."""
        return gaussian_fit(self._positions, self._weights)

    @property
    def history_capacity(self) -> int:
        """Number of estimates the history keeps (the ``history`` argument)."""
        return int(self._history.maxlen or 0)

    @property
    def history(self) -> np.ndarray:
        """Stored estimates, oldest first, ``(K, d)`` metres (``K <= history``)."""
        if not self._history:
            return np.zeros((0, self._positions.shape[1]))
        return np.array(self._history)

    # ----------------------------------------------------------------- updates
    def update(self, log_likelihood: np.ndarray, record: bool = True) -> None:
        """Bayes update ``log w += log p(z | L)`` then normalise (eq. 4).

        Parameters
        ----------
        log_likelihood : (N,) ndarray
            ``-inf`` allowed; if every particle ends at ``-inf`` the weights become uniform.
        record : bool
            Append the new estimate to the history.
        """
        ll = np.asarray(log_likelihood, float)
        if ll.shape != (self.n,):
            raise ConfigError("log_likelihood", f"expected shape ({self.n},), got {ll.shape}")
        top = ll.max() if ll.size else 0.0
        # the maximum is NaN if any entry is, +inf if any is and none is NaN
        if top != top or top == np.inf:
            raise ConfigError("log_likelihood", "must not contain NaN or +inf")
        self._log_weights, self._weights = normalise_log_weights(self._log_weights + ll)
        if record:
            self.record_estimate()

    def record_estimate(self) -> None:
        """Append the current estimate to the history (the oldest drops out)."""
        self._history.append(self.estimate())

    def needs_resampling(self) -> bool:
        """``N_eff < resample_threshold * N`` (eq. 12)."""
        return self.ess < self.resample_threshold * self.n

    def resample(self, rng: np.random.Generator, n: int | None = None) -> None:
        """Resample now with the configured resampler (no-op without one).

        ``n`` is the target particle count (default: keep the current count).
        """
        if self.resampler is None:
            return
        pos, lw = self.resampler.resample(
            self._positions, self._log_weights, rng, n=n, constraint=self.constraint
        )
        self._positions = pos
        self._log_weights, self._weights = normalise_log_weights(lw)
        self.n_resamples += 1
        self._version += 1

    def resample_if_needed(self, rng: np.random.Generator, n: int | None = None) -> bool:
        """Resample when degenerate (or when a new target count ``n`` is asked); ``True`` if it
        did."""
        changed = n is not None and n != self.n
        if self.resampler is not None and (changed or self.needs_resampling()):
            self.resample(rng, n)
            return True
        return False

    def replace(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray | None = None,
        *,
        resampled: bool = False,
    ) -> None:
        """Replace the particle set (e.g. after a position-update move); history is kept.

        Parameters
        ----------
        positions : (N, d) array_like, metres
            Finite; ``d`` as before, ``N`` may change.
        log_weights : (N,) array_like, optional
            Default uniform; ``-inf`` allowed, NaN and ``+inf`` are not.
        resampled : bool
            The new set is a resampling of the old one (done outside :meth:`resample`, e.g. by
            compiled code): counted in :attr:`n_resamples`.
        """
        pos, lw = _particle_set(positions, log_weights, self._positions.shape[1])
        self._positions = pos
        self._log_weights, self._weights = normalise_log_weights(lw)
        self._version += 1
        if resampled:
            self.n_resamples += 1

    def adopt(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray | None = None,
        weights: np.ndarray | None = None,
        *,
        resampled: bool = False,
    ) -> None:
        """Take a particle set computed from this filter's own state, without checks or copies.

        For compiled code that derives the new set from the filter's checked particles (a
        resampling, moves that keep particles inside a box): what :meth:`replace` would check
        holds by construction, and the arrays become the filter's own. Anything from elsewhere
        goes through :meth:`replace`.

        Parameters
        ----------
        positions : (N, d) ndarray of float64, metres
            Finite; ``d`` as before. Owned by the filter from now on (never written).
        log_weights, weights : (N,) ndarray of float64, optional
            Normalised log-weights (``logsumexp == 0``) and their exponentials, as
            :func:`~odorloc.inference.weights.normalise_log_weights` returns them; ``None``
            (both) keeps the current ones (``N`` unchanged).
        resampled : bool
            The new set is a resampling of the old one: counted in :attr:`n_resamples`.
        """
        if (log_weights is None) != (weights is None):
            raise TypeError("adopt() takes both log_weights and weights, or neither")
        if log_weights is not None:
            self._log_weights, self._weights = log_weights, weights
        self._positions = positions
        self._version += 1
        if resampled:
            self.n_resamples += 1

    # ----------------------------------------------------------------- stopping
    def spread(self, variance: Literal["trace", "radius", "max_axis"] = "trace") -> float:
        """Particle spread (see :func:`~odorloc.inference.particles.convergence.spread`)."""
        if variance not in ("trace", "radius", "max_axis"):
            raise ConfigError("variance", f"unknown spread measure {variance!r}")
        return _spread(self._positions, self._weights, variance)

    def convergence(self, params: ConvergenceParams | None = None) -> ConvergenceStatus:
        """The dual convergence test (eqs. 15-16) with each criterion separately."""
        return DualConvergence(params).status(self)

    def converged(self, rule: StoppingRule) -> bool:
        """Whether ``rule`` says the estimate may be declared."""
        return rule.converged(self)
