"""Kernel DM+V and its wind and time extensions (registry names ``kernel-dmv``,
``kernel-dmvw``, ``td-kernel-dmv``).

Kernel DM+V (Lilienthal, Reggente, Trincavelli, Blanco and Gonzalez, IROS 2009) spreads every
reading ``r_i`` taken at ``x_i`` over the cells ``k`` (centres ``x^(k)``) with a Gaussian kernel:

* weights ``w_i^(k) = N(x^(k) - x_i; sigma)`` (eq. 1), cut off beyond ``cutoff`` standard
  deviations (the paper evaluates the kernel within a cut-off radius);
* importance weights ``Omega^(k) = sum_i w_i^(k)`` (eq. 2) and weighted readings
  ``R^(k) = sum_i w_i^(k) r_i`` (eq. 3);
* confidence ``alpha^(k) = 1 - exp(-(Omega^(k))^2 / sigma_Omega^2)`` (eq. 4);
* mean ``r^(k) = alpha^(k) R^(k) / Omega^(k) + (1 - alpha^(k)) r_0`` (eq. 5);
* ``V^(k) = sum_i w_i^(k) (r_i - r^(k(i)))^2`` with ``k(i)`` the cell holding reading ``i``
  (eq. 6), and variance ``v^(k) = alpha^(k) V^(k) / Omega^(k) + (1 - alpha^(k)) v_0`` (eq. 7).

Readings of the paper (each a parameter): ``sigma_Omega`` is given as ``confidence_scale``
times the kernel's peak weight ``N(0; sigma)``, so that ``confidence_scale = 1`` gives a cell
with one reading at its centre ``alpha = 1 - 1/e``, whatever ``sigma``; the prior ``r_0`` is the
mean of all readings and ``v_0`` their variance about it (``prior_mean``, ``prior_variance``
fix them instead); a reading outside the grid takes the nearest cell as ``k(i)``.

Kernel DM+V/W (Reggente and Lilienthal, IEEE Sensors 2009) stretches each reading's kernel along
the wind ``v_i`` measured with it: an elliptic Gaussian whose semi-axis along the wind is
``a = sigma + gamma |v_i|`` and whose semi-axes across it are ``b = sigma / (1 + gamma |v_i| /
sigma)`` (``a b = sigma^2``: the stretched kernel covers the area of the round one), i.e.
``Sigma_i = b^2 I + (a^2 - b^2) v_hat v_hat^T`` in 2-D and 3-D (the 3-D form of Reggente and
Lilienthal's 3D-Kernel DM+V/W, ICRA 2010). ``wind_shift`` (seconds, default 0: the kernel as
the papers give it, centred on the reading) additionally moves each kernel's centre by
``wind_shift * v_i``, downwind for positive values.

TD Kernel DM+V (Asadi, Fan, Hernandez Bennetts and Lilienthal, Robotics and Autonomous Systems
2017) weighs each reading by its recency at the time ``t*`` of the latest reading,
``phi_i = exp(-beta (t* - t_i))``, in every sum (``w_i^(k) phi_i`` in eqs. 2, 3 and 6) and in
the prior (``r_0 = sum phi_i r_i / sum phi_i``, ``v_0`` likewise), so that old readings fade
from the mean, the variance and the confidence.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from odorloc.core.params import Finite, NonNegative, Positive
from odorloc.core.registry import register
from odorloc.inference.gas_map.base import GasMap, GasMapParams
from odorloc.inference.gas_map.kernels import anisotropic_sums, gaussian_peak, isotropic_sums
from odorloc.inference.gas_map.readings import Readings

__all__ = [
    "KernelDMV",
    "KernelDMVParams",
    "KernelDMVW",
    "KernelDMVWParams",
    "TDKernelDMV",
    "TDKernelDMVParams",
    "wind_covariances",
]

FloatArray = NDArray[np.float64]


class KernelDMVParams(GasMapParams):
    """Parameters of Kernel DM+V (see the module docstring).

    Attributes
    ----------
    kernel_width : float, metres
        ``sigma`` of the Gaussian kernel (eq. 1); the paper learns it by cross-validation
        (:func:`~odorloc.inference.gas_map.selection.select_parameters`).
    cutoff : float
        The kernel is evaluated within this many standard deviations of its centre.
    confidence_scale : float
        ``sigma_Omega`` of eq. 4 in units of the kernel's peak weight ``N(0; sigma)``.
    prior_mean : float, optional
        ``r_0`` (reading units); default the mean of the readings.
    prior_variance : float, optional
        ``v_0`` (reading units squared); default the readings' variance about ``r_0``.
    backend : {"auto", "numpy", "numba"}
        The kernel sums' loop (``auto``: compiled when numba is installed; same numbers).
    """

    kernel_width: Positive = 0.3
    cutoff: Positive = 3.0
    confidence_scale: Positive = 1.0
    prior_mean: Finite | None = None
    prior_variance: NonNegative | None = None
    backend: Literal["auto", "numpy", "numba"] = "auto"


class KernelDMVWParams(KernelDMVParams):
    """Parameters of Kernel DM+V/W: those of Kernel DM+V, and

    Attributes
    ----------
    wind_scale : float, seconds
        ``gamma``: the kernel's semi-axis along the wind grows by ``gamma |v|``.
    wind_shift : float, seconds
        Each kernel's centre moves by ``wind_shift * v`` (downwind for positive values;
        0 keeps it on the reading, as in the papers).
    """

    wind_scale: NonNegative = 0.3
    wind_shift: Finite = 0.0


class TDKernelDMVParams(KernelDMVParams):
    """Parameters of TD Kernel DM+V: those of Kernel DM+V, and

    Attributes
    ----------
    time_scale : float, 1/s
        ``beta`` of the recency weight ``exp(-beta (t* - t_i))``.
    """

    time_scale: NonNegative = 0.001


@register("gas_map", "kernel-dmv", KernelDMVParams, "Kernel DM+V (Lilienthal et al. 2009)")
class KernelDMV(GasMap):
    """Kernel DM+V: kernel-weighted mean and variance maps blended with a prior (Lilienthal
    et al. 2009)."""

    params: KernelDMVParams
    needs_wind: ClassVar[bool] = False
    needs_time: ClassVar[bool] = False

    def __init__(self, params: KernelDMVParams | None = None) -> None:
        super().__init__(params if params is not None else KernelDMVParams())

    # ------------------------------------------------------------------ member hooks
    def _weights(self, readings: Readings) -> FloatArray:
        """The per-reading factor of every sum (1 here; the recency weight of TD)."""
        return np.ones(len(readings))

    def _sums(self, readings: Readings, scale: FloatArray, values: FloatArray) -> FloatArray:
        """``(m, nx, ny[, nz])`` kernel sums of ``values`` (``(N, m)``) over the cells."""
        p = self.params
        out = isotropic_sums(
            self.grid, readings.positions, p.kernel_width, p.cutoff, scale, values, p.backend
        )
        return out.reshape(values.shape[1], *self.grid.shape)

    # ------------------------------------------------------------------ maps
    def _prior(self, readings: Readings) -> tuple[float, float]:
        """``(r_0, v_0)``: the (weighted) mean of the readings and their variance about it,
        unless fixed by the parameters."""
        p = self.params
        phi = self._weights(readings)
        total = float(phi.sum())
        r = readings.values
        r0 = p.prior_mean if p.prior_mean is not None else float(phi @ r) / total
        if p.prior_variance is not None:
            return float(r0), float(p.prior_variance)
        return float(r0), float(phi @ (r - r0) ** 2) / total

    def _compute_mean(self, readings: Readings) -> FloatArray:
        p = self.params
        scale = self._weights(readings)
        values = np.column_stack([np.ones(len(readings)), readings.values])
        omega, weighted = self._sums(readings, scale, values)
        sigma_omega = p.confidence_scale * gaussian_peak(p.kernel_width, self.grid.dim)
        alpha = 1.0 - np.exp(-((omega / sigma_omega) ** 2))  # eq. 4
        ratio = np.divide(weighted, omega, out=np.zeros_like(omega), where=omega > 0)
        r0, _ = self._prior(readings)
        self._state = (omega, alpha, scale)
        return alpha * ratio + (1.0 - alpha) * r0  # eq. 5

    def _compute_spread(
        self, readings: Readings, mean: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        omega, alpha, scale = self._state
        own = tuple(self.grid.index(readings.positions).T)
        residual = (readings.values - mean[own]) ** 2
        (v_sum,) = self._sums(readings, scale, residual[:, None])  # eq. 6
        _, v0 = self._prior(readings)
        ratio = np.divide(v_sum, omega, out=np.zeros_like(omega), where=omega > 0)
        var = alpha * ratio + (1.0 - alpha) * v0  # eq. 7
        return var, alpha, var


def wind_covariances(wind: FloatArray, sigma: float, gamma: float) -> FloatArray:
    """Kernel DM+V/W covariances ``Sigma_i = b^2 I + (a^2 - b^2) v_hat v_hat^T`` with
    ``a = sigma + gamma |v|``, ``b = sigma / (1 + gamma |v| / sigma)`` (Reggente and
    Lilienthal 2009), ``(N, d, d)`` m^2 for winds ``(N, d)`` m/s."""
    speed = np.linalg.norm(wind, axis=1)
    a = sigma + gamma * speed
    b = sigma / (1.0 + gamma * speed / sigma)
    unit = np.divide(wind, speed[:, None], out=np.zeros_like(wind), where=speed[:, None] > 0)
    d = wind.shape[1]
    eye = np.eye(d)[None, :, :]
    outer = unit[:, :, None] * unit[:, None, :]
    return (b * b)[:, None, None] * eye + (a * a - b * b)[:, None, None] * outer


@register(
    "gas_map", "kernel-dmvw", KernelDMVWParams, "Kernel DM+V/W (Reggente and Lilienthal 2009)"
)
class KernelDMVW(KernelDMV):
    """Kernel DM+V/W: Kernel DM+V with each kernel stretched along the wind of its reading
    (Reggente and Lilienthal 2009)."""

    params: KernelDMVWParams
    needs_wind: ClassVar[bool] = True

    def __init__(self, params: KernelDMVWParams | None = None) -> None:
        super().__init__(params if params is not None else KernelDMVWParams())

    def _sums(self, readings: Readings, scale: FloatArray, values: FloatArray) -> FloatArray:
        p = self.params
        wind = readings.wind
        assert wind is not None  # the base class refuses readings without it
        centres = readings.positions + p.wind_shift * wind
        cov = wind_covariances(wind, p.kernel_width, p.wind_scale)
        out = anisotropic_sums(self.grid, centres, cov, p.cutoff, scale, values)
        return out.reshape(values.shape[1], *self.grid.shape)


@register("gas_map", "td-kernel-dmv", TDKernelDMVParams, "TD Kernel DM+V (Asadi et al. 2017)")
class TDKernelDMV(KernelDMV):
    """TD Kernel DM+V: Kernel DM+V with readings weighted by their recency (Asadi et al.
    2017)."""

    params: TDKernelDMVParams
    needs_time: ClassVar[bool] = True

    def __init__(self, params: TDKernelDMVParams | None = None) -> None:
        super().__init__(params if params is not None else TDKernelDMVParams())

    def _weights(self, readings: Readings) -> FloatArray:
        """``phi_i = exp(-beta (t* - t_i))`` with ``t*`` the latest reading's time."""
        t = readings.t
        return np.exp(-self.params.time_scale * (float(t.max()) - t))
