"""Source-term measurement models: a reading's law given a whole source term.

A source term is more than a position: the release rate, the wind speed and direction, the
dispersion and the sensor's background all shape a reading, and several sources add up. A
hypothesis is one row of a matrix ``theta (N, P)`` laid out by a :class:`ThetaLayout`:

==================  ====================================================================
columns             meaning
==================  ====================================================================
``x y [z]``         position of source slot ``k`` (metres), one block per slot
``log_rate``        natural log of its release rate (the plume model's rate unit)
``active``          1.0 / 0.0: whether slot ``k`` holds a source (several slots only)
``speed``           wind speed, m/s (optional; else the measured wind)
``direction``       direction the wind blows towards, rad from +x (optional; else measured)
``log_dispersion``  log of the dispersion factor ``s`` (optional; Gaussian plume: widths
                    times ``s``; Vergassola: diffusivity times ``s``)
``background``      sensor background (optional; reading units, or counts/s)
==================  ====================================================================

:class:`SourceTerms` wraps such a matrix with named views. A :class:`SourceTermModel` is a
:class:`~odorloc.models.base.MeasurementModel` whose hypotheses are source terms (a plain
``(N, d)`` position array is read as single sources of the model's default rate):

- ``ste-gaussian`` (:class:`GaussianSourceTermModel`): the Gaussian plume of
  :mod:`odorloc.models.gaussian` (diffusion, power-law or Pasquill-Gifford widths) and a
  Gaussian reading ``z = b + gain C + eps``, ``eps ~ N(0, sigma_a^2 + (sigma_r gain C)^2)``,
  censored below the detection threshold ``t`` (:class:`ReadingLaw`): a reading under ``t``
  only says ``z < t``, ``p = Phi((t - m) / sigma)`` (Tobin 1958), and a source may be missed
  (intermittency) with probability ``miss``, ``p = miss + (1 - miss) Phi(...)`` below the
  threshold and ``(1 - miss) N(z; m, sigma^2)`` above; or, with ``reading="detection"``, only
  the binary detection, ``p(1) = fa + (1 - fa - miss) Phi((m - t) / sigma)``;
- ``ste-vergassola`` (:class:`VergassolaSourceTermModel`): Poisson encounter counts at the
  Vergassola rate (eqs. 1-3, muc-osl-multi-uav paper), plus a background count rate;
- ``ste-adapter`` (:class:`AdapterSourceTermModel`): any registered model that accepts one
  release rate per hypothesis (the ``release`` condition), for position and rate only.

The readings of a whole history are summed by :meth:`SourceTermModel.log_likelihood_sum`
(compiled loops for the first two, :mod:`odorloc.models.source_term_kernels`).
"""

from __future__ import annotations

import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field
from scipy.special import gammainc, gammaln, log_ndtr, ndtr

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Observation, SensorInfo
from odorloc.models import source_term_kernels as kern
from odorloc.models.base import MeasurementModel
from odorloc.models.gaussian import GaussianParams, gaussian_plume_matrix
from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import vergassola_rate_matrix

__all__ = [
    "AdapterSourceTermModel",
    "GaussianSourceTermModel",
    "GaussianSourceTermParams",
    "ReadingLaw",
    "SourceTermModel",
    "SourceTerms",
    "ThetaLayout",
    "VergassolaSourceTermModel",
    "VergassolaSourceTermParams",
    "as_terms",
]

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_CHUNK = 1 << 20  # entries of a (T, N) block evaluated at once on the NumPy path


# ---------------------------------------------------------------------- layout
@dataclass(frozen=True)
class ThetaLayout:
    """Column layout of a source-term matrix (see the module docstring).

    Attributes
    ----------
    dim : int
        2 or 3.
    slots : int
        Source slots (1: a single source, always active).
    speed, direction, dispersion, background : bool
        Which shared components are estimated.
    """

    dim: int
    slots: int = 1
    speed: bool = False
    direction: bool = False
    dispersion: bool = False
    background: bool = False

    def __post_init__(self) -> None:
        if self.dim not in (2, 3):
            raise ConfigError("dim", f"must be 2 or 3, got {self.dim}")
        if not 1 <= self.slots <= 16:
            raise ConfigError("max_sources", f"must be in [1, 16], got {self.slots}")

    @property
    def block(self) -> int:
        """Columns per slot besides its flag: position and log rate."""
        return self.dim + 1

    def position_columns(self, k: int = 0) -> slice:
        """Columns of slot ``k``'s position."""
        return slice(k * self.block, k * self.block + self.dim)

    def log_rate_column(self, k: int = 0) -> int:
        """Column of slot ``k``'s log release rate."""
        return k * self.block + self.dim

    @property
    def active_start(self) -> int:
        """First activity-flag column (``-1`` for a single slot)."""
        return self.slots * self.block if self.slots > 1 else -1

    def _shared(self) -> list[str]:
        return [
            n
            for n, on in (
                ("speed", self.speed),
                ("direction", self.direction),
                ("log_dispersion", self.dispersion),
                ("background", self.background),
            )
            if on
        ]

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names (``x0, y0, log_rate0, ...`` for several slots)."""
        axes = "xyz"[: self.dim]
        if self.slots == 1:
            names = [*axes, "log_rate"]
        else:
            names = [f"{a}{k}" for k in range(self.slots) for a in (*axes, "log_rate")]
            names += [f"active{k}" for k in range(self.slots)]
        return (*names, *self._shared())

    @property
    def n_columns(self) -> int:
        """``P``."""
        return len(self.columns)

    def column(self, name: str) -> int:
        """Index of a named column, ``-1`` if absent."""
        cols = self.columns
        return cols.index(name) if name in cols else -1

    @property
    def continuous(self) -> np.ndarray:
        """Indices of the columns a random walk moves (all but the activity flags)."""
        flags = set(range(self.active_start, self.active_start + self.slots))
        return np.array([i for i in range(self.n_columns) if i not in flags or self.slots == 1])

    def kernel_columns(self) -> np.ndarray:
        """``[active_start, speed, direction, log_dispersion, background]`` (``-1``: absent),
        as the compiled loops take them."""
        return np.array(
            [
                self.active_start,
                self.column("speed"),
                self.column("direction"),
                self.column("log_dispersion"),
                self.column("background"),
            ],
            np.int64,
        )


@dataclass(frozen=True, eq=False)
class SourceTerms:
    """``N`` source-term hypotheses: a matrix ``theta (N, P)`` and its layout."""

    theta: np.ndarray
    layout: ThetaLayout

    def __post_init__(self) -> None:
        th = np.asarray(self.theta, float)
        if th.ndim != 2 or th.shape[1] != self.layout.n_columns:
            raise ConfigError(
                "hypotheses", f"expected shape (N, {self.layout.n_columns}), got {th.shape}"
            )
        object.__setattr__(self, "theta", th)

    @staticmethod
    def single(positions: np.ndarray, rate: float | np.ndarray) -> SourceTerms:
        """Single sources at ``(N, d)`` positions with rate(s) ``rate``."""
        pos = np.atleast_2d(np.asarray(positions, float))
        lq = np.log(np.broadcast_to(np.asarray(rate, float), (len(pos),)))
        return SourceTerms(np.column_stack([pos, lq]), ThetaLayout(pos.shape[1]))

    def __len__(self) -> int:
        return len(self.theta)

    @property
    def positions(self) -> np.ndarray:
        """``(N, K, d)`` metres."""
        lay = self.layout
        return np.stack([self.theta[:, lay.position_columns(k)] for k in range(lay.slots)], 1)

    @property
    def log_rates(self) -> np.ndarray:
        """``(N, K)``."""
        lay = self.layout
        return self.theta[:, [lay.log_rate_column(k) for k in range(lay.slots)]]

    @property
    def rates(self) -> np.ndarray:
        """``(N, K)`` release rates."""
        return np.exp(self.log_rates)

    @property
    def active(self) -> np.ndarray:
        """``(N, K)`` bool: which slots hold a source."""
        lay = self.layout
        if lay.slots == 1:
            return np.ones((len(self.theta), 1), bool)
        return self.theta[:, lay.active_start : lay.active_start + lay.slots] > 0.5

    def _col(self, name: str) -> np.ndarray | None:
        c = self.layout.column(name)
        return None if c < 0 else self.theta[:, c]

    @property
    def speed(self) -> np.ndarray | None:
        """``(N,)`` wind speed, m/s, or ``None`` (measured)."""
        return self._col("speed")

    @property
    def direction(self) -> np.ndarray | None:
        """``(N,)`` direction the wind blows towards, rad, or ``None`` (measured)."""
        return self._col("direction")

    @property
    def dispersion(self) -> np.ndarray | None:
        """``(N,)`` dispersion factor ``s`` (not its log), or ``None`` (1)."""
        c = self._col("log_dispersion")
        return None if c is None else np.exp(c)

    @property
    def background(self) -> np.ndarray | None:
        """``(N,)`` sensor background, or ``None`` (the model's)."""
        return self._col("background")

    def subset(self, index: Any) -> SourceTerms:
        """The hypotheses ``theta[index]``."""
        return SourceTerms(self.theta[index], self.layout)


def as_terms(hypotheses: Any, rate: float) -> SourceTerms:
    """``hypotheses`` as :class:`SourceTerms`: a plain ``(N, d)`` array gives single sources of
    release rate ``rate``."""
    if isinstance(hypotheses, SourceTerms):
        return hypotheses
    h = np.atleast_2d(np.asarray(hypotheses, float))
    if h.shape[1] not in (2, 3):
        raise ConfigError("hypotheses", f"expected (N, 2|3) positions, got {h.shape}")
    return SourceTerms.single(h, rate)


def _points(sensor_positions: Any, dim: int) -> np.ndarray:
    s = np.atleast_2d(np.asarray(sensor_positions, float))
    if s.shape[1] != dim or not np.all(np.isfinite(s)):
        raise ConfigError("sensor_positions", f"need {dim} finite components, got {s.shape}")
    return s


# ---------------------------------------------------------------------- reading laws
class ReadingLaw:
    """The law of one concentration reading around its predicted mean (module docstring).

    Parameters
    ----------
    kind : {"censored", "gaussian", "detection"}
        Censored analogue readings, uncensored ones, or binary detections.
    noise_std : float
        ``sigma_a``, reading units.
    relative_noise : float
        ``sigma_r``: noise proportional to the plume's part of the mean.
    threshold : float
        Detection threshold ``t``, reading units.
    background : float
        ``b``, the clean-air reading.
    miss : float
        Probability that a source's signal is not seen at all (intermittency).
    false_alarm : float
        ``detection`` only: probability of a detection without signal beyond the noise's.
    """

    CODES: ClassVar[dict[str, int]] = {"gaussian": 0, "censored": 1, "detection": 2}

    def __init__(
        self,
        kind: str,
        noise_std: float,
        relative_noise: float,
        threshold: float,
        background: float,
        miss: float,
        false_alarm: float,
    ) -> None:
        self.kind = kind
        self.code = self.CODES[kind]
        self.noise_std = float(noise_std)
        self.relative_noise = float(relative_noise)
        self.threshold = float(threshold)
        self.background = float(background)
        self.miss = float(miss)
        self.false_alarm = float(false_alarm)

    def sd(self, signal: np.ndarray) -> np.ndarray:
        """``sqrt(sigma_a^2 + (sigma_r signal)^2)``."""
        rel = self.relative_noise * signal
        return np.sqrt(self.noise_std**2 + rel * rel)

    def log_prob(self, z: np.ndarray, signal: np.ndarray, bg: np.ndarray | None) -> np.ndarray:
        """``log p(z | mean)``, broadcast over ``z (T, 1)`` and the signal ``gain C (T, N)``;
        ``bg`` the background of each hypothesis (``None``: the law's)."""
        m = signal + (self.background if bg is None else bg)
        sd = self.sd(signal)
        if self.code == 2:
            x = (m - self.threshold) / sd
            one = z > 0.5
            live = 1.0 - self.false_alarm - self.miss
            return np.log(
                np.where(one, self.false_alarm + live * ndtr(x), self.miss + live * ndtr(-x))
            )
        r = (z - m) / sd
        dens = -0.5 * r * r - np.log(sd) - _LOG_SQRT_2PI
        if self.code == 0:
            return dens
        below = z < self.threshold
        with np.errstate(divide="ignore"):
            cens = log_ndtr((self.threshold - m) / sd)
            if self.miss > 0:
                cens = np.logaddexp(math.log(self.miss), math.log1p(-self.miss) + cens)
                dens = dens + math.log1p(-self.miss)
        return np.where(below, cens, dens)

    def classes(
        self, signal: np.ndarray, bg: np.ndarray | None, width: float, max_classes: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Outcome classes for planning: probabilities ``(M, Z, N)`` and class values ``(Z,)``.

        ``detection``: ``[no detection, detection]``. Otherwise class 0 is "below the
        threshold" and the others are bins of ``width`` above it, the last one open; ``Z`` is
        the fewest bins reaching 4 sigma above the largest mean (at most ``max_classes``), so
        that every candidate's discretised reading has the same resolution.
        """
        m = signal + (self.background if bg is None else bg)
        sd = self.sd(signal)
        if self.code == 2:
            x = (m - self.threshold) / sd
            live = 1.0 - self.false_alarm - self.miss
            p1 = self.false_alarm + live * ndtr(x)
            return np.stack([1.0 - p1, p1], axis=1), np.array([0.0, 1.0])
        top = float(np.max(m + 4.0 * sd)) if m.size else self.threshold
        n_bins = int(np.clip(math.ceil((top - self.threshold) / width), 1, max_classes - 1))
        edges = self.threshold + width * np.arange(n_bins + 1, dtype=float)
        # most hypotheses send (next to) no signal to most candidates: one law serves them all
        # (a mean within 1e-9 sigma of the background moves no class by more than 4e-10)
        quiet = signal < 1e-9 * self.noise_std if bg is None else np.zeros(m.shape, bool)
        row = self.class_rows(np.array([self.background]), np.array([self.noise_std]), edges)[0]
        values = np.concatenate([[self.threshold - 0.5 * width], edges[:-1] + 0.5 * width])
        if kern.HAVE_NUMBA:
            probs = kern.class_probabilities(
                np.ascontiguousarray(m, dtype=float),
                np.ascontiguousarray(np.broadcast_to(sd, m.shape), dtype=float),
                np.ascontiguousarray(quiet),
                row,
                edges,
                self.miss,
                self.code == 1,
            )
            return probs, values
        out = np.empty((*m.shape, n_bins + 1))  # pragma: no cover - numba is a core dependency
        out[quiet] = row
        out[~quiet] = self.class_rows(m[~quiet], np.broadcast_to(sd, m.shape)[~quiet], edges)
        return np.ascontiguousarray(np.moveaxis(out, -1, 1)), values

    def class_rows(self, m: np.ndarray, sd: np.ndarray, edges: np.ndarray) -> np.ndarray:
        """Class probabilities ``(K, Z)`` of ``K`` readings of means ``m`` and deviations
        ``sd``: below the first edge, then between edges, the last bin open above (NumPy; the
        reference of :func:`~odorloc.models.source_term_kernels.class_probabilities`)."""
        cdf = ndtr((edges[None, :] - m[:, None]) / sd[:, None])  # (K, B+1)
        bins = np.diff(cdf, axis=1)
        bins[:, -1] += 1.0 - cdf[:, -1]
        below = cdf[:, :1]
        if self.code == 1:
            keep = 1.0 - self.miss
            below, bins = self.miss + keep * below, keep * bins
        return np.maximum(np.concatenate([below, bins], axis=1), 0.0)


# ---------------------------------------------------------------------- base model
class SourceTermModel(MeasurementModel):
    """A measurement model over source terms (see the module docstring).

    Conditions of a single reading: ``wind`` ``(d,)`` m/s, the measured mean wind (used for
    the components a hypothesis does not carry), and ``dt`` s, the exposure (counts). A
    history passes them per reading to :meth:`log_likelihood_sum`.
    """

    params: Params
    default_rate: float = 1.0

    def with_sensor(self, sensor: SensorInfo) -> SourceTermModel:
        """The model with settings left to the sensor filled in (default: itself)."""
        return self

    def check_layout(self, layout: ThetaLayout) -> None:
        """:class:`ConfigError` if the model cannot evaluate hypotheses of ``layout``."""
        return None

    @abstractmethod
    def reading(self, observation: Observation) -> float:
        """The number the model's law is about (a concentration, a detection, a count)."""

    @abstractmethod
    def log_likelihood_sum(
        self,
        z: np.ndarray,
        points: np.ndarray,
        terms: SourceTerms,
        winds: np.ndarray,
        dts: np.ndarray,
    ) -> np.ndarray:
        """``sum_t log p(z_t | theta_i)`` over ``T`` readings, ``(N,)``.

        Parameters
        ----------
        z : (T,) ndarray
            Readings (:meth:`reading`).
        points : (T, d) ndarray, metres
            Where they were taken.
        terms : SourceTerms
            ``N`` hypotheses.
        winds : (T, d) ndarray, m/s
            Measured mean wind at each reading.
        dts : (T,) ndarray, s
            Exposure of each reading.
        """

    @abstractmethod
    def classes(
        self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Outcome classes of readings at ``(M, d)`` points with measured winds ``(M, d)``:
        probabilities ``(M, Z, N)`` and the reading each class stands for ``(Z,)``."""

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: Any, **conditions: Any
    ) -> np.ndarray:
        return self._classes(sensor_positions, hypotheses, conditions)[0]

    def outcome_values(
        self, sensor_positions: np.ndarray, hypotheses: Any, **conditions: Any
    ) -> np.ndarray:
        return self._classes(sensor_positions, hypotheses, conditions)[1]

    def _classes(
        self, sensor_positions: Any, hypotheses: Any, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray]:
        terms = as_terms(hypotheses, self.default_rate)
        d = terms.layout.dim
        s = _points(sensor_positions, d)
        w = np.broadcast_to(_wind(conditions, d), s.shape)
        return self.classes(s, terms, w, conditions)

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: Any, **conditions: Any
    ) -> np.ndarray:
        terms = as_terms(hypotheses, self.default_rate)
        d = terms.layout.dim
        p = _points(sensor_position, d)[:1]
        zz = np.array([_finite_reading(z)])
        wind = _wind(conditions, d)[None, :]
        return self.log_likelihood_sum(zz, p, terms, wind, np.array([_dt(conditions)]))


def _finite_reading(z: Any) -> float:
    try:
        v = float(z)
    except (TypeError, ValueError):
        raise ConfigError("reading", f"must be a finite number, got {z!r}") from None
    if not math.isfinite(v):
        raise ConfigError("reading", f"must be finite, got {v}")
    return v


def _wind(conditions: dict[str, Any], dim: int) -> np.ndarray:
    w = conditions.get("wind")
    if w is None:
        return np.zeros(dim)
    w = np.asarray(w, float).reshape(-1)
    if w.shape != (dim,) or not np.all(np.isfinite(w)):
        raise ConfigError("wind", f"needs {dim} finite components")
    return w


def _dt(conditions: dict[str, Any]) -> float:
    dt = conditions.get("dt", 1.0)
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ConfigError("dt", f"the exposure time must be a finite number > 0, got {dt}")
    return float(dt)


def _measured(winds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speeds ``(T,)`` and unit horizontal directions ``(T, 2)`` of measured winds (calm air:
    +x, as :func:`~odorloc.models.gaussian.gaussian_plume`)."""
    w = np.asarray(winds, float)
    u = np.hypot(w[:, 0], w[:, 1])
    e = np.zeros((len(w), 2))
    calm = u <= 0
    e[~calm] = w[~calm, :2] / u[~calm, None]
    e[calm] = (1.0, 0.0)
    return u, e


def _wind_of(
    terms: SourceTerms, u_meas: np.ndarray, e_meas: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Speed ``(T, N)|(N,)`` and direction ``(T, N, 2)|(N, 2)`` of each hypothesis at each
    reading: its own components where it has them, the measured wind otherwise."""
    sp, dr = terms.speed, terms.direction
    speed = u_meas[:, None] if sp is None else sp
    direction = e_meas[:, None, :] if dr is None else np.stack([np.cos(dr), np.sin(dr)], axis=-1)
    return np.asarray(speed, float), direction


def _check_history(z: np.ndarray, points: np.ndarray, winds: np.ndarray, dts: np.ndarray) -> int:
    t = len(z)
    if not (points.shape[0] == winds.shape[0] == len(dts) == t):
        raise ConfigError("readings", "readings, positions, winds and exposures differ in number")
    return t


# ---------------------------------------------------------------------- Gaussian plume
class GaussianSourceTermParams(GaussianParams):
    """Parameters of :class:`GaussianSourceTermModel` (the plume's width law, then the law of a
    reading; module docstring).

    Attributes
    ----------
    reading : {"censored", "gaussian", "detection"}
        What a reading is and how it is weighed (:class:`ReadingLaw`).
    noise_std : float
        Absolute noise ``sigma_a`` (reading units).
    relative_noise : float
        Noise proportional to the plume signal, ``sigma_r``.
    threshold : float, optional
        Detection threshold (reading units); default: the gas sensor's.
    background : float
        Clean-air reading ``b`` (when not estimated).
    miss : float
        Probability that the signal is missed at a reading (intermittency).
    false_alarm : float
        ``detection`` only: probability of a detection in clean air beyond the noise's.
    gain : float
        Reading units per concentration unit.
    ground : float, metres
        Floor height (3-D reflection).
    release : float
        Rate of plain position hypotheses (not source terms).
    bin_width : float, optional
        Width of a reading's outcome class for planning (reading units); default
        ``noise_std``.
    max_classes : int
        Most outcome classes of a reading for planning (below the threshold, bins, an open
        last bin).
    """

    reading: Literal["censored", "gaussian", "detection"] = "censored"
    noise_std: Positive = 0.1
    relative_noise: NonNegative = 0.0
    threshold: Finite | None = None
    background: Finite = 0.0
    miss: float = Field(0.0, ge=0.0, lt=1.0)
    false_alarm: float = Field(0.0, ge=0.0, lt=0.5)
    gain: Positive = 1.0
    ground: Finite = 0.0
    release: Positive = 1.0
    bin_width: Positive | None = None
    max_classes: int = Field(48, ge=2, le=256)


_SPREAD = {"diffusion": 0, "power": 1, "pasquill-gifford": 2}


@register("model", "ste-gaussian", GaussianSourceTermParams, "source terms, Gaussian plume")
class GaussianSourceTermModel(SourceTermModel):
    """Censored Gaussian readings around a Gaussian plume over source terms (module docstring).

    ``bin_width`` (default ``noise_std``) and ``max_classes`` discretise a reading for planning
    (:meth:`ReadingLaw.classes`).
    """

    Params = GaussianSourceTermParams

    def __init__(self, params: GaussianSourceTermParams | None = None) -> None:
        self.params = params or GaussianSourceTermParams()
        self.default_rate = self.params.release
        p = self.params
        thr = 0.0 if p.threshold is None else p.threshold
        self.law = ReadingLaw(
            p.reading, p.noise_std, p.relative_noise, thr, p.background, p.miss, p.false_alarm
        )

    def with_sensor(self, sensor: SensorInfo) -> GaussianSourceTermModel:
        """The sensor's threshold where none is given."""
        if self.params.threshold is not None:
            return self
        return GaussianSourceTermModel(
            self.params.model_copy(update={"threshold": float(sensor.threshold)})
        )

    def reading(self, observation: Observation) -> float:
        if self.law.code == 2:
            return 1.0 if observation.detection else 0.0
        return float(observation.gas)

    def signal(self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray) -> np.ndarray:
        """Expected plume part of the readings ``gain C``, ``(T, N)``, for readings at
        ``(T, d)`` points with measured winds ``(T, d)`` (NumPy; the reference of the compiled
        loops)."""
        p = self.params
        u, e = _measured(winds)
        speed, direction = _wind_of(terms, u, e)
        scale = terms.dispersion
        pos, q, act = terms.positions, terms.rates, terms.active
        out = np.zeros((len(points), len(terms)))
        for k in range(terms.layout.slots):
            qk = np.where(act[:, k], q[:, k], 0.0)
            out += gaussian_plume_matrix(
                points, pos[:, k], qk, speed, direction, p, p.ground, scale
            )
        return p.gain * out

    def log_likelihood_reference(
        self, z: np.ndarray, points: np.ndarray, terms: SourceTerms, winds: np.ndarray
    ) -> np.ndarray:
        """:meth:`log_likelihood_sum` in NumPy (the reference of the compiled loop)."""
        out = np.zeros(len(terms))
        step = max(1, _CHUNK // max(1, len(terms)))
        bg = terms.background
        for a in range(0, len(z), step):
            sl = slice(a, a + step)
            sig = self.signal(points[sl], terms, winds[sl])
            out += self.law.log_prob(np.asarray(z[sl], float)[:, None], sig, bg).sum(axis=0)
        return out

    def log_likelihood_sum(
        self,
        z: np.ndarray,
        points: np.ndarray,
        terms: SourceTerms,
        winds: np.ndarray,
        dts: np.ndarray,
    ) -> np.ndarray:
        _check_history(z, points, winds, dts)
        if not kern.HAVE_NUMBA:  # pragma: no cover - numba is a core dependency
            return self.log_likelihood_reference(z, points, terms, winds)
        p, law = self.params, self.law
        u, e = _measured(winds)
        if p.spread == "pasquill-gifford":
            from odorloc.models.gaussian import PG_RURAL, PG_URBAN

            pg = (PG_RURAL if p.terrain == "rural" else PG_URBAN)[p.stability]
        else:
            pg = (0.0, 0.0, 0.0, 0.0, 0.0)
        consts = np.array(
            [
                p.sigma0**2,
                p.K,
                p.a_y,
                p.b_y,
                p.a_z,
                p.b_z,
                *pg,
                p.min_speed,
                p.gain,
                p.ground,
                1.0 if p.ground_reflection else 0.0,
                law.noise_std,
                law.relative_noise,
                law.threshold,
                law.background,
                law.miss,
                law.false_alarm,
            ]
        )
        lay = terms.layout
        return kern.gaussian_history(
            np.ascontiguousarray(terms.theta),
            np.ascontiguousarray(terms.rates),
            lay.slots,
            lay.dim,
            lay.kernel_columns(),
            np.ascontiguousarray(z, dtype=float),
            np.ascontiguousarray(points, dtype=float),
            u,
            np.ascontiguousarray(e),
            _SPREAD[p.spread],
            law.code,
            consts,
        )

    def classes(
        self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray]:
        sig = self.signal(points, terms, winds)
        p = self.params
        width = p.bin_width if p.bin_width is not None else p.noise_std
        return self.law.classes(sig, terms.background, width, p.max_classes)


# ---------------------------------------------------------------------- Vergassola
class VergassolaSourceTermParams(Params):
    """Parameters of :class:`VergassolaSourceTermModel` (defaults: the multi-UAV paper's).

    Attributes
    ----------
    V, D, tau : float
        Wind speed (m/s; when not estimated), diffusivity (m^2/s, times the dispersion factor
        when estimated), particle lifetime (s).
    sensor_radius : float, metres
        Sensor radius ``a``: sets the encounter rate and floors the distance to a source (in
        2-D it must stay below the correlation length ``lambda``).
    background : float, 1/s
        Encounters per second without a source (when not estimated).
    release : float
        Rate of plain position hypotheses.
    max_classes : int
        Count classes for planning at most (the last holds the tail).
    tail_mass : float
        Classes are added until the tail beyond holds less than this.
    """

    V: Positive = 1.0
    D: Positive = 1.0
    tau: Positive = 100.0
    sensor_radius: Positive = 1.0
    background: NonNegative = 0.0
    release: Positive = 5.0
    max_classes: int = Field(16, ge=2, le=256)
    tail_mass: float = Field(1e-6, gt=0.0, lt=1.0)


@register("model", "ste-vergassola", VergassolaSourceTermParams, "source terms, Poisson counts")
class VergassolaSourceTermModel(SourceTermModel):
    """Poisson counts at the Vergassola rate over source terms (eqs. 1-3, muc-osl paper).

    A hypothesis' ``speed`` replaces ``V``, its ``direction`` the measured wind direction
    (horizontal), its dispersion factor multiplies ``D``; ``background`` adds counts/s.
    """

    Params = VergassolaSourceTermParams

    def __init__(self, params: VergassolaSourceTermParams | None = None) -> None:
        self.params = params or VergassolaSourceTermParams()
        self.default_rate = self.params.release

    def reading(self, observation: Observation) -> float:
        return float(observation.gas)

    def rate(self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray) -> np.ndarray:
        """Encounter rates ``(T, N)``, 1/s, at ``(T, d)`` points (NumPy reference)."""
        p = self.params
        d = terms.layout.dim
        _, e = _measured(winds)
        sp, dr = terms.speed, terms.direction
        V = p.V if sp is None else sp
        D = p.D if terms.dispersion is None else p.D * terms.dispersion
        if dr is None:
            direction = np.zeros((len(points), 1, d))
            direction[:, 0, :2] = e
        else:
            direction = np.zeros((len(terms), d))
            direction[:, 0], direction[:, 1] = np.cos(dr), np.sin(dr)
        pos, q, act = terms.positions, terms.rates, terms.active
        out = np.zeros((len(points), len(terms)))
        for k in range(terms.layout.slots):
            qk = np.where(act[:, k], q[:, k], 0.0)
            out += vergassola_rate_matrix(
                points, pos[:, k], qk, V=V, D=D, tau=p.tau, a=p.sensor_radius, direction=direction
            )
        bg = p.background if terms.background is None else terms.background
        return out + bg

    def log_likelihood_reference(
        self,
        z: np.ndarray,
        points: np.ndarray,
        terms: SourceTerms,
        winds: np.ndarray,
        dts: np.ndarray,
    ) -> np.ndarray:
        """:meth:`log_likelihood_sum` in NumPy."""
        out = np.zeros(len(terms))
        step = max(1, _CHUNK // max(1, len(terms)))
        for a in range(0, len(z), step):
            sl = slice(a, a + step)
            mu = self.rate(points[sl], terms, winds[sl]) * np.asarray(dts[sl])[:, None]
            k = np.asarray(z[sl], float)[:, None]
            with np.errstate(divide="ignore"):
                ll = np.where(k > 0, k * np.log(mu), 0.0) - mu - gammaln(k + 1.0)
            out += ll.sum(axis=0)
        return out

    def log_likelihood_sum(
        self,
        z: np.ndarray,
        points: np.ndarray,
        terms: SourceTerms,
        winds: np.ndarray,
        dts: np.ndarray,
    ) -> np.ndarray:
        _check_history(z, points, winds, dts)
        k = np.asarray(z, float)
        if np.any(k < 0) or np.any(k != np.floor(k)):
            raise ConfigError("counts", "must be non-negative integers")
        lay = terms.layout
        if lay.dim == 2 or not kern.HAVE_NUMBA:
            return self.log_likelihood_reference(z, points, terms, winds, dts)
        p = self.params
        _, e = _measured(winds)
        consts = np.array([p.V, p.D, p.tau, p.sensor_radius, p.background])
        return kern.vergassola_history(
            np.ascontiguousarray(terms.theta),
            lay.slots,
            lay.kernel_columns(),
            np.ascontiguousarray(k),
            gammaln(k + 1.0),
            np.ascontiguousarray(points, dtype=float),
            np.ascontiguousarray(e),
            np.ascontiguousarray(dts, dtype=float),
            consts,
        )

    def classes(
        self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray]:
        mu = self.rate(points, terms, winds) * _dt(conditions)
        top = float(mu.max()) if mu.size else 0.0
        p = self.params
        z = p.max_classes
        for n in range(1, p.max_classes):
            if gammainc(n, top) < p.tail_mass:
                z = n + 1
                break
        probs = np.ascontiguousarray(np.moveaxis(censored_poisson(mu, z), -1, 1))
        return probs, np.arange(z, dtype=float)


# ---------------------------------------------------------------------- any model
class AdapterParams(Params):
    """Parameters of :class:`AdapterSourceTermModel`.

    Attributes
    ----------
    model : dict
        The wrapped measurement model, ``{type: name, **params}``; it must take one release
        rate per hypothesis as its ``release`` condition.
    reading : {"gas", "detection", "count"}
        What the wrapped model reads: the analogue reading, the binary detection, or an
        integer count.
    release : float
        Rate of plain position hypotheses.
    """

    model: Ref("model") = ComponentRef(type="gaussian")
    reading: Literal["gas", "detection", "count"] = "gas"
    release: Positive = 1.0


@register("model", "ste-adapter", AdapterParams, "source terms (position, rate) of any model")
class AdapterSourceTermModel(SourceTermModel):
    """Position and release rate with any registered measurement model (module docstring).

    Each reading of a history is one call of the wrapped model's ``log_likelihood`` with the
    hypotheses' positions, ``release`` = their rates, and the reading's ``wind`` and ``dt``:
    general, but not fast. Several sources, wind or dispersion components are refused.
    """

    Params = AdapterParams

    def __init__(self, params: AdapterParams | None = None) -> None:
        self.params = params or AdapterParams()
        self.default_rate = self.params.release
        self.inner: MeasurementModel = self.params.model.build("model", field="model.model")

    def check_layout(self, layout: ThetaLayout) -> None:
        if layout.slots > 1 or layout.n_columns != layout.dim + 1:
            raise ConfigError("model", "ste-adapter estimates one source's position and rate only")

    def reading(self, observation: Observation) -> float:
        if self.params.reading == "detection":
            return 1.0 if observation.detection else 0.0
        return float(observation.gas)

    def _z(self, z: float) -> Any:
        kind = self.params.reading
        return bool(z > 0.5) if kind == "detection" else (int(z) if kind == "count" else z)

    def log_likelihood_sum(
        self,
        z: np.ndarray,
        points: np.ndarray,
        terms: SourceTerms,
        winds: np.ndarray,
        dts: np.ndarray,
    ) -> np.ndarray:
        _check_history(z, points, winds, dts)
        self.check_layout(terms.layout)
        pos, q = terms.positions[:, 0], terms.rates[:, 0]
        out = np.zeros(len(terms))
        for zt, st, wt, dt in zip(z, points, winds, dts, strict=True):
            out += self.inner.log_likelihood(
                self._z(float(zt)), st, pos, release=q, wind=wt, dt=float(dt)
            )
        return out

    def classes(
        self, points: np.ndarray, terms: SourceTerms, winds: np.ndarray, conditions: dict[str, Any]
    ) -> tuple[np.ndarray, np.ndarray]:
        self.check_layout(terms.layout)
        cond = {"dt": _dt(conditions), **conditions, "wind": winds[0]}
        pos, q = terms.positions[:, 0], terms.rates[:, 0]
        return (
            self.inner.outcome_probabilities(points, pos, release=q, **cond),
            self.inner.outcome_values(points, pos, release=q, **cond),
        )
