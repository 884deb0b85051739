"""The windy lattice problem of otto-benchmark: its hit law and the episode start."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.engine.episode import Episode
from odorloc.models.lattice_windy import WindyHitModel, WindyHitParams, windy_length
from odorloc.scenarios import get_scenario


def test_mean_hits_match_the_formula() -> None:
    """mu = R / d exp(V x / 2 - d / lambda), lambda = sqrt((tau / V^2) / (1 + tau / 4))."""
    m = WindyHitModel(WindyHitParams(rate=2.5, wind=2.0, tau=150.0))
    lam = math.sqrt((150.0 / 4.0) / (1.0 + 150.0 / 4.0))
    assert windy_length(2.0, 150.0) == pytest.approx(lam, rel=1e-12)
    # sensor (3, 4) cells downwind-right of a source at the origin: d = 5, x = 3
    mu = m.mean_hits([[3.0, 4.0]], [[0.0, 0.0]])[0, 0]
    assert mu == pytest.approx(2.5 / 5.0 * math.exp(0.5 * 2.0 * 3.0 - 5.0 / lam), rel=1e-12)
    # the same distance upwind of the source gets exp(-V x) as many hits
    up = m.mean_hits([[-3.0, 4.0]], [[0.0, 0.0]])[0, 0]
    assert up / mu == pytest.approx(math.exp(-2.0 * 3.0), rel=1e-12)


def test_binary_classes_sum_to_one_and_match_poisson() -> None:
    m = WindyHitModel()
    hyp = np.array([[0.0, 0.0], [10.0, 3.0], [-4.0, 1.0]])
    p = m.outcome_probabilities(np.array([[5.0, 2.0]]), hyp)
    assert p.shape == (1, 2, 3)
    np.testing.assert_allclose(p.sum(axis=1), 1.0, rtol=1e-12)
    mu = m.mean_hits([[5.0, 2.0]], hyp)[0]
    np.testing.assert_allclose(p[0, 0], np.exp(-mu), rtol=1e-12)
    np.testing.assert_allclose(np.exp(m.log_likelihood(3, np.array([5.0, 2.0]), hyp)), p[0, 1])


def test_episode_start_draws_the_source_upwind_after_one_hit() -> None:
    """The start reading is one hit; the source follows b0 ∝ P(1 | cell), which puts it upwind
    (x_source < x_agent: the wind blows along +x) far more often than not; same seed, same
    source."""
    sc = get_scenario("lattice-windy-medium")
    xs = []
    for seed in range(40):
        ep = Episode(sc)
        obs = ep.reset(seed, 0)
        assert obs[0].gas == 1
        xs.append(ep.sources[0][0])
        if seed == 3:
            again = Episode(sc)
            again.reset(seed, 0)
            np.testing.assert_array_equal(again.sources, ep.sources)
    assert np.mean(np.asarray(xs) < 65.5) > 0.9


def test_bad_settings_are_refused() -> None:
    sc = get_scenario("lattice-windy-medium").with_overrides({"world.plume.initial_hit": 2})
    with pytest.raises(ConfigError, match="initial_hit"):
        Episode(sc)
