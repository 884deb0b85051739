"""Where did the detected air come from? The odor-path maps of the detections, summed
(registry ``estimator``: ``odor-path``; odor-path paper, section IV).

Each control period's record (position, wind, detection) feeds an
:class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator`; the path map of every reading
with a detection is added to a running sum over the log, and the sum, normalised, is the belief:
where the air of the detections passed, weighted by how often. It needs no measurement model.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Positive
from odorloc.core.registry import register
from odorloc.core.types import Observation, SearchContext
from odorloc.inference.belief import GridBelief
from odorloc.inference.estimator import Estimator
from odorloc.inference.odor_path.estimator import OdorPathEstimator, OdorPathParams
from odorloc.models.base import MeasurementModel

__all__ = ["OdorPathMapEstimator", "OdorPathMapParams"]


class OdorPathMapParams(OdorPathParams):
    """:class:`~odorloc.inference.odor_path.estimator.OdorPathParams` with 0.25 m cells and the
    cell-integrated kernel, so that a map summed over a whole log is smooth at the scale of a
    robot's step. ``dt`` is the control period: another value is refused at reset."""

    cell_size: Positive = 0.25
    kernel: Literal["point", "cell"] = "cell"


@register("estimator", "odor-path", OdorPathMapParams, "odor-path maps of the detections, summed")
class OdorPathMapEstimator(Estimator):
    """The odor-path maps of the detections summed over the log (module docstring).

    The map covers the arena's first two axes (``dims = (2,)``: its estimate is horizontal).
    """

    params: OdorPathMapParams
    Params = OdorPathMapParams
    dims = (2,)
    needs_model = False

    def __init__(self, params: OdorPathMapParams | None = None) -> None:
        super().__init__(params or OdorPathMapParams())

    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        """A blank map over the arena's horizontal extent."""
        p = self.params
        if "dt" in p.model_fields_set and not math.isclose(p.dt, ctx.dt, rel_tol=1e-9):
            raise ConfigError(
                "dt", f"is the control period {ctx.dt:g} s here (one record per period)"
            )
        values = p.model_dump(exclude={"dt"})
        self.estimator = OdorPathEstimator(
            OdorPathParams(**values, dt=ctx.dt), ctx.arena.lower[:2], ctx.arena.upper[:2]
        )
        self.accum = np.zeros(self.estimator.grid.shape)
        self.n_detections = 0

    def update(self, observation: Observation) -> None:
        """Record one period; add its path map when it has a detection."""
        o = observation
        self.estimator.update(o.t, o.position[:2], o.wind[:2], 1.0 if o.detection else 0.0)
        if o.detection:
            self.accum += self.estimator.path_map()
            self.n_detections += 1

    def belief(self) -> GridBelief | None:
        """The normalised sum (``None`` before the first detection)."""
        total = float(self.accum.sum())
        if total <= 0:
            return None
        return GridBelief(self.estimator.grid, self.accum / total)

    def estimate(self) -> np.ndarray:
        """The mean of the belief, ``(1, 2)`` metres (``(0, 2)`` before a detection)."""
        b = self.belief()
        return np.zeros((0, 2)) if b is None else b.mean[None, :]

    def final_metrics(self) -> dict[str, float]:
        """Readings with a detection."""
        return {"detections": float(self.n_detections)}
