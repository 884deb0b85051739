"""Pang & Farrell transport likelihood and the Poisson count likelihood."""

from __future__ import annotations

import math

import numpy as np
import pydantic
import pytest
from scipy.stats import poisson

from odorloc.core.errors import ConfigError
from odorloc.models.pang_farrell import (
    PangFarrellModel,
    PangFarrellParams,
    reference_detection_probability,
    wind_variance,
)
from odorloc.models.poisson import censored_poisson
from odorloc.models.poisson import poisson_log_pmf as poisson_log_likelihood

EXACT = PangFarrellParams(mu=0.9, sensor_area=0.01, min_wind_variance=0.0, p_floor=0.0)


def test_hand_computed_one_particle_two_records() -> None:
    # Records (oldest first): U_0 = (1.0, 0), U_1 = (0.5, 0); dt = 0.5 s; wind variance 0.02
    # per axis (given); robot at (1.0, 0.1); source hypothesis at (0, 0).
    # l = 0: s = (1.0 + 0.5) * 0.5 = 0.75 m in x, elapsed 1.0 s, var = 0.02 * 1.0 = 0.02 m^2
    #   delta = (1.0 - 0 - 0.75, 0.1) = (0.25, 0.1)
    #   p^R = exp(-(0.0625 + 0.01) / 0.04) / (2 pi 0.02) = 0.1632455 * 7.957747 = 1.2990665
    # l = 1: s = 0.5 * 0.5 = 0.25 m, elapsed 0.5 s, var = 0.01 m^2
    #   delta = (0.75, 0.1); p^R = exp(-0.5725 / 0.02) / (2 pi 0.01) = 5.8903e-12
    # p(z=0) = (1 - 0.9 * 0.01 * 1.2990665) * (1 - 0.009 * 5.89e-12) = 0.98830840
    # p(z=1) = 0.01169160
    model = PangFarrellModel(EXACT)
    wind = np.array([[1.0, 0.0], [0.5, 0.0]])
    robot = np.array([1.0, 0.1])
    hyp = np.array([[0.0, 0.0]])
    var = np.array([0.02, 0.02])
    p1 = model.detection_probability(robot, wind, 0.5, hyp, wind_var=var)
    assert p1.shape == (1,)
    assert p1[0] == pytest.approx(0.011691598610, rel=1e-9)
    ll1 = model.log_likelihood(True, robot, hyp, wind_window=wind, dt=0.5, wind_var=var)
    ll0 = model.log_likelihood(False, robot, hyp, wind_window=wind, dt=0.5, wind_var=var)
    assert ll1[0] == pytest.approx(math.log(0.011691598610), rel=1e-9)
    assert ll0[0] == pytest.approx(math.log(0.98830840139), rel=1e-9)
    shift, v = model.puff_geometry(wind, 0.5, var)
    np.testing.assert_allclose(shift, [[0.75, 0.0], [0.25, 0.0]])
    np.testing.assert_allclose(v, [[0.02, 0.02], [0.01, 0.01]])


@pytest.mark.parametrize("dim", [2, 3])
def test_vectorised_equals_reference_loop(dim: int) -> None:
    rng = np.random.default_rng(3)
    params = PangFarrellParams(sensor_area=0.05, initial_variance=0.01)
    model = PangFarrellModel(params)
    wind = np.tile(np.r_[0.3, 0.4, 0.0][:dim], (20, 1)) + rng.normal(0, 0.05, (20, dim))
    robot = np.r_[1.0, 1.5, 0.2][:dim]
    hyp = robot - np.r_[0.3, 0.4, 0.0][:dim] * rng.uniform(0, 10, (200, 1)) * 0.5
    hyp += rng.normal(0, 0.3, hyp.shape)
    fast = model.detection_probability(robot, wind, 0.5, hyp)
    ref = reference_detection_probability(robot, wind, 0.5, hyp, params)
    np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=1e-15)
    assert fast.max() > 10 * params.p_floor  # the comparison covers non-trivial values


def test_several_sensor_positions_match_single_calls() -> None:
    rng = np.random.default_rng(4)
    model = PangFarrellModel()
    wind = rng.normal([0.2, 0.3], 0.05, (20, 2))
    hyp = rng.uniform(0, 3, (50, 2))
    sensors = rng.uniform(0, 3, (4, 2))
    many = model.detection_probability(sensors, wind, 0.5, hyp)
    assert many.shape == (4, 50)
    for m, s in enumerate(sensors):
        np.testing.assert_allclose(many[m], model.detection_probability(s, wind, 0.5, hyp))


def test_upwind_hypothesis_is_more_likely_to_be_detected() -> None:
    # Steady wind +x at 0.4 m/s: odor from a source 1 m upwind (-x) of the robot arrives after
    # 2.5 s; a source 1 m crosswind never reaches it.
    model = PangFarrellModel(PangFarrellParams(p_floor=0.0))
    wind = np.tile([0.4, 0.0], (20, 1))
    robot = np.array([2.0, 1.0])
    hyp = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 1.0]])  # upwind, crosswind, downwind
    p = model.detection_probability(robot, wind, 0.5, hyp)
    assert p[0] > 100 * max(p[1], p[2])
    # Outcomes are complementary.
    l1 = model.log_likelihood(True, robot, hyp, wind_window=wind, dt=0.5)
    l0 = model.log_likelihood(False, robot, hyp, wind_window=wind, dt=0.5)
    np.testing.assert_allclose(np.exp(l1) + np.exp(l0), 1.0)


def test_floor_and_total_underflow_give_no_nan() -> None:
    wind = np.tile([1.0, 0.0], (20, 1))
    far = np.array([[-500.0, 300.0]])
    exact = PangFarrellModel(PangFarrellParams(p_floor=0.0)).log_likelihood(
        True, np.zeros(2), far, wind_window=wind, dt=0.5
    )
    assert exact[0] == -np.inf
    floored = PangFarrellModel(PangFarrellParams(p_floor=1e-3)).log_likelihood(
        True, np.zeros(2), far, wind_window=wind, dt=0.5
    )
    assert floored[0] == pytest.approx(math.log(1e-3))


def test_bad_input() -> None:
    model = PangFarrellModel()
    hyp = np.zeros((3, 2))
    with pytest.raises(ConfigError, match="wind_window"):
        model.detection_probability(np.zeros(2), np.zeros((5, 3)), 0.5, hyp)
    with pytest.raises(ConfigError, match="dt"):
        model.detection_probability(np.zeros(2), np.zeros((5, 2)), 0.0, hyp)
    with pytest.raises(ConfigError, match="sensor_positions"):
        model.detection_probability(np.zeros(3), np.zeros((5, 2)), 0.5, hyp)
    with pytest.raises(pydantic.ValidationError, match="mu"):
        PangFarrellParams(mu=1.5)


def test_wind_variance() -> None:
    w = np.array([[1.0, 0.0], [3.0, 0.0]])
    np.testing.assert_allclose(wind_variance(w), [1.0, 0.0])
    np.testing.assert_allclose(wind_variance(w, floor=0.01), [1.0, 0.01])
    np.testing.assert_allclose(wind_variance(w[:1], floor=0.2), [0.2, 0.2])


def test_poisson_matches_scipy_and_edge_cases() -> None:
    k = np.array([0, 1, 3, 7])
    lam = np.array([0.5, 2.0, 3.0, 0.1])
    np.testing.assert_allclose(poisson_log_likelihood(k, lam), poisson.logpmf(k, lam))
    assert poisson_log_likelihood(0, 0.0) == 0.0
    assert poisson_log_likelihood(2, 0.0) == -np.inf
    # One count against many hypotheses broadcasts to (N,).
    assert poisson_log_likelihood(2, np.ones(5)).shape == (5,)
    with pytest.raises(ConfigError, match="counts"):
        poisson_log_likelihood(-1, 1.0)
    with pytest.raises(ConfigError, match="expected_counts"):
        poisson_log_likelihood(1, -1.0)


def test_censored_poisson_classes() -> None:
    lam = np.array([0.0, 0.3, 2.5])
    p = censored_poisson(lam, 4)
    np.testing.assert_allclose(p.sum(axis=-1), 1.0, rtol=1e-14)
    np.testing.assert_allclose(p[:, :3], poisson.pmf(np.arange(3)[None], lam[:, None]), rtol=1e-12)
    np.testing.assert_allclose(p[:, 3], poisson.sf(2, lam), rtol=1e-12)
    assert p[0].tolist() == [1.0, 0.0, 0.0, 0.0]


def test_models_give_outcome_classes_for_planning() -> None:
    """Every model's outcome probabilities sum to one and agree with its log-likelihood."""
    from odorloc.models.gaussian import GaussianPlumeModel
    from odorloc.models.vergassola import VergassolaModel

    rng = np.random.default_rng(4)
    hyp = rng.uniform(0, 5, (50, 2))
    sensors = rng.uniform(0, 5, (3, 2))
    pf = PangFarrellModel(PangFarrellParams(sensor_area=0.05)).bind(
        wind_window=np.tile([0.4, 0.1], (10, 1)), dt=0.5
    )
    verg = VergassolaModel().bind(dt=1.0, direction=(0.0, -1.0), n_classes=6)
    gauss = GaussianPlumeModel().bind(wind=np.array([0.5, 0.0]))
    for model, values in ((pf, [False, True]), (verg, range(5)), (gauss, [False, True])):
        q = model.outcome_probabilities(sensors, hyp)
        assert q.shape[0] == 3 and q.shape[2] == 50
        np.testing.assert_allclose(q.sum(axis=1), 1.0, rtol=1e-10)
        for z, v in enumerate(values):
            ll = model.log_likelihood(v, sensors[0], hyp)
            np.testing.assert_allclose(np.exp(ll), q[0, z], rtol=1e-9, atol=1e-300)


def test_gaussian_detection_likelihood_stays_finite_in_the_far_tails() -> None:
    """A miss where the plume predicts many noise widths above the threshold is very unlikely
    but not impossible: its log-likelihood is log Phi(-x), not log(1 - Phi(x)) = -inf."""
    from scipy.special import log_ndtr

    from odorloc.models.gaussian import GaussianPlumeModel, GaussianReadingParams

    params = GaussianReadingParams(noise_std=0.02, threshold=1.0, release=5.0)
    model = GaussianPlumeModel(params)
    wind = np.array([1.0, 0.0])
    sensor = np.array([1.0, 0.0])
    # on the plume axis (far above the threshold), off the axis (20 widths above it) and far
    # downwind of the sensor (zero reading)
    hyp = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.6], [8.0, 0.0]])
    x = (model.predict(sensor, hyp, wind)[0] - params.threshold) / params.noise_std
    assert x[0] > 40 and x[1] > 40 and 15 < x[2] < 25 and x[3] < -40
    miss = model.log_likelihood(False, sensor, hyp, wind=wind)
    hit = model.log_likelihood(True, sensor, hyp, wind=wind)
    assert np.all(np.isfinite(miss)) and np.all(np.isfinite(hit))
    np.testing.assert_allclose(miss, log_ndtr(-x), rtol=1e-12)
    np.testing.assert_allclose(hit, log_ndtr(x), rtol=1e-12)
    # planning sees the same tail probabilities (not 1 - Phi(x) rounded to 0 or to 1e-16)
    q = model.outcome_probabilities(sensor[None], hyp, wind=wind)[0]
    np.testing.assert_allclose(q[0], np.exp(miss), rtol=1e-9)
    np.testing.assert_allclose(q[1], np.exp(hit), rtol=1e-9)
    assert q[0, 2] > 0  # Phi(-20) ~ 1e-89, where 1 - Phi(20) is exactly 0


def test_gaussian_bad_reading_and_conditions_name_the_field() -> None:
    from odorloc.models.gaussian import GaussianPlumeModel

    model = GaussianPlumeModel()
    hyp = np.zeros((2, 2))
    wind = np.array([1.0, 0.0])
    sensor = np.array([1.0, 0.0])
    for z in (float("nan"), float("inf"), "abc", None):
        with pytest.raises(ConfigError, match="reading"):
            model.log_likelihood(z, sensor, hyp, wind=wind)
    for bad in (np.array([np.nan, 0.0]), np.array([1.0, 0.0, 0.0])):
        with pytest.raises(ConfigError, match="sensor_positions"):
            model.log_likelihood(0.5, bad, hyp, wind=wind)
    for release in (float("nan"), -2.0):
        with pytest.raises(ConfigError, match="release"):
            model.log_likelihood(0.5, sensor, hyp, wind=wind, release=release)


def test_pang_farrell_rejects_non_finite_wind_and_bad_detections() -> None:
    model = PangFarrellModel()
    hyp = np.zeros((3, 2))
    sensor = np.array([1.0, 0.0])
    good = np.tile([1.0, 0.0], (4, 1))
    gap = good.copy()
    gap[2, 0] = np.nan  # one missing anemometer reading
    with pytest.raises(ConfigError, match="wind_window"):
        model.log_likelihood(False, sensor, hyp, wind_window=gap, dt=0.5)
    with pytest.raises(ConfigError, match="wind_window"):
        model.puff_geometry(gap, 0.5)
    for var in ([np.nan, 0.1], [0.1, -0.1], [0.1, 0.1, 0.1]):
        with pytest.raises(ConfigError, match="wind_var"):
            model.log_likelihood(False, sensor, hyp, wind_window=good, dt=0.5, wind_var=var)
    with pytest.raises(ConfigError, match="sensor_positions"):
        model.log_likelihood(False, np.array([np.nan, 0.0]), hyp, wind_window=good, dt=0.5)
    for z in (2, -1, float("nan"), "yes"):
        with pytest.raises(ConfigError, match="detection"):
            model.log_likelihood(z, sensor, hyp, wind_window=good, dt=0.5)
    # 0/1 and numpy booleans remain valid detections
    one = model.log_likelihood(1, sensor, hyp, wind_window=good, dt=0.5)
    np.testing.assert_array_equal(
        one, model.log_likelihood(np.bool_(True), sensor, hyp, wind_window=good, dt=0.5)
    )


def _outcome_cases() -> dict[str, list[tuple[object, np.ndarray, np.ndarray, dict]]]:
    """Per registered model: (model, sensors, hypotheses, conditions), in 2-D and 3-D where the
    model has both, with class counts fixed and chosen from the means."""
    from odorloc.models.gaussian import GaussianPlumeModel
    from odorloc.models.kernels import HAVE_NUMBA
    from odorloc.models.lattice import IsotropicHitModel, IsotropicHitParams
    from odorloc.models.lattice_windy import WindyHitModel, WindyHitParams
    from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams

    rng = np.random.default_rng(11)
    s2, h2 = rng.uniform(0, 5, (3, 2)), rng.uniform(0, 5, (40, 2))
    s3, h3 = rng.uniform(0, 5, (3, 3)), rng.uniform(0, 5, (40, 3))
    backends = ("numpy", "numba") if HAVE_NUMBA else ("numpy",)
    verg = [VergassolaModel(VergassolaModelParams(backend=b)) for b in backends]
    lattice = IsotropicHitModel(IsotropicHitParams(length=5.0, intensity=30.0, cell=1.0))
    return {
        "gaussian": [(GaussianPlumeModel(), s2, h2, {"wind": np.array([0.5, 0.0])})],
        "pang-farrell": [
            (PangFarrellModel(), s2, h2, {"wind_window": np.tile([0.4, 0.1], (10, 1)), "dt": 0.5})
        ],
        "vergassola": [
            (m, s, h, {"dt": 1.0, **fixed})
            for m in verg
            for s, h in ((s2, h2), (s3, h3))
            for fixed in ({}, {"n_classes": 7})
        ],
        "lattice-isotropic": [(lattice, s2, h2, {}), (lattice, s3, h3, {})],
        "lattice-windy": [(WindyHitModel(WindyHitParams(n_hits=n)), s2, h2, {}) for n in (2, 4)],
        **_source_term_cases(s2, h2, s3, h3),
    }


def _source_term_cases(s2, h2, s3, h3):  # type: ignore[no-untyped-def]
    """The source-term models over plain positions (single sources of the default rate)."""
    from odorloc.models.source_term import (
        AdapterSourceTermModel,
        GaussianSourceTermModel,
        GaussianSourceTermParams,
        VergassolaSourceTermModel,
    )

    wind2, wind3 = np.array([0.5, 0.0]), np.array([0.0, -1.0, 0.0])
    gauss = [
        GaussianSourceTermModel(GaussianSourceTermParams(reading=r, threshold=0.2))
        for r in ("censored", "detection")
    ]
    return {
        "ste-gaussian": [
            (m, s, h, {"wind": w}) for m in gauss for s, h, w in ((s2, h2, wind2), (s3, h3, wind3))
        ],
        "ste-vergassola": [(VergassolaSourceTermModel(), s3, h3, {"dt": 1.0, "wind": wind3})],
        "ste-adapter": [(AdapterSourceTermModel(), s2, h2, {"wind": wind2})],
    }


def test_outcome_values_match_the_outcome_classes_of_every_model() -> None:
    """``outcome_values`` names one reading per class of ``outcome_probabilities`` (same
    arguments), also where the class count depends on the means or on the dimension."""
    from odorloc.core import registry

    cases = _outcome_cases()
    assert set(cases) == set(registry.names("model"))
    for name, rows in cases.items():
        for model, sensors, hyp, cond in rows:
            z = model.outcome_probabilities(sensors, hyp, **cond).shape[1]
            assert len(model.outcome_values(sensors, hyp, **cond)) == z, (name, cond)
            bound = model.bind(**cond)
            assert len(bound.outcome_values(sensors, hyp)) == z, (name, cond)
    # the cases cover class counts other than the ones the values used to assume
    # (``max_classes`` for adaptive counts, the 2-D count of OTTO's rule)
    verg = cases["vergassola"][0][0]
    assert any(
        len(m.outcome_values(s, h, **c)) < verg.params.max_classes
        for m, s, h, c in cases["vergassola"]
    )
    lat = cases["lattice-isotropic"][0][0]
    assert lat.n_classes(2) != lat.n_classes(3)


def test_vergassola_release_of_the_wrong_length_names_the_field() -> None:
    from odorloc.models.kernels import HAVE_NUMBA
    from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams

    hyp = np.ones((5, 3))
    for b in ("numpy", "numba") if HAVE_NUMBA else ("numpy",):
        model = VergassolaModel(VergassolaModelParams(backend=b))
        with pytest.raises(ConfigError, match="release"):
            model.outcome_probabilities(np.zeros((1, 3)), hyp, dt=1.0, release=np.ones(3))
        with pytest.raises(ConfigError, match="release"):
            model.log_likelihood(1, np.zeros(3), hyp, dt=1.0, release=np.ones((2, 5)))
        # one rate, or one per source, stay accepted
        for release in (2.0, np.ones(1), np.full(5, 2.0)):
            assert model.log_likelihood(1, np.zeros(3), hyp, dt=1.0, release=release).shape == (5,)
