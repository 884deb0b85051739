"""PUGL's moves as Markov moves: the measurement history, the reversible moves against a known
posterior, and the printed moves' drift (multi-UAV paper, eqs. 15-17)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.inference.particles.collaborative import fit_payload
from odorloc.inference.particles.history import MeasurementHistory
from odorloc.inference.particles.pugl import (
    PriorSupport,
    env_position_update,
    gbest_gaussian,
    reversible_col_move,
    reversible_env_move,
)
from odorloc.inference.particles.team_estimators import ColPFEstimator, ColPFParams, Measurement
from odorloc.models.base import MeasurementModel
from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams

#: A 2-D toy: source at (10, 12) in 30 x 20 m, wind towards -y, eight 1 s Poisson counts taken
#: downwind (drawn once from the model with a fixed seed). Its posterior under a uniform prior
#: is elongated along the wind: mean about (11.1, 13.7) m, spread about (1.2, 3.2) m.
ARENA = Arena.box((0.0, 0.0), (30.0, 20.0), 0.5)
DOWN = np.array([0.0, -1.0])
SENSORS = np.array([[x, y] for x in (4.0, 8.0, 12.0, 16.0) for y in (2.0, 6.0)])


def _toy() -> tuple[VergassolaModel, MeasurementHistory, np.ndarray]:
    model = VergassolaModel(VergassolaModelParams(backend="numpy"))
    mu = model.rate(SENSORS, np.array([[10.0, 12.0]]))[:, 0]
    counts = np.random.default_rng(5).poisson(mu).astype(float)
    history = MeasurementHistory(2)
    for s, c in zip(SENSORS, counts, strict=True):
        history.append(c, s, 1.0, DOWN)
    return model, history, counts


def _grid_posterior(
    model: VergassolaModel, history: MeasurementHistory
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The posterior on a 0.1 m grid: its points, weights, mean and per-axis spread."""
    gx, gy = np.meshgrid(np.arange(0.05, 30.0, 0.1), np.arange(0.05, 20.0, 0.1), indexing="ij")
    g = np.column_stack([gx.ravel(), gy.ravel()])
    ll = history.log_likelihood(model, g)
    w = np.exp(ll - ll.max())
    w /= w.sum()
    mean = w @ g
    return g, w, mean, np.sqrt(w @ (g - mean) ** 2)


def _posterior_samples(n: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    model, history, _ = _toy()
    g, w, mean, sd = _grid_posterior(model, history)
    x = g[rng.choice(len(g), size=n, p=w)] + rng.uniform(-0.05, 0.05, (n, 2))
    return model, history, x, mean, sd


def test_the_toy_posterior_is_what_the_tests_assume() -> None:
    model, history, counts = _toy()
    _, _, mean, sd = _grid_posterior(model, history)
    assert counts.sum() > 10  # informative, not a flat likelihood
    np.testing.assert_allclose(mean, [11.1, 13.7], atol=0.1)
    np.testing.assert_allclose(sd, [1.2, 3.2], atol=0.1)


def test_reversible_moves_keep_a_known_posterior() -> None:
    """Particles drawn from the exact posterior stay distributed as it after 20 sweeps of both
    reversible moves: the mean within 0.1 and the spread within 10 % of the grid's spread on
    each axis (the Monte Carlo error of 2 000 particles is about 0.02 spreads and 1.6 %)."""
    rng = np.random.default_rng(3)
    model, history, x, mean, sd = _posterior_samples(2000, rng)
    support = PriorSupport(ARENA)

    def target(p: np.ndarray) -> np.ndarray:
        return history.log_likelihood(model, p)

    ll = target(x)
    # an independence proposal deliberately off the posterior (the acceptance corrects it)
    centre, cov = np.array([14.0, 9.0]), np.diag([16.0, 25.0])
    accepted = {"env": 0, "col": 0}
    for _ in range(20):
        res = reversible_env_move(x, ll, -DOWN, 2.0, rng, target, support)
        x, ll = res.positions, res.log_likelihood
        accepted["env"] += int(res.accepted.sum())
        res = reversible_col_move(x, ll, centre, cov, rng, target, support)
        x, ll = res.positions, res.log_likelihood
        accepted["col"] += int(res.accepted.sum())
    assert all(0.05 * 20 * 2000 < a < 0.95 * 20 * 2000 for a in accepted.values())
    assert np.all(np.abs(x.mean(axis=0) - mean) < 0.1 * sd)
    assert np.all(np.abs(x.std(axis=0) / sd - 1.0) < 0.10)
    np.testing.assert_allclose(ll, target(x))  # the carried log-likelihood is the particles'


def test_printed_moves_drift_off_the_same_posterior() -> None:
    """The same start and number of sweeps with eq. 16 as printed (unjudged upwind steps):
    the mean moves upwind by more than a spread along the wind."""
    rng = np.random.default_rng(3)
    _, _, x, mean, sd = _posterior_samples(2000, rng)
    for _ in range(20):
        x = env_position_update(x, np.arange(len(x)), -DOWN, rng, step=2.0, reading="invariant")
        x = ARENA.clip(x)
    drift = x.mean(axis=0) - mean
    assert drift[1] > sd[1]
    assert abs(drift[0]) < 0.1 * sd[0]  # along the wind only


@pytest.mark.parametrize("move", ["printed", "reversible"])
def test_colpf_estimator_against_the_known_posterior(move: str) -> None:
    """The estimator fed the toy's eight counts, one per iteration (2 000 particles, resampled
    without roughening, PUGL on N_s = N particles at these iterations): with reversible moves
    its weighted mean lies within 0.25 spreads of the posterior's on both axes; with the printed
    moves it lies more than a spread upwind."""
    model, history, counts = _toy()
    _, _, mean, sd = _grid_posterior(model, history)
    ctx = SearchContext(arena=ARENA, dt=1.0, agent_ids=(0,), start=[[2.0, 1.0]], speed_limits=[1.0])
    est = ColPFEstimator(
        ColPFParams(
            n_particles=2000,
            n_max=2000,
            n_min=2000,
            adaptive_count=False,
            col_pu=False,
            resampler={"type": "low-variance", "jitter_std": 0.0},
            pugl_move=move,
        )
    )
    rng = np.random.default_rng(17)
    est.reset(ctx, model, rng)
    for k, (s, c) in enumerate(zip(SENSORS, counts, strict=True), start=1):
        est.update(Measurement(c, s, 1.0, k, DOWN), {}, rng)
    got = est.estimate()
    if move == "reversible":
        assert np.all(np.abs(got - mean) < 0.25 * sd)
        assert est.acceptance()["env"] > 0.2
    else:
        assert got[1] - mean[1] > 1.0 * sd[1]


def test_a_proposal_outside_the_prior_is_rejected_not_projected() -> None:
    """Particles against the upwind wall: a step beyond it leaves the particle where it was
    (a projection would pile particles on the wall)."""
    model, history, _ = _toy()
    x = np.column_stack([np.linspace(5.0, 15.0, 200), np.full(200, 19.9)])

    def target(p: np.ndarray) -> np.ndarray:
        return history.log_likelihood(model, p)

    res = reversible_env_move(
        x, target(x), -DOWN, 2.0, np.random.default_rng(0), target, PriorSupport(ARENA)
    )
    stayed = ~res.accepted
    assert stayed.any() and res.accepted.any()
    np.testing.assert_array_equal(res.positions[stayed], x[stayed])
    assert np.all(res.positions[:, 1] < 20.0)
    assert not np.any(res.positions[:, 1] == 20.0)
    # a search region narrower than the arena bounds the prior too
    region = PriorSupport(ARENA, ((0.0, 0.0), (30.0, 15.0)))
    assert region.contains(np.array([[5.0, 14.0], [5.0, 16.0]])).tolist() == [True, False]


def test_gbest_gaussian_is_the_weighted_mixture_moments() -> None:
    means = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0]])
    covs = np.array([np.eye(3), 3 * np.eye(3)])
    g, cov = gbest_gaussian(means, covs, np.array([0.25, 0.75]), floor=0.0)
    np.testing.assert_allclose(g, [3.0, 0.0, 0.0])
    # within: 0.25 * 1 + 0.75 * 3; between along x: 0.25 * 9 + 0.75 * 1
    np.testing.assert_allclose(np.diag(cov), [2.5 + 3.0, 2.5, 2.5])
    _, floored = gbest_gaussian(means, covs, np.array([0.25, 0.75]), floor=1.0)
    np.testing.assert_allclose(floored - cov, np.eye(3))
    assert gbest_gaussian(means, covs, np.zeros(2)) is None


# ----------------------------------------------------------------------------- history
def test_history_keeps_the_latest_readings_when_bounded() -> None:
    h = MeasurementHistory(3, capacity=4)
    for k in range(10):
        h.append(float(k), [float(k), 0.0, 0.0], 1.0, None, 0.5 if k % 2 else 1.0)
    assert len(h) == 4 and h.total == 10
    a = h.arrays()
    assert a["counts"].tolist() == [6.0, 7.0, 8.0, 9.0]  # oldest first
    assert a["exponents"].tolist() == [1.0, 0.5, 1.0, 0.5]
    assert np.isnan(a["directions"]).all()
    unbounded = MeasurementHistory(3)
    for k in range(200):  # past the first allocation
        unbounded.append(1.0, [0.0, 0.0, float(k % 30)], 1.0)
    assert len(unbounded) == unbounded.total == 200
    h.clear()
    assert len(h) == 0 and h.log_likelihood(VergassolaModel(), np.zeros((5, 3))).tolist() == [0] * 5


@pytest.mark.parametrize("capacity", [None, 4, 5])
def test_history_latest_are_the_readings_appended_last(capacity: int | None) -> None:
    """``latest(k)``: the last ``k`` readings, oldest first, before and after a bounded ring
    wraps (and exactly when it comes round); ``k`` beyond the readings held is refused."""
    h = MeasurementHistory(3, capacity=capacity)
    for n in range(1, 13):
        h.append(float(n), [float(n), 1.0, 2.0], 0.5 * n, [0.0, 1.0, 0.0] if n % 3 else None, 1.0)
        a = h.arrays()
        for k in range(len(h) + 1):
            counts, where, dts, dirs, exps = h.latest(k)
            np.testing.assert_array_equal(counts, a["counts"][len(h) - k :])
            np.testing.assert_array_equal(where, a["positions"][len(h) - k :])
            np.testing.assert_array_equal(dts, a["dts"][len(h) - k :])
            np.testing.assert_array_equal(dirs, a["directions"][len(h) - k :])
            np.testing.assert_array_equal(exps, a["exponents"][len(h) - k :])
        assert h.latest(1)[0].tolist() == [float(n)]
        with pytest.raises(ConfigError, match=r"^k: "):
            h.latest(len(h) + 1)


def test_a_bounded_history_judges_by_the_latest_readings_only() -> None:
    model = VergassolaModel(VergassolaModelParams(backend="numpy"))
    x = np.array([[10.0, 30.0, 25.0], [50.0, 20.0, 10.0]])
    full, last = MeasurementHistory(3), MeasurementHistory(3, capacity=3)
    readings = [(float(k % 3), [5.0 * k, 10.0, 5.0]) for k in range(8)]
    for c, s in readings:
        full.append(c, s, 1.0)
        last.append(c, s, 1.0)
    tail = MeasurementHistory(3)
    for c, s in readings[-3:]:
        tail.append(c, s, 1.0)
    np.testing.assert_allclose(last.log_likelihood(model, x), tail.log_likelihood(model, x))
    assert not np.allclose(full.log_likelihood(model, x), tail.log_likelihood(model, x))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"count": -1.0}, "count"),
        ({"dt": 0.0}, "dt"),
        ({"exponent": math.nan}, "exponent"),
        ({"position": [1.0, math.nan, 0.0]}, "position"),
    ],
)
def test_history_refuses_bad_readings(kwargs: dict, field: str) -> None:
    args = {"count": 1.0, "position": [1.0, 2.0, 3.0], "dt": 1.0, **kwargs}
    with pytest.raises(ConfigError, match=rf"^{field}: "):
        MeasurementHistory(3).append(**args)
    with pytest.raises(ConfigError, match=r"^history: "):
        MeasurementHistory(3, capacity=0)


def test_each_reading_is_judged_under_its_own_conditions() -> None:
    """The history's log-likelihood is the sum of each reading's own likelihood, with its own
    exposure and wind direction (NaN: the model's), counted with its exponent."""
    model = VergassolaModel(VergassolaModelParams(sensor_radius=3.5, backend="numpy"))
    rng = np.random.default_rng(2)
    x = rng.uniform([0, 0, 0], [100, 60, 30], (50, 3))
    h = MeasurementHistory(3)
    readings = [
        (2.0, [10.0, 20.0, 25.0], 1.0, np.array([0.0, -1.0, 0.0]), 1.0),
        (0.0, [30.0, 10.0, 5.0], 2.5, np.array([0.6, -0.8, 0.0]), 0.4),
        (1.0, [12.0, 25.0, 20.0], 1.0, None, 0.0),
        (3.0, [11.0, 27.0, 24.0], 0.5, None, 0.9),
    ]
    expected = np.zeros(len(x))
    for c, s, dt, direction, e in readings:
        h.append(c, s, dt, direction, e)
        cond = {"dt": dt} if direction is None else {"dt": dt, "direction": direction}
        if e > 0:
            expected += e * model.log_likelihood(c, np.array(s), x, **cond)
    np.testing.assert_allclose(h.log_likelihood(model, x), expected, rtol=1e-12)
    # the base class's loop over readings gives the same
    arrays = h.arrays()
    base = MeasurementModel.prepared_log_likelihood(
        model,
        MeasurementModel.prepare_readings(
            model,
            arrays["counts"],
            arrays["positions"],
            arrays["exponents"],
            {"dt": arrays["dts"], "direction": arrays["directions"]},
        ),
        x,
    )
    np.testing.assert_allclose(base, expected, rtol=1e-12)


def test_a_neighbours_reading_keeps_its_own_conditions() -> None:
    """A neighbour that measured another wind and exposure is weighed under them, not under
    the receiver's: the weights of two filters that differ only in the neighbour's message
    conditions differ, and match the hand-made sum."""
    model = VergassolaModel(VergassolaModelParams(sensor_radius=3.5, backend="numpy"))
    ctx = SearchContext(
        arena=Arena.box((0.0, 0.0, 0.0), (100.0, 60.0, 30.0), 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[[10.0, 10.0, 5.0]],
        speed_limits=[1.0],
    )
    own = Measurement(1.0, np.array([10.0, 20.0, 20.0]), 1.0, 1, np.array([0.0, -1.0, 0.0]))
    weights = {}
    for name, dt, direction in (("same", 1.0, [0.0, -1.0, 0.0]), ("own", 3.0, [0.8, -0.6, 0.0])):
        est = ColPFEstimator(
            ColPFParams(env_pu="off", col_pu=False, adaptive_count=False, resample_threshold=0.0)
        )
        est.reset(ctx, model, np.random.default_rng(4))
        x0 = est.pf.positions.copy()
        mean, cov = est.fit
        inbox = {1: fit_payload(mean, cov, 2.0, [15.0, 18.0, 22.0], True, dt, direction)}
        est.update(own, inbox, np.random.default_rng(5))
        ll = model.log_likelihood(own.count, own.position, x0, **own.conditions())
        ll = ll + model.log_likelihood(
            2.0, np.array([15.0, 18.0, 22.0]), x0, dt=dt, direction=np.array(direction)
        )
        w = np.exp(ll - ll.max())
        np.testing.assert_allclose(est.pf.weights, w / w.sum(), rtol=1e-9, atol=1e-15)
        weights[name] = est.pf.weights
    assert not np.allclose(weights["same"], weights["own"])


def test_literal_env_pu_has_no_reversible_form() -> None:
    with pytest.raises(ValueError, match="env_pu: literal"):
        ColPFParams(env_pu="literal")
    assert ColPFParams(env_pu="literal", pugl_move="printed").env_pu == "literal"
