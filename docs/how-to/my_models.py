"""A measurement model of one's own (the how-to guide "Write a measurement model")."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.models.base import MeasurementModel, binary_outcomes


class NearDetectionParams(Params):
    """Parameters of :class:`NearDetectionModel`.

    Attributes
    ----------
    p_near : float
        Probability of a detection right at the source.
    length : float, metres
        Distance over which the detection probability falls by a factor e.
    p_false : float
        Probability of a detection far from any source (false alarms).
    """

    p_near: float = Field(0.9, gt=0.0, le=1.0)
    length: Positive = 1.5
    p_false: float = Field(0.01, ge=0.0, lt=0.5)


@register("model", "near-detection", NearDetectionParams, "detections likelier near the source")
class NearDetectionModel(MeasurementModel):
    """Binary detections whose probability decays with the distance to the source, whatever
    the wind: ``p(z = 1 | x, s) = p_false + (p_near - p_false) exp(-|s - x| / length)``."""

    Params = NearDetectionParams

    def __init__(self, params: NearDetectionParams | None = None) -> None:
        self.params = params or NearDetectionParams()

    def p_detect(self, sensors: np.ndarray, hypotheses: np.ndarray) -> np.ndarray:
        """``(M, N)`` detection probabilities of ``M`` sensor positions, ``N`` hypotheses."""
        p = self.params
        d = np.linalg.norm(np.atleast_2d(sensors)[:, None, :] - hypotheses[None], axis=2)
        return p.p_false + (p.p_near - p.p_false) * np.exp(-d / p.length)

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        p1 = self.p_detect(np.asarray(sensor_position, float), hypotheses)[0]
        return np.log(p1) if bool(z) else np.log1p(-p1)

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        return binary_outcomes(self.p_detect(np.asarray(sensor_positions, float), hypotheses))
