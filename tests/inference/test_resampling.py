"""Resampler invariants and the statistics of each scheme."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.inference.particles.constraints import ArenaConstraint
from odorloc.inference.particles.resampling import (
    MultinomialResampler,
    RouletteParams,
    RouletteResampler,
    StratifiedResampler,
    SystematicParams,
    SystematicResampler,
    effective_sample_size,
    multinomial,
    residual,
    stratified,
    systematic,
)

ALL = registry.names("resampler")


def make_resampler(name: str):
    """The one way to choose a resampler: by registry name."""
    e = registry.entry("resampler", name, field="resampler")
    return e.build(registry.make_params("resampler", name, {}))


def _cloud(n: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 4, (n, 2))
    lw = -0.5 * np.sum((pos - 2.0) ** 2, axis=1) / 0.3
    return pos, lw


@pytest.mark.parametrize("name", ALL)
def test_the_resampled_cloud_follows_the_weight(name: str) -> None:
    """Beyond the contract (``checks.check_resampler``, applied to every resampler in
    ``test_contracts.py``): the resampled cloud has the weighted cloud's mean and spread."""
    r = make_resampler(name)
    # a peak off the middle of the square, so that ignoring the weights (the uniform cloud's
    # mean is near (2, 2)) cannot pass
    pos = np.random.default_rng(3).uniform(0, 4, (300, 2))
    lw = -0.5 * np.sum((pos - [3.0, 1.0]) ** 2, axis=1) / 0.3
    w = np.exp(lw - lw.max())
    w /= w.sum()
    mean = w @ pos
    var = w @ (pos - mean) ** 2
    out, _ = r.resample(pos, lw, np.random.default_rng(4))
    if name == "roulette":
        # The paper's roulette lets a light particle survive with probability at least
        # survival_floor = 0.5, so about half of the light cloud stays: the mean moves only part
        # of the way (a scheme ignoring the weights stays at 1, an unbiased one near 0).
        left = np.linalg.norm(out.mean(axis=0) - mean) / np.linalg.norm(pos.mean(axis=0) - mean)
        assert 0.2 < left < 0.6, left
        return
    # the resampled mean is that of 300 draws from the weighted cloud: standard error
    # sqrt(var / 300), about 0.03 m per axis; 4 standard errors allowed
    np.testing.assert_array_less(np.abs(out.mean(axis=0) - mean), 4 * np.sqrt(var / len(pos)))
    assert np.linalg.norm(out.mean(axis=0) - pos.mean(axis=0)) > 1.0
    # and its spread: the weighted variance (about 0.3 m^2 per axis, the uniform square's is
    # 1.33), within a factor allowing the sampling error and a regularising kernel
    ratio = out.var(axis=0) / var
    assert np.all((ratio > 0.7) & (ratio < 1.5)), ratio


def test_systematic_counts_are_floor_or_ceil_and_equal_low_variance() -> None:
    rng = np.random.default_rng(5)
    w = rng.dirichlet(np.ones(40))
    idx = SystematicResampler().indices(w, np.random.default_rng(9))
    counts = np.bincount(idx, minlength=40)
    assert np.all(counts >= np.floor(40 * w) - 1e-9) and np.all(counts <= np.ceil(40 * w) + 1e-9)
    # "low-variance" is another name of the same resampler (Thrun's sampler = systematic)
    idx2 = make_resampler("low-variance").indices(w, np.random.default_rng(9))
    np.testing.assert_array_equal(idx, idx2)
    idx3 = StratifiedResampler().indices(w, np.random.default_rng(9))
    assert np.all(np.abs(np.bincount(idx3, minlength=40) - 40 * w) < 2.0 + 1e-9)


def test_multinomial_counts_are_unbiased() -> None:
    w = np.array([0.5, 0.3, 0.2])
    r = MultinomialResampler()
    rng = np.random.default_rng(2)
    total = np.zeros(3)
    for _ in range(200):
        total += np.bincount(r.indices(w, rng), minlength=3)
    # 600 draws: std of each frequency <= sqrt(0.25 / 600) = 0.02; allow 4 sigma.
    np.testing.assert_allclose(total / total.sum(), w, atol=0.08)


def test_roulette_children_have_the_stated_spread() -> None:
    # All weight on one particle: it spawns min(floor(N), 5) = 5 children and the set is filled
    # back to N with further children, so every particle ~ N(parent, 0.25 I).
    n = 4000
    pos = np.zeros((n, 2))
    pos[1:] = 10.0
    lw = np.full(n, -np.inf)
    lw[0] = 0.0
    r = RouletteResampler(RouletteParams(survival_floor=0.0))
    out, _ = r.resample(pos, lw, np.random.default_rng(3))
    assert out.shape == (n, 2)
    # Sample variance of 4000 normals: relative std sqrt(2/4000) = 2.2 %; allow 10 %.
    np.testing.assert_allclose(out.var(axis=0), 0.25, rtol=0.1)
    np.testing.assert_allclose(out.mean(axis=0), 0.0, atol=0.05)


def test_roulette_bounded_count_and_survival_floor() -> None:
    n = 2000
    pos = np.arange(2 * n, dtype=float).reshape(n, 2)
    lw = np.full(n, -np.inf)
    lw[0] = 0.0
    p = RouletteParams(count="bounded", min_particles=1, max_particles=10_000, child_variance=0.0)
    out, olw = RouletteResampler(p).resample(pos, lw, np.random.default_rng(4))
    # Floor 0.5: each of the 1999 light particles survives with probability 0.5 (std 22);
    # the heavy one is replaced by 5 children (exact copies with zero variance).
    survivors = len(out) - 5
    assert abs(survivors - 999.5) < 5 * 22.4
    assert np.sum(np.all(out == pos[0], axis=1)) == 5
    np.testing.assert_allclose(olw, -np.log(len(out)))
    # Upper bound enforced.
    p2 = p.model_copy(update={"max_particles": 300})
    out2, _ = RouletteResampler(p2).resample(pos, lw, np.random.default_rng(4))
    assert len(out2) == 300
    # Lower bound enforced.
    p3 = RouletteParams(count="bounded", min_particles=1500, survival_floor=0.0)
    out3, _ = RouletteResampler(p3).resample(pos, lw, np.random.default_rng(4))
    assert len(out3) == 1500


def test_children_stay_in_free_space() -> None:
    arena = Arena.box((0, 0), (3, 3), 0.1).with_boxes([((1.0, 0.0), (1.3, 3.0))])
    pos = np.array([[0.9, 1.5], [0.1, 0.1], [2.0, 2.0]])
    lw = np.log([0.9, 0.05, 0.05])
    for r in (RouletteResampler(), SystematicResampler(SystematicParams(jitter_std=0.5))):
        out, _ = r.resample(
            np.repeat(pos, 100, 0),
            np.repeat(lw, 100),
            np.random.default_rng(0),
            constraint=ArenaConstraint(arena),
        )
        assert arena.is_free(out).all()


def test_bad_input() -> None:
    r = SystematicResampler()
    with pytest.raises(ConfigError, match="positions"):
        r.resample(np.zeros((0, 2)), np.zeros(0), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="log_weights"):
        r.resample(np.zeros((3, 2)), np.zeros(2), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="resampler"):
        make_resampler("nope")
    with pytest.raises(ConfigError, match="n"):
        r.resample(np.zeros((3, 2)), np.zeros(3), np.random.default_rng(0), n=0)
    with pytest.raises(pydantic.ValidationError, match="max_particles"):
        RouletteParams(min_particles=10, max_particles=5)
    with pytest.raises(pydantic.ValidationError, match="survival_floor"):
        RouletteParams(survival_floor=1.5)


def test_effective_sample_size() -> None:
    assert effective_sample_size(np.zeros(10)) == pytest.approx(10.0)
    assert effective_sample_size(np.array([0.0, -np.inf, -np.inf])) == pytest.approx(1.0)
    assert effective_sample_size(np.full(4, -np.inf)) == pytest.approx(4.0)
    assert effective_sample_size(np.log([0.5, 0.25, 0.25])) == pytest.approx(1 / 0.375)


@pytest.mark.parametrize("scheme", [systematic, stratified, multinomial, residual])
@pytest.mark.parametrize("m", [1, 7, 250])
def test_schemes_draw_the_target_count_without_bias(scheme, m: int) -> None:
    rng = np.random.default_rng(11)
    w = rng.dirichlet(np.ones(6))
    idx = scheme(w, m, rng)
    assert idx.shape == (m,) and idx.min() >= 0 and idx.max() < 6
    total = np.zeros(6)
    for _ in range(4000 // max(m, 1) + 1):
        total += np.bincount(scheme(w, m, rng), minlength=6)
    np.testing.assert_allclose(total / total.sum(), w, atol=0.03)


def test_residual_keeps_the_deterministic_copies() -> None:
    w = np.array([0.55, 0.3, 0.15])
    idx = residual(w, 10, np.random.default_rng(0))
    counts = np.bincount(idx, minlength=3)
    assert np.all(counts >= np.floor(10 * w))


@pytest.mark.parametrize("name", ["systematic", "stratified", "multinomial", "residual"])
def test_index_resamplers_reach_a_new_particle_count(name: str) -> None:
    pos, lw = _cloud()
    out, olw = make_resampler(name).resample(pos, lw, np.random.default_rng(1), n=40)
    assert out.shape == (40, 2) and np.allclose(olw, -np.log(40))


def test_roulette_keep_fills_to_the_target_count() -> None:
    pos, lw = _cloud()
    out, _ = RouletteResampler().resample(pos, lw, np.random.default_rng(1), n=120)
    assert out.shape == (120, 2)


def test_regularised_settings_refuse_infinite_kernels() -> None:
    """An infinite bandwidth used to be accepted and the kernel move then skipped (exact
    copies, no regularisation) without a word."""
    for field in ("bandwidth", "max_std"):
        with pytest.raises(ConfigError, match=field):
            registry.make_params("resampler", "regularised", {field: float("inf")})
    p = registry.make_params("resampler", "regularised", {"bandwidth": 0.5, "max_std": 1.0})
    assert p.bandwidth == 0.5 and p.max_std == 1.0
