"""Reactive single-robot strategies: moth-inspired surge-cast and surge-spiral, and the
chemotaxis, anemotaxis and fluxotaxis rules on the robot's own recent samples.

Each is a short recipe over the behaviours of :mod:`odorloc.behaviours`; all move one control
period at a time (``step_length``, default the platform's speed times the period), turn to the
nearest free direction when blocked (0, +-45, +-90, +-135, 180 degrees, else any free one of 16:
:func:`~odorloc.behaviours.escape.free_move`), never declare (they suit tasks that end when the
source is reached, ``task.end: reach``) and search for the plume by casting
(:class:`~odorloc.behaviours.surge_cast.SurgeCast` with the legs of ``cast``: crosswind legs
that grow from ``amplitude`` by ``growth`` up to ``max_amplitude``; in 3-D tilted by
``elevation_deg`` to sweep heights) whenever their rule has nothing to say.

- ``surge-cast`` (Kennedy & Marsh 1974; Li, Farrell & Cardé 2001; MAPIRlab's GSL package): every
  detection (re)starts a surge of ``surge_steps`` periods straight upwind of the averaged wind;
  when it runs out without a detection the robot casts.
- ``surge-spiral`` (MAPIRlab's GSL package): the same surge, but the plume is searched for by a
  square spiral (:class:`~odorloc.behaviours.spiral.Spiral` with the legs of ``spiral``: a first
  step of ``initial_step`` growing by ``step_increment`` every second leg; the package's
  defaults 1 m and 0.4 m) started where the surge ended (and from the start position before the
  first detection).
- ``chemotaxis``: the virtual-physics paper's chemotaxis rule (eq. 3,
  :func:`~odorloc.behaviours.taxis.chemotaxis`) applied to the last ``memory`` (position,
  reading) samples of the robot around their centroid: it heads from the centroid towards the
  sample with the highest reading, so it keeps going while readings rise and turns back towards
  the best point when they fall (a gradient climb by memory). It applies once a sample detects.
- ``anemotaxis`` (eq. 4, :func:`~odorloc.behaviours.taxis.anemotaxis`): upwind of the mean of
  the last ``memory`` winds while all of the last ``memory`` readings exceed the threshold.
- ``fluxotaxis`` (eqs. 5-6, :func:`~odorloc.behaviours.taxis.fluxotaxis`): towards the sample
  with the most negative mass flux ``rho v . n`` through the ring of the last ``memory``
  samples around their centroid (odor flowing in through that side) while all readings exceed
  the threshold.

The threshold ``rho_T`` is ``threshold``; by default the gas sensor's detection threshold, and
then a reading at it counts as exceeding it, as it counts as a detection (one encounter of a hit
counter whose threshold is one hit).
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import free_move
from odorloc.behaviours.spiral import Spiral, SpiralLegParams
from odorloc.behaviours.surge_cast import CastParams, SurgeCast
from odorloc.behaviours.taxis import anemotaxis, chemotaxis, fluxotaxis
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Observation, SearchContext
from odorloc.geometry.vectors import ring
from odorloc.searchers.base import Searcher
from odorloc.sensors.preprocessing import WindAverage

__all__ = [
    "AnemotaxisParams",
    "AnemotaxisSearcher",
    "ChemotaxisParams",
    "ChemotaxisSearcher",
    "FluxotaxisSearcher",
    "ReactiveParams",
    "ReactiveSearcher",
    "SurgeCastSearchParams",
    "SurgeCastSearcher",
    "SurgeSpiralParams",
    "SurgeSpiralSearcher",
]


class ReactiveParams(Params):
    """Settings shared by the reactive strategies (see the module docstring).

    Attributes
    ----------
    step_length : float, metres, optional
        Length of one move (default: one control period at the platform's speed limit).
    wind_average : int
        Anemometer readings averaged for the upwind direction.
    threshold : float, optional
        ``rho_T`` of the taxis rules, in the sensor's units (default: its detection threshold).
    cast : CastParams
        The casting legs (:class:`~odorloc.behaviours.surge_cast.CastParams`).
    """

    step_length: Positive | None = None
    wind_average: int = Field(4, ge=1, le=10_000)
    threshold: Finite | None = None
    cast: CastParams = CastParams()


class ReactiveSearcher(Searcher):
    """Common part of the reactive strategies: step, wind average, casting, free moves."""

    params: ReactiveParams
    max_agents = 1

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Start casting with empty memories."""
        super().reset(ctx, rng)
        p = self.params
        self.step = p.step_length if p.step_length is not None else ctx.max_speed * ctx.dt
        self.threshold = p.threshold if p.threshold is not None else ctx.gas_threshold
        # rho_T of "every reading exceeds rho_T" (eqs. 4-6): with the sensor's own threshold a
        # reading counts as it does for a detection (>= threshold; one encounter of a counter)
        self.rho_t = (
            p.threshold if p.threshold is not None else math.nextafter(ctx.gas_threshold, -math.inf)
        )
        self.wind = WindAverage(p.wind_average)
        self.caster = SurgeCast(p.cast)
        self.mode = "cast"
        self.detections = 0

    def _detected(self, o: Observation) -> bool:
        return bool(o.detection)

    def free_move(
        self, pos: np.ndarray, direction: np.ndarray, rng: np.random.Generator
    ) -> Command:
        """A move of ``step`` along ``direction`` or its nearest free rotation, else any free
        direction of 16, else hold (:func:`~odorloc.behaviours.escape.free_move`)."""
        d = free_move(self.ctx.arena, pos, direction, self.step, rng)
        return Command.hold() if d is None else Command.move(d)

    def cast(self, pos: np.ndarray, up: np.ndarray, rng: np.random.Generator) -> Command:
        """One step of the casting search."""
        self.mode = "cast"
        return self.free_move(pos, self.caster.direction(self.ctx.arena, pos, up, self.step), rng)

    def diagnostics(self) -> dict[str, float]:
        """``phase``: ``"cast"``, ``"track"`` (following the rule: surge, taxis) or
        ``"spiral"``."""
        return {"phase": self.mode}

    def final_metrics(self) -> dict[str, Any]:
        """Number of detections."""
        return {"detections": float(self.detections)}


# ---------------------------------------------------------------------- surge-cast
class SurgeCastSearchParams(ReactiveParams):
    """:class:`ReactiveParams` and ``surge_steps``: periods of upwind surge per detection."""

    surge_steps: int = Field(4, ge=1, le=1_000_000)


@register("searcher", "surge-cast", SurgeCastSearchParams, "moth-inspired upwind surge + casts")
class SurgeCastSearcher(ReactiveSearcher):
    """Upwind surge after every detection, widening crosswind casts when the odor is lost."""

    params: SurgeCastSearchParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.caster = SurgeCast(self.params.cast, self.params.surge_steps)

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        pos = np.asarray(o.position, float)
        self.wind.add(o.wind)
        if self._detected(o):
            self.detections += 1
            self.caster.start_surge()
        if not o.ready:
            return Action([None])
        up = self.wind.upwind(o.heading)
        surging = self.caster.surging
        cmd = self.cast(pos, up, rng)
        self.mode = "track" if surging else "cast"
        return Action([cmd])


# ---------------------------------------------------------------------- surge-spiral
class GSLSpiralLegs(SpiralLegParams):
    """The spiral legs of MAPIRlab's GSL package: 1 m growing by 0.4 m every second leg."""

    initial_step: Positive = 1.0
    step_increment: NonNegative = 0.4


class SurgeSpiralParams(ReactiveParams):
    """:class:`ReactiveParams` and the surge and spiral settings.

    Attributes
    ----------
    surge_steps : int
        Periods of upwind surge per detection.
    spiral : SpiralLegParams
        The spiral's legs, metres (MAPIRlab's GSL defaults: ``initial_step`` 1.0,
        ``step_increment`` 0.4).
    max_skips : int
        Blocked spiral legs skipped before the spiral restarts.
    """

    surge_steps: int = Field(4, ge=1, le=1_000_000)
    spiral: GSLSpiralLegs = GSLSpiralLegs()
    max_skips: int = Field(3, ge=0, le=10_000)


@register("searcher", "surge-spiral", SurgeSpiralParams, "upwind surge + square spiral (GSL)")
class SurgeSpiralSearcher(ReactiveSearcher):
    """Upwind surge after every detection; a square spiral where the odor was lost."""

    params: SurgeSpiralParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        self.spiral = Spiral(self.params.spiral)
        self.surge_left = 0
        self.on_leg = False
        self.spiral_started = False

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        pos = np.asarray(o.position, float)
        self.wind.add(o.wind)
        up = self.wind.upwind(o.heading)
        if self._detected(o):
            self.detections += 1
            self.surge_left = self.params.surge_steps
            self.spiral_started = False
            if self.on_leg:
                # a detection ends the spiral leg at once: surge from here
                self.on_leg = False
                return Action([self._surge(pos, up, rng)])
        if self.on_leg and not o.ready:
            return Action([None])
        self.on_leg = False
        if not o.ready:
            return Action([None])
        if self.surge_left > 0:
            return Action([self._surge(pos, up, rng)])
        if not self.spiral_started:
            self.spiral.restart(math.atan2(up[1], up[0]))
            self.spiral_started = True
        return Action([self._leg(pos, rng)])

    def _surge(self, pos: np.ndarray, up: np.ndarray, rng: np.random.Generator) -> Command:
        self.surge_left = max(self.surge_left - 1, 0)
        self.mode = "track"
        return self.free_move(pos, up, rng)

    def _leg(self, pos: np.ndarray, rng: np.random.Generator) -> Command:
        self.mode = "spiral"
        arena = self.ctx.arena
        target = self.spiral.free_leg(arena, pos, self.params.max_skips)
        if target is not None:
            self.on_leg = True
            return Command.move(target - pos)
        return self.free_move(pos, ring(1, arena.dim, rng.uniform(0, 2 * math.pi))[0], rng)


# ---------------------------------------------------------------------- taxis rules
class ChemotaxisParams(ReactiveParams):
    """:class:`ReactiveParams` and ``memory``: recent samples the rule compares."""

    memory: int = Field(6, ge=2, le=10_000)


class _TaxisSearcher(ReactiveSearcher):
    """Samples of the last ``memory`` periods: positions, readings, winds."""

    params: ChemotaxisParams

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        m = self.params.memory
        self.positions: deque[np.ndarray] = deque(maxlen=m)
        self.readings: deque[float] = deque(maxlen=m)
        self.winds: deque[np.ndarray] = deque(maxlen=m)

    @abstractmethod
    def rule(self) -> np.ndarray | None:
        """The rule's direction from the samples, or ``None``."""

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        o = observations[0]
        pos = np.asarray(o.position, float)
        self.wind.add(o.wind)
        if self._detected(o):
            self.detections += 1
        self.positions.append(pos.copy())
        self.readings.append(float(o.gas))
        self.winds.append(np.asarray(o.wind, float).copy())
        if not o.ready:
            return Action([None])
        d = self.rule() if len(self.readings) == self.params.memory else None
        if d is None:
            return Action([self.cast(pos, self.wind.upwind(o.heading), rng)])
        self.mode = "track"
        return Action([self.free_move(pos, d, rng)])


@register("searcher", "chemotaxis", ChemotaxisParams, "towards the best recent reading")
class ChemotaxisSearcher(_TaxisSearcher):
    """Chemotaxis on the robot's recent samples (virtual-physics paper eq. 3)."""

    def rule(self) -> np.ndarray | None:
        r = np.array(self.readings)
        if not np.any(r >= self.threshold):
            return None
        x = np.array(self.positions)
        return chemotaxis(x.mean(axis=0), x, r)


class AnemotaxisParams(ReactiveParams):
    """:class:`ReactiveParams` and ``memory``: recent readings that must all exceed the
    threshold (and winds averaged)."""

    memory: int = Field(2, ge=1, le=10_000)


@register("searcher", "anemotaxis", AnemotaxisParams, "upwind while the odor holds, else cast")
class AnemotaxisSearcher(_TaxisSearcher):
    """Anemotaxis on the robot's recent samples (virtual-physics paper eq. 4)."""

    params: AnemotaxisParams  # type: ignore[assignment]

    def rule(self) -> np.ndarray | None:
        d = anemotaxis(np.array(self.winds), np.array(self.readings), self.rho_t)
        if d is not None and d.size == 3:
            d = d.copy()
            d[2] = 0.0  # upwind in the horizontal plane
            n = float(np.linalg.norm(d))
            return None if n < 1e-12 else d / n
        return d


@register("searcher", "fluxotaxis", ChemotaxisParams, "towards the strongest odor inflow")
class FluxotaxisSearcher(_TaxisSearcher):
    """Fluxotaxis on the robot's recent samples (virtual-physics paper eqs. 5-6)."""

    def rule(self) -> np.ndarray | None:
        x = np.array(self.positions)
        return fluxotaxis(
            x.mean(axis=0), x, np.array(self.readings), np.array(self.winds), self.rho_t
        )
