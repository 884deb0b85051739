"""Selection of one candidate from its scores, with explicit tie rules.

:func:`select` is the rule; the registry family ``selection`` (:class:`Selection`) makes it a
part of a planner: ``best`` (:class:`BestSelection`), the lowest score with ties broken first
or at random.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, NonNegative, Params
from odorloc.core.registry import register

__all__ = ["BestSelection", "Selection", "select"]


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


# ---------------------------------------------------------------------- the ``selection`` family
class Selection(Configured, ABC):
    """Base class of the ``selection`` family: one candidate from its (minimised) scores."""

    @property
    def tolerance(self) -> float:
        """Scores within this of the best count as ties (default 0)."""
        return 0.0

    @abstractmethod
    def choose(
        self, scores: np.ndarray, feasible: np.ndarray, rng: np.random.Generator | None
    ) -> int | None:
        """Index of the chosen candidate, or ``None`` when none is feasible."""


class BestParams(Params):
    """Settings of :class:`BestSelection`.

    Attributes
    ----------
    ties : {"first", "random"}
        Ties go to the first candidate in candidate order or to one drawn uniformly.
    tolerance : float
        Scores within this of the best tie (in the reward's unit).
    """

    ties: Literal["first", "random"] = "first"
    tolerance: NonNegative = 0.0


@register("selection", "best", BestParams, "the lowest score, with an explicit tie rule")
class BestSelection(Selection):
    """The feasible candidate of lowest score (:func:`select`, ``mode="min"``)."""

    params: BestParams
    Params = BestParams

    @property
    def tolerance(self) -> float:
        return self.params.tolerance

    def choose(
        self, scores: np.ndarray, feasible: np.ndarray, rng: np.random.Generator | None
    ) -> int | None:
        p = self.params
        return select(scores, mode="min", feasible=feasible, ties=p.ties, atol=p.tolerance, rng=rng)
