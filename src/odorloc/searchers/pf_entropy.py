"""Plume-model particle filter + expected-entropy moves (indoor PF paper).

Recipe (indoor PF paper, section 2):

1. **Zigzag** (section 2.1, Fig. 1): until the first detection, straight legs at a fixed angle
   to the measured wind, alternating sides; a leg ends when the next step is blocked
   (``arena.segment_free``) or after ``zigzag_leg`` metres. When both upwind legs are blocked
   (the robot reached the upwind wall) the legs turn to the downwind side, and back again at the
   downwind wall, so the Z pattern sweeps the room.
2. **Initialisation** at the first detection: ``n_particles`` particles by back-tracking the
   recorded wind window (:func:`~odorloc.inference.particle_filter.backtrack_initialise`).
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

``diagnostics()`` reports ``phase`` (0 zigzag, 1 tracking), ``ess``, ``entropy`` (Shannon
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

from odorloc.inference.belief import ParticleBelief
from odorloc.inference.likelihoods import PangFarrellLikelihood, PangFarrellParams, wind_variance
from odorloc.inference.particle_filter import (
    ConvergenceParams,
    ParticleFilter,
    backtrack_initialise,
)
from odorloc.inference.resampling import (
    Resampler,
    RouletteParams,
    RouletteResampler,
    SystematicParams,
    SystematicResampler,
)
from odorloc.params import NonNegative, Params, Positive
from odorloc.planning.astar import astar_path
from odorloc.planning.entropy import EntropyPlanner, EntropyPlannerParams
from odorloc.registry import register
from odorloc.searchers.base import (
    Action,
    Command,
    Declaration,
    Observation,
    SearchContext,
    Searcher,
)
from odorloc.searchers.simple import zigzag_leg
from odorloc.world.arena import Arena

__all__ = ["PFEntropyParams", "PFEntropySearcher", "ZigzagLegs"]


def _upwind_unit(wind: np.ndarray, fallback_heading: float) -> np.ndarray:
    u = np.zeros(len(wind))
    if math.hypot(wind[0], wind[1]) > 1e-9:
        u[:2] = -np.asarray(wind[:2]) / math.hypot(wind[0], wind[1])
    else:
        u[:2] = [math.cos(fallback_heading), math.sin(fallback_heading)]
    return u


class ZigzagLegs:
    """State of the Z-shaped search (indoor PF paper, section 2.1).

    Parameters
    ----------
    angle : float, rad
        Angle between a leg and the upwind (or downwind) direction.
    max_leg : float or None, metres
        Leg length after which the robot turns even without an obstacle.
    """

    def __init__(self, angle: float, max_leg: float | None) -> None:
        self.angle = angle
        self.max_leg = max_leg
        self.side = 1.0
        self.along = 1.0  # +1: legs angled upwind, -1: downwind
        self.travelled = 0.0

    def next_move(
        self, arena: Arena, pos: np.ndarray, wind: np.ndarray, heading: float, step: float
    ) -> np.ndarray | None:
        """Displacement ``(d,)`` of the next zigzag step (metres), ``None`` if boxed in."""
        up = _upwind_unit(wind, heading)
        if self.max_leg is not None and self.travelled >= self.max_leg:
            self.side, self.travelled = -self.side, 0.0
        leg = zigzag_leg(arena, pos, up, self.angle, self.side, self.along, step)
        if leg is None:
            return None
        d, side, along = leg
        if (side, along) != (self.side, self.along):
            self.travelled = 0.0
        self.side, self.along = side, along
        self.travelled += step
        return d * step


class PFEntropyParams(Params):
    """Parameters of :class:`PFEntropySearcher` (defaults from the indoor PF paper).

    Parameters
    ----------
    n_particles : int
        ``N_s`` (paper: 1000).
    mu : float
        Sensor detection probability of a present patch (paper: 0.9, eq. 10).
    sensor_area : float, m^2
        ``S_p`` of eq. 10 (not given in the paper; 0.1 was tuned on the indoor-ventilated
        scenario).
    time_scale : float, s
        Turns wind variance x elapsed time into m^2 (see :mod:`odorloc.inference.likelihoods`).
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
        read as a number, all estimates within 0.5 m of their mean) the filter declared while
        its estimate was still trailing the robot upwind: 25 % success from (2.40, 4.55) in the
        indoor-ventilated scenario versus 94 % with these defaults (16 episodes each).
    history : int
        Number of estimates kept and required (paper: 20).
    history_on_detection : bool
        Store an estimate only at steps with a detection (the flattened ``{P_j | z_j = 1}`` of
        the paper read literally) instead of at every step.
    variance : {"trace", "radius", "max_axis"}
        Particle spread measure of the convergence test.
    resampler : {"roulette", "systematic"}
    resample_threshold : float
        Resample when ``N_eff < resample_threshold * N`` (paper: 0.5).
    roulette : RouletteParams
        Roulette settings (paper: survival floor 0.5, 5 children, 0.25 m^2).
    systematic_jitter : float, metres
        Roughening std of the systematic resampler.
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

    n_particles: int = Field(1000, ge=2)
    mu: float = Field(0.9, gt=0.0, le=1.0)
    sensor_area: Positive = 0.1
    time_scale: Positive = 1.0
    min_wind_variance: NonNegative = 0.05
    p_floor: float = Field(1e-4, ge=0.0, lt=0.5)
    window: int = Field(20, ge=1)
    wind_var_window: Positive = 10.0
    r_conv: Positive = 0.5
    r_err: Positive = 0.25
    history: int = Field(20, ge=1)
    history_on_detection: bool = False
    variance: Literal["trace", "radius", "max_axis"] = "radius"
    resampler: Literal["roulette", "systematic"] = "roulette"
    resample_threshold: float = Field(0.5, ge=0.0, le=1.0)
    roulette: RouletteParams = RouletteParams()
    systematic_jitter: NonNegative = 0.1
    step_length: Positive | None = None
    move_frame: Literal["robot", "wind", "world"] = "robot"
    zigzag_angle_deg: float = Field(45.0, ge=0.0, le=90.0)
    zigzag_leg: Positive | None = None
    wind_average: int = Field(4, ge=1)
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
        """The configured resampler."""
        if self.resampler == "roulette":
            return RouletteResampler(self.roulette)
        return SystematicResampler(SystematicParams(jitter_std=self.systematic_jitter))


@register("searcher", "pf-entropy", PFEntropyParams, "plume-model PF + expected-entropy moves")
class PFEntropySearcher(Searcher):
    """Zigzag until the first detection, then a Pang & Farrell particle filter with
    expected-entropy moves and the dual convergence test (indoor PF paper). Single agent."""

    def __init__(self, params: PFEntropyParams | None = None) -> None:
        self.params = params or PFEntropyParams()
        self.model = PangFarrellLikelihood(self.params.likelihood_params())
        self.planner = EntropyPlanner(EntropyPlannerParams(frame=self.params.move_frame))
        self.convergence_params = self.params.convergence_params()

    # ----------------------------------------------------------------- lifecycle
    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Clear records and the filter; start in the zigzag phase."""
        super().reset(ctx, rng)
        p = self.params
        self.step = p.step_length if p.step_length is not None else ctx.max_speed * ctx.dt
        n_var = max(2, round(p.wind_var_window / ctx.dt))
        self._winds: deque[np.ndarray] = deque(maxlen=max(p.window, n_var, p.wind_average))
        self._zigzag = ZigzagLegs(math.radians(p.zigzag_angle_deg), p.zigzag_leg)
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
                    bool(o.detection), pos, window, self.ctx.dt, pf.positions, wvar
                ),
                record=bool(o.detection) or not self.params.history_on_detection,
            )
            status = pf.convergence(self.convergence_params)
            self._converged = status.converged
            near = (
                self.params.approach_radius is None
                or np.linalg.norm(pf.estimate() - pos) <= self.params.approach_radius
            )
            if status.converged and near:
                declaration = Declaration(pf.estimate()[None, :])
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
            arena=self.ctx.arena,
        )
        self._entropy_init = histogram_entropy(self.pf.belief(), self.ctx.arena, p.entropy_cell)

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
            d = self._zigzag.next_move(arena, pos, recent, o.heading, self.step)
            return Command.move(d) if d is not None else self._escape(pos, rng)

        if self._converged and self.params.approach_radius is not None:
            return self._approach(pos, self.pf.estimate(), rng)

        # Hypothetical reading one record later: the window (already holding the current wind,
        # appended in act) is the one the next update will use (eq. 10).
        nxt = self._window_before(wind)
        dt = self.ctx.dt

        def likelihood_fn(z: int, sensor_positions: np.ndarray, hyp: np.ndarray) -> np.ndarray:
            p1 = self.model.detection_probability(sensor_positions, nxt, dt, hyp, wvar)
            return p1 if z == 1 else 1.0 - p1

        plan = self.planner.plan(
            self.pf.belief(),
            pos,
            likelihood_fn,
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
        """A free step in a random direction (boxed in by obstacles), else hold."""
        arena = self.ctx.arena
        angles = rng.permutation(16) * (2.0 * math.pi / 16)
        for a in angles:
            d = np.zeros(arena.dim)
            d[:2] = [math.cos(a), math.sin(a)]
            d *= self.step
            if arena.segment_free(pos, pos + d)[0]:
                return Command.move(d)
        return Command.hold()

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
            histogram_entropy(self.pf.belief(), self.ctx.arena, self.params.entropy_cell)
            if self.pf is not None
            else math.nan
        )
        return {"entropy_init": self._entropy_init, "entropy_end": end}

    def diagnostics(self) -> dict[str, float]:
        """``phase`` (0 zigzag / 1 tracking), ``ess``, ``entropy``, ``weight_entropy``,
        ``spread`` (m^2 or m), ``n_particles``, ``expected_entropy`` of the last plan."""
        if self.pf is None:
            return {"phase": 0.0, "ess": math.nan, "entropy": math.nan, "n_particles": 0.0}
        b = self.pf.belief()
        return {
            "phase": 1.0,
            "ess": b.ess,
            "entropy": histogram_entropy(b, self.ctx.arena, self.params.entropy_cell),
            "weight_entropy": b.entropy,
            "spread": self.pf.spread(self.params.variance),
            "n_particles": float(self.pf.n),
            "expected_entropy": self._last_entropy,
        }


def histogram_entropy(belief: ParticleBelief, arena: Arena, cell: float) -> float:
    """Shannon entropy (nats) of the weighted particle histogram on ``cell``-sized bins."""
    bins = [max(1, math.ceil(s / cell)) for s in arena.size]
    rng_ = list(zip(arena.lower, arena.upper, strict=True))
    h, _ = np.histogramdd(belief.positions, bins=bins, range=rng_, weights=belief.weights)
    q = h.ravel()
    q = q[q > 0] / q.sum()
    return float(-np.sum(q * np.log(q)))
