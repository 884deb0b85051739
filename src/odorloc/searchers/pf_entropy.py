"""Plume-model particle filter + expected-entropy moves (indoor PF paper).

Recipe (indoor PF paper, section 2):

1. **Zigzag** (section 2.1, Fig. 1): until the first detection, straight legs at a fixed angle
   to the measured wind, alternating sides; a leg ends when the next step is blocked
   (``arena.segment_free``) or after ``zigzag_leg`` metres. When both upwind legs are blocked
   (the robot reached the upwind wall) the legs turn to the downwind side, and back again at the
   downwind wall, so the Z pattern sweeps the room.
2. **Initialisation** at the first detection: ``n_particles`` particles by back-tracking the
   recorded wind window (:func:`~odorloc.inference.particles.init.backtrack_initialise`).
3. **Every control period**: Pang & Farrell weight update from the binary reading and the last
   ``window`` wind records (eqs. 4, 10, 11), estimate history, convergence test (eqs. 15-16) ->
   declaration; otherwise resample when ``N_eff < 0.5 N`` (roulette by default, eq. 12).
4. **Motion**: when the previous move is done, one of forward/backward/left/right (robot frame)
   minimising the expected posterior entropy (eqs. 17-18). The hypothetical reading is evaluated
   with the wind window shifted by one record (the current wind appended). Moves blocked by walls
   or obstacles are excluded; when all are blocked the robot follows an A* path towards the
   current estimate.
5. Optional (``approach_radius``, off by default): once converged, drive to the estimate (A*
   around obstacles) and declare only within that distance of it.

``diagnostics()`` reports ``phase`` (``"zigzag"``, ``"tracking"``), ``ess``, ``entropy`` (Shannon
entropy, nats, of the weighted particle histogram on ``entropy_cell`` cells -- unlike the weight
entropy it keeps falling through resampling as the cloud contracts, which is what the paper's
Figs. 5/7 show), ``weight_entropy``, ``spread`` and ``n_particles``.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.behaviours.escape import first_free
from odorloc.behaviours.zigzag import Zigzag
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.geometry.vectors import ring, upwind_unit
from odorloc.inference.belief import ParticleBelief, histogram_entropy
from odorloc.inference.particles import (
    ArenaConstraint,
    ConvergenceParams,
    DualConvergence,
    ParticleFilter,
    Resampler,
    backtrack_initialise,
)
from odorloc.models.pang_farrell import PangFarrellModel, PangFarrellParams, wind_variance
from odorloc.planning.astar import astar_path
from odorloc.planning.entropy import EntropyPlanner, EntropyPlannerParams
from odorloc.searchers.base import Searcher

__all__ = ["PFEntropyParams", "PFEntropySearcher"]


class PFEntropyParams(Params):
    """Parameters of :class:`PFEntropySearcher` (defaults from the indoor PF paper).

    Parameters
    ----------
    n_particles : int
        ``N_s`` (paper: 1000).
    mu : float
        Sensor detection probability of a present patch (paper: 0.9, eq. 10).
    sensor_area : float, m^2
        ``S_p`` of eq. 10 (not given in the paper; 0.1 is chosen for the indoor-ventilated
        scenario).
    time_scale : float, s
        Turns wind variance x elapsed time into m^2 (see :mod:`odorloc.models.pang_farrell`).
    min_wind_variance : float, m^2/s^2
        Floor on the recorded wind variance (not in the paper; 0.05 chosen as ``sensor_area``).
    p_floor : float
        Likelihood floor (false-alarm / miss probability).
    window : int
        Number of wind records in the likelihood window (paper: 20 at 0.5 s = 10 s).
    wind_var_window : float, s
        Time span of readings used for the wind variance (paper: 10 s).
    pad_window : bool
        Pad a window shorter than ``window`` records (start of an episode) with its oldest
        reading, so odor released before recording started is accounted for.
    r_conv, r_err : float, metres
        Convergence thresholds, see :class:`ConvergenceParams`. The paper gives 0.5 m for both.
        Defaults here: ``r_conv = 0.5`` m read as a radius (``variance="radius"``: RMS particle
        distance ``sqrt(trace) <= 0.5`` m) and ``r_err = 0.25`` m, i.e. the 20 estimates must
        fit in a tolerance circle of 0.5 m *diameter*. With the literal reading (trace <= 0.5
        read as a number, all estimates within 0.5 m of their mean) the filter declares while
        its estimate still trails the robot upwind; the reproduction reports both readings
        side by side (``pf-entropy-literal``).
    history : int
        Number of estimates kept and required (paper: 20).
    history_on_detection : bool
        Store an estimate only at steps with a detection (the flattened ``{P_j | z_j = 1}`` of
        the paper read literally) instead of at every step.
    variance : {"trace", "radius", "max_axis"}
        Particle spread measure of the convergence test.
    resampler : dict
        The resampler, ``{type: name, **params}`` from the registry (paper: ``roulette`` with
        survival floor 0.5, 5 children, 0.25 m^2; e.g. ``{type: systematic, jitter_std: 0.1}``).
    resample_threshold : float
        Resample when ``N_eff < resample_threshold * N`` (paper: 0.5).
    step_length : float or None, metres
        Length of one planned move; ``None`` = one control period at the platform's top speed.
    move_frame : {"robot", "wind", "world"}
        Frame of forward/backward/left/right (paper: robot).
    zigzag_angle_deg : float, degrees
        Leg angle to the measured wind in the zigzag phase.
    zigzag_leg : float or None, metres
        Maximum leg length (``None``: turn only at walls/obstacles, as in the paper).
    wind_average : int
        Number of recent wind readings averaged for the zigzag direction.
    init_min_std : float, metres
        Floor on the back-tracking spread.
    init_uniform_fraction : float
        Fraction of initial particles drawn uniformly over free space.
    approach_radius : float or None, metres
        ``None`` (paper): declare as soon as the convergence test holds. Otherwise, once it
        holds, the robot drives to the estimate (still updating the filter) and declares only
        within this distance of it -- the paper's robots end at the source (Table 1
        "Terminal"), and close readings correct estimates made from afar.
    astar_clearance : float, metres
        Obstacle growth for A* detours.
    entropy_cell : float, metres
        Cell size of the particle histogram behind the ``entropy`` diagnostic.
    """

    n_particles: int = Field(1000, ge=2, le=10_000_000)
    mu: float = Field(0.9, gt=0.0, le=1.0)
    sensor_area: Positive = 0.1
    time_scale: Positive = 1.0
    min_wind_variance: NonNegative = 0.05
    p_floor: float = Field(1e-4, ge=0.0, lt=0.5)
    window: int = Field(20, ge=1, le=100_000)
    wind_var_window: Positive = 10.0
    r_conv: Positive = 0.5
    r_err: Positive = 0.25
    history: int = Field(20, ge=1, le=100_000)
    history_on_detection: bool = False
    variance: Literal["trace", "radius", "max_axis"] = "radius"
    resampler: Ref("resampler") = ComponentRef(type="roulette")
    resample_threshold: float = Field(0.5, ge=0.0, le=1.0)
    step_length: Positive | None = None
    move_frame: Literal["robot", "wind", "world"] = "robot"
    zigzag_angle_deg: float = Field(45.0, ge=0.0, le=90.0)
    zigzag_leg: Positive | None = None
    wind_average: int = Field(4, ge=1, le=10_000)
    pad_window: bool = True
    init_min_std: NonNegative = 0.1
    init_uniform_fraction: float = Field(0.0, ge=0.0, le=1.0)
    approach_radius: Positive | None = None
    astar_clearance: NonNegative = 0.0
    entropy_cell: Positive = 0.25

    def likelihood_params(self) -> PangFarrellParams:
        """The measurement-model part of these parameters."""
        return PangFarrellParams(
            mu=self.mu,
            sensor_area=self.sensor_area,
            time_scale=self.time_scale,
            min_wind_variance=self.min_wind_variance,
            p_floor=self.p_floor,
        )

    def convergence_params(self) -> ConvergenceParams:
        """The termination-test part of these parameters."""
        return ConvergenceParams(
            r_conv=self.r_conv, r_err=self.r_err, history=self.history, variance=self.variance
        )

    def make_resampler(self) -> Resampler:
        """The configured resampler (built through the registry)."""
        return self.resampler.build("resampler", field="searcher.resampler")


@register("searcher", "pf-entropy", PFEntropyParams, "plume-model PF + expected-entropy moves")
class PFEntropySearcher(Searcher):
    """Zigzag until the first detection, then a Pang & Farrell particle filter with
    expected-entropy moves and the dual convergence test (indoor PF paper). Single agent."""

    params: PFEntropyParams
    max_agents = 1

    def __init__(self, params: PFEntropyParams | None = None) -> None:
        super().__init__(params or PFEntropyParams())
        self.model = PangFarrellModel(self.params.likelihood_params())
        self.planner = EntropyPlanner(EntropyPlannerParams(frame=self.params.move_frame))
        self.stopping = DualConvergence(self.params.convergence_params())

    # ----------------------------------------------------------------- lifecycle
    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Clear records and the filter; start in the zigzag phase."""
        super().reset(ctx, rng)
        p = self.params
        self.step = p.step_length if p.step_length is not None else ctx.max_speed * ctx.dt
        n_var = max(2, round(p.wind_var_window / ctx.dt))
        self._winds: deque[np.ndarray] = deque(maxlen=max(p.window, n_var, p.wind_average))
        self._zigzag = Zigzag(math.radians(p.zigzag_angle_deg), p.zigzag_leg)
        self.pf: ParticleFilter | None = None
        self._path: list[np.ndarray] = []
        self._n_var = n_var
        self._last_entropy = math.nan
        self._entropy_init = math.nan
        self._converged = False

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """One control period: record, update/initialise the filter, declare or plan."""
        o = observations[0]
        pos = np.asarray(o.position, float)
        wind = np.asarray(o.wind, float)
        window = self._window_before(wind)
        wvar = self._wind_var(wind)

        if self.pf is None and o.detection:
            self._initialise(pos, window, wvar, rng)
        declaration = None
        if self.pf is not None:
            pf = self.pf
            pf.update(
                self.model.log_likelihood(
                    bool(o.detection),
                    pos,
                    pf.positions,
                    wind_window=window,
                    dt=self.ctx.dt,
                    wind_var=wvar,
                ),
                record=bool(o.detection) or not self.params.history_on_detection,
            )
            status = self.stopping.status(pf)
            self._converged = status.converged
            near = (
                self.params.approach_radius is None
                or np.linalg.norm(pf.estimate() - pos) <= self.params.approach_radius
            )
            if status.converged and near:
                declaration = Declaration(pf.estimate()[None, :], agent=o.agent)
            elif not status.converged:
                pf.resample_if_needed(rng)
        self._winds.append(wind)
        if declaration is not None:
            return Action([Command.hold()], declaration=declaration)
        if not o.ready:
            return Action([None])
        return Action([self._next_command(o, pos, wind, wvar, rng)])

    # ----------------------------------------------------------------- helpers
    def _window_before(self, wind: np.ndarray) -> np.ndarray:
        """Wind records before the current step (oldest first), ``(window, d)`` m/s.

        Early in an episode fewer than ``window`` records exist although odor released before
        the robot started recording can already arrive; the window is then padded at its old
        end with the oldest available reading (the current one if none), i.e. the wind before
        the first record is assumed equal to it (``pad_window=True``).
        """
        w = list(self._winds)[-self.params.window :]
        if not w:
            w = [wind]
        if self.params.pad_window and len(w) < self.params.window:
            w = [w[0]] * (self.params.window - len(w)) + w
        return np.array(w)

    def _wind_var(self, wind: np.ndarray) -> np.ndarray:
        recent = [*list(self._winds)[-(self._n_var - 1) :], wind]
        return wind_variance(np.array(recent), self.params.min_wind_variance)

    def _initialise(
        self, pos: np.ndarray, window: np.ndarray, wvar: np.ndarray, rng: np.random.Generator
    ) -> None:
        p = self.params
        particles = backtrack_initialise(
            pos,
            window,
            self.ctx.dt,
            p.n_particles,
            rng,
            arena=self.ctx.arena,
            model=self.model,
            wind_var=wvar,
            min_std=p.init_min_std,
            uniform_fraction=p.init_uniform_fraction,
        )
        self.pf = ParticleFilter(
            particles,
            resampler=p.make_resampler(),
            resample_threshold=p.resample_threshold,
            history=p.history,
            constraint=ArenaConstraint(self.ctx.arena),
        )
        self._entropy_init = histogram_entropy(
            self.pf.belief(), self.ctx.arena.lower, self.ctx.arena.upper, p.entropy_cell
        )

    def _next_command(
        self,
        o: Observation,
        pos: np.ndarray,
        wind: np.ndarray,
        wvar: np.ndarray,
        rng: np.random.Generator,
    ) -> Command:
        arena = self.ctx.arena
        if self._path:
            return Command.waypoint(self._path.pop(0))
        if self.pf is None:
            recent = np.mean(list(self._winds)[-self.params.wind_average :], axis=0)
            up = upwind_unit(recent, o.heading)
            d = self._zigzag.direction(arena, pos, up, self.step, self.step)
            return Command.move(d * self.step) if d is not None else self._escape(pos, rng)

        if self._converged and self.params.approach_radius is not None:
            return self._approach(pos, self.pf.estimate(), rng)

        # Hypothetical reading one record later: the window (already holding the current wind,
        # appended in act) is the one the next update will use (eq. 10).
        nxt = self._window_before(wind)
        model = self.model.bind(wind_window=nxt, dt=self.ctx.dt, wind_var=wvar)
        plan = self.planner.plan(
            self.pf.belief(),
            pos,
            model,
            heading=o.heading,
            wind=wind,
            arena=arena,
            step_length=self.step,
        )
        finite = plan.expected_entropy[np.isfinite(plan.expected_entropy)]
        self._last_entropy = float(finite.min()) if finite.size else math.nan
        if plan.target is not None:
            return Command.move(plan.target - pos)
        goal = self.pf.estimate()
        path = astar_path(arena, pos, goal, clearance=self.params.astar_clearance)
        if path is not None and len(path) > 1:
            self._path = [q for q in path[2:]]
            return Command.waypoint(path[1])
        return self._escape(pos, rng)

    def _approach(self, pos: np.ndarray, goal: np.ndarray, rng: np.random.Generator) -> Command:
        """One step towards ``goal`` (straight if in sight, else along an A* path)."""
        arena = self.ctx.arena
        d = goal - pos
        dist = float(np.linalg.norm(d))
        step = min(self.step, dist)
        if dist > 1e-9:
            tgt = pos + d / dist * step
            if arena.segment_free(pos, tgt)[0]:
                return Command.move(tgt - pos)
        path = astar_path(arena, pos, goal, clearance=self.params.astar_clearance)
        if path is not None and len(path) > 1:
            self._path = [q for q in path[2:]]
            return Command.waypoint(path[1])
        return self._escape(pos, rng)

    def _escape(self, pos: np.ndarray, rng: np.random.Generator) -> Command:
        """A free step in a random one of 16 directions (boxed in by obstacles), else hold."""
        moves = ring(16, self.ctx.arena.dim)[rng.permutation(16)] * self.step
        k = first_free(self.ctx.arena, pos, moves)
        return Command.hold() if k is None else Command.move(moves[k])

    # ----------------------------------------------------------------- reporting
    @property
    def phase(self) -> str:
        """``"zigzag"`` before the first detection, then ``"tracking"``."""
        return "zigzag" if self.pf is None else "tracking"

    def belief(self) -> ParticleBelief | None:
        """The particle set, ``None`` during the zigzag phase."""
        return None if self.pf is None else self.pf.belief()

    def final_metrics(self) -> dict[str, float]:
        """Row fields: posterior entropy (nats) at initialisation and at the end of the episode,
        so a sweep can check that entropy falls as the robot closes in."""
        end = (
            histogram_entropy(
                self.pf.belief(),
                self.ctx.arena.lower,
                self.ctx.arena.upper,
                self.params.entropy_cell,
            )
            if self.pf is not None
            else math.nan
        )
        return {"entropy_init": self._entropy_init, "entropy_end": end}

    def diagnostics(self) -> dict[str, float]:
        """``phase`` (``"zigzag"`` / ``"tracking"``), ``ess``, ``entropy``, ``weight_entropy``,
        ``spread`` (m^2 or m), ``n_particles``, ``expected_entropy`` of the last plan."""
        if self.pf is None:
            return {"phase": self.phase, "ess": math.nan, "entropy": math.nan, "n_particles": 0.0}
        b = self.pf.belief()
        return {
            "phase": self.phase,
            "ess": b.ess,
            "entropy": histogram_entropy(
                b, self.ctx.arena.lower, self.ctx.arena.upper, self.params.entropy_cell
            ),
            "weight_entropy": b.entropy,
            "spread": self.pf.spread(self.params.variance),
            "n_particles": float(self.pf.n),
            "expected_entropy": self._last_entropy,
        }
