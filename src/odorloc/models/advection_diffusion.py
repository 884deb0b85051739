"""Steady advection-diffusion from a point source in a uniform wind, 2-D, in closed form.

A source releasing ``Q`` (mass per second, per metre of height in 2-D) into a uniform wind of
speed ``U`` blowing along the unit vector ``e``, with diffusivity ``D_a`` along the wind and
``D_c`` across it, in an unbounded plane, reaches the steady concentration::

    c(p) = Q / (2 pi sqrt(D_a D_c)) exp(U xi / (2 D_a)) K0(U rho / (2 sqrt(D_a)))
    rho  = sqrt(xi^2 / D_a + eta^2 / D_c)

with ``xi = (p - s) . e`` the distance downwind of the source and ``eta`` the cross-wind offset
(the isotropic solution, ``D_a = D_c = D``, is the Green's function of ``U dc/dx = D lap c + Q
delta``; stretching each axis by ``sqrt(D)`` gives the anisotropic one). It is the ``tau -> inf``
limit of the 2-D encounter-rate model of :mod:`odorloc.models.vergassola` (no finite lifetime).

:func:`point_source_2d` evaluates it, :func:`point_source_flux_2d` gives the total mass flux
``(U c - D grad c)`` density there, so that the flux leaving any closed curve around the source is
``Q`` (a check of both).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import k0e, k1e

from odorloc.core.errors import ConfigError

__all__ = ["point_source_2d", "point_source_flux_2d"]

FloatArray = NDArray[np.float64]


def _frame(
    points: ArrayLike,
    source: ArrayLike,
    wind: ArrayLike,
    D_along: float,
    D_across: float | None,
) -> tuple[FloatArray, FloatArray, float, float, float, FloatArray]:
    p = np.atleast_2d(np.asarray(points, float))
    s = np.asarray(source, float).reshape(-1)
    w = np.asarray(wind, float).reshape(-1)
    if p.shape[1] != 2 or s.size != 2 or w.size != 2:
        raise ConfigError("points", "point_source_2d is 2-D: points (Q, 2), source and wind (2,)")
    da = float(D_along)
    dc = da if D_across is None else float(D_across)
    if not (math.isfinite(da) and da > 0 and math.isfinite(dc) and dc > 0):
        raise ConfigError("D", f"diffusivities must be finite and > 0, got {da}, {dc}")
    speed = float(np.hypot(*w))
    if not math.isfinite(speed) or speed <= 0:
        raise ConfigError("wind", "must be a finite, non-zero vector")
    e = w / speed
    rel = p - s
    xi = rel @ e
    eta = rel @ np.array([-e[1], e[0]])
    return xi, eta, speed, da, dc, e


def point_source_2d(
    points: ArrayLike,
    source: ArrayLike,
    rate: float,
    wind: ArrayLike,
    D_along: float,
    D_across: float | None = None,
) -> FloatArray:
    """Steady concentration of a point source in a uniform 2-D wind (see the module docstring).

    Parameters
    ----------
    points : (Q, 2) array_like, metres
    source : (2,) array_like, metres
    rate : float
        Release ``Q`` (mass/s; per metre of height in 2-D).
    wind : (2,) array_like, m/s
        Uniform wind (not zero).
    D_along, D_across : float, m^2/s
        Diffusivity along and across the wind (``D_across`` defaults to ``D_along``).

    Returns
    -------
    (Q,) ndarray
        Concentration (mass/m^2 in 2-D); ``inf`` at the source itself.
    """
    xi, eta, U, da, dc, _ = _frame(points, source, wind, D_along, D_across)
    rho = np.sqrt(xi * xi / da + eta * eta / dc)
    z = U * rho / (2.0 * math.sqrt(da))
    with np.errstate(divide="ignore"):
        # K0(z) = k0e(z) exp(-z); the exponent U xi / (2 D_a) - z is <= 0, so no overflow
        c = k0e(z) * np.exp(U * xi / (2.0 * da) - z)
    return float(rate) / (2.0 * math.pi * math.sqrt(da * dc)) * c


def point_source_flux_2d(
    points: ArrayLike,
    source: ArrayLike,
    rate: float,
    wind: ArrayLike,
    D_along: float,
    D_across: float | None = None,
) -> FloatArray:
    """Total (advective + diffusive) mass flux density ``U c - D grad c`` at ``points``.

    Returns
    -------
    (Q, 2) ndarray
        Mass per metre per second (2-D); the flux out of any closed curve around the source is
        ``rate``.
    """
    xi, eta, U, da, dc, e = _frame(points, source, wind, D_along, D_across)
    rho = np.sqrt(xi * xi / da + eta * eta / dc)
    a = U / (2.0 * math.sqrt(da))
    z = a * rho
    pref = float(rate) / (2.0 * math.pi * math.sqrt(da * dc))
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.exp(U * xi / (2.0 * da) - z)
        c = pref * k0e(z) * g
        # d/dq K0(a rho) = -a K1(a rho) d rho/dq, d rho/dxi = xi / (D_a rho), eta likewise
        k1 = pref * k1e(z) * g * a / rho
        dxi = U / (2.0 * da) * c - k1 * xi / da
        deta = -k1 * eta / dc
    f_along = U * c - da * dxi
    f_across = -dc * deta
    n = np.array([-e[1], e[0]])
    return f_along[:, None] * e[None, :] + f_across[:, None] * n[None, :]
