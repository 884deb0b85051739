"""Spatially uniform, constant wind."""

from __future__ import annotations

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Vector
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.wind.base import WindModel


class UniformWindParams(Params):
    """Parameters of :class:`UniformWind`.

    velocity : (d,) tuple of float, m/s, optional
        The wind; ``None`` (default) is 1 m/s along +x in the arena's dimension.
    """

    velocity: Vector | None = None


@register("wind", "uniform", UniformWindParams, "uniform constant wind")
class UniformWind(WindModel):
    """The same constant velocity everywhere and always."""

    deterministic = True
    steady = True

    def __init__(self, params: UniformWindParams, arena: Arena) -> None:
        super().__init__(arena)
        v = params.velocity
        if v is None:
            v = (1.0,) + (0.0,) * (arena.dim - 1)
        if len(v) != arena.dim:
            raise ConfigError("wind.velocity", f"needs {arena.dim} components, got {len(v)}")
        self.params = params
        self._u = np.asarray(v, float)

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        out = np.empty(points.shape)
        out[...] = self._u
        return out

    def mean_velocity(self) -> np.ndarray:
        """The velocity itself (no grid needed: it is the same everywhere), ``(d,)`` m/s."""
        return self._u.copy()
