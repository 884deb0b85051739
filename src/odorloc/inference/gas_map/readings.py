"""Gas readings as arrays: where, what, the wind and the time of each one.

:class:`Readings` is the batch a gas map is fed (:meth:`~odorloc.inference.gas_map.base.GasMap.
update`), the held-out set it is scored on and what cross-validation splits into folds. Every
array is checked once, here, so that no NaN reaches a map: a bad batch is refused with a
:class:`~odorloc.core.errors.ConfigError` naming the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError

__all__ = ["Readings", "as_readings", "time_blocks"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Readings:
    """A batch of gas readings.

    Attributes
    ----------
    positions : (N, d) ndarray, metres
    values : (N,) ndarray
        Gas readings, in the sensor's units.
    wind : (N, d) ndarray or None, m/s
        Air velocity measured with each reading (world frame); ``None`` when not known.
    t : (N,) ndarray, seconds
        Time of each reading; NaN where not known (methods that weigh readings by their age
        refuse such readings).
    """

    positions: FloatArray
    values: FloatArray
    wind: FloatArray | None
    t: FloatArray

    def __len__(self) -> int:
        return len(self.values)

    @property
    def dim(self) -> int:
        """Spatial dimension of the positions."""
        return self.positions.shape[1]

    @property
    def has_times(self) -> bool:
        """Whether every reading has a time."""
        return bool(np.all(np.isfinite(self.t)))

    def subset(self, mask: ArrayLike) -> Readings:
        """The readings selected by a boolean mask or an index array."""
        m = np.asarray(mask)
        return Readings(
            self.positions[m],
            self.values[m],
            None if self.wind is None else self.wind[m],
            self.t[m],
        )

    @staticmethod
    def concat(parts: list[Readings], dim: int) -> Readings:
        """One batch of several (in order); an empty list gives an empty batch of ``dim``."""
        if not parts:
            return Readings(np.zeros((0, dim)), np.zeros(0), None, np.zeros(0))
        winds = [p.wind for p in parts]
        wind = None
        if all(w is not None for w in winds):
            wind = np.concatenate([w for w in winds if w is not None])
        return Readings(
            np.concatenate([p.positions for p in parts]),
            np.concatenate([p.values for p in parts]),
            wind,
            np.concatenate([p.t for p in parts]),
        )


def as_readings(
    position: ArrayLike,
    reading: ArrayLike,
    wind: ArrayLike | None = None,
    t: ArrayLike | float | None = None,
    dim: int | None = None,
) -> Readings:
    """Check and shape one batch.

    Parameters
    ----------
    position : (N, d) or (d,) array_like, metres
    reading : (N,) array_like or float
    wind : (N, d) or (d,) array_like, m/s, optional
    t : (N,) array_like or float, seconds, optional
        One time for the whole batch, or one per reading.
    dim : int, optional
        The dimension the positions must have.

    Raises
    ------
    ConfigError
        Naming ``position``, ``reading``, ``wind`` or ``t``: a wrong shape, a count that
        differs from the positions', or a value that is not finite.
    """
    p = np.asarray(position, float)
    if p.ndim == 1:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] not in (2, 3) or (dim is not None and p.shape[1] != dim):
        want = f"(N, {dim})" if dim is not None else "(N, 2) or (N, 3)"
        raise ConfigError("position", f"expected shape {want}, got {np.shape(position)}")
    n = len(p)
    if not np.all(np.isfinite(p)):
        raise ConfigError("position", "must be finite")
    r = np.atleast_1d(np.asarray(reading, float))
    if r.shape != (n,):
        raise ConfigError("reading", f"expected {n} values (one per position), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ConfigError("reading", "must be finite")
    w = None
    if wind is not None:
        w = np.asarray(wind, float)
        if w.ndim == 1:
            w = np.broadcast_to(w, (n, len(w))).copy() if n else w.reshape(0, len(w))
        if w.shape != p.shape:
            raise ConfigError("wind", f"expected shape {p.shape}, got {np.shape(wind)}")
        if not np.all(np.isfinite(w)):
            raise ConfigError("wind", "must be finite")
    if t is None:
        tt = np.full(n, math.nan)
    else:
        tt = np.atleast_1d(np.asarray(t, float))
        if tt.size == 1 and n != 1:
            tt = np.full(n, float(tt[0]))
        if tt.shape != (n,):
            raise ConfigError("t", f"expected one time or {n} times, got {tt.shape}")
        if not np.all(np.isfinite(tt)):
            raise ConfigError("t", "must be finite")
    return Readings(p.copy(), r.copy(), w, tt.copy())


def time_blocks(readings: Readings, block: float, folds: int) -> NDArray[np.intp]:
    """The fold of each reading: consecutive ``block``-second stretches take folds in turn.

    Neighbouring readings of a robot's path are nearly the same reading; holding out whole
    stretches of the path tests a map where it must interpolate, not where it has a twin of
    the held-out reading. Readings without times are split into blocks of 20 readings.

    Parameters
    ----------
    readings : Readings
    block : float, seconds
    folds : int
        Number of folds, >= 2.

    Returns
    -------
    (N,) int ndarray
        Fold index ``0 .. folds - 1`` of each reading.
    """
    if folds < 2:
        raise ConfigError("folds", f"must be >= 2, got {folds}")
    if not (math.isfinite(block) and block > 0):
        raise ConfigError("block", f"must be a finite number > 0, got {block}")
    n = len(readings)
    if readings.has_times and n:
        k = np.floor((readings.t - readings.t.min()) / block).astype(np.intp)
    else:
        k = np.arange(n, dtype=np.intp) // 20
    return k % folds
