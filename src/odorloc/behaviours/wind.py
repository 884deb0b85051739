"""Running wind averages and the upwind direction they give."""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.geometry.vectors import upwind_unit

__all__ = ["WindAverage"]


class WindAverage:
    """The mean of the last ``n`` anemometer readings of one agent.

    Parameters
    ----------
    n : int
        Readings averaged (>= 1).
    """

    def __init__(self, n: int) -> None:
        if n < 1:
            raise ConfigError("wind_average", "must be >= 1")
        self.n = int(n)
        self._buf: deque[np.ndarray] = deque(maxlen=self.n)

    def add(self, wind: ArrayLike) -> np.ndarray:
        """Add a reading ``(d,)`` m/s; return the mean of the last ``n`` (this one included).

        Raises
        ------
        ConfigError
            If a component of ``wind`` is not finite: a NaN would spoil the next ``n`` means
            and turn the upwind direction into the calm-air fallback without a word.
        """
        w = np.asarray(wind, float)
        if not np.all(np.isfinite(w)):
            raise ConfigError("wind", f"every component must be finite, got {w}")
        self._buf.append(w)
        return self.mean

    @property
    def mean(self) -> np.ndarray:
        """Mean of the stored readings, ``(d,)`` m/s."""
        return np.mean(self._buf, axis=0)

    def upwind(self, fallback_heading: float) -> np.ndarray:
        """Horizontal unit vector against the mean wind (``fallback_heading`` rad in calm air)."""
        return upwind_unit(self.mean, fallback_heading)
