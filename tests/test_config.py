"""Scenario configuration: validation with field names, YAML round trip, overrides, built-ins."""

from __future__ import annotations

import copy

import pytest

from conftest import small_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.scenarios import Scenario, builtin_names, get_scenario


def test_yaml_round_trip(tmp_path) -> None:
    sc = Scenario.from_dict(small_scenario_dict())
    path = tmp_path / "s.yaml"
    sc.to_yaml(path)
    back = Scenario.from_yaml(path)
    assert back == sc
    assert back.config_hash() == sc.config_hash()


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_scenarios_round_trip_and_build(name: str, tmp_path) -> None:
    from odorloc.scenarios.build import build

    sc = get_scenario(name)
    path = tmp_path / f"{name}.yaml"
    sc.to_yaml(path)
    assert Scenario.from_yaml(path) == sc
    b = build(sc)
    assert b.world.arena.dim == len(sc.agents.starts[0])


def test_overrides_and_hash_change() -> None:
    sc = Scenario.from_dict(small_scenario_dict())
    sc2 = sc.with_overrides({"limits.time": 60.0, "agents.starts": [[7.0, 2.0]]})
    assert sc2.limits.time == 60.0 and sc2.agents.starts == [(7.0, 2.0)]
    assert sc2.config_hash() != sc.config_hash()
    with pytest.raises(ConfigError, match="nosuch"):
        sc.with_overrides({"limits.nosuch.x": 1})


def _bad(mutate) -> ConfigError:
    d = copy.deepcopy(small_scenario_dict())
    mutate(d)
    with pytest.raises(ConfigError) as ei:
        from odorloc.scenarios.build import build

        build(Scenario.from_dict(d))
    return ei.value


def test_invalid_inputs_name_the_field() -> None:
    e = _bad(lambda d: d["world"]["sources"][0].update(position=[20.0, 2.5]))
    assert "sources" in e.field and "outside" in e.problem
    e = _bad(lambda d: d["world"]["wind"].update(velocity=[float("nan"), 0.0]))
    assert e.field == "world.wind.velocity"
    e = _bad(lambda d: d["world"].update(dt=0.0))
    assert e.field == "world.dt"
    e = _bad(lambda d: d["world"]["plume"].update(type="nonsense"))
    assert e.field == "world.plume.type" and "unknown plume" in e.problem
    e = _bad(lambda d: d["world"]["arena"].update(upper=[-1.0, 5.0]))
    assert e.field.startswith("world.arena")
    e = _bad(lambda d: d["agents"].update(starts=[[1.0, 2.0, 3.0]]))
    assert e.field == "agents.starts[0]"
    e = _bad(lambda d: d["searcher"].update(angle_deg=-5))
    assert e.field == "searcher.angle_deg"
    e = _bad(lambda d: d.update(unknown_key=1))
    assert e.field == "unknown_key"


def test_source_inside_obstacle_rejected() -> None:
    def put_box(d):
        d["world"]["arena"]["obstacles"] = {"boxes": [[[0.5, 2.0], [1.5, 3.0]]]}

    e = _bad(put_box)
    assert e.field == "world.sources[0].position" and "obstacle" in e.problem


def test_unknown_builtin() -> None:
    with pytest.raises(ConfigError, match="unknown scenario"):
        get_scenario("nope")
