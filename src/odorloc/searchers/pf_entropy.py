"""Plume-model particle filter + expected-entropy moves (indoor PF paper).

Recipe (indoor PF paper, section 2): a measurement model, a single-agent estimator and a
planner, each a part named in :class:`PFEntropyParams`:

1. **Zigzag** (section 2.1, Fig. 1): until the estimator has a belief (the first detection),
   straight legs at a fixed angle to the averaged wind, alternating sides; a leg ends when the
   next step is blocked (``arena.segment_free``) or after ``zigzag.max_leg`` metres. When both
   upwind legs are blocked (the robot reached the upwind wall) the legs turn to the downwind
   side, and back again at the downwind wall, so the Z pattern sweeps the room.
2. **Estimator** (``estimator``, default the ``particle-filter`` with the paper's parts:
   back-tracking initialisation at the first detection, the Pang & Farrell likelihood over the
   recorded wind window (eqs. 4, 10, 11), roulette resampling when ``N_eff < 0.5 N`` (eq. 12)
   and the dual convergence test (eqs. 15-16)), updated every control period; when its
   stopping rule holds, the estimate is declared.
3. **Motion** (``planner``, default ``entropy``): when the previous move is done, one of
   forward/backward/left/right (robot frame) minimising the expected posterior entropy
   (eqs. 17-18), the hypothetical reading evaluated under the conditions of the next reading
   (the wind window shifted by one record, :meth:`~odorloc.inference.estimator.Estimator.
   conditions`). When every move is blocked the robot follows an A* path towards the current
   estimate.
4. Optional (``approach_radius``, off by default): once converged, drive to the estimate (A*
   around obstacles) and declare only within that distance of it.

``diagnostics()`` reports the estimator's (``ess``, ``weight_entropy``, ``spread``,
``n_particles``) and ``phase`` (``"zigzag"``, ``"tracking"``), ``entropy`` (Shannon entropy, nats,
of the weighted particle histogram on ``entropy_cell`` cells -- unlike the weight entropy it keeps
falling through resampling as the cloud contracts, which is what the paper's Figs. 5/7 show) and
``expected_entropy`` of the last plan.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import escape_move
from odorloc.behaviours.zigzag import Zigzag, ZigzagLegParams
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.inference.belief import ParticleBelief, histogram_entropy
from odorloc.inference.estimator import Estimator
from odorloc.models.base import MeasurementModel
from odorloc.planning.astar import astar_path
from odorloc.planning.base import Planner, Pose
from odorloc.searchers.base import Belief, Searcher
from odorloc.sensors.preprocessing import WindAverage

__all__ = ["PFEntropyParams", "PFEntropySearcher"]


class PFEntropyParams(Params):
    """Parameters of :class:`PFEntropySearcher` (defaults from the indoor PF paper).

    Parameters
    ----------
    model : dict
        The measurement model, ``{type: pang-farrell, ...}`` (paper: detection probability
        ``mu = 0.9``, eq. 10). ``sensor_area`` ``S_p`` is not given in the paper: 0.1 m^2 is
        chosen for the indoor-ventilated scenario, and ``min_wind_variance`` 0.05 m^2/s^2 as a
        floor on the recorded wind variance.
    estimator : dict
        The estimator, ``{type: particle-filter, ...}`` (see
        :class:`~odorloc.inference.particles.estimator.ParticleFilterParams`: 1000 particles,
        back-tracking, 20-record wind window, roulette, ``N_eff < 0.5 N``, dual convergence
        with ``r_conv = 0.5`` m read as a radius and ``r_err = 0.25`` m; the reproduction reports
        the literal reading too, ``pf-entropy-literal``).
    planner : dict
        The motion planner, ``{type: entropy, candidates: {frame: robot | wind | world}}``.
    zigzag : dict
        The zigzag legs before the first detection, ``{angle_deg: 45, max_leg: null}``
        (``max_leg`` ``None``: turn only at walls and obstacles, as in the paper).
    step_length : float or None, metres
        Length of a zigzag or approach step; ``None`` = one control period at the platform's
        top speed (the planner's moves have their own, ``planner.candidates.step_length``).
    wind_average : int
        Number of recent wind readings averaged for the zigzag direction.
    approach_radius : float or None, metres
        ``None`` (paper): declare as soon as the estimator's stopping rule holds. Otherwise,
        once it holds, the robot drives to the estimate (still updating the filter) and
        declares only within this distance of it -- the paper's robots end at the source
        (Table 1 "Terminal"), and close readings correct estimates made from afar.
    astar_clearance : float, metres
        Obstacle growth for A* detours.
    entropy_cell : float, metres
        Cell size of the particle histogram behind the ``entropy`` diagnostic.
    """

    model: Ref("model") = ComponentRef(type="pang-farrell", sensor_area=0.1, min_wind_variance=0.05)
    estimator: Ref("estimator") = ComponentRef(type="particle-filter")
    planner: Ref("planner") = ComponentRef(type="entropy")
    zigzag: ZigzagLegParams = ZigzagLegParams()
    step_length: Positive | None = None
    wind_average: int = Field(4, ge=1, le=10_000)
    approach_radius: Positive | None = None
    astar_clearance: NonNegative = 0.0
    entropy_cell: Positive = 0.25


@register("searcher", "pf-entropy", PFEntropyParams, "plume-model PF + expected-entropy moves")
class PFEntropySearcher(Searcher):
    """Zigzag until the estimator has a belief, then expected-entropy moves until its stopping
    rule holds (indoor PF paper). Single agent."""

    params: PFEntropyParams
    max_agents = 1

    def __init__(self, params: PFEntropyParams | None = None) -> None:
        super().__init__(params or PFEntropyParams())
        p = self.params
        self.model: MeasurementModel = p.model.build("model", field="searcher.model")
        self.estimator: Estimator = p.estimator.build("estimator", field="searcher.estimator")
        self.planner: Planner = p.planner.build("planner", field="searcher.planner")

    # ----------------------------------------------------------------- lifecycle
    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """A fresh estimator; start in the zigzag phase."""
        super().reset(ctx, rng)
        p = self.params
        self.step = p.step_length if p.step_length is not None else ctx.max_speed * ctx.dt
        self.estimator.reset(ctx, self.model, rng)
        self.planner.reset(ctx, self.model)
        self.wind = WindAverage(p.wind_average)
        self._zigzag = Zigzag.from_params(p.zigzag)
        self._path: list[np.ndarray] = []
        self._last_entropy = math.nan

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """One control period: update the estimator, declare or move."""
        o = observations[0]
        pos = np.asarray(o.position, float)
        est = self.estimator
        est.use_stream(rng)
        est.update(o)
        self.wind.add(o.wind)
        if est.converged() and self._near(pos):
            return Action([Command.hold()], declaration=Declaration(est.estimate(), agent=o.agent))
        if not o.ready:
            return Action([None])
        return Action([self._next_command(o, pos, rng)])

    def _near(self, pos: np.ndarray) -> bool:
        r = self.params.approach_radius
        return r is None or float(np.linalg.norm(self.estimator.estimate()[0] - pos)) <= r

    # ----------------------------------------------------------------- motion
    def _next_command(self, o: Observation, pos: np.ndarray, rng: np.random.Generator) -> Command:
        arena = self.ctx.arena
        if self._path:
            return Command.waypoint(self._path.pop(0))
        belief = self.estimator.belief()
        if belief is None:
            up = self.wind.upwind(o.heading)
            d = self._zigzag.direction(arena, pos, up, self.step, self.step)
            return Command.move(d * self.step) if d is not None else self._escape(pos, rng)
        goal = self.estimator.estimate()[0]
        if self.estimator.converged() and self.params.approach_radius is not None:
            return self._approach(pos, goal, rng)
        pose = Pose(pos, o.heading, np.asarray(o.wind, float), self.estimator.conditions())
        plan = self.planner.plan(belief, pose, rng)
        finite = plan.scores[np.isfinite(plan.scores)]
        self._last_entropy = float(finite.min()) if finite.size else math.nan
        if plan.target is not None:
            return Command.move(plan.target - pos)
        return self._detour(pos, goal, rng)

    def _approach(self, pos: np.ndarray, goal: np.ndarray, rng: np.random.Generator) -> Command:
        """One step towards ``goal`` (straight if in sight, else along an A* path)."""
        d = goal - pos
        dist = float(np.linalg.norm(d))
        step = min(self.step, dist)
        if dist > 1e-9:
            tgt = pos + d / dist * step
            if self.ctx.arena.segment_free(pos, tgt)[0]:
                return Command.move(tgt - pos)
        return self._detour(pos, goal, rng)

    def _detour(self, pos: np.ndarray, goal: np.ndarray, rng: np.random.Generator) -> Command:
        """The first waypoint of an A* path to ``goal`` (the rest follow), else an escape."""
        path = astar_path(self.ctx.arena, pos, goal, clearance=self.params.astar_clearance)
        if path is not None and len(path) > 1:
            self._path = [q for q in path[2:]]
            return Command.waypoint(path[1])
        return self._escape(pos, rng)

    def _escape(self, pos: np.ndarray, rng: np.random.Generator) -> Command:
        """A free step in a random one of 16 directions (boxed in by obstacles), else hold."""
        d = escape_move(self.ctx.arena, pos, self.step, rng)
        return Command.hold() if d is None else Command.move(d)

    # ----------------------------------------------------------------- reporting
    @property
    def phase(self) -> str:
        """``"zigzag"`` before the estimator has a belief, then ``"tracking"``."""
        return "zigzag" if self.estimator.belief() is None else "tracking"

    def _entropy(self, belief: Belief | None) -> float:
        """Histogram entropy (nats) of a particle belief (NaN for none)."""
        if not isinstance(belief, ParticleBelief):
            return math.nan
        a = self.ctx.arena
        return histogram_entropy(belief, a.lower, a.upper, self.params.entropy_cell)

    def belief(self) -> Belief | None:
        """The estimator's belief, ``None`` during the zigzag phase."""
        return self.estimator.belief()

    def estimation(self) -> tuple[Estimator, MeasurementModel | None]:
        """The estimator and the model."""
        return self.estimator, self.model

    def final_metrics(self) -> dict[str, float]:
        """Row fields: posterior entropy (nats) at initialisation and at the end of the episode,
        so a sweep can check that entropy falls as the robot closes in."""
        return {
            "entropy_init": self._entropy(self.estimator.initial_belief()),
            "entropy_end": self._entropy(self.estimator.belief()),
        }

    def diagnostics(self) -> dict[str, float]:
        """The estimator's, ``phase`` (``"zigzag"`` / ``"tracking"``), ``entropy`` and the last
        plan's ``expected_entropy``."""
        belief = self.estimator.belief()
        out = {**self.estimator.diagnostics(), "entropy": self._entropy(belief)}
        if belief is None:
            return {**out, "phase": "zigzag"}
        return {**out, "phase": "tracking", "expected_entropy": self._last_entropy}
