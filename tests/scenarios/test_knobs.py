"""Scenario knobs (one name for several settings) and the release modulation's frequency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import small_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.experiments.runner import cell_scenario
from odorloc.plume.sources import Modulation
from odorloc.scenarios import Scenario, get_scenario


def _knobbed(**extra) -> dict:
    d = small_scenario_dict()
    d["world"]["sources"] = [
        {"position": [1.0, 2.0], "modulation": {"kind": "sine", "period": 20.0}},
        {"position": [1.0, 3.0], "modulation": {"kind": "onoff", "period": 10.0}},
    ]
    d["world"]["wind"] = {"type": "meander", "speed": 1.0}
    d["knobs"] = {
        "frequency": [
            "world.wind.frequency_factor",
            "world.sources.0.modulation.frequency_factor",
            "world.sources.1.modulation.frequency_factor",
        ],
        **extra,
    }
    return d


def test_a_knob_sets_every_listed_setting(tmp_path) -> None:
    sc = Scenario.from_dict(_knobbed())
    twice = sc.with_overrides({"frequency": 2.0})
    assert twice.world.wind.values["frequency_factor"] == 2.0
    assert [s.modulation.frequency_factor for s in twice.world.sources] == [2.0, 2.0]
    assert twice.knobs == sc.knobs
    twice.to_yaml(tmp_path / "twice.yaml")
    assert Scenario.from_yaml(tmp_path / "twice.yaml") == twice  # knobs round-trip
    # a sweep cell overrides the knob like any setting
    cell = {"scenario": "virtual-physics-two-groups", "scenario_params": {"frequency": 3}}
    vp = cell_scenario(cell)
    assert vp.world.wind.values["frequency_factor"] == 3
    assert all(s.modulation.frequency_factor == 3 for s in vp.world.sources)


def test_bad_knobs_are_refused_naming_the_knob() -> None:
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(_knobbed(speed=["world.wind.nope.speed"]))
    assert ei.value.field == "knobs.speed"
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(_knobbed(bad=["limits.no_such_limit"]))
    assert ei.value.field == "knobs.bad"
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(_knobbed(**{"world.dt": ["world.dt"]}))
    assert ei.value.field == "knobs.world.dt"
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(_knobbed(limits=["limits.time"]))  # shadows a section
    with pytest.raises(ConfigError) as ei:
        Scenario.from_dict(_knobbed(empty=[]))
    assert ei.value.field == "knobs.empty"
    sc = Scenario.from_dict(_knobbed())
    with pytest.raises(ConfigError) as ei:
        sc.with_overrides({"frequency": 2.0, "world.wind.frequency_factor": 1.0})
    assert ei.value.field == "world.wind.frequency_factor"
    with pytest.raises(ConfigError) as ei:
        sc.with_overrides({"frequency": -1.0})  # validated where it lands, named by the knob
    assert ei.value.field == "frequency"
    assert "frequency_factor must be" in ei.value.problem
    with pytest.raises(ConfigError):
        sc.with_overrides({"world.sources.7.rate": 1.0})


def test_modulation_frequency_factor_divides_the_period() -> None:
    base = Modulation(kind="sine", period=20.0, depth=0.5)
    fast = Modulation(kind="sine", period=20.0, depth=0.5, frequency_factor=2.0)
    assert fast.effective_period == 10.0
    for t in np.linspace(0, 40, 17):
        assert fast.factor(t) == pytest.approx(base.factor(2 * t))
    onoff = Modulation(kind="onoff", period=10.0, duty=0.5, frequency_factor=2.0)
    assert [onoff.factor(t) for t in (0.0, 2.4, 2.6, 5.1)] == [1.0, 1.0, 0.0, 1.0]
    assert Modulation(kind="sine", period=20.0).factor(5.0) == pytest.approx(1.5)
    assert math.isclose(Modulation().factor(3.0), 1.0)


def test_the_virtual_physics_scenario_sweeps_frequency_as_one_knob() -> None:
    sc = get_scenario("virtual-physics-two-groups")
    assert set(sc.knobs) == {"frequency"}
    treble = sc.with_overrides({"frequency": 3})
    periods = {s.modulation.effective_period for s in treble.world.sources}
    assert periods == {20.0 / 3}
    assert treble.world.wind.values["frequency_factor"] == 3
