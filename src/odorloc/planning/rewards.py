"""Rewards of candidate moves over a weighted belief and a model's outcome probabilities.

All functions take prior log-weights ``(N,)`` and outcome probabilities ``q (M, Z, N)``,
``q[m, z, i] = p(z | hypothesis i, candidate m)`` (from
:meth:`~odorloc.models.base.MeasurementModel.outcome_probabilities`), and return ``(M,)``.

- :func:`expected_entropy`: expected Shannon entropy of the posterior after the reading
  (infotaxis, Vergassola et al. 2007; indoor PF paper eqs. 17-18);
- :func:`predictive_entropy`: entropy of the predicted reading itself (entrotaxis, Hutchinson
  et al. 2018).
"""

from __future__ import annotations

import numpy as np
from scipy.special import xlogy

from odorloc.core.errors import ConfigError
from odorloc.inference.weights import normalise_log_weights

__all__ = ["expected_entropy", "outcome_marginals", "predictive_entropy"]


def _check(log_weights: np.ndarray, outcome_probs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(outcome_probs, float)
    if q.ndim != 3:
        raise ConfigError("outcome_probs", f"expected shape (M, Z, N), got {q.shape}")
    w = normalise_log_weights(log_weights)[1]
    if q.shape[2] != w.size:
        raise ConfigError("outcome_probs", f"last axis {q.shape[2]} != {w.size} hypotheses")
    return w, q


def outcome_marginals(log_weights: np.ndarray, outcome_probs: np.ndarray) -> np.ndarray:
    """Predicted probability of each outcome at each candidate, ``(M, Z)``."""
    w, q = _check(log_weights, outcome_probs)
    return q @ w


def expected_entropy(log_weights: np.ndarray, outcome_probs: np.ndarray) -> np.ndarray:
    """Expected posterior entropy after one reading at each candidate, ``(M,)`` nats.

    ``E[H](m) = sum_z P_m(z) H(w' | z)`` with ``P_m(z) = sum_i w_i q_mzi`` and
    ``w'_i = w_i q_mzi / P_m(z)``, which simplifies to
    ``sum_z P(z) log P(z) - sum_{z,i} (w_i q_zi) log(w_i q_zi)``: one pass over the array.
    """
    w, q = _check(log_weights, outcome_probs)
    wp = q * w  # joint p(z, hypothesis) per candidate
    pz = wp.sum(axis=2)  # (M, Z)
    return xlogy(pz, pz).sum(axis=1) - xlogy(wp, wp).sum(axis=(1, 2))


def predictive_entropy(log_weights: np.ndarray, outcome_probs: np.ndarray) -> np.ndarray:
    """Entropy of the predicted reading ``-sum_z P(z) log P(z)`` at each candidate, nats."""
    w, q = _check(log_weights, outcome_probs)
    pz = q @ w
    return -xlogy(pz, pz).sum(axis=1)
