"""A model-agnostic particle filter over static source positions.

The filter holds particle positions ``(N, d)`` and normalised log-weights ``(N,)``; it knows
nothing of plumes or sensors: callers pass log-likelihoods ``(N,)`` computed by any measurement
model (:mod:`odorloc.inference.likelihoods`). It adds them in log space (eq. 4, indoor PF paper:
``W_k ∝ W_{k-1} p(z_k | L)``), resamples with any :class:`~odorloc.inference.resampling.Resampler`
when ``N_eff < threshold * N`` (eqs. 12-13), keeps the weighted-mean estimate history (eq. 14)
and evaluates the dual convergence test of the indoor PF paper (eqs. 15-16).

The particle count may change between steps (roulette resampling with ``count="bounded"``, or
the adaptive counts of the multi-UAV paper); nothing here assumes a fixed ``N``.

Convergence (indoor PF paper, section 2.2, "Termination Conditions")
--------------------------------------------------------------------
- Particle convergence (eq. 15): ``sigma_k^2 = sum_i w_i |L^i - P_k|^2 <= R_conv``. The paper
  defines the "weighted variance" as the sum of squared weighted distances, i.e. the trace of
  the weighted covariance (m^2), and compares it with the "convergence radius" R_conv = 0.5
  (given in m). ``variance="trace"`` (default) follows the text literally: trace (m^2) <= R_conv
  read as a number. ``variance="radius"`` compares the RMS distance ``sqrt(trace)`` (m) with
  R_conv; ``variance="max_axis"`` compares the largest per-axis variance (m^2).
- Estimate convergence (eq. 16): the history holds the last ``K = 20`` estimates
  ``{P_j}`` (one per filter update; the flattened ``P_j | z_j = 1`` is read as ``j = 1..20``);
  it must be full and every element within ``R_err`` of the history mean.
- The current estimate must not lie inside an obstacle (nor outside the arena).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.errors import ConfigError
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.likelihoods import PangFarrellLikelihood
from odorloc.inference.resampling import Resampler
from odorloc.params import NonNegative, Params, Positive
from odorloc.world.arena import Arena

__all__ = [
    "ConvergenceParams",
    "ConvergenceStatus",
    "ParticleFilter",
    "backtrack_initialise",
    "sample_free_uniform",
]


def _normalise(log_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalised log-weights and weights; same rules as ``normalize_log_weights`` (NaN counts
    as ``-inf``; all ``-inf`` becomes uniform) but NumPy-only, as this runs every step."""
    lw = np.where(np.isnan(log_w), -np.inf, log_w)
    m = lw.max()
    if not np.isfinite(m):
        lw = np.full(lw.shape, -math.log(lw.size))
        return lw, np.exp(lw)
    w = np.exp(lw - m)
    total = w.sum()
    return lw - (m + math.log(total)), w / total


class ConvergenceParams(Params):
    """Dual convergence test of the indoor PF paper (eqs. 15-16).

    Parameters
    ----------
    r_conv : float
        Threshold on the particle spread (0.5; m^2 for ``"trace"``/``"max_axis"``, m for
        ``"radius"``).
    r_err : float, metres
        Radius around the history mean that every stored estimate must lie within.
    history : int
        Number of estimates that must be stored (and agree) before declaring.
    variance : {"trace", "radius", "max_axis"}
        How the particle spread is measured, see the module docstring.
    """

    r_conv: Positive = 0.5
    r_err: Positive = 0.5
    history: int = Field(20, ge=1)
    variance: Literal["trace", "radius", "max_axis"] = "trace"


@dataclass(frozen=True)
class ConvergenceStatus:
    """Outcome of :meth:`ParticleFilter.convergence` with each criterion separately."""

    spread: float
    """Particle spread in the chosen measure (m^2 or m)."""
    particles_converged: bool
    history_full: bool
    max_history_deviation: float
    """Largest distance of a stored estimate from the history mean, metres (inf if empty)."""
    estimates_converged: bool
    estimate_free: bool

    @property
    def converged(self) -> bool:
        """All criteria hold."""
        return (
            self.particles_converged
            and self.history_full
            and self.estimates_converged
            and self.estimate_free
        )


class ParticleFilter:
    """Weighted particles over source positions with log-space updates.

    Parameters
    ----------
    positions : (N, d) array_like, metres
    log_weights : (N,) array_like, optional
        Default uniform.
    resampler : Resampler, optional
        ``None`` disables resampling.
    resample_threshold : float
        Resample when ``N_eff < resample_threshold * N`` (paper: 0.5, eq. 12).
    history : int
        Number of past estimates kept (paper: 20).
    arena : Arena, optional
        Passed to the resampler (children stay in free space) and used by the convergence test.
    """

    def __init__(
        self,
        positions: np.ndarray,
        log_weights: np.ndarray | None = None,
        *,
        resampler: Resampler | None = None,
        resample_threshold: float = 0.5,
        history: int = 20,
        arena: Arena | None = None,
    ) -> None:
        pos = np.array(positions, dtype=float)
        if pos.ndim != 2 or len(pos) == 0:
            raise ConfigError("positions", f"expected shape (N>=1, d), got {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise ConfigError("positions", "must be finite")
        if not 0.0 <= resample_threshold <= 1.0:
            raise ConfigError("resample_threshold", "must be in [0, 1]")
        if history < 1:
            raise ConfigError("history", "must be >= 1")
        self._positions = pos
        lw = np.zeros(len(pos)) if log_weights is None else np.asarray(log_weights, float)
        if lw.shape != (len(pos),):
            raise ConfigError("log_weights", f"expected shape ({len(pos)},), got {lw.shape}")
        self._log_weights, self._weights = _normalise(lw)
        self.resampler = resampler
        self.resample_threshold = float(resample_threshold)
        self.arena = arena
        self._history: deque[np.ndarray] = deque(maxlen=int(history))
        self.n_resamples = 0

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
    def n(self) -> int:
        """Current number of particles."""
        return len(self._positions)

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
        if np.any(np.isnan(ll)) or np.any(ll == np.inf):
            raise ConfigError("log_likelihood", "must not contain NaN or +inf")
        self._log_weights, self._weights = _normalise(self._log_weights + ll)
        if record:
            self.record_estimate()

    def record_estimate(self) -> None:
        """Append the current estimate to the history (the oldest drops out)."""
        self._history.append(self.estimate())

    def needs_resampling(self) -> bool:
        """``N_eff < resample_threshold * N`` (eq. 12)."""
        return self.ess < self.resample_threshold * self.n

    def resample(self, rng: np.random.Generator) -> None:
        """Resample now with the configured resampler (no-op without one)."""
        if self.resampler is None:
            return
        pos, lw = self.resampler.resample(self._positions, self._log_weights, rng, self.arena)
        self._positions = pos
        self._log_weights, self._weights = _normalise(lw)
        self.n_resamples += 1

    def resample_if_needed(self, rng: np.random.Generator) -> bool:
        """Resample when degenerate; ``True`` if it did."""
        if self.resampler is not None and self.needs_resampling():
            self.resample(rng)
            return True
        return False

    def replace(self, positions: np.ndarray, log_weights: np.ndarray | None = None) -> None:
        """Replace the particle set (e.g. after a position-update move); history is kept."""
        pos = np.array(positions, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != self._positions.shape[1] or len(pos) == 0:
            raise ConfigError("positions", f"expected shape (N>=1, {self._positions.shape[1]})")
        lw = np.zeros(len(pos)) if log_weights is None else np.asarray(log_weights, float)
        if lw.shape != (len(pos),):
            raise ConfigError("log_weights", f"expected shape ({len(pos)},), got {lw.shape}")
        self._positions = pos
        self._log_weights, self._weights = _normalise(lw)

    # ----------------------------------------------------------------- convergence
    def spread(self, variance: Literal["trace", "radius", "max_axis"] = "trace") -> float:
        """Particle spread: trace of the weighted covariance (m^2, eq. 15), its square root
        (``"radius"``, m) or the largest per-axis variance (``"max_axis"``, m^2)."""
        w = self._weights
        dx = self._positions - w @ self._positions
        per_axis = w @ (dx * dx)
        if variance == "trace":
            return float(per_axis.sum())
        if variance == "radius":
            return float(math.sqrt(per_axis.sum()))
        if variance == "max_axis":
            return float(per_axis.max())
        raise ConfigError("variance", f"unknown spread measure {variance!r}")

    def convergence(self, params: ConvergenceParams | None = None) -> ConvergenceStatus:
        """Evaluate the dual convergence test (eqs. 15-16) and the obstacle check."""
        c = params or ConvergenceParams()
        spread = self.spread(c.variance)
        hist = self.history[-c.history :]
        full = len(hist) >= c.history
        if len(hist):
            dev = float(np.linalg.norm(hist - hist.mean(axis=0), axis=1).max())
        else:
            dev = math.inf
        est = self.estimate()
        free = True if self.arena is None else bool(self.arena.is_free(est)[0])
        return ConvergenceStatus(
            spread=spread,
            particles_converged=spread <= c.r_conv,
            history_full=full,
            max_history_deviation=dev,
            estimates_converged=full and dev <= c.r_err,
            estimate_free=free,
        )


# ---------------------------------------------------------------------- initialisation
def sample_free_uniform(arena: Arena, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points uniform over the free space of ``arena``, ``(n, d)`` metres.

    Rejection sampling from the bounding box; raises :class:`ConfigError` when the arena has
    (almost) no free space.
    """
    out = np.zeros((0, arena.dim))
    for _ in range(100):
        if len(out) >= n:
            break
        cand = arena.lo + rng.random((max(2 * (n - len(out)), 16), arena.dim)) * arena.size
        out = np.concatenate([out, cand[arena.is_free(cand)]], axis=0)
    if len(out) < n:
        raise ConfigError("arena", "too little free space to sample particles")
    return out[:n]


def backtrack_initialise(
    detection_pos: np.ndarray,
    wind_window: np.ndarray,
    dt: float,
    n: int,
    rng: np.random.Generator,
    *,
    arena: Arena | None = None,
    model: PangFarrellLikelihood | None = None,
    wind_var: np.ndarray | None = None,
    min_std: NonNegative = 0.1,
    uniform_fraction: float = 0.0,
    max_redraws: int = 10,
) -> np.ndarray:
    """Initial particles by back-tracking the recorded wind from the first detection.

    A patch detected at ``detection_pos`` at step ``k`` and released at record ``l`` left the
    source from about ``detection_pos - s(l, k)`` (``s`` the advection of eq. 8) with a spread
    that grows with the elapsed time (eq. 11). Each particle picks a record ``l`` of the window
    uniformly at random and is drawn from ``N(detection_pos - s(l, k), v(l, k) + min_std^2)``
    per axis, so the cloud stretches upwind along the recorded wind path (indoor PF paper,
    section 2.2, step 1).

    A fraction ``uniform_fraction`` of the particles is instead drawn uniformly over the free
    space (robustness when the window is shorter than the travel time from the source).
    Particles outside the arena or in obstacles are redrawn up to ``max_redraws`` times, then
    clipped into the bounds; any still in an obstacle are replaced by uniform free-space draws.

    Parameters
    ----------
    detection_pos : (d,) ndarray, metres
    wind_window : (W, d) ndarray, m/s
        Recorded winds before the detection, oldest first.
    dt : float, s
        Record period.
    n : int
        Number of particles.
    rng : numpy.random.Generator
    arena : Arena, optional
    model : PangFarrellLikelihood, optional
        Supplies the advection/spread geometry (default parameters if ``None``).
    wind_var : (d,) ndarray, m^2/s^2, optional
    min_std : float, metres
    uniform_fraction : float in [0, 1]
    max_redraws : int

    Returns
    -------
    (n, d) ndarray, metres
    """
    if n < 1:
        raise ConfigError("n", "must be >= 1")
    if not 0.0 <= uniform_fraction <= 1.0:
        raise ConfigError("uniform_fraction", "must be in [0, 1]")
    if uniform_fraction > 0 and arena is None:
        raise ConfigError("uniform_fraction", "needs an arena")
    model = model or PangFarrellLikelihood()
    det = np.asarray(detection_pos, float)
    shift, var = model.puff_geometry(np.asarray(wind_window, float), dt, wind_var)
    std = np.sqrt(var + min_std**2)  # (W, d)

    n_uni = round(uniform_fraction * n)
    n_bt = n - n_uni

    def draw(m: int) -> np.ndarray:
        rec = rng.integers(0, len(shift), size=m)
        return det - shift[rec] + std[rec] * rng.standard_normal((m, det.size))

    pos = draw(n_bt)
    if arena is not None and n_bt:
        for _ in range(max_redraws):
            bad = ~arena.is_free(pos)
            if not bad.any():
                break
            pos[bad] = draw(int(bad.sum()))
        pos = arena.clip(pos)
        bad = ~arena.is_free(pos)
        if bad.any():
            pos[bad] = sample_free_uniform(arena, int(bad.sum()), rng)
    if n_uni:
        assert arena is not None
        pos = np.concatenate([pos, sample_free_uniform(arena, n_uni, rng)], axis=0)
    return pos
