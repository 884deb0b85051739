"""Scenario configuration: validation with field names, YAML round trip, overrides, built-ins."""

from __future__ import annotations

import copy

import pytest

from helpers import small_scenario_dict
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


def test_relative_files_in_a_scenario_file_are_relative_to_it(tmp_path, monkeypatch) -> None:
    """An obstacle file named relative to the scenario file is found from any current folder;
    the loaded scenario holds its absolute path (so a written copy still finds it)."""
    import yaml

    from odorloc.scenarios.build import build

    d = small_scenario_dict()
    d["world"]["arena"]["obstacles"] = {"file": "room.csv"}
    folder = tmp_path / "study"
    folder.mkdir()
    grid = [["0"] * 100 for _ in range(50)]
    grid[10][20] = "1"  # row 10 from the top: y in [3.9, 4.0), x in [2.0, 2.1)
    (folder / "room.csv").write_text("\n".join(",".join(r) for r in grid) + "\n")
    (folder / "s.yaml").write_text(yaml.safe_dump(d))
    monkeypatch.chdir(tmp_path)
    sc = Scenario.from_yaml(folder / "s.yaml")
    assert sc.world.arena.obstacles.file == str(folder / "room.csv")
    arena = build(sc).world.arena
    assert arena.in_obstacle([[2.05, 3.95]])[0] and not arena.in_obstacle([[5.0, 2.5]])[0]
