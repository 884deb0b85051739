"""The isotropic lattice hit model of infotaxis, the lattice problem's constants and offset tables:
against closed forms and the check values of OTTO's own classes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import k0
from scipy.stats import poisson

from odorloc.core.errors import ConfigError
from odorloc.models.lattice import (
    IsotropicHitModel,
    IsotropicHitParams,
    auto_grid_size,
    auto_n_hits,
    auto_step_cap,
    initial_belief,
    initial_hit_probabilities,
    isotropic_mean_hits,
    tabulate,
)
from odorloc.models.vergassola import VergassolaModel, VergassolaModelParams, vergassola_rate
from odorloc.papers.infotaxis.reference import CHECKS

SETTING = {"2d-l1-i1": (1.0, 1.0), "2d-l2-i2": (2.0, 2.0)}


def test_mean_hits_closed_forms() -> None:
    d = np.array([1.0, 2.0, 3.5, 10.0])
    # 2-D: I K0(d / lambda) / ln(lambda / a), a = dx / 2
    np.testing.assert_allclose(
        isotropic_mean_hits(d, 2.0, 1.5, 1.0, 2), 1.5 * k0(d / 2.0) / math.log(4.0), rtol=1e-12
    )
    # 3-D: I a exp(-d / lambda) / d
    np.testing.assert_allclose(
        isotropic_mean_hits(d, 2.0, 1.5, 1.0, 3), 1.5 * 0.5 * np.exp(-d / 2.0) / d, rtol=1e-12
    )
    # metres: a lattice of 0.5 m cells with lambda = 1 m is the lattice of 1 m cells, lambda 2 m
    np.testing.assert_allclose(
        isotropic_mean_hits(d / 2, 1.0, 1.0, 0.5, 2), isotropic_mean_hits(d, 2.0, 1.0, 1.0, 2)
    )


def test_mean_hits_are_the_vergassola_rate_in_still_air() -> None:
    pts = np.array([[1.0, 0.0, 0.0], [0.0, 3.0, 1.0]])
    rate = vergassola_rate(pts, np.zeros((1, 3)), 2.0, V=0.0, D=1.0, tau=4.0, a=0.5)[:, 0]
    d = np.linalg.norm(pts, axis=1)
    np.testing.assert_allclose(isotropic_mean_hits(d, 2.0, 2.0, 1.0, 3), rate, rtol=1e-13)


@pytest.mark.parametrize("key", list(SETTING))
def test_otto_check_values(key: str) -> None:
    L, intensity = SETTING[key]
    ref = CHECKS[key]
    z = auto_n_hits(L, intensity, 1.0, 2)
    assert z == ref["n_hits"]
    assert isotropic_mean_hits(1.0, L, intensity, 1.0, 2) == pytest.approx(ref["mu1"], rel=1e-11)
    m = IsotropicHitModel(IsotropicHitParams(length=L, intensity=intensity))
    q = m.outcome_probabilities(np.zeros((1, 2)), np.array([[1.0, 0.0], [2.0, 0.0]]))
    np.testing.assert_allclose(q[0, :, 0], ref["p_hit_d1"], atol=1e-9)
    if "p_hit_d2" in ref:
        np.testing.assert_allclose(q[0, :, 1], ref["p_hit_d2"], atol=1e-9)
    np.testing.assert_allclose(
        initial_hit_probabilities(L, intensity, 1.0, 2, z), ref["p_h0"], atol=1e-9
    )
    n = auto_grid_size(L, intensity, 1.0, 2, z)
    assert n == ref["n_grid"]
    assert auto_step_cap(L, intensity, 1.0, 2, n) == ref["step_cap"]


def test_censored_classes_and_likelihood() -> None:
    m = IsotropicHitModel(IsotropicHitParams(length=1.0, intensity=3.0, n_hits=3))
    hyp = np.array([[1.0, 0.0], [0.0, 2.0], [3.0, 4.0]])
    mu = m.mean_hits(np.zeros(2), hyp)[0]
    q = m.outcome_probabilities(np.zeros((1, 2)), hyp)
    np.testing.assert_allclose(q[0].sum(axis=0), 1.0)
    np.testing.assert_allclose(q[0, 0], poisson.pmf(0, mu))
    np.testing.assert_allclose(q[0, 2], poisson.sf(1, mu))  # "2 or more"
    for z in range(3):
        np.testing.assert_allclose(np.exp(m.log_likelihood(z, np.zeros(2), hyp)), q[0, z])
    # counts above the last class fall into it
    np.testing.assert_allclose(m.log_likelihood(7, np.zeros(2), hyp), np.log(q[0, 2]))
    # the release condition scales the intensity
    np.testing.assert_allclose(
        m.mean_hits(np.zeros(2), hyp, release=6.0), 2.0 * m.mean_hits(np.zeros(2), hyp)
    )


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="length"):
        IsotropicHitModel(IsotropicHitParams(length=0.5, cell=1.0))
    m = IsotropicHitModel()
    with pytest.raises(ConfigError, match="hits"):
        m.log_likelihood(-1, np.zeros(2), np.ones((1, 2)))
    with pytest.raises(ConfigError, match="hits"):
        m.log_likelihood(1.5, np.zeros(2), np.ones((1, 2)))
    with pytest.raises(ConfigError):
        initial_belief(np.zeros((3, 3)), (1, 1))


def test_invalid_hits_release_and_position_name_the_field() -> None:
    m = IsotropicHitModel(IsotropicHitParams(length=3.0))
    hyp = np.array([[2.0, 0.0], [5.0, 1.0]])
    for z in (math.inf, math.nan, "x", None):
        with pytest.raises(ConfigError, match="hits"):
            m.log_likelihood(z, np.zeros(2), hyp)
    for release in (math.nan, -1.0, [1.0, -1.0]):
        with pytest.raises(ConfigError, match="release"):
            m.log_likelihood(1, np.zeros(2), hyp, release=release)
    with pytest.raises(ConfigError, match="sensor_positions"):
        m.log_likelihood(1, np.array([math.nan, 0.0]), hyp)


def test_initial_belief_excludes_the_start_and_obstacles() -> None:
    like = np.arange(9.0).reshape(3, 3) + 1
    free = np.ones((3, 3), bool)
    free[0, 0] = False
    b = initial_belief(like, (1, 1), free)
    assert b[1, 1] == 0 and b[0, 0] == 0
    assert b.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(b[2, 2] / b[0, 1], like[2, 2] / like[0, 1])


@pytest.mark.parametrize("dim", [2, 3])
def test_table_entries_and_windows(dim: int) -> None:
    m = IsotropicHitModel(IsotropicHitParams(length=1.5, intensity=2.0))
    shape = (5, 4) if dim == 2 else (4, 3, 3)
    half = tuple(n - 1 for n in shape)
    t = tabulate(m, 1.0, half)
    z = m.n_classes(dim)
    assert t.prob.shape == (z, *(2 * h + 1 for h in half))
    np.testing.assert_allclose(t.prob.sum(axis=0), 1.0)
    cell = (1,) * dim
    w = t.window(cell, shape)
    centres = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij"), -1)
    centres = centres.reshape(-1, dim)
    sensor = np.array(cell) + 0.5
    direct = m.outcome_probabilities(sensor[None], centres)[0]
    np.testing.assert_allclose(t.prob[(slice(None), *w)].reshape(z, -1), direct, rtol=1e-12)
    ent = -(direct * np.log(direct)).sum(axis=0)
    np.testing.assert_allclose(t.cond_entropy[w].reshape(-1), ent, rtol=1e-12)
    # a sensor outside the grid is fine while its offsets stay inside the table
    assert t.covers((-1,) * dim, (2,) * dim)
    with pytest.raises(ConfigError, match="beyond"):
        t.window((-1,) * dim, shape)


def test_table_of_a_wind_model_is_translation_invariant() -> None:
    v = VergassolaModel(VergassolaModelParams(V=1.0, D=1.0, tau=20.0, sensor_radius=0.2))
    cond = {"dt": 1.0, "direction": np.array([1.0, 0.0]), "n_classes": 3}
    t = tabulate(v, 0.5, (6, 6), **cond)
    grid = np.stack(np.meshgrid(np.arange(7) * 0.5, np.arange(7) * 0.5, indexing="ij"), -1)
    hyp = grid.reshape(-1, 2)
    sensor = np.array([1.5, 1.0])
    direct = v.outcome_probabilities(sensor[None], hyp, **cond)[0]
    w = t.window((3, 2), (7, 7))
    np.testing.assert_allclose(t.prob[(slice(None), *w)].reshape(3, -1), direct, rtol=1e-12)
