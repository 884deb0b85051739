"""Vergassola rate model: mean rate of odor-particle encounters (infotaxis).

A source releasing ``Q`` particles/s that live ``tau`` seconds, spread with an isotropic
effective diffusivity ``D`` and are advected by a mean wind of speed ``V`` along the unit vector
``e`` gives, at the relative position ``r = x - x_s`` of a sensor of radius ``a``:

2D (Vergassola et al. 2007, infotaxis)::

    R(r) = Q / ln(lambda / a) * exp(V (r . e) / (2 D)) * K0(|r| / lambda)

3D (eq. 1, muc-osl-multi-uav paper)::

    R(r) = a Q / |r| * exp(V (r . e) / (2 D)) * exp(-|r| / lambda)

with ``lambda = sqrt(D tau / (1 + V^2 tau / (4 D)))`` (eq. 2, muc-osl-multi-uav paper). The
multi-UAV paper writes the advection factor as ``exp(-(y_i - y_s) V / (2 D))``, i.e. a wind
blowing towards ``-y`` (``e = (0, -1, 0)``): odor is enhanced on the side the wind blows to.
Distances are floored at the sensor radius ``a`` (both forms diverge at the source).

Encounters in ``dt`` are Poisson with mean ``R dt`` (eq. 3, muc-osl-multi-uav paper).
:meth:`VergassolaPlume.concentration` returns the concentration whose diffusive absorption by the
sensor gives that rate (Smoluchowski): ``c = R / (4 pi D a)`` in 3D and
``c = R ln(lambda / a) / (2 pi D)`` in 2D.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gammaln, k0e, xlogy

from odorloc.errors import ConfigError
from odorloc.params import Params, Positive, Vector
from odorloc.plume.base import PlumeModel
from odorloc.registry import register
from odorloc.wind.base import WindModel
from odorloc.world.arena import Arena, as_points
from odorloc.world.sources import Source


class VergassolaParams(Params):
    """Parameters of :class:`VergassolaPlume` (defaults: multi-UAV paper's table).

    The release rate ``Q`` is each source's ``rate`` (the paper uses ``Q = 5``).

    Attributes
    ----------
    V : float or None, m/s
        Mean wind speed; ``None`` uses the speed of the wind model's spatial mean.
    D : float, m^2/s
        Isotropic effective diffusivity.
    tau : float, s
        Particle lifetime.
    sensor_radius : float, metres
        Sensor radius ``a`` (must be below ``lambda`` in 2D).
    wind_direction : (d,) tuple of float or None
        Direction the wind blows towards (normalised). ``None`` follows the wind model's spatial
        mean velocity (updated every step), falling back to ``-y`` (the paper's eq. 1) when the
        wind is calm.
    """

    V: Positive | None = 1.0
    D: Positive = 1.0
    tau: Positive = 100.0
    sensor_radius: Positive = 1.0
    wind_direction: Vector | None = None


def correlation_length(V: float, D: float, tau: float) -> float:
    """``lambda = sqrt(D tau / (1 + V^2 tau / (4 D)))``, metres (eq. 2, muc-osl-multi-uav)."""
    return float(np.sqrt(D * tau / (1.0 + V * V * tau / (4.0 * D))))


def vergassola_rate(
    sensor: ArrayLike,
    sources: ArrayLike,
    release: ArrayLike = 5.0,
    *,
    V: float = 1.0,
    D: float = 1.0,
    tau: float = 100.0,
    a: float = 1.0,
    direction: ArrayLike | None = None,
) -> np.ndarray:
    """Encounter rates for every (sensor position, source hypothesis) pair.

    Parameters
    ----------
    sensor : (Q, d) array_like, metres
        Sensor positions.
    sources : (N, d) array_like, metres
        Hypothesised source positions.
    release : float or (N,) array_like, particles/s
        Release rate ``Q`` of each hypothesis.
    V, D, tau, a : float
        Wind speed (m/s), diffusivity (m^2/s), lifetime (s), sensor radius (m).
    direction : (d,) array_like, optional
        Direction the wind blows towards; default ``-y`` (eq. 1, muc-osl-multi-uav).

    Returns
    -------
    (Q, N) ndarray, 1/s
    """
    x = np.asarray(sensor, float)
    s = np.asarray(sources, float)
    if x.ndim == 1:
        x = x[None, :]
    if s.ndim == 1:
        s = s[None, :]
    dim = x.shape[1]
    if dim not in (2, 3) or s.shape[1] != dim:
        raise ConfigError(
            "sources", f"sensor {x.shape} and sources {s.shape} need equal d in {{2, 3}}"
        )
    if direction is None:
        e = np.zeros(dim)
        e[1] = -1.0
    else:
        e = np.asarray(direction, float)
        n = float(np.linalg.norm(e))
        if e.shape != (dim,) or not n > 0:
            raise ConfigError("wind_direction", f"needs a non-zero {dim}-vector")
        e = e / n
    lam = correlation_length(V, D, tau)
    rel = x[:, None, :] - s[None, :, :]
    r = np.maximum(np.sqrt((rel**2).sum(axis=2)), a)
    along = rel @ e
    q = np.broadcast_to(np.asarray(release, float), (len(s),))
    if dim == 3:
        # Combined exponent avoids overflow of the two factors at long range.
        return (a * q) / r * np.exp(V * along / (2.0 * D) - r / lam)
    if lam <= a:
        raise ConfigError("sensor_radius", f"must be below lambda = {lam:.3g} m in 2D")
    z = r / lam
    # K0(z) = k0e(z) exp(-z): the scaled form keeps far-field values finite.
    return q / np.log(lam / a) * k0e(z) * np.exp(V * along / (2.0 * D) - z)


def poisson_log_likelihood(counts: ArrayLike, rates: np.ndarray, dt: float) -> np.ndarray:
    """Sum over sensors of ``log Poisson(counts | rates * dt)`` (eq. 3, muc-osl-multi-uav).

    Parameters
    ----------
    counts : (Q,) array_like of int
        Encounters counted at each sensor position during ``dt``.
    rates : (Q, N) ndarray, 1/s
        Encounter rates per sensor position and hypothesis.
    dt : float, seconds

    Returns
    -------
    (N,) ndarray
    """
    k = np.asarray(counts, float).reshape(-1, 1)
    if k.shape[0] != rates.shape[0]:
        raise ConfigError("counts", f"{k.shape[0]} counts for {rates.shape[0]} sensor positions")
    if np.any(k < 0):
        raise ConfigError("counts", "must be >= 0")
    mu = rates * dt
    return (xlogy(k, mu) - mu - gammaln(k + 1.0)).sum(axis=0)


@register("plume", "vergassola", VergassolaParams, "Vergassola rate model (infotaxis), 2D/3D")
class VergassolaPlume(PlumeModel):
    """Steady Vergassola rate model; :meth:`encounter_rate` is the rate ``R``.

    Several sources add their rates. ``rate_at`` and ``log_likelihood_poisson`` are the
    vectorised forms used by likelihood-based estimators (many source hypotheses at once).
    """

    def __init__(
        self,
        params: VergassolaParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        if params.wind_direction is not None and len(params.wind_direction) != self.dim:
            raise ConfigError("plume.wind_direction", f"needs {self.dim} components")
        self._src = self.source_positions
        self._sync()
        if self.dim == 2 and self.length <= params.sensor_radius:
            raise ConfigError(
                "plume.sensor_radius", f"must be below lambda = {self.length:.3g} m in 2D"
            )

    def _sync(self) -> None:
        p = self.params
        mean = self.wind.mean_velocity()
        speed = float(np.linalg.norm(mean))
        self.V = float(p.V) if p.V is not None else speed
        if p.wind_direction is not None:
            e = np.asarray(p.wind_direction, float)
        elif speed > 1e-12:
            e = mean
        else:
            e = np.zeros(self.dim)
            e[1] = -1.0
        self.direction = e / np.linalg.norm(e)
        self._q = self.source_rates()

    @property
    def length(self) -> float:
        """Correlation length ``lambda``, metres."""
        return correlation_length(self.V, self.params.D, self.params.tau)

    def rate_at(
        self, sensor_points: ArrayLike, source_hypotheses: ArrayLike, release: ArrayLike = 5.0
    ) -> np.ndarray:
        """Encounter rates ``(Q, N)`` for ``(Q, d)`` sensor points and ``(N, d)`` hypotheses.

        Uses this plume's ``V``, ``D``, ``tau``, ``a`` and wind direction; ``release`` is the
        hypothesised ``Q`` (scalar or ``(N,)``).
        """
        p = self.params
        return vergassola_rate(
            as_points(sensor_points, self.dim, "sensor_points"),
            as_points(source_hypotheses, self.dim, "source_hypotheses"),
            release,
            V=self.V,
            D=p.D,
            tau=p.tau,
            a=p.sensor_radius,
            direction=self.direction,
        )

    def log_likelihood_poisson(
        self,
        counts: ArrayLike,
        sensor_pos: ArrayLike,
        hypotheses: ArrayLike,
        dt: float,
        release: ArrayLike = 5.0,
    ) -> np.ndarray:
        """Log-likelihood ``(N,)`` of encounter ``counts`` ``(Q,)`` at ``(Q, d)`` sensor positions.

        Each count is Poisson with mean ``R dt`` (eq. 3, muc-osl-multi-uav paper); the sensors'
        log-probabilities are summed.
        """
        if not (np.isfinite(dt) and dt > 0):
            raise ConfigError("dt", f"must be a finite number > 0, got {dt}")
        return poisson_log_likelihood(counts, self.rate_at(sensor_pos, hypotheses, release), dt)

    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        p = self.params
        return vergassola_rate(
            points,
            self._src,
            self._q,
            V=self.V,
            D=p.D,
            tau=p.tau,
            a=p.sensor_radius,
            direction=self.direction,
        ).sum(axis=1)

    def _to_concentration(self, rate: np.ndarray) -> np.ndarray:
        p = self.params
        if self.dim == 3:
            return rate / (4.0 * np.pi * p.D * p.sensor_radius)
        return rate * np.log(self.length / p.sensor_radius) / (2.0 * np.pi * p.D)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return self._to_concentration(self._encounter_rate(points))

    def frame(self) -> dict[str, np.ndarray]:
        p = self.params
        return {
            "model": np.array("vergassola"),
            "src": self._src.copy(),
            "q": self._q.copy(),
            "V": np.array(self.V),
            "D": np.array(p.D),
            "tau": np.array(p.tau),
            "a": np.array(p.sensor_radius),
            "direction": self.direction.copy(),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        V, D, tau, a = (float(frame[k]) for k in ("V", "D", "tau", "a"))
        rate = vergassola_rate(
            points,
            np.asarray(frame["src"], float),
            np.asarray(frame["q"], float),
            V=V,
            D=D,
            tau=tau,
            a=a,
            direction=np.asarray(frame["direction"], float),
        ).sum(axis=1)
        if points.shape[1] == 3:
            return rate / (4.0 * np.pi * D * a)
        return rate * np.log(correlation_length(V, D, tau) / a) / (2.0 * np.pi * D)
