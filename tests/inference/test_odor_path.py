"""Tests of the dynamic-window odor-path estimator (odor-path paper)."""

from __future__ import annotations

import math
import weakref

import numpy as np
import pydantic
import pytest

from odorloc.core.errors import ConfigError
from odorloc.inference.odor_path import (
    HAVE_NUMBA,
    CellGrid,
    OdorPathEstimator,
    OdorPathParams,
    from_paper_k,
    paper_k,
)
from odorloc.inference.odor_path.estimator import PathPatch
from odorloc.inference.odor_path.kernel import (
    dw_kernel,
    exp_nonpositive,
    exp_nonpositive_fast,
    paint,
    path_kernel,
    path_meta,
    path_workspace,
    window_fill,
    window_kernel,
)


def feed(est: OdorPathEstimator, winds: np.ndarray, position=(8.0, 5.0), dt=0.5, signal=1.0):
    for i, u in enumerate(winds):
        est.update(i * dt, position, u, signal)


def noisy_winds(rng: np.random.Generator, n=21, mean=(0.8, 0.1), sigma=0.05) -> np.ndarray:
    return np.asarray(mean) + rng.normal(0.0, sigma, (n, 2))


def dense(patch: PathPatch) -> np.ndarray:
    """The patch made dense in a new array."""
    out = np.zeros(patch.grid.shape)
    out[patch.slices] = patch.values
    return out


def assert_same_map(ref_est: OdorPathEstimator, ref: np.ndarray, got: np.ndarray) -> int:
    """``got`` is the map ``ref`` within 1e-12 relative on every cell of both supports; a cell
    in one support only must lie within rounding of a window's ellipse edge (``q`` of eq. 12
    within 1e-12 relative of ``2 k``, windows from ``ref_est``). Returns the number of such
    edge cells."""
    differ = np.argwhere((ref > 0) != (got > 0))
    if len(differ):
        w = ref_est.window_arrays()
        xc, yc = ref_est.grid.x_centers(), ref_est.grid.y_centers()
        for ix, iy in differ:
            q = (xc[ix] - w.center[:, 0]) ** 2 / w.var[:, 0]
            q += (yc[iy] - w.center[:, 1]) ** 2 / w.var[:, 1]
            edge = np.abs(q - 2.0 * w.k) <= 1e-12 * np.maximum(2.0 * w.k, 1.0)
            assert edge.any(), f"cell {(ix, iy)} in one map only, not at a window's edge"
    both = (ref > 0) & (got > 0)
    np.testing.assert_allclose(got[both], ref[both], rtol=1e-12, atol=0.0)
    return len(differ)


# ---------------------------------------------------------------------------------------- grid
def test_grid_matches_paper_index_formulas():
    g = CellGrid.from_extent((0.0, 0.0), (10.0, 10.0), 0.05)
    assert g.shape == (200, 200) and g.n_cells == 40_000  # section V
    # eq. (8-a): i = int(y / a), j = int(x / a); our index is (ix = j, iy = i)
    np.testing.assert_array_equal(g.index([[0.07, 0.12]]), [[1, 2]])
    np.testing.assert_allclose(g.center([[1, 2]]), [[0.075, 0.125]])  # eq. (8-b)
    # eq. (9-a) with 1-based row i = iy + 1 = 3 and column j = ix + 1 = 2: k = 2 * 200 + 2
    assert paper_k(g, 1, 2) == 402
    ix, iy = from_paper_k(g, np.array([402, 1, 40_000]))
    np.testing.assert_array_equal(ix, [1, 0, 199])
    np.testing.assert_array_equal(iy, [2, 0, 199])
    with pytest.raises(ConfigError):
        from_paper_k(g, 0)
    # eq. (7): m = int(extent / a) drops a partial strip
    assert CellGrid.from_extent((0, 0), (1.03, 0.5), 0.1).shape == (10, 5)
    with pytest.raises(ConfigError):
        CellGrid.from_extent((0, 0), (0.05, 1.0), 0.1)
    with pytest.raises(ConfigError):
        CellGrid.from_extent((0, 0), (-1.0, 1.0), 0.1)


# ------------------------------------------------------------------------------------ windows
def test_windows_follow_constant_wind_and_closed_form_axes():
    params = OdorPathParams(variance="fixed", fixed_variance=(1e-3, 4e-3))
    est = OdorPathEstimator(params, (0, 0), (10, 10))
    feed(est, np.tile([0.5, 0.0], (21, 1)), position=(8.01, 5.01))
    wins = est.windows()
    assert len(wins) == 20  # t_thr = 10 s at 0.5 s: 20 sub-windows
    ref = np.array([8.025, 5.025])  # centre of the robot cell (eq. 11)
    eta = 1.0 / 40_000
    for w in wins:
        age = 10.0 - w.t_r
        # eq. (10), interval reading: displacement u * (t_c - t_r)
        np.testing.assert_allclose(w.center, ref - [0.5 * age, 0.0], atol=1e-12)
        var = age * np.array([1e-3, 4e-3])  # tau = 1 s
        k = math.log(0.05**2 / (2 * math.pi * eta * math.sqrt(var[0] * var[1])))  # eq. (13)
        np.testing.assert_allclose(w.variance, var)
        np.testing.assert_allclose(w.semi_axes, np.sqrt(2 * k * var))
        assert w.n_cells > 0
    inclusive = OdorPathEstimator(
        params.model_copy(update={"advection": "inclusive"}), (0, 0), (10, 10)
    )
    feed(inclusive, np.tile([0.5, 0.0], (21, 1)), position=(8.01, 5.01))
    # the literal sum i = r..c has one more period of wind
    np.testing.assert_allclose(inclusive.windows()[5].center, wins[5].center - [0.25, 0.0])


def test_window_cells_satisfy_eta_and_outside_cells_do_not():
    # A single sub-window (two records) and no normalisation: the map is S itself (eq. 14).
    params = OdorPathParams(variance="fixed", fixed_variance=(2e-3, 5e-3), normalise=False)
    est = OdorPathEstimator(params, (0, 0), (10, 10))
    est.update(0.0, (5.0, 5.0), (0.7, 0.2))
    est.update(2.0, (5.0, 5.0), (0.7, 0.2))  # one window, t_c - t_r = 2 s
    pi = est.path_map()
    (w,) = est.windows()
    g = est.grid
    gx, gy = np.meshgrid(g.x_centers(), g.y_centers(), indexing="ij")
    var = w.variance
    s = (
        0.05**2
        / (2 * math.pi * math.sqrt(var[0] * var[1]))
        * np.exp(-((gx - w.center[0]) ** 2) / (2 * var[0]) - (gy - w.center[1]) ** 2 / (2 * var[1]))
    )
    inside = pi > 0
    assert inside.sum() == w.n_cells > 50
    assert np.all(s[inside] >= est.eta * (1 - 1e-9))
    assert np.all(s[~inside] < est.eta * (1 + 1e-9))
    np.testing.assert_allclose(pi[inside], s[inside], rtol=1e-12)
    np.testing.assert_allclose(w.center, [5.025 - 1.4, 5.025 - 0.4])


def test_single_window_is_normalised():
    params = OdorPathParams(variance="fixed", fixed_variance=(2e-3, 5e-3))
    est = OdorPathEstimator(params, (0, 0), (10, 10))
    est.update(0.0, (5.0, 5.0), (0.7, 0.2))
    est.update(2.0, (5.0, 5.0), (0.7, 0.2))
    assert est.path_map().sum() == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("kernel", ["point", "cell"])
@pytest.mark.parametrize("backend", ["numpy", "auto"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dynamic_window_equals_full_grid_reference(kernel, backend, seed):
    rng = np.random.default_rng(seed)
    params = OdorPathParams(kernel=kernel, backend=backend)
    est = OdorPathEstimator(params, (0, 0), (10, 10))
    # robot near a corner as well, so windows are clipped by the grid
    pos = (8.0, 5.0) if seed != 2 else (0.3, 9.7)
    mean = (0.8, 0.1) if seed != 2 else (-0.3, 0.4)
    feed(est, noisy_winds(rng, mean=mean, sigma=0.05 + 0.05 * seed), position=pos)
    fast = est.path_map()
    full = est.path_map_full()
    np.testing.assert_array_equal(fast > 0, full > 0)
    np.testing.assert_allclose(fast, full, rtol=1e-12, atol=1e-15)
    # zero outside the union of the window ellipses
    g = est.grid
    gx, gy = np.meshgrid(g.x_centers(), g.y_centers(), indexing="ij")
    union = np.zeros(g.shape, bool)
    for w in est.windows():
        if w.n_cells:
            h = w.semi_axes
            union |= ((gx - w.center[0]) / h[0]) ** 2 + ((gy - w.center[1]) / h[1]) ** 2 <= 1 + 1e-9
    assert fast.any()
    assert not np.any(fast[~union])
    assert np.all(fast <= 1.0)


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("kernel", ["point", "cell"])
@pytest.mark.parametrize("seed", [7, 8, 9])
def test_compiled_kernel_equals_numpy_batch(kernel: str, seed: int):
    """The same patch from both backends over many online steps (the robot near the middle
    and near a corner): the cell kernel's bit for bit (NumPy's ``ndtr`` on both paths), the
    point kernel's fused map within 1e-12 relative with the same cells; the sub-windows bit
    for bit on both."""
    rng = np.random.default_rng(seed)
    a = OdorPathEstimator(OdorPathParams(backend="numpy", kernel=kernel), (0, 0), (10, 10))
    b = OdorPathEstimator(OdorPathParams(backend="numba", kernel=kernel), (0, 0), (10, 10))
    winds = noisy_winds(rng, n=60, sigma=0.1)
    pos = (6.0, 4.0) if seed != 9 else (0.4, 9.5)
    for i, u in enumerate(winds):
        for e in (a, b):
            e.update(0.5 * i, np.asarray(pos, float), u, float(i % 3 == 0))
        if i >= 20:
            pa, pb = a.path_patch(), b.path_patch()
            np.testing.assert_array_equal(pa.ref_cell, pb.ref_cell)
            if kernel == "cell":
                assert (pa.ix0, pa.iy0) == (pb.ix0, pb.iy0)
                np.testing.assert_array_equal(pa.values, pb.values)
            else:
                assert_same_map(a, dense(pa), dense(pb))
    assert [w.box for w in a.windows()] == [w.box for w in b.windows()]
    assert [w.n_cells for w in a.windows()] == [w.n_cells for w in b.windows()]


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("advection", ["interval", "inclusive"])
@pytest.mark.parametrize("variance", ["online", "fixed"])
@pytest.mark.parametrize("snap", [False, True])
def test_compiled_windows_equal_numpy_to_the_bit(advection: str, variance: str, snap: bool):
    """The sub-windows (record times, centres, variances, k of eq. 13) from both backends, bit
    for bit, and the fused map within 1e-12 of the batch's (same cells, normalised or not),
    under every reading of eqs. 10-13, with uneven record intervals, a steady stretch (the
    variance floor), a moving robot and records trimmed away."""
    rng = np.random.default_rng(13)
    kw = {"advection": advection, "variance": variance, "snap_to_cell": snap, "cell_size": 0.1}
    kw |= {"t_thr": 5.0, "history": 1.0}
    a = OdorPathEstimator(OdorPathParams(backend="numpy", **kw), (0, 0), (10, 8))
    b = OdorPathEstimator(OdorPathParams(backend="numba", **kw), (0, 0), (10, 8))
    kw["normalise"] = False
    raw_a = OdorPathEstimator(OdorPathParams(backend="numpy", **kw), (0, 0), (10, 8))
    raw_b = OdorPathEstimator(OdorPathParams(backend="numba", **kw), (0, 0), (10, 8))
    t = 0.0
    for i in range(50):
        t += float(rng.uniform(0.3, 0.7))
        pos = rng.uniform(1.0, 9.0, 2)
        wind = np.array([0.6, 0.2]) + (rng.normal(0.0, 0.1, 2) if i % 9 else 0.0)
        for e in (a, b, raw_a, raw_b):
            e.update(t, pos, wind, 1.0)
        if i < 2:
            continue
        wa, wb = a.window_arrays(), b.window_arrays()
        assert wa.t_c == wb.t_c
        for name in ("t_r", "center", "var", "k", "ref_cell"):
            np.testing.assert_array_equal(getattr(wa, name), getattr(wb, name), err_msg=name)
        assert_same_map(a, a.path_map(), b.path_map())
        assert_same_map(raw_a, raw_a.path_map(), raw_b.path_map())


def test_python_window_kernel_matches_numpy():
    """The window kernel run as plain Python (what numba compiles) equals NumPy's arrays."""
    rng = np.random.default_rng(14)
    est = OdorPathEstimator(OdorPathParams(backend="numpy"), (0, 0), (10, 10))
    feed(est, noisy_winds(rng, n=40, sigma=0.1), position=(6.0, 4.0))
    ref = est.window_arrays()
    p, g = est.params, est.grid
    times = est.times  # the stored records: the last n of the 40 fed
    n = len(times)
    winds = noisy_winds(np.random.default_rng(14), n=40, sigma=0.1)[-n:]
    limit = times[-1] - p.t_thr - 1e-9
    t_r, center, var, k_arg, cell = window_kernel(
        times, winds, np.tile([6.0, 4.0], (n, 1)), limit, n - 1, 0, p.dt, True, p.snap_to_cell,
        g.lower[0], g.lower[1], g.cell_size, False, np.zeros(2), p.min_variance,
        p.noise_time_scale, est.eta,
    )  # fmt: skip
    np.testing.assert_array_equal(t_r, ref.t_r)
    np.testing.assert_array_equal(center, ref.center)
    np.testing.assert_array_equal(var, ref.var)
    np.testing.assert_array_equal(np.log(k_arg), ref.k)
    np.testing.assert_array_equal(cell, ref.ref_cell)


def test_python_fused_kernel_gives_the_numpy_patch():
    """The fused map's kernel run as plain Python (what numba compiles) on a workspace of its
    own: the NumPy batch's patch within 1e-12 and its robot cell; and the window pass's core
    run as plain Python gives the sub-windows."""
    rng = np.random.default_rng(15)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2, backend="numpy"), (0, 0), (10, 8))
    feed(est, noisy_winds(rng, n=30, sigma=0.1), position=(6.0, 4.0))
    ref = est.path_patch()
    p, g = est.params, est.grid
    times = est.times
    n = len(times)
    winds = noisy_winds(np.random.default_rng(15), n=30, sigma=0.1)[-n:]
    pos = np.tile([6.0, 4.0], (n, 1))
    fixed = (*g.lower, g.cell_size, *p.fixed_variance, p.min_variance)
    # interval advection, snapped, online variance, normalised
    par = np.array([p.dt, *fixed, p.noise_time_scale, est.eta, p.t_thr, 1e-9, 1, 1, 0, 1, *g.shape])
    ws = path_workspace(n, *g.shape)
    values = path_kernel(times, winds, pos, n - 1, 0, par, ws)
    ix0, iy0, *cell = path_meta(ws).tolist()
    got = PathPatch(ix0, iy0, values, g, np.array(cell))
    assert_same_map(est, dense(ref), dense(got))
    np.testing.assert_array_equal(cell, ref.ref_cell)
    assert values.shape[0] > 5 and values.shape[1] > 5
    win = [np.zeros(n), np.zeros((n, 2)), np.zeros((n, 2)), np.zeros(n), np.zeros(2, np.intp)]
    settings = (p.dt, True, True, *g.lower, g.cell_size, False, np.zeros(2), p.min_variance)
    limit = times[-1] - p.t_thr - 1e-9
    assert window_fill(times, winds, pos, limit, n - 1, 0, *settings, 1.0, est.eta, *win) == 20
    w = est.window_arrays()
    for a, b in zip(win[:3], (w.t_r, w.center, w.var), strict=True):
        np.testing.assert_array_equal(a[:20], b)
    np.testing.assert_array_equal(np.log(win[3][:20]), w.k)
    np.testing.assert_array_equal(win[4], ref.ref_cell)


def test_vectorised_exponential_is_numpys_within_one_ulp():
    """The fused map's exponential against NumPy's over the arguments a map meets (and the
    subnormal range, which goes to the C library's)."""
    rng = np.random.default_rng(31)
    x = -np.concatenate(
        [rng.uniform(0, 1, 3000), rng.uniform(0, 60, 3000), rng.uniform(700, 760, 500)]
    )
    x[:4] = (0.0, -0.0, -5e-324, -1e-300)
    ref = np.exp(x)
    normal = ref >= np.finfo(float).tiny
    for kernel in (exp_nonpositive, exp_nonpositive_fast):  # as Python, and compiled
        out = np.empty_like(x)
        kernel(x, out, np.empty(x.size, np.int64))
        ulps = np.abs(out[normal] - ref[normal]) / np.spacing(ref[normal])
        assert ulps.max() <= 1.0
        # subnormal results: within a few of the smallest steps
        assert np.abs(out[~normal] - ref[~normal]).max() <= 4 * 5e-324
        assert out[0] == 1.0 and np.array_equal(out > 0, ref > 0)


def test_cost_follows_window_size_not_map_size():
    rng = np.random.default_rng(3)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, noisy_winds(rng, sigma=0.03))
    patch = est.path_patch()
    n_win = sum(w.n_cells for w in est.windows())
    assert patch.values.size < 0.2 * est.grid.n_cells
    assert n_win < 0.02 * 20 * est.grid.n_cells


# ------------------------------------------------------------------------------- behaviour
def _crosswind_std(pi: np.ndarray, grid: CellGrid) -> float:
    y = grid.y_centers()
    w = pi.sum(axis=0)
    m = (w * y).sum() / w.sum()
    return float(np.sqrt((w * (y - m) ** 2).sum() / w.sum()))


def test_smaller_wind_variance_gives_thinner_path():
    widths, cells = [], []
    for var in (1e-3, 1e-2):
        params = OdorPathParams(variance="fixed", fixed_variance=(var, var))
        est = OdorPathEstimator(params, (0, 0), (10, 10))
        feed(est, np.tile([0.6, 0.0], (21, 1)), position=(8.0, 5.0))
        pi = est.path_map()
        widths.append(_crosswind_std(pi, est.grid))
        cells.append(np.count_nonzero(pi))
    # Gaussian cross-sections scale with sqrt(variance): ratio sqrt(10) ~ 3.2
    assert 2.0 < widths[1] / widths[0] < 4.5
    assert cells[1] > 3 * cells[0]


def test_online_variance_is_sample_variance_of_the_window_records():
    rng = np.random.default_rng(4)
    winds = noisy_winds(rng, n=30, sigma=0.1)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, winds)
    # interval reading: the 20 winds after the oldest window record
    np.testing.assert_allclose(est.wind_variance(), winds[-20:].var(axis=0, ddof=1))
    steady = OdorPathEstimator(OdorPathParams(min_variance=2e-4), (0, 0), (10, 10))
    feed(steady, np.tile([0.5, 0.0], (5, 1)))
    np.testing.assert_allclose(steady.wind_variance(), [2e-4, 2e-4])


def test_detection_in_steady_plume_points_at_upwind_source():
    """Source upwind of the robot, constant noisy wind, 20-step record."""
    rng = np.random.default_rng(5)
    source = np.array([2.0, 5.0])
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    robot = np.array([8.0, 5.1])
    u_mean = np.array([0.8, 0.0])
    for i in range(21):
        u = u_mean + rng.normal(0, 0.05, 2)
        # a simple Gaussian plume: detection when the robot is within the plume width
        x = robot[0] - source[0]
        conc = math.exp(-((robot[1] - source[1]) ** 2) / (2 * (0.1 * x) ** 2))
        est.update(i * 0.5, robot, u, float(conc > 0.5))
    pi = est.path_map(require_detection=True)
    cell = tuple(est.grid.index(source)[0])
    nz = pi[pi > 0]
    assert pi[cell] > 0
    assert pi[cell] >= np.median(nz)
    # cells far crosswind of the source are not on the path
    assert pi[tuple(est.grid.index([2.0, 7.0])[0])] == 0
    assert pi[tuple(est.grid.index([2.0, 3.0])[0])] == 0


def test_require_detection_applies_eq_17():
    rng = np.random.default_rng(6)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, noisy_winds(rng), signal=0.0)
    assert not est.path_map(require_detection=True).any()
    assert est.path_map().any()  # the air-mass path itself exists
    assert not est.detected()


def test_records_are_trimmed_and_history_allows_earlier_maps():
    rng = np.random.default_rng(8)
    winds = noisy_winds(rng, n=100)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, winds)
    assert est.n_records == 21
    hist = OdorPathEstimator(OdorPathParams(history=5.0), (0, 0), (10, 10))
    feed(hist, winds)
    assert hist.n_records == 31
    fresh = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(fresh, winds[:95])
    np.testing.assert_allclose(hist.path_map(t_c=94 * 0.5), fresh.path_map(), rtol=1e-12)
    with pytest.raises(ConfigError):
        est.path_map(t_c=10.0)  # trimmed away
    with pytest.raises(ConfigError):
        est.path_map(t_c=49.25)  # not a record time


def test_first_records_give_empty_or_short_paths():
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    with pytest.raises(ConfigError):
        est.path_map()
    est.update(0.0, (5, 5), (1, 0), 1.0)
    assert est.path_patch().empty and est.windows() == []
    est.update(0.5, (5, 5), (1, 0), 1.0)
    assert len(est.windows()) == 1 and est.path_map().sum() == pytest.approx(1.0)


def test_determinism_same_input_same_map():
    winds = noisy_winds(np.random.default_rng(9))
    maps = []
    for _ in range(2):
        est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
        feed(est, winds)
        maps.append(est.path_map())
    np.testing.assert_array_equal(maps[0], maps[1])


def test_bad_input_raises():
    with pytest.raises(pydantic.ValidationError, match="eta"):
        OdorPathParams(eta=2.0)
    with pytest.raises(pydantic.ValidationError, match="cell_size"):
        OdorPathParams(cell_size=-0.05)
    with pytest.raises(pydantic.ValidationError, match="tthr"):
        OdorPathParams(tthr=10.0)
    with pytest.raises(pydantic.ValidationError, match="kernel"):
        OdorPathParams(kernel="box")
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    est.update(1.0, (5, 5), (1, 0))
    with pytest.raises(ConfigError, match="t"):
        est.update(1.0, (5, 5), (1, 0))
    with pytest.raises(ConfigError, match="position"):
        est.update(2.0, (5, 5, 1), (1, 0))
    with pytest.raises(ConfigError, match="wind"):
        est.update(2.0, (5, 5), (np.nan, 0))
    with pytest.raises(ConfigError, match="signal"):
        est.update(2.0, (5, 5), (1, 0), float("inf"))


def test_numpy_fallback_without_numba(monkeypatch):
    import odorloc.inference.odor_path.estimator as op

    rng = np.random.default_rng(10)
    winds = noisy_winds(rng)
    ref = OdorPathEstimator(OdorPathParams(backend="numpy"), (0, 0), (10, 10))
    feed(ref, winds)
    monkeypatch.setattr(op, "HAVE_NUMBA", False)
    est = OdorPathEstimator(OdorPathParams(backend="auto"), (0, 0), (10, 10))
    feed(est, winds)
    np.testing.assert_array_equal(est.path_map(), ref.path_map())
    forced = OdorPathEstimator(OdorPathParams(backend="numba"), (0, 0), (10, 10))
    feed(forced, winds)
    with pytest.raises(ConfigError, match="backend"):
        forced.path_map()


def test_python_loop_kernel_matches_compiled_form():
    """The loop kernel run as plain Python (what numba compiles) equals the NumPy batch."""
    rng = np.random.default_rng(11)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2, backend="numpy"), (0, 0), (10, 10))
    feed(est, noisy_winds(rng, sigma=0.1), position=(7.0, 3.0))
    # the axis terms both paths start from (eqs. 11-12, computed with NumPy)
    t = est.axis_terms(est.window_arrays())
    n_cells, patch, ix0, iy0 = dw_kernel(t.boxes, t.qx, t.qy, t.fx, t.fy, t.lim, True)
    ref = est.path_patch()
    assert (ix0, iy0) == (ref.ix0, ref.iy0)
    np.testing.assert_array_equal(patch, ref.values)
    assert list(n_cells) == [x.n_cells for x in est.windows()]
    kept = [tuple(b) for b, n in zip(t.boxes.tolist(), n_cells, strict=True) if n]
    assert kept == [x.box for x in est.windows() if x.n_cells]


def test_nan_record_time_is_refused_not_read_as_the_oldest_record():
    rng = np.random.default_rng(12)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, noisy_winds(rng))
    for call in (est.path_map, est.path_patch, est.windows, est.detected, est.wind_variance):
        with pytest.raises(ConfigError, match="t_c"):
            call(float("nan"))
    with pytest.raises(ConfigError, match="t_c"):
        est.path_map(t_c=float("inf"))


def test_fixed_variance_is_used_as_given_below_the_online_floor():
    params = OdorPathParams(variance="fixed", fixed_variance=(1e-5, 4e-5), min_variance=1e-4)
    est = OdorPathEstimator(params, (0, 0), (10, 10))
    feed(est, np.tile([0.5, 0.0], (5, 1)))
    np.testing.assert_allclose(est.wind_variance(), [1e-5, 4e-5])
    np.testing.assert_allclose(est.windows()[-1].variance, [0.5e-5, 2e-5])  # age 0.5 s, tau 1 s


def test_three_dimensional_bounds_are_refused_up_front():
    with pytest.raises(ConfigError, match="lower"):
        OdorPathEstimator(OdorPathParams(cell_size=0.5), (0, 0, 0), (10, 10, 2))


def test_synthetic_wind_record_speed_follows_its_documented_process():
    from odorloc.papers.odor_path.figures import synthetic_wind_record

    w = synthetic_wind_record(20_000, 0.5, 0.5, 5.0, np.random.default_rng(13))
    rel = np.hypot(w[:, 0], w[:, 1]) / 0.5 - 1.0
    # 10 % standard deviation, lag-one correlation exp(-dt / correlation_time) = 0.905
    assert rel.std() == pytest.approx(0.1, rel=0.1)
    assert np.corrcoef(rel[1:], rel[:-1])[0, 1] == pytest.approx(math.exp(-0.1), abs=0.02)
    heading = np.degrees(np.arctan2(w[:, 1], w[:, 0]))
    assert heading.std() == pytest.approx(5.0, rel=0.1)


def test_earlier_map_needing_trimmed_records_is_refused_not_truncated():
    rng = np.random.default_rng(14)
    winds = noisy_winds(rng, n=60)
    est = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(est, winds)
    with pytest.raises(ConfigError, match="history"):
        est.path_map(t_c=54 * 0.5)  # its five oldest windows were trimmed
    with pytest.raises(ConfigError, match="history"):
        est.windows(t_c=54 * 0.5)
    kept = OdorPathEstimator(OdorPathParams(history=2.5), (0, 0), (10, 10))
    feed(kept, winds)
    fresh = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(fresh, winds[:55])
    assert len(kept.windows(t_c=54 * 0.5)) == 20
    np.testing.assert_allclose(kept.path_map(t_c=54 * 0.5), fresh.path_map(), rtol=1e-12)
    # early on nothing was trimmed: fewer windows are all there is
    early = OdorPathEstimator(OdorPathParams(), (0, 0), (10, 10))
    feed(early, winds[:8])
    assert len(early.windows(t_c=5 * 0.5)) == 5


# ------------------------------------------------------------------------------ dense maps
def _fresh_dense(patch: PathPatch) -> np.ndarray:
    """The patch made dense in a new array (no canvas)."""
    return PathPatch(patch.ix0, patch.iy0, patch.values, patch.grid, patch.ref_cell).to_dense()


@pytest.mark.parametrize("compiled_paint", [True, False])
def test_reused_dense_map_never_changes_a_map_already_returned(monkeypatch, compiled_paint):
    """The estimator writes its dense maps into one array while nothing else refers to it: a
    map somebody keeps (or keeps a view of) never changes, and every map equals the patch
    made dense in a new array, whatever the previous map covered (the robot jumps across
    the grid, and a reading without a detection gives an empty map in between)."""
    import odorloc.inference.odor_path.estimator as op

    if not compiled_paint:
        monkeypatch.setattr(op, "HAVE_NUMBA", False)
    rng = np.random.default_rng(21)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.1, backend="auto"), (0, 0), (10, 10))
    spots = [(8.0, 5.0), (8.5, 5.5), (2.0, 8.5), (0.3, 0.4), (9.8, 9.7), (5.0, 5.0)]
    kept, copies = [], []
    view = None
    for i in range(60):
        spot = spots[(i // 7) % len(spots)]
        est.update(0.5 * i, spot, np.array([0.8, 0.1]) + rng.normal(0, 0.08, 2), i % 5 != 4)
        if i < 3:
            continue
        patch = est.path_patch(require_detection=True)
        pi = patch.to_dense()
        np.testing.assert_array_equal(pi, _fresh_dense(patch))
        assert not pi.flags.writeable
        if i % 11 == 0:  # kept whole
            kept.append(pi)
            copies.append(pi.copy())
        elif i == 20:  # only a view of it kept
            view, view_copy = pi[::2, 3:].T, pi[::2, 3:].T.copy()
        del pi
    assert any(c.any() for c in copies) and view_copy.any()
    for m, c in zip(kept, copies, strict=True):
        np.testing.assert_array_equal(m, c)
    np.testing.assert_array_equal(view, view_copy)
    # a returned map cannot be written into (its memory may serve a later map)
    with pytest.raises(ValueError, match="read-only"):
        est.path_map()[0, 0] = 1.0
    # the memory is reused once the map is dropped, and only then
    first = est.path_map()
    second = est.path_map()
    assert second is not first
    gone = weakref.ref(second)
    del second
    assert est.path_map() is gone()


def test_copied_estimator_draws_its_own_dense_maps():
    import copy
    import pickle

    rng = np.random.default_rng(24)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.1), (0, 0), (10, 10))
    feed(est, noisy_winds(rng))
    held = est.path_map()
    twin = copy.deepcopy(est)
    thawed = pickle.loads(pickle.dumps(est))
    # the same records and one more, in an estimator never copied: its map is the copies'
    fresh = OdorPathEstimator(OdorPathParams(cell_size=0.1), (0, 0), (10, 10))
    feed(fresh, noisy_winds(np.random.default_rng(24)))
    fresh.update(10.5, (2.0, 2.0), (0.5, 0.5), 1.0)
    moved = fresh.path_patch()
    for other in (twin, thawed):
        np.testing.assert_array_equal(other.path_map(), held)
        other.update(10.5, (2.0, 2.0), (0.5, 0.5), 1.0)
        assert not np.array_equal(other.path_map(), held)
        patch = other.path_patch()
        assert (patch.ix0, patch.iy0) == (moved.ix0, moved.iy0)
        np.testing.assert_array_equal(patch.ref_cell, moved.ref_cell)
        np.testing.assert_array_equal(patch.values, moved.values)
    np.testing.assert_array_equal(est.path_map(), held)  # the original is unchanged


def test_paint_kernel_as_python_writes_the_patch_and_clears_only_the_old_box():
    """The canvas kernel run as plain Python (what numba compiles)."""
    rng = np.random.default_rng(22)
    canvas = np.zeros((9, 7))
    last = np.zeros(4, np.intp)
    for _ in range(40):
        bx, by = int(rng.integers(0, 5)), int(rng.integers(0, 5))
        ix0, iy0 = int(rng.integers(0, 10 - bx)), int(rng.integers(0, 8 - by))
        values = rng.uniform(0.1, 1.0, (bx, by))
        paint(canvas, last, values, ix0, iy0)
        expect = np.zeros((9, 7))
        expect[ix0 : ix0 + bx, iy0 : iy0 + by] = values
        np.testing.assert_array_equal(canvas, expect)
        np.testing.assert_array_equal(last, [ix0, ix0 + bx, iy0, iy0 + by])


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_compiled_map_with_more_windows_than_the_first_buffer_holds():
    """Records every 0.05 s: 200 sub-windows, more than the first record buffer (64) and so
    the compiled map's first workspace holds; the maps stay the NumPy batch's."""
    rng = np.random.default_rng(23)
    kw = {"cell_size": 0.2, "dt": 0.05}
    a = OdorPathEstimator(OdorPathParams(backend="numpy", **kw), (0, 0), (10, 10))
    b = OdorPathEstimator(OdorPathParams(backend="numba", **kw), (0, 0), (10, 10))
    for i in range(230):
        u = np.array([0.7, -0.2]) + rng.normal(0, 0.1, 2)
        for e in (a, b):
            e.update(0.05 * i, (7.0, 6.0), u, 1.0)
        if i in (40, 63, 64, 65, 120, 229):
            assert_same_map(a, a.path_map(), b.path_map())
    assert len(b.windows()) == 200


@pytest.mark.skipif(not HAVE_NUMBA, reason="numba not installed")
def test_fused_map_on_first_records_empty_windows_and_without_detection():
    """The fused map against the batch where it has little or nothing to draw: one, two and
    three records, readings without a detection under eq. (17) (an empty map, the robot's cell
    still reported), and a threshold no cell reaches (``k <= 0`` in every window)."""
    rng = np.random.default_rng(32)
    for eta in (None, 0.9):
        kw = {"cell_size": 0.1, "eta": eta}
        a = OdorPathEstimator(OdorPathParams(backend="numpy", **kw), (0, 0), (10, 10))
        b = OdorPathEstimator(OdorPathParams(backend="numba", **kw), (0, 0), (10, 10))
        for i in range(12):
            detect = float(i % 4 != 3)
            u = np.array([0.5, 0.3]) + rng.normal(0, 0.1, 2)
            for e in (a, b):
                e.update(0.5 * i, (4.0 + 0.1 * i, 6.0), u, detect)
            for literal in (False, True):
                pa = a.path_patch(require_detection=literal)
                pb = b.path_patch(require_detection=literal)
                np.testing.assert_array_equal(pa.ref_cell, pb.ref_cell)
                assert pa.empty == pb.empty
                assert_same_map(a, dense(pa), dense(pb))
                if eta is not None or (literal and not detect) or i == 0:
                    assert pb.empty and pb.values.shape == (0, 0)
            if eta is None and i >= 2:
                assert not b.path_patch().empty


def test_map_comparison_fails_off_the_edge():
    """The comparison the fused map is tested with: a relative error above 1e-12, or a cell
    missing away from every window's edge, fails it."""
    est = OdorPathEstimator(OdorPathParams(cell_size=0.1, backend="numpy"), (0, 0), (10, 10))
    feed(est, noisy_winds(np.random.default_rng(33)))
    ref = est.path_map()
    assert assert_same_map(est, ref, ref.copy()) == 0
    off = ref.copy()
    off[np.unravel_index(np.argmax(ref), ref.shape)] *= 1 + 1e-11
    with pytest.raises(AssertionError):
        assert_same_map(est, ref, off)
    hole = ref.copy()
    hole[np.unravel_index(np.argmax(ref), ref.shape)] = 0.0  # the path's peak: no edge
    with pytest.raises(AssertionError, match="not at a window's edge"):
        assert_same_map(est, ref, hole)
