"""Earth Mover's Distance and source matching between point sets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.geometry.point_sets import earth_movers_distance, match_sources


def test_emd_of_equal_sets_is_the_mean_assignment_distance() -> None:
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    assert earth_movers_distance(a, a[::-1]) == 0.0
    assert earth_movers_distance(a, a + np.array([3.0, 4.0])) == pytest.approx(5.0)
    # the best assignment, not the given order
    b = np.array([[10.0, 1.0], [0.0, 1.0]])
    assert earth_movers_distance(a, b) == pytest.approx(1.0)


def test_emd_with_unequal_counts_moves_the_masses() -> None:
    # one estimate for two sources 2 m apart: half the mass travels 2 m
    assert earth_movers_distance([[0.0, 0.0]], [[0.0, 0.0], [2.0, 0.0]]) == pytest.approx(1.0)
    # an extra estimate 6 m from the only source: a third of the mass travels 6 m
    got = earth_movers_distance([[0.0, 0.0], [0.0, 0.0], [6.0, 0.0]], [[0.0, 0.0]])
    assert got == pytest.approx(2.0)
    # weights are normalised and used
    w = earth_movers_distance([[0.0], [4.0]], [[0.0]], a_weights=[3.0, 1.0])
    assert w == pytest.approx(1.0)
    # the general solver agrees with the assignment for equal counts
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0, 10, (4, 2)), rng.uniform(0, 10, (4, 2))
    lp = earth_movers_distance(a, b, a_weights=np.ones(4), b_weights=np.ones(4))
    assert lp == pytest.approx(earth_movers_distance(a, b), rel=1e-9)


def test_emd_of_an_empty_set_is_nan_and_bad_input_is_refused() -> None:
    assert math.isnan(earth_movers_distance(np.zeros((0, 2)), [[1.0, 1.0]]))
    with pytest.raises(ConfigError, match="b"):
        earth_movers_distance([[0.0, 0.0]], [[0.0, 0.0, 0.0]])
    with pytest.raises(ConfigError, match="a_weights"):
        earth_movers_distance([[0.0], [1.0]], [[0.0]], a_weights=[-1.0, 1.0])
    with pytest.raises(ConfigError, match="a"):
        earth_movers_distance([[math.nan, 0.0]], [[0.0, 0.0]])


def test_matching_counts_found_and_false_one_to_one() -> None:
    true = np.array([[0.0, 0.0], [10.0, 0.0]])
    # two estimates near the first source: one matches it, the other is false
    assert match_sources([[0.2, 0.0], [0.0, 0.3]], true, 1.0) == (1, 1)
    assert match_sources([[0.2, 0.0], [9.5, 0.0], [5.0, 5.0]], true, 1.0) == (2, 1)
    assert match_sources(np.zeros((0, 2)), true, 1.0) == (0, 0)
