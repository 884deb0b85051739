"""Grid Bayes filter over the source position (2-D and 3-D), in log space.

The hypotheses are the cells of a :class:`~odorloc.geometry.grid.CellGrid` (obstacle cells
excluded) and, optionally, a small set of release rates ``Q_1 .. Q_K`` marginalised with the
position: the state is the joint log-probability ``log b(k, x)``, shape ``(K, n1, ..., nd)``
(``K = 1`` for a known release). A reading ``z`` at the sensor position ``s`` updates it by
Bayes' rule,

    ``log b(k, x) <- log b(k, x) + log p(z | x, Q_k, s) - log Z``,

with any measurement model of :mod:`odorloc.models` (:meth:`GridFilter.observe`; the release is
passed as the model's ``release`` condition), or, for a translation-invariant model tabulated
over lattice offsets (:func:`~odorloc.models.lattice.tabulate`), by adding a slice of the table
(:meth:`GridFilter.observe_table`, the fast path of the lattice problem). Normalisation subtracts
the maximum first (:func:`~odorloc.inference.weights.normalise_log_weights`).

Not finding the source where the searcher stands is information too (a search that ends when
the source is reached): :meth:`GridFilter.exclude_near` removes the cells within a radius of a
point. If a reading is impossible under every remaining hypothesis (a model that contradicts the
data), the belief restarts uniform over the admissible cells and :attr:`GridFilter.restarts`
counts it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.belief import GridBelief
from odorloc.inference.weights import normalise_log_weights
from odorloc.models.base import BoundModel, MeasurementModel
from odorloc.models.lattice import OffsetTable

__all__ = ["GridFilter", "grid_entropy"]

FloatArray = NDArray[np.float64]
_LN2 = math.log(2.0)


def grid_entropy(prob: ArrayLike, unit: Literal["bits", "nats"] = "bits") -> float:
    """Shannon entropy ``-sum p log p`` of a probability array (zeros ignored), bits or nats."""
    p = np.asarray(prob, float).reshape(-1)
    p = p[p > 0]
    h = float(-np.sum(p * np.log(p)))
    if unit == "bits":
        return h / _LN2
    if unit == "nats":
        return h
    raise ConfigError("unit", f"expected 'bits' or 'nats', got {unit!r}")


class GridFilter:
    """Bayes filter over source cells (and release rates); see the module docstring.

    Parameters
    ----------
    grid : CellGrid
    free : bool ndarray of the grid's shape, optional
        Cells that may hold the source (default all; obstacle cells are ``False``).
    log_prior : ndarray of the grid's shape, optional
        Unnormalised log prior over positions (default uniform over ``free``).
    releases : sequence of float, optional
        Release rates marginalised with the position (model units, passed as ``release``).
    release_prior : sequence of float, optional
        Prior weights of ``releases`` (default uniform).
    """

    def __init__(
        self,
        grid: CellGrid,
        *,
        free: ArrayLike | None = None,
        log_prior: ArrayLike | None = None,
        releases: Sequence[float] | None = None,
        release_prior: Sequence[float] | None = None,
    ) -> None:
        self.grid = grid
        self.shape = grid.shape
        ok = np.ones(self.shape, bool) if free is None else np.asarray(free, bool)
        if ok.shape != self.shape:
            raise ConfigError("free", f"shape {ok.shape} != grid {self.shape}")
        if not ok.any():
            raise ConfigError("free", "no cell may hold the source")
        self.free = ok.copy()
        if releases is None:
            self.releases: FloatArray | None = None
            lr = np.zeros(1)
        else:
            r = np.asarray(releases, float).reshape(-1)
            if r.size == 0 or not np.all(np.isfinite(r)) or np.any(r <= 0):
                raise ConfigError("releases", "need one or more finite rates > 0")
            self.releases = r
            if release_prior is None:
                lr = np.zeros(r.size)
            else:
                w = np.asarray(release_prior, float).reshape(-1)
                # an infinite weight would make the joint +inf and the belief silently uniform
                if (
                    w.shape != r.shape
                    or not np.all(np.isfinite(w))
                    or np.any(w < 0)
                    or not w.sum() > 0
                ):
                    raise ConfigError(
                        "release_prior", f"needs {r.size} finite weights >= 0, not all 0"
                    )
                with np.errstate(divide="ignore"):
                    lr = np.log(w)
        if log_prior is None:
            lp = np.zeros(self.shape)
        else:
            lp = np.asarray(log_prior, float)
            if lp.shape != self.shape or np.any(np.isnan(lp)) or np.any(lp == np.inf):
                raise ConfigError("log_prior", f"needs shape {self.shape}, no NaN or +inf")
            if not np.isfinite(lp[ok]).any():
                raise ConfigError("log_prior", "gives no free cell a probability above zero")
        self._log_release_prior = lr
        self._log_position_prior = np.where(ok, lp, -np.inf)
        self.admissible = ok.copy()
        self.restarts = 0
        self._centres: FloatArray | None = None
        self._lo = np.asarray(grid.lower, float)
        self._cs = grid.cells
        self._set(lr[:, None] + self._log_position_prior.reshape(1, -1))

    @classmethod
    def over_arena(
        cls,
        arena: Arena,
        *,
        cell_size: float | None = None,
        region: Sequence[Sequence[float]] | None = None,
        **kwargs: Any,
    ) -> GridFilter:
        """A filter over an arena's free cells.

        Parameters
        ----------
        arena : Arena
        cell_size : float, metres, optional
            Cell side (default: the arena's occupancy cells).
        region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
            Box to cover (default the arena; a 2-component box of a 3-D arena keeps its height).
        **kwargs
            ``log_prior``, ``releases``, ``release_prior`` (see the class).
        """
        if cell_size is None and region is None:
            grid = arena.grid
        else:
            lo, hi = arena.lo.copy(), arena.hi.copy()
            if region is not None:
                k = len(region[0])
                lo[:k] = np.maximum(lo[:k], np.asarray(region[0], float))
                hi[:k] = np.minimum(hi[:k], np.asarray(region[1], float))
            cs = float(arena.resolution if cell_size is None else cell_size)
            grid = CellGrid.from_extent(lo, hi, cs, rounding="floor")
        free = arena.is_free(grid.flat_centers()).reshape(grid.shape)
        return cls(grid, free=free, **kwargs)

    # ------------------------------------------------------------------ state
    def _set(self, log_joint: np.ndarray) -> None:
        lw = np.asarray(log_joint, float).reshape(-1)
        if not np.isfinite(lw.max(initial=-np.inf)):
            # every hypothesis contradicted: start again from the prior over admissible cells
            self.restarts += 1
            base = np.where(self.admissible, self._log_position_prior, -np.inf)
            if not np.isfinite(base.max()):
                raise ConfigError("grid_filter", "every cell has been excluded")
            lw = (self._log_release_prior[:, None] + base.reshape(1, -1)).reshape(-1)
        log_w, w = normalise_log_weights(lw)
        self._log = log_w.reshape(self.n_releases, *self.shape)
        self._joint = w.reshape(self.n_releases, *self.shape)
        self._prob: FloatArray | None = None

    @property
    def centres(self) -> FloatArray:
        """Cell centres ``(n, d)`` in C order, metres (read-only, computed once)."""
        if self._centres is None:
            c = self.grid.flat_centers()
            c.setflags(write=False)
            self._centres = c
        return self._centres

    @property
    def n_releases(self) -> int:
        """``K``, the number of release hypotheses (1 for a known release)."""
        return 1 if self.releases is None else int(self.releases.size)

    @property
    def log_joint(self) -> FloatArray:
        """Normalised joint log-probabilities ``(K, n1, ..., nd)`` (a copy)."""
        return self._log.copy()

    @property
    def joint(self) -> FloatArray:
        """Joint probabilities ``(K, n1, ..., nd)``, summing to one (read-only view)."""
        v = self._joint.view()
        v.setflags(write=False)
        return v

    @property
    def prob(self) -> FloatArray:
        """Position probabilities ``(n1, ..., nd)`` (the release marginalised; read-only)."""
        if self._prob is None:
            self._prob = self._joint.sum(axis=0) if self.n_releases > 1 else self._joint[0]
        v = self._prob.view()
        v.setflags(write=False)
        return v

    @property
    def release_prob(self) -> FloatArray:
        """Posterior of the release hypotheses ``(K,)``."""
        return self._joint.reshape(self.n_releases, -1).sum(axis=1)

    def entropy(self, unit: Literal["bits", "nats"] = "bits", joint: bool = False) -> float:
        """Entropy of the position belief (or of the joint position-release belief)."""
        return grid_entropy(self._joint if joint else self.prob, unit)

    def mean(self) -> FloatArray:
        """Expected source position, ``(d,)`` metres."""
        return self.prob.reshape(-1) @ self.centres

    def belief(self) -> GridBelief:
        """A snapshot for planners and the recorder (the release posterior in ``extra``)."""
        extra = {} if self.releases is None else {"release_prob": self.release_prob}
        return GridBelief(self.grid, self.prob.copy(), extra)

    # ------------------------------------------------------------------ updates
    def update(self, log_likelihood: ArrayLike) -> None:
        """Add log-likelihoods ``(n1, ..., nd)`` or ``(K, n1, ..., nd)`` and normalise."""
        ll = np.asarray(log_likelihood, float)
        if ll.shape == self.shape:
            ll = ll[None]
        if ll.shape != (self.n_releases, *self.shape):
            raise ConfigError(
                "log_likelihood", f"shape {ll.shape} != {self.shape} or (K, {self.shape})"
            )
        if np.any(np.isnan(ll)) or np.any(ll == np.inf):
            raise ConfigError("log_likelihood", "must not contain NaN or +inf")
        self._set(self._log + ll)

    def observe(
        self,
        model: MeasurementModel | BoundModel,
        z: Any,
        sensor_position: ArrayLike,
        **conditions: Any,
    ) -> None:
        """Bayes update with a reading ``z`` at ``sensor_position`` ``(d,)`` under ``model``."""
        centres = self.centres
        s = np.asarray(sensor_position, float)
        rows = []
        for k in range(self.n_releases):
            cond = dict(conditions)
            if self.releases is not None:
                cond["release"] = float(self.releases[k])
            rows.append(np.asarray(model.log_likelihood(z, s, centres, **cond), float))
        ll = np.stack(rows).reshape(self.n_releases, *self.shape)
        self.update(np.where(self.free, ll, 0.0))

    def observe_table(
        self, tables: Sequence[OffsetTable], z_class: int, sensor_cell: Sequence[int]
    ) -> None:
        """Bayes update from offset tables (one per release): class ``z_class`` read in cell
        ``sensor_cell`` (which may lie outside the grid if the tables cover it)."""
        if len(tables) != self.n_releases:
            raise ConfigError("tables", f"need {self.n_releases} table(s), got {len(tables)}")
        cell = tuple(int(v) for v in sensor_cell)
        rows = []
        for t in tables:
            if not 0 <= z_class < t.n_classes:
                raise ConfigError("z_class", f"{z_class} is not a class of 0..{t.n_classes - 1}")
            rows.append(t.log_prob[(z_class, *t.window(cell, self.shape))])
        ll = np.stack(rows)
        self._set(self._log + np.where(self.free, ll, 0.0))

    def exclude(self, mask: ArrayLike) -> None:
        """Cells (bool ``(n1, ..., nd)``) that cannot hold the source, from now on."""
        m = np.asarray(mask, bool)
        if m.shape != self.shape:
            raise ConfigError("mask", f"shape {m.shape} != grid {self.shape}")
        if not m.any():
            return
        self.admissible &= ~m
        self._set(np.where(m[None], -np.inf, self._log))

    def near(self, point: ArrayLike, radius: float) -> NDArray[np.bool_]:
        """Cells whose centre lies within ``radius`` metres of ``point`` (always the cell that
        contains the point, when it is in the grid)."""
        p = np.asarray(point, float).reshape(-1)
        g = self.grid
        m = np.zeros(self.shape, bool)
        lo, cs = self._lo, self._cs
        # only the box of cells that can be within the radius
        i0 = np.maximum(np.floor((p - radius - lo) / cs).astype(int), 0)
        i1 = np.minimum(np.floor((p + radius - lo) / cs).astype(int) + 1, np.asarray(self.shape))
        if np.all(i1 > i0):
            axes = [lo[a] + (np.arange(i0[a], i1[a]) + 0.5) * cs[a] for a in range(g.dim)]
            d2 = sum(
                ((ax - p[a]) ** 2).reshape([-1 if b == a else 1 for b in range(g.dim)])
                for a, ax in enumerate(axes)
            )
            box = tuple(slice(int(a), int(b)) for a, b in zip(i0, i1, strict=True))
            m[box] = np.asarray(d2) <= radius * radius
        k = np.floor((p - lo) / cs).astype(int)
        if np.all((k >= 0) & (k < np.asarray(self.shape))):
            m[tuple(k)] = True
        return m

    def exclude_near(self, point: ArrayLike, radius: float) -> None:
        """The source is not within ``radius`` metres of ``point`` (nor in its cell)."""
        self.exclude(self.near(point, radius))
