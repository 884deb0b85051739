"""The hit field of the windy lattice problem (otto-benchmark), as simulated truth.

:class:`LatticeWindyPlume` gives an agent on the arena's cell lattice the hits of
:func:`odorloc.models.lattice_windy.windy_mean_hits` per step: the encounter rate is
``mu / exposure`` (1/s), so an ``encounter`` sensor read every ``exposure`` seconds counts
``Poisson(mu)`` hits. The source's ``rate`` is the problem's ``R`` per step of ``exposure``.

With ``start: initial-hit`` each episode starts as otto-benchmark's windy cases do: the agent
has received ``initial_hit`` hits (1) at its start; the source is drawn, from the world's
random stream, from the posterior of a uniform prior after that reading, ``b0 ∝ P(h0 | cell)``
over the free cells other than the start cell, and the hit counter reports ``h0`` there as its
first reading (:meth:`initial_hits`). With ``start: fixed`` the configured source is used.
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
from odorloc.models.lattice_windy import windy_length, windy_mean_hits
from odorloc.models.poisson import censored_poisson
from odorloc.plume.base import PlumeModel
from odorloc.plume.lattice import draw_source_after, hits_at_origin, lattice_origin
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel
from odorloc.wind.uniform import UniformWind

__all__ = ["LatticeWindyParams", "LatticeWindyPlume"]


class LatticeWindyParams(Params):
    """Parameters of :class:`LatticeWindyPlume`.

    Attributes
    ----------
    wind : float
        ``V``: dimensionless mean wind, blowing along the first axis (a uniform world wind
        that blows another way is refused).
    tau : float
        Dimensionless turbulent coherence time.
    start : {"fixed", "initial-hit"}
        ``initial-hit``: draw the source per episode after the first reading (module
        docstring); ``fixed``: the configured source.
    origin : (d,) tuple of float, optional, metres
        Where the search starts, for ``initial-hit`` (the agent must start there); default the
        centre of the arena's central cell.
    initial_hit : int
        The first reading's hits (otto-benchmark: 1).
    n_hits : int
        Hit classes of the first reading's law (the last holds ``n_hits - 1`` or more).
    exposure : float, seconds
        Duration of one reading (the control period).
    """

    wind: Positive = 2.0
    tau: Positive = 150.0
    start: Literal["fixed", "initial-hit"] = "fixed"
    origin: Vector | None = None
    initial_hit: int = Field(1, ge=1, le=63)
    n_hits: int = Field(2, ge=2, le=64)
    exposure: Positive = 1.0


@register("plume", "lattice-windy", LatticeWindyParams, "hits on a lattice in a mean wind (OTTO)")
class LatticeWindyPlume(PlumeModel):
    """Hits of the windy lattice problem, optionally with otto-benchmark's episode start."""

    dims = (2,)

    def __init__(
        self,
        params: LatticeWindyParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        if self.dim != 2:
            raise ConfigError("world.plume", "the windy lattice problem is 2-D")
        self.params = params
        self.cell = float(arena.resolution)
        windy_length(params.wind, params.tau)
        if params.initial_hit > params.n_hits - 1:
            raise ConfigError("plume.initial_hit", f"must be below n_hits ({params.n_hits})")
        self.origin = lattice_origin(arena, params.origin)
        if params.start == "initial-hit" and len(sources) != 1:
            raise ConfigError("plume.start", "initial-hit draws one source; configure exactly one")
        if isinstance(wind, UniformWind):
            # the hits blow along +x whatever world.wind says; a world wind the other way
            # would be read by the anemometer and drawn, but never carry the plume
            u = wind.mean_velocity()
            speed = float(np.hypot(u[0], u[1]))
            if speed > 0.0 and not (u[0] > 0.0 and abs(u[1]) <= 1e-9 * speed):
                raise ConfigError(
                    "plume.wind",
                    "the windy lattice problem's wind blows along +x, but world.wind blows "
                    f"towards ({u[0]:g}, {u[1]:g}) m/s: give world.wind a velocity along +x",
                )
        self._initial: int | None = None
        self._src = self.source_positions
        self._q = self.source_rates()

    def _sources_changed(self) -> None:
        self._src = self.source_positions
        self._q = self.source_rates()

    def _sync(self) -> None:
        self._q = self.source_rates()

    def reset(self, rng: np.random.Generator) -> None:
        """Restart; with ``start: initial-hit`` draw the source after the first reading."""
        if self.params.start == "initial-hit":
            self._draw_start(rng)
        super().reset(rng)

    def _draw_start(self, rng: np.random.Generator) -> None:
        p = self.params
        src = self.sources[0]
        centres = self.arena.grid.flat_centers()
        mu = windy_mean_hits(
            self.origin - centres, src.rate_at(0.0) * p.exposure, p.wind, p.tau, self.cell
        )
        like = censored_poisson(mu, p.n_hits)[:, p.initial_hit]
        pos = draw_source_after(self.arena, self.origin, like, rng)
        self.set_sources([src.model_copy(update={"position": pos})])
        self._initial = p.initial_hit

    @property
    def draws_sources(self) -> bool:
        """``True`` with ``start: initial-hit`` (the source is drawn after the first hit)."""
        return self.params.start == "initial-hit"

    def initial_hits(self, position: np.ndarray) -> int | None:
        """The first reading at the start (``initial-hit``), ``None`` elsewhere."""
        return hits_at_origin(self._initial, self.origin, position, self.cell)

    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        return self.frame_concentration(self.frame(), points)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return self.frame_concentration(self.frame(), points)

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Hits per second at ``points`` ``(N, 2)`` of a recorded frame, summed over sources."""
        pts = np.atleast_2d(np.asarray(points, float))
        src = np.atleast_2d(frame["src"])
        q = np.asarray(frame["q"], float)
        mu = windy_mean_hits(
            pts[:, None, :] - src[None, :, :],
            q[None, :] * float(frame["exposure"]),
            float(frame["wind"]),
            float(frame["tau"]),
            float(frame["cell"]),
        )
        return mu.sum(axis=1) / float(frame["exposure"])

    def frame(self) -> dict[str, np.ndarray]:
        p = self.params
        return {
            "model": np.array("lattice-windy"),
            "src": self._src.copy(),
            "q": self._q.copy(),
            "wind": np.array(p.wind),
            "tau": np.array(p.tau),
            "cell": np.array(self.cell),
            "exposure": np.array(p.exposure),
        }
