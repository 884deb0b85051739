"""Particle-filter core: log-space updates, estimates, convergence test, initialisation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.inference.belief import ParticleBelief, histogram_entropy
from odorloc.inference.particles import (
    ArenaConstraint,
    ConvergenceParams,
    ParticleFilter,
    backtrack_initialise,
    sample_free_uniform,
)
from odorloc.inference.particles.resampling import SystematicParams, SystematicResampler


def test_update_is_bayes_in_log_space() -> None:
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]])
    pf = ParticleFilter(pos)
    pf.update(np.log([0.2, 0.6, 0.2]))
    pf.update(np.log([0.5, 0.5, 1.0]))
    # Posterior ∝ (0.1, 0.3, 0.2) -> (1/6, 1/2, 1/3).
    np.testing.assert_allclose(np.exp(pf.log_weights), [1 / 6, 1 / 2, 1 / 3])
    np.testing.assert_allclose(pf.estimate(), [0.5, 2 / 3])
    assert pf.ess == pytest.approx(1 / (1 / 36 + 1 / 4 + 1 / 9))
    assert len(pf.history) == 2
    b = pf.belief()
    np.testing.assert_allclose(b.mean, pf.estimate())


def test_total_underflow_resets_to_uniform() -> None:
    pf = ParticleFilter(np.zeros((4, 2)))
    pf.update(np.full(4, -np.inf))
    np.testing.assert_allclose(np.exp(pf.log_weights), 0.25)
    assert np.all(np.isfinite(pf.estimate()))


def test_update_rejects_bad_input() -> None:
    pf = ParticleFilter(np.zeros((4, 2)))
    with pytest.raises(ConfigError, match="log_likelihood"):
        pf.update(np.zeros(3))
    with pytest.raises(ConfigError, match="log_likelihood"):
        pf.update(np.array([0.0, np.nan, 0.0, 0.0]))
    with pytest.raises(ConfigError, match="positions"):
        ParticleFilter(np.zeros((0, 2)))
    with pytest.raises(ConfigError, match="resample_threshold"):
        ParticleFilter(np.zeros((3, 2)), resample_threshold=2.0)


def test_history_keeps_last_k() -> None:
    pf = ParticleFilter(np.zeros((3, 2)), history=5)
    for _ in range(12):
        pf.update(np.zeros(3))
    assert pf.history.shape == (5, 2)


def test_spread_measures() -> None:
    a = 0.6
    pf = ParticleFilter(np.array([[-a, 0.0], [a, 0.0], [0.0, -0.2], [0.0, 0.2]]))
    # Per-axis variances: x = a^2 / 2, y = 0.02; trace = 0.18 + 0.02 (eq. 15).
    assert pf.spread("trace") == pytest.approx(a * a / 2 + 0.02)
    assert pf.spread("radius") == pytest.approx(math.sqrt(a * a / 2 + 0.02))
    assert pf.spread("max_axis") == pytest.approx(a * a / 2)


def _stable_filter(spread: float, arena: Arena | None = None, centre=(1.0, 1.0)) -> ParticleFilter:
    rng = np.random.default_rng(0)
    pos = np.asarray(centre) + rng.normal(0, spread, (500, 2))
    pf = ParticleFilter(pos, constraint=ArenaConstraint(arena) if arena is not None else None)
    for _ in range(20):
        pf.update(np.zeros(len(pos)))
    return pf


def test_convergence_cases() -> None:
    c = ConvergenceParams()
    # Tight cloud (trace ~ 2 * 0.1^2 = 0.02 <= 0.5), 20 identical estimates -> converged.
    ok = _stable_filter(0.1).convergence(c)
    assert ok.converged and ok.max_history_deviation < 1e-12
    # Wide cloud: trace ~ 2 * 0.8^2 = 1.28 > 0.5.
    wide = _stable_filter(0.8).convergence(c)
    assert not wide.particles_converged and not wide.converged
    # Between: trace ~ 2 * 0.4^2 = 0.32 passes "trace" (m^2 read as a number) but its RMS radius
    # sqrt(0.32) = 0.57 m fails "radius".
    mid = _stable_filter(0.4)
    assert mid.convergence(c).particles_converged
    assert not mid.convergence(c.model_copy(update={"variance": "radius"})).particles_converged
    # History not yet full.
    pf = ParticleFilter(np.full((10, 2), 1.0))
    for _ in range(19):
        pf.update(np.zeros(10))
    st = pf.convergence(c)
    assert st.particles_converged and not st.history_full and not st.converged
    # 19 estimates at (0.6, 0) then one at (0, 0): the last is 0.57 m from the history mean
    # (0.57, 0), beyond R_err = 0.5 m (eq. 16).
    pos = np.array([[0.0, 0.0], [1.2, 0.0]])
    pf = ParticleFilter(pos)
    for _ in range(19):
        pf.update(np.zeros(2))
    pf.update(np.array([0.0, -70.0]))
    st = pf.convergence(c.model_copy(update={"r_conv": 10.0}))
    assert st.history_full and not st.estimates_converged


def test_estimate_inside_obstacle_blocks_convergence() -> None:
    arena = Arena.box((0, 0), (3, 3), 0.1).with_boxes([((0.8, 0.8), (1.2, 1.2))])
    st = _stable_filter(0.1, arena).convergence()
    assert st.particles_converged and st.estimates_converged and not st.estimate_free
    assert not st.converged
    assert _stable_filter(0.1, arena, centre=(2.0, 2.0)).convergence().converged


def test_resample_only_when_degenerate() -> None:
    rng = np.random.default_rng(0)
    pos = rng.uniform(0, 1, (100, 2))
    pf = ParticleFilter(pos, resampler=SystematicResampler())
    pf.update(np.where(np.arange(100) < 60, 0.0, -1.0))  # ESS well above 50
    assert not pf.resample_if_needed(rng)
    pf.update(np.where(np.arange(100) < 10, 0.0, -20.0))  # ESS ~ 10 < 50
    assert pf.needs_resampling() and pf.resample_if_needed(rng)
    assert pf.n_resamples == 1 and pf.ess == pytest.approx(100.0)


def test_pf_converges_on_a_static_source_with_a_synthetic_sensor() -> None:
    # Bernoulli sensor: p(detect) = 0.9 exp(-r^2 / 0.5) + 0.02 at 30 random positions;
    # a Bayesian check that update + (roughened systematic) resampling localises the source.
    rng = np.random.default_rng(7)
    arena = Arena.box((0, 0), (4, 4), 0.1)
    src = np.array([2.5, 1.5])
    pf = ParticleFilter(
        sample_free_uniform(arena, 1000, rng),
        resampler=SystematicResampler(SystematicParams(jitter_std=0.05)),
        constraint=ArenaConstraint(arena),
    )

    def p_detect(sensor: np.ndarray, hyp: np.ndarray) -> np.ndarray:
        return 0.9 * np.exp(-np.sum((hyp - sensor) ** 2, axis=-1) / 0.5) + 0.02

    for _ in range(150):
        s = rng.uniform(0, 4, 2)
        z = rng.random() < p_detect(s, src[None])[0]
        p = p_detect(s, pf.positions)
        pf.update(np.log(p if z else 1.0 - p))
        pf.resample_if_needed(rng)
    assert np.linalg.norm(pf.estimate() - src) < 0.4
    assert pf.spread() < 0.3


def test_backtracking_puts_particles_upwind() -> None:
    arena = Arena.box((-5, -5), (10, 5), 0.1)
    wind = np.tile([0.5, 0.0], (20, 1))  # blowing towards +x
    det = np.array([5.0, 0.0])
    pos = backtrack_initialise(det, wind, 0.5, 2000, np.random.default_rng(0), arena=arena)
    assert pos.shape == (2000, 2) and arena.is_free(pos).all()
    # Records are 0.5..10 s old: advection 0.25..5 m upwind, mean 2.625 m.
    assert np.mean(pos[:, 0] < det[0]) > 0.95
    assert pos[:, 0].mean() == pytest.approx(det[0] - 2.625, abs=0.1)
    assert abs(pos[:, 1].mean()) < 0.1
    # Spread grows with the elapsed time: far particles are more spread crosswind.
    far = pos[:, 0] < det[0] - 3.5
    near = pos[:, 0] > det[0] - 1.0
    assert pos[far, 1].std() > 1.5 * pos[near, 1].std()
    again = backtrack_initialise(det, wind, 0.5, 2000, np.random.default_rng(0), arena=arena)
    np.testing.assert_array_equal(pos, again)


def test_backtracking_respects_walls_and_obstacles() -> None:
    arena = Arena.box((0, 0), (4, 2), 0.1).with_boxes([((1.0, 0.0), (1.5, 1.0))])
    wind = np.tile([1.0, 0.0], (20, 1))  # back-track runs 0.5..10 m: mostly out of the room
    pos = backtrack_initialise(
        np.array([3.5, 0.5]),
        wind,
        0.5,
        500,
        np.random.default_rng(1),
        arena=arena,
        uniform_fraction=0.1,
    )
    assert pos.shape == (500, 2) and arena.is_free(pos).all()


def test_sample_free_uniform_avoids_obstacles() -> None:
    arena = Arena.box((0, 0), (2, 2), 0.1).with_boxes([((0.0, 0.0), (1.0, 2.0))])
    pts = sample_free_uniform(arena, 400, np.random.default_rng(0))
    assert arena.is_free(pts).all() and pts[:, 0].min() >= 1.0
    full = Arena.box((0, 0), (1, 1), 0.5).with_boxes([((0.0, 0.0), (1.0, 1.0))])
    with pytest.raises(ConfigError, match="arena"):
        sample_free_uniform(full, 10, np.random.default_rng(0))


def test_log_weight_normalisation_keeps_precision_for_huge_log_likelihoods() -> None:
    """Subtracting the maximum first: at L = -1e17 the weights still sum to one and a
    systematic resample still returns every equally weighted particle."""
    pos = np.arange(8, dtype=float)[:, None] * np.ones((1, 2))
    pf = ParticleFilter(pos, resampler=SystematicResampler())
    pf.update(np.full(8, -1e17))
    assert pf.weights.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(pf.weights, np.full(8, 1 / 8))
    pf.resample(np.random.default_rng(0))
    assert sorted(set(pf.positions[:, 0].tolist())) == list(range(8))


def test_resample_to_a_new_target_count() -> None:
    rng = np.random.default_rng(1)
    pf = ParticleFilter(rng.uniform(0, 1, (100, 2)), resampler=SystematicResampler())
    assert pf.resample_if_needed(rng, n=40)
    assert pf.n == 40
    assert not pf.resample_if_needed(rng, n=40)  # not degenerate, same count: nothing to do


def test_dual_convergence_is_a_stopping_rule() -> None:
    from odorloc.inference.particles import DualConvergence

    rule = DualConvergence(ConvergenceParams())
    assert _stable_filter(0.1).converged(rule)
    assert not _stable_filter(0.8).converged(rule)


def test_new_particle_sets_refuse_nan_and_infinite_log_weights() -> None:
    """A NaN log-weight used to be read as -inf and a +inf one as uniform weights, silently;
    a NaN position given to ``replace`` used to make every estimate NaN."""
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    for bad in ([np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0], [0.0, -np.inf, np.nan], [0, 1, np.inf]):
        with pytest.raises(ConfigError, match="log_weights"):
            ParticleFilter(pos, log_weights=bad)
    for i, bad in enumerate((np.nan, np.inf, -np.inf)):
        broken = pos.copy()
        broken[2 - i, i % 2] = bad
        with pytest.raises(ConfigError, match="positions"):
            ParticleFilter(broken)
    pf = ParticleFilter(pos, log_weights=[0.0, -np.inf, 0.0])  # an excluded hypothesis is fine
    np.testing.assert_allclose(pf.weights, [0.5, 0.0, 0.5])
    with pytest.raises(ConfigError, match="log_weights"):
        pf.replace(pos, [np.inf, 0.0, 0.0])
    with pytest.raises(ConfigError, match="positions"):
        pf.replace(np.array([[np.nan, 0.0], [1.0, 0.0], [2.0, 0.0]]))
    with pytest.raises(ConfigError, match="positions"):
        pf.replace(np.zeros((3, 3)))
    np.testing.assert_allclose(pf.estimate(), [1.0, 0.0])  # the set was left as it was


def test_backtracking_refuses_malformed_input() -> None:
    arena = Arena.box((0, 0), (4, 4), 0.1)
    wind = np.tile([0.5, 0.0], (10, 1))
    rng = np.random.default_rng(0)
    det = np.array([3.0, 2.0])
    cases = [
        ("detection_pos", dict(detection_pos=np.array([np.nan, 2.0]))),
        ("detection_pos", dict(detection_pos=np.array([3.0, 2.0, 1.0]))),
        ("wind_window", dict(wind_window=np.zeros((0, 2)))),
        ("wind_window", dict(wind_window=np.tile([0.5, 0.0, 0.0], (10, 1)))),
        ("wind_window", dict(wind_window=np.full((10, 2), np.nan))),
        ("dt", dict(dt=float("nan"))),
        ("dt", dict(dt=0.0)),
        ("wind_var", dict(wind_var=np.array([np.nan, 0.1]))),
    ]
    for field, bad in cases:
        kw = dict(detection_pos=det, wind_window=wind, dt=0.5) | bad
        # with an arena a NaN draw used to be replaced by a uniform one without a word
        with pytest.raises(ConfigError, match=field):
            backtrack_initialise(
                kw["detection_pos"],
                kw["wind_window"],
                kw["dt"],
                50,
                rng,
                arena=arena,
                wind_var=kw.get("wind_var"),
            )


def test_convergence_refuses_a_filter_that_keeps_too_few_estimates() -> None:
    """A filter keeping 10 estimates could never fill the test's history of 20: it used to
    report 'not converged' for ever instead of saying so."""
    pf = ParticleFilter(np.zeros((5, 2)), history=10)
    for _ in range(30):
        pf.update(np.zeros(5))
    assert pf.history_capacity == 10
    with pytest.raises(ConfigError, match="history"):
        pf.convergence(ConvergenceParams())
    assert pf.convergence(ConvergenceParams(history=10)).converged


def test_histogram_entropy_needs_weight_inside_the_extent() -> None:
    """Particles all outside the binned extent used to give entropy 0, a certain belief."""
    four = np.array([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [1.5, 1.5]])
    b = ParticleBelief(four, np.full(4, -math.log(4)))
    assert histogram_entropy(b, (0, 0), (2, 2), 1.0) == pytest.approx(math.log(4))
    far = ParticleBelief(four + 10.0, b.log_weights)
    with pytest.raises(ConfigError, match="upper"):
        histogram_entropy(far, (0, 0), (2, 2), 1.0)
    with pytest.raises(ConfigError, match="cell"):
        histogram_entropy(b, (0, 0), (2, 2), 0.0)


def test_a_plus_infinite_log_weight_is_an_error_not_uniform_weights() -> None:
    from odorloc.inference.weights import normalise_log_weights

    with pytest.raises(ConfigError, match=r"\+inf"):
        normalise_log_weights([math.inf, 0.0, -1.0])
    # NaN still counts as -inf, and all -inf still reads as uniform
    _, w = normalise_log_weights([math.nan, 0.0])
    assert w.tolist() == [0.0, 1.0]
    _, w = normalise_log_weights([-math.inf, -math.inf])
    assert w.tolist() == [0.5, 0.5]


def test_checked_normalisation_is_the_normalisation_bit_for_bit() -> None:
    """The unchecked form, on valid log-weights (normalised or not, with -inf entries), gives
    the same arrays as the checked one to the last bit."""
    from odorloc.inference.weights import normalise_checked_log_weights, normalise_log_weights

    rng = np.random.default_rng(5)
    for scale in (0.1, 3.0, 300.0):
        lw = rng.normal(0.0, scale, 157)
        lw[::13] = -np.inf
        for v in (lw, normalise_log_weights(lw)[0]):
            ref = normalise_log_weights(v)
            got = normalise_checked_log_weights(v)
            assert all(np.array_equal(a, b) for a, b in zip(got, ref, strict=True))


def test_an_adopted_set_becomes_the_filter_state_and_versions_count_replacements() -> None:
    """adopt() takes the arrays it is given (weights kept when none are given); every change of
    the set, and no weight update, moves the version on."""
    rng = np.random.default_rng(2)
    pf = ParticleFilter(rng.uniform(0.0, 10.0, (40, 2)))
    v0 = pf.version
    pf.update(rng.normal(0.0, 1.0, 40))
    assert pf.version == v0
    lw, w = pf.log_weights.copy(), pf.weights.copy()
    moved = pf.positions + 0.5
    pf.adopt(moved)
    assert pf.version == v0 + 1 and pf.n_resamples == 0
    assert np.array_equal(pf.positions, moved) and np.array_equal(pf.log_weights, lw)
    assert np.array_equal(pf.weights, w)
    fresh = rng.uniform(0.0, 10.0, (25, 2))
    pf.adopt(fresh, np.full(25, -math.log(25)), np.full(25, 1 / 25), resampled=True)
    assert pf.n == 25 and pf.n_resamples == 1 and pf.version == v0 + 2
    assert pf.ess == pytest.approx(25.0)
    pf.replace(fresh)
    assert pf.version == v0 + 3
    with pytest.raises(TypeError):
        pf.adopt(fresh, np.zeros(25))


@pytest.mark.parametrize("n", [1, 7, 23, 160, 1000])
def test_uniform_weights_written_directly_are_the_normalised_ones(n: int) -> None:
    """What a compiled resampling adopts (``0 - log n`` and ``1 / n``) is, bit for bit, what
    replace() makes of uniform log-weights, and a renormalisation leaves it unchanged."""
    from odorloc.inference.weights import normalise_checked_log_weights

    pf = ParticleFilter(np.zeros((3, 2)))
    pf.replace(np.zeros((n, 2)), np.full(n, -math.log(n)))
    lw, w = np.full(n, 0.0 - math.log(n)), np.full(n, 1.0 / n)
    # compared as bytes: the sign of a zero counts too
    assert pf.log_weights.tobytes() == lw.tobytes() and pf.weights.tobytes() == w.tobytes()
    again = normalise_checked_log_weights(lw)
    assert again[0].tobytes() == lw.tobytes() and again[1].tobytes() == w.tobytes()
