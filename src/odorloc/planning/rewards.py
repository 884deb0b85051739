"""Rewards of candidate moves over a weighted belief and a model's outcome probabilities.

All functions take prior log-weights ``(N,)`` and outcome probabilities ``q (M, Z, N)``,
``q[m, z, i] = p(z | hypothesis i, candidate m)`` (from
:meth:`~odorloc.models.base.MeasurementModel.outcome_probabilities`), and return ``(M,)``.

A search that ends when the agent reaches the source has one more outcome than the reading: the
source is *found* at candidate ``m`` when it is one of the hypotheses ``found[m, i]`` (those
within reach of the candidate). ``p_found = sum_i w_i found_mi``; otherwise a reading ``z`` is
taken with ``P(z, not found) = sum_i w_i (1 - found_mi) q_mzi``, and the posterior is
``b_z ∝ w (1 - found_m) q_mz`` (Vergassola et al. 2007; Loisy & Eloy 2022). Finding the source
leaves no uncertainty.

- :func:`expected_entropy`: expected Shannon entropy of the posterior after the move
  (infotaxis, Vergassola et al. 2007; indoor PF paper eqs. 17-18);
- :func:`predictive_entropy`: entropy of the predicted outcome itself (entrotaxis, Hutchinson
  et al. 2018);
- :func:`space_aware_value`: space-aware infotaxis (Loisy & Eloy 2022),
  ``sum_z P(z, not found) g(D_z + 2^(S_z - 1) - 1/2)`` with ``S_z`` the posterior entropy in bits,
  ``D_z`` the posterior mean distance in moves and ``g(v) = log2 v`` for ``v > 0``, else ``v``;
- :func:`mean_distance`: expected posterior mean distance to the source (Loisy & Eloy 2022);
- :func:`greedy`: the probability of *not* finding the source at the candidate.

``floor`` reproduces the conventions of the reference implementation of these policies (OTTO):
a posterior is normalised only when its mass exceeds ``floor``, entropies run over hypotheses of
probability above ``floor``, and a candidate that finds the source with probability above
``1 - floor`` scores ``-floor`` (bits, or distance), i.e. it is always taken. ``floor = 0`` is the
exact mathematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.special import xlogy

from odorloc.core.errors import ConfigError
from odorloc.inference.weights import normalise_log_weights

__all__ = [
    "OutcomePosteriors",
    "expected_entropy",
    "expected_entropy_from",
    "found_probability",
    "greedy",
    "mean_distance",
    "mean_distance_from",
    "outcome_marginals",
    "outcome_posteriors",
    "predictive_entropy",
    "space_aware_from",
    "space_aware_value",
]

Unit = Literal["nats", "bits"]
_LN2 = math.log(2.0)


def _scale(unit: Unit) -> float:
    if unit == "nats":
        return 1.0
    if unit == "bits":
        return 1.0 / _LN2
    raise ConfigError("unit", f"expected 'nats' or 'bits', got {unit!r}")


def _check(
    log_weights: np.ndarray, outcome_probs: np.ndarray, found: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    q = np.asarray(outcome_probs, float)
    if q.ndim != 3:
        raise ConfigError("outcome_probs", f"expected shape (M, Z, N), got {q.shape}")
    w = normalise_log_weights(log_weights)[1]
    if q.shape[2] != w.size:
        raise ConfigError("outcome_probs", f"last axis {q.shape[2]} != {w.size} hypotheses")
    f = None
    if found is not None:
        f = np.asarray(found, bool)
        if f.shape != (q.shape[0], q.shape[2]):
            raise ConfigError("found", f"expected shape {(q.shape[0], q.shape[2])}, got {f.shape}")
    return w, q, f


def _entropy(p: np.ndarray, floor: float, axis: int) -> np.ndarray:
    """``-sum p log p`` over ``axis``, counting only entries above ``floor``, nats."""
    if floor <= 0:
        return -xlogy(p, p).sum(axis=axis)
    keep = p > floor
    lg = np.log(p, where=keep, out=np.zeros_like(p))
    return -(p * lg).sum(axis=axis)


def found_probability(log_weights: np.ndarray, found: np.ndarray) -> np.ndarray:
    """Probability that the source is among the found hypotheses of each candidate, ``(M,)``."""
    w = normalise_log_weights(log_weights)[1]
    f = np.atleast_2d(np.asarray(found, bool))
    if f.shape[1] != w.size:
        raise ConfigError("found", f"last axis {f.shape[1]} != {w.size} hypotheses")
    return f.astype(float) @ w


def outcome_marginals(log_weights: np.ndarray, outcome_probs: np.ndarray) -> np.ndarray:
    """Predicted probability of each outcome at each candidate, ``(M, Z)``."""
    w, q, _ = _check(log_weights, outcome_probs)
    return q @ w


@dataclass(frozen=True)
class OutcomePosteriors:
    """The outcome law of every candidate and the posterior after each reading.

    Attributes
    ----------
    p_found : (M,) ndarray
    p : (M, Z) ndarray
        Law of the reading given that the source was not found.
    posterior : (M, Z, N) ndarray
        Posterior after reading ``z`` (normalised where ``p`` exceeds the floor).
    """

    p_found: np.ndarray
    p: np.ndarray
    posterior: np.ndarray


def outcome_posteriors(
    log_weights: np.ndarray,
    outcome_probs: np.ndarray,
    found: np.ndarray | None = None,
    floor: float = 0.0,
) -> OutcomePosteriors:
    """The posteriors of every (candidate, reading) pair, with the ``floor`` conventions."""
    w, q, f = _check(log_weights, outcome_probs, found)
    m = q.shape[0]
    if f is None:
        pe = np.zeros(m)
        rest = np.broadcast_to(w, (m, w.size))
    else:
        pe = f.astype(float) @ w
        rest = np.where(f, 0.0, w[None, :])
    s = rest.sum(axis=1)
    keep = s > floor
    rest = rest / np.where(keep, s, 1.0)[:, None]
    joint = rest[:, None, :] * q
    p = joint.sum(axis=2)
    post = joint / np.where(p > floor, p, 1.0)[:, :, None]
    return OutcomePosteriors(pe, p, post)


def expected_entropy_from(
    p_found: np.ndarray, p: np.ndarray, entropy: np.ndarray, floor: float = 0.0
) -> np.ndarray:
    """``(1 - p_found) sum_z p(z) S_z`` from the outcome law and the posterior entropies
    ``S (M, Z)``; a candidate found with probability above ``1 - floor`` scores ``-floor``."""
    out = (1.0 - p_found) * (p * entropy).sum(axis=1)
    return np.where(p_found > 1.0 - floor, -floor, out) if floor > 0 else out


def space_aware_from(
    p_found: np.ndarray,
    p: np.ndarray,
    entropy_bits: np.ndarray,
    distance: np.ndarray,
    floor: float = 0.0,
) -> np.ndarray:
    """Space-aware infotaxis from the outcome law, the posterior entropies (bits) and mean
    distances ``(M, Z)``: ``sum_z (1 - p_found) p(z) g(D_z + 2^(S_z - 1) - 1/2)``."""
    v = distance + np.exp2(entropy_bits - 1.0) - 0.5
    g = np.where(v > 0, np.log2(np.where(v > 0, v, 1.0)), v)
    out = ((1.0 - p_found)[:, None] * p * g).sum(axis=1)
    return np.where(p_found > 1.0 - floor, -floor, out) if floor > 0 else out


def mean_distance_from(
    p_found: np.ndarray, p: np.ndarray, distance: np.ndarray, floor: float = 0.0
) -> np.ndarray:
    """``(1 - p_found) sum_z p(z) D_z`` from the outcome law and the posterior mean distances."""
    out = (1.0 - p_found) * (p * distance).sum(axis=1)
    return np.where(p_found > 1.0 - floor, -floor, out) if floor > 0 else out


def expected_entropy(
    log_weights: np.ndarray,
    outcome_probs: np.ndarray,
    found: np.ndarray | None = None,
    *,
    floor: float = 0.0,
    unit: Unit = "nats",
) -> np.ndarray:
    """Expected Shannon entropy of the posterior after one move to each candidate, ``(M,)``.

    ``E[H](m) = sum_z P_m(z, not found) H(b_z)`` (a found source leaves entropy 0). With
    ``floor = 0`` it is computed in one pass as
    ``sum_z P(z) log P(z) - sum_{z,i} J_zi log J_zi``, ``J_zi = w_i (1 - found_mi) q_mzi``.
    """
    scale = _scale(unit)
    if floor <= 0:
        w, q, f = _check(log_weights, outcome_probs, found)
        rest = w[None, :] if f is None else np.where(f, 0.0, w[None, :])
        wp = q * rest[:, None, :]  # joint p(z, hypothesis, not found) per candidate
        pz = wp.sum(axis=2)  # (M, Z)
        return scale * (xlogy(pz, pz).sum(axis=1) - xlogy(wp, wp).sum(axis=(1, 2)))
    op = outcome_posteriors(log_weights, outcome_probs, found, floor)
    s = scale * _entropy(op.posterior, floor, axis=2)
    return expected_entropy_from(op.p_found, op.p, s, floor)


def predictive_entropy(
    log_weights: np.ndarray,
    outcome_probs: np.ndarray,
    found: np.ndarray | None = None,
    *,
    unit: Unit = "nats",
) -> np.ndarray:
    """Entropy of the predicted outcome at each candidate, ``(M,)``.

    ``-sum_z P(z) log P(z)``; with ``found`` the outcomes are "found" and the readings when not
    found: ``-p_found log p_found - sum_z P(z, not found) log P(z, not found)``.
    """
    w, q, f = _check(log_weights, outcome_probs, found)
    rest = w[None, :] if f is None else np.where(f, 0.0, w[None, :])
    pz = np.einsum("mzn,mn->mz", q, rest)
    h = -xlogy(pz, pz).sum(axis=1)
    if f is not None:
        pe = f.astype(float) @ w
        h = h - xlogy(pe, pe)
    return _scale(unit) * h


def _distances(distances: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    d = np.asarray(distances, float)
    if d.shape != shape or not np.all(np.isfinite(d)):
        raise ConfigError("distances", f"expected finite shape {shape}, got {d.shape}")
    return d


def space_aware_value(
    log_weights: np.ndarray,
    outcome_probs: np.ndarray,
    found: np.ndarray | None,
    distances: np.ndarray,
    *,
    floor: float = 0.0,
) -> np.ndarray:
    """Space-aware infotaxis (Loisy & Eloy 2022), to be minimised, ``(M,)``.

    ``sum_z (1 - p_found) p(z) g(D_z + 2^(S_z - 1) - 1/2)``, ``S_z`` in bits,
    ``D_z = sum_i b_z(i) distances_mi`` (in moves: the policy weighs distance against the
    number ``2^S`` of equally likely cells), ``g(v) = log2 v`` if ``v > 0`` else ``v``.
    """
    op = outcome_posteriors(log_weights, outcome_probs, found, floor)
    d = _distances(distances, (op.posterior.shape[0], op.posterior.shape[2]))
    s = _entropy(op.posterior, floor, axis=2) / _LN2
    dz = np.einsum("mzn,mn->mz", op.posterior, d)
    return space_aware_from(op.p_found, op.p, s, dz, floor)


def mean_distance(
    log_weights: np.ndarray,
    outcome_probs: np.ndarray,
    found: np.ndarray | None,
    distances: np.ndarray,
    *,
    floor: float = 0.0,
) -> np.ndarray:
    """Expected posterior mean distance to the source (Loisy & Eloy 2022), ``(M,)``.

    ``(1 - p_found) sum_z p(z) sum_i b_z(i) distances_mi`` (in the units of ``distances``).
    """
    op = outcome_posteriors(log_weights, outcome_probs, found, floor)
    d = _distances(distances, (op.posterior.shape[0], op.posterior.shape[2]))
    dz = np.einsum("mzn,mn->mz", op.posterior, d)
    return mean_distance_from(op.p_found, op.p, dz, floor)


def greedy(log_weights: np.ndarray, found: np.ndarray) -> np.ndarray:
    """The greedy policy's score ``1 - p_found`` (the most probable neighbour wins), ``(M,)``."""
    return 1.0 - found_probability(log_weights, found)
