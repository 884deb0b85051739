"""Distances between sets of points: how far an estimated set of sources is from the true one.

The Earth Mover's Distance (Rubner, Tomasi & Guibas 2000) between two weighted point sets
``a_i`` (masses ``u_i``) and ``b_j`` (masses ``v_j``), each normalised to total mass 1, is the
least average distance mass must travel to turn one into the other:

    EMD(a, b) = min_f sum_ij f_ij |a_i - b_j|   s.t.  sum_j f_ij = u_i,  sum_i f_ij = v_j,
                f_ij >= 0,

the 1-Wasserstein distance of the two discrete distributions. With equal masses on both sides
it is the mean distance of the best one-to-one assignment; with unequal numbers of points,
a missing or an extra estimate costs the distance its mass must travel to the others. This is
the score of the multi-source comparison of Sensors 2023, 23(10), 4799 (there between a
probability map and the true sources).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linear_sum_assignment, linprog

from odorloc.core.errors import ConfigError

__all__ = ["earth_movers_distance", "match_sources"]


def _points(x: ArrayLike, name: str) -> np.ndarray:
    p = np.asarray(x, float)
    if p.ndim == 1:
        p = p.reshape(0 if p.size == 0 else 1, -1)
    if p.ndim != 2 or not np.all(np.isfinite(p)):
        raise ConfigError(name, f"needs finite (K, d) points, got shape {p.shape}")
    return p


def earth_movers_distance(
    a: ArrayLike,
    b: ArrayLike,
    a_weights: ArrayLike | None = None,
    b_weights: ArrayLike | None = None,
) -> float:
    """Earth Mover's Distance between two point sets (module docstring), metres.

    Parameters
    ----------
    a : (n, d) array_like
    b : (m, d) array_like
    a_weights, b_weights : (n,), (m,) array_like, optional
        Non-negative masses (normalised here); default equal.

    Returns
    -------
    float
        NaN when either set is empty (no mass to move).
    """
    pa, pb = _points(a, "a"), _points(b, "b")
    if len(pa) == 0 or len(pb) == 0:
        return math.nan
    if pa.shape[1] != pb.shape[1]:
        raise ConfigError("b", f"has {pb.shape[1]} components, a has {pa.shape[1]}")
    cost = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)
    if a_weights is None and b_weights is None and len(pa) == len(pb):
        r, c = linear_sum_assignment(cost)
        return float(cost[r, c].mean())
    u = _masses(a_weights, len(pa), "a_weights")
    v = _masses(b_weights, len(pb), "b_weights")
    n, m = cost.shape
    rows = np.zeros((n + m, n * m))
    for i in range(n):
        rows[i, i * m : (i + 1) * m] = 1.0
    for j in range(m):
        rows[n + j, j::m] = 1.0
    res = linprog(
        cost.ravel(), A_eq=rows, b_eq=np.concatenate([u, v]), bounds=(0, None), method="highs"
    )
    if not res.success:  # pragma: no cover - a transport problem is always feasible
        raise ConfigError("weights", f"transport problem failed: {res.message}")
    return float(res.fun)


def _masses(w: ArrayLike | None, n: int, name: str) -> np.ndarray:
    if w is None:
        return np.full(n, 1.0 / n)
    x = np.asarray(w, float).reshape(-1)
    if x.shape != (n,) or not np.all(np.isfinite(x)) or np.any(x < 0) or not x.sum() > 0:
        raise ConfigError(name, f"needs {n} finite masses >= 0 with a positive sum")
    return x / x.sum()


def match_sources(estimated: ArrayLike, true: ArrayLike, radius: float) -> tuple[int, int]:
    """``(found, false)``: true sources with an estimate within ``radius`` (one estimate per
    source, best one-to-one assignment), and estimates matched to no true source."""
    pe, pt = _points(estimated, "estimated"), _points(true, "true")
    if len(pe) == 0 or len(pt) == 0:
        return 0, len(pe)
    cost = np.linalg.norm(pe[:, None, :] - pt[None, :, :], axis=2)
    r, c = linear_sum_assignment(cost)
    found = int(np.sum(cost[r, c] <= radius))
    return found, len(pe) - found
