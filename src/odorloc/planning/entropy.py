"""Expected-entropy move selection over a weighted source posterior.

Indoor PF paper, section 2.2: the robot evaluates a small set of moves ``M_k`` (forward,
backward, left, right in its own frame) and picks ``m_k* = argmin_{m in M_k} H(m_k)`` (eq. 18),
``H`` being the Shannon entropy of the source posterior expected after the reading the robot
would take at the end of the move. The flattened eq. 17 mixes the likelihood into the entropy;
it is read here, as in infotaxis / entrotaxis (the works it cites), as the expected posterior
entropy

    E[H](m) = sum_z P_m(z) H(w' | z),   P_m(z) = sum_i w_i p(z | L^i, x_m),
    w'_i = w_i p(z | L^i, x_m) / P_m(z),

which simplifies to ``E[H] = sum_z P(z) log P(z) - sum_{z,i} (w_i p_zi) log(w_i p_zi)`` (nats):
one pass over an ``(M, Z, N)`` array, vectorised over candidates and particles.

The planner is model-agnostic: it takes ``likelihood_fn(z, sensor_positions, hypotheses)``
returning ``p(z | L^i)`` as an ``(M, N)`` array for ``(M, d)`` sensor positions (wrap a
one-position function with :func:`pointwise`). For binary readings only ``z = 1`` is evaluated
and ``p(z = 0) = 1 - p(z = 1)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.special import xlogy

from odorloc.errors import ConfigError
from odorloc.inference.belief import ParticleBelief, normalize_log_weights
from odorloc.params import Params, Positive
from odorloc.world.arena import Arena

__all__ = [
    "MOVE_NAMES",
    "EntropyPlan",
    "EntropyPlanner",
    "EntropyPlannerParams",
    "LikelihoodFn",
    "expected_posterior_entropy",
    "move_directions",
    "pointwise",
]

LikelihoodFn = Callable[[int, np.ndarray, np.ndarray], np.ndarray]
"""``likelihood_fn(z, sensor_positions (M, d), hypotheses (N, d)) -> (M, N)`` probabilities."""

MOVE_NAMES = ("forward", "backward", "left", "right")


def expected_posterior_entropy(log_weights: np.ndarray, outcome_probs: np.ndarray) -> np.ndarray:
    """Expected Shannon entropy (nats) of the posterior after one reading, per candidate.

    Parameters
    ----------
    log_weights : (N,) ndarray
        Prior log-weights (normalised or not).
    outcome_probs : (M, Z, N) ndarray
        ``p(z | L^i)`` for each candidate ``m`` and outcome ``z``; for each ``(m, i)`` the
        ``Z`` outcomes should sum to one (they are used as given).

    Returns
    -------
    (M,) ndarray, nats
    """
    q = np.asarray(outcome_probs, float)
    if q.ndim != 3:
        raise ConfigError("outcome_probs", f"expected shape (M, Z, N), got {q.shape}")
    w = np.exp(normalize_log_weights(log_weights))
    if q.shape[2] != w.size:
        raise ConfigError("outcome_probs", f"last axis {q.shape[2]} != {w.size} particles")
    wp = q * w  # joint p(z, L^i) per candidate
    pz = wp.sum(axis=2)  # (M, Z)
    return xlogy(pz, pz).sum(axis=1) - xlogy(wp, wp).sum(axis=(1, 2))


def pointwise(fn: Callable[[int, np.ndarray, np.ndarray], np.ndarray]) -> LikelihoodFn:
    """Adapt ``fn(z, sensor_pos (d,), hypotheses) -> (N,)`` to ``(M, d)`` sensor positions."""

    def batched(z: int, sensor_positions: np.ndarray, hypotheses: np.ndarray) -> np.ndarray:
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        return np.stack([np.asarray(fn(z, s, hypotheses), float) for s in sp])

    return batched


def move_directions(
    frame: Literal["robot", "wind", "world"],
    dim: int,
    heading: float = 0.0,
    wind: np.ndarray | None = None,
) -> np.ndarray:
    """Unit vectors of the moves forward, backward, left, right, ``(4, dim)``.

    ``"robot"``: forward along ``heading`` (rad), left at +90 deg (paper, eq. 18: moves in the
    robot coordinate system). ``"wind"``: forward = upwind (against the horizontal ``wind``),
    falling back to ``heading`` in calm air. ``"world"``: forward = +x, left = +y. Moves are
    horizontal in 3D.
    """
    if frame == "robot":
        ang = heading
    elif frame == "wind":
        if wind is None:
            raise ConfigError("wind", "frame 'wind' needs the wind vector")
        u = np.asarray(wind, float)
        ang = math.atan2(-u[1], -u[0]) if math.hypot(u[0], u[1]) > 1e-9 else heading
    elif frame == "world":
        ang = 0.0
    else:
        raise ConfigError("frame", f"unknown frame {frame!r}")
    c, s = math.cos(ang), math.sin(ang)
    out = np.zeros((4, dim))
    out[:, :2] = [[c, s], [-c, -s], [-s, c], [s, -c]]
    return out


class EntropyPlannerParams(Params):
    """Settings of :class:`EntropyPlanner`.

    Parameters
    ----------
    step_length : float, metres
        Length of a move (the searcher may override per call, e.g. max speed x control period).
    frame : {"robot", "wind", "world"}
        Reference of forward/backward/left/right (paper: the robot frame).
    """

    step_length: Positive = 0.25
    frame: Literal["robot", "wind", "world"] = "robot"


@dataclass(frozen=True)
class EntropyPlan:
    """Outcome of :meth:`EntropyPlanner.plan`.

    Attributes
    ----------
    index : int or None
        Chosen move (index into :data:`MOVE_NAMES`), ``None`` when every move is blocked.
    targets : (M, d) ndarray, metres
    expected_entropy : (M,) ndarray, nats
        ``inf`` for blocked moves.
    feasible : (M,) bool ndarray
    """

    index: int | None
    targets: np.ndarray
    expected_entropy: np.ndarray
    feasible: np.ndarray

    @property
    def target(self) -> np.ndarray | None:
        """Chosen target position, ``(d,)`` metres, or ``None``."""
        return None if self.index is None else self.targets[self.index]

    @property
    def name(self) -> str | None:
        """Name of the chosen move."""
        return None if self.index is None else MOVE_NAMES[self.index]


class EntropyPlanner:
    """Pick the move whose reading minimises the expected posterior entropy (eq. 18).

    Parameters
    ----------
    params : EntropyPlannerParams, optional
    """

    def __init__(self, params: EntropyPlannerParams | None = None) -> None:
        self.params = params or EntropyPlannerParams()

    def candidates(
        self,
        position: np.ndarray,
        heading: float = 0.0,
        wind: np.ndarray | None = None,
        step_length: float | None = None,
    ) -> np.ndarray:
        """Target positions of the four moves, ``(4, d)`` metres."""
        pos = np.asarray(position, float)
        step = self.params.step_length if step_length is None else float(step_length)
        if not (math.isfinite(step) and step > 0):
            raise ConfigError("step_length", "must be a finite number > 0")
        return pos + step * move_directions(self.params.frame, pos.size, heading, wind)

    def expected_entropies(
        self,
        belief: ParticleBelief,
        targets: np.ndarray,
        likelihood_fn: LikelihoodFn,
        outcomes: Sequence[int] = (0, 1),
    ) -> np.ndarray:
        """Expected posterior entropy after a reading at each target, ``(M,)`` nats."""
        t = np.atleast_2d(np.asarray(targets, float))
        if tuple(outcomes) == (0, 1):
            p1 = np.asarray(likelihood_fn(1, t, belief.positions), float)
            q = np.stack([1.0 - p1, p1], axis=1)
        else:
            q = np.stack([np.asarray(likelihood_fn(z, t, belief.positions)) for z in outcomes], 1)
        if q.shape != (len(t), q.shape[1], len(belief.positions)):
            raise ConfigError("likelihood_fn", f"must return (M, N) arrays, got {q.shape}")
        return expected_posterior_entropy(belief.log_weights, q)

    def plan(
        self,
        belief: ParticleBelief,
        position: np.ndarray,
        likelihood_fn: LikelihoodFn,
        *,
        heading: float = 0.0,
        wind: np.ndarray | None = None,
        arena: Arena | None = None,
        step_length: float | None = None,
        outcomes: Sequence[int] = (0, 1),
    ) -> EntropyPlan:
        """Choose ``argmin`` expected entropy among the moves not blocked in ``arena``.

        Ties go to the first move in :data:`MOVE_NAMES` order (deterministic).
        """
        targets = self.candidates(position, heading, wind, step_length)
        if arena is not None:
            feasible = arena.segment_free(np.asarray(position, float), targets)
        else:
            feasible = np.ones(len(targets), bool)
        eh = np.full(len(targets), np.inf)
        if feasible.any():
            eh[feasible] = self.expected_entropies(
                belief, targets[feasible], likelihood_fn, outcomes
            )
            index: int | None = int(np.argmin(eh))
        else:
            index = None
        return EntropyPlan(index, targets, eh, feasible)
