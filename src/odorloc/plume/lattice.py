"""The isotropic hit field of the lattice problem of infotaxis, as simulated truth.

:class:`LatticeIsotropicPlume` is the Vergassola rate in still air on the arena's cell lattice
(:func:`~odorloc.models.lattice.isotropic_mean_hits`): a source of rate ``R`` (the source's
``rate``, 1/s) gives an agent of radius ``a = dx / 2`` (``dx`` the arena's resolution) the
encounter rate ``R K0(d / lambda) / ln(lambda / a)`` (2-D) or ``R a exp(-d / lambda) / d``
(3-D); a hit counter (the ``encounter`` sensor) exposed ``dt`` seconds counts
``Poisson(rate dt)`` hits, so ``I = R dt``.

With ``start: initial-hit`` the plume draws each episode as OTTO does (Loisy & Eloy 2022): a first
hit ``h0 >= 1`` from its law on an unbounded domain
(:func:`~odorloc.models.lattice.initial_hit_probabilities`, with ``I = R exposure``), then the
source from the posterior ``b0 ∝ P(h0 | cell)`` over the free cells other than the start cell
(:func:`~odorloc.models.lattice.initial_belief`), both from the world's random stream. The hit
counter then reports ``h0`` as its first reading at the start (:meth:`initial_hits`). With
``start: fixed`` the configured source is used and the first reading is an ordinary one.

Concentration is the Vergassola plume's (:meth:`~odorloc.plume.vergassola.VergassolaPlume.
frame_concentration`), so frames replay like that plume's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive, Vector
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.models.lattice import (
    auto_n_hits,
    initial_belief,
    initial_hit_probabilities,
    isotropic_mean_hits,
)
from odorloc.models.poisson import MAX_CLASSES, censored_poisson
from odorloc.models.vergassola import vergassola_rate
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.plume.vergassola import VergassolaPlume
from odorloc.wind.base import WindModel

__all__ = [
    "LatticeIsotropicPlume",
    "LatticePlumeParams",
    "draw_source_after",
    "hits_at_origin",
    "lattice_origin",
]


def lattice_origin(arena: Arena, origin: Sequence[float] | None) -> np.ndarray:
    """The centre of the cell a lattice search starts from, ``(d,)`` metres: ``origin``'s cell,
    or the arena's central cell (OTTO's start); :class:`ConfigError` naming ``plume.origin``
    outside free space."""
    grid = arena.grid
    if origin is None:
        return grid.center(np.asarray(grid.shape) // 2)[0]
    o = np.asarray(origin, float)
    if o.shape != (arena.dim,):
        raise ConfigError("plume.origin", f"needs {arena.dim} components, got {o.size}")
    if not arena.is_free(o)[0]:
        where = ", ".join(f"{v:g}" for v in o)
        raise ConfigError("plume.origin", f"({where}) is outside the arena or blocked")
    return grid.center(grid.index(o))[0]


def draw_source_after(
    arena: Arena, origin: np.ndarray, likelihood: np.ndarray, rng: np.random.Generator
) -> tuple[float, ...]:
    """A source cell centre drawn from the posterior of a uniform prior after the first reading
    at ``origin``: ``b0 ∝ P(h0 | cell)`` (``likelihood``, one value per cell in the grid's flat
    order) over the free cells other than the start cell (:func:`~odorloc.models.lattice.
    initial_belief`)."""
    grid = arena.grid
    centres = grid.flat_centers()
    like = np.asarray(likelihood, float).reshape(grid.shape)
    free = arena.is_free(centres).reshape(grid.shape)
    start = tuple(int(v) for v in grid.index(origin)[0])
    b0 = initial_belief(like, start, free).reshape(-1)
    k = int(rng.choice(b0.size, p=b0))
    return tuple(float(v) for v in centres[k])


def hits_at_origin(
    initial: int | None, origin: np.ndarray, position: np.ndarray, cell: float
) -> int | None:
    """The first reading ``initial`` at the start cell's centre, ``None`` elsewhere."""
    if initial is None:
        return None
    if np.max(np.abs(np.asarray(position, float) - origin)) > 1e-9 * max(cell, 1):
        return None
    return initial


class LatticePlumeParams(Params):
    """Parameters of :class:`LatticeIsotropicPlume`.

    Attributes
    ----------
    length : float, metres
        Dispersion length ``lambda`` (at least one cell).
    start : {"fixed", "initial-hit"}
        ``initial-hit``: draw the first hit and then the source per episode (module docstring);
        ``fixed``: the configured source (``world.source_draw`` may still move it).
    origin : (d,) tuple of float, optional, metres
        Where the search starts, for ``initial-hit`` (default: the centre of the arena's central
        cell, OTTO's start; the agent must start there).
    exposure : float, seconds
        Duration of one reading (the control period), for the law of the first hit.
    n_hits : int, optional
        Hit classes of the first-hit law (the last holds ``n_hits - 1`` or more); default OTTO's
        rule ``ceil(mu(dx) + sqrt(mu(dx))) + 1``.
    """

    length: Positive = 1.0
    start: Literal["fixed", "initial-hit"] = "fixed"
    origin: Vector | None = None
    exposure: Positive = 1.0
    n_hits: int | None = Field(None, ge=2, le=256)


@register("plume", "lattice-isotropic", LatticePlumeParams, "still-air hits on a lattice (OTTO)")
class LatticeIsotropicPlume(PlumeModel):
    """Isotropic hits of the lattice problem, optionally with OTTO's episode start."""

    def __init__(
        self,
        params: LatticePlumeParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        self.cell = float(arena.resolution)
        if params.length < self.cell:
            raise ConfigError(
                "plume.length", f"must be at least one cell ({self.cell:g} m), got {params.length}"
            )
        self.origin = lattice_origin(arena, params.origin)
        if params.start == "initial-hit" and len(sources) != 1:
            raise ConfigError("plume.start", "initial-hit draws one source; configure exactly one")
        if params.start == "initial-hit":
            # a rate that gives no first hit is refused with the scenario, not at the first reset
            self._first_hit_law()
        self._initial: int | None = None
        self._src = self.source_positions
        self._sync()

    def _sources_changed(self) -> None:
        self._src = self.source_positions
        self._sync()

    def _sync(self) -> None:
        self._q = self.source_rates()

    # ------------------------------------------------------------------ episode start
    @property
    def draws_sources(self) -> bool:
        """``True`` with ``start: initial-hit`` (the source is drawn after the first hit)."""
        return self.params.start == "initial-hit"

    @property
    def initial_hit(self) -> int | None:
        """The first hit drawn at the last reset (``None`` with ``start: fixed``)."""
        return self._initial

    def reset(self, rng: np.random.Generator) -> None:
        """Restart; with ``start: initial-hit`` draw the first hit, then the source."""
        if self.params.start == "initial-hit":
            self._draw_start(rng)
        super().reset(rng)

    def _first_hit_law(self) -> tuple[float, int]:
        """Intensity ``I`` of the first reading and its number of hit classes."""
        p = self.params
        intensity = self.sources[0].rate_at(0.0) * p.exposure
        if not intensity > 0:
            raise ConfigError("world.sources[0].rate", "initial-hit needs a positive rate")
        z = (
            p.n_hits
            if p.n_hits is not None
            else auto_n_hits(p.length, intensity, self.cell, self.dim)
        )
        if z > MAX_CLASSES:
            # only the automatic rule can get here (n_hits itself is bounded)
            raise ConfigError(
                "world.plume.n_hits",
                f"OTTO's rule gives {z} hit classes at intensity {intensity:g} (at most "
                f"{MAX_CLASSES}): set n_hits or lower the rate",
            )
        return intensity, z

    def _draw_start(self, rng: np.random.Generator) -> None:
        p, dim, cell = self.params, self.dim, self.cell
        src = self.sources[0]
        intensity, z = self._first_hit_law()
        ph = initial_hit_probabilities(p.length, intensity, cell, dim, z)
        h0 = int(rng.choice(z, p=ph))
        centres = self.arena.grid.flat_centers()
        d = np.linalg.norm(centres - self.origin, axis=1)
        mu = isotropic_mean_hits(d, p.length, intensity, cell, dim)
        pos = draw_source_after(self.arena, self.origin, censored_poisson(mu, z)[:, h0], rng)
        self.set_sources([src.model_copy(update={"position": pos})])
        self._initial = h0

    def initial_hits(self, position: np.ndarray) -> int | None:
        """The first hit at the start (``initial-hit``), ``None`` elsewhere or with ``fixed``."""
        return hits_at_origin(self._initial, self.origin, position, self.cell)

    # ------------------------------------------------------------------ fields
    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        L = self.params.length
        rate = vergassola_rate(
            points, self._src, self._q, V=0.0, D=1.0, tau=L * L, a=0.5 * self.cell
        )
        return rate.sum(axis=1)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return VergassolaPlume.frame_concentration(self.frame(), points)

    def frame(self) -> dict[str, np.ndarray]:
        L = self.params.length
        e = np.zeros(self.dim)
        e[1] = -1.0  # unused at zero wind
        return {
            "model": np.array("vergassola"),
            "src": self._src.copy(),
            "q": self._q.copy(),
            "V": np.array(0.0),
            "D": np.array(1.0),
            "tau": np.array(L * L),
            "a": np.array(0.5 * self.cell),
            "direction": e,
        }
