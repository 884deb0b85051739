"""Pre-processing of recorded wind and concentration data (section II, odor-path paper).

Per calculation period ``t_i`` (period ``dt_c``, one concentration sample per period):

* wind: mean of the ``M_f`` anemometer readings of the period (eq. 1);
* delay: the concentration read at ``t_i`` belongs to ``t_{i-k}``, ``k = int(tau / dt_c)``
  (eq. 2, ``int`` = floor), so the aligned series is ``c_al[j] = c[j + k]`` and pairs with the
  wind and position recorded at ``t_j``;
* baseline (eq. 3): ``c_bar_j = (1 - w) c_bar_{j-1} + w c_al[j]`` with ``c_bar_0 = c_al[0]``; the
  paper's moving average is ``w = 1/2``;
* relative concentration (eq. 4): ``c'_j = max(c_al[j] - c_bar_{j-1}, 0)``;
* signal intensity (eq. 5): ``s_j = K_c c'_j / c_bar_{j-1}``.

For ``j = 0`` there is no previous baseline; ``c_bar_{-1} = c_al[0]`` is used, so ``c'_0 = 0``.
``c_bar`` is floored at ``min_baseline`` in the division (clean air has ``c_bar = 0``).

:func:`preprocess` works on whole recorded arrays; :class:`OnlinePreprocessor` gives identical
results one period at a time (each aligned sample is emitted ``k`` periods after its time).

:class:`WindAverage` is the running mean of an agent's last anemometer readings that searchers
steer by (the upwind direction) and estimators read their models' wind from.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field
from scipy.signal import lfilter

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.geometry.vectors import upwind_unit


class PreprocessorParams(Params):
    """Parameters of the odor-path pre-processing.

    delay : float, seconds
        Sensor delay ``tau`` (5-6 s for the paper's PID).
    period : float, seconds
        Concentration sampling / calculation period ``dt_c``.
    gain : float
        ``K_c`` of eq. 5.
    baseline_weight : float
        Weight ``w`` of the newest sample in the baseline (eq. 3: 1/2).
    min_baseline : float
        Floor of ``c_bar`` in the division of eq. 5.
    """

    delay: NonNegative = 0.0
    period: Positive = 0.5
    gain: Positive = 1.0
    baseline_weight: float = Field(0.5, gt=0.0, le=1.0)
    min_baseline: Positive = 1e-12

    @property
    def delay_steps(self) -> int:
        """``k = int(tau / dt_c)`` (eq. 2)."""
        return delay_steps(self.delay, self.period)


@dataclass(frozen=True, eq=False)
class PreprocessedSignal:
    """Aligned, pre-processed records ``j = 0 .. N - k - 1``.

    Attributes
    ----------
    index : (J,) int ndarray
        Period index ``j`` each row belongs to.
    wind : (J, d) ndarray, m/s
        Period-mean wind (eq. 1).
    concentration : (J,) ndarray
        Delay-aligned concentration ``c(t_j)`` (eq. 2).
    baseline : (J,) ndarray
        ``c_bar(t_j)`` (eq. 3).
    relative : (J,) ndarray
        ``c'(t_j)`` (eq. 4).
    intensity : (J,) ndarray
        ``s(t_j)`` (eq. 5).
    """

    index: np.ndarray
    wind: np.ndarray
    concentration: np.ndarray
    baseline: np.ndarray
    relative: np.ndarray
    intensity: np.ndarray


@dataclass(frozen=True, eq=False)
class PreprocessedSample:
    """One aligned record (the fields of :class:`PreprocessedSignal` for one ``j``)."""

    index: int
    wind: np.ndarray
    concentration: float
    baseline: float
    relative: float
    intensity: float


# ---------------------------------------------------------------------- vectorised pieces
def wind_from_polar(speed: ArrayLike, direction: ArrayLike) -> np.ndarray:
    """Cartesian wind ``(u cos theta, u sin theta)`` from speed (m/s) and direction (rad).

    Returns ``(..., 2)``.
    """
    u = np.asarray(speed, float)
    th = np.asarray(direction, float)
    return np.stack([u * np.cos(th), u * np.sin(th)], axis=-1)


def average_wind(readings: ArrayLike) -> np.ndarray:
    """Period means of anemometer readings (eq. 1, odor-path paper).

    Parameters
    ----------
    readings : (N, M_f, d) array_like, m/s

    Returns
    -------
    (N, d) ndarray, m/s
    """
    r = np.asarray(readings, float)
    if r.ndim != 3 or r.shape[1] < 1:
        raise ConfigError("wind_readings", f"expected shape (N, M_f, d), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ConfigError("wind_readings", "every reading must be finite")
    return r.mean(axis=1)


def _check_concentration(c: np.ndarray) -> None:
    # the baseline of eq. 3 is recursive: one NaN would poison every later record
    if not np.all(np.isfinite(c)):
        raise ConfigError("concentration", "every reading must be finite")


def delay_steps(delay: float, period: float) -> int:
    """``k = int(tau / dt_c)``, the greatest integer <= ``tau / dt_c`` (eq. 2)."""
    if not (math.isfinite(delay) and delay >= 0):
        raise ConfigError("delay", "must be a finite number >= 0")
    if not (math.isfinite(period) and period > 0):
        raise ConfigError("period", "must be a finite number > 0")
    # The small tolerance keeps exact multiples (6.0 / 0.5) from flooring one step short.
    return math.floor(delay / period + 1e-9)


def align_delay(concentration: ArrayLike, k: int) -> np.ndarray:
    """Delay-aligned concentration ``c_al[j] = c[j + k]`` (eq. 2), length ``N - k``."""
    c = np.asarray(concentration, float)
    return c[k:].copy()


def moving_baseline(concentration: ArrayLike, weight: float = 0.5) -> np.ndarray:
    """Recursive baseline ``c_bar_j = (1 - w) c_bar_{j-1} + w c_j``, ``c_bar_0 = c_0`` (eq. 3)."""
    c = np.asarray(concentration, float)
    if c.size == 0:
        return c.copy()
    y, _ = lfilter([weight], [1.0, -(1.0 - weight)], c, zi=[(1.0 - weight) * c[0]])
    return y


def previous_baseline(concentration: np.ndarray, baseline: np.ndarray) -> np.ndarray:
    """``c_bar_{j-1}`` with ``c_bar_{-1} = c_0``."""
    if baseline.size == 0:
        return baseline.copy()
    return np.concatenate([concentration[:1], baseline[:-1]])


def relative_concentration(concentration: ArrayLike, baseline: ArrayLike) -> np.ndarray:
    """``c'_j = max(c_j - c_bar_{j-1}, 0)`` (eq. 4)."""
    c = np.asarray(concentration, float)
    prev = previous_baseline(c, np.asarray(baseline, float))
    return np.maximum(c - prev, 0.0)


def signal_intensity(
    concentration: ArrayLike, baseline: ArrayLike, gain: float, min_baseline: float = 1e-12
) -> np.ndarray:
    """``s_j = K_c c'_j / c_bar_{j-1}`` (eq. 5), ``c_bar`` floored at ``min_baseline``."""
    c = np.asarray(concentration, float)
    prev = previous_baseline(c, np.asarray(baseline, float))
    return gain * np.maximum(c - prev, 0.0) / np.maximum(prev, min_baseline)


def preprocess(
    concentration: ArrayLike, wind_readings: ArrayLike, params: PreprocessorParams
) -> PreprocessedSignal:
    """Pre-process a whole record (section II, odor-path paper).

    Parameters
    ----------
    concentration : (N,) array_like
        Raw sensor readings, one per period.
    wind_readings : (N, M_f, d) array_like, m/s
        Anemometer readings of each period.
    params : PreprocessorParams

    Returns
    -------
    PreprocessedSignal
        ``J = max(N - k, 0)`` aligned records.
    """
    c = np.asarray(concentration, float).reshape(-1)
    _check_concentration(c)
    w = average_wind(wind_readings)
    if len(w) != len(c):
        raise ConfigError("wind_readings", f"{len(w)} periods but {len(c)} concentrations")
    k = params.delay_steps
    J = max(len(c) - k, 0)
    c_al = align_delay(c, k)
    cbar = moving_baseline(c_al, params.baseline_weight)
    return PreprocessedSignal(
        index=np.arange(J),
        wind=w[:J].copy(),
        concentration=c_al,
        baseline=cbar,
        relative=relative_concentration(c_al, cbar),
        intensity=signal_intensity(c_al, cbar, params.gain, params.min_baseline),
    )


class OnlinePreprocessor:
    """Streaming version of :func:`preprocess`: feed one period at a time.

    Parameters
    ----------
    params : PreprocessorParams
    """

    def __init__(self, params: PreprocessorParams) -> None:
        self.params = params
        self.k = params.delay_steps
        self.reset()

    def reset(self) -> None:
        """Forget every past period."""
        self._winds: deque[np.ndarray] = deque(maxlen=self.k + 1)
        self._i = 0
        self._cbar: float | None = None

    def update(self, concentration: float, wind_readings: ArrayLike) -> PreprocessedSample | None:
        """Add period ``i``; return the aligned record ``j = i - k`` or ``None`` while ``i < k``.

        Parameters
        ----------
        concentration : float
            Raw reading at ``t_i``.
        wind_readings : (M_f, d) array_like, m/s
        """
        r = np.asarray(wind_readings, float)
        if r.ndim == 1:
            r = r[None, :]
        c = float(concentration)
        _check_concentration(np.asarray(c))
        self._winds.append(average_wind(r[None])[0])
        i = self._i
        self._i += 1
        if i < self.k:
            return None
        p = self.params
        prev = c if self._cbar is None else self._cbar
        rel = max(c - prev, 0.0)
        s = p.gain * rel / max(prev, p.min_baseline)
        w = p.baseline_weight
        self._cbar = w * c + (1.0 - w) * prev
        return PreprocessedSample(
            index=i - self.k,
            wind=self._winds[0].copy(),
            concentration=c,
            baseline=self._cbar,
            relative=rel,
            intensity=s,
        )


class SignalPreprocessor:
    """The odor-path paper's pre-processing, batch (:meth:`process`) or streaming (:meth:`online`).

    Parameters
    ----------
    params : PreprocessorParams
    """

    def __init__(self, params: PreprocessorParams | None = None) -> None:
        self.params = params or PreprocessorParams()

    def process(self, concentration: ArrayLike, wind_readings: ArrayLike) -> PreprocessedSignal:
        """Pre-process whole records; see :func:`preprocess`."""
        return preprocess(concentration, wind_readings, self.params)

    def online(self) -> OnlinePreprocessor:
        """A fresh streaming pre-processor with the same parameters."""
        return OnlinePreprocessor(self.params)


class WindAverage:
    """The mean of the last ``n`` anemometer readings of one agent.

    Parameters
    ----------
    n : int
        Readings averaged (>= 1).
    """

    def __init__(self, n: int) -> None:
        if n < 1:
            raise ConfigError("wind_average", "must be >= 1")
        self.n = int(n)
        self._buf: deque[np.ndarray] = deque(maxlen=self.n)

    def add(self, wind: ArrayLike) -> np.ndarray:
        """Add a reading ``(d,)`` m/s; return the mean of the last ``n`` (this one included).

        Raises
        ------
        ConfigError
            If a component of ``wind`` is not finite: a NaN would spoil the next ``n`` means
            and turn the upwind direction into the calm-air fallback without a word.
        """
        w = np.asarray(wind, float)
        if not np.all(np.isfinite(w)):
            raise ConfigError("wind", f"every component must be finite, got {w}")
        self._buf.append(w)
        return self.mean

    @property
    def mean(self) -> np.ndarray:
        """Mean of the stored readings, ``(d,)`` m/s."""
        return np.mean(self._buf, axis=0)

    def upwind(self, fallback_heading: float) -> np.ndarray:
        """Horizontal unit vector against the mean wind (``fallback_heading`` rad in calm air)."""
        return upwind_unit(self.mean, fallback_heading)
