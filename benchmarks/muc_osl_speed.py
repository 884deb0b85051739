"""Speed of MUC-OSL's parts and of whole team episodes (multi-UAV paper), compiled and NumPy.

1. One Col-PF update of one UAV (N = 160 particles, two neighbour messages, iteration 30 of a
   search whose measurement history holds 90 readings, the default parameters): confidence
   factors (eq. 10), weights (eqs. 13-14), low-variance resampling with its 1 m jitter, PUGL on
   N_s particles (eq. 15) as reversible moves judged by the history (eqs. 16-17), the count of
   eq. 18 and the Gaussian fit (eqs. 19-20);
2. one Adap-PP decision of one UAV at N = 160: 26 directions x the Poisson outcome classes
   (eqs. 21-25), then the step length (eqs. 26-28);

each with the compiled kernels (numba) and with the NumPy reference (``backend: numpy`` on the
model and the planner). A straightforward per-particle Python loop of the same maths checks
the vector code: the weights of eqs. 13-14 and the whole Col-PF update *with the printed moves*
from Generators of the same seed (the loop draws its random numbers with the same calls in the
same order, so it ends with the same particles, N_s, count and fit), and the direction rewards
and the chosen hover point of Adap-PP; the loop is timed too. Then
3. the mean wall time of whole episodes of each algorithm on ``muc-osl-3d`` (3 UAVs,
   100 x 60 x 30 m), each backend after one untimed warm-up episode of its own, then timed in
   pairs: each episode is played on both backends in turn, ``--repeats`` times with the order
   reversed at each repeat, and its least wall time on a backend counts (a busy machine only
   ever adds time, and a slow spell falls on both sides alike); every repeat must give the same
   rows. Col-Inf's rows must be equal bit for bit across the backends (its kernels reproduce
   NumPy to the bit), the others' agree within round-off (their kernels: 1e-9 relative), so
   their episodes may part. An episode's wall time is its simulated length times the cost of
   one simulated second: the table shows both.

Targets: decision <= 0.5 ms at N = 160, mean MUC-OSL episode <= 0.3 s, both >= 3x the NumPy
path. The last line is machine-readable::

    RESULT colpf_update_ms=<x> adap_pp_decision_ms=<y> episode_s_mucosl=<z> episode_s_colinf=<w>
           adap_pp_decision_ms_numpy=<a> episode_s_mucosl_numpy=<b> ms_per_sim_s_mucosl=<c>
           episode_s_mucosl_no_eq16=<e> same_rows=<yes|no|n/a>
           colpf_update_loop_ms=<f> colpf_vs_loop=<g> adap_pp_loop_ms=<h> adap_pp_vs_loop=<i>
           colpf_update_ms_numpy=<j> adap_pp_vs_numpy=<k> episode_vs_numpy=<l>
           episode_s_mucosl_printed=<m> colpf_update_alone_ms=<n> colpf_update_alone_ms_numpy=<o>

(``same_rows``: Col-Inf's rows with and without the kernels; the ``_vs_loop`` ratios: the
loop's time over the compiled printed update's and decision's; ``_vs_numpy``: the NumPy path's
time over the compiled one's; ``colpf_update_ms`` times loading the case's state, the 90
readings of its history appended one by one, with each update, ``colpf_update_alone_ms``
restores that state from a copy and times the update itself).

Run: ``python benchmarks/muc_osl_speed.py [--repeat 200] [--episodes 6] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import copy
import math
import time
from collections.abc import Callable

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.core.types import SearchContext
from odorloc.engine.episode import run_episode
from odorloc.geometry.arena import Arena
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.particles.adaptive_count import spacing_minimum
from odorloc.inference.particles.collaborative import fit_payload
from odorloc.inference.particles.history import MeasurementHistory
from odorloc.inference.particles.team_estimators import ColPFEstimator, ColPFParams, Measurement
from odorloc.models.kernels import HAVE_NUMBA
from odorloc.models.vergassola import (
    VergassolaModel,
    VergassolaModelParams,
    correlation_length,
)
from odorloc.planning.adaptive import (
    AdaptivePathPlanner,
    AdaptivePlannerParams,
    merge_tail_classes,
)
from odorloc.planning.base import Pose
from odorloc.planning.steps import lattice_offsets
from odorloc.scenarios import get_scenario
from odorloc.searchers.uav_team import SENSOR_RADIUS

N = 160
WIND = np.array([0.0, -1.0, 0.0])
#: the arena's upper corner (the lower one is the origin) and the UAV's start
UPPER = (100.0, 60.0, 30.0)
START = (10.0, 10.0, 5.0)
Q, V, D, TAU, A = 5.0, 1.0, 1.0, 100.0, SENSOR_RADIUS
ALGORITHMS = ("muc-osl", "col-inf", "col-pf", "adap-pp")
#: MUC-OSL without the upwind moves of eq. 16 (the reproduction's ablation): the same parts, but
#: its episodes end at the source
NO_EQ16 = {"type": "col-pf", "env_pu": "off"}
TIMING = ("wall_time", "wall_per_step_ms", "world_fraction", "searcher_fraction")
#: seed key of the untimed warm-up episodes (apart from the timed episodes' "muc-osl-3d")
WARMUP_KEY = "muc-osl-3d warm-up"


def sample_case(seed: int = 0) -> dict:
    """A mid-search state: particles spread around the source, the UAV 8 m downwind."""
    rng = np.random.default_rng(seed)
    src = np.array([10.0, 30.0, 25.0])
    x = np.clip(src + rng.normal(0, [6.0, 10.0, 4.0], (N, 3)), [0, 0, 0], UPPER)
    lw = rng.normal(0, 0.5, N)
    lw -= np.log(np.exp(lw).sum())
    pos = np.array([10.0, 22.0, 23.0])
    hist = pos + rng.normal(0, 6.0, (40, 3))
    w = np.exp(lw)
    mean = w @ x
    cov = ((x - mean) * w[:, None]).T @ (x - mean)
    inbox = {
        1: fit_payload(mean + 1.0, cov * 1.2, 1.0, [16.0, 18.0, 25.0], True, 1.0, WIND),
        2: fit_payload(mean - 2.0, cov * 0.8, 0.0, [4.0, 14.0, 21.0], False, 1.0, WIND),
    }
    # 30 iterations of three UAVs climbing towards the source: the readings the history holds
    path = np.linspace([10.0, 10.0, 5.0], [10.0, 24.0, 22.0], 30)
    readings = []
    # the UAV's own readings (exponent 1) and two neighbours' (their confidence factor)
    for u, beta in ((path, 1.0), (path + np.array([6.0, -2.0, 2.0]), 0.8), (path - 3.0, 0.6)):
        for q in u:
            readings.append((float(rng.poisson(_rate(q.tolist(), src.tolist()))), q, beta))
    return {
        "x": x,
        "lw": lw,
        "pos": pos,
        "hist": hist,
        "inbox": inbox,
        "count": 1.0,
        # the estimator's state besides its particles and fit: the iteration, the cues captured
        # before it, the count eq. 18 chose last time, and how far the UAV started from the
        # prior's mean (the arena's centre), which fixes eq. 18's reference g_0
        "k": 30,
        "cues": [],
        "history": readings,
        "target_n": N,
        "start_distance": math.dist(START, [0.5 * h for h in UPPER]),
    }


def context() -> SearchContext:
    return SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), UPPER, 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[list(START)],
        speed_limits=[1.0],
    )


# ---------------------------------------------------------------------- reference maths
#: eq. 2's correlation length and eq. 1's constant factors, fixed for the whole benchmark
LAM = correlation_length(V, D, TAU)
AQ = A * Q
DRIFT = V / (2 * D)


def _rate(u: list[float], o: list[float]) -> float:
    """Eq. 1 for one sensor position and one source hypothesis (wind towards -y)."""
    r = max(math.dist(u, o), A)
    return AQ / r * math.exp(-(u[1] - o[1]) * DRIFT - r / LAM)


def _log_poisson(d: float, mu: float, log_fact: float) -> float:
    """Eq. 3 in log form (``log_fact = lgamma(d + 1)``, the same for every particle)."""
    if mu == 0.0:
        return 0.0 if d == 0 else -math.inf
    return d * math.log(mu) - mu - log_fact


def _kl(m0: np.ndarray, s0: np.ndarray, m1: np.ndarray, s1: np.ndarray) -> float:
    inv = np.linalg.inv(s1)
    dm = m1 - m0
    return 0.5 * float(
        np.trace(inv @ s0) + dm @ inv @ dm - 3 + math.log(np.linalg.det(s1) / np.linalg.det(s0))
    )


def _neighbours_loop(case: dict, fit: tuple[np.ndarray, np.ndarray]) -> list[tuple]:
    """Per message, in sender order: ``beta`` (eq. 10), the count, ``log d!``, where it was
    taken, the cue flag and the sender's mean."""
    out = []
    for s in sorted(case["inbox"]):
        msg = case["inbox"][s]
        m = msg.measurement
        d = float(m.count)
        beta = math.exp(-max(_kl(fit[0], fit[1], msg.mean, msg.cov), 0.0))
        out.append(
            (beta, d, math.lgamma(d + 1.0), m.position.tolist(), m.cue_captured, msg.mean.tolist())
        )
    return out


def colpf_weights_loop(
    case: dict, fit: tuple[np.ndarray, np.ndarray], nbrs: list[tuple] | None = None
) -> list[float]:
    """Eqs. 10, 13, 14 particle by particle."""
    pos = case["pos"].tolist()
    own = (float(case["count"]), math.lgamma(case["count"] + 1.0))
    if nbrs is None:
        nbrs = _neighbours_loop(case, fit)
    meas = [(b, d, lf, u) for b, d, lf, u, _, _ in nbrs]
    new = []
    for o, lw in zip(case["x"].tolist(), case["lw"].tolist(), strict=True):
        v = lw + _log_poisson(own[0], _rate(pos, o), own[1])
        for b, d, lf, u in meas:
            v += b * _log_poisson(d, _rate(u, o), lf)
        new.append(v)
    top = max(new)
    z = top + math.log(sum(math.exp(v - top) for v in new))
    return [math.exp(v - z) for v in new]


def _weighted_mean(w: list[float], x: list[list[float]]) -> list[float]:
    """``sum_n w_n x_n`` in one pass."""
    sx = sy = sz = 0.0
    for wi, q in zip(w, x, strict=True):
        sx += wi * q[0]
        sy += wi * q[1]
        sz += wi * q[2]
    return [sx, sy, sz]


def colpf_update_loop(
    case: dict, fit: tuple[np.ndarray, np.ndarray], p: ColPFParams, rng: np.random.Generator
) -> dict[str, object]:
    """One ``ColPFEstimator.update`` particle by particle, step for step: the weights
    (eqs. 10, 13-14) and the estimate the filter records after them, the effective sample size,
    low-variance resampling with the resampler's Gaussian jitter and its projection into the
    arena, PUGL on ``N_s`` particles (eq. 15: env-pu upwind by the invariant reading of eq. 16,
    col-pu towards ``gbest`` of eq. 17 while no cue is captured), the next count (eq. 18) and the
    Gaussian fit (eqs. 19-20). The random numbers are drawn by the same Generator calls in the
    same order as the vector code draws them (one call per kind: a call per number would time
    NumPy's call overhead, not the maths), so from the same seed both end with the same
    particles. Returns the estimate recorded after the weighting, the particles ``x`` and weights
    ``w``, ``n_s``, the next count ``n_next`` and the fit ``mean``, ``cov``."""
    ref = p.resampler
    if ref.type not in ("low-variance", "systematic") or p.env_pu == "literal":
        raise ValueError("the loop follows low-variance resampling and the invariant env-pu")
    if p.pugl_move != "printed":
        raise ValueError("the loop follows PUGL's printed moves")
    # the configuration, read once (attribute look-ups per particle would be the loop's own cost)
    jitter = float(ref.params("resampler").jitter_std)
    hx, hy, hz = UPPER
    k, count, pos = case["k"], float(case["count"]), case["pos"].tolist()
    nbrs = _neighbours_loop(case, fit)
    w = colpf_weights_loop(case, fit, nbrs)
    x = case["x"].tolist()
    n = len(w)
    cues = [*case["cues"], k] if count > 0 else list(case["cues"])
    # the filter records its estimate after every weighting (its history), so the loop does too
    recorded = _weighted_mean(w, x)

    # ---- low-variance resampling (eq. 12's N_eff; or to the count eq. 18 chose last time)
    target = case["target_n"]
    ess = 1.0 / sum(v * v for v in w)
    if target != n or ess < p.resample_threshold * n:
        u0 = rng.random()
        noise = rng.normal(0.0, jitter, (target, 3)).tolist() if jitter > 0 else None
        out, c, i = [], w[0], 0
        for j in range(target):
            ptr = (u0 + j) / target
            while c <= ptr and i < n - 1:
                i += 1
                c += w[i]
            q = x[i]
            if noise is not None:
                e = noise[j]
                r = [
                    min(max(q[0] + e[0], 0.0), hx),
                    min(max(q[1] + e[1], 0.0), hy),
                    min(max(q[2] + e[2], 0.0), hz),
                ]
                # the arena's free test (an obstacle-free box: its bounds); a copy that fails
                # it falls back onto its parent
                ok = 0.0 <= r[0] <= hx and 0.0 <= r[1] <= hy and 0.0 <= r[2] <= hz
                q = r if ok else q[:]
            else:
                q = q[:]
            out.append(q)
        x, n = out, target
        w = [1.0 / n] * n

    # ---- PUGL (eqs. 15-17)
    n_s = 0
    if k < p.k_max:
        frac = (1.0 - (k / p.k_max) ** p.gamma1) ** p.gamma2
        n_s = int(min(n, math.floor(n * frac + 0.5)))
    if n_s:
        sel = rng.choice(n, size=n_s, replace=False).tolist()
        # eq. 16 moves particles horizontally: the wind's vertical part sets no direction
        ux, uy, uz = -float(WIND[0]), -float(WIND[1]), 0.0
        norm = math.hypot(ux, uy)
        env = p.env_pu != "off" and (p.env_pu_from == "start" or bool(cues))
        if env and norm >= 1e-12:
            ux, uy = ux / norm, uy / norm
            step = p.env_step
            for s, r in zip(sel, rng.random(n_s).tolist(), strict=True):
                q, sr = x[s], step * r
                x[s] = [
                    min(max(q[0] + sr * ux, 0.0), hx),
                    min(max(q[1] + sr * uy, 0.0), hy),
                    min(max(q[2] + sr * uz, 0.0), hz),
                ]
        if p.col_pu and not cues:
            cued = [(b, mu) for b, _, _, _, flag, mu in nbrs if flag]
            total = sum(b for b, _ in cued)
            if cued and total > 0:
                g = [sum(b * mu[a] for b, mu in cued) / total for a in range(3)]
                gx, gy, gz = g
                for s, r in zip(sel, rng.random(n_s).tolist(), strict=True):
                    q = x[s]
                    x[s] = [
                        min(max(q[0] + r * (gx - q[0]), 0.0), hx),
                        min(max(q[1] + r * (gy - q[1]), 0.0), hy),
                        min(max(q[2] + r * (gz - q[2]), 0.0), hz),
                    ]

    # ---- the next count (eq. 18) from the estimate after PUGL
    n_next = target
    if p.adaptive_count:
        dist = math.dist(pos, _weighted_mean(w, x))
        f_dist = 0.0 if dist == 0 else math.exp(-1.0 / dist)
        m, dc = len(cues), p.delta_c
        if m == 0 or k < 1:
            f_cue = 0.0
        elif m > dc:
            f_cue = min(1.0, dc / max(k - cues[m - dc - 1], 1))
        else:
            f_cue = min(1.0, m / k)
        g = f_dist * (1.0 - f_cue)
        # g_0: the gap at the start (the estimator's reset), from the case's start distance
        g0 = max(math.exp(-1.0 / case["start_distance"]), 1e-6)
        goal = n * g if p.count_reading == "literal" else p.n_particles * g / g0
        n_min = p.n_min
        if n_min is None:
            n_min = min(spacing_minimum(float(np.prod(UPPER)), D, TAU), p.n_max)
        n_next = min(max(math.floor(goal + 0.5), n_min), p.n_max)

    # ---- the Gaussian fit (eqs. 19-20)
    mean = _weighted_mean(w, x)
    mx, my, mz = mean
    cov = [[0.0] * 3 for _ in range(3)]
    c0, c1, c2 = cov
    for wi, q in zip(w, x, strict=True):
        dx, dy, dz = q[0] - mx, q[1] - my, q[2] - mz
        a0, a1, a2 = wi * dx, wi * dy, wi * dz
        c0[0] += a0 * dx
        c0[1] += a0 * dy
        c0[2] += a0 * dz
        c1[0] += a1 * dx
        c1[1] += a1 * dy
        c1[2] += a1 * dz
        c2[0] += a2 * dx
        c2[1] += a2 * dy
        c2[2] += a2 * dz
    return {
        "recorded": recorded,
        "x": x,
        "w": w,
        "n_s": n_s,
        "n_next": n_next,
        "mean": mean,
        "cov": cov,
    }


def adap_pp_loop(case: dict, h1_scale: float, h2_scale: float, l_max: int, z_classes: int):
    """Eqs. 21-28 with loops over directions, particles and count classes."""
    x = case["x"].tolist()
    w = [math.exp(v) for v in case["lw"].tolist()]
    pos = case["pos"].tolist()
    est = [sum(wi * p[a] for wi, p in zip(w, x, strict=True)) for a in range(3)]
    var = sum(sum(wi * (p[a] - est[a]) ** 2 for wi, p in zip(w, x, strict=True)) for a in range(3))
    h1 = h1_scale * var
    h_now = -sum(wi * math.log(wi) for wi in w if wi > 0)
    d_now = math.dist(pos, est)
    w_now = d_now + h1 * h_now
    steps = 2.0 * lattice_offsets(3)
    box = (100, 60, 30)
    # log d! of the head classes 0 .. Z-2, the same for every direction and particle
    head = range(z_classes - 1)
    log_fact = [math.lgamma(d + 1.0) for d in head]
    rewards = []
    for s in steps.tolist():
        t = [p + v for p, v in zip(pos, s, strict=True)]
        if not all(0 <= c <= hi for c, hi in zip(t, box, strict=True)):
            rewards.append(-math.inf)
            continue
        # p(d | o_n) of every class, once per particle: eq. 3 for the head classes, and the
        # censored class d >= Z - 1 as one minus the head
        probs = []
        for o in x:
            mu = _rate(t, o)
            if mu == 0.0:
                q = [1.0] + [0.0] * (z_classes - 1)
            else:
                log_mu = math.log(mu)
                q = [math.exp(d * log_mu - mu - lf) for d, lf in zip(head, log_fact, strict=True)]
                q.append(max(1.0 - sum(q), 0.0))
            probs.append(q)
        ew = 0.0
        for z in range(z_classes):
            joint = [wi * q[z] for wi, q in zip(w, probs, strict=True)]
            pz = sum(joint)
            if pz <= 1e-300:
                continue
            mx = my = mz = hz = 0.0
            for j, p in zip(joint, x, strict=True):
                mx += j * p[0]
                my += j * p[1]
                mz += j * p[2]
                if j > 0:
                    r = j / pz
                    hz -= r * math.log(r)
            ew += pz * (math.dist(t, (mx / pz, my / pz, mz / pz)) + h1 * hz)
        rewards.append(w_now - ew)
    k = int(np.argmax(rewards))
    step = steps[k].tolist()
    norm = float(np.linalg.norm(steps[k]))
    h2 = h2_scale * d_now
    # past points at the current position lie on every sphere and are not counted (eq. 28)
    pts = [p for p in case["hist"].tolist() if math.dist(p, pos) > 1e-9]
    best, best_r = 1, math.inf
    z_prev = 0
    for ell in range(1, l_max + 1):
        t = [p + ell * v for p, v in zip(pos, step, strict=True)]
        if not all(0 <= c <= hi for c, hi in zip(t, box, strict=True)):
            break
        c = [p + 0.5 * ell * v for p, v in zip(pos, step, strict=True)]
        r = 0.5 * ell * norm + 1e-9
        # z(l): the points inside the sphere whose diameter joins the UAV and the point l
        # cells on; the spheres are nested, so z(l) - z(l-1) counts the new ones (eq. 28)
        z_in = sum(math.dist(p, c) <= r for p in pts)
        val = math.dist(t, est) + h2 * (z_in - z_prev)
        z_prev = z_in
        if val < best_r:
            best, best_r = ell, val
    return k, best, np.array(rewards)


# ---------------------------------------------------------------------- odorloc's code
def _time(fn: Callable[[], object], repeat: int) -> float:
    """Best-of-3 mean wall time per call, milliseconds."""
    fn()
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        best = min(best, (time.perf_counter() - t0) / repeat)
    return best * 1e3


def _planner(
    params: AdaptivePlannerParams, ctx: SearchContext, model: VergassolaModel, hist: np.ndarray
) -> AdaptivePathPlanner:
    """An Adap-PP planner reset for the case, its measurement points recorded."""
    planner = AdaptivePathPlanner(params)
    planner.reset(ctx, model)
    for p in hist:
        planner.record(p)
    return planner


def _load_case(est: ColPFEstimator, case: dict, fit: tuple[np.ndarray, np.ndarray]) -> None:
    """Put the case's state into an estimator (after its reset): particles, fit, cues so far,
    the count eq. 18 chose last time, the measurement history."""
    est.history.clear()
    for count, pos, beta in case["history"]:
        est.history.append(count, pos, 1.0, WIND, beta)
    est.pf.replace(case["x"], case["lw"])
    est.fit = fit
    est.target_n = case["target_n"]
    est.cue_iterations = list(case["cues"])


def colpf_update_agreement(
    est: ColPFEstimator, case: dict, fit: tuple[np.ndarray, np.ndarray], seed: int = 7
) -> dict[str, float]:
    """One update of ``est`` (reset, its params those of the loop) and :func:`colpf_update_loop`
    from Generators of the same seed: ``N_s`` and the next count of each side, the largest
    differences of the recorded estimate, the particles, the weights and the fit, and whether
    they agree (counts equal, particles to 1e-9 m, the rest to 1e-9 relative)."""
    # eq. 18's g_0 is set at reset from the prior the reset drew; both sides take the case's
    est.counter.start(case["start_distance"])
    _load_case(est, case, fit)
    m = Measurement(case["count"], case["pos"], 1.0, case["k"], WIND)
    est.update(m, case["inbox"], np.random.default_rng(seed))
    ref = colpf_update_loop(case, fit, est.params, np.random.default_rng(seed))
    x, w = np.array(ref["x"]), np.array(ref["w"])
    mean, cov = est.fit
    same_n = x.shape == est.pf.positions.shape
    out = {
        "n_s": float(est.n_moved),
        "n_s_loop": float(ref["n_s"]),
        "n_next": float(est.target_n),
        "n_next_loop": float(ref["n_next"]),
        "recorded": float(np.max(np.abs(est.pf.history[-1] - ref["recorded"]))),
        "x": float(np.max(np.abs(est.pf.positions - x))) if same_n else math.inf,
        "w": float(np.max(np.abs(est.pf.weights - w))) if same_n else math.inf,
        "mean": float(np.max(np.abs(mean - ref["mean"]))),
        "cov": float(np.max(np.abs(cov - np.array(ref["cov"])))),
    }
    out["agree"] = (
        out["n_s"] == out["n_s_loop"]
        and out["n_next"] == out["n_next_loop"]
        and same_n
        and out["x"] <= 1e-9
        and bool(np.allclose(est.pf.history[-1], ref["recorded"], rtol=1e-9, atol=0))
        and bool(np.allclose(est.pf.weights, w, rtol=1e-9, atol=1e-15))
        and bool(np.allclose(mean, ref["mean"], rtol=1e-9, atol=0))
        and bool(np.allclose(cov, ref["cov"], rtol=1e-9, atol=1e-12))
    )
    return out


def _episode_scenario(name: str, backend: str, estimator: dict | None) -> object:
    """``muc-osl-3d`` with the algorithm ``name`` on ``backend`` (``estimator``: its estimator
    replaced, for the ablation)."""
    planner = "adap-pp" if name in ("muc-osl", "adap-pp") else "fixed-step-infotaxis"
    searcher = {
        "type": name,
        "model": {"type": "vergassola", "sensor_radius": SENSOR_RADIUS, "backend": backend},
        "planner": {"type": planner, "backend": backend},
    }
    if estimator is not None:
        searcher["estimator"] = estimator
    return get_scenario("muc-osl-3d").with_overrides({"searcher": searcher})


def episode_rows(
    name: str,
    backends: tuple[str, ...],
    episodes: int,
    estimator: dict | None = None,
    repeats: int = 1,
) -> dict[str, tuple[list[float], list[dict]]]:
    """Wall times (s) and metric rows of ``episodes`` episodes of one algorithm on each
    backend, timed in pairs.

    Each backend first plays one untimed episode on seeds of its own (the first episode of a
    backend and algorithm in a process loads the kernels the later ones find ready: about half
    a second with numba). Then episode ``e`` is played on every backend in turn, ``repeats``
    times, the backends' order reversed at each repeat, so that a slow spell of the machine
    falls on both sides alike; an episode's wall time is the least of its repeats on that
    backend (the machine only ever adds time). Every repeat must give the same metric rows (the
    same seed gives the same episode), or ``RuntimeError``.

    Returns
    -------
    dict
        Per backend: the wall times ``(episodes,)`` and the metric rows (the timing columns
        left out).
    """
    scenarios = {b: _episode_scenario(name, b, estimator) for b in backends}
    for b in backends:
        run_episode(scenarios[b], *episode_seeds(2024, WARMUP_KEY, 0), record=False)
    out: dict[str, tuple[list[float], list[dict]]] = {b: ([], []) for b in backends}
    for e in range(episodes):
        seeds = episode_seeds(2024, "muc-osl-3d", e)
        best: dict[str, float] = {}
        for r in range(repeats):
            for b in backends if r % 2 == 0 else backends[::-1]:
                t0 = time.perf_counter()
                res = run_episode(scenarios[b], *seeds, record=False)
                wall = time.perf_counter() - t0
                row = {k: v for k, v in res.metrics.items() if k not in TIMING}
                if r == 0:
                    out[b][1].append(row)
                elif not _same([row], [out[b][1][e]]):
                    raise RuntimeError(f"{name} ({b}): episode {e} differs between repeats")
                best[b] = min(best.get(b, math.inf), wall)
        for b in backends:
            out[b][0].append(best[b])
    return out


def _same(a: list[dict], b: list[dict]) -> bool:
    """Metric rows equal bit for bit (NaN equal to NaN)."""
    return all(
        ra.keys() == rb.keys()
        and all(v == rb[k] or (v != v and rb[k] != rb[k]) for k, v in ra.items())
        for ra, rb in zip(a, b, strict=True)
    )


def _time_split(episodes: int) -> tuple[float, dict[str, float]]:
    """Mean MUC-OSL episode (s) and the seconds per episode spent in its parts: the engine's
    step (world, sensors, flight, messages), the estimators' updates, the planners' decisions,
    and, inside those, the compiled kernels (the arithmetic; the rest is interpreter work on
    small arrays). Timers wrap the functions for this measurement only."""
    import odorloc.engine.episode as engine
    import odorloc.inference.particles.colpf_kernels as colpf_kernels
    import odorloc.inference.particles.team_estimators as estimators
    import odorloc.models.kernels as model_kernels
    import odorloc.planning.adaptive as adaptive
    import odorloc.planning.kernels as planning_kernels

    acc: dict[str, float] = dict.fromkeys(("engine step", "update", "plan", "kernels"), 0.0)
    saved: list[tuple[object, str, object]] = []

    def wrap(owner: object, name: str, key: str) -> None:
        f = getattr(owner, name)
        saved.append((owner, name, f))

        def timed(*a: object, **k: object) -> object:
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                acc[key] += time.perf_counter() - t

        setattr(owner, name, timed)

    wrap(engine.Episode, "step", "engine step")
    wrap(estimators.ColPFEstimator, "update", "update")
    wrap(adaptive.AdaptivePathPlanner, "plan", "plan")
    for mod in (model_kernels, planning_kernels, colpf_kernels):
        for name in list(vars(mod)):
            if type(getattr(mod, name)).__name__ == "CPUDispatcher":
                wrap(mod, name, "kernels")
    try:
        sc = get_scenario("muc-osl-3d").with_overrides({"searcher": {"type": "muc-osl"}})
        t0 = time.perf_counter()
        for e in range(episodes):
            run_episode(sc, *episode_seeds(2024, "muc-osl-3d", e), record=False)
        wall = (time.perf_counter() - t0) / episodes
    finally:
        for owner, name, f in reversed(saved):
            setattr(owner, name, f)
    return wall, {k: v / episodes for k, v in acc.items()}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=200, help="calls per timing of the vector code")
    ap.add_argument("--episodes", type=int, default=6, help="episodes per algorithm")
    ap.add_argument(
        "--repeats",
        type=int,
        default=3,
        help="plays of each timed episode per backend (its least wall time counts)",
    )
    args = ap.parse_args(argv)

    case = sample_case()
    ctx = context()
    rng = np.random.default_rng(1)
    backends = ("numpy", "numba") if HAVE_NUMBA else ("numpy",)
    models = {
        b: VergassolaModel(VergassolaModelParams(sensor_radius=A, backend=b)) for b in backends
    }
    w0 = np.exp(case["lw"])
    mean0 = w0 @ case["x"]
    cov0 = ((case["x"] - mean0) * w0[:, None]).T @ (case["x"] - mean0)
    meas = Measurement(case["count"], case["pos"], 1.0, case["k"], WIND)

    # ---- Col-PF update: the weights (eqs. 10-14) against the loop's (no resampling, no PUGL),
    # then the whole update against the loop from the same seed, then the update timed with
    # each backend
    fit0 = (mean0, cov0)
    ref_w = colpf_weights_loop(case, fit0)
    printed = ColPFParams(n_particles=N, n_max=N, pugl_move="printed")
    t_colpf, t_printed, colpf_ok, colpf_diff = {}, {}, {}, {}
    t_alone: dict[str, float] = {}
    for b, model in models.items():
        check = ColPFEstimator(
            ColPFParams(
                n_particles=N,
                resample_threshold=0.0,
                env_pu="off",
                adaptive_count=False,
                col_pu=False,
            )
        )
        check.reset(ctx, model, rng, n=N)
        check.pf.replace(case["x"], case["lw"])
        check.fit = fit0
        check.update(Measurement(case["count"], case["pos"], 1.0, 1000, WIND), case["inbox"], rng)
        weights_ok = bool(np.allclose(check.pf.weights, ref_w, rtol=1e-9, atol=1e-15))
        loop_est = ColPFEstimator(printed)
        loop_est.reset(ctx, model, rng, n=N)
        colpf_diff[b] = colpf_update_agreement(loop_est, case, fit0)
        colpf_ok[b] = weights_ok and colpf_diff[b]["agree"]
        for params, times in ((ColPFParams(n_particles=N, n_max=N), t_colpf), (printed, t_printed)):
            est = ColPFEstimator(params)
            est.reset(ctx, model, rng, n=N)
            est.counter.start(case["start_distance"])

            def colpf(est: ColPFEstimator = est) -> None:
                _load_case(est, case, fit0)
                est.update(meas, case["inbox"], rng)

            times[b] = _time(colpf, args.repeat)
        # the same update with the state restored from a copy: re-appending the 90 readings
        # of the history (what the rows above time with each update) left out
        est = ColPFEstimator(ColPFParams(n_particles=N, n_max=N))
        est.reset(ctx, model, rng, n=N)
        est.counter.start(case["start_distance"])
        _load_case(est, case, fit0)
        saved = copy.deepcopy(est.history)

        def alone(est: ColPFEstimator = est, saved: MeasurementHistory = saved) -> None:
            est.history = copy.deepcopy(saved)
            est.pf.replace(case["x"], case["lw"])
            est.fit = fit0
            est.target_n = case["target_n"]
            est.cue_iterations = list(case["cues"])
            est.update(meas, case["inbox"], rng)

        t_alone[b] = _time(alone, args.repeat)
    t_colpf_ref = _time(lambda: colpf_update_loop(case, fit0, printed, rng), 1)

    # ---- Adap-PP decision: exact classes (tail 1e-300) against the loop, then the default
    # (classes merged beyond the predicted tail) timed with each backend
    belief = ParticleBelief(case["x"], case["lw"])
    t_dec, dec_ok = {}, {}
    k_ref = l_ref = r_ref = None
    t_dec_ref = math.nan
    z = z_timed = 0
    pose = Pose(case["pos"], conditions={"dt": 1.0, "direction": WIND})
    for b, model in models.items():
        bound = model.bind(dt=1.0, direction=WIND)
        params = AdaptivePlannerParams(l_max=4, tail_mass=1e-300, backend=b)
        planner = _planner(params, ctx, model, case["hist"])
        plan = planner.plan(belief, pose, rng)
        if r_ref is None:
            targets = case["pos"] + planner.steps
            z = bound.outcome_probabilities(targets, case["x"]).shape[1]
            # the timed planner (default tail mass) may merge the classes beyond the predicted
            # tail (eq. 24's d_max); the loop's time is comparable only if it keeps all of them
            ok = planner.feasible(case["pos"], targets)
            q = bound.outcome_probabilities(targets[ok], case["x"])
            tail = AdaptivePlannerParams().tail_mass
            z_timed = merge_tail_classes(belief.weights, q, tail).shape[1]
            k_ref, l_ref, r_ref = adap_pp_loop(case, params.h1_scale, params.h2_scale, 4, z)
            # timed as the vector code is (a call before, the best of three rounds)
            loop_args = (case, params.h1_scale, params.h2_scale, 4, z)
            t_dec_ref = _time(lambda args=loop_args: adap_pp_loop(*args), 1)
        finite = np.isfinite(r_ref)
        dec_ok[b] = (
            plan.index == k_ref
            and plan.extra["length"] == l_ref
            and bool(np.allclose(-plan.scores[finite], r_ref[finite], rtol=1e-8, atol=1e-8))
        )
        fast = _planner(AdaptivePlannerParams(l_max=4, backend=b), ctx, model, case["hist"])
        t_dec[b] = _time(lambda fast=fast: fast.plan(belief, pose, rng), args.repeat)
    best = backends[-1]

    print(f"N = {N} particles, 26 directions, l_max = 4, two neighbours (shared machine)")
    classes = f"{z} count classes in the loop, {z_timed} in the timed decision"
    print(classes if z == z_timed else f"{classes}: the decision's ratio is not like for like")
    d = colpf_diff[best]
    print(
        f"Col-PF update against the loop, same seed ({best}): N_s {d['n_s']:.0f} / "
        f"{d['n_s_loop']:.0f}, next count (eq. 18) {d['n_next']:.0f} / {d['n_next_loop']:.0f}, "
        f"largest differences: particles {d['x']:.1e} m, weights {d['w']:.1e}, "
        f"fit {max(d['mean'], d['cov']):.1e}"
    )
    print(
        f"{'operation':<22} {'backend':>8} {'ms':>8} {'loop ms':>9} {'vs loop':>8} "
        f"{'vs numpy':>9} {'target':>7} {'agree':>6}"
    )
    for name, times, tl, target, oks in (
        ("Col-PF update", t_colpf, math.nan, math.nan, colpf_ok),
        ("Col-PF update alone", t_alone, math.nan, math.nan, colpf_ok),
        ("Col-PF, printed moves", t_printed, t_colpf_ref, math.nan, colpf_ok),
        ("Adap-PP decision", t_dec, t_dec_ref, 0.5, dec_ok),
    ):
        for b in backends:
            tv = times[b]
            tgt = "-" if math.isnan(target) else f"{target:.1f}"
            flag = "" if math.isnan(target) or tv <= target else "  (over target)"
            print(
                f"{name:<22} {b:>8} {tv:8.3f} {tl:9.3f} {tl / tv:7.1f}x "
                f"{times['numpy'] / tv:8.1f}x {tgt:>7} {'yes' if oks[b] else 'NO':>6}{flag}"
            )

    # ---- whole episodes, the backends in pairs per episode (same seeds: Col-Inf's rows must
    # be equal bit for bit)
    print(
        f"\nepisodes of muc-osl-3d (3 UAVs), {args.episodes} per algorithm, one process, "
        f"backends in pairs, least of {args.repeats} plays"
    )
    print(
        f"{'algorithm':<17} {'backend':>8} {'mean s':>8} {'sim s':>6} {'per step ms':>12} "
        f"{'vs numpy':>9} {'reached':>8} {'same rows':>10}"
    )
    means: dict[tuple[str, str], float] = {}
    per_step: dict[tuple[str, str], float] = {}
    same_all = True
    for name, label, estimator in (
        *((a, a, None) for a in ALGORITHMS),
        ("muc-osl-printed", "muc-osl-printed", None),
        ("muc-osl", "muc-osl w/o eq.16", NO_EQ16),
    ):
        timed = episode_rows(name, backends, args.episodes, estimator, args.repeats)
        rows = {b: timed[b][1] for b in backends}
        for b in backends:
            walls = timed[b][0]
            means[label, b] = float(np.mean(walls))
            steps = sum(r["steps"] for r in rows[b])
            per_step[label, b] = 1e3 * sum(walls) / max(steps, 1)
            reached = sum(int(r["success"]) for r in rows[b])
            # Col-Inf's compiled rows against the NumPy ones (its kernels are exact; the others'
            # agree within round-off, so their episodes may part)
            exact = name == "col-inf"
            same = b == "numpy" or not exact or _same(rows["numpy"], rows[b])
            same_all &= same
            print(
                f"{label:<17} {b:>8} {means[label, b]:8.3f} {steps / args.episodes:6.0f} "
                f"{per_step[label, b]:12.3f} {means[label, 'numpy'] / means[label, b]:8.1f}x "
                f"{f'{reached}/{args.episodes}':>8} "
                f"{'ref' if b == 'numpy' else '-' if not exact else 'yes' if same else 'NO':>10}"
            )
    if HAVE_NUMBA:
        wall, parts = _time_split(args.episodes)
        print(f"\nwhere a MUC-OSL episode's time goes ({best}, timers on: {wall:.3f} s)")
        print(f"{'part':<38} {'s/episode':>10} {'share':>7}")
        rest = wall - parts["engine step"] - parts["update"] - parts["plan"]
        for name, v in (
            ("engine step (world, sensors, flight)", parts["engine step"]),
            ("Col-PF updates", parts["update"]),
            ("Adap-PP decisions", parts["plan"]),
            ("searcher bookkeeping, episode loop", rest),
            ("  of all: inside compiled kernels", parts["kernels"]),
        ):
            print(f"{name:<38} {v:10.3f} {v / wall:6.0%}")
    m = means["muc-osl", best]
    target = "  (over the 0.3 s target)" if m > 0.3 else ""
    ratio_ep = means["muc-osl", "numpy"] / m
    ratio_dec = t_dec["numpy"] / t_dec[best]
    print(f"mean MUC-OSL episode ({best}) {m:.3f} s{target}, {ratio_ep:.1f}x the NumPy path")
    print(f"Adap-PP decision ({best}) {t_dec[best]:.3f} ms, {ratio_dec:.1f}x the NumPy path")
    # the targets, each both an absolute time and a ratio to the NumPy path in this run
    print(f"\n{'target':<46} {'measured':>17} {'met':>4}")
    for name, value, unit, ratio, limit in (
        ("Adap-PP decision <= 0.5 ms, >= 3x NumPy", t_dec[best], "ms", ratio_dec, 0.5),
        ("MUC-OSL episode <= 0.3 s, >= 3x NumPy", m, "s", ratio_ep, 0.3),
    ):
        met = "yes" if value <= limit and ratio >= 3.0 else "no"
        print(f"{name:<46} {f'{value:.3f} {unit}, {ratio:.1f}x':>17} {met:>4}")
    # an episode's wall time is its simulated length times the cost of a simulated second; the
    # second factor is the code's, the first the method's (episodes that miss the source fly
    # the whole 1 200 s)
    print(
        f"per simulated second ({best}): MUC-OSL {per_step['muc-osl', best]:.3f} ms, without "
        f"eq. 16 {per_step['muc-osl w/o eq.16', best]:.3f} ms, Col-Inf "
        f"{per_step['col-inf', best]:.3f} ms"
    )
    print(
        f"RESULT colpf_update_ms={t_colpf[best]:.3f} adap_pp_decision_ms={t_dec[best]:.3f} "
        f"episode_s_mucosl={m:.3f} episode_s_colinf={means['col-inf', best]:.3f} "
        f"adap_pp_decision_ms_numpy={t_dec['numpy']:.3f} "
        f"episode_s_mucosl_numpy={means['muc-osl', 'numpy']:.3f} "
        f"ms_per_sim_s_mucosl={per_step['muc-osl', best]:.3f} "
        f"episode_s_mucosl_no_eq16={means['muc-osl w/o eq.16', best]:.3f} "
        f"same_rows={'n/a' if not HAVE_NUMBA else 'yes' if same_all else 'no'} "
        f"colpf_update_loop_ms={t_colpf_ref:.3f} "
        f"colpf_vs_loop={t_colpf_ref / t_printed[best]:.1f} "
        f"adap_pp_loop_ms={t_dec_ref:.3f} adap_pp_vs_loop={t_dec_ref / t_dec[best]:.1f} "
        f"colpf_update_ms_numpy={t_colpf['numpy']:.3f} adap_pp_vs_numpy={ratio_dec:.1f} "
        f"episode_vs_numpy={ratio_ep:.1f} "
        f"episode_s_mucosl_printed={means['muc-osl-printed', best]:.3f} "
        f"colpf_update_alone_ms={t_alone[best]:.3f} "
        f"colpf_update_alone_ms_numpy={t_alone['numpy']:.3f}"
    )


if __name__ == "__main__":
    main()
