"""Wind models: a shared contract for every model, then per-model physics and statistics."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pydantic
import pytest

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.models.gaussian import GaussianParams
from odorloc.plume import GaussianPlume, ReplayParams, ReplayWind, record_movie
from odorloc.plume.sources import Source
from odorloc.wind import (
    FarrellWind,
    FarrellWindParams,
    MeanderWind,
    MeanderWindParams,
    Opening,
    PotentialWind,
    PotentialWindParams,
    SecondOrderNoise,
    UniformWind,
    UniformWindParams,
    WindModel,
)
from odorloc.wind.farrell import advect_diffuse_step


def _arena(dim: int) -> Arena:
    if dim == 2:
        return Arena.box((0.0, 0.0), (10.0, 6.0), 0.2)
    return Arena.box((0.0, 0.0, 0.0), (10.0, 6.0, 3.0), 0.2)


def _replayed_meander(a: Arena) -> ReplayWind:
    """The wind of a recorded movie of a meandering wind, so that it changes between frames;
    the movie lasts as long as a :func:`_roll`."""
    wind = MeanderWind(MeanderWindParams(speed_std=0.2, vertical_std=0.05), a)
    source = Source(position=tuple(float(v) for v in a.lo + 0.25 * a.size))
    plume = GaussianPlume(GaussianParams(), a, wind, [source])
    rng = np.random.default_rng(11)
    wind.reset(rng)
    plume.reset(rng)
    movie = record_movie((plume, wind), 9.0, 0.6, rng, dt=0.3)
    return ReplayWind(ReplayParams(), a, movie=movie)


FACTORIES: dict[str, Callable[[Arena], WindModel]] = {
    "uniform": lambda a: UniformWind(
        UniformWindParams(velocity=(1.0, 0.2) if a.dim == 2 else (1.0, 0.2, 0.0)), a
    ),
    "meander": lambda a: MeanderWind(MeanderWindParams(speed_std=0.2, vertical_std=0.05), a),
    "farrell": lambda a: FarrellWind(FarrellWindParams(nodes=(8, 6)), a),
    "potential": lambda a: PotentialWind(PotentialWindParams(modulation="rotate"), a),
    "replay": _replayed_meander,
}

# A float field of each model's parameters to poison with NaN (the replayed wind has none: a
# movie path and a loop flag).
NAN_FIELD = {"uniform": "velocity", "meander": "speed", "farrell": "speed", "potential": "vertical"}


def _roll(model: WindModel, seed: int, steps: int = 30, dt: float = 0.3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    model.reset(rng)
    pts = np.column_stack([np.linspace(0.5, 9.5, 7), np.linspace(0.5, 5.5, 7)])
    if model.dim == 3:
        pts = np.column_stack([pts, np.full(7, 1.0)])
    out = []
    for _ in range(steps):
        model.step(dt, rng)
        out.append(model.velocity(pts))
    return np.array(out)


# ---------------------------------------------------------------------- contract
def test_every_model_here_is_registered() -> None:
    assert sorted(FACTORIES) == sorted(registry.names("wind"))
    assert set(FACTORIES) - set(NAN_FIELD) == {"replay"}
    for name in FACTORIES:
        assert registry.entry("wind", name).params is type(FACTORIES[name](_arena(2)).params)


@pytest.mark.parametrize("name", sorted(FACTORIES))
@pytest.mark.parametrize("dim", [2, 3])
def test_contract_shapes_finite_deterministic(name: str, dim: int) -> None:
    a = _arena(dim)
    v1 = _roll(FACTORIES[name](a), seed=7)
    v2 = _roll(FACTORIES[name](a), seed=7)
    assert v1.shape == (30, 7, dim)
    assert np.all(np.isfinite(v1))
    np.testing.assert_array_equal(v1, v2)
    m = FACTORIES[name](a)
    m.reset(np.random.default_rng(0))
    assert m.velocity(np.zeros((0, dim))).shape == (0, dim)
    assert m.velocity(np.full(dim, 1.0)).shape == (1, dim)
    assert m.mean_velocity().shape == (dim,)


@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_contract_different_seeds_differ_for_stochastic_models(name: str) -> None:
    m = FACTORIES[name](_arena(2))
    if m.deterministic:
        pytest.skip("deterministic model: no seed enters its velocities")
    assert not np.array_equal(_roll(m, 1), _roll(FACTORIES[name](_arena(2)), 2))


@pytest.mark.parametrize("name", sorted(FACTORIES))
@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_contract_bad_dt_raises(name: str, dt: float) -> None:
    m = FACTORIES[name](_arena(2))
    m.reset(np.random.default_rng(0))
    with pytest.raises(ConfigError) as exc:
        m.step(dt, np.random.default_rng(0))
    assert exc.value.field == "dt"


@pytest.mark.parametrize("name", sorted(NAN_FIELD))
def test_contract_nan_param_raises_naming_field(name: str) -> None:
    fld = NAN_FIELD[name]
    value: object = (math.nan, 0.0) if fld == "velocity" else math.nan
    with pytest.raises(ConfigError) as exc:
        registry.make_params("wind", name, {fld: value})
    assert exc.value.field.split("[")[0] == fld


@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_contract_points_of_wrong_dimension_raise(name: str) -> None:
    m = FACTORIES[name](_arena(2))
    with pytest.raises(ConfigError):
        m.velocity(np.zeros((4, 3)))


# ---------------------------------------------------------------------- second-order noise
def test_noise_discretisation_is_exact_composition() -> None:
    n = SecondOrderNoise(1, omega=0.9, damping=0.4)
    F1, L1 = n.transition(0.1)
    F2, L2 = n.transition(0.2)
    np.testing.assert_allclose(F1 @ F1, F2, atol=1e-12)
    Q1, Q2 = L1 @ L1.T, L2 @ L2.T
    np.testing.assert_allclose(F1 @ Q1 @ F1.T + Q1, Q2, atol=1e-12)


@pytest.mark.parametrize("dt", [0.01, 0.1])
@pytest.mark.parametrize("damping", [0.4, 1.6])
def test_noise_statistics_do_not_depend_on_dt(dt: float, damping: float) -> None:
    """Stationary std 1 and the closed-form autocorrelation at 1 s and 3 s, for any dt.

    4000 independent channels; the standard error of a correlation estimate is
    about (1 - rho^2) / sqrt(4000) < 0.016, tolerance 0.05.
    """
    rng = np.random.default_rng(123)
    n = SecondOrderNoise(4000, omega=2 * math.pi * 0.15, damping=damping)
    n.reset(rng)
    x0 = n.value.copy()
    out = {}
    steps = round(3.0 / dt)
    for k in range(1, steps + 1):
        n.step(dt, rng)
        if k in (round(1.0 / dt), steps):
            out[k * dt] = n.value.copy()
    for lag, x in out.items():
        assert np.std(x) == pytest.approx(1.0, abs=0.05)
        rho = np.corrcoef(x0, x)[0, 1]
        assert rho == pytest.approx(float(n.autocorrelation(lag)), abs=0.05), lag


def test_noise_autocorrelation_closed_form_limits() -> None:
    for z in (0.5, 1.0, 2.0):
        n = SecondOrderNoise(1, omega=1.3, damping=z)
        assert float(n.autocorrelation(0.0)) == pytest.approx(1.0)
        assert abs(float(n.autocorrelation(40.0))) < 1e-3


# ---------------------------------------------------------------------- meander
def test_meander_direction_bounded_and_swinging() -> None:
    p = MeanderWindParams(speed=5.0, direction=0.0, direction_swing=22.5, frequency_factor=3)
    m = MeanderWind(p, _arena(2))
    rng = np.random.default_rng(5)
    m.reset(rng)
    dirs, speeds = [], []
    for _ in range(4000):
        m.step(0.1, rng)
        u = m.current()
        dirs.append(math.degrees(math.atan2(u[1], u[0])))
        speeds.append(np.hypot(*u))
    dirs_a = np.array(dirs)
    assert np.all(np.abs(dirs_a) < 22.5)
    assert np.abs(dirs_a).max() > 15.0
    np.testing.assert_allclose(speeds, 5.0)  # speed_std = 0: constant 5 m/s as in the paper


def test_meander_frequency_factor_scales_time() -> None:
    base = MeanderWindParams(frequency=0.05)
    treble = MeanderWindParams(frequency=0.05, frequency_factor=3)
    a = MeanderWind(base, _arena(2)).noise
    b = MeanderWind(treble, _arena(2)).noise
    assert b.omega == pytest.approx(3 * a.omega)
    # Same correlation after a third of the lag.
    assert float(b.autocorrelation(2.0)) == pytest.approx(float(a.autocorrelation(6.0)))


@pytest.mark.parametrize("mode", ["tanh", "clip", "gaussian"])
def test_meander_swing_modes(mode: str) -> None:
    from odorloc.wind.meander import swing

    x = np.linspace(-5, 5, 101)
    s = swing(x, 20.0, mode)  # type: ignore[arg-type]
    assert s[50] == 0.0
    assert np.all(np.diff(s) >= 0)
    if mode == "gaussian":
        assert s[-1] == pytest.approx(100.0)
    else:
        assert np.abs(s).max() <= 20.0


def test_meander_3d_vertical_mean() -> None:
    m = MeanderWind(MeanderWindParams(vertical=0.3), _arena(3))
    m.reset(np.random.default_rng(0))
    v = m.velocity([[1.0, 1.0, 1.0], [5.0, 2.0, 0.5]])
    np.testing.assert_allclose(v[:, 2], 0.3)
    np.testing.assert_allclose(v[0], v[1])


def test_meander_rejects_past_time() -> None:
    m = MeanderWind(MeanderWindParams(), _arena(2))
    m.reset(np.random.default_rng(0))
    m.step(0.5, np.random.default_rng(0))
    with pytest.raises(ConfigError):
        m.velocity([[1.0, 1.0]], t=0.0)


# ---------------------------------------------------------------------- farrell
def test_farrell_uniform_field_is_a_fixed_point() -> None:
    u = np.full((6, 5), 1.3)
    v = np.full((6, 5), -0.4)
    un, vn = advect_diffuse_step(u, v, 0.5, 0.5, 1.0, 1.0, 0.05)
    np.testing.assert_allclose(un, u, atol=1e-14)
    np.testing.assert_allclose(vn, v, atol=1e-14)


def test_farrell_diffusion_matches_heat_equation_mode() -> None:
    """With u = 0 the v equation is pure diffusion: a sine mode decays as exp(-K/2 k^2 t)."""
    nx, ny, L = 3, 41, 4.0
    y = np.linspace(0, L, ny)
    dy = y[1] - y[0]
    v = np.tile(0.01 * np.sin(np.pi * y / L), (nx, 1))
    u = np.zeros_like(v)
    K, dt, T = 1.0, 0.002, 0.5
    for _ in range(round(T / dt)):
        # x-direction neighbours equal the centre, so only the y Laplacian acts.
        u, v = advect_diffuse_step(u, np.vstack([v[1:2], v[1:2], v[1:2]]), 1.0, dy, K, K, dt)
    expected = 0.01 * np.sin(np.pi * y[ny // 2] / L) * math.exp(-0.5 * K * (np.pi / L) ** 2 * T)
    # Advection of v by its own (small) value adds O(1e-4) relative changes.
    assert v[1, ny // 2] == pytest.approx(expected, rel=3e-3)


def test_farrell_long_run_stable_mean_smooth_and_time_varying() -> None:
    p = FarrellWindParams(speed=1.0, direction=0.0, noise_std=0.3)
    arena = Arena.box((18.7, 40.3), (32.7, 60.3), 0.5)
    w = FarrellWind(p, arena)
    rng = np.random.default_rng(11)
    w.reset(rng)
    probe = np.array([[25.0, 50.0]])
    means, probes = [], []
    for _ in range(2400):  # 1200 s in 0.5 s frames as in the multi-source paper
        w.step(0.5, rng)
        means.append(w.mean_velocity())
        probes.append(w.velocity(probe)[0])
    assert np.all(np.isfinite(w.u)) and np.all(np.isfinite(w.v))
    means_a, probes_a = np.array(means), np.array(probes)
    np.testing.assert_allclose(means_a.mean(axis=0), [1.0, 0.0], atol=0.12)
    assert probes_a.std(axis=0).min() > 0.05  # time varying
    assert np.abs(probes_a).max() < 3.0
    # Neighbouring nodes differ by far less than the noise amplitude: a smooth field.
    gx = np.abs(np.diff(w.u, axis=0)).max()
    gy = np.abs(np.diff(w.u, axis=1)).max()
    assert max(gx, gy) < 0.25


def test_farrell_velocity_interpolates_nodes_and_layers_in_3d() -> None:
    a3 = _arena(3)
    w = FarrellWind(FarrellWindParams(nodes=(5, 4), vertical=0.1), a3)
    w.reset(np.random.default_rng(3))
    for _ in range(10):
        w.step(0.5, np.random.default_rng(4))
    v = w.velocity([[w.x[2], w.y[1], 0.0], [w.x[2], w.y[1], 2.9]])
    assert v[0, 0] == pytest.approx(w.u[2, 1]) and v[0, 1] == pytest.approx(w.v[2, 1])
    np.testing.assert_allclose(v[0, :2], v[1, :2])
    np.testing.assert_allclose(v[:, 2], 0.1)
    mid = w.velocity([[0.5 * (w.x[2] + w.x[3]), w.y[1], 1.0]])[0, 0]
    assert mid == pytest.approx(0.5 * (w.u[2, 1] + w.u[3, 1]))


def test_farrell_rejects_tiny_grid() -> None:
    with pytest.raises(pydantic.ValidationError, match="nodes"):
        FarrellWindParams(nodes=(2, 15))


# ---------------------------------------------------------------------- potential
def _channel() -> tuple[Arena, PotentialWind]:
    arena = Arena.box((0.0, 0.0), (6.0, 3.0), 0.1).with_boxes([((2.5, 1.0), (3.5, 2.0))])
    return arena, PotentialWind(PotentialWindParams(), arena)


def test_potential_divergence_free_and_flux_balance() -> None:
    _, w = _channel()
    div = w.divergence()[w.fluid]
    assert np.abs(div).max() < 1e-9 * 1.0 / w.h
    assert w.inflow_rate() == pytest.approx(3.0)  # 1 m/s over the 3 m left face
    assert w.outflow_rate() == pytest.approx(w.inflow_rate(), rel=1e-9)


def test_potential_zero_normal_velocity_at_walls_and_obstacles() -> None:
    _, w = _channel()
    xs = np.linspace(0.05, 5.95, 50)
    bottom = w.velocity(np.column_stack([xs, np.zeros_like(xs)]))
    top = w.velocity(np.column_stack([xs, np.full_like(xs, 3.0)]))
    assert np.abs(bottom[:, 1]).max() < 1e-12 and np.abs(top[:, 1]).max() < 1e-12
    # Obstacle faces: cells with centres in [2.5, 3.5] x [1.0, 2.0] -> x in [2.5, 3.5]
    # (cells 25..34) and y in [1.0, 2.0] (cells 10..19, centres 1.05..1.95).
    ys = np.linspace(1.01, 1.99, 30)
    left = w.velocity(np.column_stack([np.full_like(ys, 2.5), ys]))
    right = w.velocity(np.column_stack([np.full_like(ys, 3.5), ys]))
    assert np.abs(left[:, 0]).max() < 1e-12 and np.abs(right[:, 0]).max() < 1e-12
    xs_o = np.linspace(2.51, 3.49, 30)
    under = w.velocity(np.column_stack([xs_o, np.full_like(xs_o, 1.0)]))
    assert np.abs(under[:, 1]).max() < 1e-12
    inside = w.velocity([[3.0, 1.5], [2.7, 1.2]])
    np.testing.assert_array_equal(inside, 0.0)
    # Slightly off the face the normal velocity is still small (linear in distance).
    near = w.velocity(np.column_stack([np.full_like(ys, 2.5 - 1e-4), ys]))
    assert np.abs(near[:, 0]).max() < 1e-2


def test_potential_flow_goes_around_obstacle() -> None:
    arena, w = _channel()
    # Stagnation in front of the block, acceleration beside it.
    front = w.velocity([[2.45, 1.5]])[0]
    beside = w.velocity([[3.0, 0.5], [3.0, 2.5]])
    assert abs(front[0]) < 0.3
    assert np.all(beside[:, 0] > 1.2)
    # A streamline started upstream at the block's mid-height passes it without entering.
    p = np.array([0.2, 1.45])  # just off the symmetry line (exactly on it: stagnation)
    ys_beside = []
    for _ in range(4000):
        p = p + 0.005 * w.velocity(p)[0]
        assert not arena.in_obstacle(p)[0]
        if 2.5 <= p[0] <= 3.5:
            ys_beside.append(p[1])
        if p[0] > 4.0:
            break
    assert p[0] > 4.0
    assert max(ys_beside) < 1.0  # it went under the block
    assert abs(p[1] - 1.45) < 0.1  # and closed back behind it


def test_potential_indoor_room_fan_from_source_to_starts() -> None:
    """Indoor-pf-entropy room: fan behind the source (0, 0), outlet beyond the start points."""
    arena = Arena.box((-0.3, -0.3), (2.7, 4.7), 0.05).with_boxes([((1.0, 1.6), (1.6, 2.0))])
    p = PotentialWindParams(
        inlets=[Opening(side="bottom", interval=(-0.3, 0.4), speed=1.0)],
        outlets=[Opening(side="top", interval=(1.2, 2.7))],
    )
    w = PotentialWind(p, arena)
    assert w.outflow_rate() == pytest.approx(w.inflow_rate(), rel=1e-9)
    assert w.inflow_rate() == pytest.approx(0.7, rel=1e-6)
    assert np.abs(w.divergence()[w.fluid]).max() < 1e-9 / w.h
    src = np.array([0.0, 0.0])
    u_src = w.velocity(src)[0]
    assert u_src[1] > 0.3
    starts = np.array([[1.90, 2.50], [2.00, 3.00], [2.15, 3.60], [2.40, 4.00], [2.40, 4.55]])
    u = w.velocity(starts)
    # Air at every start point moves away from the source (downwind search start).
    assert np.all(np.einsum("ij,ij->i", u, starts - src) > 0)
    assert np.all(u[:, 1] > 0)


def test_potential_prescribed_outflow_balance() -> None:
    arena = Arena.box((0.0, 0.0), (4.0, 2.0), 0.1)
    ok = PotentialWindParams(
        inlets=[Opening(side="left", speed=1.0)],
        outlets=[Opening(side="top", interval=(2.0, 4.0), speed=1.0)],
    )
    w = PotentialWind(ok, arena)
    assert np.abs(w.divergence()).max() < 1e-9 / w.h
    np.testing.assert_allclose(w.uy[20:, -1], 1.0)
    bad = PotentialWindParams(
        inlets=[Opening(side="left", speed=1.0)],
        outlets=[Opening(side="top", interval=(2.0, 4.0), speed=0.5)],
    )
    with pytest.raises(ConfigError, match="balance"):
        PotentialWind(bad, arena)


def test_potential_bad_openings() -> None:
    arena = Arena.box((0.0, 0.0), (4.0, 2.0), 0.1)
    with pytest.raises(ConfigError) as exc:
        PotentialWind(
            PotentialWindParams(inlets=[Opening(side="left", interval=(1.0, 5.0), speed=1.0)]),
            arena,
        )
    assert exc.value.field == "wind.inlets[0].interval"
    with pytest.raises(ConfigError) as exc:
        PotentialWind(
            PotentialWindParams(
                inlets=[Opening(side="left", speed=1.0)], outlets=[Opening(side="left")]
            ),
            arena,
        )
    assert exc.value.field == "wind.outlets[0].interval"
    with pytest.raises(ConfigError, match="speed") as exc:
        registry.make_params("wind", "potential", {"inlets": [{"side": "left"}]})
    assert exc.value.field == "inlets"
    with pytest.raises(ConfigError) as exc:
        registry.make_params("wind", "potential", {"outlets": []})
    assert exc.value.field == "outlets"
    with pytest.raises(ConfigError) as exc:
        registry.make_params("wind", "potential", {"inlets": [{"side": "front", "speed": 1}]})
    assert "inlets" in exc.value.field


def test_potential_enclosed_pocket_has_no_flow() -> None:
    arena = Arena.box((0.0, 0.0), (4.0, 2.0), 0.1)
    occ = np.zeros(arena.grid_shape, bool)
    occ[25:35, 5:15] = True
    occ[27:33, 7:13] = False  # a hollow box: enclosed free cells
    arena = Arena(arena.lower, arena.upper, arena.resolution, occ)
    w = PotentialWind(PotentialWindParams(), arena)
    np.testing.assert_array_equal(w.velocity([[3.0, 1.0]]), 0.0)
    assert w.outflow_rate() == pytest.approx(2.0)


def test_potential_scale_modulation_keeps_shape() -> None:
    arena, _ = _channel()
    w = PotentialWind(PotentialWindParams(modulation="scale", speed_std=0.3), arena)
    rng = np.random.default_rng(2)
    w.reset(rng)
    pts = np.array([[1.0, 0.5], [3.0, 2.5], [5.0, 1.5]])
    base = w.base_velocity(pts)
    factors = []
    for _ in range(50):
        w.step(0.5, rng)
        v = w.velocity(pts)
        f = v[0, 0] / base[0, 0]
        np.testing.assert_allclose(v, f * base, rtol=1e-12, atol=1e-15)
        factors.append(f)
    assert np.std(factors) > 0.01


def test_potential_3d_extrudes_obstacle_columns() -> None:
    arena = Arena.box((0.0, 0.0, 0.0), (4.0, 2.0, 1.0), 0.1).with_boxes(
        [((1.5, 0.5, 0.0), (2.5, 1.5, 0.5))]
    )
    w = PotentialWind(PotentialWindParams(vertical=0.05), arena)
    assert not w.fluid[20, 10]  # the column under a partial-height box is blocked
    v = w.velocity([[2.0, 1.0, 0.2], [2.0, 1.0, 0.9], [0.5, 1.0, 0.5]])
    np.testing.assert_array_equal(v[:2, :2], 0.0)
    np.testing.assert_allclose(v[:, 2], 0.05)
    assert v[2, 0] > 0.5


def test_potential_params_round_trip_and_rotation() -> None:
    p = PotentialWindParams(
        inlets=[Opening(side="bottom", interval=(0.0, 1.0), speed=0.6)],
        outlets=[Opening(side="top")],
        modulation="rotate",
        direction_swing=30.0,
        speed_std=0.0,
    )
    q = registry.make_params("wind", "potential", p.model_dump())
    assert q == p
    arena = Arena.box((0.0, 0.0), (3.0, 3.0), 0.1)
    w = PotentialWind(p, arena)
    rng = np.random.default_rng(8)
    w.reset(rng)
    pt = np.array([[1.5, 1.5]])
    base = w.base_velocity(pt)[0]
    angles = []
    for _ in range(200):
        w.step(0.5, rng)
        v = w.velocity(pt)[0]
        assert np.linalg.norm(v) == pytest.approx(np.linalg.norm(base))  # pure rotation
        angles.append(math.degrees(math.atan2(v[1], v[0]) - math.atan2(base[1], base[0])))
    assert max(np.abs(angles)) < 30.0
    assert np.std(angles) > 3.0


@pytest.mark.parametrize(
    ("nodes", "upper", "diffusivity"),
    [
        ((1000, 1000), (10.0, 10.0), 1.0),
        ((15, 15), (0.1, 0.1), 1.0),
        ((101, 101), (10.0, 10.0), 100.0),
    ],
)
def test_farrell_refuses_grids_that_need_countless_substeps(
    nodes: tuple[int, int], upper: tuple[float, float], diffusivity: float
) -> None:
    from odorloc.wind.farrell import MAX_SUBSTEPS_PER_SECOND

    # each of these took over 10 000 sub-steps per 0.25 s world step: minutes to hours per step
    params = FarrellWindParams(nodes=nodes, diffusivity=(diffusivity, diffusivity))
    with pytest.raises(ConfigError, match="fewer nodes") as err:
        FarrellWind(params, Arena.box((0.0, 0.0), upper, 0.01))
    assert err.value.field == "nodes"
    assert str(MAX_SUBSTEPS_PER_SECOND) in err.value.problem


def test_farrell_substep_count_follows_the_stability_limit() -> None:
    w = FarrellWind(FarrellWindParams(nodes=(101, 101)), Arena.box((0.0, 0.0), (10.0, 10.0), 0.1))
    w.reset(np.random.default_rng(0))
    rate = np.abs(w.u).max() / w.dx + np.abs(w.v).max() / w.dy + 1.0 / w.dx**2 + 1.0 / w.dy**2
    assert w.substeps(0.25) == math.ceil(0.25 * rate / 0.5)
    assert w.substeps(1e-9) == 1


def test_farrell_scenarios_keep_their_wind_and_name_the_field_of_a_fine_grid() -> None:
    from odorloc.scenarios import get_scenario
    from odorloc.scenarios.build import build_world
    from odorloc.scenarios.config import Scenario

    for name in ("two-sources-farrell", "muc-osl-filament-3d"):
        sc = get_scenario(name)
        w = build_world(sc).wind
        assert isinstance(w, FarrellWind)
        w.reset(np.random.default_rng(1))
        assert w.substeps(sc.world.dt) == 1
    data = get_scenario("two-sources-farrell").to_dict()
    data["world"]["wind"].update(nodes=[1000, 1000], diffusivity=[10.0, 10.0])
    with pytest.raises(ConfigError) as err:
        build_world(Scenario.from_dict(data))
    assert err.value.field == "world.wind.nodes"
