"""The isotropic lattice hit model of infotaxis, the lattice problem's constants, and any
translation-invariant measurement model tabulated over lattice offsets.

Isotropic hits (Vergassola, Villermaux & Shraiman 2007; Loisy & Eloy 2022, the OTTO package)
----------------------------------------------------------------------------------------------
An agent of radius ``a = dx / 2`` (``dx`` the lattice step, the agent's move) at distance ``d``
from a source in still air receives, during one step, a Poisson number of odor hits of mean

    2-D: ``mu(d) = I K0(d / lambda) / ln(lambda / a)``,
    3-D: ``mu(d) = I a exp(-d / lambda) / d``,

with ``lambda`` the dispersion length and ``I = R dt`` the source intensity (emission rate times
the step time). This is the Vergassola rate (:func:`~odorloc.models.vergassola.vergassola_rate`)
at zero wind with ``lambda = sqrt(D tau)``, sensor radius ``a`` and exposure ``dt``; it is
evaluated through that function. Hits are *censored*: the classes are ``0, ..., Z - 2`` and
``Z - 1 or more``, with ``Z = ceil(mu(dx) + sqrt(mu(dx))) + 1`` (OTTO's automatic choice).

The lattice problem (OTTO's POMDP)
----------------------------------
:func:`initial_hit_probabilities` is the law of the first hit ``h0 >= 1`` of an episode (hits on
radial shells of an unbounded domain), :func:`initial_belief` the prior after it,
:func:`auto_grid_size` and :func:`auto_step_cap` OTTO's automatic grid size and step cap.

Offset tables
-------------
:func:`tabulate` evaluates any translation-invariant model (one whose outcome law depends on the
source-minus-sensor offset only: the lattice model, the Vergassola model in a uniform wind, ...)
once over all offsets of a cell lattice. Grid filters and planners then read a reading's
likelihood, or a candidate move's outcome law over every cell, as a slice of the table instead of
evaluating the model again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field
from scipy.special import gammaln, xlogy

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.models.base import BoundModel, MeasurementModel
from odorloc.models.poisson import MAX_CLASSES, censored_poisson
from odorloc.models.vergassola import vergassola_rate

__all__ = [
    "IsotropicHitModel",
    "IsotropicHitParams",
    "OffsetTable",
    "auto_grid_size",
    "auto_n_hits",
    "auto_step_cap",
    "initial_belief",
    "initial_hit_probabilities",
    "isotropic_mean_hits",
    "shell_weights",
    "tabulate",
]

FloatArray = NDArray[np.float64]


def isotropic_mean_hits(
    distance: ArrayLike, length: float, intensity: ArrayLike, cell: float, dim: int
) -> FloatArray:
    """Mean hits per step ``mu(d)`` at distances ``d`` (metres) from the source.

    Parameters
    ----------
    distance : array_like, metres
        Any shape; distances below ``a = cell / 2`` are read as ``a`` (the formula diverges at the
        source; a hypothesis on the sensor is excluded by the search itself).
    length : float, metres
        Dispersion length ``lambda``.
    intensity : float or array_like broadcasting with ``distance``
        ``I = R dt``, the mean emission per step.
    cell : float, metres
        Lattice step ``dx``.
    dim : {2, 3}

    Returns
    -------
    ndarray
        ``mu``, the shape of ``distance`` broadcast with ``intensity``.
    """
    d = np.asarray(distance, float)
    flat = d.reshape(-1)
    pts = np.zeros((flat.size, dim))
    pts[:, 0] = flat
    # The Vergassola rate in still air: lambda = sqrt(D tau) with D = 1, tau = lambda^2.
    rate = vergassola_rate(
        pts, np.zeros((1, dim)), 1.0, V=0.0, D=1.0, tau=length * length, a=0.5 * cell
    )[:, 0]
    return np.asarray(intensity, float) * rate.reshape(d.shape)


def auto_n_hits(length: float, intensity: float, cell: float, dim: int) -> int:
    """OTTO's number of hit classes, ``ceil(mu(dx) + sqrt(mu(dx))) + 1``."""
    m1 = float(isotropic_mean_hits(cell, length, intensity, cell, dim))
    return math.ceil(m1 + math.sqrt(m1)) + 1


def _ball_volume(r: np.ndarray, dim: int) -> np.ndarray:
    return np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3


def shell_weights(
    length: float, intensity: float, cell: float, dim: int, n_hits: int
) -> tuple[np.ndarray, np.ndarray]:
    """Radii ``r = 1 .. floor(1000 lambda / dx) - 1`` (cells) and the weights
    ``w_h(r) = P(h | mu(r)) [V(r + 1/2) - V(r - 1/2)]``, ``(n_hits, R)``.

    The hits a searcher would receive from sources spread uniformly over an unbounded domain,
    shell by shell (OTTO's construction of the initial hit and of the grid size).
    """
    r = np.arange(1, int(1000.0 * length / cell), dtype=float)
    shell = _ball_volume(r + 0.5, dim) - _ball_volume(r - 0.5, dim)
    mu = isotropic_mean_hits(r * cell, length, intensity, cell, dim)
    p = censored_poisson(mu, n_hits)  # (R, Z)
    return r, (p * shell[:, None]).T


def initial_hit_probabilities(
    length: float, intensity: float, cell: float, dim: int, n_hits: int
) -> FloatArray:
    """Law of the first hit ``h0 >= 1`` of an episode, ``(n_hits,)`` (class 0 has probability 0).

    ``P(h0 = h) ∝ sum_r P(h | mu(r)) [V(r + 1/2) - V(r - 1/2)]`` for ``h >= 1``.
    """
    return _initial_hit_probabilities(
        float(length), float(intensity), float(cell), int(dim), int(n_hits)
    ).copy()


@lru_cache(maxsize=64)
def _initial_hit_probabilities(
    length: float, intensity: float, cell: float, dim: int, n_hits: int
) -> FloatArray:
    _, w = shell_weights(length, intensity, cell, dim, n_hits)
    p = np.maximum(w.sum(axis=1), 0.0)
    p[0] = 0.0
    return p / p.sum()


def auto_grid_size(
    length: float, intensity: float, cell: float, dim: int, n_hits: int, p_out: float = 1e-3
) -> int:
    """OTTO's lattice size ``N`` (odd): after any first hit, the source lies outside the ball of
    radius ``(N - 1) / 2`` cells with probability below ``p_out`` (unbounded domain)."""
    r, w = shell_weights(length, intensity, cell, dim, n_hits)
    size = 0
    for h in range(1, n_hits):
        cdf = np.cumsum(w[h])
        cdf /= cdf[-1]
        k = int(np.argmax(1.0 - cdf < p_out))
        size = max(size, 2 * int(r[k]) + 1)
    return size


def auto_step_cap(length: float, intensity: float, cell: float, dim: int, grid_size: int) -> int:
    """OTTO's step cap (``n >= 2``).

    With ``mu0 = mu(lambda)`` and ``L = lambda / dx``: ``10 N^n`` if ``mu0 < 1e-3``,
    ``round(5 10^n L / sqrt(mu0))`` if ``mu0 < 1``, else ``round(5 10^n L)``.
    """
    mu0 = float(isotropic_mean_hits(length, length, intensity, cell, dim))
    L = length / cell
    if mu0 < 1e-3:
        return int(10 * grid_size**dim)
    if mu0 < 1.0:
        return round(5 * 10**dim * L / math.sqrt(mu0))
    return round(5 * 10**dim * L)


def initial_belief(
    likelihood: np.ndarray, start_index: tuple[int, ...], free: np.ndarray | None = None
) -> FloatArray:
    """Prior after the first hit: ``b0 ∝ P(h0 | cell)`` over free cells, 0 on the start cell.

    Parameters
    ----------
    likelihood : (n1, ..., nd) ndarray
        ``P(h0 | source in cell)``.
    start_index : tuple of int
        Cell of the searcher.
    free : bool ndarray, optional
        Cells that may hold the source (default all).
    """
    b = np.array(likelihood, float)
    if free is not None:
        b = np.where(free, b, 0.0)
    b[start_index] = 0.0
    total = b.sum()
    if not total > 0:
        raise ConfigError("initial_hit", "no cell is compatible with the first hit")
    return b / total


class IsotropicHitParams(Params):
    """Parameters of :class:`IsotropicHitModel`.

    Attributes
    ----------
    length : float, metres
        Dispersion length ``lambda`` (at least one lattice step: ``length >= cell``).
    intensity : float
        ``I = R dt``: mean emission per step (OTTO's ``R_dt``).
    cell : float, metres
        Lattice step ``dx`` (the agent radius is ``dx / 2``).
    n_hits : int, optional
        Number of hit classes ``Z`` (the last holds ``Z - 1`` or more); default OTTO's rule.
    """

    length: Positive = 1.0
    intensity: Positive = 1.0
    cell: Positive = 1.0
    n_hits: int | None = Field(None, ge=2, le=256)


@register("model", "lattice-isotropic", IsotropicHitParams, "censored Poisson hits, still air")
class IsotropicHitModel(MeasurementModel):
    """Censored Poisson hits of the isotropic lattice problem (see the module docstring).

    Conditions: ``release`` (the intensity ``I`` per hypothesis, default the parameter).
    Readings are hit counts; a count of ``Z - 1`` or more falls in the last class.
    """

    Params = IsotropicHitParams

    def __init__(self, params: IsotropicHitParams | None = None) -> None:
        self.params = params or IsotropicHitParams()
        p = self.params
        if p.length < p.cell:
            raise ConfigError("length", f"must be at least one cell ({p.cell:g} m)")

    def n_classes(self, dim: int) -> int:
        """``Z``: the parameter, else OTTO's rule (at most :data:`MAX_CLASSES`)."""
        p = self.params
        if p.n_hits is not None:
            return p.n_hits
        z = auto_n_hits(p.length, p.intensity, p.cell, dim)
        if z > MAX_CLASSES:
            # a strong source makes the rule ask for thousands of classes: (M, Z, N) arrays
            # that take minutes to build
            raise ConfigError(
                "n_hits",
                f"OTTO's rule gives {z} hit classes at intensity {p.intensity:g} (at most "
                f"{MAX_CLASSES}): set n_hits or lower the intensity",
            )
        return z

    def mean_hits(
        self, sensor_positions: ArrayLike, hypotheses: ArrayLike, release: ArrayLike | None = None
    ) -> FloatArray:
        """``mu`` for every (sensor, hypothesis) pair, ``(M, N)``."""
        s = np.atleast_2d(np.asarray(sensor_positions, float))
        h = np.atleast_2d(np.asarray(hypotheses, float))
        if s.shape[1] != h.shape[1] or s.shape[1] not in (2, 3):
            raise ConfigError("hypotheses", f"sensor {s.shape} and hypotheses {h.shape} need d")
        if not np.all(np.isfinite(s)):
            raise ConfigError("sensor_positions", "must be finite")
        q = self.default_release() if release is None else np.broadcast_to(release, (len(h),))
        if release is not None and not (np.all(np.isfinite(q)) and np.all(q >= 0)):
            raise ConfigError("release", "must be finite and >= 0")
        return self.offset_mean_hits(s[:, None, :] - h[None, :, :], np.asarray(q, float))

    def default_release(self) -> float:
        """The intensity of a hypothesis without its own ``release``: ``I``."""
        return self.params.intensity

    def offset_mean_hits(self, offsets: np.ndarray, release: np.ndarray) -> FloatArray:
        """``mu`` at sensor-minus-source ``offsets`` ``(M, N, d)`` (metres) for intensities
        ``release`` (scalar or ``(N,)``), ``(M, N)``: the law's one model-specific part."""
        p = self.params
        d = np.sqrt((offsets**2).sum(axis=2))
        return isotropic_mean_hits(d, p.length, release, p.cell, offsets.shape[2])

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``log P(class of z | hypothesis)`` for one count ``z`` at one position, ``(N,)``."""
        try:
            k = float(z)
        except (TypeError, ValueError):
            k = math.nan
        # math.isfinite first: math.floor raises on an infinite count
        if not (math.isfinite(k) and k >= 0 and k == math.floor(k)):
            raise ConfigError("hits", f"must be a non-negative integer, got {z!r}")
        h = np.atleast_2d(np.asarray(hypotheses, float))
        zc = self.n_classes(h.shape[1])
        mu = self.mean_hits(np.atleast_2d(sensor_position), h, conditions.get("release"))[0]
        c = min(int(k), zc - 1)
        if c < zc - 1:
            return xlogy(c, mu) - mu - gammaln(c + 1.0)
        with np.errstate(divide="ignore"):
            return np.log(censored_poisson(mu, zc)[:, -1])

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """Probabilities of the ``Z`` hit classes, ``(M, Z, N)``."""
        h = np.atleast_2d(np.asarray(hypotheses, float))
        mu = self.mean_hits(sensor_positions, h, conditions.get("release"))
        return np.moveaxis(censored_poisson(mu, self.n_classes(h.shape[1])), -1, 1)

    def outcome_values(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """Hit count of each class, ``(Z,)`` (the last stands for its lower bound); ``Z`` as
        :meth:`outcome_probabilities` has it (OTTO's rule depends on the dimension of the
        hypotheses)."""
        h = np.atleast_2d(np.asarray(hypotheses, float))
        return np.arange(self.n_classes(h.shape[1]))


# ---------------------------------------------------------------------- offset tables
@dataclass(frozen=True, eq=False)
class OffsetTable:
    """A translation-invariant model tabulated over the offsets of a cell lattice.

    Entry ``[z, k_1, ..., k_d]`` is ``P(class z | source at sensor + (k - half) * cell)``: the
    offsets run from ``-half`` to ``+half`` cells per axis, which covers every (sensor cell,
    source cell) pair of a grid of ``half + 1`` cells per axis.

    Attributes
    ----------
    cell : (d,) ndarray, metres
    half : tuple of int
        Largest offset per axis, cells.
    prob : (Z, 2 half_1 + 1, ..., 2 half_d + 1) ndarray
        Outcome probabilities (every offset sums to one over ``Z``).
    log_prob : same shape
        Their logarithms (``-inf`` where a class is impossible).
    cond_entropy : (2 half_1 + 1, ...) ndarray, nats
        Entropy of the outcome at each offset, ``-sum_z P log P``.
    """

    cell: np.ndarray
    half: tuple[int, ...]
    prob: np.ndarray
    log_prob: np.ndarray
    cond_entropy: np.ndarray

    @property
    def n_classes(self) -> int:
        """Number of outcome classes ``Z``."""
        return int(self.prob.shape[0])

    @property
    def dim(self) -> int:
        """Number of axes."""
        return len(self.half)

    def offsets(self) -> np.ndarray:
        """``(2 half + 1, ..., d)`` offsets of the entries, metres."""
        axes = [np.arange(-h, h + 1) * c for h, c in zip(self.half, self.cell, strict=True)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)

    def window(self, sensor: tuple[int, ...], shape: tuple[int, ...]) -> tuple[slice, ...]:
        """Index of the table entries of a sensor in cell ``sensor`` over a grid of ``shape``.

        ``table.prob[(slice(None), *window)]`` is ``P(z | source in cell x)`` for every cell
        ``x`` of the grid, ``(Z, *shape)``; the sensor cell may lie outside the grid as long as
        every offset stays inside the table (else :class:`ConfigError`).
        """
        out = []
        for a, (s, n, h) in enumerate(zip(sensor, shape, self.half, strict=True)):
            lo = h - int(s)
            if lo < 0 or lo + n > 2 * h + 1:
                raise ConfigError("sensor", f"cell {tuple(sensor)} is beyond the table (axis {a})")
            out.append(slice(lo, lo + n))
        return tuple(out)

    def covers(self, sensor: tuple[int, ...], shape: tuple[int, ...]) -> bool:
        """``True`` when :meth:`window` of ``sensor`` over ``shape`` stays inside the table."""
        return all(
            h - int(s) >= 0 and h - int(s) + n <= 2 * h + 1
            for s, n, h in zip(sensor, shape, self.half, strict=True)
        )


def tabulate(
    model: MeasurementModel | BoundModel,
    cell: ArrayLike,
    half: tuple[int, ...],
    **conditions: Any,
) -> OffsetTable:
    """Tabulate a translation-invariant model over lattice offsets (see :class:`OffsetTable`).

    Parameters
    ----------
    model : MeasurementModel or BoundModel
        Its outcome law must depend on the source-minus-sensor offset only (the caller's
        assumption; e.g. a uniform wind).
    cell : float or (d,) array_like, metres
    half : tuple of int
        Largest offset per axis, cells (``grid_shape - 1`` covers a whole grid).
    **conditions
        Passed to :meth:`~odorloc.models.base.MeasurementModel.outcome_probabilities`.
    """
    h = tuple(int(v) for v in half)
    if len(h) not in (2, 3) or min(h) < 0:
        raise ConfigError("half", f"needs 2 or 3 non-negative offsets, got {half}")
    c = np.broadcast_to(np.asarray(cell, float), (len(h),)).copy()
    axes = [np.arange(-k, k + 1) * cc for k, cc in zip(h, c, strict=True)]
    hyp = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(h))
    sensor = np.zeros((1, len(h)))
    if isinstance(model, BoundModel):
        q = model.model.outcome_probabilities(sensor, hyp, **{**model.conditions, **conditions})
    else:
        q = model.outcome_probabilities(sensor, hyp, **conditions)
    shape = tuple(2 * k + 1 for k in h)
    prob = np.ascontiguousarray(q[0].reshape((q.shape[1], *shape)))
    if not np.all(np.isfinite(prob)) or np.any(prob < 0):
        raise ConfigError("model", "outcome probabilities must be finite and >= 0")
    with np.errstate(divide="ignore"):
        log_prob = np.log(prob)
    cond = -xlogy(prob, prob).sum(axis=0)
    for a in (c, prob, log_prob, cond):
        a.setflags(write=False)
    return OffsetTable(c, h, prob, log_prob, cond)
