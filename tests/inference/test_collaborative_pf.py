"""Col-PF parts of the multi-UAV paper: confidence factor, weight update, PUGL, adaptive count."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.inference.particles.adaptive_count import (
    CueDistanceCount,
    cue_frequency,
    distance_gap,
    spacing_minimum,
)
from odorloc.inference.particles.collaborative import (
    ParticleSetMessage,
    collaborative_log_likelihood,
    confidence_factor,
    confidence_factors,
    fit_payload,
    read_fit_payload,
)
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.pugl import (
    col_position_update,
    env_position_update,
    gbest,
    moved_count,
)
from odorloc.inference.particles.team_estimators import (
    ColPFEstimator,
    ColPFParams,
    Measurement,
    StandardPFEstimator,
    StandardPFParams,
)
from odorloc.inference.weights import kl_gaussian, kl_gaussians
from odorloc.models.base import MeasurementModel
from odorloc.models.vergassola import VergassolaModel


def _spd(rng: np.random.Generator, d: int = 3) -> np.ndarray:
    a = rng.normal(size=(d, d))
    return a @ a.T + d * np.eye(d)


# ----------------------------------------------------------------------------- KL and beta
def test_kl_gaussian_matches_closed_form_and_monte_carlo() -> None:
    rng = np.random.default_rng(0)
    m0, m1 = rng.normal(size=3), rng.normal(size=3)
    s0, s1 = _spd(rng), _spd(rng)
    # the closed form written out once more, with explicit inverses
    inv1 = np.linalg.inv(s1)
    dm = m1 - m0
    ref = 0.5 * (
        np.trace(inv1 @ s0) + dm @ inv1 @ dm - 3 + math.log(np.linalg.det(s1) / np.linalg.det(s0))
    )
    assert kl_gaussian(m0, s0, m1, s1) == pytest.approx(ref, rel=1e-9)
    # E_p[log p - log q] by sampling (100 000 draws: standard error 3e-3)
    x = rng.multivariate_normal(m0, s0, size=100_000)
    mc = np.mean(multivariate_normal(m0, s0).logpdf(x) - multivariate_normal(m1, s1).logpdf(x))
    assert kl_gaussian(m0, s0, m1, s1) == pytest.approx(mc, abs=0.02)
    # 1-D: KL = log(s1/s0) + (s0^2 + dm^2) / (2 s1^2) - 1/2
    k1 = kl_gaussian([0.0], [[4.0]], [1.0], [[9.0]])
    assert k1 == pytest.approx(math.log(3 / 2) + (4 + 1) / 18 - 0.5, rel=1e-9)


def test_confidence_factor_is_in_zero_one_and_one_for_identical_fits() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        m0, m1 = rng.normal(scale=10, size=3), rng.normal(scale=10, size=3)
        s0, s1 = _spd(rng), _spd(rng)
        b = confidence_factor(m0, s0, m1, s1)
        assert 0.0 < b <= 1.0 or (b == 0.0 and kl_gaussian(m0, s0, m1, s1) > 700)
        assert b == pytest.approx(math.exp(-kl_gaussian(m0, s0, m1, s1)))
        assert confidence_factor(m0, s0, m0, s0) == pytest.approx(1.0, abs=1e-12)
    # farther apart -> less trusted
    s = np.eye(3)
    near = confidence_factor(np.zeros(3), s, np.full(3, 0.5), s)
    far = confidence_factor(np.zeros(3), s, np.full(3, 2.0), s)
    assert 1.0 > near > far > 0.0


# ----------------------------------------------------------------------------- weight update
class TableModel(MeasurementModel):
    """Likelihoods read from a table: row = the sensor's x coordinate (0, 1 or 2)."""

    def __init__(self, table: np.ndarray) -> None:
        self.table = np.asarray(table, float)

    def log_likelihood(self, z, sensor_position, hypotheses, **conditions):
        return np.log(self.table[round(float(np.ravel(sensor_position)[0]))])

    def outcome_probabilities(self, sensor_positions, hypotheses, **conditions):
        raise NotImplementedError


def test_batched_kl_and_confidence_equal_the_pairwise_ones() -> None:
    rng = np.random.default_rng(8)
    for h in (1, 2, 3, 5):
        a = rng.standard_normal((h + 1, 3, 3)) * rng.uniform(0.1, 20.0, (h + 1, 1, 1))
        covs = a @ np.swapaxes(a, 1, 2) + 0.01 * np.eye(3)
        means = rng.uniform(0, 100, (h + 1, 3))
        kl = kl_gaussians(means[0], covs[0], means[1:], covs[1:])
        assert kl == [kl_gaussian(means[0], covs[0], means[j], covs[j]) for j in range(1, h + 1)]
        betas = confidence_factors(means[0], covs[0], means[1:], covs[1:])
        ref = [confidence_factor(means[0], covs[0], means[j], covs[j]) for j in range(1, h + 1)]
        assert betas.tolist() == ref
    assert confidence_factors(means[0], covs[0], np.zeros((0, 3)), np.zeros((0, 3, 3))).size == 0
    with pytest.raises(ConfigError, match="positive definite"):
        kl_gaussians(means[0], covs[0], means[1:2], -covs[1:2])


def test_collaborative_weight_update_hand_worked_with_two_neighbours() -> None:
    # three particles, prior weights (0.5, 0.3, 0.2); own likelihood p_i and two neighbours'
    prior = np.array([0.5, 0.3, 0.2])
    own = np.array([0.10, 0.40, 0.20])
    n1 = np.array([0.50, 0.25, 0.50])
    n2 = np.array([0.80, 0.10, 0.40])
    b1, b2 = 0.5, 1.0
    # eq. 13 by hand: w~ = w p_i p_1^b1 p_2^b2
    wt = np.array(
        [
            0.5 * 0.10 * math.sqrt(0.50) * 0.80,
            0.3 * 0.40 * math.sqrt(0.25) * 0.10,
            0.2 * 0.20 * math.sqrt(0.50) * 0.40,
        ]
    )
    expected = wt / wt.sum()  # eq. 14
    ll = collaborative_log_likelihood(np.log(own), np.log([n1, n2]), [b1, b2])
    got = prior * np.exp(ll)
    np.testing.assert_allclose(got / got.sum(), expected, rtol=1e-12)

    # the same through the estimator: neighbour fits chosen so that beta = 0.5 and 1
    ctx = SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), (10.0, 10.0, 10.0), 0.5),
        dt=1.0,
        agent_ids=(0,),
        start=[[0.0, 5.0, 5.0]],
        speed_limits=[1.0],
    )
    est = ColPFEstimator(
        ColPFParams(
            env_pu="off", col_pu=False, adaptive_count=False, resample_threshold=0.0, k_max=1
        )
    )
    est.reset(ctx, TableModel([own, n1, n2]), np.random.default_rng(0), n=3)
    pts = np.array([[1.0, 1.0, 1.0], [5.0, 5.0, 5.0], [8.0, 2.0, 6.0]])
    est.pf.replace(pts, np.log(prior))
    est.fit = est.pf.gaussian()
    mean, cov = est.fit
    # KL(N(m, S) || N(m + dm, S)) = dm' S^-1 dm / 2 = ln 2 for beta = 1/2
    v = np.linalg.solve(cov, np.ones(3))
    dm = np.ones(3) * math.sqrt(2 * math.log(2) / float(np.ones(3) @ v))
    inbox = {
        1: fit_payload(mean + dm, cov, 1.0, [1.0, 0.0, 0.0], True),
        2: fit_payload(mean, cov, 0.0, [2.0, 0.0, 0.0], False),
    }
    est.update(Measurement(1.0, np.array([0.0, 0.0, 0.0]), 1.0, 1), inbox, np.random.default_rng(1))
    assert est.betas[1] == pytest.approx(0.5, rel=1e-6)
    assert est.betas[2] == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_allclose(est.pf.weights, expected, rtol=1e-6)


def test_collaborative_log_likelihood_rejects_bad_betas() -> None:
    with pytest.raises(ConfigError, match="betas"):
        collaborative_log_likelihood(np.zeros(3), np.zeros((2, 3)), [0.5])
    with pytest.raises(ConfigError, match="betas"):
        collaborative_log_likelihood(np.zeros(3), np.zeros((1, 3)), [1.5])
    # an untrusted neighbour contributes nothing, even with an impossible reading
    out = collaborative_log_likelihood(np.zeros(2), np.array([[-np.inf, 0.0]]), [0.0])
    assert out.tolist() == [0.0, 0.0]


def test_fit_payload_round_trip_and_size() -> None:
    p = fit_payload(np.arange(3.0), np.eye(3) * 2, 4.0, [1.0, 2.0, 3.0], True)
    assert p.numbers == 17  # 12 for the fit + count, position, cue
    assert p.nbytes == 17 * 8
    with pytest.raises(ValueError, match="read-only"):
        p.mean[0] = 9.0  # what was sent cannot change
    f = read_fit_payload(5, p)
    assert f.sender == 5 and f.count == 4.0 and f.cue_captured
    np.testing.assert_array_equal(f.mean, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(f.cov, np.eye(3) * 2)
    with pytest.raises(ConfigError, match="message"):
        read_fit_payload(1, ParticleSetMessage(np.zeros((3, 3)), np.ones(3) / 3))


# ----------------------------------------------------------------------------- PUGL
def test_moved_count_eq15() -> None:
    assert moved_count(100, 0, 800) == 100
    # (1 - 0.5^1.8)^4 = 0.2584...
    frac = (1 - 0.5**1.8) ** 4
    assert moved_count(100, 400, 800) == round(100 * frac) == 26
    assert moved_count(160, 400, 800) == round(160 * frac)
    assert moved_count(100, 800, 800) == 0
    assert moved_count(100, 900, 800) == 0
    counts = [moved_count(100, k, 800) for k in range(0, 801, 20)]
    assert counts == sorted(counts, reverse=True)
    with pytest.raises(ConfigError):
        moved_count(100, -1, 800)


def test_env_pu_invariant_reading_is_translation_invariant_and_upwind() -> None:
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 50, (40, 3))
    sel = np.arange(0, 40, 2)
    up = np.array([0.0, 1.0, 0.0])
    a = env_position_update(x, sel, up, np.random.default_rng(5), step=2.0)
    b = env_position_update(x + 1000.0, sel, up, np.random.default_rng(5), step=2.0)
    np.testing.assert_allclose(b - 1000.0, a, atol=1e-9)
    d = a - x
    assert np.all(d[sel, 1] >= 0) and np.all(d[sel, 1] <= 2.0)
    assert np.all(d[sel][:, [0, 2]] == 0)  # straight upwind; z unchanged
    assert np.all(d[1::2] == 0)  # unselected particles stay


def test_env_pu_literal_reading_scales_with_the_coordinate() -> None:
    x = np.array([[10.0, 20.0, 5.0], [10.0, 40.0, 5.0]])
    up = np.array([0.0, 1.0, 0.0])  # theta = 90 deg: x += 0, y += rand y
    a = env_position_update(x, [0, 1], up, np.random.default_rng(3), reading="literal")
    r = np.random.default_rng(3).random(2)
    np.testing.assert_allclose(a[:, 1], x[:, 1] * (1 + r))
    np.testing.assert_allclose(a[:, [0, 2]], x[:, [0, 2]])
    box = ArenaConstraint(Arena.box((0, 0, 0), (60, 60, 30), 1.0))
    c = env_position_update(
        x, [0, 1], up, np.random.default_rng(3), reading="literal", constraint=box
    )
    assert np.all(c[:, 1] <= 60.0)


def test_col_pu_moves_towards_gbest() -> None:
    x = np.zeros((5, 3))
    g = gbest(np.array([[10.0, 0.0, 0.0], [0.0, 10.0, 0.0]]), np.array([1.0, 3.0]))
    np.testing.assert_allclose(g, [2.5, 7.5, 0.0])  # normalised beta-weighted mean
    assert gbest(np.zeros((0, 3)), np.zeros(0)) is None
    out = col_position_update(x, [0, 1, 2], g, np.random.default_rng(0))
    r = np.random.default_rng(0).random(3)
    np.testing.assert_allclose(out[:3], r[:, None] * g[None, :])
    assert np.all(out[3:] == 0)


# ----------------------------------------------------------------------------- count
def test_cue_frequency_and_distance_gap() -> None:
    assert cue_frequency([], 10) == 0.0
    assert cue_frequency([2, 5], 10, delta_c=3) == pytest.approx(2 / 10)
    # cues at 2, 5, 7, 9, 10: the 2nd-to-last 3 since cue 2 (iteration 5): 3 / (10 - 5)
    assert cue_frequency([2, 5, 7, 9, 10], 10, delta_c=3) == pytest.approx(3 / 5)
    assert cue_frequency([1, 2, 3, 4], 4, delta_c=3) == 1.0
    assert distance_gap(0.0) == 0.0
    assert distance_gap(1.0) == pytest.approx(math.exp(-1))
    assert spacing_minimum(100 * 60 * 30, 1.0, 100.0) == 23  # 180 000 / 20^3 = 22.5


def test_particle_count_stays_within_bounds() -> None:
    rng = np.random.default_rng(4)
    for reading in ("proportional", "literal"):
        c = CueDistanceCount(100, 20, 160, delta_c=3, reading=reading)
        n = c.start(30.0)
        assert n == 100
        cues: list[int] = []
        seen = []
        for k in range(1, 400):
            if rng.random() < 0.3:
                cues.append(k)
            n = c.next(n, cues, k, float(rng.uniform(0, 80)))
            assert 20 <= n <= 160
            seen.append(n)
        if reading == "literal":
            assert seen[-1] == 20  # the printed recursion can only shrink
    # the proportional reading grows back when the UAV is far and without cues
    c = CueDistanceCount(100, 20, 160)
    c.start(2.0)
    assert c.next(100, [], 5, 50.0) > 100


def _uav_context() -> SearchContext:
    """One UAV in the paper's 100 x 60 x 30 m area, starting at (10, 10, 5)."""
    return SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), (100.0, 60.0, 30.0), 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[[10.0, 10.0, 5.0]],
        speed_limits=[1.0],
    )


def test_colpf_estimator_keeps_count_in_bounds_and_moves_particles() -> None:
    ctx = _uav_context()
    rng = np.random.default_rng(7)
    est = ColPFEstimator()
    est.reset(ctx, VergassolaModel(), rng)
    assert est.pf.n == 100
    down = np.array([0.0, -1.0, 0.0])
    for k in range(1, 60):
        pos = np.array([10.0, 10.0 + k * 0.3, 20.0])
        count = float(rng.poisson(0.3))
        est.update(Measurement(count, pos, 1.0, k, down), {}, rng)
        assert 20 <= est.pf.n <= 160
        assert np.all(ctx.arena.is_free(est.pf.positions))
    msg = est.message()
    assert msg.mean.size + msg.cov.size == 12


@pytest.mark.parametrize("k", [1, 200, 400])
def test_colpf_update_moves_n_s_particles_upwind(k: int) -> None:
    """Inside one update, PUGL moves exactly N_s of eq. 15 particles, each straight upwind by at
    most ``env_step`` (eq. 16, invariant reading); the others keep their positions. Without
    resampling or a count change the particles before and after the update can be matched
    one to one."""
    ctx = _uav_context()
    rng = np.random.default_rng(11)
    est = ColPFEstimator(
        ColPFParams(resample_threshold=0.0, adaptive_count=False, env_step=2.0, n_max=160)
    )
    est.reset(ctx, VergassolaModel(), rng)
    # particles away from the walls, so that no move is cut short by the arena
    x0 = np.column_stack(
        [rng.uniform(20, 80, 100), rng.uniform(10, 40, 100), rng.uniform(5, 25, 100)]
    )
    est.pf.replace(x0, np.full(100, -math.log(100)))
    down = np.array([0.0, -1.0, 0.0])  # the wind blows towards -y: upwind is +y
    est.update(Measurement(0.0, np.array([50.0, 5.0, 10.0]), 1.0, k, down), {}, rng)
    d = est.pf.positions - x0
    moved = np.flatnonzero(np.any(d != 0.0, axis=1))
    n_s = round(100 * (1 - (k / 800) ** 1.8) ** 4)  # eq. 15 by hand
    assert len(moved) == n_s == est.n_moved
    assert np.all(d[moved, 0] == 0.0) and np.all(d[moved, 2] == 0.0)
    assert np.all((d[moved, 1] > 0.0) & (d[moved, 1] <= 2.0))
    # the steps are rand * env_step: spread over the whole interval, not one fixed length
    assert d[moved, 1].std() > 0.3


def test_standard_pf_pools_neighbour_particles() -> None:
    ctx = SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), (10.0, 10.0, 10.0), 0.5),
        dt=1.0,
        agent_ids=(0,),
        start=[[0.0, 5.0, 5.0]],
        speed_limits=[1.0],
    )
    est = StandardPFEstimator(StandardPFParams(n_particles=50))
    flat = TableModel(np.ones((3, 100)))
    est.reset(ctx, flat, np.random.default_rng(0))
    theirs = ParticleSetMessage(np.full((50, 3), 7.0), np.full(50, 1 / 50))
    est.update(Measurement(0.0, np.zeros(3), 1.0, 1), {1: theirs}, np.random.default_rng(1))
    assert est.pf.n == 50
    # half of the pooled mass sat on the neighbour's point: about half the resampled particles
    near = np.linalg.norm(est.pf.positions - 7.0, axis=1) < 4.0
    assert 0.3 < near.mean() < 0.8
    msg = est.message()
    assert msg.positions.shape == (50, 3) and msg.weights.shape == (50,)
    assert msg.numbers == 4 * 50  # the paper's 4N
    assert msg.nbytes == 8 * 4 * 50
