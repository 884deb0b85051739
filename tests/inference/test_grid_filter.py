"""Grid Bayes filter: Bayes updates against hand-worked posteriors, exclusions, releases,
entropy units, obstacles and bad input."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.grid_filter import GridFilter, grid_entropy
from odorloc.models.base import MeasurementModel
from odorloc.models.lattice import IsotropicHitModel, IsotropicHitParams, tabulate


class TwoLevel(MeasurementModel):
    """A hand model: p(detection) = 0.8 for hypotheses with x < 1 m, else 0.2 (release scales
    nothing but the odds: p = min(0.8 * release, 0.99) on the left)."""

    def p1(self, hyp: np.ndarray, release: float = 1.0) -> np.ndarray:
        return np.where(hyp[:, 0] < 1.0, min(0.8 * release, 0.99), 0.2)

    def log_likelihood(
        self, z: Any, sensor_position: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        p1 = self.p1(np.atleast_2d(hypotheses), conditions.get("release", 1.0))
        return np.log(p1 if z else 1.0 - p1)

    def outcome_probabilities(
        self, sensor_positions: np.ndarray, hypotheses: np.ndarray, **conditions: Any
    ) -> np.ndarray:
        p1 = self.p1(np.atleast_2d(hypotheses), conditions.get("release", 1.0))
        q = np.stack([1 - p1, p1])[None]
        return np.repeat(q, len(np.atleast_2d(sensor_positions)), axis=0)


GRID = CellGrid((0.0, 0.0), 1.0, (2, 2))  # centres x = 0.5 (left) and 1.5 (right)


def test_bayes_update_against_hand_posterior() -> None:
    f = GridFilter(GRID)
    np.testing.assert_allclose(f.prob, 0.25)
    f.observe(TwoLevel(), True, np.zeros(2))
    # prior 1/4 each; likelihoods 0.8 (left column) and 0.2 (right): 0.8 / (2 * 0.8 + 2 * 0.2)
    np.testing.assert_allclose(f.prob, [[0.4, 0.4], [0.1, 0.1]])
    f.observe(TwoLevel(), False, np.zeros(2))
    # then a miss: 0.4 * 0.2 vs 0.1 * 0.8 -> equal
    np.testing.assert_allclose(f.prob, 0.25)
    assert f.entropy("bits") == pytest.approx(2.0)
    assert f.entropy("nats") == pytest.approx(2.0 * math.log(2.0))


def test_release_marginalised_on_a_grid() -> None:
    f = GridFilter(GRID, releases=(0.5, 1.0))
    f.observe(TwoLevel(), True, np.zeros(2))
    # joint prior 1/8; left likelihood 0.4 (Q = 0.5) or 0.8 (Q = 1), right 0.2 for both
    like = np.array([[0.4, 0.4, 0.2, 0.2], [0.8, 0.8, 0.2, 0.2]])
    post = like / like.sum()
    np.testing.assert_allclose(f.joint.reshape(2, -1), post)
    np.testing.assert_allclose(f.release_prob, post.sum(axis=1))
    np.testing.assert_allclose(f.prob.reshape(-1), post.sum(axis=0))
    assert f.entropy(joint=True) == pytest.approx(grid_entropy(post))


def test_exclusions_and_restarts() -> None:
    f = GridFilter(GRID)
    f.exclude_near(np.array([0.4, 0.4]), 0.2)  # only the containing cell
    assert f.prob[0, 0] == 0.0
    np.testing.assert_allclose(f.prob.sum(), 1.0)
    np.testing.assert_allclose(f.prob[f.prob > 0], 1 / 3)
    # a likelihood that is zero everywhere left: the belief restarts over admissible cells
    f.update(np.full((2, 2), -np.inf))
    assert f.restarts == 1
    assert f.prob[0, 0] == 0.0
    np.testing.assert_allclose(f.prob[f.prob > 0], 1 / 3)
    # excluding every cell leaves no hypothesis: an error, not a silent uniform belief
    with pytest.raises(ConfigError, match="excluded"):
        GridFilter(GRID).exclude(np.ones((2, 2), bool))


def test_near_takes_cells_within_the_radius() -> None:
    f = GridFilter(CellGrid((0.0, 0.0), 0.5, (6, 6)))
    m = f.near(np.array([1.25, 1.25]), 0.6)
    centres = f.centres.reshape(6, 6, 2)
    want = np.linalg.norm(centres - [1.25, 1.25], axis=-1) <= 0.6
    np.testing.assert_array_equal(m, want)
    m3 = GridFilter(CellGrid((0.0, 0.0, 0.0), 1.0, (3, 3, 3))).near(np.array([0.3, 0.3, 0.3]), 0.1)
    assert m3.sum() == 1 and m3[0, 0, 0]


def test_table_update_equals_the_model_update() -> None:
    m = IsotropicHitModel(IsotropicHitParams(length=2.0, intensity=2.0))
    grid = CellGrid((0.0, 0.0), 1.0, (9, 9))
    t = tabulate(m, 1.0, (8, 8))
    a, b = GridFilter(grid), GridFilter(grid)
    for cell, z in (((4, 4), 1), ((3, 4), 0), ((3, 5), 3), ((0, 8), 2)):
        pos = grid.center(cell)[0]
        a.exclude_near(pos, 0.5)
        b.exclude_near(pos, 0.5)
        a.observe_table([t], z, cell)
        b.observe(m, z, pos)
        np.testing.assert_allclose(a.prob, b.prob, rtol=1e-10, atol=1e-300)


def test_obstacles_are_not_hypotheses() -> None:
    arena = Arena.box((0.0, 0.0), (4.0, 2.0), 0.5).with_boxes([((1.0, 0.0), (2.0, 2.0))])
    f = GridFilter.over_arena(arena)
    assert f.grid.shape == (8, 4)
    blocked = ~arena.is_free(f.centres).reshape(8, 4)
    assert blocked.any()
    np.testing.assert_array_equal(f.prob[blocked], 0.0)
    coarse = GridFilter.over_arena(arena, cell_size=1.0, region=((0.0, 0.0), (2.0, 2.0)))
    assert coarse.grid.shape == (2, 2)


def test_bad_input() -> None:
    f = GridFilter(GRID)
    with pytest.raises(ConfigError, match="log_likelihood"):
        f.update(np.zeros((3, 3)))
    with pytest.raises(ConfigError, match="NaN"):
        f.update(np.full((2, 2), np.nan))
    with pytest.raises(ConfigError, match="free"):
        GridFilter(GRID, free=np.zeros((2, 2), bool))
    with pytest.raises(ConfigError, match="releases"):
        GridFilter(GRID, releases=(1.0, -2.0))
    with pytest.raises(ConfigError, match="unit"):
        f.entropy("decibans")  # type: ignore[arg-type]
    t = tabulate(IsotropicHitModel(), 1.0, (1, 1))
    with pytest.raises(ConfigError, match="z_class"):
        f.observe_table([t], 9, (0, 0))
    with pytest.raises(ConfigError, match="table"):
        f.observe_table([t, t], 0, (0, 0))


def test_priors_without_usable_mass_are_refused() -> None:
    """An infinite release weight used to turn the belief uniform over every cell, obstacles
    included; a position prior of zero on every free cell was reported as excluded cells."""
    free = np.array([[True, False], [True, True]])
    with pytest.raises(ConfigError, match="release_prior"):
        GridFilter(GRID, free=free, releases=(1.0, 2.0), release_prior=(1.0, np.inf))
    with pytest.raises(ConfigError, match="log_prior"):
        GridFilter(GRID, free=free, log_prior=np.where(free, -np.inf, 0.0))
    f = GridFilter(GRID, free=free, releases=(1.0, 2.0), release_prior=(1.0, 3.0))
    np.testing.assert_allclose(f.release_prob, [0.25, 0.75])
    assert f.prob[0, 1] == 0.0 and f.restarts == 0
