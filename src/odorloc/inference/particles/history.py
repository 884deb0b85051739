"""A filter's measurement history: the readings it has used, each with what its likelihood needs.

A particle filter that *moves* its particles (a resample-move filter, Gilks & Berzuini 2001)
keeps its posterior only if every move is judged by the measurements the posterior rests on:
a Metropolis-Hastings move of a particle from ``x`` to ``x'`` needs ``log p(D | x')`` and
``log p(D | x)`` for the whole data ``D`` so far, not only the last reading. For a UAV of the
multi-UAV paper, ``D`` is its own readings and those its neighbours sent, each counted with the
exponent it entered the weights with (1 for its own, the confidence factor ``beta`` for a
neighbour's: eqs. 11 and 13), so the history's log-likelihood is the log of the posterior (up
to the prior) that the weights approximate.

Each record keeps the reading, where it was taken, its exposure ``dt``, the wind direction of
its likelihood (NaN when the reading gave none: the model's default) and its exponent.
:meth:`MeasurementHistory.log_likelihood` evaluates ``sum_k e_k log p(z_k | x_n)`` for ``N``
hypotheses at once through the model's
:meth:`~odorloc.models.base.MeasurementModel.weighted_log_likelihood` (one compiled pass for the
3-D Vergassola model).

The history may be bounded (``capacity``): it then keeps the latest ``capacity`` readings, and a
move is judged by those alone (a posterior that forgets the oldest data). Unbounded, it grows by
doubling its arrays.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.models.base import MeasurementModel

__all__ = ["MeasurementHistory"]


class MeasurementHistory:
    """The readings a filter has used (see the module docstring).

    Parameters
    ----------
    dim : int
        Dimension of the positions (2 or 3).
    capacity : int or None
        Keep at most this many readings, the latest (``None``: every reading).
    """

    def __init__(self, dim: int, capacity: int | None = None) -> None:
        if dim not in (2, 3):
            raise ConfigError("dim", f"must be 2 or 3, got {dim}")
        if capacity is not None and (isinstance(capacity, bool) or int(capacity) < 1):
            raise ConfigError("history", f"must be a whole number >= 1 or None, got {capacity}")
        self.dim = int(dim)
        self.capacity = None if capacity is None else int(capacity)
        size = 64 if self.capacity is None else min(self.capacity, 64)
        self._alloc(size)
        self._prepared: Any = None  # the model's checked form of the readings, until the next
        self._prepared_for: Any = None  # ... append, and the model it was prepared for
        self._n = 0  # readings held
        self._next = 0  # the oldest reading of a full bounded history (overwritten next)
        self._total = 0  # readings ever appended
        self._version = 0  # changes (appends and clears) ever made

    def _alloc(self, size: int) -> None:
        self._counts = np.zeros(size)
        self._positions = np.zeros((size, self.dim))
        self._dts = np.zeros(size)
        self._directions = np.full((size, self.dim), np.nan)
        self._exponents = np.zeros(size)

    def _grow(self) -> None:
        old = (self._counts, self._positions, self._dts, self._directions, self._exponents)
        size = len(self._counts)
        limit = self.capacity if self.capacity is not None else 2 * size
        self._alloc(min(2 * size, limit))
        for new, arr in zip(
            (self._counts, self._positions, self._dts, self._directions, self._exponents),
            old,
            strict=True,
        ):
            new[:size] = arr

    # ----------------------------------------------------------------- writing
    def append(
        self,
        count: float,
        position: np.ndarray,
        dt: float,
        direction: np.ndarray | None = None,
        exponent: float = 1.0,
    ) -> None:
        """Add one reading (the oldest drops out of a full bounded history).

        Parameters
        ----------
        count : float
            The reading (encounters).
        position : (d,) ndarray, metres
        dt : float, seconds
            Its exposure.
        direction : (d,) ndarray or None
            Unit vector the wind blew towards for its likelihood (``None``: the model's own).
        exponent : float
            The power its likelihood entered the weights with (``>= 0``).
        """
        # checked number by number: a filter appends a few readings per iteration, and array
        # reductions on 3-vectors cost more than the arithmetic
        pos = np.asarray(position, float).reshape(-1)
        if pos.shape != (self.dim,) or not all(map(math.isfinite, pos.tolist())):
            raise ConfigError("position", f"needs a finite {self.dim}-vector, got {pos}")
        dt, exponent, count = float(dt), float(exponent), float(count)
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError("dt", f"the exposure time must be a finite number > 0, got {dt}")
        if not (math.isfinite(exponent) and exponent >= 0):
            raise ConfigError("exponent", f"must be a finite number >= 0, got {exponent}")
        if not (math.isfinite(count) and count >= 0):
            raise ConfigError("count", f"must be a finite number >= 0, got {count}")
        if self._n < len(self._counts):
            i = self._n
            self._n += 1
        elif self.capacity is None or len(self._counts) < self.capacity:
            self._grow()
            i = self._n
            self._n += 1
        else:
            # full: overwrite the oldest
            i = self._next
            self._next = (i + 1) % self.capacity
        self._counts[i] = count
        self._positions[i] = pos
        self._dts[i] = dt
        if direction is None:
            self._directions[i] = np.nan
        else:
            self._directions[i] = np.asarray(direction, float).reshape(self.dim)
        self._exponents[i] = exponent
        self._prepared = self._prepared_for = None
        self._total += 1
        self._version += 1

    def clear(self) -> None:
        """Forget every reading."""
        self._n = self._next = self._total = 0
        self._prepared = self._prepared_for = None
        self._version += 1

    # ----------------------------------------------------------------- reading
    def __len__(self) -> int:
        """Readings held (at most ``capacity``)."""
        return self._n

    @property
    def version(self) -> int:
        """Changes made since construction (each :meth:`append` and :meth:`clear` counts; never
        reset): what a cache of evaluations against the history is keyed by."""
        return self._version

    @property
    def dropped(self) -> bool:
        """``True`` once a bounded history has let a reading drop out."""
        return self._total > self._n

    @property
    def total(self) -> int:
        """Readings appended since the start (or :meth:`clear`), including dropped ones."""
        return self._total

    def arrays(self) -> dict[str, np.ndarray]:
        """Copies of the readings held, oldest first: ``counts (K,)``, ``positions (K, d)``,
        ``dts (K,)``, ``directions (K, d)`` (NaN rows: the model's default) and
        ``exponents (K,)``."""
        order = self._order()
        return {
            "counts": self._counts[order],
            "positions": self._positions[order],
            "dts": self._dts[order],
            "directions": self._directions[order],
            "exponents": self._exponents[order],
        }

    def held(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Views of the readings held, in storage order (a bounded history's ring is not
        unrolled): ``counts (K,)``, ``positions (K, d)``, ``dts (K,)``, ``directions (K, d)``
        (NaN rows: the model's default) and ``exponents (K,)``. For compiled evaluations that
        take the checked readings as they are stored: read them, never write (they are left
        writable so that a kernel sees one array type, compiled once); valid until the next
        :meth:`append`."""
        n = self._n
        return (
            self._counts[:n],
            self._positions[:n],
            self._dts[:n],
            self._directions[:n],
            self._exponents[:n],
        )

    def latest(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The ``k`` readings appended last, oldest first, as :meth:`held` gives them (views
        while the ring has not wrapped, else copies): ``counts (k,)``, ``positions (k, d)``,
        ``dts (k,)``, ``directions (k, d)`` and ``exponents (k,)``; read them, never write."""
        n = self._n
        if not 0 <= k <= n:
            raise ConfigError("k", f"needs 0 <= k <= {n} (the readings held), got {k}")
        if self._next == 0:
            # the last written slot is n - 1 (an unbounded history, or a full ring that has
            # just come round)
            sl = slice(n - k, n)
            return (
                self._counts[sl],
                self._positions[sl],
                self._dts[sl],
                self._directions[sl],
                self._exponents[sl],
            )
        idx = (np.arange(n - k, n) + self._next) % n
        return (
            self._counts[idx],
            self._positions[idx],
            self._dts[idx],
            self._directions[idx],
            self._exponents[idx],
        )

    def _order(self) -> np.ndarray:
        n = self._n
        return (np.arange(n) + self._next) % n if n else np.arange(0)

    def log_likelihood(self, model: MeasurementModel, hypotheses: np.ndarray) -> np.ndarray:
        """``sum_k e_k log p(z_k | x_n)`` over the readings held, ``(N,)`` (0 when empty).

        The readings are checked once per model and change
        (:meth:`~odorloc.models.base.MeasurementModel.prepare_readings`), so repeated
        evaluations between two readings (the moves of one iteration) cost only the
        evaluation. They are passed in storage order (a bounded history's ring is not
        unrolled: the order of a sum does not matter beyond round-off).
        """
        x = np.atleast_2d(np.asarray(hypotheses, float))
        n = self._n
        if n == 0:
            return np.zeros(len(x))
        if self._prepared is None or self._prepared_for is not model:
            dirs = self._directions[:n]
            record: dict[str, np.ndarray] = {"dt": self._dts[:n]}
            if not np.isnan(dirs).all():
                record["direction"] = dirs
            self._prepared = model.prepare_readings(
                self._counts[:n], self._positions[:n], self._exponents[:n], record
            )
            self._prepared_for = model
        return model.prepared_log_likelihood(self._prepared, x)
