"""Spatially uniform, constant wind."""

from __future__ import annotations

import numpy as np

from odorloc.errors import ConfigError
from odorloc.params import Params, Vector
from odorloc.registry import register
from odorloc.wind.base import WindModel
from odorloc.world.arena import Arena


class UniformWindParams(Params):
    """Parameters of :class:`UniformWind`.

    velocity : (d,) tuple of float, m/s
    """

    velocity: Vector = (1.0, 0.0)


@register("wind", "uniform", UniformWindParams, "uniform constant wind")
class UniformWind(WindModel):
    """The same constant velocity everywhere and always."""

    deterministic = True

    def __init__(self, params: UniformWindParams, arena: Arena) -> None:
        super().__init__(arena)
        if len(params.velocity) != arena.dim:
            raise ConfigError(
                "wind.velocity", f"needs {arena.dim} components, got {len(params.velocity)}"
            )
        self.params = params
        self._u = np.asarray(params.velocity, float)

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        return np.broadcast_to(self._u, points.shape).copy()
