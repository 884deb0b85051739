"""Steady Gaussian plume model (the time-averaged plume of the indoor particle-filter paper).

For a source of rate ``Q`` in a wind of speed ``u`` blowing along the unit vector ``e``, with
downwind distance ``x = (p - s) . e > 0``, horizontal cross-wind offset ``y`` and height offset
``z`` (3D), the concentration is (the Gaussian plume of eq. 3, indoor-pf-entropy paper)::

    C = Q / (2 pi sigma_y sigma_z u) * exp(-y^2 / (2 sigma_y^2)) * Z(z)

and ``0`` upwind (``x <= 0``). In 2D the plane through the source height is modelled, so
``Z = 1`` (this is the paper's formula exactly). In 3D ``Z = exp(-z^2 / (2 sigma_z^2))`` plus,
with ground reflection, the image term ``exp(-(z_s + z_r - 2 z_g)^2 / (2 sigma_z^2))`` for a
ground at the arena floor ``z_g``. Several sources superpose.

The widths grow downwind either by eddy diffusion (``spread="diffusion"``,
``sigma^2 = sigma0^2 + 2 K x / u``) or by a power law (``spread="power"``,
``sigma^2 = sigma0^2 + (a x^b)^2``); ``sigma0`` keeps the plume finite at the source.
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
    "GaussianParams",
    "GaussianPlumeModel",
    "GaussianReadingParams",
    "gaussian_concentration",
    "gaussian_plume",
]


class GaussianParams(Params):
    """Parameters of :class:`GaussianPlume`.

    Attributes
    ----------
    spread : "diffusion" | "power"
        Width law (see module docstring).
    sigma0 : float, metres
        Width at the source.
    K : float, m^2/s
        Eddy diffusivity (``spread="diffusion"``), cross-wind and vertical.
    a_y, b_y, a_z, b_z : float
        Power-law coefficients (``spread="power"``), ``sigma = a x^b`` with ``x`` in metres.
    min_speed : float, m/s
        Wind speeds below this are raised to it (the formula diverges as ``u -> 0``).
    ground_reflection : bool
        3D only: add the image source below the arena floor.
    """

    spread: Literal["diffusion", "power"] = "diffusion"
    sigma0: Positive = 0.1
    K: Positive = 0.05
    a_y: Positive = 0.2
    b_y: Positive = 0.9
    a_z: Positive = 0.12
    b_z: Positive = 0.85
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
        rel = points - s
        x = rel[:, 0] * e[0] + rel[:, 1] * e[1]
        y = -rel[:, 0] * e[1] + rel[:, 1] * e[0]
        down = x > 0
        xd = np.where(down, x, 0.0)
        if p.spread == "diffusion":
            sy2 = p.sigma0**2 + 2.0 * p.K * xd / u
            sz2 = sy2
        else:
            sy2 = p.sigma0**2 + (p.a_y * xd**p.b_y) ** 2
            sz2 = p.sigma0**2 + (p.a_z * xd**p.b_z) ** 2
        c = q / (2.0 * np.pi * np.sqrt(sy2 * sz2) * u) * np.exp(-0.5 * y**2 / sy2)
        if dim == 3:
            zr = points[:, 2]
            zt = np.exp(-0.5 * (zr - s[2]) ** 2 / sz2)
            if p.ground_reflection:
                zt = zt + np.exp(-0.5 * (zr + s[2] - 2.0 * ground) ** 2 / sz2)
            c = c * zt
        yield np.where(down, c, 0.0)


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

    Conditions: ``wind`` ``(d,)`` m/s (the mean wind; required) and optionally ``release``.
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
        release: float | None = None,
    ) -> np.ndarray:
        """Expected reading ``gain C`` at ``(M, d)`` positions for ``(N, d)`` hypotheses."""
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
        rate = p.release if release is None else float(release)
        if not (math.isfinite(rate) and rate >= 0):
            raise ConfigError("release", f"must be a finite number >= 0, got {rate}")
        q = np.full(len(h), rate)
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
