"""The wind-model interface.

A wind model is a velocity field that may evolve in time. Parameters are immutable
(:class:`odorloc.core.params.Params`); the evolving state lives in the model instance and is
reset by :meth:`WindModel.reset`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.timestep import TimeStepped
from odorloc.geometry.arena import Arena, as_points


class WindModel(TimeStepped, ABC):
    """Base class of wind models.

    Subclasses implement :meth:`_velocity`, and :meth:`_advance` when they evolve in time.
    """

    arena: Arena
    t: float

    def __init__(self, arena: Arena) -> None:
        self.arena = arena
        self.t = 0.0

    @property
    def dim(self) -> int:
        """Spatial dimension (that of the arena)."""
        return self.arena.dim

    def velocity(self, points: ArrayLike, t: float | None = None) -> np.ndarray:
        """Air velocity at ``points``.

        Parameters
        ----------
        points : (Q, d) array_like, metres
        t : float, optional
            Time in seconds. Stochastic fields only know their current state, so ``t`` must be
            ``None`` or the current time; deterministic fields accept any ``t``.

        Returns
        -------
        (Q, d) ndarray, m/s
        """
        p = as_points(points, self.dim)
        if t is not None and not self.deterministic and abs(t - self.t) > 1e-9:
            raise ConfigError(
                "t", f"{type(self).__name__} only knows its current time {self.t:g} s, not {t:g} s"
            )
        return self._velocity(p, self.t if t is None else float(t))

    #: ``True`` when :meth:`velocity` is a pure function of (points, t).
    deterministic: bool = False
    #: ``True`` when the field never changes (the same velocities at every time).
    steady: bool = False

    @abstractmethod
    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        """Velocity at ``(Q, d)`` points, ``(Q, d)`` m/s."""

    def mean_velocity(self) -> np.ndarray:
        """Current spatial-mean velocity over the arena (sampled on a coarse grid), ``(d,)`` m/s."""
        axes = [
            np.linspace(lo, hi, 5)
            for lo, hi in zip(self.arena.lower, self.arena.upper, strict=True)
        ]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, self.dim)
        return self.velocity(pts).mean(axis=0)

    def state(self) -> dict[str, np.ndarray]:
        """A copy of the evolving state (for recording); steady fields return ``{}``."""
        return {}
