"""The composed world: arena + wind + plume, stepped together."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from odorloc.errors import ConfigError
from odorloc.timestep import check_dt
from odorloc.world.arena import Arena

if TYPE_CHECKING:
    # Type-only: the plume and wind packages import ``odorloc.world`` themselves.
    from odorloc.plume.base import PlumeModel
    from odorloc.wind.base import WindModel


@dataclass(eq=False)
class World:
    """Arena, wind and plume with one clock.

    ``step(dt, rng)`` advances the wind, then the plume, which reads the new wind.
    The world's generator must be independent of the searcher's and the sensors' so that the
    same episode index gives the same plume to every searcher (common random numbers).
    """

    arena: Arena
    wind: WindModel
    plume: PlumeModel

    def __post_init__(self) -> None:
        if self.wind.dim != self.arena.dim:
            raise ConfigError("wind", f"wind is {self.wind.dim}D but arena is {self.arena.dim}D")
        if self.plume.dim != self.arena.dim:
            raise ConfigError("plume", f"plume is {self.plume.dim}D but arena is {self.arena.dim}D")

    @property
    def t(self) -> float:
        """Current simulation time, seconds."""
        return self.plume.t

    @property
    def sources(self) -> np.ndarray:
        """True source positions, ``(S, d)`` metres."""
        return np.array([s.pos for s in self.plume.sources])

    def reset(self, rng: np.random.Generator) -> None:
        """Reset wind then plume to time 0."""
        self.wind.reset(rng)
        self.plume.reset(rng)

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Advance the world by ``dt`` seconds."""
        check_dt(dt)
        self.wind.step(dt, rng)
        self.plume.step(dt, rng)
