"""Censored Poisson count classes over the whole range of means and class counts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import gammainc
from scipy.stats import poisson

from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams


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
        # the largest mean given as a number (the compiled planner's form): the same count
        assert m.n_classes(float(mean)) == n == m.n_classes(np.array([[mean, 0.5 * mean]]))


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


@pytest.mark.parametrize("backend", ["numpy", "auto"])
@pytest.mark.parametrize("bad", [0, 1, -3, 2.7, True, "3", 10**9])
def test_fixed_class_counts_are_refused_outside_two_to_the_cap(backend: str, bad: object) -> None:
    from odorloc.core.errors import ConfigError
    from odorloc.models.vergassola import VergassolaModelParams

    # 0 used to mean "choose", -3 gave no class values, 2.7 became 2 and 10**9 ran for ever
    m = VergassolaModel(VergassolaModelParams(backend=backend))
    x, h = np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    for method in (m.outcome_probabilities, m.outcome_values):
        with pytest.raises(ConfigError) as err:
            method(x, h, dt=1.0, n_classes=bad)
        assert err.value.field == "n_classes"
    with pytest.raises(ConfigError, match="n_classes"):
        censored_poisson(np.ones(3), bad)  # type: ignore[arg-type]


def test_fixed_class_counts_accept_whole_numbers_up_to_the_cap() -> None:
    from odorloc.models.poisson import MAX_CLASSES

    m = VergassolaModel()
    x, h = np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 2.0, 3.0]])
    for z in (2, np.int64(5), 7.0, MAX_CLASSES):
        assert m.outcome_probabilities(x, h, dt=1.0, n_classes=z).shape == (1, int(z), 1)
        assert m.outcome_values(x, h, dt=1.0, n_classes=z).size == int(z)


def test_lattice_rule_refuses_thousands_of_hit_classes() -> None:
    from odorloc.core.errors import ConfigError
    from odorloc.models.lattice import IsotropicHitModel, IsotropicHitParams

    strong = IsotropicHitModel(IsotropicHitParams(intensity=1e4))
    with pytest.raises(ConfigError, match="n_hits"):
        strong.outcome_values(np.zeros((1, 2)), np.ones((3, 2)))
    fixed = IsotropicHitModel(IsotropicHitParams(intensity=1e4, n_hits=8))
    assert fixed.outcome_values(np.zeros((1, 2)), np.ones((3, 2))).size == 8


@pytest.mark.parametrize("backend", ["numpy", "auto"])
def test_release_arrays_kept_between_calls_stay_few(backend: str) -> None:
    # one cached ``a Q`` array per (hypothesis count, release) ever seen grew over an episode:
    # the memory a model holds must stop growing once its caches are full
    import gc
    import tracemalloc

    from odorloc.models.vergassola import VergassolaModelParams

    m = VergassolaModel(VergassolaModelParams(backend=backend))
    rng = np.random.default_rng(3)
    x = np.zeros((1, 3))
    first = None
    n_hyp = 4000  # 32 kB per cached array: growth stands far above the noise
    held = []
    tracemalloc.start()
    try:
        for i in range(60):
            h = rng.uniform(0.0, 10.0, (n_hyp + i, 3))
            rows = m.log_likelihood_rows([1.0], x, h, dt=1.0, release=1.0 + 0.01 * i)
            if i == 0:
                first = (h, rows)
            if i in (19, 59):
                gc.collect()
                held.append(tracemalloc.get_traced_memory()[0])
    finally:
        tracemalloc.stop()
    # 40 more arrays kept would be 40 x 32 kB = 1.3 MB; a bounded cache adds nothing
    assert held[1] - held[0] < 10 * 8 * n_hyp, held
    # an entry pushed out is rebuilt with the same numbers
    assert first is not None
    again = m.log_likelihood_rows([1.0], x, first[0], dt=1.0, release=1.0)
    np.testing.assert_array_equal(again, first[1])


@pytest.mark.parametrize(("tail", "top"), [(1e-3, 16), (1e-6, 40), (1e-2, 2), (1e-9, 3)])
def test_class_count_is_the_first_small_tail(tail: float, top: int) -> None:
    """The Vergassola model's class count (searched from its last answer) is the first ``n``
    whose tail ``P(d >= n) = gammainc(n, mean)`` is below ``tail_mass``, plus one, as a scan
    from 1 finds it, or ``max_classes``; for means in any order, from 0 to far beyond it."""
    rng = np.random.default_rng(5)
    means = np.concatenate([[0.0, 1e-300, 1e-20, 700.0, 1e4], 10 ** rng.uniform(-12, 3, 400)])
    rng.shuffle(means)
    model = VergassolaModel(VergassolaModelParams(tail_mass=tail, max_classes=top))
    for m in means:
        want = next((n + 1 for n in range(1, top) if gammainc(n, m) < tail), top)
        assert model.n_classes(np.array([m])) == want, m
