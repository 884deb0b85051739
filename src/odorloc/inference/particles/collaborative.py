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
:func:`fit_payload` is the message that carries both beside the fit, with the conditions
(exposure, wind direction) that reading's likelihood needs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.inference.weights import kl_gaussian, kl_gaussians

__all__ = [
    "NeighbourFit",
    "collaborative_log_likelihood",
    "confidence_factor",
    "confidence_factors",
    "fit_payload",
    "measurement_payload",
    "read_fit_payload",
    "read_measurement_payload",
    "reading_conditions",
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
    dt : float, seconds
        The exposure of that measurement.
    direction : (d,) ndarray or None
        The wind direction its likelihood was evaluated with (``None``: the model's own).
    """

    sender: int
    mean: np.ndarray
    cov: np.ndarray
    count: float
    position: np.ndarray
    cue_captured: bool
    dt: float = 1.0
    direction: np.ndarray | None = None

    def conditions(self) -> dict[str, Any]:
        """The measurement-model conditions of the neighbour's measurement."""
        return reading_conditions(self.dt, self.direction)


def reading_conditions(dt: float, direction: np.ndarray | None) -> dict[str, Any]:
    """The measurement-model conditions of a reading: its exposure ``dt`` (s) and, when it
    has one, the wind ``direction`` its likelihood uses."""
    out: dict[str, Any] = {"dt": dt}
    if direction is not None:
        out["direction"] = direction
    return out


def measurement_payload(
    count: float,
    position: np.ndarray,
    cue_captured: bool,
    dt: float,
    direction: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """A measurement as a neighbour's likelihood needs it: ``measurement`` (count, position,
    cue flag: ``d + 2`` numbers) and its ``conditions`` (exposure and wind direction: ``d + 1``,
    or the exposure alone when the sender's model used its own wind).

    The conditions travel with the reading because a likelihood is only right under the
    conditions of its own reading: each UAV measures its own wind.
    """
    pos = np.asarray(position, float).reshape(-1)
    cond = [float(dt)]
    if direction is not None:
        cond += np.asarray(direction, float).reshape(pos.size).tolist()
    return {
        "measurement": np.concatenate([[float(count)], pos, [1.0 if cue_captured else 0.0]]),
        "conditions": np.array(cond),
    }


def fit_payload(
    mean: np.ndarray,
    cov: np.ndarray,
    count: float,
    position: np.ndarray,
    cue_captured: bool,
    dt: float,
    direction: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The Col-PF message: the fit (``d + d^2`` numbers, 12 in 3-D, as the paper counts it) and
    the last measurement with its conditions (:func:`measurement_payload`).

    Every number is a float64, so a 3-D message is 21 numbers = 168 bytes.
    """
    m = np.asarray(mean, float).reshape(-1)
    c = np.asarray(cov, float).reshape(m.size, m.size)
    return {
        "fit": np.concatenate([m, c.ravel()]),
        **measurement_payload(count, position, cue_captured, dt, direction),
    }


def read_measurement_payload(
    sender: int, payload: Mapping[str, np.ndarray], d: int
) -> tuple[float, np.ndarray, bool, float, np.ndarray | None]:
    """Inverse of :func:`measurement_payload`: ``(count, position, cue_captured, dt,
    direction)``; :class:`ConfigError` naming ``message`` for a payload of another shape."""
    if "measurement" not in payload or "conditions" not in payload:
        raise ConfigError("message", f"agent {sender} sent no measurement")
    meas = np.asarray(payload["measurement"], float).reshape(-1)
    cond = np.asarray(payload["conditions"], float).reshape(-1)
    if meas.size != d + 2 or cond.size not in (1, d + 1):
        raise ConfigError(
            "message", f"agent {sender}: measurement of {meas.size}, conditions of {cond.size}"
        )
    if not (np.isfinite(cond[0]) and cond[0] > 0):
        raise ConfigError("message", f"agent {sender}: exposure {cond[0]} is not > 0")
    direction = cond[1:].copy() if cond.size > 1 else None
    return float(meas[0]), meas[1 : 1 + d].copy(), bool(meas[-1] > 0.5), float(cond[0]), direction


def read_fit_payload(sender: int, payload: Mapping[str, np.ndarray]) -> NeighbourFit:
    """Inverse of :func:`fit_payload`; :class:`ConfigError` for a payload of another shape."""
    if "fit" not in payload:
        raise ConfigError("message", f"agent {sender} sent no Gaussian fit")
    fit = np.asarray(payload["fit"], float)
    # fit holds d + d^2 numbers
    d = round((-1 + math.sqrt(1 + 4 * fit.size)) / 2)
    if d + d * d != fit.size:
        raise ConfigError("message", f"agent {sender}: fit of {fit.size} numbers")
    count, position, cue, dt, direction = read_measurement_payload(sender, payload, d)
    return NeighbourFit(
        sender=int(sender),
        mean=fit[:d].copy(),
        cov=fit[d:].reshape(d, d).copy(),
        count=count,
        position=position,
        cue_captured=cue,
        dt=dt,
        direction=direction,
    )
