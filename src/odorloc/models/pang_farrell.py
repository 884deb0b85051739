"""The Pang & Farrell binary-detection model for source-position hypotheses.

- :class:`PangFarrellModel`: the binary-detection likelihood of Pang & Farrell (2006) as used
  by the indoor PF paper (section 2.2, eqs. 6-11): odor patches released from a hypothesised
  source during the recorded window are advected by the recorded wind and spread as Gaussian
  puffs; the probability that none of them is detected at the robot gives ``p(z = 0 | L)``.
All functions are vectorised over hypotheses (``(N, d)``) and, where it matters, over records and
sensor positions; they return log-likelihoods ``(N,)`` (``-inf`` allowed, never NaN) so that any
estimator can add them to its log-weights.

Reading of the paper's equations (the text is a flattened PDF)
--------------------------------------------------------------
With records ``l = f..k-1`` (``f`` the oldest record of the window, ``k`` the current step,
period ``dt``):

- Advection (eq. 8): ``s(l, k) = sum_{j=l}^{k-1} U(L^R_j) dt`` -- the wind measured at record
  ``j`` is held over ``[t_j, t_j + dt]``, so a patch released at ``l`` has travelled ``k - l``
  periods (the paper's sum written ``j = l..k`` would count one period more than the elapsed
  time).
- Offset (text after eq. 11): ``delta_i(l, k) = L^R_k - L^i - s(l, k)`` per axis.
- Density (eq. 11), per axis variance growing linearly with the elapsed time
  ``tau = (k - l) dt``: ``p^R_i(l, k) = exp(-dx^2 / (2 vx) - dy^2 / (2 vy)) / (2 pi sqrt(vx vy))``
  with ``v_a = var0 + sigma_a^2 T_s tau``. The flattened text shows ``1 / (2 sx sy (k-l) dt)``;
  the ``pi`` of a normalised 2D Gaussian is restored here. ``sigma_a^2`` is the variance of the
  wind component ``a`` over the last 10 s (world x and y axes, as in eq. 11). The paper's
  ``sigma^2 (k-l) dt`` mixes units (m^2/s^2 * s); ``T_s`` (``time_scale``, default 1 s, i.e.
  the paper's numbers) makes it a displacement variance in m^2 (a Taylor-diffusion reading with
  Lagrangian time scale ``T_s``). A floor ``min_wind_variance`` keeps puffs from collapsing to
  points in a perfectly steady wind.
- Likelihood (eq. 10): ``p(z_k = 0 | L^i) = prod_l [1 - mu S_p p^R_i(l, k)]`` and
  ``p(z_k = 1 | L^i) = 1 - prod_l [...]``, with detection probability ``mu = 0.9`` inside the
  product (each patch is detected with probability ``mu``) and ``S_p`` the sensing area that
  turns the density into a probability (``sensor_area``). Each factor is clipped into [0, 1].
  Both outcomes are finally clipped into ``[p_floor, 1 - p_floor]``: a small false-alarm / miss
  probability so that one surprising reading cannot zero a hypothesis for ever.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.models.base import MeasurementModel, binary_outcomes

__all__ = [
    "PangFarrellModel",
    "PangFarrellParams",
    "reference_detection_probability",
    "wind_variance",
]


class PangFarrellParams(Params):
    """Parameters of the Pang & Farrell transport likelihood (indoor PF paper, eqs. 10-11).

    Parameters
    ----------
    mu : float
        Probability that the sensor detects a patch present at its position (paper: 0.9).
    sensor_area : float, m^2
        ``S_p``: area over which the patch density is integrated (eq. 10).
    time_scale : float, s
        ``T_s`` turning wind-velocity variance times elapsed time into a displacement variance.
    min_wind_variance : float, m^2/s^2
        Floor on each wind-component variance.
    initial_variance : float, m^2
        Puff variance at release (source size); 0 = point source.
    p_floor : float
        Both ``p(z=1|L)`` and ``p(z=0|L)`` are clipped into ``[p_floor, 1 - p_floor]``.
    """

    mu: float = Field(0.9, gt=0.0, le=1.0)
    sensor_area: Positive = 0.01
    time_scale: Positive = 1.0
    min_wind_variance: NonNegative = 0.01
    initial_variance: NonNegative = 0.0
    p_floor: float = Field(1e-4, ge=0.0, lt=0.5)


def wind_variance(winds: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Per-component variance of recorded wind readings, floored.

    Parameters
    ----------
    winds : (W, d) ndarray, m/s
        Recent anemometer readings (the paper uses the last 10 s).
    floor : float, m^2/s^2

    Returns
    -------
    (d,) ndarray, m^2/s^2
        Population variance per axis; ``floor`` when fewer than two readings.
    """
    w = np.asarray(winds, float)
    if w.ndim != 2:
        raise ConfigError("winds", f"expected shape (W, d), got {w.shape}")
    if len(w) < 2:
        return np.full(w.shape[1], float(floor))
    return np.maximum(w.var(axis=0), floor)


def _check_window(wind_window: np.ndarray, dim: int | None, dt: float) -> np.ndarray:
    """The wind window as a ``(W, d)`` float array; :class:`ConfigError` if malformed.

    ``dim=None`` accepts any number of components.
    """
    w = np.asarray(wind_window, float)
    if w.ndim != 2 or len(w) == 0 or (dim is not None and w.shape[1] != dim):
        want = "d" if dim is None else str(dim)
        raise ConfigError("wind_window", f"expected shape (W>=1, {want}), got {w.shape}")
    # one missing anemometer reading would otherwise turn every likelihood into NaN
    if not np.all(np.isfinite(w)):
        raise ConfigError("wind_window", "every reading must be finite")
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError("dt", f"must be a finite number > 0, got {dt}")
    return w


def _check_wind_var(wind_var: np.ndarray, dim: int) -> np.ndarray:
    v = np.asarray(wind_var, float)
    if v.shape != (dim,) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ConfigError(
            "wind_var", f"expected {dim} finite variances >= 0, got {np.asarray(wind_var)!r}"
        )
    return v


@register("model", "pang-farrell", PangFarrellParams, "Pang & Farrell binary detections")
class PangFarrellModel(MeasurementModel):
    """Binary-detection likelihood of source hypotheses from a recorded wind window.

    Conditions: ``wind_window`` ``(W, d)`` m/s (the anemometer readings of the last ``W``
    records before the current step, oldest first; row ``j`` is held over one period ``dt``),
    ``dt`` (record period, s) and optionally ``wind_var`` ``(d,)`` m^2/s^2. See the module
    docstring for how each equation is read.

    Parameters
    ----------
    params : PangFarrellParams, optional
    """

    Params = PangFarrellParams

    def __init__(self, params: PangFarrellParams | None = None) -> None:
        self.params = params or PangFarrellParams()

    # ----------------------------------------------------------------- building blocks
    def puff_geometry(
        self, wind_window: np.ndarray, dt: float, wind_var: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Advection and per-axis spread of the patch released at each record.

        Parameters
        ----------
        wind_window : (W, d) ndarray, m/s
        dt : float, s
        wind_var : (d,) ndarray, m^2/s^2, optional
            Wind-component variances; default: :func:`wind_variance` of ``wind_window``.

        Returns
        -------
        shift : (W, d) ndarray, metres
            ``s(l, k)`` for ``l = k-W..k-1`` (eq. 8).
        var : (W, d) ndarray, m^2
            Spread ``initial_variance + sigma_a^2 T_s (k - l) dt`` (eq. 11).
        """
        p = self.params
        w = _check_window(wind_window, None, dt)
        if wind_var is None:
            sig2 = wind_variance(w, p.min_wind_variance)
        else:
            sig2 = np.maximum(_check_wind_var(wind_var, w.shape[1]), p.min_wind_variance)
        # Reverse cumulative sum: the patch of record l drifts with winds l..k-1 (eq. 8).
        shift = np.cumsum(w[::-1] * dt, axis=0)[::-1]
        elapsed = dt * np.arange(len(w), 0, -1, dtype=float)
        var = p.initial_variance + sig2[None, :] * p.time_scale * elapsed[:, None]
        return shift, var

    def detection_probability(
        self,
        sensor_positions: np.ndarray,
        wind_window: np.ndarray,
        dt: float,
        hypotheses: np.ndarray,
        wind_var: np.ndarray | None = None,
    ) -> np.ndarray:
        """``p(z = 1 | L^i)`` at one or several sensor positions (eq. 10).

        Parameters
        ----------
        sensor_positions : (d,) or (M, d) ndarray, metres
            Robot position(s) at the current step ``k``.
        wind_window : (W, d) ndarray, m/s
        dt : float, s
        hypotheses : (N, d) ndarray, metres
            Hypothesised source positions.
        wind_var : (d,) ndarray, m^2/s^2, optional

        Returns
        -------
        (N,) ndarray for a single ``(d,)`` position, else (M, N) ndarray
            Clipped into ``[p_floor, 1 - p_floor]``.
        """
        hyp = np.asarray(hypotheses, float)
        if hyp.ndim != 2:
            raise ConfigError("hypotheses", f"expected shape (N, d), got {hyp.shape}")
        dim = hyp.shape[1]
        sp = np.asarray(sensor_positions, float)
        single = sp.ndim == 1
        sp = np.atleast_2d(sp)
        if sp.ndim != 2 or sp.shape[1] != dim or not np.all(np.isfinite(sp)):
            raise ConfigError(
                "sensor_positions", f"expected {dim} finite components, got {sp.shape}"
            )
        w = _check_window(wind_window, dim, dt)
        shift, var = self.puff_geometry(w, dt, wind_var)
        p = self.params

        # Layout (M, W, N): the reductions over records then run over contiguous rows.
        # Exponent of eq. 11, accumulated axis by axis; delta = L^R_k - L^i - s(l, k).
        neg_half_inv = -0.5 / var  # (W, d)
        log_norm = -0.5 * np.sum(np.log(2.0 * np.pi * var), axis=-1)  # (W,)
        expo = np.zeros((len(sp), len(shift), len(hyp)))
        for a in range(dim):
            delta = (sp[:, a, None] - shift[None, :, a])[:, :, None] - hyp[None, None, :, a]
            delta *= delta
            delta *= neg_half_inv[None, :, a, None]
            expo += delta
        expo += log_norm[None, :, None]
        miss = np.exp(expo, out=expo)  # p^R_i(l, k), eq. 11, overwritten in place below
        miss *= -p.mu * p.sensor_area
        miss += 1.0
        np.clip(miss, 0.0, 1.0, out=miss)
        p1 = 1.0 - np.prod(miss, axis=1)  # eq. 10
        p1 = np.clip(p1, p.p_floor, 1.0 - p.p_floor)
        return p1[0] if single else p1

    def log_likelihood(  # type: ignore[override]
        self,
        z: bool | int,
        sensor_position: np.ndarray,
        hypotheses: np.ndarray,
        *,
        wind_window: np.ndarray,
        dt: float,
        wind_var: np.ndarray | None = None,
    ) -> np.ndarray:
        """``log p(z_k | L^i)`` for a binary reading ``z`` at ``sensor_position`` (eq. 10).

        Parameters
        ----------
        z : bool or {0, 1}
            Detection.
        sensor_position : (d,) ndarray, metres
        hypotheses : (N, d) ndarray, metres
        wind_window : (W, d) ndarray, m/s
        dt : float, s
        wind_var : (d,) ndarray, m^2/s^2, optional

        Returns
        -------
        (N,) ndarray
        """
        rp = np.asarray(sensor_position, float)
        if rp.ndim != 1:
            raise ConfigError("sensor_position", f"expected shape (d,), got {rp.shape}")
        # bool(z) would read a count of 2, a -1 or a NaN as a detection
        if not isinstance(z, bool | np.bool_) and z not in (0, 1):
            raise ConfigError("detection", f"must be a bool or 0/1, got {z!r}")
        p1 = self.detection_probability(rp, wind_window, dt, hypotheses, wind_var)
        with np.errstate(divide="ignore"):  # p_floor = 0 may give log(0) = -inf on purpose
            return np.log(p1 if bool(z) else 1.0 - p1)

    def outcome_probabilities(  # type: ignore[override]
        self,
        sensor_positions: np.ndarray,
        hypotheses: np.ndarray,
        *,
        wind_window: np.ndarray,
        dt: float,
        wind_var: np.ndarray | None = None,
    ) -> np.ndarray:
        """``[p(z=0), p(z=1)]`` at ``(M, d)`` sensor positions, ``(M, 2, N)`` (eq. 10)."""
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        return binary_outcomes(
            self.detection_probability(sp, wind_window, dt, hypotheses, wind_var)
        )


def reference_detection_probability(
    robot_pos: np.ndarray,
    wind_window: np.ndarray,
    dt: float,
    hypotheses: np.ndarray,
    params: PangFarrellParams | None = None,
    wind_var: np.ndarray | None = None,
) -> np.ndarray:
    """Plain per-particle, per-record loop of eqs. 8, 10, 11 (for tests and benchmarks).

    Same arguments and result as :meth:`PangFarrellModel.detection_probability` for a single
    ``(d,)`` robot position; written without NumPy vectorisation on purpose. Eq. 11's density
    times ``mu S_p`` is evaluated as ``c_l exp(-sum_a delta_a^2 / (2 v_a))`` with
    ``c_l = mu S_p / prod_a sqrt(2 pi v_a)`` (``mu S_p / (2 pi sqrt(vx vy))`` in 2-D): one
    exponential per record and particle, as the vector code takes.
    """
    p = params or PangFarrellParams()
    winds = np.asarray(wind_window, float).tolist()
    n_rec, dim = len(winds), len(winds[0])
    if wind_var is None:
        sig2 = []
        for a in range(dim):
            vals = [row[a] for row in winds]
            m = sum(vals) / n_rec
            v = sum((x - m) ** 2 for x in vals) / n_rec if n_rec > 1 else 0.0
            sig2.append(max(v, p.min_wind_variance))
    else:
        sig2 = [max(float(v), p.min_wind_variance) for v in wind_var]
    rp = np.asarray(robot_pos, float).tolist()
    mu_s = p.mu * p.sensor_area
    floor = p.p_floor
    # what does not depend on the particle, once per record l: the robot position shifted back
    # by the wind since record l (eq. 8), 1 / (2 v_a) per axis, and mu S_p over eq. 11's
    # normaliser
    per_record = []
    for l in range(n_rec):  # noqa: E741 - the paper's record index
        steps = n_rec - l  # k - l
        shifted, inv_two_var, norm = [], [], 1.0
        for a in range(dim):
            s_a = sum(winds[j][a] * dt for j in range(l, n_rec))
            var = p.initial_variance + sig2[a] * p.time_scale * steps * dt
            shifted.append(rp[a] - s_a)
            inv_two_var.append(1.0 / (2.0 * var))
            norm *= math.sqrt(2.0 * math.pi * var)
        per_record.append((shifted, inv_two_var, mu_s / norm))
    out = []
    if dim == 2:
        # eq. 11 as printed, the axes written out
        recs = [(sx, sy, ix, iy, c) for (sx, sy), (ix, iy), c in per_record]
        for hx, hy in np.asarray(hypotheses, float).tolist():
            prod_miss = 1.0
            for sx, sy, ix, iy, c in recs:
                dx = sx - hx
                dy = sy - hy
                prod_miss *= min(1.0, max(0.0, 1.0 - math.exp(-(dx * dx * ix + dy * dy * iy)) * c))
            p1 = 1.0 - prod_miss
            out.append(min(max(p1, floor), 1.0 - floor))
        return np.asarray(out)
    for h in np.asarray(hypotheses, float).tolist():
        prod_miss = 1.0
        for shifted, inv_two_var, c in per_record:
            e = 0.0
            for s_a, h_a, i_a in zip(shifted, h, inv_two_var, strict=True):
                d = s_a - h_a
                e += d * d * i_a
            prod_miss *= min(1.0, max(0.0, 1.0 - math.exp(-e) * c))
        p1 = 1.0 - prod_miss
        out.append(min(max(p1, floor), 1.0 - floor))
    return np.asarray(out)
