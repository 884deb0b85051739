"""Virtual-physics behaviours: formation forces (eqs. 1-2, 8), flux declaration, and the forces
between groups (repulsion eqs. 9-10, forbidden area eq. 11, rotary force eqs. 12-16)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.behaviours.formation import (
    FluxDeclaration,
    declaration_series,
    equilibrium_radius,
    formation_shape,
    hexagon_errors,
    regular_polygon,
    structure_force,
    structure_potential,
    structure_step,
)
from odorloc.behaviours.groups import (
    Bypass,
    in_forbidden_area,
    repulsion,
    rotary_force,
    rotary_sense,
)
from odorloc.core.errors import ConfigError

R, KR, KS, S1, S2 = 0.3, 5.0, 1.0e5, 0.06, 0.12


# ---------------------------------------------------------------------- eq. 1-2
def test_structure_force_hand_computed() -> None:
    # one robot: only the ring term, -k_s (x - c)(|x - c|^2 - r^2)
    f = structure_force([[0.5, 0.0]], [0.0, 0.0], R, KR, KS)
    np.testing.assert_allclose(f, [[-KS * 0.5 * (0.25 - 0.09), 0.0]])
    # two robots on the ring, 0.6 m apart: the ring term vanishes, charges repel with k_r / d^2
    f = structure_force([[0.3, 0.0], [-0.3, 0.0]], [0.0, 0.0], R, KR, KS)
    np.testing.assert_allclose(f, [[KR / 0.36, 0.0], [-KR / 0.36, 0.0]])


def test_structure_force_is_minus_the_gradient_of_each_robots_potential() -> None:
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.6, 0.6, (6, 2))
    c = np.array([0.05, -0.02])
    f = structure_force(x, c, R, KR, KS)
    h = 1e-7
    for k in range(6):
        for a in range(2):
            xp, xm = x.copy(), x.copy()
            xp[k, a] += h
            xm[k, a] -= h
            grad = (
                structure_potential(xp, c, R, KR, KS)[k] - structure_potential(xm, c, R, KR, KS)[k]
            ) / (2 * h)
            assert -grad == pytest.approx(f[k, a], rel=1e-5, abs=1e-3)


def test_equilibrium_radius_balances_the_charges_and_the_ring() -> None:
    Rq = equilibrium_radius(6, R, KR, KS)
    s = sum(1.0 / math.sin(math.pi * j / 6) for j in range(1, 6))
    assert KS * Rq * (Rq**2 - R**2) == pytest.approx(KR * s / (4 * Rq**2), rel=1e-9)
    assert R < Rq < 1.02 * R  # the default ring keeps the hexagon within 2 % of r
    # a regular hexagon at that radius is in equilibrium: every force is (numerically) zero
    hexagon = regular_polygon([0.0, 0.0], Rq, 6)
    assert np.abs(structure_force(hexagon, [0.0, 0.0], R, KR, KS)).max() < 1e-6 * KR / R**2


@pytest.mark.parametrize("seed", range(12))
def test_formation_converges_to_a_regular_hexagon_of_radius_r_from_random_starts(seed) -> None:
    rng = np.random.default_rng(seed)
    centre = np.array([5.0, 5.0])
    x = centre + rng.uniform(-1.5, 1.5, (6, 2))
    for _ in range(300):
        d = structure_step(x, centre, R, KR, KS, S2)
        assert np.all(np.linalg.norm(d, axis=1) <= S2 + 1e-12)  # eq. 8: never more than s2
        x = x + d
    shape = formation_shape(x, centre)
    side_err, rad_err = hexagon_errors(x, centre)
    assert side_err < 0.05 and rad_err < 0.05
    assert np.all(np.abs(shape.sides / R - 1.0) < 0.05)  # a hexagon of side (and radius) r
    assert np.all(np.abs(shape.radii / R - 1.0) < 0.05)
    assert shape.surrounds(R)


def test_formation_keeps_its_hexagon_while_the_virtual_robot_moves() -> None:
    rng = np.random.default_rng(1)
    c = np.zeros(2)
    x = regular_polygon(c, R, 6) + rng.normal(0, 0.05, (6, 2))
    for k in range(400):
        step = S1 * np.array([math.cos(k / 50), math.sin(k / 50)])
        c = c + step
        d = structure_step(x, c, R, KR, KS, S2, carry=step)
        assert np.all(np.linalg.norm(d, axis=1) <= S2 + 1e-12)
        x = x + d
    side_err, rad_err = hexagon_errors(x, c)
    assert side_err < 0.05 and rad_err < 0.05
    # eq. 8 read literally (no carry): the robots bunch up behind their moving leader
    y = regular_polygon(np.zeros(2), R, 6)
    c = np.zeros(2)
    for _ in range(200):
        c = c + np.array([S1, 0.0])
        y = y + structure_step(y, c, R, KR, KS, S2)
    assert formation_shape(y, c).max_gap > math.pi


def test_step_rules() -> None:
    rng = np.random.default_rng(5)
    x = rng.uniform(-1, 1, (6, 2))
    c = np.zeros(2)
    fixed = structure_step(x, c, R, KR, KS, S2, rule="fixed")
    np.testing.assert_allclose(np.linalg.norm(fixed, axis=1), S2)  # unit force x s2 (eq. 2, 8)
    capped = structure_step(x, c, R, KR, KS, S2)
    u = capped / np.maximum(np.linalg.norm(capped, axis=1, keepdims=True), 1e-300)
    f = structure_force(x, c, R, KR, KS)
    moved = np.linalg.norm(capped, axis=1) > 0
    np.testing.assert_allclose(u[moved], (f / np.linalg.norm(f, axis=1, keepdims=True))[moved])
    # the capped step never raises a robot's own potential (the others held still)
    before = structure_potential(x, c, R, KR, KS)
    for k in range(6):
        y = x.copy()
        y[k] += capped[k]
        assert structure_potential(y, c, R, KR, KS)[k] <= before[k] + 1e-12
    with pytest.raises(ConfigError, match="step_rule"):
        structure_step(x, c, R, KR, KS, S2, rule="jump")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="step"):
        structure_step(x, c, R, KR, KS, -1.0)


def test_formation_shape_and_surrounding() -> None:
    hexagon = regular_polygon([1.0, 2.0], R, 6)
    shape = formation_shape(hexagon, [1.0, 2.0])
    np.testing.assert_allclose(shape.sides, R)
    assert shape.max_gap == pytest.approx(math.pi / 3)
    assert shape.surrounds(R)
    half = regular_polygon([0, 0], R, 12)[:6]  # all on one side of the centre
    assert not formation_shape(half, [0, 0]).surrounds(R)
    far = hexagon.copy()
    far[0] += [1.0, 0.0]  # one robot off the ring
    assert not formation_shape(far, [1.0, 2.0]).surrounds(R)
    assert not formation_shape(hexagon[:2], [1.0, 2.0]).surrounds(R)


# ---------------------------------------------------------------------- declaration
def test_flux_declaration_counts_n_s_consecutive_steps() -> None:
    d = FluxDeclaration(0.05, 10)
    assert not any(d.update(0.2) for _ in range(9))
    assert d.update(0.2)  # the 10th consecutive step declares
    d.reset()
    for _ in range(9):
        d.update(0.2)
    assert not d.update(0.05)  # not above the threshold: the count starts again
    assert d.count == 0
    assert not any(d.update(0.2) for _ in range(9))
    assert not d.update(0.2, surrounds=False)  # the robots must surround their centre
    assert not any(d.update(0.3) for _ in range(9))
    assert d.update(0.3)
    with pytest.raises(ConfigError, match="n_s"):
        FluxDeclaration(0.05, 0)


# ---------------------------------------------------------------------- eqs. 9-10
def test_repulsion_only_inside_five_r() -> None:
    own = np.array([0.0, 0.0])
    np.testing.assert_allclose(repulsion(own, [[1.49, 0.0]], 5 * R), [-1.0, 0.0])
    np.testing.assert_allclose(repulsion(own, [[1.5, 0.0]], 5 * R), [0.0, 0.0])
    np.testing.assert_allclose(repulsion(own, [[0.0, 3.0]], 5 * R), [0.0, 0.0])
    both = repulsion(own, [[1.0, 0.0], [0.0, -1.0], [5.0, 5.0]], 5 * R)
    np.testing.assert_allclose(both, [-1.0, 1.0])  # unit pushes add (eq. 10)
    np.testing.assert_allclose(repulsion(own, np.zeros((0, 2)), 5 * R), [0.0, 0.0])


# ---------------------------------------------------------------------- eqs. 11-16
def test_forbidden_area_is_the_closed_circle_of_radius_r_t() -> None:
    assert in_forbidden_area([1.5, 0.0], [0.0, 0.0], 1.5)
    assert in_forbidden_area([1.0, 1.0], [0.0, 0.0], 1.5)
    assert not in_forbidden_area([1.2, 0.91], [0.0, 0.0], 1.5)


def test_rotary_force_directions_eqs_14_to_16() -> None:
    located = np.array([1.0, 1.0])
    own = np.array([3.0, 1.0])  # group 2 east of group 1
    # clockwise: (y2 - y1, -(x2 - x1)) = (0, -2), normalised
    np.testing.assert_allclose(rotary_force(own, located, "cw"), [0.0, -1.0])
    np.testing.assert_allclose(rotary_force(own, located, "ccw"), [0.0, 1.0])
    # moving along it turns own clockwise around located (the cross product is negative)
    step = rotary_force(own, located, "cw") * 0.06
    a0 = math.atan2(*(own - located)[::-1])
    a1 = math.atan2(*(own + step - located)[::-1])
    assert a1 < a0


def test_rotary_sense_follows_the_angle_test_eq_13() -> None:
    own, located = np.array([3.0, 1.0]), np.array([1.0, 1.0])
    # theta_1 (own -> located) = pi; a goal leaning below it (theta_2 = pi + 0.2 > theta_1)
    down = np.array([math.cos(math.pi + 0.2), math.sin(math.pi + 0.2)])
    up = np.array([math.cos(math.pi - 0.2), math.sin(math.pi - 0.2)])
    assert rotary_sense(own, located, down) == "cw"  # theta_1 <= theta_2: clockwise, downwards
    assert rotary_sense(own, located, up) == "ccw"
    assert rotary_force(own, located, rotary_sense(own, located, down))[1] < 0  # side of goal
    # the comparison holds across the x axis: located due east, goal just below +x
    own2, loc2 = np.array([0.0, 0.0]), np.array([2.0, 0.0])
    assert rotary_sense(own2, loc2, [math.cos(-0.1), math.sin(-0.1)]) == "ccw"
    assert rotary_sense(own2, loc2, [math.cos(0.1), math.sin(0.1)]) == "cw"


def test_rotary_force_is_kept_until_the_group_has_escaped() -> None:
    located = {6: np.array([0.0, 0.0])}
    by = Bypass(r_T=1.5)
    own = np.array([1.55, 0.0])
    goal = np.array([-1.0, -0.05]) / np.hypot(1.0, 0.05)  # into the circle, leaning clockwise
    d, why = by.steer(own, goal, located, S1)
    assert why == "rotary" and by.engaged == {6: "cw"}
    np.testing.assert_allclose(d, [0.0, -1.0])
    # the goal now leans the other way, still towards the located group: the sense is kept
    other = np.array([-1.0, 0.3]) / np.hypot(1.0, 0.3)
    d, why = by.steer(own, other, located, S1)
    assert why == "rotary" and by.engaged == {6: "cw"}
    # going round: the virtual robot never enters the forbidden circle
    x = own.copy()
    for _ in range(60):
        g = -x / np.linalg.norm(x)  # always straight at the located group
        d, why = by.steer(x, g, located, S1)
        if d is None:
            break
        x = x + S1 * d
        assert not in_forbidden_area(x, located[6], 1.5)
        assert why == "rotary"
    # escaped: a goal pointing away from the located group is followed as it is
    away = x / np.linalg.norm(x)
    d, why = by.steer(x, away, located, S1)
    assert why == "goal" and by.engaged == {}
    np.testing.assert_allclose(d, away)


def test_bypass_without_rotary_refuses_the_step_and_ignores_far_groups() -> None:
    located = {3: np.array([0.0, 0.0])}
    by = Bypass(r_T=1.5, rotary=False)
    d, why = by.steer([1.55, 0.0], [-1.0, 0.0], located, S1)
    assert d is None and why == "blocked"
    # a step that stays outside the circle is taken, even towards the group
    d, why = by.steer([3.0, 0.0], [-1.0, 0.0], located, S1)
    assert why == "goal"
    np.testing.assert_allclose(d, [-1.0, 0.0])
    d, why = Bypass(1.5).steer([1.55, 0.0], None, located, S1)
    assert d is None and why == "idle"


def test_clear_escape_slides_round_the_circle_and_keeps_the_sense() -> None:
    located = {6: np.array([0.0, 0.0])}
    by = Bypass(r_T=1.5, escape="clear")
    own = np.array([1.55, 0.0])
    west = np.array([-1.0, 0.0])  # an upwind goal force, straight through the circle
    d, why = by.steer(own, west + np.array([0.0, -0.05]), located, S1)
    assert why == "rotary" and by.engaged == {6: "cw"}
    x, reasons = own + S1 * d, []
    while x[0] > -1.0:  # the goal is followed whenever a step along it stays outside
        d, why = by.steer(x, west, located, S1)
        reasons.append(why)
        x = x + S1 * d
        assert not in_forbidden_area(x, located[6], 1.5)
        assert len(reasons) < 500
    assert "goal" in reasons and "rotary" in reasons
    assert x[1] < -1.4  # round the bottom, the side the group had turned to
    # "goal-away" turns without a goal step until west no longer points at the located group
    away = Bypass(r_T=1.5)
    d, why = away.steer(own, west + np.array([0.0, -0.05]), located, S1)
    x, reasons = own + S1 * d, [why]
    while x[0] > 0.0:
        d, why = away.steer(x, west, located, S1)
        reasons.append(why)
        x = x + S1 * d
    assert set(reasons) == {"rotary"}
    # coming back towards the circle later, the group turns the same way (the kept sense)
    lean = np.array([-1.0, 0.1]) / np.hypot(1.0, 0.1)  # would choose ccw afresh
    d, why = by.steer(np.array([1.55, 0.02]), lean, located, S1)
    assert why == "rotary" and by.engaged == {6: "cw"}
    # beyond the release distance the sense is forgotten
    by.steer(np.array([10.0, 0.0]), west, located, S1)
    d, why = by.steer(np.array([1.55, 0.02]), lean, located, S1)
    assert by.engaged == {6: "ccw"}


@pytest.mark.parametrize("reading", ["consecutive", "window", "mean"])
def test_declaration_series_is_what_flux_declaration_says_step_by_step(reading: str) -> None:
    rng = np.random.default_rng(3)
    flux = rng.normal(0.06, 0.05, (300, 5))
    surrounds = rng.random((300, 5)) > 0.1
    got = declaration_series(flux, 0.05, 6, reading, 15, surrounds)
    for m in range(5):
        d = FluxDeclaration(0.05, 6, reading, 15)
        want = [d.update(flux[t, m], surrounds[t, m]) for t in range(300)]
        assert np.array_equal(got[:, m], want)
    assert 0 < got.mean() < 1  # the test exercises both outcomes


def test_declaration_readings_on_an_alternating_flux() -> None:
    """A 2-cycle above and below Phi_T (chemotaxis at the edge of the region): never n_s in a
    row, n_s of a window of 3 n_s after 2 n_s - 1 steps, a mean that follows the amplitudes."""
    flux = np.tile([0.09, 0.02], 20)  # mean 0.055 > 0.05
    fired = {}
    for r in ("consecutive", "window", "mean"):  # the whole series fed to one declaration
        d = FluxDeclaration(0.05, 10, r)
        fired[r] = [d.update(f) for f in flux]
    assert not any(fired["consecutive"])
    assert fired["window"].index(True) == 2 * 10 - 2  # the 10th step above: step 19 (index 18)
    assert fired["mean"].index(True) == 9  # ten steps whose mean is 0.055 > 0.05
    d = FluxDeclaration(0.05, 10, "mean")
    assert not any(d.update(f) for f in np.tile([0.07, 0.02], 20))  # mean 0.045 < 0.05


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"reading": "most"}, "reading"), ({"window": 5}, "window"), ({"steps": 0}, "n_s")],
)
def test_bad_declaration_settings_are_refused(kwargs: dict, field: str) -> None:
    args = {"threshold": 0.05, "steps": 10, "reading": "window"}
    args.update(kwargs)
    with pytest.raises(ConfigError) as err:
        FluxDeclaration(**args)
    assert err.value.field == field
