"""Behaviours, one implementation each: their decisions on hand-made situations."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from odorloc.behaviours.escape import first_free, free_step
from odorloc.behaviours.monitor import MaxTracker, PassiveMonitor
from odorloc.behaviours.spiral import Spiral, SpiralParams, proximity_index
from odorloc.behaviours.surge_cast import CastParams, SurgeCast
from odorloc.behaviours.zigzag import Zigzag
from odorloc.core.errors import ConfigError
from odorloc.core.types import Observation
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import directions_26, fan, lattice_moves, ring, rotate2, upwind_unit

OPEN = Arena.box((0.0, 0.0), (10.0, 10.0), 0.1)


def test_first_free_takes_the_first_unblocked_candidate() -> None:
    arena = OPEN.with_boxes([((5.2, 4.0), (6.0, 6.0))])
    pos = np.array([5.0, 5.0])
    cand = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    assert first_free(arena, pos, cand) == 1  # +x runs into the box
    assert first_free(arena, pos, np.zeros((0, 2))) is None
    boxed = Arena.box((4.9, 4.9), (5.1, 5.1), 0.05)
    assert first_free(boxed, pos, cand) is None
    assert free_step(OPEN, pos, [0.0, 0.0], 3.0)  # no direction: nothing to block


def test_vector_helpers() -> None:
    np.testing.assert_allclose(rotate2([1.0, 0.0, 0.5], math.pi / 2), [0.0, 1.0, 0.5], atol=1e-15)
    np.testing.assert_allclose(upwind_unit([2.0, 0.0], 0.0), [-1.0, 0.0])
    np.testing.assert_allclose(upwind_unit([0.0, 0.0], math.pi / 2), [0.0, 1.0], atol=1e-15)
    # a NaN wind is not calm air
    with pytest.raises(ConfigError, match="wind"):
        upwind_unit([math.nan, 0.0], 0.0)
    assert ring(16, 3).shape == (16, 3)
    np.testing.assert_allclose(np.linalg.norm(ring(7, 2), axis=1), 1.0)
    np.testing.assert_allclose(fan([1.0, 0.0], [0, 90])[1], [0.0, 1.0], atol=1e-15)
    np.testing.assert_array_equal(lattice_moves(2), [[-1, 0], [1, 0], [0, -1], [0, 1]])
    assert lattice_moves(3, stay=True).shape == (7, 3)
    d = directions_26()
    assert d.shape == (26, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert len({tuple(np.sign(v).astype(int)) for v in d}) == 26  # every neighbour once


def test_zigzag_mirrors_at_walls_and_turns_after_max_leg() -> None:
    up = np.array([-1.0, 0.0])
    z = Zigzag(math.radians(45.0))
    d = z.direction(OPEN, np.array([5.0, 5.0]), up, 1.0, 0.5)
    np.testing.assert_allclose(d, rotate2(up, math.radians(45.0)))
    # Near the y = 0 wall the current leg (towards -x, -y) is blocked: the mirror leg is taken.
    d = z.direction(OPEN, np.array([5.0, 0.5]), up, 1.0, 0.5)
    assert d[1] > 0 and z.side == -1.0
    # Against the upwind wall both upwind legs are blocked: progress reverses (downwind).
    d = z.direction(OPEN, np.array([0.3, 5.0]), up, 1.0, 0.5)
    assert d[0] > 0 and z.along == -1.0
    legs = Zigzag(math.radians(45.0), max_leg=1.0)
    sides = [legs.side]
    for _ in range(6):
        legs.direction(OPEN, np.array([5.0, 5.0]), up, 0.5, 0.5)
        sides.append(legs.side)
    # without walls every leg is max_leg / advance = 1.0 / 0.5 = 2 steps long
    assert sides == [1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0]


def test_surge_then_widening_casts() -> None:
    p = CastParams(angle_deg=90.0, amplitude=0.4, growth=2.0)
    sc = SurgeCast(p, surge_steps=2)
    up = np.array([-1.0, 0.0])
    sc.start_surge()
    assert sc.surging
    np.testing.assert_allclose(sc.direction(OPEN, np.array([5.0, 5.0]), up, 0.2), up)
    np.testing.assert_allclose(sc.direction(OPEN, np.array([5.0, 5.0]), up, 0.2), up)
    assert not sc.surging
    dirs = [sc.direction(OPEN, np.array([5.0, 5.0]), up, 0.2) for _ in range(8)]
    ys = [round(float(d[1])) for d in dirs]
    # 90 deg casts: 2 steps of 0.2 m one way (0.4 m), then 4 steps the other way (0.8 m)
    assert ys[:2] == [-1, -1] and ys[2:6] == [1, 1, 1, 1] and ys[6:] == [-1, -1]


def test_monitors() -> None:
    m, t = PassiveMonitor(), MaxTracker()
    obs = [
        Observation(0, k * 0.5, np.array([k, 0.0]), 0.0, g, g > 1.0, np.zeros(2))
        for k, g in enumerate([0.5, 2.0, 0.1, 3.0])
    ]
    assert [m.update(o) for o in obs] == [False, True, False, False]
    assert m.arrival == 0.5
    for o in obs:
        t.update(o)
    assert t.best == 3.0 and t.pos.tolist() == [3.0, 0.0]


def test_spiral_legs_grow_every_second_leg() -> None:
    s = Spiral(SpiralParams(initial_step=1.0, step_increment=0.5))
    legs = [s.next_offset() for _ in range(6)]
    np.testing.assert_allclose(legs[0], [1.0, 1.0])  # diagonal first leg, facing 45 deg
    lengths = [float(np.linalg.norm(v)) for v in legs[1:]]
    assert lengths == pytest.approx([1.0, 1.5, 1.5, 2.0, 2.0])
    # each later leg turns 90 deg left of the previous one
    for a, b in itertools.pairwise(legs[1:]):
        assert a[0] * b[1] - a[1] * b[0] > 0 and abs(float(a @ b)) < 1e-9


def test_proximity_index_and_restarts() -> None:
    c = np.array([0.0, 2.0, 1.0, 3.0])  # local maxima 2 and 3
    assert proximity_index(c, 0.5, kmu=0.5, kp=1.0) == pytest.approx(0.5 * 1.5 + 0.5 * 5.0)
    s = Spiral(SpiralParams())
    assert s.judge(4.0, 0.0, 1, 0.5) and s.best == 4.0 and s.leg == 0
    s.next_offset()
    assert not s.judge(1.0, 0.0, 1, 0.5) and s.best == 4.0
    # patience exhausted: the best is halved
    assert not s.judge(1.0, 0.0, 1, 0.5) and s.best == 2.0
    assert s.judge(2.5, 1.0, 1, 0.5) and s.heading == 1.0


# ---------------------------------------------------------------------- taxis rules
HEX = np.array([[0.3 * math.cos(a), 0.3 * math.sin(a)] for a in np.arange(6) * math.pi / 3])


def test_chemotaxis_points_at_the_strongest_robot() -> None:
    from odorloc.behaviours.taxis import chemotaxis

    r = np.array([0.1, 0.5, 0.2, 0.0, 0.0, 0.3])
    np.testing.assert_allclose(chemotaxis(np.zeros(2), HEX, r), HEX[1] / 0.3)
    assert chemotaxis(np.zeros(2), HEX, np.zeros(6)) is None
    assert chemotaxis(np.zeros(2), HEX, np.full(6, 0.4)) is None


def test_anemotaxis_goes_upwind_only_inside_the_plume() -> None:
    from odorloc.behaviours.taxis import anemotaxis

    winds = np.tile([2.0, 1.0], (6, 1)) + np.linspace(-0.1, 0.1, 6)[:, None]
    u = anemotaxis(winds, np.full(6, 0.01), threshold=0.005)
    np.testing.assert_allclose(u, -winds.mean(axis=0) / np.linalg.norm(winds.mean(axis=0)))
    r = np.full(6, 0.01)
    r[3] = 0.005  # one robot at the threshold: not all inside
    assert anemotaxis(winds, r, 0.005) is None
    assert anemotaxis(np.zeros((6, 2)), np.ones(6), 0.005) is None


def test_fluxotaxis_follows_the_most_negative_flux() -> None:
    from odorloc.behaviours.taxis import fluxotaxis, mass_flux

    # Wind along +x through the hexagon: robot 3 at angle 180 deg sees v . n = -1 (inflow).
    winds = np.tile([1.0, 0.0], (6, 1))
    rho = np.full(6, 0.02)
    flux, total = mass_flux(np.zeros(2), HEX, rho, winds)
    np.testing.assert_allclose(flux, 0.02 * np.cos(np.arange(6) * math.pi / 3), atol=1e-15)
    assert total == pytest.approx(0.0, abs=1e-15)  # uniform concentration: in = out
    np.testing.assert_allclose(
        fluxotaxis(np.zeros(2), HEX, rho, winds, 0.005), [-1.0, 0.0], atol=1e-12
    )
    # A source upwind: more odor on the inflow side makes the total negative (net inflow).
    rho2 = rho * (1.0 - 0.5 * np.cos(np.arange(6) * math.pi / 3))
    _, total2 = mass_flux(np.zeros(2), HEX, rho2, winds)
    assert total2 < 0
    assert fluxotaxis(np.zeros(2), HEX, np.full(6, 0.001), winds, 0.005) is None


@pytest.mark.parametrize(
    ("rule", "field"),
    [
        ("chemotaxis-reading", "readings"),
        ("chemotaxis-centre", "centre"),
        ("anemotaxis-wind", "winds"),
        ("anemotaxis-reading", "readings"),
        ("anemotaxis-threshold", "threshold"),
        ("fluxotaxis-wind", "winds"),
        ("fluxotaxis-position", "positions"),
        ("mass-flux-reading", "readings"),
    ],
)
def test_taxis_rules_refuse_non_finite_samples(rule: str, field: str) -> None:
    from odorloc.behaviours.taxis import anemotaxis, chemotaxis, fluxotaxis, mass_flux
    from odorloc.core.errors import ConfigError

    # NaN compares false: before, argmax picked the NaN sample, the mean wind turned into a
    # NaN direction, or the rule quietly said "no signal"
    nan = math.nan
    rho = np.array([0.1, 0.5, nan, 0.0, 0.0, 0.3])
    winds = np.tile([1.0, 0.0], (6, 1))
    bad_winds = winds.copy()
    bad_winds[0, 0] = nan
    bad_hex = HEX.copy()
    bad_hex[2, 1] = nan
    full = np.full(6, 0.02)
    calls = {
        "chemotaxis-reading": lambda: chemotaxis(np.zeros(2), HEX, rho),
        "chemotaxis-centre": lambda: chemotaxis([nan, 0.0], HEX, full),
        "anemotaxis-wind": lambda: anemotaxis(bad_winds, full, 0.005),
        "anemotaxis-reading": lambda: anemotaxis(winds, rho, 0.005),
        "anemotaxis-threshold": lambda: anemotaxis(winds, full, nan),
        "fluxotaxis-wind": lambda: fluxotaxis(np.zeros(2), HEX, full, bad_winds, 0.005),
        "fluxotaxis-position": lambda: fluxotaxis(np.zeros(2), bad_hex, full, winds, 0.005),
        "mass-flux-reading": lambda: mass_flux(np.zeros(2), HEX, rho, winds),
    }
    with pytest.raises(ConfigError) as err:
        calls[rule]()
    assert err.value.field == field


def test_taxis_rules_refuse_samples_that_do_not_pair_up() -> None:
    from odorloc.behaviours.taxis import chemotaxis, mass_flux
    from odorloc.core.errors import ConfigError

    with pytest.raises(ConfigError, match="readings"):
        chemotaxis(np.zeros(2), HEX, np.arange(7.0))  # was an IndexError deep inside
    with pytest.raises(ConfigError, match="winds"):
        mass_flux(np.zeros(2), HEX, np.ones(6), np.ones((5, 2)))
    with pytest.raises(ConfigError, match="positions"):
        chemotaxis(np.zeros(3), HEX, np.arange(6.0))


def test_losing_the_odor_restarts_narrow_casts_even_without_a_surge() -> None:
    p = CastParams(angle_deg=90.0, amplitude=0.4, growth=2.0)
    sc = SurgeCast(p)
    up = np.array([-1.0, 0.0])
    pos = np.array([5.0, 5.0])
    for _ in range(20):  # casts widened up to max_amplitude
        sc.direction(OPEN, pos, up, 0.2)
    sc.start_surge()
    assert not sc.surging
    ys = [round(float(sc.direction(OPEN, pos, up, 0.2)[1])) for _ in range(4)]
    # a first leg of amplitude (2 steps of 0.2 m), then the other side
    assert ys[:2] == [ys[0]] * 2 and ys[2] == -ys[0]
