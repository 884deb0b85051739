"""Gradient-bionic hybrid: concentration-gradient following with moth-inspired surge and cast.

The baseline of the indoor PF paper ("gradient-bionic hybrid algorithm"; the paper gives no
equations, so this is the standard combination from the literature it cites):

- **Gradient** (signal present): the concentration gradient is estimated by a least-squares
  plane fit ``c ≈ a + g · (x - x̄)`` of the last ``fit_readings`` (position, reading) pairs.
  In 3-D the fit is horizontal (the robot moves horizontally; the vertical component is 0).
  When the fit is well posed (positions spread over at least ``min_spread`` metres along both
  principal axes) and ``|g| >= min_gradient``, the robot steps along ``g / |g| + b u`` (``u`` the
  upwind unit vector, ``b = upwind_bias``); otherwise it steps upwind (anemotaxis).
- **Surge** (signal lost for ``lost_after`` steps) and **cast**: the moth-inspired behaviour of
  :mod:`odorloc.behaviours.surge_cast` (``surge_steps`` steps upwind, then the crosswind legs
  of ``cast``). Casting is also the plume-finding behaviour before the first detection.
- **Declaration** (peak confirmed): over the last ``declare_steps`` steps the robot has stayed
  within ``declare_radius`` of the mean of those positions (it circles a peak instead of
  climbing), with a detection on at least ``declare_fraction`` of them, and the last fitted
  gradient magnitude is below ``declare_gradient`` (default: no limit), and the mean reading over
  those steps is at least ``declare_peak_fraction`` of the best reading so far (a plateau far
  from the source is not a peak). The declared position is
  the reading-weighted mean of those positions (readings clipped at 0; the plain mean if all are
  0), which averages out the turbulent noise of single readings. ``declare_steps`` is 30
  (15 s at 0.5 s): shorter windows let a random walk inside the plume near the start pass for a
  peak.
- **Blocked steps** turn to the nearest free direction (0, +-45, +-90, +-135, 180 degrees;
  :func:`~odorloc.behaviours.escape.free_move`), else the robot holds.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import free_move
from odorloc.behaviours.surge_cast import CastParams, SurgeCast
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.geometry.vectors import upwind_unit
from odorloc.searchers.base import Searcher

__all__ = ["GradientBionicParams", "GradientBionicSearcher", "fit_gradient"]


def fit_gradient(
    positions: np.ndarray, readings: np.ndarray, min_spread: float = 0.0
) -> np.ndarray | None:
    """Least-squares plane fit ``c = a + g · (x - x̄)``; returns ``g`` or ``None``.

    Parameters
    ----------
    positions : (K, d) ndarray, metres
    readings : (K,) ndarray, concentration units
    min_spread : float, metres
        Minimum standard deviation of the positions along every principal axis; below it the
        gradient is not identifiable and ``None`` is returned.

    Returns
    -------
    (d,) ndarray, concentration units per metre, or None
    """
    x = np.asarray(positions, float)
    c = np.asarray(readings, float)
    if len(x) < x.shape[1] + 1:
        return None
    dx = x - x.mean(axis=0)
    sv = np.linalg.svd(dx, compute_uv=False) / math.sqrt(len(x))
    if sv.min() <= max(min_spread, 1e-12):
        return None
    g, *_ = np.linalg.lstsq(dx, c - c.mean(), rcond=None)
    return g


class GradientBionicParams(Params):
    """Parameters of :class:`GradientBionicSearcher` (see the module docstring).

    ``surge_steps`` are the steps of upwind surge after the signal is lost and ``cast`` the
    casting legs that follow (:class:`~odorloc.behaviours.surge_cast.CastParams`).
    """

    fit_readings: int = Field(6, ge=3, le=10_000)
    min_spread: NonNegative = 0.03
    min_gradient: NonNegative = 0.0
    upwind_bias: NonNegative = 0.0
    lost_after: int = Field(3, ge=1, le=1_000_000)
    surge_steps: int = Field(4, ge=0, le=1_000_000)
    cast: CastParams = CastParams()
    step_length: Positive | None = None
    declare_radius: Positive = 0.5
    declare_steps: int = Field(30, ge=1, le=1_000_000)
    declare_fraction: float = Field(0.5, ge=0.0, le=1.0)
    declare_gradient: NonNegative = math.inf
    declare_peak_fraction: float = Field(0.0, ge=0.0, le=1.0)


@register("searcher", "gradient-bionic", GradientBionicParams, "gradient following + surge/cast")
class GradientBionicSearcher(Searcher):
    """Gradient following while the signal holds, upwind surge then widening casts when it is
    lost (moth-inspired); declares at a confirmed concentration peak. Single agent."""

    params: GradientBionicParams
    max_agents = 1

    def __init__(self, params: GradientBionicParams | None = None) -> None:
        super().__init__(params or GradientBionicParams())

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Start casting (plume finding) with empty reading memory."""
        super().reset(ctx, rng)
        p = self.params
        self.step = p.step_length if p.step_length is not None else ctx.max_speed * ctx.dt
        self._readings: deque[tuple[np.ndarray, float]] = deque(maxlen=p.fit_readings)
        self.mode = "cast"
        self._since_detection = math.inf
        self._surge_cast = SurgeCast(p.cast, p.surge_steps)
        self._best = -math.inf
        self._best_pos: np.ndarray | None = None
        self._recent: deque[tuple[np.ndarray, float, bool]] = deque(maxlen=p.declare_steps)
        self._gradient: np.ndarray | None = None

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """One control period: update memory and mode, maybe declare, else move."""
        o = observations[0]
        p = self.params
        pos = np.asarray(o.position, float)
        self._readings.append((pos.copy(), float(o.gas)))
        if o.detection and o.gas > self._best:
            self._best, self._best_pos = float(o.gas), pos.copy()
        self._since_detection = 0 if o.detection else self._since_detection + 1
        if len(self._readings) >= 3:
            xs = np.array([r[0] for r in self._readings])
            cs = np.array([r[1] for r in self._readings])
            if xs.shape[1] == 3:
                # the robot moves horizontally: its heights do not spread, so fit the plane in
                # x, y (a 3-D fit would never be well posed)
                g = fit_gradient(xs[:, :2], cs, p.min_spread)
                self._gradient = None if g is None else np.append(g, 0.0)
            else:
                self._gradient = fit_gradient(xs, cs, p.min_spread)

        # Peak confirmation.
        self._recent.append((pos.copy(), float(o.gas), bool(o.detection)))
        decl = self._peak_confirmed()
        if decl is not None:
            return Action([Command.hold()], declaration=Declaration(decl[None, :], agent=o.agent))

        # Mode transitions.
        if o.detection:
            self.mode = "gradient"
        elif self.mode == "gradient" and self._since_detection >= p.lost_after:
            self.mode = "surge"
            self._surge_cast.start_surge()
        if not o.ready:
            return Action([None])
        return Action([self._move(o, pos, rng)])

    def _peak_confirmed(self) -> np.ndarray | None:
        """The declared position if the peak-confirmation rule holds, else ``None``."""
        p = self.params
        if len(self._recent) < p.declare_steps:
            return None
        xs = np.array([r[0] for r in self._recent])
        cs = np.clip([r[1] for r in self._recent], 0.0, None)
        hits = sum(r[2] for r in self._recent)
        centre = xs.mean(axis=0)
        if np.linalg.norm(xs - centre, axis=1).max() > p.declare_radius:
            return None
        if hits < p.declare_fraction * len(xs) or hits == 0:
            return None
        g = self._gradient
        if g is not None and float(np.linalg.norm(g)) >= p.declare_gradient:
            return None
        if cs.mean() < p.declare_peak_fraction * self._best:
            return None
        return (cs @ xs) / cs.sum() if cs.sum() > 0 else centre

    # ----------------------------------------------------------------- motion
    def _free_move(self, pos: np.ndarray, direction: np.ndarray) -> Command:
        """Step along ``direction``, or the nearest free rotation of it (±45°, ±90°, ...)."""
        d = free_move(self.ctx.arena, pos, direction, self.step)
        return Command.hold() if d is None else Command.move(d)

    def _move(self, o: Observation, pos: np.ndarray, rng: np.random.Generator) -> Command:
        p = self.params
        up = upwind_unit(o.wind, o.heading)
        if self.mode == "gradient":
            g = self._gradient
            gn = 0.0 if g is None else float(np.linalg.norm(g))
            if g is not None and gn > max(p.min_gradient, 1e-12):
                # Unit gradient plus an upwind bias: single readings in a turbulent plume give
                # noisy gradients; the bias keeps the robot progressing towards the source.
                return self._free_move(pos, g / gn + p.upwind_bias * up)
            return self._free_move(pos, up)
        d = self._surge_cast.direction(self.ctx.arena, pos, up, self.step)
        self.mode = "surge" if self._surge_cast.surging else "cast"
        return self._free_move(pos, d)

    def diagnostics(self) -> dict[str, float]:
        """``phase`` (``"cast"``, ``"gradient"`` or ``"surge"``), ``best`` reading,
        ``gradient`` magnitude."""
        g = self._gradient
        return {
            "phase": self.mode,
            "best": self._best if math.isfinite(self._best) else math.nan,
            "gradient": math.nan if g is None else float(np.linalg.norm(g)),
        }
