"""Source positions drawn anew for every episode (from the world's random stream).

A scenario's ``world.source_draw`` replaces the positions of its configured sources (keeping their
rates and modulations) at the start of each episode, before the plume is reset. The draw uses the
world's generator, so episode ``i`` of every searcher faces the same sources (common random
numbers) and the draw is part of the world seed.

Members (registry family ``"source_draw"``):

- ``uniform``: uniform over a box (default the arena), in free space, at least
  ``min_start_distance`` from every agent start and ``min_separation`` from each other; with
  ``rates``, each source's release rate is drawn too (log-uniform or uniform), after the
  positions (so draws without it are unchanged).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Region
from odorloc.geometry.arena import Arena
from odorloc.geometry.regions import check_region, narrow_box
from odorloc.plume.sources import Source

__all__ = ["SourceDraw", "UniformSourceDraw", "UniformSourceDrawParams"]


class SourceDraw(ABC):
    """Draws the positions of a scenario's sources for one episode."""

    params: Params

    def draw(
        self,
        sources: Sequence[Source],
        arena: Arena,
        starts: np.ndarray,
        rng: np.random.Generator,
    ) -> list[Source]:
        """The sources with new positions (and, if the draw says so, rates; modulations
        kept)."""
        pos = self.positions(len(sources), arena, np.atleast_2d(starts), rng)
        rates = self.rates(len(sources), rng)
        out = []
        for i, (s, p) in enumerate(zip(sources, pos, strict=True)):
            update: dict[str, object] = {"position": tuple(float(v) for v in p)}
            if rates is not None:
                update["rate"] = float(rates[i])
            out.append(s.model_copy(update=update))
        return out

    def rates(self, n: int, rng: np.random.Generator) -> np.ndarray | None:
        """``(n,)`` release rates, or ``None`` to keep the configured ones (default)."""
        return None

    def check(self, arena: Arena) -> None:
        """Raise :class:`ConfigError` if the draw cannot work in ``arena`` (called when the
        scenario is checked, before any episode); default: nothing to check."""
        return None

    @abstractmethod
    def positions(
        self, n: int, arena: Arena, starts: np.ndarray, rng: np.random.Generator
    ) -> np.ndarray:
        """``(n, d)`` source positions, metres."""


class UniformSourceDrawParams(Params):
    """Uniform source positions.

    Attributes
    ----------
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Box to draw from, metres (default: the arena; a 2-component box in 3D keeps the
        arena's vertical extent).
    min_start_distance : float, metres
        Least distance from every agent start.
    min_separation : float, metres
        Least distance between two sources.
    max_tries : int
        Candidate batches tried before giving up with an error.
    rates : (low, high), optional
        Draw each source's release rate from ``[low, high]`` (``0 < low < high``).
    rate_law : {"log-uniform", "uniform"}
        The law of the rates.
    """

    region: Region | None = None
    min_start_distance: NonNegative = 0.0
    min_separation: NonNegative = 0.0
    max_tries: int = Field(1000, ge=1, le=1_000_000)
    rates: tuple[Positive, Positive] | None = None
    rate_law: Literal["log-uniform", "uniform"] = "log-uniform"

    @model_validator(mode="after")
    def _check(self) -> UniformSourceDrawParams:
        if self.region is not None:
            # a NaN or inverted box is refused with the scenario, not at the first draw
            check_region(self.region, "region")
        if self.rates is not None and not self.rates[1] > self.rates[0]:
            raise ConfigError("rates", f"high ({self.rates[1]}) must exceed low ({self.rates[0]})")
        return self


@register("source_draw", "uniform", UniformSourceDrawParams, "uniform source positions")
class UniformSourceDraw(SourceDraw):
    """Sources uniform over a box in free space, away from the starts and from each other."""

    Params = UniformSourceDrawParams

    def __init__(self, params: UniformSourceDrawParams | None = None) -> None:
        self.params = params or UniformSourceDrawParams()

    def check(self, arena: Arena) -> None:
        """The region must fit the arena's dimension and overlap it."""
        # a 2-component box in a 3D arena keeps the arena's vertical extent
        narrow_box(arena.lo, arena.hi, self.params.region, "region")

    def positions(
        self, n: int, arena: Arena, starts: np.ndarray, rng: np.random.Generator
    ) -> np.ndarray:
        p = self.params
        lo, hi = arena.lo.copy(), arena.hi.copy()
        if p.region is not None:
            rlo, rhi = check_region(p.region, "world.source_draw.region")
            k = len(rlo)
            lo[:k], hi[:k] = rlo, rhi
        out: list[np.ndarray] = []
        for _ in range(p.max_tries):
            c = lo + rng.random(arena.dim) * (hi - lo)
            if not arena.is_free(c)[0]:
                continue
            if len(starts) and np.min(np.linalg.norm(starts - c, axis=1)) < p.min_start_distance:
                continue
            if out and np.min(np.linalg.norm(np.array(out) - c, axis=1)) < p.min_separation:
                continue
            out.append(c)
            if len(out) == n:
                return np.array(out)
        raise ConfigError(
            "world.source_draw", f"found no place for {n} source(s) in {p.max_tries} tries"
        )

    def rates(self, n: int, rng: np.random.Generator) -> np.ndarray | None:
        """Rates drawn from ``rates`` by ``rate_law`` (``None`` without ``rates``)."""
        p = self.params
        if p.rates is None:
            return None
        lo, hi = p.rates
        if p.rate_law == "uniform":
            return rng.uniform(lo, hi, n)
        return np.exp(rng.uniform(np.log(lo), np.log(hi), n))
