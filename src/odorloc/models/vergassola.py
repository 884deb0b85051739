"""Vergassola rate model: mean rate of odor-particle encounters (infotaxis), 2D and 3D.

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

Encounters in ``dt`` are Poisson with mean ``R dt`` (eq. 3, muc-osl-multi-uav paper). The same
:func:`vergassola_rate` is the truth of :class:`~odorloc.plume.vergassola.VergassolaPlume` and
the belief of :class:`VergassolaModel`.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field
from scipy.special import cython_special, gammainc, gammaln, k0e

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive, Vector
from odorloc.core.registry import register
from odorloc.models import kernels
from odorloc.models.base import MeasurementModel
from odorloc.models.kernels import Backend
from odorloc.models.poisson import (
    censored_poisson,
    check_counts,
    check_n_classes,
    poisson_log_pmf,
)

__all__ = [
    "VergassolaModel",
    "VergassolaModelParams",
    "correlation_length",
    "vergassola_rate",
    "vergassola_rate_matrix",
]

_AQ_KEEP = 8
"""``a Q`` arrays a model keeps: a step's calls share a few hypothesis counts (the particles,
one centre), but the particle count and the release vary over an episode, and one entry per
value seen would grow without bound."""


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
    x, s, e, q = _rate_inputs(sensor, sources, release, direction)
    dim = x.shape[1]
    lam = correlation_length(V, D, tau)
    if dim == 3:
        expo, r = rate_exponent(x, s, e, V=V, D=D, lam=lam, a=a)
        return (a * q) * np.exp(expo) / r
    if lam <= a:
        raise ConfigError("sensor_radius", f"must be below lambda = {lam:.3g} m in 2D")
    r = floored_distances(x, s, a)
    along = (x @ e)[:, None] - (s @ e)[None, :]
    z = r / lam
    # K0(z) = k0e(z) exp(-z): the scaled form keeps far-field values finite.
    return q / np.log(lam / a) * k0e(z) * np.exp(V * along / (2.0 * D) - z)


def vergassola_rate_matrix(
    sensor: ArrayLike,
    sources: ArrayLike,
    release: ArrayLike,
    *,
    V: ArrayLike,
    D: ArrayLike,
    tau: ArrayLike,
    a: float,
    direction: ArrayLike,
) -> np.ndarray:
    """Encounter rates ``(M, N)`` when wind and dispersion differ between hypotheses.

    The same eqs. 1-2 (muc-osl-multi-uav paper; 2-D: Vergassola et al. 2007) as
    :func:`vergassola_rate`, with ``V``, ``D``, ``tau`` and the wind direction given per
    hypothesis (a source-term posterior over them).

    Parameters
    ----------
    sensor : (M, d) array_like, metres
    sources : (N, d) array_like, metres
    release : (N,) array_like, particles/s
    V, D, tau : float or (N,) array_like
        Wind speed (m/s), diffusivity (m^2/s), lifetime (s) of each hypothesis.
    a : float, metres
        Sensor radius.
    direction : (N, d) or (M, N, d) array_like
        Unit vector the wind blows towards, per hypothesis (or per reading and hypothesis).

    Raises
    ------
    ConfigError
        In 2-D when a hypothesis has ``lambda <= a`` (the 2-D rate needs ``lambda > a``).
    """
    x = np.atleast_2d(np.asarray(sensor, float))
    s = np.atleast_2d(np.asarray(sources, float))
    V_, D_, tau_ = (np.asarray(v, float) for v in (V, D, tau))
    lam = np.sqrt(D_ * tau_ / (1.0 + V_ * V_ * tau_ / (4.0 * D_)))
    rel = x[:, None, :] - s[None, :, :]
    r = np.maximum(np.sqrt((rel * rel).sum(axis=2)), a)
    along = (rel * np.asarray(direction, float)).sum(axis=-1)
    q = np.asarray(release, float)
    if x.shape[1] == 3:
        return (a * q) * np.exp(along * (V_ / (2.0 * D_)) - r / lam) / r
    if np.any(lam <= a):
        raise ConfigError("sensor_radius", "must be below lambda of every hypothesis in 2D")
    z = r / lam
    return q / np.log(lam / a) * k0e(z) * np.exp(V_ * along / (2.0 * D_) - z)


def _rate_inputs(
    sensor: ArrayLike, sources: ArrayLike, release: ArrayLike, direction: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Checked ``(Q, d)`` points, ``(N, d)`` sources, unit wind direction, release rates."""
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
    e = unit_direction(direction, dim)
    q = np.asarray(release, float)
    if q.ndim and q.shape != (len(s),):
        try:
            q = np.broadcast_to(q, (len(s),))
        except ValueError:
            raise ConfigError(
                "release", f"needs one rate or {len(s)} (one per source), got shape {q.shape}"
            ) from None
    return x, s, e, q


def unit_direction(direction: ArrayLike | None, dim: int) -> np.ndarray:
    """The unit vector the wind blows towards, ``(dim,)``; ``None`` is ``-y`` (eq. 1)."""
    if direction is None:
        e = np.zeros(dim)
        e[1] = -1.0
        return e
    e = np.asarray(direction, float)
    n = math.sqrt(float(e @ e)) if e.shape == (dim,) else 0.0
    if not n > 0:
        raise ConfigError("wind_direction", f"needs a non-zero {dim}-vector")
    return e / n


def floored_distances(x: np.ndarray, s: np.ndarray, a: float) -> np.ndarray:
    """``max(|x_q - s_n|, a)`` for ``(Q, d)`` points and ``(N, d)`` sources, ``(Q, N)`` metres."""
    if len(x) * len(s) <= 64:
        rel = x[:, None, :] - s[None, :, :]
        r2 = (rel * rel).sum(axis=2)
    else:
        # |x - s|^2 = |x|^2 + |s|^2 - 2 x.s: no (Q, N, d) array; the round-off (1e-12 m^2 at
        # 100 m coordinates) is far below the floor a^2
        r2 = x @ s.T
        r2 *= -2.0
        r2 += (x * x).sum(axis=1)[:, None]
        r2 += (s * s).sum(axis=1)[None, :]
    np.maximum(r2, a * a, out=r2)
    return np.sqrt(r2, out=r2)


def rate_exponent(
    x: np.ndarray, s: np.ndarray, e: np.ndarray, *, V: float, D: float, lam: float, a: float
) -> tuple[np.ndarray, np.ndarray]:
    """The exponent ``V (r . e) / (2 D) - |r| / lambda`` of the 3-D rate (eq. 1) and the floored
    distance ``|r|``, both ``(Q, N)``, for ``(Q, 3)`` points ``x``, ``(N, 3)`` sources ``s`` and
    the unit wind direction ``e`` (no input checks: :func:`vergassola_rate` makes them).

    The rate is ``a Q exp(exponent) / |r|``; one exponent keeps the two factors from
    overflowing at long range.
    """
    r = floored_distances(x, s, a)
    along = (x @ e)[:, None] - (s @ e)[None, :]
    expo = along * (V / (2.0 * D))
    expo -= r * (1.0 / lam)
    return expo, r


class VergassolaModelParams(Params):
    """Belief-side parameters of the rate model (defaults: the multi-UAV paper's table).

    Attributes
    ----------
    Q : float, particles/s
        Hypothesised release rate.
    V : float, m/s
        Mean wind speed.
    D : float, m^2/s
        Isotropic effective diffusivity.
    tau : float, s
        Particle lifetime.
    sensor_radius : float, metres
        Sensor radius ``a``.
    wind_direction : (d,) tuple of float, optional
        Direction the wind blows towards; ``None`` is ``-y`` (eq. 1, multi-UAV paper). A
        ``direction`` condition given at call time overrides it (e.g. the measured wind).
    max_classes : int
        Cap on the number of count classes used for planning (the last holds the tail).
    tail_mass : float
        Count classes are added until the tail beyond them holds less than this probability
        for every candidate and hypothesis (or ``max_classes`` is reached).
    backend : {"auto", "numpy", "numba"}
        How the 3-D likelihoods and outcome classes are computed: NumPy arrays, or the compiled
        loops of :mod:`odorloc.models.kernels` (the ``fast`` extra; the same numbers bit for
        bit, several times faster). ``auto`` compiles when numba is installed.
    """

    Q: Positive = 5.0
    V: Positive = 1.0
    D: Positive = 1.0
    tau: Positive = 100.0
    sensor_radius: Positive = 1.0
    wind_direction: Vector | None = None
    max_classes: int = Field(16, ge=2, le=256)
    tail_mass: float = Field(1e-6, gt=0.0, lt=1.0)
    backend: Backend = "auto"


@register("model", "vergassola", VergassolaModelParams, "Poisson encounters at the Vergassola rate")
class VergassolaModel(MeasurementModel):
    """Poisson encounter counts at the Vergassola rate (eqs. 1-3, multi-UAV paper).

    Conditions: ``dt`` (exposure, s; required), ``release`` (``Q`` per hypothesis, default the
    parameter), ``direction`` (unit vector the wind blows towards, default the parameter).
    """

    Params = VergassolaModelParams

    def __init__(self, params: VergassolaModelParams | None = None) -> None:
        self.params = params or VergassolaModelParams()
        self._compiled = kernels.compiled(self.params.backend)
        p = self.params
        # constants of the compiled path: V / (2 D), 1 / lambda, a^2 (as vergassola_rate has them)
        self._consts = (
            p.V / (2.0 * p.D),
            1.0 / correlation_length(p.V, p.D, p.tau),
            p.sensor_radius * p.sensor_radius,
        )
        # ``a Q`` per hypothesis for the common case of one release rate for all (by count),
        # the most recently used first to go last
        self._aq: OrderedDict[tuple[int, float], np.ndarray] = OrderedDict()
        # where the search for the class count starts (the last answer; see _classes_for)
        self._class_guess = 1

    @property
    def length(self) -> float:
        """Correlation length ``lambda``, metres (eq. 2)."""
        p = self.params
        return correlation_length(p.V, p.D, p.tau)

    def rate(
        self,
        sensor_positions: ArrayLike,
        hypotheses: ArrayLike,
        release: ArrayLike | None = None,
        direction: ArrayLike | None = None,
    ) -> np.ndarray:
        """Encounter rates ``(M, N)``, 1/s, for ``(M, d)`` sensor points, ``(N, d)`` hypotheses."""
        p = self.params
        return vergassola_rate(
            sensor_positions,
            hypotheses,
            p.Q if release is None else release,
            V=p.V,
            D=p.D,
            tau=p.tau,
            a=p.sensor_radius,
            direction=direction if direction is not None else p.wind_direction,
        )

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``log Poisson(z | R dt)`` for ``z`` encounters counted at one sensor position, ``(N,)``.

        ``sensor_position`` may also be ``(Q, d)`` with ``z`` ``(Q,)``: the log-probabilities of
        the sensors are summed.
        """
        dt = _exposure(conditions)
        sp = np.atleast_2d(np.asarray(sensor_position, float))
        k = np.asarray(z, float).reshape(-1, 1)
        if k.shape[0] != sp.shape[0]:
            raise ConfigError("counts", f"{k.shape[0]} counts for {sp.shape[0]} sensor positions")
        parts = self._kernel_parts(sp, hypotheses, conditions)
        if parts is not None:
            return _log_rows(parts, dt, k[:, 0]).sum(axis=0)
        mu = self.rate(sp, hypotheses, conditions.get("release"), conditions.get("direction"))
        return poisson_log_pmf(k, mu * dt).sum(axis=0)

    def log_likelihood_rows(
        self, z: Any, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``log Poisson(z_q | R(s_q) dt)`` of each count at its own position, ``(Q, N)``."""
        dt = _exposure(conditions)
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        k = np.asarray(z, float).reshape(-1, 1)
        if k.shape[0] != sp.shape[0]:
            raise ConfigError("counts", f"{k.shape[0]} counts for {sp.shape[0]} sensor positions")
        parts = self._kernel_parts(sp, hypotheses, conditions)
        if parts is not None:
            return _log_rows(parts, dt, k[:, 0])
        mu = self.rate(sp, hypotheses, conditions.get("release"), conditions.get("direction"))
        return poisson_log_pmf(k, mu * dt)

    def kernel_constants(self) -> tuple[float, float, float, float, np.ndarray] | None:
        """What compiled 3-D evaluations of eqs. 1-3 need, or ``None`` without the compiled
        backend: ``a Q`` (one release rate for every hypothesis), ``V / (2 D)`` (1/m),
        ``1 / lambda`` (1/m), ``a^2`` (m^2) and the model's unit wind direction ``(3,)``."""
        if not self._compiled:
            return None
        p = self.params
        if p.wind_direction is not None and np.size(p.wind_direction) != 3:
            return None
        adv, inv_lam, a2 = self._consts
        default = unit_direction(p.wind_direction, 3)
        return float(p.sensor_radius * p.Q), adv, inv_lam, a2, default

    def prepare_readings(
        self,
        z: Any,
        sensor_positions: np.ndarray,
        exponents: np.ndarray,
        record_conditions: Mapping[str, np.ndarray] | None = None,
        **conditions: Any,
    ) -> Any:
        """Readings with their own exposure ``dt`` ``(K,)`` and wind ``direction`` ``(K, d)``
        checked once (see :meth:`~odorloc.models.base.MeasurementModel.weighted_log_likelihood`):
        directions made unit (NaN rows: the shared ``direction``, else the model's), readings
        with exponent 0 left out. Other per-reading conditions take the base class's path."""
        per = dict(record_conditions or {})
        if set(per) - {"dt", "direction"}:
            return super().prepare_readings(z, sensor_positions, exponents, per, **conditions)
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        counts = np.asarray(z, float).reshape(-1)
        e = np.asarray(exponents, float).reshape(-1)
        dim = sp.shape[1]
        if not (len(counts) == len(sp) == len(e)) or dim not in (2, 3):
            raise ConfigError(
                "readings", f"{len(counts)} counts, positions {sp.shape}, {len(e)} exponents"
            )
        check_counts(counts)
        if np.any(~(e >= 0)):
            raise ConfigError("exponents", "must be >= 0")
        dts = _record_exposures(per.get("dt"), conditions, len(counts))
        dirs = self._record_directions(per.get("direction"), conditions, len(counts), dim)
        release = conditions.get("release")
        q = np.asarray(self.params.Q if release is None else release, float)
        if np.any(~(q >= 0)) or not np.all(np.isfinite(q)) or q.ndim > 1:
            raise ConfigError("release", "needs one rate >= 0 or one per source")
        keep = e > 0
        if not keep.all():
            counts, sp, e, dts, dirs = counts[keep], sp[keep], e[keep], dts[keep], dirs[keep]
        return _VergassolaReadings(
            np.ascontiguousarray(sp),
            np.ascontiguousarray(dirs),
            counts,
            gammaln(counts + 1.0),
            dts,
            e,
            q,
        )

    def prepared_log_likelihood(self, prepared: Any, hypotheses: np.ndarray) -> np.ndarray:
        """``sum_k e_k log Poisson(z_k | R(s_k) dt_k)``, ``(N,)``, of prepared readings.

        In 3-D with the compiled backend one pass of
        :func:`~odorloc.models.kernels.weighted_poisson_log_likelihood`; otherwise the NumPy
        evaluation :meth:`_weighted_log_likelihood_numpy`, its reference (the two agree within
        round-off).
        """
        if not isinstance(prepared, _VergassolaReadings):
            return super().prepared_log_likelihood(prepared, hypotheses)
        r = prepared
        x = np.ascontiguousarray(hypotheses, dtype=float)
        if x.ndim != 2 or x.shape[1] != r.positions.shape[1]:
            raise ConfigError(
                "hypotheses", f"expected (N, {r.positions.shape[1]}) points, got {x.shape}"
            )
        q = r.release if r.release.ndim == 0 else r.release.reshape(-1)
        if q.ndim and len(q) != len(x):
            raise ConfigError("release", f"needs one rate or {len(x)} (one per source)")
        if self._compiled and x.shape[1] == 3:
            p = self.params
            a = float(p.sensor_radius)
            aq = np.full(len(x), a * float(q)) if q.ndim == 0 else np.ascontiguousarray(a * q)
            out = kernels.weighted_poisson_log_likelihood(
                x,
                r.positions,
                r.directions,
                r.counts,
                r.log_fact,
                r.dts,
                r.exponents,
                aq,
                p.V / (2.0 * p.D),
                1.0 / self.length,
                a * a,
            )
        else:
            out = self._weighted_log_likelihood_numpy(
                x,
                r.positions,
                r.directions,
                r.counts,
                r.dts,
                r.exponents,
                np.broadcast_to(q, (len(x),)),
            )
        total = out.sum()
        # -inf is allowed (a reading impossible under a hypothesis), NaN and +inf are not
        if total != total or total == np.inf:
            raise ConfigError("expected_counts", "must be finite and >= 0")
        return out

    def _weighted_log_likelihood_numpy(
        self,
        x: np.ndarray,
        sp: np.ndarray,
        dirs: np.ndarray,
        counts: np.ndarray,
        dts: np.ndarray,
        e: np.ndarray,
        q: np.ndarray,
    ) -> np.ndarray:
        """The NumPy reference of :meth:`weighted_log_likelihood` (either dimension)."""
        p = self.params
        lam = self.length
        a = float(p.sensor_radius)
        rel = sp[:, None, :] - x[None, :, :]  # (K, N, d)
        r = np.sqrt(np.maximum((rel * rel).sum(axis=2), a * a))
        along = np.einsum("knd,kd->kn", rel, dirs)
        expo = along * (p.V / (2.0 * p.D)) - r / lam
        with np.errstate(divide="ignore"):
            if x.shape[1] == 3:
                # eq. 1: a Q exp(...) / |r|, times the exposure
                log_mu = np.log(dts[:, None] * a * q[None, :]) + expo - np.log(r)
            else:
                # 2-D: Q / ln(lambda / a) K0(|r| / lambda) exp(V (r . e) / (2 D))
                log_mu = (
                    np.log(dts[:, None] * q[None, :] / math.log(lam / a))
                    + np.log(k0e(r / lam))
                    + expo
                )
        mu = np.exp(log_mu)
        c = counts[:, None]
        ll = np.where(c > 0, c * log_mu, 0.0) - mu - gammaln(c + 1.0)
        return e @ ll if len(e) else np.zeros(len(x))

    def _record_directions(
        self, given: np.ndarray | None, conditions: dict[str, Any], k: int, dim: int
    ) -> np.ndarray:
        """Unit wind directions of ``k`` readings ``(k, dim)``; NaN rows take the default (the
        shared ``direction`` condition, else the model's)."""
        default = conditions.get("direction")
        base = unit_direction(default if default is not None else self.params.wind_direction, dim)
        if given is None:
            return np.broadcast_to(base, (k, dim)).copy()
        g = np.asarray(given, float).reshape(k, dim).copy()
        missing = np.isnan(g).all(axis=1)
        g[missing] = base
        norm = np.sqrt((g * g).sum(axis=1))
        if not np.all(norm > 0) or not np.all(np.isfinite(norm)):
            raise ConfigError("wind_direction", f"needs non-zero {dim}-vectors")
        return g / norm[:, None]

    def n_classes(self, mean: np.ndarray | float) -> int:
        """Count classes needed so that the tail beyond holds < ``tail_mass`` (capped), for
        expected counts ``mean`` (any shape; a float: their maximum)."""
        if type(mean) is float:
            return self._classes_for(mean)
        return self._classes_for(float(np.max(mean)) if np.size(mean) else 0.0)

    def _classes_for(self, m: float) -> int:
        p = self.params
        # tail of class n - 1 is P(d >= n - 1) = gammainc(n - 1, m), decreasing in n: the first
        # n in 1 .. max_classes - 1 with a small enough tail. Consecutive decisions ask about
        # similar means, so the search starts at the last answer and walks to the first such
        # n (the n a scan from 1 finds: the tails are monotone), one call per step.
        tail, top = p.tail_mass, p.max_classes
        # the scalar form of scipy's gammainc (the same C function as the ufunc, without a
        # ufunc call's overhead per number)
        inc = cython_special.gammainc
        n = min(self._class_guess, top - 1)
        if inc(n, m) < tail:
            while n > 1 and inc(n - 1, m) < tail:
                n -= 1
        else:
            n += 1
            while n < top and not inc(n, m) < tail:
                n += 1
            if n == top:
                return top
        self._class_guess = n
        return n + 1

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """Probabilities of ``0, 1, ..., Z-2`` and ``>= Z-1`` encounters, ``(M, Z, N)``.

        ``Z`` is chosen by :meth:`n_classes` unless the condition ``n_classes`` fixes it.
        """
        mu, neg, top, z = self._class_means(sensor_positions, hypotheses, conditions)
        if neg is not None and z >= 2 and not top > 600.0:
            out, rest, any_rest = kernels.censored_classes(mu, np.exp(neg), z)
            if any_rest:
                out[:, -1, :][rest] = np.maximum(gammainc(z - 1, mu[rest]), 0.0)
            return out
        # C order (M, Z, N): planners reduce over the last axis and reshape freely
        return np.ascontiguousarray(np.moveaxis(censored_poisson(mu, z), -1, 1))

    def poisson_outcomes(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> tuple[np.ndarray, int]:
        """Expected counts ``R dt`` ``(M, N)`` and the class count ``Z`` of
        :meth:`outcome_probabilities` (eq. 3: its classes are Poisson counts of these means).

        In 3-D with the compiled backend the means are one pass of
        :func:`~odorloc.models.kernels.rate_means_direct` (the C library's ``exp``: equal to the
        NumPy means within round-off, not to the bit).
        """
        fixed = conditions.get("n_classes")
        z = None if fixed is None else check_n_classes(fixed)
        dt = _exposure(conditions)
        if self._compiled:
            p = self.params
            x, s, e, q = self._inputs(sensor_positions, hypotheses, conditions)
            if x.shape[1] == 3:
                a = float(p.sensor_radius)
                aq = np.full(len(s), a * float(q)) if q.ndim == 0 else a * q
                mu, top = kernels.rate_means_direct(
                    np.ascontiguousarray(x),
                    np.ascontiguousarray(s),
                    e,
                    np.ascontiguousarray(aq, dtype=float),
                    dt,
                    p.V / (2.0 * p.D),
                    1.0 / self.length,
                    a * a,
                )
                if mu.size and not (top < math.inf and mu.min() >= 0.0):
                    raise ConfigError("expected_counts", "must be finite and >= 0")
                return mu, self._classes_for(top if mu.size else 0.0) if z is None else z
        mu, _, _, zz = self._class_means(sensor_positions, hypotheses, conditions)
        return mu, zz

    def outcome_values(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """Count of each class, ``(Z,)`` (the last class stands for its lower bound).

        ``Z`` is the number of classes :meth:`outcome_probabilities` gives for the same
        arguments: unless the condition ``n_classes`` fixes it, it depends on the means.
        """
        return np.arange(self._class_means(sensor_positions, hypotheses, conditions)[3])

    def _class_means(
        self, sensor_positions: ArrayLike, hypotheses: ArrayLike, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray | None, float, int]:
        """Expected counts ``R dt`` ``(M, N)``, their negatives (compiled path only, else
        ``None``), their maximum, and the number of count classes ``Z``.

        Raises :class:`ConfigError` (``expected_counts``) for a negative or non-finite mean (a
        negative release rate, a NaN position), as :func:`censored_poisson` does, and
        (``n_classes``) for a fixed class count that is not an integer in ``[2, MAX_CLASSES]``.
        """
        fixed = conditions.get("n_classes")
        # checked here, not only by censored_poisson: outcome_values and the compiled path
        # would otherwise take 0 for "choose", -3 for no class, 2.7 for 2 or 10**9 as given
        z = None if fixed is None else check_n_classes(fixed)
        dt = _exposure(conditions)
        parts = self._kernel_parts(sensor_positions, hypotheses, conditions)
        neg: np.ndarray | None = None
        if parts is not None:
            mu, neg, top = kernels.rate_means(*parts, dt)
        else:
            mu = dt * self.rate(
                sensor_positions, hypotheses, conditions.get("release"), conditions.get("direction")
            )
            top = float(np.max(mu)) if mu.size else 0.0
        if mu.size:
            # one reduction: the minimum is NaN if any mean is, and the kernel's maximum skips
            # NaN but not +inf
            if not (top < math.inf and mu.min() >= 0.0):
                raise ConfigError("expected_counts", "must be finite and >= 0")
        else:
            top = 0.0
        return mu, neg, top, self._classes_for(top) if z is None else z

    def _inputs(
        self, sensor_positions: ArrayLike, hypotheses: ArrayLike, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Checked points, hypotheses, unit wind direction and release rates of a call: the
        ``release`` and ``direction`` conditions, else the model's."""
        p = self.params
        release = conditions.get("release")
        direction = conditions.get("direction")
        return _rate_inputs(
            sensor_positions,
            hypotheses,
            p.Q if release is None else release,
            direction if direction is not None else p.wind_direction,
        )

    def _kernel_parts(
        self, sensor_positions: ArrayLike, hypotheses: ArrayLike, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """``exp(exponent)``, floored distances ``(Q, N)`` and ``a Q`` ``(N,)`` for the compiled
        path (``None`` in 2-D or without it): what :func:`vergassola_rate` computes, with the
        same BLAS and ``exp`` calls, and the element-wise rest in one compiled loop."""
        if not self._compiled:
            return None
        p = self.params
        x, s, e, q = self._inputs(sensor_positions, hypotheses, conditions)
        if x.shape[1] != 3:
            return None
        adv, inv_lam, a2 = self._consts
        xe, se = x @ e, s @ e
        xc, sc = np.ascontiguousarray(x), np.ascontiguousarray(s)
        if len(x) * len(s) <= 64:
            expo, r = kernels.rate_exponent_direct(xc, sc, xe, se, adv, inv_lam, a2)
        else:
            expo, r = kernels.rate_exponent_gram(x @ s.T, xc, sc, xe, se, adv, inv_lam, a2)
        if q.ndim == 0:
            key = (len(s), float(q))
            aq = self._aq.get(key)
            if aq is None:
                # shared between calls: the kernels only read it
                aq = self._aq[key] = np.full(len(s), float(p.sensor_radius * q))
                if len(self._aq) > _AQ_KEEP:
                    self._aq.popitem(last=False)
            else:
                self._aq.move_to_end(key)
        else:
            aq = np.ascontiguousarray(p.sensor_radius * q, dtype=float)
        return np.exp(expo), r, aq


def _log_rows(
    parts: tuple[np.ndarray, np.ndarray, np.ndarray], dt: float, counts: np.ndarray
) -> np.ndarray:
    """The compiled :func:`poisson_log_pmf` of ``counts`` ``(Q,)`` at the kernel parts."""
    check_counts(counts)
    ll, valid = kernels.poisson_log_rows(*parts, dt, counts, gammaln(counts + 1.0))
    if not valid:
        raise ConfigError("expected_counts", "must be finite and >= 0")
    return ll


class _VergassolaReadings:
    """Readings checked by :meth:`VergassolaModel.prepare_readings` (exponent-0 ones left out)."""

    __slots__ = ("counts", "directions", "dts", "exponents", "log_fact", "positions", "release")

    def __init__(
        self,
        positions: np.ndarray,
        directions: np.ndarray,
        counts: np.ndarray,
        log_fact: np.ndarray,
        dts: np.ndarray,
        exponents: np.ndarray,
        release: np.ndarray,
    ) -> None:
        self.positions = positions
        self.directions = directions
        self.counts = counts
        self.log_fact = log_fact
        self.dts = dts
        self.exponents = exponents
        self.release = release


def _record_exposures(given: np.ndarray | None, conditions: dict[str, Any], k: int) -> np.ndarray:
    """Exposures of ``k`` readings ``(k,)``, seconds: ``given`` with NaN for the shared ``dt``."""
    if given is None:
        return np.full(k, _exposure(conditions))
    dts = np.asarray(given, float).reshape(k).copy()
    missing = np.isnan(dts)
    if missing.any():
        dts[missing] = _exposure(conditions)
    if not (np.all(np.isfinite(dts)) and np.all(dts > 0)):
        raise ConfigError("dt", "the exposure time must be a finite number > 0")
    return dts


def _exposure(conditions: dict[str, Any]) -> float:
    dt = conditions.get("dt")
    if dt is None or not (np.isfinite(dt) and dt > 0):
        raise ConfigError("dt", f"the exposure time must be a finite number > 0, got {dt}")
    return float(dt)
