"""PUGL: particle position update with global and local information (multi-UAV paper, IV.1.2).

After resampling, UAV ``i`` picks ``N_s`` of its ``N`` particles at random (eq. 15)::

    N_s = N [1 - (k / k_max)^gamma_1]^gamma_2

and moves them in two stages:

- **env-pu** (eq. 16): upwind, as an anemotactic animal would. As printed,
  ``x_k = x_{k-1} + rand x_{k-1} cos(theta)``, ``y_k = y_{k-1} + rand y_{k-1} sin(theta)``,
  ``z_k = z_{k-1}``: the step scales with the particle's own coordinate, so the same particle
  moves further the further the arena's origin lies from it, which no physical reading supports
  (the update is not invariant to translating the coordinates). Two readings are offered:

  - ``"invariant"`` (default): ``o_k = o_{k-1} + rand * step * u_up`` with ``u_up`` the
    horizontal upwind unit vector (``theta`` its angle) and ``step`` a length (metres): every
    selected particle moves a uniform random fraction of ``step`` straight upwind, whatever the
    coordinates;
  - ``"literal"``: the printed form, ``rand`` one uniform number per particle, ``theta`` the
    angle of the upwind direction; with the arena's origin at its corner and the paper's wind
    towards ``-y`` it moves particles by up to their distance from the downwind edge.

  Both keep ``z`` (the wind is horizontal) and project the result back into the constraint;
- **col-pu** (eq. 17), only for a UAV that has not captured any cue yet:
  ``o <- o + rand (gbest - o)`` with ``gbest`` the beta-weighted mean of the estimates of its
  cue-captured neighbours. The paper writes ``gbest = sum_i beta_ji mu_i`` and calls it "the
  weighted mean position"; the weights are normalised here (``sum_i beta_ji mu_i / sum_i
  beta_ji``), which is what makes it a position.

**Printed or reversible moves** (``pugl_move`` of the Col-PF estimator). As printed, the moved
particles keep their weights and nothing checks them against the measurements: env-pu pushes
most particles upwind at every iteration (``N_s`` of eq. 15 is at least 97 % of ``N`` for the
first 50 of 800 iterations), so the particle set drifts upwind whatever the UAVs measure. A
particle filter that moves its particles keeps its posterior only if each move is a Markov move
that leaves the posterior invariant (resample-move, Gilks & Berzuini 2001): a
Metropolis-Hastings move judged by the whole measurement history. The reversible reading keeps
what eqs. 16-17 propose and judges it:

- **env-pu, reversible** (:func:`reversible_env_move`): each selected particle proposes eq. 16's
  step (the invariant reading: a uniform fraction of ``step`` along the horizontal wind axis),
  upwind or downwind with equal probability. The proposal is symmetric (the step from ``x`` to
  ``x'`` and back has the same density), so the move is accepted with probability
  ``min(1, p(D | x') / p(D | x))`` under a uniform prior on the free search region;
- **col-pu, reversible** (:func:`reversible_col_move`): eq. 17's pull towards ``gbest`` becomes
  an independence proposal ``x' ~ N(gbest, Sigma_g)``, ``Sigma_g`` the beta-weighted mixture
  covariance of the cue-captured neighbours' fits (:func:`gbest_gaussian`), accepted with
  probability ``min(1, p(D | x') q(x) / (p(D | x) q(x')))``: the proposal density enters the
  ratio, which makes the move reversible although it does not depend on ``x``;
- a proposal outside the prior's support (:class:`PriorSupport`) is rejected, never projected
  back: a projection would pile particles on the walls and break the symmetry of the proposal.

Eq. 16's literal, coordinate-scaled step has no reversible form of its own kind (the move back
from ``x'`` is not one of the moves proposed from ``x'``), so ``env_pu: literal`` runs with the
printed moves only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.types import Region
from odorloc.geometry.arena import Arena
from odorloc.inference.particles.constraints import Constraint

__all__ = [
    "MoveResult",
    "PriorSupport",
    "col_position_update",
    "env_position_update",
    "gbest",
    "gbest_gaussian",
    "moved_count",
    "reversible_col_move",
    "reversible_env_move",
]

#: ``target(points (S, d)) -> (S,)``: the log-likelihood of the measurement history (the log
#: posterior up to the uniform prior's constant).
Target = Callable[[np.ndarray], np.ndarray]


def moved_count(n: int, k: int, k_max: int, gamma1: float = 1.8, gamma2: float = 4.0) -> int:
    """``N_s = N [1 - (k/k_max)^gamma_1]^gamma_2`` rounded to an integer (eq. 15).

    Parameters
    ----------
    n : int
        Current particle count ``N``.
    k : int
        Iteration, ``0 <= k``; ``k >= k_max`` moves none.
    k_max : int
        Maximum iteration number (paper: 800).
    gamma1, gamma2 : float
        Exponents (paper: 1.8 and 4).
    """
    if n < 0 or k < 0 or k_max < 1:
        raise ConfigError("k", f"need n >= 0, k >= 0 and k_max >= 1, got {n}, {k}, {k_max}")
    if k >= k_max:
        return 0
    frac = (1.0 - (k / k_max) ** gamma1) ** gamma2
    return int(min(n, math.floor(n * frac + 0.5)))


def env_position_update(
    positions: np.ndarray,
    selected: np.ndarray,
    upwind: np.ndarray,
    rng: np.random.Generator,
    *,
    step: float = 2.0,
    reading: Literal["invariant", "literal"] = "invariant",
    constraint: Constraint | None = None,
) -> np.ndarray:
    """env-pu (eq. 16): the selected particles move upwind; a new ``(N, d)`` array.

    Parameters
    ----------
    positions : (N, d) ndarray, metres
    selected : (S,) int ndarray
        Indices of the particles to move.
    upwind : (d,) ndarray
        Direction against the wind (only its horizontal part is used; normalised here).
    rng : numpy.random.Generator
        One uniform ``rand`` per selected particle.
    step : float, metres
        Largest step of the ``"invariant"`` reading.
    reading : {"invariant", "literal"}
        See the module docstring.
    constraint : Constraint, optional
        Moved particles are projected back into it.
    """
    out = np.array(positions, float)
    sel = np.asarray(selected, np.int64)
    u = np.zeros(out.shape[1])
    u[:2] = np.asarray(upwind, float)[:2]
    norm = math.hypot(u[0], u[1])
    if len(sel) == 0 or norm < 1e-12:
        return out
    u /= norm
    r = rng.random(len(sel))
    if reading == "invariant":
        moved = out[sel] + (step * r)[:, None] * u[None, :]
    elif reading == "literal":
        moved = out[sel].copy()
        # x += rand x cos(theta), y += rand y sin(theta), with (cos, sin) = u
        moved[:, 0] += r * moved[:, 0] * u[0]
        moved[:, 1] += r * moved[:, 1] * u[1]
    else:
        raise ConfigError("env_pu", f"unknown reading {reading!r}")
    if constraint is not None:
        moved = constraint.project(moved)
    out[sel] = moved
    return out


def gbest(means: np.ndarray, betas: np.ndarray) -> np.ndarray | None:
    """The beta-weighted mean ``sum beta_i mu_i / sum beta_i`` of neighbours' estimates, or
    ``None`` without neighbours (or with all betas 0), ``(d,)`` metres (col-pu, eq. 17)."""
    m = np.asarray(means, float)
    b = np.asarray(betas, float).reshape(-1)
    if m.size == 0 or b.sum() <= 0:
        return None
    return (b @ m.reshape(len(b), -1)) / b.sum()


def col_position_update(
    positions: np.ndarray,
    selected: np.ndarray,
    target: np.ndarray,
    rng: np.random.Generator,
    constraint: Constraint | None = None,
) -> np.ndarray:
    """col-pu (eq. 17): ``o <- o + rand (gbest - o)`` for the selected particles; a new array."""
    out = np.array(positions, float)
    sel = np.asarray(selected, np.int64)
    if len(sel) == 0:
        return out
    g = np.asarray(target, float)
    r = rng.random(len(sel))
    moved = out[sel] + r[:, None] * (g[None, :] - out[sel])
    if constraint is not None:
        moved = constraint.project(moved)
    out[sel] = moved
    return out


class PriorSupport:
    """Where the uniform prior of the source lives: the arena's free space, within the search
    region when the task names one (the region particles are first drawn from).

    Parameters
    ----------
    arena : Arena
    region : Region, optional
        ``(lower, upper)`` bounds on the first ``k <= d`` coordinates, metres.
    """

    def __init__(self, arena: Arena, region: Region | None = None) -> None:
        self.arena = arena
        self.lower: np.ndarray | None = None
        self.upper: np.ndarray | None = None
        if region is not None:
            self.lower = np.asarray(region[0], float)
            self.upper = np.asarray(region[1], float)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """``(Q,)`` bool: which of ``(Q, d)`` points the prior gives a positive density."""
        p = np.asarray(points, float)
        ok = self.arena.is_free(p)
        if self.lower is not None and self.upper is not None:
            k = len(self.lower)
            ok &= ((p[:, :k] >= self.lower) & (p[:, :k] <= self.upper)).all(axis=1)
        return ok


class MoveResult:
    """The outcome of a Metropolis-Hastings move of ``S`` particles.

    Attributes
    ----------
    positions : (S, d) ndarray, metres
        The particles after the move (a rejected proposal leaves its particle where it was).
    log_likelihood : (S,) ndarray
        The history's log-likelihood at the new positions.
    accepted : (S,) bool ndarray
    evaluated : int
        Hypotheses whose history log-likelihood was evaluated (work done).
    """

    __slots__ = ("accepted", "evaluated", "log_likelihood", "positions")

    def __init__(
        self,
        positions: np.ndarray,
        log_likelihood: np.ndarray,
        accepted: np.ndarray,
        evaluated: int,
    ) -> None:
        self.positions = positions
        self.log_likelihood = log_likelihood
        self.accepted = accepted
        self.evaluated = evaluated


def _judge(
    x: np.ndarray,
    ll: np.ndarray,
    proposals: np.ndarray,
    log_u: np.ndarray,
    target: Target,
    support: PriorSupport,
    log_q_ratio: np.ndarray | None = None,
) -> MoveResult:
    """Accept ``proposals`` where ``log u < log p(D | x') - log p(D | x) (+ log q ratio)`` and
    the proposal lies in the prior's support (the rest is rejected unevaluated)."""
    ok = support.contains(proposals)
    ll_prop = np.full(len(x), -np.inf)
    if ok.any():
        ll_prop[ok] = target(proposals[ok])
    log_alpha = ll_prop - ll
    if log_q_ratio is not None:
        log_alpha = log_alpha + log_q_ratio
    # log_alpha is -inf (never NaN) for a rejected or impossible proposal: ll is finite where the
    # particle lies (it was accepted there), and -inf - finite = -inf
    accept = ok & (log_u < log_alpha)
    out = x.copy()
    out[accept] = proposals[accept]
    new_ll = np.where(accept, ll_prop, ll)
    return MoveResult(out, new_ll, accept, int(ok.sum()))


def reversible_env_move(
    positions: np.ndarray,
    log_likelihood: np.ndarray,
    upwind: np.ndarray,
    step: float,
    rng: np.random.Generator,
    target: Target,
    support: PriorSupport,
) -> MoveResult:
    """env-pu (eq. 16) as a reversible Metropolis-Hastings move (see the module docstring).

    Parameters
    ----------
    positions : (S, d) ndarray, metres
        The selected particles.
    log_likelihood : (S,) ndarray
        ``target`` at ``positions``.
    upwind : (d,) ndarray
        Direction against the wind (only its horizontal part is used; normalised here).
    step : float, metres
        Largest step (eq. 16's invariant reading): the step is ``step * rand``, ``rand`` uniform
        in ``[0, 1)``, upwind or downwind with probability 1/2 each.
    rng : numpy.random.Generator
        One ``(S, 3)`` uniform draw: the step fraction, the side, the acceptance.
    target : callable
        The history's log-likelihood at ``(Q, d)`` points.
    support : PriorSupport
    """
    x = np.asarray(positions, float)
    ll = np.asarray(log_likelihood, float)
    u = np.zeros(x.shape[1])
    u[:2] = np.asarray(upwind, float)[:2]
    norm = math.hypot(u[0], u[1])
    if len(x) == 0 or norm < 1e-12:
        return MoveResult(x.copy(), ll.copy(), np.zeros(len(x), bool), 0)
    u /= norm
    draws = rng.random((len(x), 3))
    side = np.where(draws[:, 1] < 0.5, 1.0, -1.0)
    proposals = x + (side * step * draws[:, 0])[:, None] * u[None, :]
    with np.errstate(divide="ignore"):
        log_u = np.log(draws[:, 2])
    return _judge(x, ll, proposals, log_u, target, support)


def gbest_gaussian(
    means: np.ndarray, covs: np.ndarray, betas: np.ndarray, floor: float = 1.0
) -> tuple[np.ndarray, np.ndarray] | None:
    """``gbest`` (eq. 17) and the covariance of the beta-weighted mixture of the neighbours'
    fits, ``(d,)`` metres and ``(d, d)`` m^2; ``None`` without neighbours or with all betas 0.

    The covariance is the moment-matched mixture ``sum_i w_i (Sigma_i + (mu_i - g)(mu_i - g)^T)``
    with ``w_i = beta_i / sum beta``, plus ``floor^2`` on the diagonal (metres: a fit of
    coincident particles would otherwise give a degenerate proposal).
    """
    m = np.asarray(means, float)
    b = np.asarray(betas, float).reshape(-1)
    if m.size == 0 or b.sum() <= 0:
        return None
    m = m.reshape(len(b), -1)
    d = m.shape[1]
    c = np.asarray(covs, float).reshape(len(b), d, d)
    w = b / b.sum()
    g = w @ m
    dm = m - g
    cov = np.einsum("i,ijk->jk", w, c) + (dm * w[:, None]).T @ dm
    cov = 0.5 * (cov + cov.T) + floor * floor * np.eye(d)
    return g, cov


def reversible_col_move(
    positions: np.ndarray,
    log_likelihood: np.ndarray,
    centre: np.ndarray,
    cov: np.ndarray,
    rng: np.random.Generator,
    target: Target,
    support: PriorSupport,
) -> MoveResult:
    """col-pu (eq. 17) as a Metropolis-Hastings independence move (module docstring).

    Parameters
    ----------
    positions : (S, d) ndarray, metres
    log_likelihood : (S,) ndarray
        ``target`` at ``positions``.
    centre : (d,) ndarray, metres
        ``gbest``.
    cov : (d, d) ndarray, m^2
        Covariance of the proposal (positive definite, :func:`gbest_gaussian`).
    rng : numpy.random.Generator
        ``(S, d)`` standard normals, then ``S`` uniforms for the acceptance.
    target, support
        As :func:`reversible_env_move`.
    """
    x = np.asarray(positions, float)
    ll = np.asarray(log_likelihood, float)
    if len(x) == 0:
        return MoveResult(x.copy(), ll.copy(), np.zeros(0, bool), 0)
    try:
        chol = np.linalg.cholesky(np.asarray(cov, float))
    except np.linalg.LinAlgError:
        raise ConfigError(
            "cov", "the col-pu proposal needs a positive definite covariance"
        ) from None
    g = np.asarray(centre, float)
    z = rng.standard_normal(x.shape)
    with np.errstate(divide="ignore"):
        log_u = np.log(rng.random(len(x)))
    proposals = g + z @ chol.T
    # log q(x) - log q(x'): the Gaussian's normalising constant cancels
    back = np.linalg.solve(chol, (x - g).T).T
    log_q_ratio = -0.5 * (back * back).sum(axis=1) + 0.5 * (z * z).sum(axis=1)
    return _judge(x, ll, proposals, log_u, target, support, log_q_ratio)
