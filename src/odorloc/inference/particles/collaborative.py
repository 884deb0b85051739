"""Collaborative particle-filter weights: the confidence factor and the Col-PF update.

Multi-UAV paper (MUC-OSL), Sect. III.3 and IV.1-2:

- each UAV fits a Gaussian ``G(mu_i, Sigma_i)`` to its weighted particles (eqs. 19-20,
  :func:`~odorloc.inference.weights.gaussian_fit`) and sends it to its neighbours;
- the *confidence factor* of neighbour ``j`` for UAV ``i`` is
  ``beta_ij = exp(-KL(P_i || P_j))`` (eq. 10), the KL divergence taken in closed form between
  the two fits (:func:`~odorloc.inference.weights.kl_gaussian`); it lies in ``(0, 1]`` and is 1
  for identical fits;
- the weight update (eq. 13) multiplies the prior weight by the own likelihood and by every
  neighbour's likelihood raised to its ``beta``:
  ``w~_n = w_n p(d_i | o_n) prod_j p(d_j | o_n)^beta_ij``, then normalises (eq. 14). In log
  space this is ``log w += ll_i + sum_j beta_ij ll_j``.

The neighbour's likelihood ``p(d_j | o_n)`` needs its measurement ``d_j`` and where it was taken;
:class:`FitMessage` (built by :func:`fit_payload`) is the message that carries both beside the
fit. The baselines' filters send :class:`ParticleSetMessage` (collaborative infotaxis shares the
particle set) or :class:`MeasurementMessage`. Every one is a frozen payload of float64 numbers
whose size is declared: ``nbytes = 8 x numbers``, with ``numbers`` counted as the paper counts
them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.types import Payload, frozen_array
from odorloc.inference.weights import kl_gaussian, kl_gaussians

__all__ = [
    "FitMessage",
    "MeasurementMessage",
    "NeighbourFit",
    "ParticleSetMessage",
    "TeamMessage",
    "collaborative_log_likelihood",
    "confidence_factor",
    "confidence_factors",
    "fit_payload",
    "read_fit_payload",
]


def confidence_factor(
    mean_i: np.ndarray, cov_i: np.ndarray, mean_j: np.ndarray, cov_j: np.ndarray
) -> float:
    """``beta_ij = exp(-KL(G_i || G_j))`` between two Gaussian fits (eqs. 10, 19-20).

    Parameters
    ----------
    mean_i, mean_j : (d,) ndarray, metres
        Means of UAV ``i``'s and neighbour ``j``'s fits.
    cov_i, cov_j : (d, d) ndarray, m^2
        Their covariances.

    Returns
    -------
    float
        In ``(0, 1]`` (0 only through underflow for fits far apart), 1 for identical fits.
    """
    kl = kl_gaussian(mean_i, cov_i, mean_j, cov_j)
    # KL >= 0 in exact arithmetic; round-off may leave -1e-12
    return math.exp(-max(kl, 0.0))


def confidence_factors(
    mean_i: np.ndarray, cov_i: np.ndarray, means: np.ndarray, covs: np.ndarray
) -> np.ndarray:
    """:func:`confidence_factor` of UAV ``i``'s fit against each of ``H`` neighbours' fits.

    Parameters
    ----------
    mean_i : (d,) ndarray, metres
    cov_i : (d, d) ndarray, m^2
    means : (H, d) ndarray, metres
    covs : (H, d, d) ndarray, m^2

    Returns
    -------
    (H,) ndarray
        ``beta_ij`` (eq. 10), the same numbers as one :func:`confidence_factor` per neighbour.
    """
    if len(means) == 0:
        return np.zeros(0)
    kl = kl_gaussians(mean_i, cov_i, means, covs)
    return np.array([math.exp(-max(v, 0.0)) for v in kl])


def collaborative_log_likelihood(
    own: np.ndarray, neighbours: np.ndarray, betas: np.ndarray
) -> np.ndarray:
    """Log of the Col-PF weight factor ``p(d_i | o) prod_j p(d_j | o)^beta_ij`` (eq. 13), ``(N,)``.

    Parameters
    ----------
    own : (N,) ndarray
        ``log p(d_i | o_n)``, the UAV's own measurement.
    neighbours : (H, N) ndarray
        ``log p(d_j | o_n)`` of each neighbour's measurement (``H`` may be 0).
    betas : (H,) ndarray
        Confidence factors ``beta_ij`` in ``[0, 1]``.
    """
    ll = np.asarray(own, float)
    nb = np.asarray(neighbours, float).reshape(-1, ll.size) if np.size(neighbours) else None
    b = np.asarray(betas, float).reshape(-1)
    if nb is None:
        nb = np.zeros((0, ll.size))
    if len(b) != len(nb):
        raise ConfigError("betas", f"{len(b)} confidence factors for {len(nb)} neighbours")
    if np.any(b < 0) or np.any(b > 1):
        raise ConfigError("betas", "confidence factors must lie in [0, 1]")
    if not len(b):
        return ll.copy()
    # 0 * -inf must count as 0: a neighbour that is not trusted at all contributes nothing
    trusted = b > 0
    if not trusted.any():
        return ll.copy()
    return ll + b[trusted] @ nb[trusted]


@dataclass(frozen=True)
class NeighbourFit:
    """What a Col-PF message tells a neighbour.

    Attributes
    ----------
    sender : int
        The sending agent.
    mean : (d,) ndarray, metres
        Mean of its particles (its source estimate, eq. 19).
    cov : (d, d) ndarray, m^2
        Covariance of its particles (eq. 20).
    count : float
        Its latest measurement ``d_j`` (encounters).
    position : (d,) ndarray, metres
        Where it took that measurement.
    cue_captured : bool
        Whether it has captured any cue so far (col-pu, eq. 17).
    """

    sender: int
    mean: np.ndarray
    cov: np.ndarray
    count: float
    position: np.ndarray
    cue_captured: bool


class TeamMessage(Payload):
    """A payload of float64 numbers: ``numbers`` of them, ``8 x numbers`` bytes."""

    @property
    def numbers(self) -> int:
        """Numbers sent (what the multi-UAV paper counts per message)."""
        raise NotImplementedError

    @property
    def nbytes(self) -> int:
        return 8 * self.numbers


@dataclass(frozen=True, eq=False)
class MeasurementMessage(TeamMessage):
    """One measurement: the count ``d_j`` (encounters), where it was taken (``(d,)``, metres)
    and whether the sender has captured a cue so far: ``d + 2`` numbers."""

    count: float
    position: np.ndarray
    cue_captured: bool

    def __post_init__(self) -> None:
        object.__setattr__(self, "count", float(self.count))
        object.__setattr__(self, "position", frozen_array(np.ravel(self.position)))
        object.__setattr__(self, "cue_captured", bool(self.cue_captured))

    @property
    def numbers(self) -> int:
        return int(self.position.size) + 2


@dataclass(frozen=True, eq=False)
class FitMessage(TeamMessage):
    """The Col-PF message: the Gaussian fit of the sender's particles (mean ``(d,)`` m,
    covariance ``(d, d)`` m^2; eqs. 19-20: ``d + d^2`` numbers, 12 in 3-D, as the paper counts
    it) and the measurement the neighbour's likelihood needs (``d + 2``). A 3-D message is 17
    numbers = 136 bytes."""

    mean: np.ndarray
    cov: np.ndarray
    measurement: MeasurementMessage

    def __post_init__(self) -> None:
        m = frozen_array(np.ravel(self.mean))
        object.__setattr__(self, "mean", m)
        object.__setattr__(self, "cov", frozen_array(np.reshape(self.cov, (m.size, m.size))))

    @property
    def numbers(self) -> int:
        d = int(self.mean.size)
        return d + d * d + self.measurement.numbers


@dataclass(frozen=True, eq=False)
class ParticleSetMessage(TeamMessage):
    """A whole particle set: positions ``(N, d)`` (metres) and weights ``(N,)``:
    ``N (d + 1)`` numbers."""

    positions: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "positions", frozen_array(self.positions))
        object.__setattr__(self, "weights", frozen_array(np.ravel(self.weights)))

    @property
    def numbers(self) -> int:
        return int(self.positions.size + self.weights.size)


def fit_payload(
    mean: np.ndarray, cov: np.ndarray, count: float, position: np.ndarray, cue_captured: bool
) -> FitMessage:
    """The Col-PF message (:class:`FitMessage`) of a fit and the last measurement."""
    return FitMessage(mean, cov, MeasurementMessage(count, position, cue_captured))


def read_fit_payload(sender: int, payload: Payload) -> NeighbourFit:
    """What a :class:`FitMessage` tells a neighbour; :class:`ConfigError` for another payload
    or one whose parts do not fit together."""
    if not isinstance(payload, FitMessage):
        raise ConfigError("message", f"agent {sender} sent no Gaussian fit")
    d, meas = payload.mean.size, payload.measurement
    if meas.position.size != d:
        raise ConfigError(
            "message", f"agent {sender}: fit in {d}-D, position in {meas.position.size}-D"
        )
    return NeighbourFit(
        sender=int(sender),
        mean=payload.mean.copy(),
        cov=payload.cov.copy(),
        count=meas.count,
        position=meas.position.copy(),
        cue_captured=meas.cue_captured,
    )
