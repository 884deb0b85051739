"""Censored Poisson count classes over the whole range of means and class counts."""

from __future__ import annotations

import numpy as np
from scipy.stats import poisson

from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import VergassolaModel


def test_censored_classes_match_scipy_from_tiny_to_huge_means() -> None:
    lam = np.r_[0.0, np.logspace(-10, 3, 300)]
    for n in (2, 3, 5, 11, 16, 40):
        p = censored_poisson(lam, n)
        np.testing.assert_allclose(p.sum(axis=-1), 1.0, rtol=1e-13)
        head = poisson.pmf(np.arange(n - 1)[None, :], lam[:, None])
        np.testing.assert_allclose(p[:, :-1], head, rtol=1e-10, atol=1e-300)
        tail = poisson.sf(n - 2, lam)
        ok = tail > 1e-300
        np.testing.assert_allclose(p[ok, -1], tail[ok], rtol=1e-10)
        assert np.all(p >= 0)


def test_censored_classes_keep_the_shape_of_the_means() -> None:
    lam = np.random.default_rng(0).exponential(1.0, (4, 7))
    p = censored_poisson(lam, 6)
    assert p.shape == (4, 7, 6)
    np.testing.assert_allclose(p[2, 3], censored_poisson(lam[2, 3], 6))


def test_class_count_is_the_smallest_with_a_negligible_tail() -> None:
    m = VergassolaModel()
    for mean in (0.0, 1e-3, 0.1, 1.0, 3.0, 50.0):
        n = m.n_classes(np.array([mean]))
        assert 2 <= n <= m.params.max_classes
        if n < m.params.max_classes:
            assert censored_poisson(mean, n)[-1] < m.params.tail_mass
        if n > 2:
            assert censored_poisson(mean, n - 1)[-1] >= m.params.tail_mass


def test_likelihood_rows_equal_one_call_per_reading() -> None:
    from odorloc.models.gaussian import GaussianPlumeModel

    rng = np.random.default_rng(2)
    hyp = rng.uniform(0, 30, (40, 3))
    where = rng.uniform(0, 30, (3, 3))
    m = VergassolaModel()
    rows = m.log_likelihood_rows([0, 2, 1], where, hyp, dt=1.0)
    assert rows.shape == (3, 40)
    for q, z in enumerate((0, 2, 1)):
        np.testing.assert_allclose(rows[q], m.log_likelihood(z, where[q], hyp, dt=1.0))
    # the base class's default: one call per reading
    g = GaussianPlumeModel()
    hyp2, where2 = hyp[:, :2], where[:, :2]
    base = g.log_likelihood_rows([True, False, True], where2, hyp2, wind=np.array([1.0, 0.0]))
    for q, z in enumerate((True, False, True)):
        np.testing.assert_allclose(
            base[q], g.log_likelihood(z, where2[q], hyp2, wind=np.array([1.0, 0.0]))
        )


def test_censored_classes_refuse_invalid_means() -> None:
    import pytest

    from odorloc.core.errors import ConfigError

    for bad in (-1.0, np.nan, np.inf, [0.5, -1e-3], [[1.0], [np.nan]]):
        with pytest.raises(ConfigError, match="expected_counts"):
            censored_poisson(bad, 3)
    # an empty set of means is valid
    assert censored_poisson(np.zeros((0,)), 3).shape == (0, 3)
