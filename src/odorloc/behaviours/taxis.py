"""Plume-tracing rules over a set of samples: chemotaxis, anemotaxis and fluxotaxis.

Each rule turns samples taken around a centre -- the robots of a formation around their virtual
leader (virtual-physics paper, eqs. 3-6), or the recent positions of one robot around its current
one -- into a goal direction, or ``None`` when the rule has nothing to say (no signal, calm air,
no inflowing flux). A sample is a position ``x_k``, a gas reading ``rho_k`` and a wind ``v_k``.

- **chemotaxis** (eq. 3): towards the sample with the highest reading,
  ``(x_j - x_c) / |x_j - x_c|``;
- **anemotaxis** (eq. 4): when every reading exceeds ``rho_T`` and the winds are not all zero,
  upwind of the mean wind, ``-v_bar / |v_bar|``;
- **fluxotaxis** (eqs. 5-6): the mass flux through the ring of samples at sample ``k`` is
  ``rho_k v_k . n_k`` with ``n_k`` the outward normal ``(x_k - x_c) / |x_k - x_c|``; when every
  reading exceeds ``rho_T``, go towards the sample with the most negative flux (odor flowing in
  through that side comes from the source beyond it).

:func:`mass_flux` also gives the total flux through the ring, which the paper's source declaration
compares with ``Phi_T`` over ``n_s`` consecutive steps (its section 2.4).

Every input must be finite: a NaN reading, wind or position raises
:class:`~odorloc.core.errors.ConfigError` naming the argument, since NaN compares false and
would otherwise pick a sample (``argmax`` returns the first NaN), send a NaN direction on, or
silently read as "no signal". A caller with a missing reading drops that sample, or substitutes
0 for "no odor", before calling.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError

__all__ = ["anemotaxis", "chemotaxis", "fluxotaxis", "mass_flux", "outward_normals"]

FloatArray = NDArray[np.float64]
_EPS = 1e-12


def _unit(v: np.ndarray) -> FloatArray | None:
    n = float(np.linalg.norm(v))
    return None if n <= _EPS else v / n


def _finite(field: str, value: ArrayLike, ndim: int) -> FloatArray:
    """``value`` as a float array of ``ndim`` (1: ``(K,)`` or ``(d,)``; 2: ``(K, d)``), refused
    with a :class:`ConfigError` naming ``field`` unless every entry is finite."""
    a = np.asarray(value, float)
    a = np.atleast_2d(a) if ndim == 2 else a.reshape(-1)
    if a.ndim != ndim:
        raise ConfigError(field, f"expected a {ndim}-d array, got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        k = int(np.argwhere(bad)[0][0])
        raise ConfigError(field, f"every value must be finite, got {a[k]} (entry {k})")
    return a


def _samples(
    centre: ArrayLike, positions: ArrayLike, readings: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Checked ``centre (d,)``, ``positions (K, d)`` and ``readings (K,)``."""
    c = _finite("centre", centre, 1)
    x = _finite("positions", positions, 2)
    r = _finite("readings", readings, 1)
    if x.shape[1] != c.size:
        raise ConfigError("positions", f"expected {c.size} components, got {x.shape[1]}")
    if len(x) != r.size:
        raise ConfigError("readings", f"expected {len(x)} (one per position), got {r.size}")
    return c, x, r


def _threshold(threshold: float) -> float:
    if math.isnan(threshold):
        # every comparison with NaN is false: the rule would never apply
        raise ConfigError("threshold", "must be a number, got nan")
    return float(threshold)


def chemotaxis(centre: ArrayLike, positions: ArrayLike, readings: ArrayLike) -> FloatArray | None:
    """Unit direction from ``centre`` ``(d,)`` to the sample with the highest reading (eq. 3).

    Parameters
    ----------
    centre : (d,) array_like, metres
    positions : (K, d) array_like, metres
    readings : (K,) array_like
        Gas readings (any units).

    Returns
    -------
    (d,) ndarray or None
        ``None`` when no reading is positive, when all are equal (no direction stands out) or
        when the best sample sits on the centre. Ties go to the first such sample.
    """
    c, x, r = _samples(centre, positions, readings)
    if r.size == 0 or not np.any(r > 0) or np.all(r == r[0]):
        return None
    return _unit(x[int(np.argmax(r))] - c)


def anemotaxis(winds: ArrayLike, readings: ArrayLike, threshold: float) -> FloatArray | None:
    """Upwind unit direction of the mean wind when every reading exceeds ``threshold`` (eq. 4).

    Parameters
    ----------
    winds : (K, d) array_like, m/s
    readings : (K,) array_like
    threshold : float
        ``rho_T``, in the readings' units.

    Returns
    -------
    (d,) ndarray or None
        ``None`` when a reading is at or below the threshold or the mean wind is zero.
    """
    w = _finite("winds", winds, 2)
    r = _finite("readings", readings, 1)
    if r.size == 0 or not np.all(r > _threshold(threshold)):
        return None
    return _unit(-w.mean(axis=0))


def outward_normals(centre: ArrayLike, positions: ArrayLike) -> FloatArray:
    """Unit vectors from ``centre`` to each sample, ``(K, d)`` (zero for a sample on the centre)."""
    c = np.asarray(centre, float)
    x = np.atleast_2d(np.asarray(positions, float))
    d = x - c
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(n > _EPS, d / np.maximum(n, _EPS), 0.0)


def mass_flux(
    centre: ArrayLike, positions: ArrayLike, readings: ArrayLike, winds: ArrayLike
) -> tuple[FloatArray, float]:
    """Mass flux ``rho_k v_k . n_k`` at each sample (eq. 5) and their sum.

    Returns
    -------
    flux : (K,) ndarray
        Readings x m/s; negative where odor flows into the ring.
    total : float
        Sum over the samples (the paper's "total mass flux" of the formation).
    """
    c, x, rho = _samples(centre, positions, readings)
    v = _finite("winds", winds, 2)
    if v.shape != x.shape:
        raise ConfigError("winds", f"expected shape {x.shape} (one per position), got {v.shape}")
    n = outward_normals(c, x)
    flux = rho * np.einsum("kd,kd->k", v, n)
    return flux, float(flux.sum())


def fluxotaxis(
    centre: ArrayLike,
    positions: ArrayLike,
    readings: ArrayLike,
    winds: ArrayLike,
    threshold: float,
) -> FloatArray | None:
    """Unit direction to the sample with the most negative mass flux (eqs. 5-6).

    Applies only when every reading exceeds ``threshold`` (``rho_T``) and some flux is
    negative; otherwise ``None``.
    """
    c, x, r = _samples(centre, positions, readings)
    if r.size == 0 or not np.all(r > _threshold(threshold)):
        return None
    flux, _ = mass_flux(c, x, r, winds)
    k = int(np.argmin(flux))
    if not flux[k] < 0:
        return None
    return _unit(x[k] - c)
