"""Fields measured over a world (the flux a ring of sensors sees), per-group episode columns
and interval statistics of sets of rows."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from helpers import small_scenario_dict
from odorloc.behaviours.formation import declaration_series, regular_polygon
from odorloc.behaviours.taxis import mass_flux
from odorloc.core.errors import ConfigError
from odorloc.core.types import Declaration
from odorloc.engine.episode import prepare_world
from odorloc.experiments.cells import stat_interval
from odorloc.experiments.fields import flux_maps_around, ring_flux_series, steady_world
from odorloc.experiments.groups import approach, group_columns
from odorloc.scenarios import Scenario
from odorloc.viz.formations import GroupView

SOURCE = np.array([1.0, 2.5])
RING = regular_polygon((0.0, 0.0), 0.3, 6)


def _world() -> tuple[object, np.random.Generator]:
    world, rng, _ = prepare_world(Scenario.from_dict(small_scenario_dict()), 0)
    return world, rng


def test_the_ring_flux_is_the_mass_flux_and_positive_only_around_the_source() -> None:
    world, rng = _world()
    centres = SOURCE + np.array([[0.05, 0.0], [2.0, 0.0], [4.0, 0.0], [2.0, 1.5]])
    series = ring_flux_series(world, rng, centres, RING, 3, 2, 0.25)
    assert series.shape == (3, 4)
    for k, c in enumerate(centres):
        pts = c + RING
        _, total = mass_flux(c, pts, world.plume.concentration(pts), world.wind.velocity(pts))
        assert series[-1, k] == pytest.approx(total, rel=1e-6)
    # the steady Gaussian plume: odour flows out of a ring around its source and into one on
    # the axis downwind (the concentration falls along the wind); on the flank, where the
    # cross-wind profile is convex, a little flows out (what diffusion brings in)
    assert series[-1, 0] > 0 > series[-1, 1] and series[-1, 2] < 0
    assert 0 < series[-1, 3] < 0.01 * series[-1, 0]


def test_flux_maps_around_are_the_fractions_of_the_series() -> None:
    sc = Scenario.from_dict(small_scenario_dict())
    off = np.array([-0.5, 0.0, 2.0])

    def fires(series: np.ndarray) -> np.ndarray:
        return declaration_series(series, 0.0, 2)

    maps = flux_maps_around(sc, 0, 2.0, [SOURCE], off, RING, 0.0, fires)
    m = maps[0]
    assert set(m) == {"mean", "above", "declares"} and m["mean"].shape == (3, 3)
    assert m["above"][1, 1] == 1.0 and m["above"][2, 1] == 0.0  # on the source, downwind
    assert m["declares"][1, 1] == pytest.approx(0.75)  # 4 periods, fires from the second on


def test_ring_flux_series_refuses_a_sensor_on_the_centre() -> None:
    world, rng = _world()
    with pytest.raises(ConfigError) as err:
        ring_flux_series(world, rng, [SOURCE], np.zeros((3, 2)), 2, 1, 0.25)
    assert err.value.field == "ring"


def test_the_steady_world_holds_the_mean_wind_and_release() -> None:
    d = small_scenario_dict()
    d["world"]["wind"] = {"type": "meander", "speed": 1.0, "direction_swing": 30.0}
    d["world"]["sources"][0]["modulation"] = {"kind": "sine", "period": 4.0, "depth": 0.5}
    sc = Scenario.from_dict(d)
    world = steady_world(sc, warmup=2.0)
    v0 = world.wind.velocity([[1.0, 1.0]])
    world.step(0.5, np.random.default_rng(1))
    np.testing.assert_allclose(world.wind.velocity([[1.0, 1.0]]), v0)
    np.testing.assert_allclose(v0, [[1.0, 0.0]], atol=1e-12)
    assert steady_world(sc, rate=3.0, warmup=1.0).plume.sources[0].rate_at(0.7) == 3.0


def _episode(paths: list[np.ndarray], declared: list[tuple[int, list[float]]]) -> SimpleNamespace:
    diag = {}
    for p, suffix in zip(paths, ("", "_6"), strict=False):
        diag[f"vr_x{suffix}"], diag[f"vr_y{suffix}"] = p[:, 0], p[:, 1]
    return SimpleNamespace(
        sources=np.array([[1.0, 11.0], [3.0, 9.0]]),
        declarations=[Declaration(np.array([pos]), group=g) for g, pos in declared],
        recording=SimpleNamespace(diagnostics=diag),
        metrics={"found_time_0": 80.0, "found_time_1": math.nan},
    )


GROUPS = [GroupView("A", (0, 1, 2), ""), GroupView("B", (6, 7, 8), "_6")]


def test_group_columns_of_two_groups_at_one_source() -> None:
    # A steps back and forth 0.06 m next to the upwind source (a 2-cycle); B ends near it too
    cycle = np.array([[1.25, 11.0], [1.19, 11.0]] * 20)
    path_a = np.vstack([np.linspace([6.0, 11.0], [1.25, 11.0], 30), cycle])
    path_b = np.linspace([6.0, 9.0], [2.5, 11.5], 70)
    cols = group_columns(_episode([path_a, path_b], [(0, [1.2, 11.0])]), GROUPS, 0.5, 0.3, 3.0)
    assert cols["source_A"] == 0 and cols["error_A"] == pytest.approx(0.2)
    assert cols["source_B"] == -1 and math.isnan(cols["error_B"])
    assert cols["first_declared"] == 0 and not cols["same_declared"]
    assert cols["closest_A_0"] == pytest.approx(0.19) and cols["same_source"]
    assert not cols["reached_both"]
    assert cols["dwell_A"] == 1.0 and cols["reversal_A"] == 1.0  # stays, always reversing
    assert math.isnan(cols["dwell_B"])  # never within 0.3 m of a source
    assert cols["first_found"] == 80.0 and math.isnan(cols["second_found"])


def test_approach_of_a_path_that_passes_by() -> None:
    path = np.column_stack([np.linspace(-1.0, 1.0, 21), np.zeros(21)])  # straight through
    dwell, rev = approach(path, np.zeros((1, 2)), 0.35)
    assert dwell == pytest.approx(7 / 14) and rev == 0.0  # 7 of the 14 steps from the entry


def test_stat_interval_rates_and_means() -> None:
    rows = pd.DataFrame(
        {"success": [True, True, False, True], "search_time": [100.0, 200.0, np.nan, 300.0]}
    )
    v, lo, hi, txt = stat_interval(rows, ("rate", "success"), 0)
    assert v == 75.0 and txt == "3/4" and lo < 75.0 < hi
    v, lo, hi, txt = stat_interval(rows, ("mean", "search_time", "success"), 0)
    assert v == 200.0 and txt == "3/4" and 100.0 <= lo <= 200.0 <= hi <= 300.0
    v, *_, txt = stat_interval(rows.iloc[:0], ("rate", "success"), 0)
    assert math.isnan(v) and txt == "0/0"
