"""Speed of the indoor-PF core: one filter update and one entropy decision.

Vectorised NumPy code side by side with a plain per-particle Python loop of the same maths
(eqs. 4, 10, 11, 17-18 of the indoor PF paper), with a check that both agree. Targets:
update <= 1 ms, decision <= 5 ms (1 000 particles, 20-record window, 4 candidate moves).

The last line is machine-readable::

    RESULT pf_update_ms=<x> entropy_decision_ms=<y> table1_s=<z> pf_update_speedup=<a>
           entropy_decision_speedup=<b> agree=<yes|no>

``table1_s`` is the wall time of the Table 1 run (2 start points x 50 PF episodes, 100 episodes
on 2 workers: :func:`odorloc.papers.indoor_pf_entropy.reproduction.table1_wall_time`), target
<= 180 s; ``nan`` with ``--no-table1``. The speed-ups are over the per-particle loops, and
``agree`` says whether both checks passed.

Run: ``python benchmarks/pf_speed.py [--repeat 200]``.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np

from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.inference.particles import ParticleFilter
from odorloc.inference.particles.resampling import RouletteResampler
from odorloc.models.pang_farrell import (
    PangFarrellModel,
    PangFarrellParams,
    reference_detection_probability,
)
from odorloc.planning.base import Pose
from odorloc.planning.entropy import EntropyPlanner, EntropyPlannerParams

N_PARTICLES = 1000
WINDOW = 20
DT = 0.5


def _setup(seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    wind_dir = np.array([2.15, 3.6]) / np.hypot(2.15, 3.6)
    wind = 0.3 * wind_dir + rng.normal(0, 0.05, (WINDOW, 2))
    robot = np.array([1.2, 2.0])
    # Particles along the back-tracked plume axis, as after an initialisation.
    along = rng.uniform(0.0, 3.0, (N_PARTICLES, 1))
    hyp = robot - along * wind_dir + rng.normal(0, 0.3, (N_PARTICLES, 2))
    log_w = rng.normal(0, 1.0, N_PARTICLES)
    log_w -= np.log(np.exp(log_w).sum())
    return {"wind": wind, "robot": robot, "hyp": hyp, "log_w": log_w}


# ---------------------------------------------------------------------- PF update
def make_filter(case: dict) -> ParticleFilter:
    """The long-lived filter the timed step works on (built once, outside the timing)."""
    return ParticleFilter(case["hyp"], case["log_w"], resampler=RouletteResampler())


def update_vectorised(case: dict, model: PangFarrellModel, pf: ParticleFilter) -> np.ndarray:
    """One filter step: likelihood (eq. 10), log-space update (eq. 4), ESS test (eq. 12).

    Weights are reset to the case's prior first so that every timed call does the same work.
    """
    pf.replace(case["hyp"], case["log_w"])
    pf.update(
        model.log_likelihood(True, case["robot"], pf.positions, wind_window=case["wind"], dt=DT)
    )
    pf.needs_resampling()
    return np.asarray(pf.log_weights)


def update_loop(case: dict, params: PangFarrellParams) -> np.ndarray:
    """The same step written as a per-particle Python loop."""
    p1 = reference_detection_probability(case["robot"], case["wind"], DT, case["hyp"], params)
    new = [lw + math.log(p) for lw, p in zip(case["log_w"].tolist(), p1.tolist(), strict=True)]
    m = max(new)
    z = m + math.log(sum(math.exp(v - m) for v in new))
    out = [v - z for v in new]
    _ess = 1.0 / sum(math.exp(2 * v) for v in out)
    return np.asarray(out)


# ---------------------------------------------------------------------- entropy decision
def make_planner(model: PangFarrellModel) -> EntropyPlanner:
    """The planner the timed decision uses (built once, outside the timing), its moves 0.11 m
    long in an open room."""
    planner = EntropyPlanner(EntropyPlannerParams(candidates={"step_length": 0.11}))
    ctx = SearchContext(
        arena=Arena.box((-10.0, -10.0), (10.0, 10.0), 0.1),
        dt=DT,
        agent_ids=(0,),
        start=np.zeros((1, 2)),
        speed_limits=np.ones(1),
    )
    planner.reset(ctx, model)
    return planner


def decision_vectorised(case: dict, planner: EntropyPlanner) -> tuple[int, np.ndarray]:
    """One planner call: 4 candidates x N particles x W records in one array pass."""
    from odorloc.inference.belief import ParticleBelief

    pose = Pose(case["robot"], heading=0.3, conditions={"wind_window": case["wind"], "dt": DT})
    plan = planner.plan(ParticleBelief(case["hyp"], case["log_w"]), pose, np.random.default_rng(0))
    assert plan.index is not None
    return int(plan.index), plan.scores


def decision_loop(case: dict, params: PangFarrellParams) -> tuple[int, np.ndarray]:
    """The same decision with per-candidate, per-particle Python loops."""
    heading = 0.3
    c, s = math.cos(heading), math.sin(heading)
    dirs = [(c, s), (-c, -s), (-s, c), (s, -c)]
    w = [math.exp(v) for v in case["log_w"].tolist()]
    out = []
    for dx, dy in dirs:
        target = case["robot"] + 0.11 * np.array([dx, dy])
        p1 = reference_detection_probability(target, case["wind"], DT, case["hyp"], params)
        p1 = p1.tolist()
        eh = 0.0
        for z in (0, 1):
            joint = [wi * (pi if z else 1.0 - pi) for wi, pi in zip(w, p1, strict=True)]
            pz = sum(joint)
            if pz > 0:
                eh -= sum(j * math.log(j / pz) for j in joint if j > 0)
        out.append(eh)
    return int(np.argmin(out)), np.asarray(out)


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


# ---------------------------------------------------------------------- Table 1 hook
def table1_wall_time(run: Callable[[], object] | None = None) -> float:
    """Wall time (s) of one Table 1 reproduction run, ``nan`` when not available.

    Parameters
    ----------
    run : callable, optional
        Called once with no arguments. Default: the indoor paper's Table 1 sweep on 2 workers
        (:func:`odorloc.papers.indoor_pf_entropy.reproduction.table1_wall_time`).
    """
    if run is None:
        from odorloc.papers.indoor_pf_entropy.reproduction import table1_wall_time as t1

        run = t1
    t0 = time.perf_counter()
    run()
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=200, help="calls per timing of the vector code")
    ap.add_argument("--no-table1", action="store_true", help="skip the Table 1 wall time")
    args = ap.parse_args(argv)

    case = _setup()
    params = PangFarrellParams()
    model = PangFarrellModel(params)

    pf = make_filter(case)
    upd_vec = update_vectorised(case, model, pf)
    upd_ref = update_loop(case, params)
    upd_ok = bool(np.allclose(upd_vec, upd_ref, rtol=1e-9, atol=1e-9))
    planner = make_planner(model)
    dec_vec = decision_vectorised(case, planner)
    dec_ref = decision_loop(case, params)
    dec_ok = dec_vec[0] == dec_ref[0] and bool(np.allclose(dec_vec[1], dec_ref[1], rtol=1e-9))

    t_upd = _time(lambda: update_vectorised(case, model, pf), args.repeat)
    t_upd_ref = _time(lambda: update_loop(case, params), 1)
    t_dec = _time(lambda: decision_vectorised(case, planner), args.repeat)
    t_dec_ref = _time(lambda: decision_loop(case, params), 1)

    rows = [
        ("PF update", t_upd, t_upd_ref, 1.0, upd_ok),
        ("entropy decision", t_dec, t_dec_ref, 5.0, dec_ok),
    ]
    print(f"N = {N_PARTICLES} particles, window = {WINDOW} records, 4 candidate moves")
    print(
        f"{'operation':<18} {'vector ms':>10} {'loop ms':>10} {'speed-up':>9} "
        f"{'target ms':>10} {'agree':>6}"
    )
    for name, tv, tl, target, ok in rows:
        flag = "" if tv <= target else "  (over target)"
        print(
            f"{name:<18} {tv:10.3f} {tl:10.1f} {tl / tv:8.0f}x {target:10.1f} "
            f"{'yes' if ok else 'NO':>6}{flag}"
        )
    t1 = math.nan if args.no_table1 else table1_wall_time()
    if math.isfinite(t1):
        flag = "" if t1 <= 180.0 else "  (over the 180 s target)"
        print(f"Table 1 wall time: {t1:.1f} s{flag}")
    else:
        print("Table 1 wall time: n/a")
    print(
        f"RESULT pf_update_ms={t_upd:.3f} entropy_decision_ms={t_dec:.3f} table1_s={t1:.1f} "
        f"pf_update_speedup={t_upd_ref / t_upd:.0f} "
        f"entropy_decision_speedup={t_dec_ref / t_dec:.0f} "
        f"agree={'yes' if upd_ok and dec_ok else 'no'}"
    )


if __name__ == "__main__":
    main()
