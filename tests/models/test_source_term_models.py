"""Source-term measurement models: widths, reading laws, compiled loops against NumPy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import log_ndtr, ndtr

from odorloc.core.errors import ConfigError
from odorloc.models.gaussian import (
    GaussianParams,
    gaussian_concentration,
    gaussian_plume_matrix,
    plume_widths,
)
from odorloc.models.source_term import (
    AdapterParams,
    AdapterSourceTermModel,
    GaussianSourceTermModel,
    GaussianSourceTermParams,
    ReadingLaw,
    SourceTerms,
    ThetaLayout,
    VergassolaSourceTermModel,
    VergassolaSourceTermParams,
)
from odorloc.models.source_term_kernels import log_ndtr as kernel_log_ndtr
from odorloc.models.vergassola import vergassola_rate, vergassola_rate_matrix

SHARED = ("speed", "direction", "log_dispersion", "background")


def _terms(layout: ThetaLayout, n: int, rng: np.random.Generator, box: float = 20.0):
    th = np.zeros((n, layout.n_columns))
    for k in range(layout.slots):
        th[:, layout.position_columns(k)] = rng.uniform(0, box, (n, layout.dim))
        th[:, layout.log_rate_column(k)] = rng.uniform(0, 3, n)
    if layout.slots > 1:
        a = layout.active_start
        th[:, a : a + layout.slots] = rng.random((n, layout.slots)) < 0.6
    for name, lo, hi in zip(SHARED, (0.5, -3, -0.5, 0), (3, 3, 0.5, 0.3), strict=True):
        c = layout.column(name)
        if c >= 0:
            th[:, c] = rng.uniform(lo, hi, n)
    return SourceTerms(th, layout)


def test_briggs_widths_at_one_kilometre() -> None:
    """Pasquill-Gifford widths of Briggs' open-country and urban formulas at x = 1 km."""
    x = np.array([1000.0])
    d = GaussianParams(spread="pasquill-gifford", stability="D", sigma0=1e-9)
    sy2, sz2 = plume_widths(x, 2.0, d)
    assert math.sqrt(sy2[0]) == pytest.approx(0.08 * 1000 / math.sqrt(1.1), rel=1e-9)
    assert math.sqrt(sz2[0]) == pytest.approx(0.06 * 1000 / math.sqrt(2.5), rel=1e-9)
    f = GaussianParams(spread="pasquill-gifford", stability="F", sigma0=1e-9)
    assert math.sqrt(plume_widths(x, 2.0, f)[1][0]) == pytest.approx(16.0 / 1.3, rel=1e-9)
    u = GaussianParams(spread="pasquill-gifford", stability="A", terrain="urban", sigma0=1e-9)
    sy2, sz2 = plume_widths(x, 2.0, u)
    assert math.sqrt(sy2[0]) == pytest.approx(320 / math.sqrt(1.4), rel=1e-9)
    assert math.sqrt(sz2[0]) == pytest.approx(240 * math.sqrt(2.0), rel=1e-9)
    # the dispersion factor scales the growth term
    s2 = plume_widths(x, 2.0, d, scale=np.array([2.0]))[0]
    assert s2[0] - 1e-18 == pytest.approx(4.0 * (0.08 * 1000) ** 2 / 1.1, rel=1e-9)


@pytest.mark.parametrize("spread", ["diffusion", "power", "pasquill-gifford"])
@pytest.mark.parametrize("dim", [2, 3])
def test_plume_matrix_is_the_per_source_plume(spread: str, dim: int) -> None:
    rng = np.random.default_rng(1)
    p = GaussianParams(spread=spread, stability="C")
    pts, src = rng.uniform(0, 30, (40, dim)), rng.uniform(0, 30, (6, dim))
    winds = rng.normal(0, 1, (6, dim)) + np.r_[1.0, 0.5, 0.0][:dim]
    rates = rng.uniform(0.5, 2, 6)
    u = np.hypot(winds[:, 0], winds[:, 1])
    m = gaussian_plume_matrix(pts, src, rates, u, winds[:, :2] / u[:, None], p, 0.2)
    np.testing.assert_allclose(
        m, gaussian_concentration(pts, src, rates, winds, p, 0.2), rtol=1e-13
    )


@pytest.mark.parametrize("dim", [2, 3])
def test_vergassola_matrix_is_the_shared_rate(dim: int) -> None:
    rng = np.random.default_rng(2)
    x, s = rng.uniform(0, 20, (9, dim)), rng.uniform(0, 20, (7, dim))
    e = np.zeros(dim)
    e[:2] = (0.6, -0.8)
    a = vergassola_rate(x, s, 3.0, V=1.2, D=1.1, tau=90, a=0.5, direction=e)
    b = vergassola_rate_matrix(
        x, s, np.full(7, 3.0), V=1.2, D=1.1, tau=90.0, a=0.5, direction=np.tile(e, (7, 1))
    )
    np.testing.assert_allclose(a, b, rtol=1e-12)
    if dim == 2:
        with pytest.raises(ConfigError, match="sensor_radius"):
            vergassola_rate_matrix(x, s, 1.0, V=1.0, D=0.01, tau=1.0, a=0.5, direction=e)


def test_log_ndtr_kernel_matches_scipy_in_both_tails() -> None:
    for x in (-300.0, -40.0, -30.0001, -29.9, -20.0, -5.0, 0.0, 3.0, 9.0, 40.0):
        assert kernel_log_ndtr(x) == pytest.approx(float(log_ndtr(x)), rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("reading", ["censored", "gaussian", "detection"])
@pytest.mark.parametrize("spread", ["diffusion", "power", "pasquill-gifford"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("shared", [False, True])
def test_compiled_history_matches_numpy(reading: str, spread: str, dim: int, shared: bool) -> None:
    """The compiled sum over a history equals the NumPy reference (every law, width law,
    dimension, one slot or three with wind, dispersion and background)."""
    rng = np.random.default_rng(3)
    lay = ThetaLayout(dim, 3, *([True] * 4)) if shared else ThetaLayout(dim)
    model = GaussianSourceTermModel(
        GaussianSourceTermParams(
            reading=reading,
            spread=spread,
            stability="B",
            threshold=0.3,
            noise_std=0.2,
            relative_noise=0.1,
            miss=0.0 if reading == "gaussian" else 0.1,
            false_alarm=0.01 if reading == "detection" else 0.0,
        )
    )
    terms = _terms(lay, 150, rng)
    t = 25
    pts = rng.uniform(0, 20, (t, dim))
    winds = rng.normal(0, 1, (t, dim)) + np.r_[1.5, 0.5, 0.0][:dim]
    z = rng.uniform(0, 1.5, t) if reading != "detection" else (rng.random(t) < 0.5) * 1.0
    a = model.log_likelihood_sum(z, pts, terms, winds, np.ones(t))
    b = model.log_likelihood_reference(z, pts, terms, winds)
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("shared", [False, True])
def test_compiled_counts_match_numpy(shared: bool) -> None:
    rng = np.random.default_rng(4)
    lay = ThetaLayout(3, 2, *([True] * 4)) if shared else ThetaLayout(3)
    model = VergassolaSourceTermModel(VergassolaSourceTermParams(background=0.01))
    terms = _terms(lay, 100, rng)
    t = 30
    pts, winds = rng.uniform(0, 20, (t, 3)), rng.normal(0, 1, (t, 3))
    z = rng.poisson(1.0, t).astype(float)
    a = model.log_likelihood_sum(z, pts, terms, winds, np.full(t, 0.7))
    b = model.log_likelihood_reference(z, pts, terms, winds, np.full(t, 0.7))
    np.testing.assert_allclose(a, b, rtol=1e-10)
    with pytest.raises(ConfigError, match="counts"):
        model.log_likelihood_sum(z - 0.5, pts, terms, winds, np.full(t, 0.7))


def test_censored_law_is_the_probability_of_reading_below_the_threshold() -> None:
    law = ReadingLaw("censored", 0.4, 0.0, 0.5, 0.1, 0.0, 0.0)
    sig = np.array([[0.0, 0.3, 2.0]])
    below = law.log_prob(np.array([[0.2]]), sig, None)
    np.testing.assert_allclose(below, np.log(ndtr((0.5 - (sig + 0.1)) / 0.4)), rtol=1e-12)
    above = law.log_prob(np.array([[1.2]]), sig, None)
    r = (1.2 - (sig + 0.1)) / 0.4
    np.testing.assert_allclose(above, -0.5 * r * r - np.log(0.4 * math.sqrt(2 * math.pi)))
    # a miss probability: below = miss + (1 - miss) Phi, above scaled by (1 - miss)
    lm = ReadingLaw("censored", 0.4, 0.0, 0.5, 0.1, 0.25, 0.0)
    np.testing.assert_allclose(
        np.exp(lm.log_prob(np.array([[0.2]]), sig, None)),
        0.25 + 0.75 * ndtr((0.5 - (sig + 0.1)) / 0.4),
        rtol=1e-12,
    )


@pytest.mark.parametrize("reading", ["censored", "gaussian", "detection"])
def test_outcome_classes_sum_to_one_and_match_their_values(reading: str) -> None:
    rng = np.random.default_rng(5)
    model = GaussianSourceTermModel(
        GaussianSourceTermParams(reading=reading, threshold=0.3, noise_std=0.2, miss=0.1)
    )
    terms = _terms(ThetaLayout(2, speed=True, direction=True), 80, rng)
    s = rng.uniform(0, 20, (5, 2))
    q = model.outcome_probabilities(s, terms, wind=np.array([1.0, 0.2]))
    assert q.shape[0] == 5 and q.shape[2] == 80
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    assert len(model.outcome_values(s, terms, wind=np.array([1.0, 0.2]))) == q.shape[1]


def test_compiled_classes_match_numpy() -> None:
    for kind, miss in (("censored", 0.2), ("gaussian", 0.0)):
        law = ReadingLaw(kind, 0.4, 0.1, 0.2, 0.0, miss, 0.0)
        rng = np.random.default_rng(6)
        sig = np.where(rng.random((7, 60)) < 0.5, 0.0, rng.uniform(0, 20, (7, 60)))
        probs, _ = law.classes(sig, None, 0.4, 48)
        z = probs.shape[1]
        edges = 0.2 + 0.4 * np.arange(z)
        ref = law.class_rows(sig.ravel(), law.sd(sig).ravel(), edges).reshape(7, 60, z)
        np.testing.assert_allclose(probs, np.moveaxis(ref, -1, 1), atol=1e-12)


def test_plain_positions_are_single_sources_of_the_default_rate() -> None:
    model = GaussianSourceTermModel(GaussianSourceTermParams(release=2.0, threshold=0.1))
    pos = np.array([[1.0, 2.0], [3.0, 1.5]])
    a = model.log_likelihood(0.7, np.array([6.0, 2.0]), pos, wind=np.array([1.0, 0.0]))
    b = model.log_likelihood(
        0.7, np.array([6.0, 2.0]), SourceTerms.single(pos, 2.0), wind=np.array([1.0, 0.0])
    )
    np.testing.assert_array_equal(a, b)


def test_adapter_sums_the_wrapped_model_per_reading() -> None:
    rng = np.random.default_rng(7)
    ad = AdapterSourceTermModel(AdapterParams(model={"type": "vergassola"}, reading="count"))
    terms = SourceTerms.single(rng.uniform(0, 10, (20, 3)), rng.uniform(1, 5, 20))
    pts = rng.uniform(0, 10, (4, 3))
    z = np.array([0.0, 1.0, 2.0, 0.0])
    winds = np.tile([0.0, -1.0, 0.0], (4, 1))
    got = ad.log_likelihood_sum(z, pts, terms, winds, np.ones(4))
    want = sum(
        ad.inner.log_likelihood(int(k), p, terms.positions[:, 0], release=terms.rates[:, 0], dt=1.0)
        for k, p in zip(z, pts, strict=True)
    )
    np.testing.assert_allclose(got, want)
    with pytest.raises(ConfigError, match="position and rate"):
        ad.check_layout(ThetaLayout(3, speed=True))


def test_bad_inputs_name_the_field() -> None:
    model = GaussianSourceTermModel(GaussianSourceTermParams(threshold=0.1))
    terms = SourceTerms.single(np.ones((3, 2)), 1.0)
    with pytest.raises(ConfigError, match="hypotheses"):
        SourceTerms(np.ones((3, 7)), ThetaLayout(2))
    with pytest.raises(ConfigError, match="reading"):
        model.log_likelihood(math.nan, np.zeros(2), terms, wind=np.ones(2))
    with pytest.raises(ConfigError, match="sensor_positions"):
        model.log_likelihood(0.1, np.array([np.nan, 0.0]), terms, wind=np.ones(2))
    with pytest.raises(ConfigError, match="wind"):
        model.log_likelihood(0.1, np.zeros(2), terms, wind=np.ones(3))
    with pytest.raises(ConfigError, match="readings"):
        model.log_likelihood_sum(np.zeros(2), np.zeros((3, 2)), terms, np.zeros((3, 2)), np.ones(3))
    with pytest.raises(ConfigError, match="max_sources"):
        ThetaLayout(2, 0)
