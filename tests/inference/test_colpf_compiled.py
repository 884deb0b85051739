"""The compiled Col-PF iteration against its NumPy reference (multi-UAV paper, eqs. 10-20).

The NumPy code is the oracle: each kernel of
:mod:`odorloc.inference.particles.colpf_kernels` and a whole update from the same state and
the same random numbers agree with it within 1e-9 relative; the compiled path is deterministic
per seed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.inference.particles import colpf_kernels
from odorloc.inference.particles.collaborative import fit_payload
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.history import MeasurementHistory
from odorloc.inference.particles.pugl import (
    PriorSupport,
    gbest_gaussian,
    reversible_col_move,
    reversible_env_move,
)
from odorloc.inference.particles.resampling import SystematicParams, SystematicResampler
from odorloc.inference.particles.team_estimators import ColPFEstimator, ColPFParams, Measurement
from odorloc.inference.weights import gaussian_fit, kl_gaussians, normalise_log_weights
from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams

UPPER = (100.0, 60.0, 30.0)
SRC = np.array([40.0, 35.0, 12.0])
RTOL = 1e-9


def _models() -> tuple[VergassolaModel, VergassolaModel]:
    return tuple(  # type: ignore[return-value]
        VergassolaModel(VergassolaModelParams(sensor_radius=3.5, backend=b))
        for b in ("numpy", "numba")
    )


def _history(rng: np.random.Generator, k: int = 60, capacity: int | None = None):
    """Readings around the source: Poisson counts of the model at random points, each with its
    own exposure, wind direction (some not unit, some the model's: None) and exponent (some 0)."""
    model = _models()[0]
    h = MeasurementHistory(3, capacity)
    for j in range(k):
        s = SRC + rng.normal(0.0, [10.0, 12.0, 4.0]) + np.array([0.0, -8.0, 0.0])
        s = np.clip(s, 0.0, UPPER)
        direction = None if j % 7 == 3 else np.array([0.1, -1.0, 0.0]) * (1.0 + 0.1 * (j % 3))
        dt = 1.0 + 0.5 * (j % 2)
        mu = model.rate(s[None, :], SRC[None, :], None, direction)[0, 0] * dt
        exponent = 0.0 if j % 11 == 5 else (1.0 if j % 3 == 0 else rng.uniform(0.2, 1.0))
        h.append(float(rng.poisson(mu)), s, dt, direction, exponent)
    return h


def _kernel_args(model: VergassolaModel, h: MeasurementHistory) -> tuple:
    aq, adv, inv_lam, a2, default = model.kernel_constants()
    counts, where, dts, dirs, exps = h.held()
    return where, dirs, counts, dts, exps, default, aq, adv, inv_lam, a2


@pytest.mark.parametrize("capacity", [None, 25])
def test_history_kernel_equals_the_numpy_history(capacity: int | None) -> None:
    """eqs. 1, 3, 11, 13 over a history (own exposures, directions, exponents; a full ring)."""
    rng = np.random.default_rng(3)
    h = _history(rng, capacity=capacity)
    numpy_model, numba_model = _models()
    x = np.column_stack([rng.uniform(0, u, 300) for u in UPPER])
    x[:5] = SRC + rng.normal(0.0, 0.5, (5, 3))  # where the counts are likely
    ref = h.log_likelihood(numpy_model, x)
    got = colpf_kernels.readings_log_likelihood(x, *_kernel_args(numba_model, h))
    assert np.all(np.isfinite(ref))
    np.testing.assert_allclose(got, ref, rtol=RTOL, atol=0)


def test_reversible_moves_kernel_equals_the_numpy_moves() -> None:
    """eq. 16's reversible move then eq. 17's independence move, from the same random numbers:
    the same particles accepted, the same positions, the same evaluations."""
    rng = np.random.default_rng(8)
    h = _history(rng)
    numpy_model, numba_model = _models()
    arena = Arena.box((0.0, 0.0, 0.0), UPPER, 2.0)
    support = PriorSupport(arena)
    # near the source and near the walls (proposals outside the support are rejected)
    xs = np.vstack([SRC + rng.normal(0.0, 4.0, (120, 3)), [[1.0, 59.5, 15.0], [50.0, 0.2, 29.9]]])
    xs = np.clip(xs, 0.0, UPPER)
    shift = np.array([2.0, 1.0, 0.0])
    fits = [(SRC + shift, np.diag([9.0, 16.0, 4.0])), (SRC - 3.0, np.eye(3) * 5.0)]
    centre, cov = gbest_gaussian(
        np.array([f[0] for f in fits]), np.array([f[1] for f in fits]), np.array([0.7, 0.4])
    )
    up = np.array([-0.1, 1.0, 0.0])
    up /= np.linalg.norm(up)

    def target(p: np.ndarray) -> np.ndarray:
        return h.log_likelihood(numpy_model, p)

    seed = 21
    ref_rng = np.random.default_rng(seed)
    env = reversible_env_move(xs, target(xs), up, 2.0, ref_rng, target, support)
    col = reversible_col_move(
        env.positions, env.log_likelihood, centre, cov, ref_rng, target, support
    )

    k_rng = np.random.default_rng(seed)
    draws = k_rng.random((len(xs), 3))
    normals = k_rng.standard_normal((len(xs), 3))
    uniforms = k_rng.random(len(xs))
    args = _kernel_args(numba_model, h)
    ll = colpf_kernels.readings_log_likelihood(xs, *args)
    np.testing.assert_allclose(ll, target(xs), rtol=RTOL)
    moved, ll_moved, env_acc, col_acc, evaluated = colpf_kernels.reversible_moves(
        xs,
        ll,
        *args,
        np.array(arena.lo, float),
        np.array(arena.hi, float),
        True,
        up,
        2.0,
        draws,
        True,
        centre,
        np.linalg.cholesky(cov),
        normals,
        uniforms,
    )
    assert 0 < env_acc < len(xs) and 0 < col_acc < len(xs)
    assert env_acc == int(env.accepted.sum()) and col_acc == int(col.accepted.sum())
    assert evaluated == env.evaluated + col.evaluated
    np.testing.assert_allclose(moved, col.positions, rtol=RTOL, atol=0)
    np.testing.assert_allclose(ll_moved, col.log_likelihood, rtol=RTOL, atol=0)


@pytest.mark.parametrize("known", [False, True])
def test_moves_of_a_whole_set_equal_the_moves_of_its_selected_rows(known: bool) -> None:
    """The whole-set kernel (gather, history evaluation, moves, scatter in one pass) gives, bit
    for bit, what the row kernel gives on the selected rows: the other rows and their kept
    log-likelihoods untouched, the input not written."""
    rng = np.random.default_rng(14)
    h = _history(rng)
    numba_model = _models()[1]
    args = _kernel_args(numba_model, h)
    arena = Arena.box((0.0, 0.0, 0.0), UPPER, 2.0)
    lo, hi = np.array(arena.lo, float), np.array(arena.hi, float)
    x = np.clip(SRC + rng.normal(0.0, 6.0, (90, 3)), 0.0, UPPER)
    x_before = x.copy()
    sel = rng.choice(len(x), size=70, replace=False)
    up = np.array([0.0, 1.0, 0.0])
    draws = rng.random((len(sel), 3))
    centre, chol = SRC + 1.0, np.linalg.cholesky(np.diag([9.0, 16.0, 4.0]))
    normals = rng.standard_normal((len(sel), 3))
    uniforms = rng.random(len(sel))
    moves = (lo, hi, True, up, 2.0, draws, True, centre, chol, normals, uniforms)
    ll_all = colpf_kernels.readings_log_likelihood(x, *args)
    ref = colpf_kernels.reversible_moves(np.ascontiguousarray(x[sel]), ll_all[sel], *args, *moves)
    got_x, got_ll, env_acc, col_acc, evaluated = colpf_kernels.reversible_moves_of_set(
        x, sel, ll_all if known else np.zeros(0), known, *args, *moves
    )
    assert (env_acc, col_acc, evaluated) == ref[2:] and env_acc > 0 and col_acc > 0
    assert np.array_equal(got_x[sel], ref[0]) and np.array_equal(got_ll[sel], ref[1])
    rest = np.setdiff1d(np.arange(len(x)), sel)
    assert np.array_equal(got_x[rest], x[rest]) and np.array_equal(got_ll[rest], ll_all[rest])
    assert np.array_equal(x, x_before)


def _context() -> SearchContext:
    return SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), UPPER, 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[[10.0, 10.0, 5.0]],
        speed_limits=[1.0],
    )


def _run_updates(model: VergassolaModel, seed: int, params: ColPFParams) -> list[tuple]:
    """Twelve iterations of one UAV with two neighbours (one cue-captured), from one seed: the
    particles, weights, fit and counters after each."""
    rng = np.random.default_rng(seed)
    est = ColPFEstimator(params)
    est.reset(_context(), model, rng)
    data = np.random.default_rng(100 + seed)  # the readings: the same for both paths
    wind = np.array([0.05, -1.0, 0.0])
    side = np.array([6.0, 2.0, 0.0])
    out = []
    for k in range(1, 13):
        pos = np.array([40.0 + 2 * k, 15.0 + k, 10.0])
        count = float(data.poisson(0.8 if k % 4 == 0 else 0.05))
        mean, cov = est.fit
        inbox = {
            1: fit_payload(mean + 3.0, cov * 1.3, 1.0, pos + side, True, 1.0, wind),
            2: fit_payload(mean - 2.0, cov * 0.7, 0.0, pos - 4.0, False, 1.0, wind),
        }
        est.update(Measurement(count, pos, 1.0, k, wind), inbox, rng)
        w = est.pf.weights
        out.append(
            (
                est.pf.positions.copy(),
                w.copy(),
                est.fit[0].copy(),
                est.fit[1].copy(),
                est.n_moved,
                est.target_n,
                dict(est.moves),
                est.processed,
                est.pf.n_resamples,
                dict(est.betas),
            )
        )
    return out


@pytest.mark.parametrize(
    "settings",
    [
        {"env_pu_from": "start"},
        {"env_pu_from": "first_cue"},
        # never resampled: the history's log-likelihood is carried from one iteration to the next
        {"adaptive_count": False, "resample_threshold": 0.0},
        {"history": 20},
        # col-pu alone: after the first cue nothing moves, and resampling changes the count
        {"env_pu": "off"},
    ],
)
def test_a_whole_update_equals_the_numpy_update(settings: dict) -> None:
    """Twelve whole updates (weights, resampling with jitter, reversible PUGL with both
    proposals, eq. 18, the fit) from the same seed: compiled == NumPy within 1e-9 relative."""
    params = ColPFParams(n_particles=120, n_max=160, **settings)
    numpy_model, numba_model = _models()
    ref = _run_updates(numpy_model, 5, params)
    got = _run_updates(numba_model, 5, params)
    for a, b in zip(ref, got, strict=True):
        assert a[0].shape == b[0].shape
        np.testing.assert_allclose(b[0], a[0], rtol=RTOL, atol=0)
        np.testing.assert_allclose(b[1], a[1], rtol=RTOL, atol=1e-300)
        np.testing.assert_allclose(b[2], a[2], rtol=RTOL, atol=0)
        np.testing.assert_allclose(b[3], a[3], rtol=RTOL, atol=1e-9 * float(np.abs(a[3]).max()))
        assert a[4:9] == b[4:9]
        assert b[9].keys() == a[9].keys()
        for sender, beta in a[9].items():
            assert b[9][sender] == pytest.approx(beta, rel=RTOL)
    # both kinds of move were proposed and judged
    moves = ref[-1][6]
    if params.env_pu == "off":
        assert moves["env"][0] == 0 and moves["col"][0] > 0
        return
    assert moves["env"][0] > 0 and moves["col"][0] > 0 and moves["col"][1] > 0
    if params.adaptive_count:
        # the particle count changed (eq. 18) and the set was resampled more than once
        assert ref[-1][8] > 1 and len({len(r[1]) for r in ref}) > 1
    else:
        assert ref[-1][8] == 0


def test_the_compiled_update_is_deterministic_per_seed() -> None:
    params = ColPFParams(n_particles=100)
    model = _models()[1]
    a, b = _run_updates(model, 9, params), _run_updates(model, 9, params)
    c = _run_updates(model, 10, params)
    for p, q in zip(a, b, strict=True):
        assert np.array_equal(p[0], q[0]) and np.array_equal(p[1], q[1])
    assert not np.array_equal(a[-1][0], c[-1][0])


def test_kernel_constants_only_with_the_compiled_backend() -> None:
    numpy_model, numba_model = _models()
    assert numpy_model.kernel_constants() is None
    aq, adv, inv_lam, a2, default = numba_model.kernel_constants()
    p = numba_model.params
    assert aq == pytest.approx(p.sensor_radius * p.Q) and a2 == pytest.approx(3.5**2)
    assert adv == pytest.approx(p.V / (2 * p.D))
    assert inv_lam == pytest.approx(1 / numba_model.length)
    np.testing.assert_array_equal(default, [0.0, -1.0, 0.0])
    assert math.isclose(float(np.linalg.norm(default)), 1.0)


def test_kl_kernel_equals_the_numpy_divergences() -> None:
    """eq. 10's divergence from one fit to several: near-equal, far apart, elongated fits."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        a = rng.normal(0.0, 3.0, (4, 3, 3))
        covs = np.einsum("hij,hkj->hik", a, a) + 0.1 * np.eye(3)
        means = rng.normal(0.0, 10.0, (4, 3))
        ref = kl_gaussians(means[0], covs[0], means[1:], covs[1:])
        got, ok = colpf_kernels.kl_divergences(means[0], covs[0], means[1:], covs[1:], 1e-9)
        assert ok
        np.testing.assert_allclose(got, ref, rtol=RTOL, atol=1e-12)
    # a covariance that is not positive definite is reported, not used
    bad = -np.eye(3)[None]
    assert not colpf_kernels.kl_divergences(means[0], covs[0], means[1:2], bad, 1e-9)[1]


@pytest.mark.parametrize("target", [37, 160])
def test_resampling_kernel_equals_the_low_variance_resampler(target: int) -> None:
    """Low-variance resampling to a new count, roughened and kept in the arena (walls near)."""
    rng = np.random.default_rng(6)
    arena = Arena.box((0.0, 0.0, 0.0), UPPER, 2.0)
    x = np.clip(SRC + rng.normal(0.0, [30.0, 20.0, 12.0], (120, 3)), 0.0, UPPER)
    lw = rng.normal(0.0, 2.0, 120)
    resampler = SystematicResampler(SystematicParams(jitter_std=1.0))
    ref, _ = resampler.resample(
        x, lw, np.random.default_rng(2), n=target, constraint=ArenaConstraint(arena)
    )
    k_rng = np.random.default_rng(2)
    u0 = k_rng.random()
    noise = k_rng.normal(0.0, 1.0, size=(target, 3))
    w = normalise_log_weights(lw)[1]
    got = colpf_kernels.resample_systematic(
        x, w, target, u0, noise, np.array(arena.lo, float), np.array(arena.hi, float)
    )
    np.testing.assert_allclose(got, ref, rtol=RTOL, atol=0)
    assert (got == 0.0).any() or (got == np.array(UPPER)).any()  # some copies clipped


def test_fit_kernel_equals_the_numpy_fit() -> None:
    rng = np.random.default_rng(12)
    x = rng.normal(20.0, [5.0, 8.0, 2.0], (150, 3))
    w = normalise_log_weights(rng.normal(0.0, 1.5, 150))[1]
    mean, cov = gaussian_fit(x, w)
    got_mean, got_cov = colpf_kernels.weighted_fit(x, w)
    np.testing.assert_allclose(got_mean, mean, rtol=RTOL, atol=0)
    np.testing.assert_allclose(got_cov, cov, rtol=RTOL, atol=1e-12)
