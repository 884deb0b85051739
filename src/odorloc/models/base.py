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
from collections.abc import Mapping
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

    def weighted_log_likelihood(
        self,
        z: Any,
        sensor_positions: np.ndarray,
        hypotheses: np.ndarray,
        exponents: np.ndarray,
        record_conditions: Mapping[str, np.ndarray] | None = None,
        **conditions: Any,
    ) -> np.ndarray:
        """``sum_k e_k log p(z_k | x_n)`` over ``K`` readings, each at its own sensor position
        and under its own conditions, ``(N,)``.

        A measurement history evaluated at once (a tempered product of likelihoods: a
        neighbour's reading counted with its confidence factor, eq. 11 of the multi-UAV paper).
        The readings are checked by :meth:`prepare_readings` and evaluated by
        :meth:`prepared_log_likelihood`; a caller that evaluates the same readings at many
        hypothesis sets (a Metropolis-Hastings move) prepares them once.

        Parameters
        ----------
        z : (K,) array_like
            The readings.
        sensor_positions : (K, d) ndarray, metres
        hypotheses : (N, d) ndarray, metres
        exponents : (K,) ndarray
            ``e_k >= 0``; a reading with ``e_k = 0`` contributes nothing (not ``0 * -inf``).
        record_conditions : mapping of str to (K, ...) ndarray, optional
            Conditions that differ between readings, one row per reading (an exposure ``dt``
            ``(K,)``, a wind ``direction`` ``(K, d)``). A row that is all NaN means "not given":
            the model's default.
        **conditions
            Conditions shared by every reading.
        """
        prepared = self.prepare_readings(
            z, sensor_positions, exponents, record_conditions, **conditions
        )
        return self.prepared_log_likelihood(prepared, hypotheses)

    def prepare_readings(
        self,
        z: Any,
        sensor_positions: np.ndarray,
        exponents: np.ndarray,
        record_conditions: Mapping[str, np.ndarray] | None = None,
        **conditions: Any,
    ) -> Any:
        """The readings of :meth:`weighted_log_likelihood` checked once, in the form
        :meth:`prepared_log_likelihood` evaluates (the default keeps them as given)."""
        zs = list(np.atleast_1d(np.asarray(z, dtype=object)))
        sp = np.atleast_2d(np.asarray(sensor_positions, float))
        e = np.asarray(exponents, float).reshape(-1)
        per = {k: np.asarray(v) for k, v in (record_conditions or {}).items()}
        if not (len(zs) == len(sp) == len(e)) or any(len(v) != len(e) for v in per.values()):
            raise ConfigError(
                "readings", f"{len(zs)} readings, {len(sp)} positions, {len(e)} exponents"
            )
        if np.any(~(e >= 0)):
            raise ConfigError("exponents", "must be >= 0")
        return _Readings(zs, sp, e, per, dict(conditions))

    def prepared_log_likelihood(self, prepared: Any, hypotheses: np.ndarray) -> np.ndarray:
        """``sum_k e_k log p(z_k | x_n)`` of readings from :meth:`prepare_readings`, ``(N,)``.

        Default: one :meth:`log_likelihood` call per reading.
        """
        r: _Readings = prepared
        out = np.zeros(len(np.atleast_2d(hypotheses)))
        for k in np.flatnonzero(r.exponents > 0):
            cond = dict(r.conditions)
            for key, values in r.record.items():
                v = np.asarray(values[k], float)
                if not np.all(np.isnan(v)):
                    cond[key] = v if v.ndim else float(v)
            out += r.exponents[k] * self.log_likelihood(r.z[k], r.positions[k], hypotheses, **cond)
        return out

    @abstractmethod
    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        """``p(class c | x_i)`` of each outcome class at each sensor position, ``(M, Z, N)``.

        For every ``(m, i)`` the ``Z`` classes sum to one.
        """

    def poisson_outcomes(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> tuple[np.ndarray, int] | None:
        """The Poisson means behind :meth:`outcome_probabilities`, when its classes are Poisson
        counts: ``(means (M, N), Z)`` such that the outcome probabilities are the classes
        ``0 .. Z-2`` and ``>= Z-1`` of Poisson(means). ``None`` (the default) for any other
        outcome model.

        A planner that knows the classes are Poisson works on their log-probabilities
        directly (``c log mu - mu - log c!``) instead of taking the log of every class.
        """
        return None

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


class _Readings:
    """Readings kept as given (:meth:`MeasurementModel.prepare_readings`)."""

    __slots__ = ("conditions", "exponents", "positions", "record", "z")

    def __init__(
        self,
        z: list[Any],
        positions: np.ndarray,
        exponents: np.ndarray,
        record: dict[str, np.ndarray],
        conditions: dict[str, Any],
    ) -> None:
        self.z = z
        self.positions = positions
        self.exponents = exponents
        self.record = record
        self.conditions = conditions


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

    def poisson_outcomes(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray
    ) -> tuple[np.ndarray, int] | None:
        """See :meth:`MeasurementModel.poisson_outcomes`."""
        return self.model.poisson_outcomes(sensor_positions, hypotheses, **self.conditions)

    def outcome_values(self, sensor_positions: np.ndarray, hypotheses: np.ndarray) -> np.ndarray:
        """See :meth:`MeasurementModel.outcome_values`."""
        return self.model.outcome_values(sensor_positions, hypotheses, **self.conditions)
