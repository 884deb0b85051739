"""Adap-PP: adaptive POMDP path planning of the multi-UAV paper (MUC-OSL, Sect. V).

Each UAV plans alone, in two decisions.

**Direction** (V.1). Among the lattice directions (26 in 3-D,
:class:`~odorloc.planning.steps.StepPlanner`), take the one maximising ``W_k - E[W_{k+1}]``
(eq. 25) with the value

    W = D + h1 H                                                     (eq. 23)

``D = ||u - sum_n w_n o_n||`` the distance from the UAV to the weighted-mean estimate (eq. 22)
and ``H = -sum_n w_n log w_n`` the weight entropy (eq. 21). ``E[W_{k+1}] = sum_{d=0}^{d_max}
p(d) W_{k+1}(d)`` (eq. 24) runs over the count outcomes of a measurement taken one cell along
the direction: ``p(d) = sum_n w_n p(d | o_n)`` and ``W_{k+1}(d)`` is the value of the posterior
``w_n p(d | o_n) / p(d)`` seen from that point. ``d_max`` is where the cumulative probability is
one to the model's tail mass: the model's outcome classes, the last one holding the tail
(:meth:`~odorloc.models.vergassola.VergassolaModel.outcome_probabilities`).

``h1`` "is positively correlated with the variance of the particle distribution" and falls as the
particles converge (V.1): ``h1 = h1_scale * tr(Sigma)`` (``h1: variance``, the default; ``Sigma``
the particles' covariance, m^2, ``h1_scale`` per metre, so that ``h1 H`` is a length like
``D``), or ``h1 = h1_scale * sqrt(tr Sigma)`` (``h1: spread``). With the variance the entropy
term dominates while the belief spans tens of metres (exploration: a direction's expected
information differs from another's by hundredths of a nat) and the distance takes over as the
particles converge to within a few metres, which is the behaviour the paper describes.

**Step length** (V.2). Along the chosen direction, ``l`` in ``1..l_max`` cells minimising

    R(l) = D(l) + h2 Z(l)                                            (eqs. 27-28)

``D(l)`` the distance from the point ``l`` cells on to the estimate, ``Z(l) = z(l) - z(l-1)`` the
past measurement points inside the sphere whose diameter joins the UAV and that point (``z(0) =
0``; the current point, on every sphere, is not counted; points on the surface are). ``h2``
shrinks as the UAV closes in on the estimate: ``h2 = h2_scale * D_k`` (metres per point).

``l_max`` (eq. 26): with ``zeta`` the fraction of the arena's lattice cells where the model
predicts a cue with probability at least ``zeta_threshold`` for a source at the arena's centre
(the paper's ``G_c>th / (L_x L_y L_z)``; the true source is unknown to the UAV, and the predicted
plume's size barely depends on where the source is), ``l_max = floor(0.1 / zeta)`` when
``zeta < 0.1`` (``zeta * l_max = 0.1``), else 1 (a fixed step).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field
from scipy.special import xlogy

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative
from odorloc.core.registry import register
from odorloc.inference.belief import ParticleBelief
from odorloc.models.base import BoundModel
from odorloc.models.vergassola import unit_direction
from odorloc.planning import kernels
from odorloc.planning.base import Plan, Pose
from odorloc.planning.selection import select
from odorloc.planning.steps import LatticeParams, StepPlanner

__all__ = [
    "AdaptivePathPlanner",
    "AdaptivePlannerParams",
    "direction_rewards",
    "max_step",
    "merge_tail_classes",
    "source_area_ratio",
    "step_rewards",
]


def direction_rewards(
    weights: np.ndarray,
    hypotheses: np.ndarray,
    outcome_probs: np.ndarray,
    targets: np.ndarray,
    position: np.ndarray,
    h1: float,
) -> np.ndarray:
    """``W_k - E[W_{k+1}]`` of each candidate (eqs. 21-25), ``(M,)`` metres.

    Parameters
    ----------
    weights : (N,) ndarray
        Normalised particle weights ``w_n``.
    hypotheses : (N, d) ndarray, metres
        Particle positions ``o_n``.
    outcome_probs : (M, Z, N) ndarray
        ``p(d | o_n)`` of each count class at each candidate.
    targets : (M, d) ndarray, metres
        Where each candidate's measurement would be taken.
    position : (d,) ndarray, metres
        The UAV now (for ``W_k``).
    h1 : float, metres per nat
        Weight of the entropy.
    """
    w = np.asarray(weights, float)
    x = np.asarray(hypotheses, float)
    q = np.asarray(outcome_probs, float)
    est = w @ x
    h_now = -float(xlogy(w, w).sum())
    w_now = float(np.linalg.norm(np.asarray(position, float) - est)) + h1 * h_now
    joint = q * w  # (M, Z, N): p(d, o_n)
    m, z, n = joint.shape
    pz = joint.sum(axis=2)  # (M, Z)
    live = pz > 1e-300
    safe = np.where(live, pz, 1.0)
    mean = (joint.reshape(m * z, n) @ x).reshape(m, z, -1) / safe[..., None]  # (M, Z, d)
    dist = np.linalg.norm(targets[:, None, :] - mean, axis=2)
    # H(w | d) = log p(d) - sum_n p(d, o_n) log p(d, o_n) / p(d)
    ent = np.log(safe) - xlogy(joint, joint).sum(axis=2) / safe
    expected = np.where(live, pz * (dist + h1 * ent), 0.0).sum(axis=1)
    return w_now - expected


def _direction_rewards_compiled(
    weights: np.ndarray,
    hypotheses: np.ndarray,
    outcome_probs: np.ndarray,
    targets: np.ndarray,
    position: np.ndarray,
    h1: float,
    tail_mass: float,
    estimate: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """:func:`merge_tail_classes` then :func:`direction_rewards` with the compiled kernels:
    the same rewards to the bit, and the number of classes kept (``estimate``: ``w @ x`` if
    the caller has it)."""
    w = np.asarray(weights, float)
    x = np.asarray(hypotheses, float)
    q = np.ascontiguousarray(outcome_probs, dtype=float)
    keep = kernels.tail_cut(q @ w, tail_mass)
    joint, pz, xl, safe = kernels.direction_terms(q, w, keep)
    m, z, n = joint.shape
    est = w @ x if estimate is None else estimate
    h_now = -float(xlogy(w, w).sum())
    # numpy.linalg.norm of a vector is sqrt(v . v)
    gap = np.asarray(position, float) - est
    w_now = math.sqrt(float(gap.dot(gap))) + h1 * h_now
    t = np.ascontiguousarray(targets, dtype=float)
    rewards = kernels.direction_finish(
        joint.reshape(m * z, n) @ x, pz, xl, safe, np.log(safe), t, h1, w_now
    )
    return rewards, z


def merge_tail_classes(
    weights: np.ndarray, outcome_probs: np.ndarray, tail_mass: float = 1e-6
) -> np.ndarray:
    """The outcome classes cut where the *predicted* count distribution has ended.

    ``d_max`` of eq. 24 is where the cumulative probability of the predicted measurement
    ``p(d) = sum_n w_n p(d | o_n)`` reaches one: the classes from the first one whose
    predicted tail ``P(d >= c)`` is below ``tail_mass`` at every candidate on are merged into a
    last class, ``(M, Z', N)`` with ``Z' <= Z`` (every ``(m, n)`` still sums to one). A model
    sizes its classes for the largest mean over all hypotheses; the weighted prediction usually
    ends much earlier, and the planner's cost is proportional to the number of classes.
    """
    q = np.asarray(outcome_probs, float)
    z = q.shape[1]
    if z <= 2:
        return q
    pz = q @ np.asarray(weights, float)  # (M, Z)
    # tail[c] = P(d >= c) for c = 1 .. Z-1, worst candidate
    tail = np.cumsum(pz[:, ::-1], axis=1)[:, ::-1][:, 1:].max(axis=0)
    small = np.flatnonzero(tail < tail_mass)
    if not small.size:
        return q
    keep = max(int(small[0]) + 1, 1)  # classes 0 .. keep - 1, then the merged tail
    if keep + 1 >= z:
        return q
    return np.concatenate([q[:, :keep], q[:, keep:].sum(axis=1, keepdims=True)], axis=1)


def step_rewards(
    position: np.ndarray,
    step: np.ndarray,
    l_max: int,
    estimate: np.ndarray,
    history: np.ndarray,
    h2: float,
) -> np.ndarray:
    """``R(l) = D(l) + h2 Z(l)`` for ``l = 1..l_max`` (eq. 27), ``(l_max,)``.

    Parameters
    ----------
    position : (d,) ndarray, metres
    step : (d,) ndarray, metres
        One-cell displacement along the chosen direction.
    l_max : int
    estimate : (d,) ndarray, metres
    history : (K, d) ndarray, metres
        Past measurement points (points at the current position are left out).
    h2 : float, metres per point
    """
    if l_max < 1:
        raise ConfigError("l_max", f"must be >= 1, got {l_max}")
    u = np.asarray(position, float)
    s = np.asarray(step, float)
    ls = np.arange(1, l_max + 1, dtype=float)
    targets = u + ls[:, None] * s
    dist = np.linalg.norm(targets - np.asarray(estimate, float), axis=1)
    pts = np.asarray(history, float).reshape(-1, u.size)
    if len(pts):
        pts = pts[np.linalg.norm(pts - u, axis=1) > 1e-9]
    if not len(pts):
        return dist
    centres = u + 0.5 * ls[:, None] * s
    radii = 0.5 * ls * float(np.linalg.norm(s))
    d = np.linalg.norm(pts[None, :, :] - centres[:, None, :], axis=2)  # (L, K)
    z = (d <= radii[:, None] + 1e-9).sum(axis=1)
    newly = np.diff(np.concatenate([[0], z]))
    return dist + h2 * newly


def max_step(zeta: float, product: float = 0.1) -> int:
    """``l_max`` from the source-area ratio (eq. 26): ``floor(product / zeta)`` when
    ``zeta < product`` (at least 1), else 1."""
    if not zeta >= 0:
        raise ConfigError("zeta", f"must be >= 0, got {zeta}")
    if zeta >= product:
        return 1
    if zeta == 0:
        raise ConfigError("zeta", "no cell of the arena reaches the threshold")
    return max(1, math.floor(product / zeta + 1e-9))


_ZETA_CACHE: dict[Any, float] = {}


def source_area_ratio(
    model: BoundModel, lower: np.ndarray, upper: np.ndarray, cell: float, threshold: float
) -> float:
    """``zeta``: fraction of the lattice cells of the box with a cue probability ``>=
    threshold`` for a source at its centre (eq. 26). Cached per model and box."""
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    cond = tuple(
        (k, tuple(np.round(np.asarray(v, float).ravel(), 9))) for k, v in model.conditions.items()
    )
    mp = getattr(model.model, "params", None)
    key = (type(model.model).__name__, mp, cond, tuple(lo), tuple(hi), cell, threshold)
    try:
        if key in _ZETA_CACHE:
            return _ZETA_CACHE[key]
    except TypeError:  # unhashable model parameters: no caching
        key = None
    axes = [np.arange(a + 0.5 * cell, b, cell) for a, b in zip(lo, hi, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, lo.size)
    centre = 0.5 * (lo + hi)
    q = model.outcome_probabilities(grid, centre[None, :])  # (G, Z, 1)
    cue = 1.0 - q[:, 0, 0]
    zeta = float(np.mean(cue >= threshold))
    if key is not None:
        _ZETA_CACHE[key] = zeta
    return zeta


class AdaptivePlannerParams(LatticeParams):
    """Parameters of :class:`AdaptivePathPlanner` (see the module docstring for the forms).

    Parameters
    ----------
    h1 : {"variance", "spread"}
        Form of ``h1``: ``h1_scale * tr(Sigma)`` or ``h1_scale * sqrt(tr Sigma)`` (the paper
        gives no form or value).
    h1_scale : float
        Per metre (``variance``) or metres per nat per metre (``spread``).
    h2_scale : float, per point
        ``h2 = h2_scale * D_k`` (the paper gives no form or value).
    zeta_threshold : float
        Cue probability per measurement above which a cell counts as source area (eq. 26's
        ``G_c > th``); 0.1 is about 0.1 expected encounters per measurement.
    zeta_product : float
        ``zeta * l_max`` (paper: 0.1).
    l_max : int or None
        Fix ``l_max`` instead of deriving it from ``zeta``.
    tail_mass : float
        ``d_max`` of eq. 24: the predicted count distribution is cut where its tail falls below
        this (:func:`merge_tail_classes`).
    """

    h1: Literal["variance", "spread"] = "variance"
    h1_scale: NonNegative = 1.0
    h2_scale: NonNegative = 0.1
    zeta_threshold: float = Field(0.1, gt=0.0, lt=1.0)
    zeta_product: float = Field(0.1, gt=0.0, le=1.0)
    l_max: int | None = Field(None, ge=1, le=1_000_000)
    tail_mass: float = Field(1e-6, gt=0.0, lt=0.1)


@register("step_planner", "adap-pp", AdaptivePlannerParams, "adaptive direction x step (MUC-OSL)")
class AdaptivePathPlanner(StepPlanner):
    """Algorithm 2 of the multi-UAV paper: direction by ``W - E[W']``, then the step length."""

    params: AdaptivePlannerParams
    Params = AdaptivePlannerParams

    def reset(self, ctx: Any, model: Any = None) -> None:
        super().reset(ctx, model)
        self.l_max: int | None = self.params.l_max
        self.zeta = math.nan
        # the model's constants for the compiled decision (fixed for the episode), once
        self._consts: tuple | None = None

    def _l_max(self, model: BoundModel) -> int:
        if self.l_max is None:
            p = self.params
            arena = self.ctx.arena
            self.zeta = source_area_ratio(model, arena.lo, arena.hi, p.cell, p.zeta_threshold)
            self.l_max = max_step(self.zeta, p.zeta_product)
        return self.l_max

    def plan(self, belief: ParticleBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        fused = self._fused_inputs(belief, pose)
        if fused is not None:
            return self._plan_fused(belief, *fused)
        p = self.params
        pos = np.asarray(pose.position, float)
        model = self.bound_model(pose)
        targets = pos + self.steps
        ok = self.feasible(pos, targets)
        # minimised: the negated reward W - E[W'] (eq. 25 maximises it)
        scores = np.full(len(targets), np.inf)
        l_max = self._l_max(model)
        if not ok.any():
            return Plan(None, targets, scores, ok, 0, {"length": 0, "l_max": l_max})
        x = belief.positions
        lw = belief.log_weights
        w = np.exp(lw)
        est = w @ x
        dx = x - est
        # tr(Sigma) of the weighted particles
        var = max(float(np.einsum("n,nd,nd->", w, dx, dx)), 0.0)
        h1 = p.h1_scale * (var if p.h1 == "variance" else math.sqrt(var))
        rewards, size = self._direction_rewards(model, w, lw, x, est, targets[ok], pos, h1)
        scores[ok] = -rewards
        k = select(scores, mode="min", feasible=ok, ties="first")
        assert k is not None
        step = self.steps[k]
        lengths = np.arange(1, l_max + 1)
        cand = pos + lengths[:, None] * step
        fine = self.feasible(pos, cand)
        # a move is feasible only up to its first blocked length
        fine = np.cumprod(fine).astype(bool)
        gap = pos - est
        h2 = p.h2_scale * math.sqrt(float(gap.dot(gap)))
        history = self.history
        if self.compiled:
            step_norm = math.sqrt(float(step.dot(step)))
            r = kernels.step_rewards(pos, step, step_norm, l_max, est, history, h2)
        else:
            r = step_rewards(pos, step, l_max, est, history, h2)
        j = select(r, mode="min", feasible=fine, ties="first")
        length = 1 if j is None else int(lengths[j])
        work = size * (x.shape[1] + 1) + l_max * (len(history) + 1)
        extra = {"length": length, "l_max": l_max, "step_scores": r}
        return Plan(k, pos + length * self.steps, scores, ok, int(work), extra)

    def _fused_inputs(
        self, belief: ParticleBelief, pose: Pose
    ) -> tuple[np.ndarray, float, np.ndarray, tuple] | None:
        """What the two compiled halves of a decision need (:func:`~odorloc.planning.kernels.
        adap_pp_means`, :func:`~odorloc.planning.kernels.adap_pp_choose`): the UAV's position,
        the exposure, the unit wind direction and the model's constants; ``None`` where the
        step-by-step path runs (NumPy backend, a model without compiled 3-D kernels, an arena
        with obstacles, conditions other than the exposure and the wind direction)."""
        if not self.compiled or self.ctx.arena.occ is not None or self.ctx.dim != 3:
            return None
        consts = self._consts
        if consts is None:
            get = getattr(self.model, "kernel_constants", None)
            consts = self._consts = get() if callable(get) else None
        cond = pose.conditions
        if consts is None or set(cond) - {"dt", "direction"}:
            return None
        dt = cond.get("dt")
        if dt is None or not (math.isfinite(dt) and dt > 0):
            return None  # the step-by-step path says what is wrong with it
        direction = cond.get("direction")
        e = consts[4] if direction is None else unit_direction(direction, 3)
        pos = np.asarray(pose.position, float)
        if pos.shape != (3,):
            return None
        return pos, float(dt), e, consts

    def _plan_fused(
        self, belief: ParticleBelief, pos: np.ndarray, dt: float, e: np.ndarray, consts: tuple
    ) -> Plan:
        """:meth:`plan` in two compiled passes (the same choice within round-off)."""
        p = self.params
        if self.l_max is None:
            self._l_max(self.model.bind(dt=dt, direction=e))
        l_max = int(self.l_max)  # type: ignore[arg-type]
        aq, adv, inv_lam, a2, _ = consts
        lo, hi = self.ctx.arena.lo, self.ctx.arena.hi
        x = np.ascontiguousarray(belief.positions, dtype=float)
        lw = np.ascontiguousarray(belief.log_weights, dtype=float)
        ok, targets, mu, top = kernels.adap_pp_means(
            x, pos, self.steps, lo, hi, e, aq, dt, adv, inv_lam, a2
        )
        scores = np.full(len(ok), np.inf)
        if not len(targets):
            # no feasible candidate (the targets are the feasible ones)
            return Plan(None, pos + self.steps, scores, ok, 0, {"length": 0, "l_max": l_max})
        if not (top < math.inf and mu.min() >= 0.0):
            raise ConfigError("expected_counts", "must be finite and >= 0")
        z = self.model.n_classes(float(top))
        rewards, kept, k, r, length = kernels.adap_pp_choose(
            mu,
            int(z),
            x,
            lw,
            pos,
            self.steps,
            ok,
            targets,
            p.tail_mass,
            p.h1_scale,
            p.h1 == "variance",
            l_max,
            lo,
            hi,
            self.history,
            p.h2_scale,
        )
        scores[ok] = -rewards
        assert k >= 0
        work = mu.shape[0] * kept * mu.shape[1] * (x.shape[1] + 1) + l_max * (len(self.history) + 1)
        extra = {"length": int(length), "l_max": l_max, "step_scores": r}
        return Plan(int(k), pos + length * self.steps, scores, ok, int(work), extra)

    def _direction_rewards(
        self,
        model: BoundModel,
        w: np.ndarray,
        lw: np.ndarray,
        x: np.ndarray,
        est: np.ndarray,
        targets: np.ndarray,
        pos: np.ndarray,
        h1: float,
    ) -> tuple[np.ndarray, int]:
        """``W_k - E[W_{k+1}]`` of the feasible candidates and the size of the outcome array
        (candidates x classes kept x particles)."""
        p = self.params
        if self.compiled:
            poisson = model.poisson_outcomes(targets, x)
            if poisson is not None:
                mu, z = poisson
                gap = pos - est
                w_now = math.sqrt(float(gap.dot(gap))) - h1 * float(xlogy(w, w).sum())
                rewards, kept = kernels.poisson_direction_rewards(
                    np.ascontiguousarray(mu),
                    w,
                    np.ascontiguousarray(lw, dtype=float),
                    np.ascontiguousarray(x, dtype=float),
                    np.ascontiguousarray(targets),
                    int(z),
                    p.tail_mass,
                    h1,
                    w_now,
                )
                return rewards, mu.shape[0] * kept * mu.shape[1]
            q = model.outcome_probabilities(targets, x)
            rewards, kept = _direction_rewards_compiled(w, x, q, targets, pos, h1, p.tail_mass, est)
            return rewards, q.shape[0] * kept * q.shape[2]
        q = merge_tail_classes(w, model.outcome_probabilities(targets, x), p.tail_mass)
        return direction_rewards(w, x, q, targets, pos, h1), q.size
