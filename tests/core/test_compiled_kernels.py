"""The compiled kernels (numba) give the NumPy numbers: bit for bit, or within round-off.

The Vergassola likelihood and outcome classes (:mod:`odorloc.models.kernels`) and the lattice
planners' rewards (:mod:`odorloc.planning.kernels`) replace NumPy code; for those the claim is
exact equality (``array_equal``), so that the backend changes no episode of the standard filter
and fixed-step infotaxis (whole metric rows at the end). The kernels of the UAV iteration (a
measurement history's log-likelihood, the expected counts, Adap-PP's Poisson rewards) compute
in one pass with the C library's ``exp`` and ``log``: they are held to 1e-9 relative.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.core.types import SearchContext
from odorloc.engine.episode import run_episode
from odorloc.geometry.arena import Arena
from odorloc.inference.belief import ParticleBelief
from odorloc.models import kernels as model_kernels
from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams
from odorloc.planning import kernels
from odorloc.planning.adaptive import (
    AdaptivePathPlanner,
    AdaptivePlannerParams,
    direction_rewards,
    merge_tail_classes,
    step_rewards,
)
from odorloc.planning.base import Pose
from odorloc.planning.fixed_step import FixedStepInfotaxis, FixedStepParams
from odorloc.scenarios import get_scenario
from odorloc.searchers.uav_team import SENSOR_RADIUS

ARENA = ((0.0, 0.0, 0.0), (100.0, 60.0, 30.0))
SOURCE = np.array([10.0, 30.0, 25.0])


def _models() -> dict[str, VergassolaModel]:
    return {b: VergassolaModel(VergassolaModelParams(backend=b)) for b in ("numpy", "numba")}


def _ctx() -> SearchContext:
    return SearchContext(
        arena=Arena.box(*ARENA, 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[[10.0, 10.0, 5.0]],
        speed_limits=[1.0],
    )


def _cloud(rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    """Particles around the source (some near it, where the means and class counts are large)."""
    x = SOURCE + rng.normal(0.0, spread, (n, 3))
    return np.clip(x, ARENA[0], ARENA[1])


def test_pairwise_sum_is_numpys_sum() -> None:
    rng = np.random.default_rng(0)
    for n in [*range(0, 300), 511, 1000, 2720, 9000, 70_000]:
        a = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)
        assert kernels.pairwise_sum(a, 0, n) == a.sum()
        if n > 5:
            assert kernels.pairwise_sum(a, 3, n - 5) == a[3 : n - 2].sum()


def test_censored_classes_equal_censored_poisson() -> None:
    """Means from 0 to 600, from far below to far above the class count (every tail path:
    the series, 1 - head, the incomplete gamma function)."""
    rng = np.random.default_rng(1)
    for z in (2, 3, 5, 9, 16, 40):
        lam = np.concatenate(
            [
                np.zeros(3),
                10.0 ** rng.uniform(-30, 0, 200),
                rng.uniform(0, 2 * z, 200),
                rng.uniform(0, 600, 50),
            ]
        ).reshape(3, -1)
        out, rest, any_rest = model_kernels.censored_classes(lam, np.exp(-lam), z)
        if any_rest:
            from scipy.special import gammainc

            out[:, -1, :][rest] = np.maximum(gammainc(z - 1, lam[rest]), 0.0)
        ref = np.moveaxis(censored_poisson(lam, z), -1, 1)
        assert np.array_equal(out, ref), z


@pytest.mark.parametrize("trial", range(40))
def test_vergassola_model_compiled_equals_numpy(trial: int) -> None:
    rng = np.random.default_rng(100 + trial)
    fast, ref = _models()["numba"], _models()["numpy"]
    n = int(rng.integers(1, 170))
    m = int(rng.integers(1, 27))
    x = _cloud(rng, n, float(rng.uniform(0.5, 30.0)))
    t = _cloud(rng, m, float(rng.uniform(1.0, 30.0)))
    direction = rng.standard_normal(3)
    cond: dict = {"dt": float(rng.uniform(0.5, 3.0))}
    if trial % 3:
        cond["direction"] = direction / np.linalg.norm(direction)
    if trial % 5 == 0:
        cond["release"] = rng.uniform(1.0, 50.0, n)
    if trial % 7 == 0:
        cond["n_classes"] = int(rng.integers(2, 30))
    assert np.array_equal(
        fast.outcome_probabilities(t, x, **cond), ref.outcome_probabilities(t, x, **cond)
    )
    k = rng.integers(0, 5, m).astype(float)
    assert np.array_equal(
        fast.log_likelihood_rows(k, t, x, **cond), ref.log_likelihood_rows(k, t, x, **cond)
    )
    assert np.array_equal(
        fast.log_likelihood(k[0], t[0], x, **cond), ref.log_likelihood(k[0], t[0], x, **cond)
    )


def test_compiled_model_keeps_the_checks_and_the_large_mean_path() -> None:
    fast, ref = _models()["numba"], _models()["numpy"]
    x = np.array([[10.0, 30.0, 25.0], [50.0, 20.0, 5.0]])
    for model in (fast, ref):
        with pytest.raises(ConfigError, match="counts"):
            model.log_likelihood(1.5, x[0], x, dt=1.0)
        with pytest.raises(ConfigError, match="counts"):
            model.log_likelihood_rows([1.0, -1.0], x, x, dt=1.0)
        with pytest.raises(ConfigError, match="dt"):
            model.log_likelihood(1.0, x[0], x, dt=0.0)
        with pytest.raises(ConfigError, match="sources"):
            model.outcome_probabilities(x, x[:, :2], dt=1.0)
    # a huge release rate puts the means beyond 600: the log-space path of censored_poisson
    big = {"dt": 1.0, "release": 1e6}
    assert np.array_equal(
        fast.outcome_probabilities(x[:1] + 0.5, x, **big),
        ref.outcome_probabilities(x[:1] + 0.5, x, **big),
    )
    # 2-D stays on the NumPy path, with the same results
    x2 = x[:, :2]
    assert np.array_equal(
        fast.log_likelihood(1.0, x2[0] + 1.0, x2, dt=1.0),
        ref.log_likelihood(1.0, x2[0] + 1.0, x2, dt=1.0),
    )


def test_compiled_outcome_classes_refuse_invalid_means() -> None:
    """A NaN position or a negative release rate gives NaN or negative means: both backends
    refuse them as :func:`censored_poisson` does, rather than return NaN or negative classes."""
    x = np.array([[10.0, 30.0, 25.0], [50.0, 20.0, 5.0], [40.0, 40.0, 10.0]])
    t = x[:2] + 0.5
    nan_hyp = x.copy()
    nan_hyp[1, 2] = np.nan
    cases = [
        (t, nan_hyp, {}),
        (np.array([[np.nan, 1.0, 2.0]]), x, {}),
        (t, x, {"release": -5.0}),
        (t, x, {"release": np.array([5.0, -1e-9, 5.0])}),
        (t, x, {"release": np.array([5.0, np.inf, 5.0])}),
        (t, x, {"release": -5.0, "n_classes": 4}),
    ]
    for method in ("outcome_probabilities", "outcome_values"):
        for model in _models().values():
            for sensors, hyp, extra in cases:
                with pytest.raises(ConfigError, match="expected_counts"):
                    getattr(model, method)(sensors, hyp, dt=1.0, **extra)
    # valid extremes stay accepted: a zero release rate, no hypotheses
    for model in _models().values():
        q = model.outcome_probabilities(t, x, dt=1.0, release=0.0)
        assert np.all(q[:, 0, :] == 1.0)
        assert model.outcome_probabilities(t, x[:0], dt=1.0).shape[::2] == (2, 0)


def test_backend_numba_is_refused_without_numba(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(model_kernels, "HAVE_NUMBA", False)
    with pytest.raises(Exception, match="numba cannot be imported"):
        VergassolaModelParams(backend="numba")
    with pytest.raises(Exception, match="numba cannot be imported"):
        AdaptivePlannerParams(backend="numba")
    assert not model_kernels.compiled("auto")
    assert VergassolaModelParams(backend="auto").backend == "auto"


def _belief(rng: np.random.Generator, n: int) -> ParticleBelief:
    x = _cloud(rng, n, float(rng.uniform(0.5, 20.0)))
    lw = rng.normal(0.0, rng.uniform(0.01, 3.0), n)
    top = lw.max()
    lw -= top + np.log(np.exp(lw - top).sum())
    return ParticleBelief(x, lw)


@pytest.mark.parametrize("trial", range(60))
def test_planners_compiled_equal_numpy(trial: int) -> None:
    """Both step planners (and the model under them) give the same choices, equal scores
    (fixed-step infotaxis to the bit; Adap-PP's Poisson kernel within 1e-9 relative) and the
    same computation counts; near walls some directions are blocked."""
    rng = np.random.default_rng(500 + trial)
    models = _models()
    belief = _belief(rng, int(rng.integers(20, 161)))
    pos = np.clip(SOURCE + rng.normal(0.0, 8.0, 3), 0.5, [99.5, 59.5, 29.5])
    if trial % 6 == 0:
        pos = np.array([0.0, 10.0, 30.0])
    hist = np.vstack([pos + rng.normal(0.0, 5.0, (int(rng.integers(0, 300)), 3)), pos])
    direction = rng.standard_normal(3) * [1.0, 1.0, 0.1]
    cond = {"dt": 1.0, "direction": direction / np.linalg.norm(direction)}
    tail = [1e-6, 1e-3, 1e-300][trial % 3]
    for kind in ("adap-pp", "fixed"):
        plans = {}
        for backend in ("numpy", "numba"):
            if kind == "adap-pp":
                lmax = [None, 1, 4, 7][trial % 4]
                planner = AdaptivePathPlanner(
                    AdaptivePlannerParams(backend=backend, tail_mass=tail, l_max=lmax)
                )
            else:
                planner = FixedStepInfotaxis(FixedStepParams(backend=backend, tail_mass=tail))
            planner.reset(_ctx(), models[backend])
            for p in hist:
                planner.record(p)
            plans[backend] = planner.plan(
                belief, Pose(pos, conditions=cond), np.random.default_rng(7)
            )
        a, b = plans["numpy"], plans["numba"]
        if kind == "fixed":
            assert np.array_equal(a.scores, b.scores), kind
        else:
            np.testing.assert_allclose(b.scores, a.scores, rtol=1e-9, atol=0)
            np.testing.assert_array_equal(a.feasible, b.feasible)
        assert (a.index, a.extra["length"], a.work) == (b.index, b.extra["length"], b.work), kind
        assert (a.target is None and b.target is None) or np.array_equal(a.target, b.target)


def test_poisson_direction_kernel_equals_numpy_on_extreme_means() -> None:
    """Adap-PP's fused kernel against :func:`merge_tail_classes` + :func:`direction_rewards` on
    the NumPy classes of the same means: means from 0 to beyond 600, every tail path, class
    counts from 2 to 40, 3-D and 2-D positions, within 1e-9 relative."""
    rng = np.random.default_rng(11)
    for trial in range(40):
        m, n = int(rng.integers(1, 27)), int(rng.integers(1, 170))
        scale = [1e-20, 1e-3, 1.0, 5.0, 50.0, 800.0][trial % 6]
        mu = scale * rng.exponential(1.0, (m, n))
        if trial % 4 == 0:
            mu[:, : n // 3] = 0.0
        z = int(rng.integers(2, 41))
        lw = rng.normal(0.0, 2.0, n)
        lw -= lw.max() + np.log(np.exp(lw - lw.max()).sum())
        w = np.exp(lw)
        x = _cloud(rng, n, 10.0)
        targets = _cloud(rng, m, 10.0)
        if trial % 5 == 4:
            # the kernel's sums for any dimension, not only its 3-D loop
            x, targets = x[:, :2].copy(), targets[:, :2].copy()
        h1 = float(rng.uniform(0.0, 3.0))
        tail = [1e-6, 1e-3, 1e-300][trial % 3]
        q = np.moveaxis(censored_poisson(mu, z), -1, 1)
        qm = merge_tail_classes(w, q, tail)
        ref = direction_rewards(w, x, qm, targets, targets[0], h1)
        # direction_rewards takes W_k from the position; give the kernel the same W_k
        gap = targets[0] - w @ x
        h_now = -float(np.sum(w * lw))
        got, kept = kernels.poisson_direction_rewards(
            mu, w, lw, x, targets, z, tail, h1, float(np.sqrt(gap @ gap)) + h1 * h_now
        )
        assert kept == qm.shape[1], trial
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * abs(ref).max())


def test_poisson_outcomes_are_the_models_classes() -> None:
    """The means and class count a model gives for its Poisson outcomes reproduce its outcome
    probabilities (compiled means within round-off of the NumPy ones)."""
    rng = np.random.default_rng(12)
    fast, ref = _models()["numba"], _models()["numpy"]
    for _ in range(20):
        x = _cloud(rng, int(rng.integers(1, 150)), 15.0)
        t = _cloud(rng, int(rng.integers(1, 27)), 15.0)
        direction = rng.standard_normal(3)
        cond = {
            "dt": float(rng.uniform(0.5, 2.0)),
            "direction": direction / np.linalg.norm(direction),
        }
        mu_f, z_f = fast.poisson_outcomes(t, x, **cond)
        mu_r, z_r = ref.poisson_outcomes(t, x, **cond)
        assert z_f == z_r
        np.testing.assert_allclose(mu_f, mu_r, rtol=1e-12, atol=0)
        q = ref.outcome_probabilities(t, x, **cond)
        np.testing.assert_allclose(np.moveaxis(censored_poisson(mu_r, z_r), -1, 1), q, rtol=1e-12)


@pytest.mark.parametrize("trial", range(20))
def test_weighted_log_likelihood_compiled_equals_numpy(trial: int) -> None:
    """A measurement history (readings with their own exposures, wind directions, some given
    none, and exponents, some 0) at particle clouds: the compiled pass equals the NumPy
    evaluation within 1e-9 relative, and both refuse a NaN hypothesis."""
    rng = np.random.default_rng(900 + trial)
    fast, ref = _models()["numba"], _models()["numpy"]
    k, n = int(rng.integers(1, 400)), int(rng.integers(1, 170))
    x = _cloud(rng, n, float(rng.uniform(0.5, 30.0)))
    s = _cloud(rng, k, 20.0)
    counts = rng.poisson(rng.uniform(0.0, 3.0), k).astype(float)
    e = rng.uniform(0.0, 1.0, k)
    e[rng.random(k) < 0.2] = 0.0
    dirs = rng.standard_normal((k, 3)) * [1.0, 1.0, 0.2]
    dirs[rng.random(k) < 0.3] = np.nan
    dts = rng.uniform(0.5, 3.0, k)
    record = {"dt": dts, "direction": dirs}
    cond = {"release": rng.uniform(1.0, 20.0, n)} if trial % 4 == 0 else {}
    got = fast.weighted_log_likelihood(counts, s, x, e, record, **cond)
    want = ref.weighted_log_likelihood(counts, s, x, e, record, **cond)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)
    bad = x.copy()
    bad[0, 1] = np.nan
    for model in (fast, ref):
        with pytest.raises(ConfigError, match="expected_counts"):
            model.weighted_log_likelihood(counts, s, bad, np.ones(k), record)


def test_step_rewards_kernel_equals_numpy() -> None:
    rng = np.random.default_rng(3)
    steps = 2.0 * np.array([p for p in itertools.product((-1, 0, 1), repeat=3) if any(p)])
    for _ in range(200):
        pos = rng.uniform(0, 30, 3)
        step = steps[rng.integers(len(steps))]
        est = rng.uniform(0, 30, 3)
        hist = np.vstack([pos, pos + rng.integers(-4, 5, (int(rng.integers(0, 80)), 3)) * 1.0])
        lmax = int(rng.integers(1, 8))
        h2 = float(rng.uniform(0, 2))
        got = kernels.step_rewards(pos, step, float(np.linalg.norm(step)), lmax, est, hist, h2)
        assert np.array_equal(got, step_rewards(pos, step, lmax, est, hist, h2))


def test_baseline_episodes_are_the_same_with_and_without_the_kernels() -> None:
    """Col-Inf (the standard filter and fixed-step infotaxis, whose kernels reproduce NumPy to
    the bit) gives the same metric rows with and without the compiled kernels (3 UAVs,
    5 minutes). The Col-PF and Adap-PP kernels agree with NumPy within round-off, not to the
    bit (tested per kernel above), so their episodes may part after enough iterations."""
    sc = get_scenario("muc-osl-3d").with_overrides({"limits": {"control_dt": 1.0, "time": 300.0}})
    rows = {}
    for backend in ("numpy", "numba"):
        searcher = {
            "type": "col-inf",
            "model": {"type": "vergassola", "sensor_radius": SENSOR_RADIUS, "backend": backend},
            "planner": {"type": "fixed-step-infotaxis", "backend": backend},
        }
        res = run_episode(
            sc.with_overrides({"searcher": searcher}), *episode_seeds(5, "muc-osl-3d", 1)
        )
        skip = ("wall_time", "wall_per_step_ms", "world_fraction", "searcher_fraction")
        rows[backend] = {k: v for k, v in res.metrics.items() if k not in skip}
    assert rows["numpy"].keys() == rows["numba"].keys()
    for key, value in rows["numpy"].items():
        other = rows["numba"][key]
        assert value == other or (value != value and other != other), key
