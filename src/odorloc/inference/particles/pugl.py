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
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.inference.particles.constraints import Constraint

__all__ = ["col_position_update", "env_position_update", "gbest", "moved_count"]


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
