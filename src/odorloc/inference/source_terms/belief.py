"""The source-term posterior as a belief: weighted particles over ``theta`` and what they say.

:class:`SourceTermBelief` is a :class:`~odorloc.inference.belief.ParticleBelief` (its
``positions`` are those of each particle's first source slot, so every particle plot and
planner of positions applies) that also carries the whole ``theta`` matrix. It gives:

- posterior moments of ``theta`` and of the position (:meth:`SourceTermBelief.theta_mean`,
  ``mean``, ``cov``);
- the 95 % credible region of the position (:class:`CredibleRegion`): the highest-posterior-
  density region of a kernel density estimate over a thinned sample (Hyndman 1996, "Computing
  and graphing highest density regions": the level is the ``1 - alpha`` quantile of the
  density at the sample points), and the equal-tailed interval of the release rate;
- thinned equal-weight samples for planning and recording (:meth:`SourceTermBelief.thin`,
  deterministic systematic selection, so a snapshot does not draw from the estimator's stream).
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.weights import normalise_log_weights
from odorloc.models.source_term import SourceTerms, ThetaLayout

__all__ = [
    "CredibleRegion",
    "SourceTermBelief",
    "layout_from_columns",
    "thin_indices",
    "weighted_quantiles",
]


def thin_indices(weights: np.ndarray, n: int) -> np.ndarray:
    """``n`` indices drawn systematically with the fixed offset 1/2: deterministic, each
    particle kept ``floor`` or ``ceil`` of ``n w_i`` times."""
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0
    pointers = (0.5 + np.arange(n)) / n
    return np.minimum(np.searchsorted(cdf, pointers, side="right"), len(weights) - 1)


def weighted_quantiles(x: np.ndarray, w: np.ndarray, qs: np.ndarray) -> np.ndarray:
    """Quantiles ``qs`` of values ``x`` with weights ``w`` (inverse of the weighted CDF)."""
    order = np.argsort(x)
    cdf = np.cumsum(w[order])
    cdf /= cdf[-1]
    idx = np.minimum(np.searchsorted(cdf, np.asarray(qs, float)), len(x) - 1)
    return x[order][idx]


def layout_from_columns(columns: list[str] | np.ndarray) -> ThetaLayout:
    """The :class:`ThetaLayout` whose :attr:`~ThetaLayout.columns` are ``columns``."""
    cols = [str(c) for c in columns]
    dim = 3 if ("z" in cols or "z0" in cols) else 2
    slots = sum(1 for c in cols if c.startswith("log_rate")) or 1
    lay = ThetaLayout(
        dim,
        slots,
        speed="speed" in cols,
        direction="direction" in cols,
        dispersion="log_dispersion" in cols,
        background="background" in cols,
    )
    if list(lay.columns) != cols:
        raise ConfigError("columns", f"not a source-term layout: {cols}")
    return lay


@dataclass(frozen=True)
class CredibleRegion:
    """A credible region of the source position and an interval of its release rate.

    Attributes
    ----------
    level : float
        Posterior probability inside (e.g. 0.95).
    sample : (n, d) ndarray, metres
        The equal-weight sample the region is built from.
    inside : (n,) bool ndarray
        Sample points inside the region.
    mean : (d,) ndarray, metres
        Posterior mean position.
    radius : float, metres
        Largest distance from ``mean`` of a sample point inside the region.
    rate : (2,) ndarray
        Equal-tailed interval of the release rate.
    """

    level: float
    sample: np.ndarray
    inside: np.ndarray
    mean: np.ndarray
    radius: float
    rate: np.ndarray
    precision: np.ndarray
    norm: float
    threshold: float

    def density(self, points: np.ndarray) -> np.ndarray:
        """Kernel density estimate at ``(m, d)`` points, 1/m^d."""
        p = np.atleast_2d(np.asarray(points, float))
        return _kde(p, self.sample, self.precision, self.norm)

    def contains(self, point: np.ndarray) -> bool:
        """Whether ``point`` ``(d,)`` lies in the region (its density reaches the level's)."""
        return bool(self.density(np.asarray(point, float)[None, :])[0] >= self.threshold)

    def contains_rate(self, rate: float) -> bool:
        """Whether ``rate`` lies in the rate interval."""
        return bool(self.rate[0] <= rate <= self.rate[1])


def _kde(points: np.ndarray, sample: np.ndarray, precision: np.ndarray, norm: float) -> np.ndarray:
    out = np.empty(len(points))
    step = max(1, (1 << 21) // max(1, len(sample)))
    for a in range(0, len(points), step):
        diff = points[a : a + step, None, :] - sample[None, :, :]
        q = np.einsum("mnd,de,mne->mn", diff, precision, diff)
        out[a : a + step] = np.exp(-0.5 * q).sum(axis=1) * norm
    return out


@dataclass(frozen=True, eq=False)
class SourceTermBelief(ParticleBelief):
    """Weighted particles over source terms (module docstring).

    Parameters
    ----------
    positions : (N, d) ndarray, metres
        First slot's positions.
    log_weights : (N,) ndarray
        Normalised.
    theta : (N, P) ndarray
        The source terms.
    layout : ThetaLayout
    snapshot_size : int
        Particles kept by :meth:`snapshot` (thinned, equal weights).
    """

    # keyword-only: the base's fields end with a default (``found_radius``)
    _: KW_ONLY
    theta: np.ndarray
    layout: ThetaLayout
    snapshot_size: int = 2000

    @staticmethod
    def of(
        theta: np.ndarray, log_weights: np.ndarray, layout: ThetaLayout, snapshot_size: int = 2000
    ) -> SourceTermBelief:
        """A belief over ``theta`` with (not necessarily normalised) ``log_weights``."""
        lw = normalise_log_weights(log_weights)[0]
        th = np.asarray(theta, float)
        return SourceTermBelief(
            th[:, layout.position_columns(0)],
            lw,
            theta=th,
            layout=layout,
            snapshot_size=snapshot_size,
        )

    @staticmethod
    def from_snapshot(snap: dict[str, np.ndarray]) -> SourceTermBelief:
        """The belief a :meth:`snapshot` recorded."""
        if "theta" not in snap or "theta_columns" not in snap:
            raise ConfigError("snapshot", "not a source-term belief snapshot")
        lay = layout_from_columns(list(np.asarray(snap["theta_columns"]).tolist()))
        w = np.asarray(snap["weights"], float)
        with np.errstate(divide="ignore"):
            return SourceTermBelief.of(np.asarray(snap["theta"], float), np.log(w), lay)

    @property
    def terms(self) -> SourceTerms:
        """The particles as :class:`~odorloc.models.source_term.SourceTerms`."""
        return SourceTerms(self.theta, self.layout)

    def theta_mean(self) -> np.ndarray:
        """Weighted mean of every column, ``(P,)`` (wind direction: the circular mean)."""
        w = self.weights
        m = w @ self.theta
        c = self.layout.column("direction")
        if c >= 0:
            phi = self.theta[:, c]
            m[c] = math.atan2(float(w @ np.sin(phi)), float(w @ np.cos(phi)))
        return m

    def thin(self, n: int) -> tuple[SourceTerms, np.ndarray]:
        """``n`` equal-weight particles (systematic, deterministic) and their log-weights."""
        idx = thin_indices(self.weights, n)
        return SourceTerms(self.theta[idx], self.layout), np.full(n, -math.log(n))

    def rate_interval(self, level: float = 0.95) -> np.ndarray:
        """Equal-tailed interval of the first slot's release rate, ``(2,)``."""
        lq = self.theta[:, self.layout.log_rate_column(0)]
        a = 0.5 * (1.0 - level)
        return np.exp(weighted_quantiles(lq, self.weights, np.array([a, 1.0 - a])))

    def credible_region(self, level: float = 0.95, n: int = 1000) -> CredibleRegion:
        """The ``level`` highest-density region of the first slot's position and the
        equal-tailed rate interval (module docstring), from ``n`` thinned particles."""
        if not 0.0 < level < 1.0:
            raise ConfigError("level", f"must be in (0, 1), got {level}")
        idx = thin_indices(self.weights, n)
        x = self.positions[idx]
        d = x.shape[1]
        cov = np.cov(x.T) if n > 1 else np.zeros((d, d))
        # Scott's rule; a floor keeps a collapsed cloud (all copies of one particle) usable
        h2 = n ** (-2.0 / (d + 4))
        band = h2 * cov + np.eye(d) * 1e-8 * max(1.0, float(np.trace(cov)))
        precision = np.linalg.inv(band)
        norm = 1.0 / (n * math.sqrt(np.linalg.det(2 * math.pi * band)))
        dens = _kde(x, x, precision, norm)
        threshold = float(np.quantile(dens, 1.0 - level))
        inside = dens >= threshold
        mean = self.weights @ self.positions
        radius = float(np.max(np.linalg.norm(x[inside] - mean, axis=1)))
        return CredibleRegion(
            float(level),
            x,
            inside,
            mean,
            radius,
            self.rate_interval(level),
            precision,
            norm,
            threshold,
        )

    def snapshot(self) -> dict[str, np.ndarray]:
        """Thinned arrays for recording: ``positions``, ``weights`` (equal), ``theta`` and
        ``theta_columns``."""
        n = min(self.snapshot_size, len(self.theta))
        idx = thin_indices(self.weights, n)
        th = self.theta[idx]
        return {
            "positions": th[:, self.layout.position_columns(0)].copy(),
            "weights": np.full(n, 1.0 / n),
            "theta": th.copy(),
            "theta_columns": np.array(self.layout.columns),
        }
