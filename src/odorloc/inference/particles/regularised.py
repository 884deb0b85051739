"""Regularised resampling: low-variance selection, then a kernel move scaled to the cloud.

A filter over a *static* source only ever copies the hypotheses it started with; after a few
resamplings the copies sit on a handful of points and the true source, if it fell between
them, can no longer be found (sample impoverishment). The regularised particle filter (Musso,
Oudjane and Le Gland, "Improving regularised particle filters", in Sequential Monte Carlo
Methods in Practice, 2001) draws each copy from a Gaussian kernel around its ancestor instead::

    x' = x_a + h L e,    e ~ N(0, I),    L L^T = Sigma

with ``Sigma`` the weighted covariance of the particles before resampling and the bandwidth
``h = (4 / (N (d + 2)))^(1 / (d + 4))`` optimal for a Gaussian density (Silverman's rule), so
the moves are large while the cloud is wide and shrink as it converges. Ancestors are chosen by
the systematic (low-variance) scheme, :func:`~odorloc.inference.particles.resampling.systematic`.
"""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.inference.particles.constraints import Constraint, place_admissible
from odorloc.inference.particles.resampling import Resampler, systematic

__all__ = ["RegularisedParams", "RegularisedResampler", "silverman_bandwidth"]


def silverman_bandwidth(n: int, d: int) -> float:
    """``h = (4 / (n (d + 2)))^(1 / (d + 4))``, the optimal Gaussian-kernel bandwidth factor."""
    return (4.0 / (max(n, 1) * (d + 2))) ** (1.0 / (d + 4))


class RegularisedParams(Params):
    """Settings of :class:`RegularisedResampler`.

    Parameters
    ----------
    bandwidth : float or None
        Kernel bandwidth factor ``h``; ``None`` uses :func:`silverman_bandwidth` of the target
        count.
    min_std : float, metres
        Floor of the kernel's standard deviation per axis (keeps a collapsed cloud moving).
    max_std : float or None, metres
        Cap of the kernel's standard deviation per axis.
    """

    # Positive, not a bare float: an infinite bandwidth or cap would be accepted and the
    # non-finite kernel then quietly skipped (exact copies)
    bandwidth: Positive | None = None
    min_std: NonNegative = 0.1
    max_std: Positive | None = None


@register("resampler", "regularised", RegularisedParams, "low-variance + kernel move (RPF)")
class RegularisedResampler(Resampler):
    """Systematic selection, then a Gaussian kernel move of covariance ``h^2 Sigma`` (module
    docstring)."""

    params: RegularisedParams
    Params = RegularisedParams

    def _resample(
        self,
        positions: np.ndarray,
        weights: np.ndarray,
        rng: np.random.Generator,
        n: int,
        constraint: Constraint | None,
    ) -> np.ndarray:
        p = self.params
        d = positions.shape[1]
        anc = positions[systematic(weights, n, rng)]
        mean = weights @ positions
        dx = positions - mean
        cov = (dx * weights[:, None]).T @ dx
        h = p.bandwidth if p.bandwidth is not None else silverman_bandwidth(n, d)
        # eigen-decomposition: covariance may be singular (a collapsed axis)
        vals, vecs = np.linalg.eigh(cov)
        std = h * np.sqrt(np.clip(vals, 0.0, None))
        std = np.maximum(std, p.min_std)
        if p.max_std is not None:
            std = np.minimum(std, p.max_std)
        if not np.all(np.isfinite(std)) or math.isclose(float(std.max()), 0.0):
            return anc
        moved = anc + (rng.standard_normal((n, d)) * std) @ vecs.T
        return place_admissible(moved, anc, constraint)
