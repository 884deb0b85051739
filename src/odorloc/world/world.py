"""The composed world: arena + wind + plume, stepped together."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.timestep import check_dt
from odorloc.geometry.arena import Arena
from odorloc.plume.base import PlumeModel
from odorloc.plume.replay import Movie, ReplayParams, ReplayPlume, ReplayWind, record_movie
from odorloc.plume.sources import Source
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

    def record(
        self,
        duration: float,
        frame_dt: float,
        rng: np.random.Generator,
        *,
        dt: float | None = None,
        wind_shape: Sequence[int] | None = None,
    ) -> Movie:
        """Record this world as a :class:`~odorloc.plume.replay.Movie` (see
        :func:`~odorloc.plume.replay.record_movie`)."""
        return record_movie(
            (self.plume, self.wind), duration, frame_dt, rng, dt=dt, wind_shape=wind_shape
        )

    @classmethod
    def replay(
        cls, movie: Movie, sources: Sequence[Source] | None = None, loop: bool = False
    ) -> World:
        """A world playing ``movie`` back: its arena, a replayed wind and plume (with
        ``sources``, default the recorded ones)."""
        params = ReplayParams(loop=loop)
        arena = movie.arena()
        wind = ReplayWind(params, arena, movie=movie)
        plume = ReplayPlume(params, arena, wind, sources, movie=movie)
        return cls(arena, wind, plume)
