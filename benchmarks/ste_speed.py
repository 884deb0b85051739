"""Speed of the source-term estimator's core: a reading, a resample-move sweep, a decision.

Each operation runs as the library does it (compiled loops over the particles, NumPy for the
rest) side by side with a plain per-particle Python loop of the same mathematics, with a check
that both give the same numbers. The world is ``ste-gaussian``'s: a Gaussian plume with
Pasquill-Gifford widths (class B), censored Gaussian readings, the wind speed and direction in
the posterior (5 parameters per particle). Targets:

- one update of 20 000 particles by one reading (likelihood, log-space reweighting, ESS)
  <= 2 ms;
- one MCMC move sweep (random-walk proposal, prior, likelihood of the whole history of 200
  readings, accept/reject) <= 30 ms, at the estimator's default 5 000 particles (the history
  term costs particles x readings: the 20 000-particle sweep is printed too);
- one entrotaxis decision with 16 directions (thinning to 500 planning particles, outcome
  classes, predictive entropy) <= 20 ms on a 20 000-particle posterior.

The last line is machine-readable::

    RESULT ste_update_ms=<x> mcmc_sweep_ms=<y> entrotaxis_ms=<z> mcmc_sweep_20k_ms=<w>
           update_speedup=<a> mcmc_speedup=<b> entrotaxis_speedup=<c> agree=<yes|no>

Run: ``python benchmarks/ste_speed.py [--repeat 20] [--clock wall|cpu] [--quick]``
(``--clock cpu``: this process's CPU time, steadier on a shared machine; ``--quick``: smaller
sets and one repeat, for the test suite; not a measurement).
"""

from __future__ import annotations

import os

# one BLAS thread: the operations timed are single-threaded, and a multi-threaded BLAS call on a
# shared machine spends its time waiting for cores
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402
from scipy.special import log_ndtr, ndtr  # noqa: E402

from odorloc.core.types import SearchContext, SensorInfo  # noqa: E402
from odorloc.geometry.arena import Arena  # noqa: E402
from odorloc.inference.source_terms import SourceTermBelief  # noqa: E402
from odorloc.inference.source_terms.priors import LogUniformPrior, SourceTermPrior, VonMisesPrior  # noqa: E402
from odorloc.inference.source_terms.priors import NormalPrior as Normal  # noqa: E402
from odorloc.inference.weights import normalise_log_weights  # noqa: E402
from odorloc.models.gaussian import PG_RURAL  # noqa: E402
from odorloc.models.source_term import (  # noqa: E402
    GaussianSourceTermModel,
    GaussianSourceTermParams,
    SourceTerms,
    ThetaLayout,
)
from odorloc.planning.base import Pose  # noqa: E402
from odorloc.planning.source_term import SourceTermEntrotaxis, SourceTermPlannerParams  # noqa: E402

WIND = np.array([-1.532, -1.286])
PARAMS = GaussianSourceTermParams(
    spread="pasquill-gifford", stability="B", sigma0=0.1, gain=1000.0, noise_std=0.4, threshold=0.2
)


def setup(n: int, readings: int, seed: int = 0) -> dict:
    """Particles from the ``ste-gaussian`` prior and a history of readings along a path."""
    rng = np.random.default_rng(seed)
    lay = ThetaLayout(2, speed=True, direction=True)
    prior = SourceTermPrior(
        lay,
        np.zeros(2),
        np.full(2, 55.0),
        None,
        LogUniformPrior(low=0.01, high=5.0),
        Normal(mean="measured", std=1.0, low=0.5, high=5.0),
        VonMisesPrior(kappa=10.0),
        None,
        None,
        np.array([0.0, 1.0]),
        WIND,
    )
    theta = prior.sample(n, rng)
    model = GaussianSourceTermModel(PARAMS)
    path = np.column_stack(
        [np.linspace(5, 40, readings), 10 + 25 * np.abs(np.sin(np.arange(readings) / 9))]
    )
    truth = SourceTerms.single(np.array([[30.0, 35.0]]), 0.2)
    sig = model.signal(path, truth, np.tile(WIND, (readings, 1)))[:, 0]
    z = np.maximum(sig + rng.normal(0, 0.4, readings), 0.0)
    return {
        "theta": theta,
        "layout": lay,
        "prior": prior,
        "model": model,
        "z": z,
        "pts": path,
        "winds": np.tile(WIND, (readings, 1)),
        "log_w": rng.normal(0, 0.5, n),
        "rng_seed": seed,
    }


# ---------------------------------------------------------------------- a per-particle loop
_PG = PG_RURAL["B"]


def loop_log_likelihood(theta: np.ndarray, z: np.ndarray, pts: np.ndarray) -> list[float]:
    """The history log-likelihood of each particle, one particle and one reading at a time
    (columns x, y, log_rate, speed, direction; censored Gaussian readings)."""
    p = PARAMS
    ay, by, az, _, _ = _PG
    out = []
    for x0, y0, lq, sp, ang in theta.tolist():
        u = max(sp, p.min_speed)
        ex, ey = math.cos(ang), math.sin(ang)
        q = math.exp(lq)
        acc = 0.0
        for zt, (sx, sy) in zip(z.tolist(), pts.tolist(), strict=True):
            dx, dy = sx - x0, sy - y0
            x = dx * ex + dy * ey
            c = 0.0
            if x > 0:
                y = -dx * ey + dy * ex
                sy2 = p.sigma0**2 + (ay * x) ** 2 / (1 + by * x)
                sz2 = p.sigma0**2 + (az * x) ** 2
                c = q / (2 * math.pi * math.sqrt(sy2 * sz2) * u) * math.exp(-0.5 * y * y / sy2)
            m = p.gain * c
            if zt < p.threshold:
                acc += float(log_ndtr((p.threshold - m) / p.noise_std))
            else:
                r = (zt - m) / p.noise_std
                acc += -0.5 * r * r - math.log(p.noise_std) - 0.5 * math.log(2 * math.pi)
        out.append(acc)
    return out


def loop_update(case: dict) -> np.ndarray:
    """One reading folded in by a per-particle loop: likelihood, reweighting, ESS."""
    ll = loop_log_likelihood(case["theta"], case["z"][-1:], case["pts"][-1:])
    new = [w + v for w, v in zip(case["log_w"].tolist(), ll, strict=True)]
    m = max(new)
    tot = m + math.log(sum(math.exp(v - m) for v in new))
    out = [v - tot for v in new]
    _ess = 1.0 / sum(math.exp(2 * v) for v in out)
    return np.asarray(out)


def vector_update(case: dict) -> np.ndarray:
    """The same by the library: the compiled likelihood and log-space normalisation."""
    m = case["model"]
    ll = m.log_likelihood_sum(
        case["z"][-1:],
        case["pts"][-1:],
        SourceTerms(case["theta"], case["layout"]),
        case["winds"][-1:],
        np.ones(1),
    )
    lw, w = normalise_log_weights(case["log_w"] + ll)
    _ess = 1.0 / float(w @ w)
    return lw


# ---------------------------------------------------------------------- one MH sweep
def _proposal(case: dict, theta: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(case["rng_seed"] + 1)
    chol = np.linalg.cholesky(np.cov(theta.T) + 1e-9 * np.eye(theta.shape[1]))
    prop = theta + 2.38 / math.sqrt(theta.shape[1]) * rng.standard_normal(theta.shape) @ chol.T
    prop[:, 4] = np.pi - np.mod(np.pi - prop[:, 4], 2 * np.pi)
    return prop


def vector_sweep(case: dict, theta: np.ndarray, ll: np.ndarray) -> np.ndarray:
    """Propose, evaluate prior and the whole history, accept: the estimator's sweep."""
    prop = _proposal(case, theta)
    prior = case["prior"]
    lp_new, lp = prior.log_density(prop), prior.log_density(theta)
    ok = np.isfinite(lp_new)
    ll_new = np.full(len(prop), -np.inf)
    ll_new[ok] = case["model"].log_likelihood_sum(
        case["z"],
        case["pts"],
        SourceTerms(prop[ok], case["layout"]),
        case["winds"],
        np.ones(len(case["z"])),
    )
    u = np.log(np.random.default_rng(case["rng_seed"] + 2).random(len(prop)))
    acc = ok & (u < lp_new + ll_new - lp - ll)
    return np.where(acc[:, None], prop, theta)


def loop_sweep(case: dict, theta: np.ndarray, ll: np.ndarray) -> np.ndarray:
    """The same sweep with the likelihood of every proposal computed by the per-particle loop."""
    prop = _proposal(case, theta)
    prior = case["prior"]
    lp_new, lp = prior.log_density(prop), prior.log_density(theta)
    ok = np.isfinite(lp_new)
    ll_new = np.full(len(prop), -np.inf)
    ll_new[ok] = loop_log_likelihood(prop[ok], case["z"], case["pts"])
    u = np.log(np.random.default_rng(case["rng_seed"] + 2).random(len(prop)))
    acc = ok & (u < lp_new + ll_new - lp - ll)
    return np.where(acc[:, None], prop, theta)


# ---------------------------------------------------------------------- entrotaxis
def _belief(case: dict) -> SourceTermBelief:
    return SourceTermBelief.of(case["theta"], case["log_w"], case["layout"])


def _context() -> SearchContext:
    return SearchContext(
        arena=Arena.box([0, 0], [55, 55], 0.5),
        dt=1.0,
        agent_ids=(0,),
        start=np.array([[20.0, 20.0]]),
        speed_limits=np.array([2.0]),
        sensor=SensorInfo(threshold=0.2),
    )


def vector_decision(case: dict, planner: SourceTermEntrotaxis) -> np.ndarray:
    """One entrotaxis decision by the planner."""
    pose = Pose(np.array([20.0, 20.0]), conditions={"wind": WIND, "dt": 1.0})
    return planner.plan(_belief(case), pose, np.random.default_rng(0)).scores


def loop_decision(case: dict, planner: SourceTermEntrotaxis) -> np.ndarray:
    """The same scores with per-candidate, per-particle loops over the outcome classes."""
    terms, _ = _belief(case).thin(planner.params.n_plan)
    p = PARAMS
    width = p.noise_std
    ay, by, az, _, _ = _PG
    targets = np.array([20.0, 20.0]) + planner.step * planner.directions
    means = []
    for tx, ty in targets.tolist():
        row = []
        for x0, y0, lq, sp, ang in terms.theta.tolist():
            u = max(sp, p.min_speed)
            ex, ey = math.cos(ang), math.sin(ang)
            dx, dy = tx - x0, ty - y0
            x = dx * ex + dy * ey
            c = 0.0
            if x > 0:
                y = -dx * ey + dy * ex
                sy2 = p.sigma0**2 + (ay * x) ** 2 / (1 + by * x)
                sz2 = p.sigma0**2 + (az * x) ** 2
                c = math.exp(lq) / (2 * math.pi * math.sqrt(sy2 * sz2) * u)
                c *= math.exp(-0.5 * y * y / sy2)
            row.append(p.gain * c)
        means.append(row)
    top = max(max(r) for r in means) + 4 * p.noise_std
    n_bins = min(max(math.ceil((top - p.threshold) / width), 1), p.max_classes - 1)
    edges = [p.threshold + width * k for k in range(n_bins + 1)]
    scores = []
    for row in means:
        probs = [0.0] * (n_bins + 1)
        for m in row:
            cdf = [float(ndtr((e - m) / p.noise_std)) for e in edges]
            probs[0] += cdf[0] / len(row)
            for k in range(n_bins):
                top_k = 1.0 if k == n_bins - 1 else cdf[k + 1]
                probs[k + 1] += (top_k - cdf[k]) / len(row)
        scores.append(sum(q * math.log(q) for q in probs if q > 0))
    return np.asarray(scores)


CLOCK: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.process_time}


def _time(fn: Callable[[], object], repeat: int, clock: str = "wall") -> float:
    """Best-of-3 mean time per call on ``clock``, milliseconds."""
    now = CLOCK[clock]
    fn()
    best = math.inf
    for _ in range(3 if repeat > 1 else 1):
        t0 = now()
        for _ in range(repeat):
            fn()
        best = min(best, (now() - t0) / repeat)
    return best * 1e3


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20, help="calls per timing of the library")
    ap.add_argument("--quick", action="store_true", help="small sets, one repeat (tests)")
    ap.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="wall time, or this process's CPU time (steadier on a shared machine)",
    )
    args = ap.parse_args(argv)
    clk = args.clock
    n_big, n_sweep, t_hist, n_loop = (20_000, 5_000, 200, 2_000)
    repeat = args.repeat
    if args.quick:
        n_big, n_sweep, t_hist, n_loop, repeat = 2_000, 500, 40, 200, 1

    big = setup(n_big, t_hist)
    sweep_case = setup(n_sweep, t_hist)
    loop_case = setup(n_loop, t_hist)  # the loops on fewer particles, scaled to the same count

    upd_ok = bool(np.allclose(vector_update(loop_case), loop_update(loop_case), atol=1e-8))
    ll0 = sweep_case["model"].log_likelihood_sum(
        sweep_case["z"],
        sweep_case["pts"],
        SourceTerms(sweep_case["theta"], sweep_case["layout"]),
        sweep_case["winds"],
        np.ones(t_hist),
    )
    ll_loop = np.full(n_loop, 0.0)
    ll_loop[:] = ll0[:n_loop]
    small = {**sweep_case, "theta": sweep_case["theta"][:n_loop]}
    sweep_ok = bool(
        np.array_equal(
            vector_sweep(small, small["theta"], ll_loop), loop_sweep(small, small["theta"], ll_loop)
        )
    )
    planner = SourceTermEntrotaxis(SourceTermPlannerParams(directions=16, n_plan=500))
    planner.reset(_context(), big["model"].with_sensor(SensorInfo(threshold=0.2)))
    dec_vec = vector_decision(big, planner)
    dec_ok = bool(np.allclose(dec_vec, loop_decision(big, planner), rtol=1e-9, atol=1e-12))

    t_upd = _time(lambda: vector_update(big), repeat, clk)
    t_upd_loop = _time(lambda: loop_update(loop_case), 1, clk) * n_big / n_loop
    t_sw = _time(
        lambda: vector_sweep(sweep_case, sweep_case["theta"], ll0), max(1, repeat // 4), clk
    )
    ll_big = big["model"].log_likelihood_sum(
        big["z"],
        big["pts"],
        SourceTerms(big["theta"], big["layout"]),
        big["winds"],
        np.ones(t_hist),
    )
    t_sw20 = _time(lambda: vector_sweep(big, big["theta"], ll_big), 1, clk)
    t_sw_loop = _time(lambda: loop_sweep(small, small["theta"], ll_loop), 1, clk) * n_sweep / n_loop
    t_dec = _time(lambda: vector_decision(big, planner), repeat, clk)
    t_dec_loop = _time(lambda: loop_decision(big, planner), 1, clk)

    rows = [
        (f"update, {n_big} particles", t_upd, t_upd_loop, 2.0, upd_ok),
        (f"MCMC sweep, {n_sweep} x {t_hist}", t_sw, t_sw_loop, 30.0, sweep_ok),
        ("entrotaxis, 16 directions", t_dec, t_dec_loop, 20.0, dec_ok),
    ]
    print(
        "Gaussian plume (Pasquill-Gifford B), censored readings, 5 parameters per particle "
        f"({clk} clock)"
    )
    print(
        f"{'operation':<28} {'ours ms':>9} {'loop ms':>10} {'speed-up':>9} {'target ms':>10} "
        f"{'agree':>6}"
    )
    for name, tv, tl, target, ok in rows:
        flag = "" if tv <= target else "  (over target)"
        print(
            f"{name:<28} {tv:9.3f} {tl:10.1f} {tl / tv:8.0f}x {target:10.1f} "
            f"{'yes' if ok else 'NO':>6}{flag}"
        )
    print(f"MCMC sweep, {n_big} x {t_hist}: {t_sw20:.1f} ms (particles x readings grows it)")
    print("loop times on fewer particles, scaled to the count (the loops are linear in it)")
    agree = upd_ok and sweep_ok and dec_ok
    print(
        f"RESULT ste_update_ms={t_upd:.3f} mcmc_sweep_ms={t_sw:.2f} entrotaxis_ms={t_dec:.2f} "
        f"mcmc_sweep_20k_ms={t_sw20:.1f} update_speedup={t_upd_loop / t_upd:.0f} "
        f"mcmc_speedup={t_sw_loop / t_sw:.0f} entrotaxis_speedup={t_dec_loop / t_dec:.0f} "
        f"agree={'yes' if agree else 'no'}"
    )


if __name__ == "__main__":
    main()
