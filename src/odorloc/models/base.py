"""The measurement-model interface shared by simulated truth and estimators.

A measurement model says how likely a reading ``z`` is at a sensor position ``s`` if the source
were at ``x``: ``log p(z | x, s)``. The same object serves two roles:

- **belief**: an estimator adds :meth:`MeasurementModel.log_likelihood` ``(N,)`` over its
  hypotheses (particles or grid cells) to its log-weights;
- **planning**: a planner asks :meth:`MeasurementModel.outcome_probabilities` ``(M, Z, N)`` over
  a finite set of outcome classes for ``M`` candidate sensor positions, to score where to go.

What a reading depends on besides the two positions (the recorded wind window, an exposure time,
a release rate) is passed as keyword *conditions*; :meth:`MeasurementModel.bind` fixes them and
returns a :class:`BoundModel` with the two-argument interface planners use. A searcher's model is
its own parameter, so it may differ from the world's plume (model mismatch is a setting).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params

__all__ = ["BoundModel", "MeasurementModel", "binary_outcomes"]


def binary_outcomes(p1: np.ndarray) -> np.ndarray:
    """``(M, 2, N)`` outcome probabilities ``[p(z=0), p(z=1)]`` from ``p(z=1)`` ``(M, N)``."""
    p1 = np.asarray(p1, float)
    return np.stack([1.0 - p1, p1], axis=1)


class MeasurementModel(ABC):
    """Base class of measurement models (see the module docstring).

    A model keeps its parameters in ``params`` (what it computes depends on them and on the
    conditions only, so they identify its outcome tables).
    """

    params: Params

    @abstractmethod
    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``log p(z | x_i)`` for a reading ``z`` at ``sensor_position`` ``(d,)``, ``(N,)``.

        ``-inf`` is allowed (an impossible hypothesis), NaN never.
        """

    def log_likelihood_rows(
        self, z: Any, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``log p(z_q | x_i)`` of each reading ``z_q`` at its own sensor position, ``(Q, N)``.

        Several sensors' readings kept apart (e.g. a team member weighing each neighbour's
        reading on its own). Default: one :meth:`log_likelihood` call per reading.
        """
        zs = list(np.atleast_1d(np.asarray(z, dtype=object)))
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        if len(zs) != len(sp):
            raise ConfigError("readings", f"{len(zs)} readings for {len(sp)} sensor positions")
        rows = [
            self.log_likelihood(zq, sq, hypotheses, **conditions)
            for zq, sq in zip(zs, sp, strict=True)
        ]
        return np.array(rows, float).reshape(len(sp), -1)

    @abstractmethod
    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``p(class c | x_i)`` of each outcome class at each sensor position, ``(M, Z, N)``.

        For every ``(m, i)`` the ``Z`` classes sum to one.
        """

    def outcome_values(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """The reading each outcome class of :meth:`outcome_probabilities` stands for, ``(Z,)``.

        Same arguments as :meth:`outcome_probabilities`, since ``Z`` may depend on them (e.g. a
        class count chosen from the expected counts). Default ``0 .. Z-1``, with ``Z`` from one
        :meth:`outcome_probabilities` call.
        """
        return np.arange(
            self.outcome_probabilities(sensor_positions, hypotheses, **conditions).shape[1]
        )

    def bind(self, **conditions: Any) -> BoundModel:
        """The model with its conditions fixed (what a planner needs)."""
        return BoundModel(self, conditions)


class BoundModel:
    """A measurement model with fixed conditions: ``log_likelihood(z, s, x)`` and
    ``outcome_probabilities(S, x)`` without keywords."""

    def __init__(self, model: MeasurementModel, conditions: dict[str, Any]) -> None:
        self.model = model
        self.conditions = dict(conditions)

    def log_likelihood(self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray) -> Any:
        """See :meth:`MeasurementModel.log_likelihood`."""
        return self.model.log_likelihood(z, sensor_position, hypotheses, **self.conditions)

    def outcome_probabilities(self, sensor_positions: np.ndarray, hypotheses: np.ndarray) -> Any:
        """See :meth:`MeasurementModel.outcome_probabilities`."""
        return self.model.outcome_probabilities(sensor_positions, hypotheses, **self.conditions)

    def outcome_values(self, sensor_positions: np.ndarray, hypotheses: np.ndarray) -> np.ndarray:
        """See :meth:`MeasurementModel.outcome_values`."""
        return self.model.outcome_values(sensor_positions, hypotheses, **self.conditions)
