"""The plume-model interface shared by every plume family.

``step(dt, rng)`` advances the plume (reading the wind model it was built with),
``concentration(points)`` gives the instantaneous concentration and ``encounter_rate(points)``
the expected rate of detectable odor encounters (Poisson sensing, infotaxis).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.timestep import TimeStepped
from odorloc.geometry.arena import Arena, as_points
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel


def check_sources(sources: Sequence[Source], arena: Arena, field: str = "world.sources") -> None:
    """Raise :class:`ConfigError` when a source lies outside the arena or inside an obstacle."""
    if len(sources) == 0:
        raise ConfigError(field, "at least one source is required")
    for k, s in enumerate(sources):
        if len(s.position) != arena.dim:
            raise ConfigError(
                f"{field}[{k}].position", f"needs {arena.dim} components, got {len(s.position)}"
            )
        if not arena.contains(s.pos)[0]:
            raise ConfigError(f"{field}[{k}].position", f"{s.position} is outside the arena")
        if arena.in_obstacle(s.pos)[0]:
            raise ConfigError(f"{field}[{k}].position", f"{s.position} is inside an obstacle")


class PlumeModel(TimeStepped, ABC):
    """Base class of plume models.

    Parameters
    ----------
    arena : Arena
    wind : WindModel
        The wind the plume is carried by. The plume reads it but never steps it (the
        :class:`~odorloc.world.World` does), so several plumes may share one wind.
    sources : sequence of Source
    """

    def __init__(self, arena: Arena, wind: WindModel, sources: Sequence[Source]) -> None:
        check_sources(sources, arena)
        self.arena = arena
        self.wind = wind
        self.sources = tuple(sources)
        self.t = 0.0

    @property
    def dim(self) -> int:
        """Spatial dimension (that of the arena)."""
        return self.arena.dim

    @property
    def source_positions(self) -> np.ndarray:
        """``(S, d)`` source positions, metres."""
        return np.array([s.pos for s in self.sources])

    def set_sources(self, sources: Sequence[Source]) -> None:
        """Replace the sources (e.g. drawn anew for an episode); call :meth:`reset` after it.

        The new sources are validated like the configured ones (inside the arena, not in an
        obstacle); models with per-source state refresh it in :meth:`_sources_changed`.
        """
        check_sources(sources, self.arena)
        self.sources = tuple(sources)
        self._sources_changed()

    def _sources_changed(self) -> None:
        """Refresh what depends on the source positions; default: :meth:`_sync`."""
        self._sync()

    def source_rates(self) -> np.ndarray:
        """``(S,)`` release rates of the sources at the current time ``t``."""
        return np.array([s.rate_at(self.t) for s in self.sources], float)

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self._sync()

    def step(self, dt: float, rng: np.random.Generator) -> None:
        super().step(dt, rng)
        self._sync()

    def check_step(self, dt: float) -> None:
        """Raise :class:`ConfigError` if steps of ``dt`` seconds cannot run with these settings.

        Called when a scenario's world is built (``dt`` the world step), so that what the step
        size rules out is refused before any episode; default: every step size can run.
        """

    def _sync(self) -> None:
        """Recompute what follows from ``t`` and the wind alone, after every reset and step.

        Steady (analytic) plumes keep their current source rates and winds here; models with
        their own state evolve it in :meth:`_advance` and need nothing.
        """

    def concentration(self, points: ArrayLike) -> np.ndarray:
        """Instantaneous concentration at ``(Q, d)`` points, ``(Q,)`` (model units)."""
        return self._concentration(as_points(points, self.dim))

    def encounter_rate(self, points: ArrayLike) -> np.ndarray:
        """Expected odor encounters per second at ``(Q, d)`` points, ``(Q,)`` 1/s."""
        return self._encounter_rate(as_points(points, self.dim))

    @abstractmethod
    def _concentration(self, points: np.ndarray) -> np.ndarray: ...

    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        """Default: concentration read as a rate (override where the model defines one)."""
        return self._concentration(points)

    @property
    def draws_sources(self) -> bool:
        """``True`` when the plume places its sources itself at every reset (the lattice
        problem's ``start: initial-hit``), so the configured positions are not where they
        end up. Default ``False``."""
        return False

    def initial_hits(self, position: np.ndarray) -> int | None:
        """Hits an episode starts with at ``position`` (``(d,)`` metres), or ``None``.

        Plumes that draw their episode from a first observation (the lattice problem of
        infotaxis: a first hit, then the source from the posterior it leaves) return that hit
        for the agent's start; a hit counter reports it as its first reading. Default ``None``:
        the first reading is an ordinary one.
        """
        return None

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``: how a recorded
        movie replays this plume. Plumes that can be replayed override it (their frames name
        the plume's registry name as ``"model"``); the default refuses."""
        raise ConfigError("movie", f"frames of plume {frame.get('model')!s} cannot be replayed")

    @abstractmethod
    def frame(self) -> dict[str, np.ndarray]:
        """A copy of the state needed to reproduce :meth:`concentration` (for recording)."""
