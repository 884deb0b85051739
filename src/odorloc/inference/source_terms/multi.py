"""Several sources in one posterior: the number of sources and where they are.

The particles carry ``K_max`` exchangeable source slots (any slot may hold any source), so a
source is not a column: it is a cluster of the active slots pooled over the particles. The
number of sources is read from the posterior of the count ``K`` (its mode), and the sources
are the ``K`` clusters of the active slots of the particles with that count (weighted k-means,
started from the slots of the heaviest such particle, so the result is deterministic).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from odorloc.models.source_term import SourceTerms

__all__ = ["ExtractedSources", "count_distribution", "extract_sources"]


@dataclass(frozen=True)
class ExtractedSources:
    """Sources read from a multi-source posterior.

    Attributes
    ----------
    positions : (K, d) ndarray, metres
    log_rates : (K,) ndarray
    spreads : (K,) ndarray, metres
        ``sqrt(trace)`` of each cluster's position covariance.
    count_probability : (K_max + 1,) ndarray
        Posterior of the number of sources.
    """

    positions: np.ndarray
    log_rates: np.ndarray
    spreads: np.ndarray
    count_probability: np.ndarray

    @property
    def count(self) -> int:
        """``K``, the number of sources read."""
        return len(self.positions)


def count_distribution(terms: SourceTerms, weights: np.ndarray) -> np.ndarray:
    """Posterior probability of ``K = 0 .. K_max`` active sources, ``(K_max + 1,)``."""
    counts = terms.active.sum(axis=1)
    return np.bincount(counts, weights=weights, minlength=terms.layout.slots + 1)


def extract_sources(terms: SourceTerms, weights: np.ndarray, iters: int = 30) -> ExtractedSources:
    """The sources of a posterior (module docstring).

    Parameters
    ----------
    terms : SourceTerms
    weights : (N,) ndarray
        Normalised particle weights.
    iters : int
        Lloyd iterations of the weighted k-means.
    """
    d = terms.layout.dim
    pk = count_distribution(terms, weights)
    k = int(np.argmax(pk))
    if k == 0:
        z = np.zeros(0)
        return ExtractedSources(np.zeros((0, d)), z, z, pk)
    act = terms.active
    rows = np.flatnonzero(act.sum(axis=1) == k)
    pos = terms.positions[rows]  # (R, K_max, d)
    lq = terms.log_rates[rows]
    mask = act[rows]
    pts = pos[mask]  # (R k, d)
    lqs = lq[mask]
    w = np.repeat(weights[rows], k)
    best = rows[np.argmax(weights[rows])]
    centres = terms.positions[best][act[best]].copy()
    label = np.zeros(len(pts), np.int64)
    for _ in range(iters):
        dist = np.linalg.norm(pts[:, None, :] - centres[None, :, :], axis=2)
        new = np.argmin(dist, axis=1)
        for j in range(k):
            sel = new == j
            if w[sel].sum() > 0:
                centres[j] = (w[sel] @ pts[sel]) / w[sel].sum()
        if np.array_equal(new, label):
            break
        label = new
    rates = np.zeros(k)
    spreads = np.zeros(k)
    for j in range(k):
        sel = label == j
        ws = w[sel]
        if ws.sum() <= 0:
            rates[j], spreads[j] = np.nan, np.nan
            continue
        ws = ws / ws.sum()
        rates[j] = ws @ lqs[sel]
        dev = pts[sel] - centres[j]
        spreads[j] = float(np.sqrt(ws @ (dev * dev).sum(axis=1)))
    order = np.lexsort(centres.T[::-1])
    return ExtractedSources(centres[order], rates[order], spreads[order], pk)
