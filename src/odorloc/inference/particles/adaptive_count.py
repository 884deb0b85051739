"""Adaptive particle counts: how many particles a filter should carry next (a policy).

:class:`CueDistanceCount` is eq. (18) of the multi-UAV paper (MUC-OSL, IV.1.3)::

    N_k = N_{k-1} * f_dist * (1 - f_cue)

with the *distance gap* ``f_dist = exp(-1 / ||u_k - r_hat_k||)`` (``u`` the UAV, ``r_hat`` the
weighted-mean estimate, metres) and the *cue-capture frequency*
``f_cue = Delta_c / (k - k_{m - Delta_c})``: ``Delta_c`` cues were captured since the iteration
``k_{m - Delta_c}`` of the ``(m - Delta_c)``-th of the ``m`` cues so far. A cue is an iteration with
a non-zero measurement, so ``f_cue <= 1``. Before ``Delta_c`` cues exist the frequency counts
from the start (``f_cue = m / k``). The count is kept in ``[N_min, N_max]``.

Both factors lie in ``[0, 1]``, so eq. 18 as printed can only shrink ``N``: it reaches
``N_min`` after a few dozen iterations whatever happens, although the text says the count follows
the search state (more particles far from the estimate and without cues, fewer near it with
frequent cues) and bounds it above by ``N_max``. Two readings:

- ``"proportional"`` (default): the count is proportional to ``g_k = f_dist (1 - f_cue)``
  relative to the start, ``N_k = N_0 g_k / g_0``, i.e. eq. 18 with its factors read as the
  ratios of successive values ``g_k / g_{k-1}`` (the recursion then telescopes). It shrinks as
  the UAV closes in and captures cues often, and grows back (up to ``N_max``) when it loses them;
- ``"literal"``: ``N_k = N_{k-1} f_dist (1 - f_cue)`` as printed.

The paper also bounds ``N_min`` from below by the particle spacing: two particles no further
apart than ``g < 2 sqrt(D tau)`` (the model's typical length) need ``N >= L_x L_y L_z / g^3``
(:func:`spacing_minimum`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError

__all__ = ["CueDistanceCount", "cue_frequency", "distance_gap", "spacing_minimum"]


def distance_gap(distance: float) -> float:
    """``f_dist = exp(-1 / d)`` for the UAV-estimate distance ``d`` (metres), 0 at ``d = 0``."""
    if not distance >= 0:
        raise ConfigError("distance", f"must be >= 0, got {distance}")
    return 0.0 if distance == 0 else math.exp(-1.0 / distance)


def cue_frequency(cue_iterations: Sequence[int], k: int, delta_c: int = 3) -> float:
    """``f_cue = Delta_c / (k - k_{m - Delta_c})`` (eq. 18's cue-capture frequency), in [0, 1].

    Parameters
    ----------
    cue_iterations : sequence of int
        Iterations (1-based, increasing, each ``<= k``) at which a cue was captured.
    k : int
        Current iteration (>= 1).
    delta_c : int
        ``Delta_c``, the number of recent cues the frequency is taken over.
    """
    m = len(cue_iterations)
    if m == 0 or k < 1:
        return 0.0
    if delta_c < 1:
        raise ConfigError("delta_c", "must be >= 1")
    if m > delta_c:
        return min(1.0, delta_c / max(k - cue_iterations[m - delta_c - 1], 1))
    return min(1.0, m / k)


def spacing_minimum(volume: float, D: float, tau: float) -> int:
    """``N_min = ceil(L_x L_y L_z / g^3)`` for the spacing ``g = 2 sqrt(D tau)`` (metres)."""
    g = 2.0 * math.sqrt(D * tau)
    return max(1, math.ceil(volume / g**3))


class CueDistanceCount:
    """The particle-count policy of eq. (18) (see the module docstring).

    Parameters
    ----------
    n0 : int
        Count at the start (paper: 100).
    n_min, n_max : int
        Bounds (paper: 20 and 160).
    delta_c : int
        ``Delta_c`` of the cue frequency (the paper gives no value).
    reading : {"proportional", "literal"}
    """

    def __init__(
        self,
        n0: int,
        n_min: int,
        n_max: int,
        delta_c: int = 3,
        reading: Literal["proportional", "literal"] = "proportional",
    ) -> None:
        if not 1 <= n_min <= n_max:
            raise ConfigError("n_min", f"need 1 <= n_min <= n_max, got {n_min}, {n_max}")
        if reading not in ("proportional", "literal"):
            raise ConfigError("count_reading", f"unknown reading {reading!r}")
        self.n0 = int(n0)
        self.n_min = int(n_min)
        self.n_max = int(n_max)
        self.delta_c = int(delta_c)
        self.reading = reading
        self._g0: float | None = None

    def start(self, distance: float) -> int:
        """The count at the start, with the UAV ``distance`` metres from the prior estimate."""
        self._g0 = max(distance_gap(distance), 1e-6)
        return int(np.clip(self.n0, self.n_min, self.n_max))

    def factor(self, cue_iterations: Sequence[int], k: int, distance: float) -> float:
        """``g_k = f_dist (1 - f_cue)`` at iteration ``k``."""
        return distance_gap(distance) * (1.0 - cue_frequency(cue_iterations, k, self.delta_c))

    def next(self, n: int, cue_iterations: Sequence[int], k: int, distance: float) -> int:
        """The count for the next iteration given the current ``n`` (eq. 18), in bounds."""
        if self._g0 is None:
            raise RuntimeError("call start() first")
        g = self.factor(cue_iterations, k, distance)
        target = n * g if self.reading == "literal" else self.n0 * g / self._g0
        return int(np.clip(math.floor(target + 0.5), self.n_min, self.n_max))
