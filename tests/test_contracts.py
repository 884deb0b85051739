"""The public contract checkers (:mod:`odorloc.checks`) over every registered component."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc import checks
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.engine.episode import EpisodeResult
from odorloc.engine.recorder import Recording
from odorloc.scenarios import Scenario


@pytest.mark.parametrize("name", registry.names("wind"))
def test_every_wind(name: str) -> None:
    if name == "replay":
        pytest.skip("the replayed wind is checked with the replayed plume")
    checks.check_wind(name)


@pytest.mark.parametrize("name", registry.names("plume"))
def test_every_plume(name: str) -> None:
    checks.check_plume(name)


@pytest.mark.parametrize("name", registry.names("gas_sensor"))
def test_every_gas_sensor(name: str) -> None:
    checks.check_sensor(name)


@pytest.mark.parametrize("name", registry.names("platform"))
def test_every_platform(name: str) -> None:
    checks.check_platform(name)


@pytest.mark.parametrize("name", registry.names("searcher"))
def test_every_searcher(name: str) -> None:
    report = checks.check_searcher(name)
    assert name in report


@pytest.mark.parametrize("name", registry.names("searcher"))
def test_every_searcher_rejects_unknown_parameters(name: str) -> None:
    with pytest.raises(ConfigError) as ei:
        checks.small_scenario({"type": name, "not_a_parameter": 1})
    assert ei.value.field == "searcher.not_a_parameter"


def _result(x: float) -> EpisodeResult:
    p = np.array([[[x, 0.0]]])
    rec = Recording(
        t=np.zeros(1),
        positions=p,
        gas=np.zeros((1, 1)),
        detection=np.zeros((1, 1), bool),
        wind=np.zeros_like(p),
        diagnostics={},
        beliefs=[],
        plume_t=np.zeros(0),
        plume_frames=np.zeros((0, 2, 2)),
        plume_extent=np.zeros(4),
        sources=np.zeros((1, 2)),
        declared=np.zeros((0, 2)),
        occupancy=None,
        arena_bounds=np.zeros((2, 2)),
    )
    return EpisodeResult({"search_time": 1.0}, rec)


def test_determinism_check_catches_differing_runs() -> None:
    with pytest.raises(checks.ContractError, match="trajectories differ"):
        checks.compare_runs(_result(0.0), _result(1.0), "searcher broken")
    checks.compare_runs(_result(0.0), _result(0.0), "searcher fine")


def test_small_scenario_is_a_valid_scenario() -> None:
    sc = checks.small_scenario({"type": "zigzag"}, dim=3, n_agents=2)
    assert isinstance(sc, Scenario) and len(sc.agents.starts) == 2


def test_components_by_import_path_must_belong_to_the_family() -> None:
    from odorloc.core import registry
    from odorloc.core.errors import ConfigError

    e = registry.entry("plume", "odorloc.replay.gaden:GadenPlume", field="world.plume.type")
    assert e.name == "odorloc.replay.gaden:GadenPlume"
    for family, ref, words in (
        ("searcher", "odorloc.planning.fixed_step:FixedStepInfotaxis", "not a searcher"),
        ("wind", "odorloc.searchers.uav_team:ColInfTeam", "not a wind"),
        ("searcher", ":", "package.module:Class"),
        ("searcher", ".x:Y", "cannot import"),
        ("searcher", "odorloc.nothing_here:X", "cannot import"),
    ):
        with pytest.raises(ConfigError, match=words) as ei:
            registry.entry(family, ref, field="x.type")
        assert ei.value.field == "x.type"
