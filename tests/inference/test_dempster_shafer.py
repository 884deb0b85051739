"""Tests of the Dempster-Shafer evidence grid (D-S multi-source paper)."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from odorloc.core.errors import ConfigError
from odorloc.inference.evidence.dempster_shafer import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    DSGrid,
    DSParams,
    cell_uncertainty,
    dempster_combine,
    detection_bba,
    non_detection_bba,
)
from odorloc.inference.odor_path import CellGrid, OdorPathEstimator, OdorPathParams


# ------------------------------------------------------------------------- Dempster's rule
def test_combination_worked_by_hand_mixed_evidence():
    # m1 = (S 0.5, notS 0.2, U 0.3), m2 = (S 0.4, notS 0, U 0.6)
    # K = 0.5 * 0 + 0.2 * 0.4 = 0.08                                       (eq. 2)
    # S: 0.5*0.4 + 0.5*0.6 + 0.3*0.4 = 0.62 -> 0.62 / 0.92                  (eq. 1)
    # notS: 0.2*0 + 0.2*0.6 + 0.3*0 = 0.12 -> 0.12 / 0.92
    # U: 0.3*0.6 = 0.18 -> 0.18 / 0.92
    ms, mn, mu, k, total = dempster_combine((0.5, 0.2, 0.3), (0.4, 0.0, 0.6))
    assert float(k) == pytest.approx(0.08)
    assert float(ms) == pytest.approx(0.62 / 0.92)
    assert float(mn) == pytest.approx(0.12 / 0.92)
    assert float(mu) == pytest.approx(0.18 / 0.92)
    assert not total


def test_combination_worked_by_hand_non_detection_on_believed_source():
    # m1 = (0.6, 0.1, 0.3), m2 = non-detection (0, 0.3, 0.7)
    # K = 0.6 * 0.3 = 0.18
    # S: 0.6*0.7 = 0.42 -> 0.42 / 0.82;  notS: 0.1*0.3 + 0.1*0.7 + 0.3*0.3 = 0.19 -> 0.19 / 0.82
    # U: 0.3*0.7 = 0.21 -> 0.21 / 0.82
    ms, mn, mu, k, _ = dempster_combine((0.6, 0.1, 0.3), (0.0, 0.3, 0.7))
    assert float(k) == pytest.approx(0.18)
    np.testing.assert_allclose([ms, mn, mu], [0.42 / 0.82, 0.19 / 0.82, 0.21 / 0.82])


def test_vacuous_evidence_is_neutral():
    # m(U) = 1 on either side returns the other mass function unchanged, K = 0
    ms, mn, mu, k, _ = dempster_combine((0.0, 0.0, 1.0), (0.0, 0.3, 0.7))
    np.testing.assert_allclose([ms, mn, mu, k], [0.0, 0.3, 0.7, 0.0])
    ms, mn, mu, k, _ = dempster_combine((0.2, 0.5, 0.3), (0.0, 0.0, 1.0))
    np.testing.assert_allclose([ms, mn, mu, k], [0.2, 0.5, 0.3, 0.0])


def test_total_conflict_without_division_by_zero():
    # m1 = certain source, m2 = certain no-source: K = 1*1 = 1, eq. (1) undefined.
    # "keep" leaves m1; "reset" returns to total ignorance. No warning may be raised
    # (RuntimeWarnings from odorloc are errors in this test suite).
    m1 = (np.array([1.0, 0.5]), np.array([0.0, 0.0]), np.array([0.0, 0.5]))
    m2 = (np.array([0.0, 0.0]), np.array([1.0, 1.0]), np.array([0.0, 0.0]))
    ms, mn, mu, k, total = dempster_combine(m1, m2, "keep")
    np.testing.assert_array_equal(total, [True, False])
    np.testing.assert_allclose(k, [1.0, 0.5])
    np.testing.assert_allclose(np.column_stack([ms, mn, mu]), [[1, 0, 0], [0, 1, 0]])
    ms, mn, mu, _, _ = dempster_combine(m1, m2, "reset")
    np.testing.assert_allclose(np.column_stack([ms, mn, mu]), [[0, 0, 1], [0, 1, 0]])


def test_combination_refuses_invalid_mass_functions():
    # a mass function must satisfy eq. (3); the rule's normalisation by 1 - K would otherwise
    # turn (0.3, 0.3, 0) into (0.5, 0.5, 0) or carry a negative mass on
    vacuous = (0.0, 0.0, 1.0)
    with pytest.raises(ConfigError, match="m1"):
        dempster_combine((0.3, 0.3, 0.0), vacuous)
    with pytest.raises(ConfigError, match="m1"):
        dempster_combine((-0.5, 0.5, 1.0), (0.2, 0.0, 0.8))
    with pytest.raises(ConfigError, match="m2"):
        dempster_combine(vacuous, (np.array([0.2, np.nan]), np.zeros(2), np.array([0.8, 1.0])))
    with pytest.raises(ConfigError, match="m2"):
        dempster_combine(vacuous, (0.2, 0.8))
    with pytest.raises(ConfigError, match="on_total_conflict"):
        dempster_combine(vacuous, vacuous, "Keep")
    # rounding far below the tolerance is accepted
    ms, mn, mu, _, _ = dempster_combine((0.1, 0.2, 0.7 + 1e-13), vacuous)
    np.testing.assert_allclose([ms, mn, mu], [0.1, 0.2, 0.7])


def test_total_conflict_is_counted_in_the_grid():
    params = DSParams(mu_d=1.0, mu_nd=1.0, zeta=1.0, rho=1.0)
    grid = DSGrid(params, CellGrid((0.0, 0.0), 1.0, (3, 3)))
    pi = np.zeros((3, 3))
    pi[1, 1] = 1.0
    grid.update(pi, True)
    assert grid.m_s[1, 1] == 1.0
    grid.update(pi, False)
    assert grid.n_total_conflict == 1
    assert grid.m_s[1, 1] == 1.0 and grid.m_u[1, 1] == 0.0  # kept
    reset = DSGrid(params.model_copy(update={"on_total_conflict": "reset"}), grid.grid)
    reset.update(pi, True)
    reset.update(pi, False)
    assert reset.m_u[1, 1] == 1.0 and reset.n_total_conflict == 1


def test_basic_belief_assignments_of_the_paper():
    p = DSParams()
    s, n, u = detection_bba(np.array([0.5, 1.0]), p)  # eq. (4-a): mu_D zeta pi
    np.testing.assert_allclose(s, [0.27, 0.54])
    np.testing.assert_allclose(n, 0.0)
    np.testing.assert_allclose(u, [0.73, 0.46])
    s, n, u = non_detection_bba(np.array([0.5, 1.0]), p)  # eq. (4-b): mu_notD zeta rho pi
    np.testing.assert_allclose(n, [0.15, 0.3])
    np.testing.assert_allclose(s, 0.0)
    with pytest.raises(ConfigError):
        detection_bba(np.array([1.5]), p)


def test_rule_is_commutative_and_associative():
    rng = np.random.default_rng(0)

    def rand_m():
        m = rng.dirichlet([1, 1, 1], size=50)
        return m[:, 0], m[:, 1], m[:, 2]

    a, b, c = rand_m(), rand_m(), rand_m()
    ab = dempster_combine(a, b)[:3]
    ba = dempster_combine(b, a)[:3]
    np.testing.assert_allclose(ab, ba, rtol=1e-12, atol=1e-15)
    left = dempster_combine(ab, c)[:3]
    right = dempster_combine(a, dempster_combine(b, c)[:3])[:3]
    np.testing.assert_allclose(left, right, rtol=1e-10, atol=1e-14)


def test_masses_stay_valid_after_many_random_updates():
    rng = np.random.default_rng(42)
    grid = DSGrid(DSParams(), CellGrid((0.0, 0.0), 0.5, (20, 20)))
    for _ in range(500):
        pi = rng.random((20, 20)) ** 3
        grid.update(pi, bool(rng.random() < 0.4))
    for m in (grid.m_s, grid.m_n, grid.m_u):
        assert np.all(m >= 0.0) and np.all(m <= 1.0)
    np.testing.assert_allclose(grid.m_s + grid.m_n + grid.m_u, 1.0, atol=1e-12)
    assert grid.n_updates == 500 and grid.n_total_conflict == 0
    # K = m1(S) m2(notS) + m1(notS) m2(S) <= max(mu_notD zeta rho, mu_D zeta) = max(0.3, 0.54)
    assert 0.3 < grid.max_conflict <= 0.54


def test_deterministic_per_seed():
    out = []
    for _ in range(2):
        rng = np.random.default_rng(3)
        grid = DSGrid(DSParams(), CellGrid((0.0, 0.0), 0.5, (8, 8)))
        for _ in range(50):
            grid.update(rng.random((8, 8)), bool(rng.random() < 0.5))
        out.append(grid.m_s.copy())
    np.testing.assert_array_equal(out[0], out[1])


# ---------------------------------------------------------------------------- uncertainty
def test_cell_uncertainty_values():
    # eq. (5): X = -[m(S) log2 m(S) + m(notS) log2 m(notS)] + q m(U), q = 3
    x = cell_uncertainty(
        np.array([0.0, 1.0, 0.5, 0.25, 0.0]),
        np.array([0.0, 0.0, 0.5, 0.25, 1.0]),
        np.array([1.0, 0.0, 0.0, 0.5, 0.0]),
    )
    np.testing.assert_allclose(x, [3.0, 0.0, 1.0, 1.0 + 1.5, 0.0])
    # pignistic variant: unknown cell has BetP(S) = 0.5, entropy 1 bit
    assert float(cell_uncertainty(0.0, 0.0, 1.0, 3.0, "pignistic")) == pytest.approx(4.0)


def test_cell_uncertainty_refuses_unknown_entropy_and_bad_weight():
    # a misspelt entropy must not fall back to the pignistic variant (4 bits instead of 3 for
    # an unknown cell), nor a negative or NaN q turn X negative or NaN
    with pytest.raises(ConfigError, match="entropy"):
        cell_uncertainty(0.0, 0.0, 1.0, 3.0, "Masses")
    with pytest.raises(ConfigError, match="q"):
        cell_uncertainty(0.0, 0.0, 1.0, -1.0)
    with pytest.raises(ConfigError, match="q"):
        cell_uncertainty(0.0, 0.0, 1.0, float("nan"))


def test_total_uncertainty_and_region():
    grid = DSGrid.from_extent(DSParams(), (0.0, 0.0), (4.0, 2.0), 0.5)
    assert grid.grid.shape == (8, 4)
    assert grid.total_uncertainty() == pytest.approx(3.0 * 32)
    grid.m_u[:] = 0.0
    grid.m_n[:] = 1.0
    grid.m_u[0, 0], grid.m_n[0, 0] = 1.0, 0.0
    assert grid.total_uncertainty() == pytest.approx(3.0)
    assert grid.total_uncertainty(region=((1.0, 0.0), (4.0, 2.0))) == pytest.approx(0.0)


def test_state_map_three_colours():
    grid = DSGrid(DSParams(), CellGrid((0.0, 0.0), 1.0, (4, 1)))
    grid.m_s[:, 0] = [0.7, 0.1, 0.3, 0.0]
    grid.m_n[:, 0] = [0.1, 0.8, 0.3, 0.0]
    grid.m_u[:, 0] = 1.0 - grid.m_s[:, 0] - grid.m_n[:, 0]
    np.testing.assert_array_equal(grid.state_map(0.5)[:, 0], [OCCUPIED, FREE, UNKNOWN, UNKNOWN])
    np.testing.assert_array_equal(grid.state_map(0.3)[:, 0], [OCCUPIED, FREE, UNKNOWN, UNKNOWN])
    with pytest.raises(ConfigError):
        grid.state_map(0.0)


def test_sources_are_mass_weighted_connected_regions():
    grid = DSGrid(DSParams(), CellGrid((10.0, 20.0), 0.5, (10, 10)))
    grid.m_s[2, 2], grid.m_s[3, 2] = 0.9, 0.6  # centres (11.25, 21.25), (11.75, 21.25)
    grid.m_s[7, 7] = 0.8
    grid.m_s[7, 8] = 0.8
    grid.m_s[7, 9] = 0.8
    grid.m_s[0, 9] = 0.4  # below threshold
    grid.m_u[:] = 1.0 - grid.m_s
    found = grid.sources(min_mass=0.5)
    assert len(found) == 2
    assert found[0].total_mass == pytest.approx(2.4) and found[0].n_cells == 3
    np.testing.assert_allclose(found[0].position, [13.75, 24.25])
    x = (0.9 * 11.25 + 0.6 * 11.75) / 1.5
    np.testing.assert_allclose(found[1].position, [x, 21.25])
    assert found[1].peak_mass == pytest.approx(0.9)
    assert len(grid.sources(min_mass=0.5, min_cells=3)) == 1
    assert len(grid.sources(min_mass=0.5, region=((10.0, 20.0), (12.5, 22.5)))) == 1
    assert len(grid.sources(min_mass=0.3)) == 3
    with pytest.raises(ConfigError):
        grid.sources(min_mass=1.5)


def test_update_with_patch_equals_dense_update():
    rng = np.random.default_rng(1)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2), (0, 0), (10, 10))
    for i in range(21):
        est.update(i * 0.5, (7.0, 5.0), np.array([0.8, 0.0]) + rng.normal(0, 0.1, 2), 1.0)
    a = DSGrid(DSParams(), est.grid)
    b = DSGrid(DSParams(), est.grid)
    for det in (True, False, True):
        a.update(est.path_patch(), det)
        b.update(est.path_map(), det)
    np.testing.assert_allclose(a.m_s, b.m_s, atol=1e-15)
    np.testing.assert_allclose(a.m_n, b.m_n, atol=1e-15)


def test_bad_input_raises():
    with pytest.raises(pydantic.ValidationError, match="mu_d"):
        DSParams(mu_d=1.2)
    with pytest.raises(pydantic.ValidationError, match="q"):
        DSParams(q=-1.0)
    with pytest.raises(pydantic.ValidationError, match="on_total_conflict"):
        DSParams(on_total_conflict="ignore")
    grid = DSGrid(DSParams(), CellGrid((0.0, 0.0), 1.0, (3, 3)))
    with pytest.raises(ConfigError, match="pi"):
        grid.update(np.zeros((4, 4)), True)
    with pytest.raises(ConfigError, match="pi"):
        grid.update(np.full((3, 3), -0.1), True)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.5), (0, 0), (3, 3))
    est.update(0.0, (1, 1), (1, 0))
    est.update(0.5, (1, 1), (1, 0))
    with pytest.raises(ConfigError, match="grid"):
        grid.update(est.path_patch(), True)


# ---------------------------------------------------------------------- two-source mapping
SOURCES = np.array([[2.0, 3.5], [4.0, 6.5]])
DT = 0.5


def _wind(t: float) -> np.ndarray:
    th = 0.45 * np.sin(2 * np.pi * t / 30.0) + 0.25 * np.sin(2 * np.pi * t / 11.0 + 1.0)
    return np.array([np.cos(th), np.sin(th)])


def _puff_concentration(p: np.ndarray, history: np.ndarray) -> float:
    """Gaussian puffs released continuously by both sources in a uniform, time-varying wind.

    ``history[m]`` is the wind ``m`` periods ago; the air now at ``p`` was at ``p - D(tau)``
    ``tau`` seconds ago, and a puff of age ``tau`` has spread to variance ``s0^2 + 2 K tau``.
    """
    disp = np.cumsum(history * DT, axis=0)  # (T, 2)
    tau = DT * np.arange(1, len(history) + 1)
    s2 = 0.05**2 + 2 * 0.01 * tau
    d = p[None, None, :] - disp[:, None, :] - SOURCES[None, :, :]
    g = np.exp(-np.sum(d * d, axis=2) / (2 * s2[:, None])) / (2 * np.pi * s2[:, None])
    return float(g.sum() * DT)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_two_source_experiment_maps_both_sources(seed):
    rng = np.random.default_rng(seed)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.2), (0, 0), (10, 10))
    ds = DSGrid(DSParams(), est.grid)
    lanes = []
    for k, x in enumerate(np.arange(0.5, 10.0, 1.0)):
        ys = np.arange(0.5, 9.51, 0.25)
        lanes += [(x, y) for y in (ys[::-1] if k % 2 else ys)]
    route = np.array(lanes * 3)  # three lawnmower rounds at 0.5 m/s
    history = np.zeros((40, 2))
    n_det = 0
    for i, p in enumerate(route):
        u = _wind(i * DT)
        history = np.vstack([u, history[:-1]])
        det = _puff_concentration(p, history) > 0.3 and rng.random() < 0.9
        n_det += det
        est.update(i * DT, p, u + rng.normal(0.0, 0.05, 2), float(det))
        ds.update(est.path_patch(), det)
    assert 50 < n_det < len(route) // 2
    found = ds.sources(min_mass=0.6)
    assert len(found) >= 2
    top = np.array([s.position for s in found[:2]])
    # each of the two heaviest regions sits on a different true source (regions are smeared
    # along the plume, as in the paper's Figs. 1-2, hence the tolerance)
    d = np.linalg.norm(top[:, None, :] - SOURCES[None, :, :], axis=2)
    assert (d[0, 0] < 0.8 and d[1, 1] < 0.8) or (d[0, 1] < 0.8 and d[1, 0] < 0.8)
    states = ds.state_map()
    for s in SOURCES:
        assert states[tuple(est.grid.index(s)[0])] == OCCUPIED
    # the air that reached the robot between and beside the plumes is mapped free
    for free in ([8.0, 1.0], [1.0, 9.0], [8.0, 9.0]):
        assert states[tuple(est.grid.index(free)[0])] == FREE
    assert ds.total_uncertainty() < 0.7 * 3.0 * est.grid.n_cells  # started at 3 per cell
    np.testing.assert_allclose(ds.m_s + ds.m_n + ds.m_u, 1.0, atol=1e-12)
