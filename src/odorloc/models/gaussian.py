"""Steady Gaussian plume model (the time-averaged plume of the indoor particle-filter paper).

For a source of rate ``Q`` in a wind of speed ``u`` blowing along the unit vector ``e``, with
downwind distance ``x = (p - s) . e > 0``, horizontal cross-wind offset ``y`` and height offset
``z`` (3D), the concentration is (the Gaussian plume of eq. 3, indoor-pf-entropy paper)::

    C = Q / (2 pi sigma_y sigma_z u) * exp(-y^2 / (2 sigma_y^2)) * Z(z)

and ``0`` upwind (``x <= 0``). In 2D the plane through the source height is modelled, so
``Z = 1`` (this is the paper's formula exactly). In 3D ``Z = exp(-z^2 / (2 sigma_z^2))`` plus,
with ground reflection, the image term ``exp(-(z_s + z_r - 2 z_g)^2 / (2 sigma_z^2))`` for a
ground at the arena floor ``z_g``. Several sources superpose.

The widths grow downwind by eddy diffusion (``spread="diffusion"``,
``sigma^2 = sigma0^2 + 2 K x / u``), by a user-given power law (``spread="power"``,
``sigma^2 = sigma0^2 + (a x^b)^2``) or by the Pasquill-Gifford curves of a stability class
(``spread="pasquill-gifford"``, ``sigma^2 = sigma0^2 + sigma_PG(x)^2``) in the interpolation
formulas of Briggs (1973) for open country and for urban terrain::

    rural   sigma_y = a_y x (1 + 1e-4 x)^(-1/2)            a_y = .22 .16 .11 .08 .06 .04 (A-F)
            sigma_z = .20 x, .12 x, .08 x (1 + 2e-4 x)^(-1/2), .06 x (1 + 1.5e-3 x)^(-1/2),
                      .03 x (1 + 3e-4 x)^(-1), .016 x (1 + 3e-4 x)^(-1)               (A-F)
    urban   sigma_y = a_y x (1 + 4e-4 x)^(-1/2)            a_y = .32 .32 .22 .16 .11 .11 (A-F)
            sigma_z = .24 x (1 + 1e-3 x)^(1/2) (A, B), .20 x (C), .14 x (1 + 3e-4 x)^(-1/2) (D),
                      .08 x (1 + 1.5e-3 x)^(-1/2) (E, F)

(``x`` downwind, metres). ``sigma0`` keeps the plume finite at the source. An estimator may
scale the widths by a dispersion factor ``s`` per hypothesis (``sigma^2 = sigma0^2 + s^2
sigma_law(x)^2``, :func:`gaussian_plume_matrix`), the source-term estimator's dispersion
parameter.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field
from scipy.special import log_ndtr, ndtr

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.models.base import MeasurementModel

__all__ = [
    "PG_RURAL",
    "PG_URBAN",
    "GaussianParams",
    "GaussianPlumeModel",
    "GaussianReadingParams",
    "gaussian_concentration",
    "gaussian_plume",
    "gaussian_plume_matrix",
    "plume_widths",
]

#: Briggs (1973) coefficients per Pasquill stability class, open country: ``(a_y, b_y, a_z, b_z,
#: p_z)`` with ``sigma_y = a_y x (1 + b_y x)^(-1/2)`` and ``sigma_z = a_z x (1 + b_z x)^(p_z)``.
PG_RURAL: dict[str, tuple[float, float, float, float, float]] = {
    "A": (0.22, 1e-4, 0.20, 0.0, 0.0),
    "B": (0.16, 1e-4, 0.12, 0.0, 0.0),
    "C": (0.11, 1e-4, 0.08, 2e-4, -0.5),
    "D": (0.08, 1e-4, 0.06, 1.5e-3, -0.5),
    "E": (0.06, 1e-4, 0.03, 3e-4, -1.0),
    "F": (0.04, 1e-4, 0.016, 3e-4, -1.0),
}
#: The same for urban terrain (Briggs 1973).
PG_URBAN: dict[str, tuple[float, float, float, float, float]] = {
    "A": (0.32, 4e-4, 0.24, 1e-3, 0.5),
    "B": (0.32, 4e-4, 0.24, 1e-3, 0.5),
    "C": (0.22, 4e-4, 0.20, 0.0, 0.0),
    "D": (0.16, 4e-4, 0.14, 3e-4, -0.5),
    "E": (0.11, 4e-4, 0.08, 1.5e-3, -0.5),
    "F": (0.11, 4e-4, 0.08, 1.5e-3, -0.5),
}


class GaussianParams(Params):
    """Parameters of :class:`GaussianPlume`.

    Attributes
    ----------
    spread : "diffusion" | "power" | "pasquill-gifford"
        Width law (see module docstring).
    sigma0 : float, metres
        Width at the source.
    K : float, m^2/s
        Eddy diffusivity (``spread="diffusion"``), cross-wind and vertical.
    a_y, b_y, a_z, b_z : float
        Power-law coefficients (``spread="power"``), ``sigma = a x^b`` with ``x`` in metres.
    stability : "A" .. "F"
        Pasquill stability class (``spread="pasquill-gifford"``): A very unstable, D neutral,
        F moderately stable.
    terrain : "rural" | "urban"
        Which of Briggs' two sets of curves (``spread="pasquill-gifford"``).
    min_speed : float, m/s
        Wind speeds below this are raised to it (the formula diverges as ``u -> 0``).
    ground_reflection : bool
        3D only: add the image source below the arena floor.
    """

    spread: Literal["diffusion", "power", "pasquill-gifford"] = "diffusion"
    sigma0: Positive = 0.1
    K: Positive = 0.05
    a_y: Positive = 0.2
    b_y: Positive = 0.9
    a_z: Positive = 0.12
    b_z: Positive = 0.85
    stability: Literal["A", "B", "C", "D", "E", "F"] = "D"
    terrain: Literal["rural", "urban"] = "rural"
    min_speed: Positive = 0.05
    ground_reflection: bool = True


def gaussian_plume(
    points: np.ndarray,
    src: np.ndarray,
    rates: np.ndarray,
    winds: np.ndarray,
    params: GaussianParams,
    ground: float = 0.0,
) -> np.ndarray:
    """Steady Gaussian-plume concentration of several sources, summed.

    Parameters
    ----------
    points : (Q, d) ndarray, metres
    src : (S, d) ndarray, metres
        Source positions.
    rates : (S,) ndarray
        Release rates ``Q`` (amount/s).
    winds : (S, d) ndarray, m/s
        Wind velocity at each source; its horizontal part sets the downwind direction and speed.
    params : GaussianParams
    ground : float, metres
        Floor height for the 3D reflection term.

    Returns
    -------
    (Q,) ndarray
        Concentration (amount per m^3; in 2D the source-height plane).
    """
    out = np.zeros(len(points))
    for c in _per_source(points, src, rates, winds, params, ground):
        out += c
    return out


def gaussian_concentration(
    points: np.ndarray,
    src: np.ndarray,
    rates: np.ndarray,
    winds: np.ndarray,
    params: GaussianParams,
    ground: float = 0.0,
) -> np.ndarray:
    """Concentration of each source separately, ``(Q, S)`` (same arguments as
    :func:`gaussian_plume`); what an estimator evaluates over source hypotheses."""
    out = np.zeros((len(points), len(src)))
    for k, c in enumerate(_per_source(points, src, rates, winds, params, ground)):
        out[:, k] = c
    return out


def plume_widths(
    xd: np.ndarray, u: np.ndarray | float, params: GaussianParams, scale: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Squared plume widths ``(sigma_y^2, sigma_z^2)`` at downwind distances ``xd`` (m).

    Parameters
    ----------
    xd : ndarray, metres
        Downwind distances (``>= 0``; upwind points pass ``0``).
    u : float or ndarray, m/s
        Wind speed (broadcast against ``xd``; used by ``spread="diffusion"``).
    params : GaussianParams
        The width law (module docstring).
    scale : ndarray, optional
        Dispersion factor ``s`` of each entry: the law's growth term is multiplied by ``s^2``.

    Returns
    -------
    sy2, sz2 : ndarray, m^2
    """
    p = params
    if p.spread == "diffusion":
        grow = 2.0 * p.K * xd / u
        if scale is not None:
            grow = grow * (scale * scale)
        sy2 = p.sigma0**2 + grow
        return sy2, sy2
    if p.spread == "power":
        gy = (p.a_y * xd**p.b_y) ** 2
        gz = (p.a_z * xd**p.b_z) ** 2
    else:
        ay, by, az, bz, pz = (PG_RURAL if p.terrain == "rural" else PG_URBAN)[p.stability]
        gy = (ay * xd) ** 2 / (1.0 + by * xd)
        gz = (az * xd) ** 2 * (1.0 + bz * xd) ** (2.0 * pz)
    if scale is not None:
        s2 = scale * scale
        gy, gz = gy * s2, gz * s2
    return p.sigma0**2 + gy, p.sigma0**2 + gz


def _plume_block(
    rel: np.ndarray,
    q: np.ndarray | float,
    u: np.ndarray | float,
    e: np.ndarray,
    params: GaussianParams,
    zr: np.ndarray | None,
    zs: np.ndarray | float,
    ground: float,
    scale: np.ndarray | None = None,
) -> np.ndarray:
    """Concentration of sources at ``rel = point - source`` (``(..., d)``), the Gaussian plume
    of eq. 3 (indoor-pf-entropy paper) with the widths of :func:`plume_widths`.

    ``e`` (``(..., 2)`` or ``(2,)``) is the unit downwind vector, ``u`` the speed (already
    raised to ``min_speed``), ``zr``/``zs`` receptor and source heights (3-D only).
    """
    p = params
    x = rel[..., 0] * e[..., 0] + rel[..., 1] * e[..., 1]
    y = -rel[..., 0] * e[..., 1] + rel[..., 1] * e[..., 0]
    down = x > 0
    xd = np.where(down, x, 0.0)
    sy2, sz2 = plume_widths(xd, u, p, scale)
    c = q / (2.0 * np.pi * np.sqrt(sy2 * sz2) * u) * np.exp(-0.5 * y**2 / sy2)
    if zr is not None:
        zt = np.exp(-0.5 * (zr - zs) ** 2 / sz2)
        if p.ground_reflection:
            zt = zt + np.exp(-0.5 * (zr + zs - 2.0 * ground) ** 2 / sz2)
        c = c * zt
    return np.where(down, c, 0.0)


def _per_source(
    points: np.ndarray,
    src: np.ndarray,
    rates: np.ndarray,
    winds: np.ndarray,
    params: GaussianParams,
    ground: float,
):  # type: ignore[no-untyped-def]
    dim = points.shape[1]
    p = params
    for s, q, w in zip(src, rates, winds, strict=True):
        horiz = np.array(w[:2], float)
        u = float(np.hypot(*horiz))
        e = horiz / u if u > 0 else np.array([1.0, 0.0])
        u = max(u, p.min_speed)
        zr = points[:, 2] if dim == 3 else None
        yield _plume_block(points - s, q, u, e, p, zr, s[2] if dim == 3 else 0.0, ground)


def gaussian_plume_matrix(
    points: np.ndarray,
    src: np.ndarray,
    rates: np.ndarray,
    speed: np.ndarray,
    direction: np.ndarray,
    params: GaussianParams,
    ground: float = 0.0,
    scale: np.ndarray | None = None,
) -> np.ndarray:
    """Concentration of each of ``N`` source hypotheses at each of ``M`` points, ``(M, N)``.

    Unlike :func:`gaussian_concentration` the wind and the dispersion may differ between
    hypotheses (a source-term posterior over wind speed, direction and dispersion).

    Parameters
    ----------
    points : (M, d) ndarray, metres
    src : (N, d) ndarray, metres
    rates : (N,) ndarray
        Release rates ``Q``.
    speed : (N,) or (M, N) ndarray, m/s
        Wind speed of each hypothesis (or of each point and hypothesis: a measured wind that
        changed between readings); raised to ``params.min_speed``.
    direction : (N, 2) or (M, N, 2) ndarray
        Unit horizontal vector the wind blows towards.
    params : GaussianParams
    ground : float, metres
        Floor height (3-D reflection).
    scale : (N,) ndarray, optional
        Dispersion factor of each hypothesis (:func:`plume_widths`).
    """
    pts = np.atleast_2d(np.asarray(points, float))
    s = np.atleast_2d(np.asarray(src, float))
    rel = pts[:, None, :] - s[None, :, :]
    u = np.maximum(np.asarray(speed, float), params.min_speed)
    e = np.asarray(direction, float)
    zr = pts[:, 2][:, None] if pts.shape[1] == 3 else None
    zs = s[:, 2][None, :] if pts.shape[1] == 3 else 0.0
    return _plume_block(rel, np.asarray(rates, float), u, e, params, zr, zs, ground, scale)


class GaussianReadingParams(GaussianParams):
    """The Gaussian plume as a measurement model of an estimator.

    Attributes
    ----------
    release : float
        Hypothesised release rate ``Q`` (amount/s).
    noise_std : float
        Standard deviation of the reading around the predicted concentration (reading units).
    gain : float
        Reading units per concentration unit.
    threshold : float
        Detection threshold for binary readings (reading units).
    ground : float, metres
        Floor height for the 3D reflection term.
    """

    release: Positive = 1.0
    noise_std: Positive = 0.1
    gain: Finite = 1.0
    threshold: NonNegative = 1.0
    ground: float = Field(0.0, allow_inf_nan=False)


@register("model", "gaussian", GaussianReadingParams, "steady Gaussian plume, noisy readings")
class GaussianPlumeModel(MeasurementModel):
    """Readings ``z = gain C(s | x) + noise`` around the steady Gaussian plume of a source at ``x``.

    Conditions: ``wind`` ``(d,)`` m/s (the mean wind; required) and optionally ``release`` (one
    rate, or one per hypothesis).
    :meth:`log_likelihood` takes an analogue reading (Gaussian noise) or a bool (detection:
    ``p(z=1) = Phi((gain C - threshold) / noise_std)``); :meth:`outcome_probabilities` gives the
    two detection classes.
    """

    Params = GaussianReadingParams

    def __init__(self, params: GaussianReadingParams | None = None) -> None:
        self.params = params or GaussianReadingParams()

    def predict(
        self,
        sensor_positions: np.ndarray,
        hypotheses: np.ndarray,
        wind: np.ndarray,
        release: float | np.ndarray | None = None,
    ) -> np.ndarray:
        """Expected reading ``gain C`` at ``(M, d)`` positions for ``(N, d)`` hypotheses.

        ``release`` is one rate for all hypotheses or one per hypothesis ``(N,)``.
        """
        p = self.params
        h = np.atleast_2d(np.asarray(hypotheses, float))
        s = np.atleast_2d(np.asarray(sensor_positions, float))
        w = np.asarray(wind, float).reshape(-1)
        if w.shape != (h.shape[1],) or not np.all(np.isfinite(w)):
            raise ConfigError("wind", f"needs {h.shape[1]} finite components")
        # a NaN position would fall outside every plume (x > 0 is False) and read as clean air
        if s.ndim != 2 or s.shape[1] != h.shape[1] or not np.all(np.isfinite(s)):
            raise ConfigError(
                "sensor_positions", f"need {h.shape[1]} finite components, got {s.shape}"
            )
        rate = np.asarray(p.release if release is None else release, float)
        if not (np.all(np.isfinite(rate)) and np.all(rate >= 0)):
            raise ConfigError("release", f"must be finite numbers >= 0, got {rate}")
        if rate.ndim and rate.shape != (len(h),):
            raise ConfigError("release", f"needs one rate or {len(h)}, got shape {rate.shape}")
        q = np.broadcast_to(rate, (len(h),))
        winds = np.broadcast_to(w, h.shape)
        return p.gain * gaussian_concentration(s, h, q, winds, p, p.ground)

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        p = self.params
        c = self.predict(
            sensor_position, hypotheses, conditions["wind"], conditions.get("release")
        )[0]
        if isinstance(z, bool | np.bool_):
            x = (c - p.threshold) / p.noise_std
            # log Phi(-x) rather than log(1 - Phi(x)): the latter rounds to log(0) = -inf a few
            # noise widths past the threshold, which would rule hypotheses out for good
            return log_ndtr(x if z else -x)
        try:
            reading = float(z)
        except (TypeError, ValueError):
            raise ConfigError("reading", f"must be a bool or a finite number, got {z!r}") from None
        if not math.isfinite(reading):
            raise ConfigError("reading", f"must be finite, got {reading}")
        r = (reading - c) / p.noise_std
        return -0.5 * r * r - math.log(p.noise_std * math.sqrt(2.0 * math.pi))

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        p = self.params
        c = self.predict(
            sensor_positions, hypotheses, conditions["wind"], conditions.get("release")
        )
        x = (c - p.threshold) / p.noise_std
        # Phi(-x) for p(z=0), not 1 - Phi(x): exact in the far tail, as in log_likelihood
        return np.stack([ndtr(-x), ndtr(x)], axis=1)
