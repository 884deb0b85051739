"""The source-term estimator: closed-form posteriors, determinism, several sources, bad input.

The two toys fix the source position (a prior box a millimetre wide) so that the posterior of
the rest is known in closed form:

- readings ``z = b + q c_t + N(0, sigma^2)`` with flat priors on ``q`` and ``b``: the posterior
  of ``(b, q)`` is the Gaussian of least squares, ``N(beta_hat, sigma^2 (X^T X)^-1)``;
- Poisson counts ``k_t ~ Poisson(q mu_t)`` with a log-uniform prior on ``q`` (density ``1/q``):
  the posterior is ``Gamma(sum k, sum mu)``.

Tolerances: the posterior mean within 0.15 posterior standard deviations of the exact one, the
standard deviation within 15 % (a few thousand particles; the Monte Carlo error of both is a
few per cent).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.types import Observation, SearchContext, SensorInfo
from odorloc.geometry.arena import Arena
from odorloc.inference.source_terms import (
    SourceTermBelief,
    SourceTermEstimator,
    SourceTermParams,
    UniformPrior,
)
from odorloc.inference.source_terms.priors import LogUniformPrior
from odorloc.models.source_term import (
    GaussianSourceTermModel,
    GaussianSourceTermParams,
    SourceTerms,
    VergassolaSourceTermModel,
    VergassolaSourceTermParams,
)

SRC2 = np.array([10.0005, 10.0005])
BOX2 = ((10.0, 10.0), (10.001, 10.001))


def _ctx(dim: int = 2, size: float = 30.0) -> SearchContext:
    return SearchContext(
        arena=Arena.box([0.0] * dim, [size] * dim, 0.5),
        dt=1.0,
        agent_ids=(0,),
        start=np.full((1, dim), 1.0),
        speed_limits=np.array([1.0]),
        sensor=SensorInfo(threshold=0.2),
    )


def _obs(t: int, pos: np.ndarray, z: float, wind: np.ndarray) -> Observation:
    return Observation(
        agent=0, t=float(t), position=pos, heading=0.0, gas=z, detection=z > 0.2, wind=wind
    )


def _linear_toy(seed: int = 0):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    model = GaussianSourceTermModel(
        GaussianSourceTermParams(reading="gaussian", K=0.1, sigma0=0.3, noise_std=0.2, release=1.0)
    )
    pts = np.array([[10.0 + d, 10.0 + c] for d in range(1, 7) for c in (-0.5, 0.0, 0.5)])
    wind = np.array([1.0, 0.0])
    c = model.signal(pts, SourceTerms.single(SRC2[None], 1.0), np.tile(wind, (len(pts), 1)))[:, 0]
    q, b = 3.0, 0.5
    z = b + q * c + rng.normal(0, 0.2, len(pts))
    x = np.column_stack([np.ones(len(c)), c])
    cov = 0.04 * np.linalg.inv(x.T @ x)
    beta = np.linalg.solve(x.T @ x, x.T @ z)
    return model, pts, z, wind, beta, cov


def _run(estimator: SourceTermEstimator, model, pts, z, wind, seed=1, dim=2):  # type: ignore[no-untyped-def]
    estimator.reset(_ctx(dim), model, np.random.default_rng(seed))
    for t, (p, v) in enumerate(zip(pts, z, strict=True)):
        estimator.update(_obs(t, p, float(v), wind))
    return estimator


def test_linear_gaussian_toy_matches_least_squares() -> None:
    model, pts, z, wind, beta, cov = _linear_toy()
    est = SourceTermEstimator(
        SourceTermParams(
            n_particles=4000,
            region=BOX2,
            rate=UniformPrior(low=0.01, high=100.0),
            background=UniformPrior(low=-10.0, high=10.0),
            mcmc_steps=5,
            wind_average=1,
        )
    )
    # the priors' bounds lie many standard deviations away: the posterior is the untruncated
    # least-squares Gaussian
    assert beta[1] > 8 * math.sqrt(cov[1, 1]) and abs(beta[0]) + 8 * math.sqrt(cov[0, 0]) < 10
    _run(est, model, pts, z, wind)
    b = est.belief()
    assert isinstance(b, SourceTermBelief)
    lay = b.layout
    draws = np.column_stack(
        [b.theta[:, lay.column("background")], np.exp(b.theta[:, lay.log_rate_column(0)])]
    )
    w = b.weights
    mean = w @ draws
    sd = np.sqrt(w @ (draws - mean) ** 2)
    exact_sd = np.sqrt(np.diag(cov))
    np.testing.assert_array_less(np.abs(mean - beta), 0.15 * exact_sd)
    np.testing.assert_allclose(sd, exact_sd, rtol=0.15)
    # b and q trade off: their posterior correlation has the sign of least squares'
    corr = (w @ ((draws[:, 0] - mean[0]) * (draws[:, 1] - mean[1]))) / (sd[0] * sd[1])
    assert np.sign(corr) == np.sign(cov[0, 1])


def test_poisson_gamma_toy_matches_the_gamma_posterior() -> None:
    rng = np.random.default_rng(2)
    model = VergassolaSourceTermModel(VergassolaSourceTermParams(sensor_radius=1.0))
    src = np.array([[10.0005, 10.0005, 5.0005]])
    pts = np.column_stack([rng.uniform(6, 14, 40), rng.uniform(2, 12, 40), rng.uniform(3, 7, 40)])
    wind = np.array([0.0, -1.0, 0.0])
    mu = model.rate(pts, SourceTerms.single(src, 1.0), np.tile(wind, (40, 1)))[:, 0]
    k = rng.poisson(4.0 * mu)
    k[0] = 12  # an informative first reading: brought in by tempered steps
    est = SourceTermEstimator(
        SourceTermParams(
            n_particles=4000,
            region=((10.0, 10.0, 5.0), (10.001, 10.001, 5.001)),
            rate=LogUniformPrior(low=0.1, high=1000.0),
            mcmc_steps=5,
        )
    )
    _run(est, model, pts, k.astype(float), wind, dim=3)
    b = est.belief()
    assert b is not None
    q = np.exp(b.theta[:, b.layout.log_rate_column(0)])
    mean = float(b.weights @ q)
    sd = math.sqrt(float(b.weights @ (q - mean) ** 2))
    shape, rate = float(k.sum()), float(mu.sum())
    assert abs(mean - shape / rate) < 0.15 * math.sqrt(shape) / rate
    assert sd == pytest.approx(math.sqrt(shape) / rate, rel=0.15)
    assert est.final_metrics()["tempered_steps"] >= 1


def test_same_seed_and_readings_give_the_same_posterior() -> None:
    model, pts, z, wind, _, _ = _linear_toy()
    params = SourceTermParams(n_particles=300, rate=UniformPrior(low=0.01, high=100.0))
    a = _run(SourceTermEstimator(params), model, pts[:12], z[:12], wind, seed=5)
    b = _run(SourceTermEstimator(params), model, pts[:12], z[:12], wind, seed=5)
    c = _run(SourceTermEstimator(params), model, pts[:12], z[:12], wind, seed=6)
    ba, bb, bc = a.belief(), b.belief(), c.belief()
    assert ba is not None and bb is not None and bc is not None
    np.testing.assert_array_equal(ba.theta, bb.theta)
    np.testing.assert_array_equal(ba.log_weights, bb.log_weights)
    assert not np.array_equal(ba.theta, bc.theta)


def test_estimator_interface_before_and_after_readings() -> None:
    model, pts, z, wind, _, _ = _linear_toy()
    est = SourceTermEstimator(SourceTermParams(n_particles=200))
    est.reset(_ctx(), model, np.random.default_rng(0))
    assert est.belief() is None
    assert est.estimate().shape == (0, 2)
    assert not est.converged()
    assert est.diagnostics() == {}
    keys = set(est.final_metrics())
    for t in range(6):
        est.update(_obs(t, pts[t], float(z[t]), wind))
    assert est.estimate().shape == (1, 2)
    assert set(est.final_metrics()) == keys
    d = est.diagnostics()
    assert 1.0 <= d["ess"] <= 200.0 and d["spread"] > 0
    snap = est.belief().snapshot()  # type: ignore[union-attr]
    assert all(isinstance(v, np.ndarray) for v in snap.values())
    back = SourceTermBelief.from_snapshot(snap)
    assert back.layout == est.layout


def test_credible_region_of_a_gaussian_cloud_holds_95_percent() -> None:
    """The KDE highest-density region of a Gaussian posterior sample contains about 95 % of
    fresh draws of that Gaussian, and the rate interval its central 95 %."""
    rng = np.random.default_rng(8)
    n = 4000
    cov = np.array([[4.0, 1.5], [1.5, 1.0]])
    pos = rng.multivariate_normal([20.0, 20.0], cov, n)
    lq = rng.normal(0.0, 0.5, n)
    from odorloc.models.source_term import ThetaLayout

    b = SourceTermBelief.of(np.column_stack([pos, lq]), np.zeros(n), ThetaLayout(2))
    region = b.credible_region(0.95, n=2000)
    fresh = rng.multivariate_normal([20.0, 20.0], cov, 2000)
    inside = np.mean(region.density(fresh) >= region.threshold)
    assert 0.93 <= inside <= 0.98
    lo, hi = region.rate
    assert lo == pytest.approx(math.exp(-1.96 * 0.5), rel=0.1)
    assert hi == pytest.approx(math.exp(1.96 * 0.5), rel=0.1)
    # the region's radius covers the bulk: at least the 95 % Gaussian ellipse's minor axis
    assert region.radius > math.sqrt(5.99 * np.linalg.eigvalsh(cov)[0])


def test_two_sources_are_found_with_an_unknown_count() -> None:
    rng = np.random.default_rng(9)
    model = GaussianSourceTermModel(
        GaussianSourceTermParams(reading="gaussian", K=0.3, sigma0=0.3, noise_std=0.05)
    )
    true = np.array([[4.0, 6.0], [4.0, 14.0]])
    th = np.array([[4.0, 6.0, math.log(3.0), 4.0, 14.0, math.log(2.0), 1.0, 1.0]])
    from odorloc.models.source_term import ThetaLayout

    terms = SourceTerms(th, ThetaLayout(2, 2))
    pts = np.array([[x, y] for x in (7.0, 10.0, 14.0) for y in np.arange(1.0, 20.0, 1.0)])
    wind = np.array([1.0, 0.0])
    z = model.signal(pts, terms, np.tile(wind, (len(pts), 1)))[:, 0] + rng.normal(0, 0.05, len(pts))
    est = SourceTermEstimator(
        SourceTermParams(
            n_particles=1500,
            region=((0.0, 0.0), (20.0, 20.0)),
            rate=LogUniformPrior(low=0.3, high=30.0),
            max_sources=3,
            source_count="poisson",
            source_count_mean=1.0,
            mcmc_steps=3,
        )
    )
    _run(est, model, pts, z, wind, seed=3)
    s = est.sources()
    assert s is not None and s.count == 2
    d = np.linalg.norm(s.positions[:, None, :] - true[None], axis=2)
    assert np.all(d.min(axis=1) < 1.0)
    assert est.estimate().shape == (2, 2)


def test_bad_input_is_refused_naming_the_field() -> None:
    model, _, _, wind, _, _ = _linear_toy()
    est = SourceTermEstimator(SourceTermParams(n_particles=50))
    from odorloc.models.gaussian import GaussianPlumeModel

    with pytest.raises(ConfigError, match="model"):
        est.reset(_ctx(), GaussianPlumeModel(), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="region"):
        SourceTermEstimator(SourceTermParams(region=((40.0, 40.0), (50.0, 50.0)))).reset(
            _ctx(), model, np.random.default_rng(0)
        )
    est.reset(_ctx(), model, np.random.default_rng(0))
    with pytest.raises(ConfigError, match="position"):
        est.update(_obs(0, np.array([1.0, 2.0, 3.0]), 0.1, wind))
    with pytest.raises(ConfigError, match="reading"):
        est.update(_obs(0, np.array([1.0, 2.0]), math.nan, wind))
    with pytest.raises(ValueError, match="min_sources"):
        SourceTermParams(max_sources=1, min_sources=2)
    with pytest.raises(ValueError, match="high"):
        UniformPrior(low=2.0, high=1.0)
