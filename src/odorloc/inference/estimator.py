"""The single-agent estimator family (registry family ``estimator``).

An estimator turns one agent's observations into a belief about the source(s): a particle
filter, a grid Bayes filter, a Dempster-Shafer evidence map, an odor-path map, a gas
distribution map or a source-term posterior. Searchers compose one (a ``Ref("estimator")``
field) with a planner or a behaviour; the offline replay of a recorded log drives one directly.

The lifecycle is the same for every member::

    est.reset(ctx, model, rng)       # new episode: what the agent knows, its measurement model,
                                     # and the estimator's own random stream
    est.update(observation)          # once per control period, in time order
    est.belief()                     # arrays for planners, the recorder and the figures
    est.estimate()                   # (k, d) source positions, k >= 0
    est.converged()                  # the member's stopping rule

Members keep their parameters immutable (a :class:`~odorloc.core.params.Params` in
``self.params``) and all evolving state in attributes set by :meth:`Estimator.reset`. The random
stream given to ``reset`` is the only source of randomness (resampling, moves); the same stream
and the same observations give the same belief.

Optional hooks (with defaults): :meth:`Estimator.conditions` (the measurement conditions of the
next reading, for a planner that anticipates it), :meth:`Estimator.initial_belief` (the belief
as first formed), :meth:`Estimator.use_stream` (draw from another stream from now on: a team
member's actions have a stream of their own), :meth:`Estimator.diagnostics` and
:meth:`Estimator.final_metrics`; the class attribute ``default_model`` names the measurement
model used where a caller has none (an offline replay).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from odorloc.core.params import Params

if TYPE_CHECKING:
    from odorloc.core.types import Observation, SearchContext
    from odorloc.inference.belief import Belief
    from odorloc.models.base import MeasurementModel

__all__ = ["Estimator"]


class Estimator(ABC):
    """Base class of the ``estimator`` family (see the module docstring).

    Class attributes
    ----------------
    dims : tuple of int
        Spatial dimensions the estimator works in.
    needs_model : bool
        ``True`` when :meth:`reset` requires a measurement model (a Bayesian filter); maps
        built from readings alone (evidence, kernel gas maps) accept ``None``.
    default_model : dict or None
        The measurement model (``{type: name, **params}``) to use where a caller has none,
        e.g. an offline replay of a log (``None``: the estimator needs no model).
    """

    params: Params
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    needs_model: ClassVar[bool] = True
    default_model: ClassVar[Mapping[str, Any] | None] = None

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else Params()

    @abstractmethod
    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        """Start a new episode.

        Parameters
        ----------
        ctx : SearchContext
            What the agent knows before the episode (arena, control period, sensor).
        model : MeasurementModel or None
            The estimator's measurement model (it may differ from the world's plume).
        rng : numpy.random.Generator
            The estimator's random stream for the whole episode.
        """

    @abstractmethod
    def update(self, observation: Observation) -> None:
        """Fold in one control period's observation (readings, wind, messages)."""

    @abstractmethod
    def belief(self) -> Belief | None:
        """The current belief (``None`` before the estimator has one, e.g. before a cue)."""

    @abstractmethod
    def estimate(self) -> np.ndarray:
        """Estimated source positions, ``(k, d)`` metres (``k = 0``: no estimate yet)."""

    def converged(self) -> bool:
        """The member's stopping rule (default: never)."""
        return False

    def initial_belief(self) -> Belief | None:
        """The belief as it was first formed (e.g. the particles as drawn), for measures of
        how much the readings taught (default ``None``: not kept)."""
        return None

    def conditions(self) -> dict[str, Any]:
        """Measurement conditions of a reading taken one control period after the last update
        (a wind window, an exposure), for a planner's :class:`~odorloc.planning.base.Pose`
        (default none)."""
        return {}

    def use_stream(self, rng: np.random.Generator) -> None:
        """Draw from ``rng`` from now on instead of the stream given to :meth:`reset` (default:
        nothing to do, for members that draw nothing). A searcher whose actions have a stream
        of their own (a team member) hands it over before each update, so that the draws of
        an update come from the stream of the action it belongs to."""
        return None

    def diagnostics(self) -> dict[str, float]:
        """Scalars worth recording each step (ESS, entropy, spread, ...). Default none."""
        return {}

    def final_metrics(self) -> dict[str, Any]:
        """Extra columns for the episode's result row (default none)."""
        return {}
