"""Gas distribution maps against their papers' equations.

Kernel DM+V (Lilienthal et al. 2009, eqs. 1-8), Kernel DM+V/W (Reggente and Lilienthal 2009),
TD Kernel DM+V (Asadi et al. 2017) and the GMRF map (Monroy et al. 2016): weights and confidence
against values worked by hand, the maps against a per-cell reference of the equations, the
properties each paper claims (a constant field recovered, variance where readings disagree, no
leak through a wall, wind stretching, fading readings), cross-validation and bad input.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.registry import names
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.gas_map import Readings, build_gas_map, map_grid, nlpd, time_blocks
from odorloc.inference.gas_map.gmrf import band_cholesky, band_inverse_diagonal, precision_system
from odorloc.inference.gas_map.kernel_dmv import wind_covariances
from odorloc.inference.gas_map.kernels import anisotropic_sums, isotropic_sums
from odorloc.inference.gas_map.selection import select_parameters

MEMBERS = names("gas_map")
GRID = CellGrid((0.0, 0.0), 0.5, (4, 4))


def _feed(name: str, pos, vals, grid=GRID, arena=None, **params):
    n = len(vals)
    gm = build_gas_map(name, **params)
    gm.start(grid, arena)
    gm.update(pos, vals, wind=np.zeros((n, grid.dim)), t=np.arange(n, dtype=float))
    return gm


# ----------------------------------------------------------------------- Kernel DM+V by hand
def test_kernel_weight_and_confidence_worked_by_hand():
    # one reading at (1.1, 0.9), sigma 0.5; cell (1, 1) has its centre at (0.75, 0.75):
    # d^2 = 0.35^2 + 0.15^2 = 0.145; w = exp(-0.145 / 0.5) / (2 pi 0.25) = 0.476359382...  (eq. 1)
    # sigma_Omega = N(0; 0.5) = 1 / (2 pi 0.25), so alpha = 1 - exp(-exp(-0.29)^2)       (eq. 4)
    sums = isotropic_sums(GRID, np.array([[1.1, 0.9]]), 0.5, 3.0, np.ones(1), np.ones((1, 1)))
    assert sums.reshape(4, 4)[1, 1] == pytest.approx(0.4763593820628206, rel=1e-14)
    gm = _feed("kernel-dmv", [[1.1, 0.9]], [4.0], kernel_width=0.5)
    assert gm.confidence()[1, 1] == pytest.approx(0.42873287926194215, rel=1e-14)
    # one reading: the map is r_0 = the reading everywhere (eq. 5), v_0 = 0 (eq. 7)
    assert np.all(gm.mean() == 4.0) and np.all(gm.variance() == 0.0)


def test_kernel_mean_of_two_readings_worked_by_hand():
    # r = 4 at (1.1, 0.9) (w1 above) and r = 1 at (0.6, 0.5): d^2 = 0.15^2 + 0.25^2 = 0.085,
    # w2 = exp(-0.17) / (pi / 2) = 0.537093703...; Omega = w1 + w2, R = 4 w1 + w2        (eqs. 2-3)
    # alpha = 1 - exp(-(Omega / N(0))^2) = 0.92067770008...; r_0 = 2.5
    # r = alpha R / Omega + (1 - alpha) r_0 = 2.41723829720...                            (eq. 5)
    gm = _feed("kernel-dmv", [[1.1, 0.9], [0.6, 0.5]], [4.0, 1.0], kernel_width=0.5)
    assert gm.confidence()[1, 1] == pytest.approx(0.9206777000841552, rel=1e-13)
    assert gm.mean()[1, 1] == pytest.approx(2.417238297208575, rel=1e-13)


def _reference_dmv(grid, pos, r, sigma, cutoff, scale=1.0, phi=None):
    """Eqs. 1-7 cell by cell, as the paper writes them (the slow reference)."""
    pos = np.asarray(pos, float)
    r = np.asarray(r, float)
    phi = np.ones(len(r)) if phi is None else phi
    centres = grid.flat_centers()
    peak = 1.0 / (2 * math.pi * sigma**2)
    r0 = float(phi @ r / phi.sum())
    v0 = float(phi @ (r - r0) ** 2 / phi.sum())

    def weights(c):
        d2 = np.sum((pos - c) ** 2, axis=1)
        w = peak * np.exp(-d2 / (2 * sigma**2)) * phi
        return np.where(d2 <= (cutoff * sigma) ** 2, w, 0.0)

    mean, alpha = np.zeros(len(centres)), np.zeros(len(centres))
    for k, c in enumerate(centres):
        w = weights(c)
        om = w.sum()
        alpha[k] = 1 - math.exp(-((om / (scale * peak)) ** 2))
        mean[k] = alpha[k] * (w @ r / om if om > 0 else 0.0) + (1 - alpha[k]) * r0
    own = np.ravel_multi_index(tuple(grid.index(pos).T), grid.shape)
    var = np.zeros(len(centres))
    for k, c in enumerate(centres):
        w = weights(c)
        om = w.sum()
        vv = w @ (r - mean[own]) ** 2
        var[k] = alpha[k] * (vv / om if om > 0 else 0.0) + (1 - alpha[k]) * v0
    return mean.reshape(grid.shape), var.reshape(grid.shape), alpha.reshape(grid.shape)


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_kernel_dmv_maps_follow_the_equations_cell_by_cell(backend):
    if backend == "numba":
        pytest.importorskip("numba", reason="numba compiles the kernel sums")
    rng = np.random.default_rng(4)
    grid = CellGrid((0.0, 0.0), 0.25, (16, 12))
    pos = rng.uniform((-0.5, -0.5), (4.5, 3.5), (150, 2))  # some outside the grid
    r = rng.gamma(2.0, 1.5, 150)
    gm = _feed("kernel-dmv", pos, r, grid, kernel_width=0.4, cutoff=2.5, backend=backend)
    mean, var, alpha = _reference_dmv(grid, pos, r, 0.4, 2.5)
    np.testing.assert_allclose(gm.mean(), mean, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(gm.variance(), var, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(gm.confidence(), alpha, rtol=1e-10, atol=1e-12)


def test_compiled_kernel_sums_equal_numpy_to_the_bit():
    pytest.importorskip("numba", reason="numba compiles the kernel sums")
    rng = np.random.default_rng(8)
    for grid in (CellGrid((0.0, 0.0), 0.1, (60, 40)), CellGrid((0.0, 0.0, 0.0), 0.2, (15, 10, 6))):
        pos = rng.uniform(-0.3, 3.3, (2500, grid.dim))
        vals = np.column_stack([np.ones(2500), rng.random(2500)])
        scale = rng.random(2500)
        a = isotropic_sums(grid, pos, 0.25, 3.0, scale, vals, "numpy")
        b = isotropic_sums(grid, pos, 0.25, 3.0, scale, vals, "numba")
        assert np.array_equal(a, b)


def test_cutoff_gives_no_weight_beyond_it_and_the_general_kernel_agrees():
    grid = CellGrid((0.0, 0.0), 0.1, (30, 30))
    x = np.array([[1.52, 1.47]])
    iso = isotropic_sums(grid, x, 0.2, 3.0, np.ones(1), np.ones((1, 1)))[0]
    d = np.linalg.norm(grid.flat_centers() - x, axis=1)
    assert np.all(iso[d > 0.6 + 1e-12] == 0.0) and np.all(iso[d < 0.6 - 1e-12] > 0.0)
    # the wind kernel without wind is the round kernel (another evaluation of the same sum)
    cov = wind_covariances(np.zeros((1, 2)), 0.2, 0.5)
    gen = anisotropic_sums(grid, x, cov, 3.0, np.ones(1), np.ones((1, 1)))[0]
    np.testing.assert_allclose(gen, iso, rtol=1e-12, atol=1e-15)
    assert iso.sum() * grid.cell_volume == pytest.approx(1.0 - math.exp(-4.5), rel=0.02)


# ----------------------------------------------------------------------- paper properties
@pytest.mark.parametrize("name", MEMBERS)
@pytest.mark.parametrize("dim", [2, 3])
def test_constant_field_recovered_exactly_where_confident(name, dim):
    rng = np.random.default_rng(dim)
    grid = map_grid(np.zeros(dim), np.full(dim, 3.0), 0.3)
    pos = rng.uniform(0.0, 3.0, (400, dim))
    gm = _feed(name, pos, np.full(400, 7.25), grid)
    sure = gm.confidence() > 0.6
    assert sure.mean() > 0.1
    np.testing.assert_allclose(gm.mean()[sure], 7.25, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", ["kernel-dmv", "kernel-dmvw", "td-kernel-dmv"])
def test_variance_is_higher_where_readings_disagree(name):
    # left: every reading 2.0; right: readings alternate 0 and 4 (the same mean, eq. 6)
    rng = np.random.default_rng(2)
    grid = map_grid((0.0, 0.0), (6.0, 2.0), 0.25)
    pos = rng.uniform((0.0, 0.0), (6.0, 2.0), (600, 2))
    r = np.where(pos[:, 0] < 3.0, 2.0, np.where(np.arange(600) % 2 == 0, 0.0, 4.0))
    gm = _feed(name, pos, r, grid, kernel_width=0.3)
    var = gm.variance()
    xs = grid.x_centers()
    left, right = var[xs < 2.0].mean(), var[xs > 4.0].mean()
    assert left < 0.05 and right > 2.0
    mean = gm.mean()
    np.testing.assert_allclose(mean[xs < 2.0].mean(), 2.0, atol=0.05)
    np.testing.assert_allclose(mean[xs > 4.0].mean(), 2.0, atol=0.3)


def test_gmrf_variance_is_the_uncertainty_of_the_mean_not_of_the_readings():
    # the GMRF's variance is (H^-1)_kk: where the readings are, not what they say
    grid = map_grid((0.0, 0.0), (4.0, 2.0), 0.25)
    # two readings in every cell of the left half; the right half is not observed
    left = grid.flat_centers()[grid.flat_centers()[:, 0] < 2.0]
    pos = np.vstack([left - 0.05, left + 0.05])
    n = len(pos)
    a = _feed("gmrf", pos, np.full(n, 2.0), grid, reading_scale=4.0)
    b = _feed("gmrf", pos, np.where(np.arange(n) % 2, 0.0, 4.0), grid, reading_scale=4.0)
    np.testing.assert_allclose(a.variance(), b.variance(), rtol=1e-12)
    xs = grid.x_centers()
    var = a.variance()
    assert var[xs > 3.0].mean() > 10 * var[xs < 1.5].mean()
    assert a.confidence()[xs < 1.5].min() > 0.9 and a.confidence()[xs > 3.5].max() < 0.5


def _walled_room():
    # a 10 m x 4 m room split by a wall at x = 4.9 .. 5.1, open nowhere
    arena = Arena.box((0.0, 0.0), (10.0, 4.0), 0.1).with_boxes([((4.9, 0.0), (5.1, 4.0))])
    grid = map_grid((0.0, 0.0), (10.0, 4.0), 0.25)
    rng = np.random.default_rng(5)
    left = rng.uniform((0.2, 0.2), (4.7, 3.8), (300, 2))
    right = rng.uniform((7.0, 0.2), (9.8, 3.8), (300, 2))  # nothing read within 2 m of the wall
    pos = np.vstack([left, right])
    r = np.concatenate([np.full(300, 10.0), np.zeros(300)])
    return arena, grid, pos, r


def test_gmrf_does_not_leak_across_a_wall():
    arena, grid, pos, r = _walled_room()
    fixed = {"information_loss": 0.0, "prior_mean": 0.0}
    walled = _feed("gmrf", pos, r, grid, arena=arena, **fixed)
    open_ = _feed("gmrf", pos, r, grid, arena=None, **fixed)
    xs = grid.x_centers()
    beside = (xs > 5.1) & (xs < 7.0)  # right of the wall, unobserved
    assert walled.mean()[beside].max() < 1e-9  # only the right side's zeros reach it
    assert open_.mean()[beside].max() > 2.0  # without the wall the left's 10s spill over
    assert walled.mean()[xs < 4.5].min() > 9.99  # the weak anchor to 0 costs a little
    # what is read left of the wall changes nothing right of it
    quiet = _feed("gmrf", pos, np.zeros(len(r)), grid, arena=arena, reading_scale=10.0, **fixed)
    right = xs > 5.1
    np.testing.assert_allclose(walled.mean()[right], quiet.mean()[right], atol=1e-12)
    # the kernel methods know no walls (as in their papers): the same readings leak
    kernel = _feed("kernel-dmv", pos, r, grid, arena=arena, kernel_width=0.5)
    near = (xs > 5.1) & (xs < 5.6)
    assert kernel.mean()[near].max() > 1.0


def test_gmrf_solution_and_variance_match_the_dense_system():
    arena, grid, pos, r = _walled_room()
    grid = map_grid((0.0, 0.0), (10.0, 4.0), 0.5)
    gm = _feed("gmrf", pos[::7], r[::7], grid, arena=arena, information_loss=0.05)
    rd = gm.readings
    s = 10.0  # the largest reading
    lam = 10.0 - 0.05 * (rd.t.max() - rd.t)
    use = lam > 0
    cells = np.ravel_multi_index(tuple(grid.index(rd.positions[use]).T), grid.shape)
    from odorloc.inference.gas_map.gmrf import neighbour_pairs

    pairs = neighbour_pairs(grid, gm.blocked, arena)
    m0 = float(r[::7][use].mean())
    h, g = precision_system(
        grid.n_cells, pairs, cells, lam[use], rd.values[use] / s, 0.5, 1e-4, m0 / s
    )
    dense = h.toarray()
    cov = np.linalg.inv(dense)
    free = ~gm.blocked
    np.testing.assert_allclose(
        gm.mean()[free], (s * np.linalg.solve(dense, g)).reshape(grid.shape)[free], rtol=1e-9
    )
    np.testing.assert_allclose(
        gm.variance()[free], (s * s * np.diag(cov)).reshape(grid.shape)[free], rtol=1e-9
    )
    # a few cells' predictions (held-out readings) solve for those cells only: the same values
    pts = rd.positions[:5]
    fresh = _feed("gmrf", pos[::7], r[::7], grid, arena=arena, information_loss=0.05)
    few_m, few_v = fresh.predict(pts)  # before any variance map exists
    own = tuple(grid.index(pts).T)
    np.testing.assert_allclose(few_v, gm.predictive_variance()[own], rtol=1e-9)
    np.testing.assert_allclose(few_m, gm.mean()[own], rtol=0, atol=0)
    # no prior factor crosses the wall: cells x < 4.9 and x > 5.1 are not neighbours in H
    xs = grid.flat_centers()[:, 0]
    cross = dense[np.ix_(xs < 4.9, xs > 5.1)]
    assert np.all(cross == 0.0)


def test_band_routines_against_lapack_and_the_inverse():
    rng = np.random.default_rng(6)
    for n, b in ((1, 0), (9, 1), (40, 6), (75, 12)):
        m = rng.normal(size=(n, n))
        a = np.where(np.abs(np.subtract.outer(np.arange(n), np.arange(n))) <= b, m + m.T, 0.0)
        a += np.eye(n) * (6 * b + 8)
        band = np.array([np.concatenate([np.diag(a, -d), np.zeros(d)]) for d in range(b + 1)])
        from scipy.linalg import cholesky_banded

        factor = band_cholesky(band)
        np.testing.assert_allclose(factor, cholesky_banded(band, lower=True), atol=1e-12)
        np.testing.assert_allclose(
            band_inverse_diagonal(factor), np.diag(np.linalg.inv(a)), rtol=1e-10
        )


def test_wind_stretch_and_shift_move_mass_downwind():
    grid = CellGrid((0.0, 0.0), 0.1, (60, 60))
    x = np.array([[3.0, 3.0]])
    wind = np.array([[1.0, 0.0]])  # towards +x
    cov = wind_covariances(wind, 0.25, 0.5)
    # semi-axes a = 0.25 + 0.5 = 0.75 along the wind, b = 0.25 / (1 + 2) across it, a b = sigma^2
    np.testing.assert_allclose(np.linalg.eigvalsh(cov[0]), [(0.25 / 3) ** 2, 0.75**2])
    om = anisotropic_sums(grid, x, cov, 3.0, np.ones(1), np.ones((1, 1)))[0].reshape(60, 60)
    # 0.55 m downwind of the reading weighs more than 0.55 m across the wind
    assert om[35, 29] > 50 * om[29, 35]
    # the shifted kernel's mass is centred wind_shift * |v| downwind
    shifted = anisotropic_sums(grid, x + 0.8 * wind, cov, 3.0, np.ones(1), np.ones((1, 1)))[0]
    cx = grid.flat_centers()[:, 0]
    assert (shifted @ cx) / shifted.sum() == pytest.approx(3.0 + 0.8, abs=1e-9)
    # in a map: a high reading among zeros raises the mean downwind, not across the wind
    # zeros on a lattice symmetric about the reading, none within 1.2 m of it
    g = np.arange(-2.5, 2.51, 0.25)
    lattice = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    lattice = lattice[np.linalg.norm(lattice, axis=1) > 1.2]
    pos = np.vstack([x, x + lattice])
    r = np.zeros(len(pos))
    r[0] = 10.0
    wind_all = np.tile(wind, (len(pos), 1))
    for shift, expect in ((0.0, "stretch"), (0.5, "shift")):
        gm = build_gas_map("kernel-dmvw", kernel_width=0.25, wind_scale=0.5, wind_shift=shift)
        gm.start(grid)
        gm.update(pos, r, wind=wind_all, t=np.zeros(len(pos)))
        mean = gm.mean()
        down, across = mean[36, 29], mean[29, 36]  # 0.65 m downwind / across of the reading
        assert down > across + 1.0, expect
        up = mean[22, 29]  # 0.75 m upwind
        if shift > 0:
            assert down > up + 1.0  # the shift moves the mass downwind of the reading
        else:
            assert down == pytest.approx(mean[23, 29], rel=1e-9)  # stretch alone: symmetric


def test_td_kernel_dmv_fades_old_readings_by_their_age():
    # the same place read 10 at t = 0 and 0 at t = 200 s; beta = 0.02 /s weighs the old
    # reading exp(-4) against 1 (Asadi et al. 2017), Kernel DM+V weighs both alike
    pos = [[1.0, 1.0], [1.0, 1.0]]
    td = build_gas_map("td-kernel-dmv", time_scale=0.02, kernel_width=0.5)
    td.start(GRID)
    td.update(pos, [10.0, 0.0], t=[0.0, 200.0])
    dmv = build_gas_map("kernel-dmv", kernel_width=0.5)
    dmv.start(GRID)
    dmv.update(pos, [10.0, 0.0], t=[0.0, 200.0])
    phi = math.exp(-4.0)
    r0 = 10.0 * phi / (1.0 + phi)  # the recency-weighted prior
    # at the reading's cell the weighted mean is r0 as well, and so is the blend (eq. 5)
    assert td.mean()[2, 2] == pytest.approx(r0, rel=1e-12)
    assert dmv.mean()[2, 2] == pytest.approx(5.0, rel=1e-12)


def test_gmrf_reading_information_decays_and_runs_out():
    # one isolated cell: mean = (sum lambda_i z_i + lambda_0 m_0) / (sum lambda_i + lambda_0)
    grid = CellGrid((0.0, 0.0), 1.0, (1, 1))
    gm = build_gas_map("gmrf", information_loss=0.1, reading_scale=1.0, prior_mean=0.0)
    gm.start(grid)
    gm.update([[0.5, 0.5]] * 3, [6.0, 2.0, 4.0], t=[0.0, 50.0, 100.0])
    # ages 100, 50, 0 s: information 10 - 10 (dropped), 10 - 5, 10
    expect = (5.0 * 2.0 + 10.0 * 4.0) / (5.0 + 10.0 + 1e-4)
    assert gm.mean()[0, 0] == pytest.approx(expect, rel=1e-12)
    assert gm.variance()[0, 0] == pytest.approx(1.0 / (15.0 + 1e-4), rel=1e-12)
    assert gm.predictive_variance()[0, 0] == pytest.approx(1.0 / (15.0 + 1e-4) + 0.1, rel=1e-12)


# ----------------------------------------------------------------------- maxima and NLPD
def test_map_maxima_are_separated_local_maxima_highest_first():
    grid = map_grid((0.0, 0.0), (10.0, 4.0), 0.25)
    c = grid.centers()
    field = 5 * np.exp(-np.sum((c - [2.125, 2.125]) ** 2, axis=-1)) + 3 * np.exp(
        -np.sum((c - [7.125, 2.125]) ** 2, axis=-1)
    )
    pos = grid.flat_centers()
    gm = build_gas_map("kernel-dmv", kernel_width=0.2, max_sources=3, peak_separation=2.0)
    gm.start(grid)
    gm.update(pos, field.ravel())
    est = gm.estimate()
    assert est.shape == (2, 2)  # two hills; no third local maximum 2 m from both
    np.testing.assert_allclose(est, [[2.125, 2.125], [7.125, 2.125]])


def test_nlpd_worked_by_hand():
    # readings 1 and 3 under N(2, 1): 1/2 log(2 pi) + 1/4 [(0 + 1) + (0 + 1)]
    assert nlpd([2.0, 2.0], [1.0, 1.0], [1.0, 3.0]) == pytest.approx(
        0.5 * math.log(2 * math.pi) + 0.5
    )
    assert math.isnan(nlpd([], [], []))
    assert np.isfinite(nlpd([1.0], [0.0], [1.0]))  # the floor: no -inf for a perfect fit


def test_cross_validation_prefers_the_width_that_predicts_held_out_readings():
    rng = np.random.default_rng(9)
    grid_for = lambda cell: map_grid((0.0, 0.0), (8.0, 4.0), cell)  # noqa: E731
    t = np.arange(1600) * 0.5
    # a lawn-mower path over a smooth field, with noise
    x = (t % 80.0) / 10.0
    y = 0.25 * (t // 80.0) % 4.0
    pos = np.column_stack([x, y])
    val = 4 * np.exp(-((x - 3.0) ** 2 + (y - 2.0) ** 2) / 2.0) + rng.normal(0, 0.3, len(t))
    rd = Readings(pos, val, None, t)
    sel = select_parameters(
        "kernel-dmv", rd, grid_for, {"kernel_width": [0.03, 0.3, 3.0]}, {"cell_size": 0.2}
    )
    assert sel.best == {"kernel_width": 0.3}
    scores = dict((v["kernel_width"], s) for v, s in sel.scores)
    assert scores[0.3] < min(scores[0.03], scores[3.0])
    # the cell size is a candidate like any other parameter (each its own grid); the winner
    # is the lowest NLPD
    sel2 = select_parameters(
        "gmrf", rd, grid_for, {"cell_size": [0.2, 0.5, 2.0]}, {"information_loss": 0}
    )
    assert len({s for _, s in sel2.scores}) == 3
    assert sel2.best == min(sel2.scores, key=lambda vs: vs[1])[0]


def test_folds_are_whole_stretches_of_the_path():
    rd = Readings(np.zeros((50, 2)), np.zeros(50), None, np.arange(50) * 1.0)
    folds = time_blocks(rd, 10.0, 3)
    assert list(folds[:25]) == [0] * 10 + [1] * 10 + [2] * 5


# ----------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("params", "field"),
    [
        ({"kernel_width": 0.0}, "kernel_width"),
        ({"kernel_width": True}, "kernel_width"),
        ({"cell_size": -1.0}, "cell_size"),
        ({"confidence_scale": math.nan}, "confidence_scale"),
        ({"max_sources": 0}, "max_sources"),
        ({"nope": 1}, "nope"),
    ],
)
def test_bad_parameters_name_the_field(params, field):
    with pytest.raises(ConfigError) as err:
        build_gas_map("kernel-dmv", **params)
    assert err.value.field == field


def test_a_gmrf_variance_too_costly_is_refused_naming_the_cell_size():
    grid = CellGrid((0.0, 0.0, 0.0), 0.1, (80, 60, 30))  # band 1800 over 144 000 cells
    gm = build_gas_map("gmrf", information_loss=0.0)
    gm.start(grid)
    gm.update([[1.0, 1.0, 1.0]], [2.0])
    with pytest.raises(ConfigError, match=r"^cell_size: the exact variance of 144000 cells"):
        gm.variance()


def test_reset_maps_the_task_region_or_the_arena():
    from odorloc.core.types import SearchContext

    arena = Arena.box((0.0, 0.0, 0.0), (10.0, 6.0, 3.0), 0.25)
    ctx = SearchContext(
        arena=arena,
        dt=0.5,
        agent_ids=(0,),
        start=[[1.0, 1.0, 1.0]],
        speed_limits=[1.0],
        search_region=((2.0, 1.0), (6.1, 4.0)),  # horizontal: the arena's height is kept
    )
    gm = build_gas_map("kernel-dmv", cell_size=0.5)
    gm.reset(ctx, None, np.random.default_rng(0))
    assert gm.grid.lower == (2.0, 1.0, 0.0) and gm.grid.shape == (9, 6, 6)  # 4.1 m: 9 cells
    own = build_gas_map("kernel-dmv", cell_size=1.0, region=((0.0, 0.0, 0.0), (10.0, 6.0, 3.0)))
    own.reset(ctx, None, np.random.default_rng(0))
    assert own.grid.shape == (10, 6, 3)
    # a region is narrowed to the arena; one outside it is refused, naming the field
    wide = build_gas_map("kernel-dmv", cell_size=1.0, region=((-5.0, -5.0), (20.0, 3.0)))
    wide.reset(ctx, None, np.random.default_rng(0))
    assert wide.grid.lower == (0.0, 0.0, 0.0) and wide.grid.shape == (10, 3, 3)
    away = build_gas_map("kernel-dmv", region=((20.0, 0.0), (30.0, 3.0)))
    with pytest.raises(ConfigError, match=r"^region: does not overlap the arena"):
        away.reset(ctx, None, np.random.default_rng(0))


def test_default_cell_size_grows_in_large_arenas():
    from odorloc.experiments.gas_maps import default_cell_size

    assert default_cell_size((0, 0), (10, 5)) == 0.25
    big = default_cell_size((0, 0, 0), (100, 60, 30))
    assert big > 0.25 and 100 * 60 * 30 / big**3 == pytest.approx(200_000)


def test_bad_readings_and_misuse_are_refused():
    gm = build_gas_map("kernel-dmvw")
    with pytest.raises(RuntimeError, match="reset"):
        gm.update([[0.0, 0.0]], [1.0], wind=[[1.0, 0.0]])
    gm.start(GRID)
    with pytest.raises(ConfigError, match="wind: KernelDMVW needs the wind"):
        gm.update([[0.0, 0.0]], [1.0])
    with pytest.raises(ConfigError, match=r"^position: expected shape"):
        gm.update([[0.0, 0.0, 0.0]], [1.0], wind=[[1.0, 0.0, 0.0]])
    with pytest.raises(ConfigError, match=r"^position: must be finite"):
        gm.update([[math.inf, 0.0]], [1.0], wind=[[1.0, 0.0]])
    with pytest.raises(ConfigError, match=r"^reading: expected 1 values"):
        gm.update([[0.0, 0.0]], [1.0, 2.0], wind=[[1.0, 0.0]])
    assert gm.n_readings == 0 and gm.belief() is None
    td = build_gas_map("td-kernel-dmv")
    td.start(GRID)
    with pytest.raises(ConfigError, match=r"^t: TDKernelDMV needs the time"):
        td.update([[0.0, 0.0]], [1.0])
    with pytest.raises(ConfigError, match=r"^candidates"):
        select_parameters(
            "kernel-dmv",
            Readings(np.zeros((0, 2)), np.zeros(0), None, np.zeros(0)),
            lambda c: GRID,
            {},
        )
