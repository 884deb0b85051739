"""Priors over a source term, one per component, in the coordinates the sampler moves.

The particle filter stores ``log(rate)`` and ``log(dispersion)`` rather than the values, and the
wind direction as an angle (rad, wrapped to ``(-pi, pi]``), so that a random walk needs no
bounds on them; the densities below are those of these coordinates (the Jacobians included):

- position: uniform over the free part of a box (the task's search region by default);
- release rate ``q``: log-uniform on ``[low, high]`` (uniform in ``log q``) or uniform (density
  ``q`` in ``log q``);
- wind speed: uniform, log-uniform or a normal truncated to ``[low, high]`` (and to ``> 0``);
- wind direction: von Mises ``exp(kappa cos(phi - mu)) / (2 pi I0(kappa))`` or uniform over an
  arc; ``mu`` may be ``"measured"``, the direction of the first measured wind;
- dispersion factor ``s``: log-uniform or uniform;
- background: uniform or a truncated normal;
- several sources: ``K_max`` slots, each with a position and a rate from the priors above and an
  activity flag; the number of active slots ``K`` is uniform on ``[K_min, K_max]`` or a Poisson
  law truncated to it, and every set of ``K`` slots is equally likely,
  ``p(a) = p(K) / C(K_max, K)``.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator
from scipy.special import gammaln, i0e, ndtr, ndtri

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, Params, Positive
from odorloc.geometry.arena import Arena
from odorloc.inference.particles.init import sample_free_uniform
from odorloc.models.source_term import ThetaLayout

__all__ = [
    "LogUniformPrior",
    "NormalPrior",
    "SourceTermPrior",
    "UniformPrior",
    "VonMisesPrior",
    "wrap_angle",
]


class _Interval(Params):
    """A prior on ``[low, high]``, ``low < high``."""

    low: float
    high: float

    @model_validator(mode="after")
    def _order(self) -> _Interval:
        if not self.high > self.low:
            raise ValueError(f"high ({self.high}) must exceed low ({self.low})")
        return self


class UniformPrior(_Interval):
    """Uniform on ``[low, high]`` (degrees for a wind direction)."""

    type: Literal["uniform"] = "uniform"
    low: Finite
    high: Finite


class LogUniformPrior(_Interval):
    """Log-uniform on ``[low, high]``, ``0 < low < high``."""

    type: Literal["log-uniform"] = "log-uniform"
    low: Positive
    high: Positive


class NormalPrior(Params):
    """Normal ``N(mean, std^2)`` truncated to ``[low, high]``; ``mean="measured"`` centres it
    on the first measured wind speed."""

    type: Literal["normal"] = "normal"
    mean: Finite | Literal["measured"] = "measured"
    std: Positive = 1.0
    low: Finite | None = None
    high: Finite | None = None


class VonMisesPrior(Params):
    """Von Mises over the direction the wind blows towards.

    Attributes
    ----------
    mean_deg : float or "measured"
        Mean direction, degrees counter-clockwise from +x; ``"measured"``: the first measured
        wind's.
    kappa : float
        Concentration (``1 / kappa`` is about the variance in rad^2 for large ``kappa``).
    """

    type: Literal["von-mises"] = "von-mises"
    mean_deg: Finite | Literal["measured"] = "measured"
    kappa: Positive = 8.0


RatePrior = Annotated[LogUniformPrior | UniformPrior, Field(discriminator="type")]
SpeedPrior = Annotated[UniformPrior | LogUniformPrior | NormalPrior, Field(discriminator="type")]
DirectionPrior = Annotated[VonMisesPrior | UniformPrior, Field(discriminator="type")]
FactorPrior = Annotated[LogUniformPrior | UniformPrior, Field(discriminator="type")]
BackgroundPrior = Annotated[UniformPrior | NormalPrior, Field(discriminator="type")]


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to ``(-pi, pi]``."""
    return np.pi - np.mod(np.pi - np.asarray(a, float), 2.0 * np.pi)


# ---------------------------------------------------------------------- 1-D pieces
class _Scalar:
    """Sampling and log-density of one component in its sampler coordinate.

    ``log_coord``: the coordinate is ``log v`` (rate, dispersion); ``positive``: ``v > 0``.
    """

    def __init__(
        self, spec: Params, log_coord: bool, centre: float | None, name: str, positive: bool
    ) -> None:
        self.spec = spec
        self.log_coord = log_coord
        self.name = name
        lo, hi = -math.inf, math.inf
        if isinstance(spec, UniformPrior | LogUniformPrior):
            lo, hi = spec.low, spec.high
        elif isinstance(spec, NormalPrior):
            lo = -math.inf if spec.low is None else spec.low
            hi = math.inf if spec.high is None else spec.high
        if positive or log_coord:
            lo = max(lo, 0.0)
        if log_coord and isinstance(spec, UniformPrior) and spec.low <= 0:
            raise ConfigError(name, "a rate or factor prior needs low > 0")
        self.lo, self.hi = lo, hi
        self.mean = 0.0
        if isinstance(spec, NormalPrior):
            if spec.mean == "measured":
                if centre is None:
                    raise ConfigError(f"{name}.mean", "'measured' needs a measured wind")
                self.mean = float(centre)
            else:
                self.mean = float(spec.mean)
            a, b = ndtr((lo - self.mean) / spec.std), ndtr((hi - self.mean) / spec.std)
            if not b - a > 1e-12:
                raise ConfigError(name, "the normal prior has no mass inside [low, high]")
            self._cdf = (float(a), float(b))

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        s = self.spec
        if isinstance(s, LogUniformPrior):
            v = np.exp(rng.uniform(math.log(s.low), math.log(s.high), n))
        elif isinstance(s, UniformPrior):
            v = rng.uniform(s.low, s.high, n)
        else:
            assert isinstance(s, NormalPrior)
            a, b = self._cdf
            v = self.mean + s.std * ndtri(a + (b - a) * rng.random(n))
            v = np.clip(v, self.lo, self.hi)
        return np.log(v) if self.log_coord else v

    def log_density(self, c: np.ndarray) -> np.ndarray:
        """Log-density of the coordinate ``c`` (``-inf`` outside the support)."""
        s = self.spec
        v = np.exp(c) if self.log_coord else c
        inside = (v >= self.lo) & (v <= self.hi)
        if isinstance(s, LogUniformPrior):
            # uniform in log v; in v the density is 1 / (v log(high/low))
            base = -math.log(math.log(s.high / s.low))
            out = np.full(c.shape, base) if self.log_coord else base - np.log(v)
        elif isinstance(s, UniformPrior):
            base = -math.log(s.high - s.low)
            out = base + c if self.log_coord else np.full(c.shape, base)
        else:
            assert isinstance(s, NormalPrior)
            a, b = self._cdf
            r = (v - self.mean) / s.std
            out = -0.5 * r * r - math.log(s.std * math.sqrt(2 * math.pi) * (b - a))
            if self.log_coord:
                out = out + c
        with np.errstate(invalid="ignore"):
            return np.where(inside, out, -np.inf)


class _Direction:
    """Wind direction (rad) under a von Mises or an arc-uniform prior."""

    def __init__(self, spec: Params, measured: float | None, name: str) -> None:
        self.spec = spec
        if isinstance(spec, VonMisesPrior):
            if spec.mean_deg == "measured":
                if measured is None:
                    raise ConfigError(f"{name}.mean_deg", "'measured' needs a measured wind")
                self.mu = float(measured)
            else:
                self.mu = math.radians(float(spec.mean_deg))
            k = spec.kappa
            # log(2 pi I0(k)) with the scaled Bessel function: I0(k) = i0e(k) exp(k)
            self.log_norm = math.log(2 * math.pi * float(i0e(k))) + k
        else:
            assert isinstance(spec, UniformPrior)
            if spec.high - spec.low > 360.0:
                raise ConfigError(name, "an arc wider than 360 degrees")
            self.lo = math.radians(spec.low)
            self.width = math.radians(spec.high - spec.low)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        s = self.spec
        if isinstance(s, VonMisesPrior):
            return wrap_angle(rng.vonmises(self.mu, s.kappa, n))
        return wrap_angle(self.lo + self.width * rng.random(n))

    def log_density(self, phi: np.ndarray) -> np.ndarray:
        s = self.spec
        if isinstance(s, VonMisesPrior):
            return s.kappa * np.cos(phi - self.mu) - self.log_norm
        off = np.mod(phi - self.lo, 2 * np.pi)
        inside = (off <= self.width) | (self.width >= 2 * np.pi - 1e-12)
        return np.where(inside, -math.log(self.width), -np.inf)


# ---------------------------------------------------------------------- the whole prior
class SourceTermPrior:
    """The prior of a source term: sampling and log-density of ``theta`` rows.

    Parameters
    ----------
    layout : ThetaLayout
    lower, upper : (d,) ndarray, metres
        Box of the source positions.
    arena : Arena or None
        Positions in obstacles are excluded.
    rate, wind_speed, wind_direction, dispersion, background : prior or None
        Component priors (``None``: the component is not in the layout).
    counts : (K_max + 1,) ndarray
        ``p(K)`` of the number of active slots (several slots only).
    wind : (d,) ndarray, m/s
        The first measured wind (for ``"measured"`` centres).
    """

    def __init__(
        self,
        layout: ThetaLayout,
        lower: np.ndarray,
        upper: np.ndarray,
        arena: Arena | None,
        rate: Params,
        wind_speed: Params | None,
        wind_direction: Params | None,
        dispersion: Params | None,
        background: Params | None,
        counts: np.ndarray,
        wind: np.ndarray,
    ) -> None:
        self.layout = layout
        self.lower = np.asarray(lower, float)
        self.upper = np.asarray(upper, float)
        if np.any(self.upper <= self.lower):
            raise ConfigError("estimator.region", "is empty (upper must exceed lower)")
        self.arena = arena
        w = np.asarray(wind, float)
        speed = float(np.hypot(w[0], w[1]))
        heading = math.atan2(w[1], w[0]) if speed > 0 else None
        self.rate = _Scalar(rate, True, None, "estimator.rate", True)
        self.speed = (
            _Scalar(wind_speed, False, speed, "estimator.wind_speed", True)
            if wind_speed is not None
            else None
        )
        self.direction = (
            _Direction(wind_direction, heading, "estimator.wind_direction")
            if wind_direction is not None
            else None
        )
        self.dispersion = (
            _Scalar(dispersion, True, None, "estimator.dispersion", True)
            if dispersion is not None
            else None
        )
        self.background = (
            _Scalar(background, False, None, "estimator.background", False)
            if background is not None
            else None
        )
        self.log_volume = float(np.sum(np.log(self.upper - self.lower)))
        kmax = layout.slots
        ks = np.arange(kmax + 1)
        with np.errstate(divide="ignore"):
            # log p(a) of one flag pattern with K active slots
            self.log_pattern = np.log(np.asarray(counts, float)) - (
                gammaln(kmax + 1) - gammaln(ks + 1) - gammaln(kmax - ks + 1)
            )
        self.counts = np.asarray(counts, float)

    # ------------------------------------------------------------------ slots
    def sample_positions(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``(n, d)`` uniform positions in the free part of the box."""
        if self.arena is None:
            return self.lower + rng.random((n, len(self.lower))) * (self.upper - self.lower)
        box = (self.lower, self.upper)
        return sample_free_uniform(self.arena, n, rng, box=box, field="estimator.region")

    def redraw_slot(
        self, theta: np.ndarray, rows: np.ndarray, k: int, rng: np.random.Generator
    ) -> None:
        """Draw slot ``k``'s position and rate of ``theta[rows]`` (row indices) from the prior,
        in place."""
        n = len(rows)
        if n == 0:
            return
        lay = self.layout
        start = k * lay.block
        cols = [*range(start, start + lay.dim), lay.log_rate_column(k)]
        block = np.column_stack([self.sample_positions(n, rng), self.rate.sample(n, rng)])
        theta[np.ix_(rows, cols)] = block

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``(n, P)`` draws of ``theta``."""
        lay = self.layout
        th = np.zeros((n, lay.n_columns))
        for k in range(lay.slots):
            self.redraw_slot(th, np.arange(n), k, rng)
        if lay.slots > 1:
            counts = rng.choice(lay.slots + 1, size=n, p=self.counts)
            order = np.argsort(rng.random((n, lay.slots)), axis=1)
            flags = order < counts[:, None]
            th[:, lay.active_start : lay.active_start + lay.slots] = flags
        for name, part in (
            ("speed", self.speed),
            ("direction", self.direction),
            ("log_dispersion", self.dispersion),
            ("background", self.background),
        ):
            c = lay.column(name)
            if c >= 0:
                assert part is not None
                th[:, c] = part.sample(n, rng)
        return th

    def log_density(self, theta: np.ndarray) -> np.ndarray:
        """``(n,)`` log prior density of ``theta`` rows (``-inf`` outside the support)."""
        lay = self.layout
        out = np.zeros(len(theta))
        for k in range(lay.slots):
            pos = theta[:, lay.position_columns(k)]
            inside = np.all((pos >= self.lower) & (pos <= self.upper), axis=1)
            if self.arena is not None and inside.any():
                inside[inside] = self.arena.is_free(pos[inside])
            out += np.where(inside, -self.log_volume, -np.inf)
            out += self.rate.log_density(theta[:, lay.log_rate_column(k)])
        if lay.slots > 1:
            count = np.rint(theta[:, lay.active_start : lay.active_start + lay.slots].sum(1))
            out += self.log_pattern[count.astype(np.int64)]
        for name, part in (
            ("speed", self.speed),
            ("direction", self.direction),
            ("log_dispersion", self.dispersion),
            ("background", self.background),
        ):
            c = lay.column(name)
            if c >= 0:
                assert part is not None
                out += part.log_density(theta[:, c])
        return out


def count_prior(
    k_min: int, k_max: int, law: Literal["uniform", "poisson"], mean: float
) -> np.ndarray:
    """``p(K)`` on ``0 .. k_max``, zero below ``k_min``: uniform, or Poisson(``mean``)
    truncated to ``[k_min, k_max]``."""
    ks = np.arange(k_max + 1)
    if law == "uniform":
        p = (ks >= k_min).astype(float)
    else:
        p = np.exp(ks * math.log(mean) - mean - gammaln(ks + 1)) * (ks >= k_min)
    return p / p.sum()
