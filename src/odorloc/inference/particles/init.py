"""Initial particle sets: uniform over free space, and back-tracking the recorded wind.

The functions draw particle sets; the ``particle_init`` family (:class:`UniformInit`,
:class:`BacktrackInit`) says when a particle filter draws them and how.
"""

from __future__ import annotations

import math
from abc import ABC
from typing import Any

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Configured, NonNegative, Params
from odorloc.core.registry import register
from odorloc.core.types import Observation, Region, SearchContext
from odorloc.geometry.arena import Arena
from odorloc.geometry.regions import narrow_box, task_region
from odorloc.models.base import MeasurementModel
from odorloc.models.pang_farrell import PangFarrellModel

__all__ = [
    "BacktrackInit",
    "BacktrackParams",
    "ParticleInit",
    "UniformInit",
    "UniformInitParams",
    "backtrack_initialise",
    "sample_free_uniform",
]


def sample_free_uniform(
    arena: Arena,
    n: int,
    rng: np.random.Generator,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    field: str = "arena",
) -> np.ndarray:
    """``n`` points uniform over the free space of ``arena`` (inside ``box``), ``(n, d)`` metres.

    Rejection sampling from ``box`` (default the arena's bounds, e.g.
    :func:`~odorloc.geometry.regions.narrow_box` of a search region).

    Raises
    ------
    ConfigError
        Naming ``field`` when the box holds (almost) no free space.
    """
    lo, size = (arena.lo, arena.size) if box is None else (box[0], box[1] - box[0])
    out = np.zeros((0, arena.dim))
    for _ in range(100):
        if len(out) >= n:
            break
        cand = lo + rng.random((max(2 * (n - len(out)), 16), arena.dim)) * size
        out = np.concatenate([out, cand[arena.is_free(cand)]], axis=0)
    if len(out) < n:
        raise ConfigError(field, "too little free space to sample particles")
    return out[:n]


def backtrack_initialise(
    detection_pos: np.ndarray,
    wind_window: np.ndarray,
    dt: float,
    n: int,
    rng: np.random.Generator,
    *,
    arena: Arena | None = None,
    model: PangFarrellModel | None = None,
    wind_var: np.ndarray | None = None,
    min_std: NonNegative = 0.1,
    uniform_fraction: float = 0.0,
    max_redraws: int = 10,
) -> np.ndarray:
    """Initial particles by back-tracking the recorded wind from the first detection.

    A patch detected at ``detection_pos`` at step ``k`` and released at record ``l`` left the
    source from about ``detection_pos - s(l, k)`` (``s`` the advection of eq. 8) with a spread
    that grows with the elapsed time (eq. 11). Each particle picks a record ``l`` of the window
    uniformly at random and is drawn from ``N(detection_pos - s(l, k), v(l, k) + min_std^2)``
    per axis, so the cloud stretches upwind along the recorded wind path (indoor PF paper,
    section 2.2, step 1).

    A fraction ``uniform_fraction`` of the particles is instead drawn uniformly over the free
    space (robustness when the window is shorter than the travel time from the source).
    Particles outside the arena or in obstacles are redrawn up to ``max_redraws`` times, then
    clipped into the bounds; any still in an obstacle are replaced by uniform free-space draws.

    Parameters
    ----------
    detection_pos : (d,) ndarray, metres
        Finite, with the arena's number of components.
    wind_window : (W, d) ndarray, m/s
        Recorded winds before the detection, oldest first; ``W >= 1``, finite.
    dt : float, s
        Record period, finite and > 0.
    n : int
        Number of particles.
    rng : numpy.random.Generator
    arena : Arena, optional
    model : PangFarrellModel, optional
        Supplies the advection/spread geometry (default parameters if ``None``).
    wind_var : (d,) ndarray, m^2/s^2, optional
    min_std : float, metres
    uniform_fraction : float in [0, 1]
    max_redraws : int

    Returns
    -------
    (n, d) ndarray, metres
    """
    if n < 1:
        raise ConfigError("n", "must be >= 1")
    if not 0.0 <= uniform_fraction <= 1.0:
        raise ConfigError("uniform_fraction", "must be in [0, 1]")
    if uniform_fraction > 0 and arena is None:
        raise ConfigError("uniform_fraction", "needs an arena")
    det = np.asarray(detection_pos, float)
    if det.ndim != 1 or not np.all(np.isfinite(det)):
        raise ConfigError("detection_pos", f"expected finite shape (d,), got {det.shape}")
    if arena is not None and det.size != arena.dim:
        raise ConfigError("detection_pos", f"expected {arena.dim} components, got {det.size}")
    winds = np.asarray(wind_window, float)
    # a malformed window would otherwise fail deep in NumPy or, with a NaN reading or period,
    # give NaN particles that the arena clipping below silently turns into uniform draws
    if winds.ndim != 2 or len(winds) == 0 or winds.shape[1] != det.size:
        raise ConfigError("wind_window", f"expected shape (W>=1, {det.size}), got {winds.shape}")
    if not np.all(np.isfinite(winds)):
        raise ConfigError("wind_window", "every reading must be finite")
    if not (math.isfinite(dt) and dt > 0):
        raise ConfigError("dt", f"must be a finite number > 0, got {dt}")
    if not (math.isfinite(min_std) and min_std >= 0):
        raise ConfigError("min_std", f"must be a finite number >= 0, got {min_std}")
    if wind_var is not None:
        wv = np.asarray(wind_var, float)
        if wv.shape != det.shape or not np.all(np.isfinite(wv)) or np.any(wv < 0):
            raise ConfigError("wind_var", f"expected {det.size} finite variances >= 0")
    model = model or PangFarrellModel()
    shift, var = model.puff_geometry(winds, dt, wind_var)
    std = np.sqrt(var + min_std**2)  # (W, d)

    n_uni = round(uniform_fraction * n)
    n_bt = n - n_uni

    def draw(m: int) -> np.ndarray:
        rec = rng.integers(0, len(shift), size=m)
        return det - shift[rec] + std[rec] * rng.standard_normal((m, det.size))

    pos = draw(n_bt)
    if arena is not None and n_bt:
        for _ in range(max_redraws):
            bad = ~arena.is_free(pos)
            if not bad.any():
                break
            pos[bad] = draw(int(bad.sum()))
        pos = arena.clip(pos)
        bad = ~arena.is_free(pos)
        if bad.any():
            pos[bad] = sample_free_uniform(arena, int(bad.sum()), rng)
    if n_uni:
        assert arena is not None
        pos = np.concatenate([pos, sample_free_uniform(arena, n_uni, rng)], axis=0)
    return pos


# ---------------------------------------------------------------------- particle_init family
class ParticleInit(Configured, ABC):
    """How a particle filter gets its first particles (registry family ``particle_init``).

    :meth:`start` may give them at the start of the episode; otherwise :meth:`on_reading` is
    asked at every reading until it gives them. :meth:`redraw` gives fresh hypotheses when every
    particle has been ruled out.
    """

    def reset(self, ctx: SearchContext, model: MeasurementModel | None) -> None:
        """A new episode (check that the model suits the initialisation)."""
        self.ctx = ctx

    def start(self, n: int, rng: np.random.Generator) -> np.ndarray | None:
        """``(n, d)`` particles at the start of the episode, or ``None`` to wait for a reading."""
        return None

    def on_reading(
        self,
        o: Observation,
        conditions: dict[str, Any],
        n: int,
        rng: np.random.Generator,
    ) -> np.ndarray | None:
        """``(n, d)`` particles drawn at the reading ``o`` (read under ``conditions``), or
        ``None`` to wait for another."""
        return None

    def redraw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``(n, d)`` fresh hypotheses, uniform over the arena's free space by default."""
        return sample_free_uniform(self.ctx.arena, n, rng)


class UniformInitParams(Params):
    """Settings of :class:`UniformInit`.

    Attributes
    ----------
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        Where the particles lie (default: the task's search region, else the arena).
    """

    region: Region | None = None


@register("particle_init", "uniform", UniformInitParams, "uniform over the free search region")
class UniformInit(ParticleInit):
    """Particles uniform over the free part of the search region, at the start."""

    params: UniformInitParams
    Params = UniformInitParams

    def reset(self, ctx: SearchContext, model: MeasurementModel | None) -> None:
        super().reset(ctx, model)
        region = task_region(ctx, self.params.region)
        self.box = narrow_box(ctx.arena.lo, ctx.arena.hi, region, "searcher.region")

    def start(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return sample_free_uniform(self.ctx.arena, n, rng, self.box, "searcher.region")

    def redraw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return self.start(n, rng)


class BacktrackParams(Params):
    """Settings of :class:`BacktrackInit`.

    Attributes
    ----------
    min_std : float, metres
        Floor on the back-tracking spread.
    uniform_fraction : float
        Fraction of the particles drawn uniformly over free space instead.
    """

    min_std: NonNegative = 0.1
    uniform_fraction: float = Field(0.0, ge=0.0, le=1.0)


@register(
    "particle_init", "backtrack", BacktrackParams, "back-tracking the wind at the first detection"
)
class BacktrackInit(ParticleInit):
    """Particles drawn at the first detection by back-tracking the recorded wind
    (:func:`backtrack_initialise`; indoor PF paper, section 2.2, step 1).

    Needs the Pang & Farrell model (its puff geometry) and a reading read under a recorded wind
    window (``reading: {type: wind-window}``).
    """

    params: BacktrackParams
    Params = BacktrackParams

    def reset(self, ctx: SearchContext, model: MeasurementModel | None) -> None:
        super().reset(ctx, model)
        if not isinstance(model, PangFarrellModel):
            raise ConfigError(
                "searcher.estimator.init",
                "back-tracking needs the pang-farrell model (its puff geometry)",
            )
        self.model = model

    def on_reading(
        self,
        o: Observation,
        conditions: dict[str, Any],
        n: int,
        rng: np.random.Generator,
    ) -> np.ndarray | None:
        if not o.detection:
            return None
        if "wind_window" not in conditions:
            raise ConfigError(
                "searcher.estimator.init", "back-tracking needs a reading of type wind-window"
            )
        return backtrack_initialise(
            np.asarray(o.position, float),
            conditions["wind_window"],
            self.ctx.dt,
            n,
            rng,
            arena=self.ctx.arena,
            model=self.model,
            wind_var=conditions.get("wind_var"),
            min_std=self.params.min_std,
            uniform_fraction=self.params.uniform_fraction,
        )
