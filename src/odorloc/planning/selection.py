"""Selection of one candidate from its scores, with explicit tie rules."""

from __future__ import annotations

from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError

__all__ = ["select"]


def select(
    scores: np.ndarray,
    *,
    mode: Literal["min", "max"] = "min",
    feasible: np.ndarray | None = None,
    ties: Literal["first", "random"] = "first",
    rtol: float = 0.0,
    atol: float = 0.0,
    rng: np.random.Generator | None = None,
) -> int | None:
    """Index of the best feasible candidate, or ``None`` when none is feasible.

    Parameters
    ----------
    scores : (M,) ndarray
        NaN and infinite scores count as infeasible.
    mode : {"min", "max"}
    feasible : (M,) bool ndarray, optional
    ties : {"first", "random"}
        Candidates within ``atol + rtol * |best|`` of the best tie; ``"first"`` takes the lowest
        index (deterministic), ``"random"`` draws one uniformly with ``rng``.
    """
    s = np.asarray(scores, float).reshape(-1)
    ok = np.isfinite(s)
    if feasible is not None:
        ok &= np.asarray(feasible, bool).reshape(-1)
    if not ok.any():
        return None
    signed = np.where(ok, s if mode == "min" else -s, np.inf)
    if ties == "first" and atol == 0.0 and rtol == 0.0:
        return int(signed.argmin())  # the first index of the minimum
    best = float(signed.min())
    tol = atol + rtol * abs(best)
    cand = np.flatnonzero(signed <= best + tol)
    if ties == "first" or len(cand) == 1:
        return int(cand[0])
    if rng is None:
        raise ConfigError("rng", "random tie-breaking needs a generator")
    return int(cand[rng.integers(len(cand))])
