"""A searcher that never declares is refused, at load, by a scenario that ends only on a
declaration (it could never succeed there); the refusal names ``task.end`` and the fix."""

from __future__ import annotations

import pytest

from helpers import small_scenario_dict
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.scenarios import Scenario
from odorloc.scenarios.loading import DECLARATION_ENDS, check_scenario

NEVER = ("zigzag", "random-walk", "surge-cast", "spiral", "chemotaxis", "infotaxis")


def _scenario(searcher: dict, end: str) -> Scenario:
    d = small_scenario_dict()
    d["searcher"] = searcher
    d["task"] = {"end": end, "reach_radius": 0.5}
    return Scenario.from_dict(d)


@pytest.mark.parametrize("end", DECLARATION_ENDS)
@pytest.mark.parametrize("name", NEVER)
def test_a_searcher_that_never_declares_is_refused_naming_task_end(name: str, end: str) -> None:
    with pytest.raises(ConfigError) as err:
        check_scenario(_scenario({"type": name}, end))
    assert err.value.field == "task.end"
    assert name in err.value.problem and "task.end: reach" in err.value.problem
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("name", NEVER)
def test_it_runs_where_reaching_or_the_limits_end_the_episode(name: str) -> None:
    for end in ("reach", "limits"):
        check_scenario(_scenario({"type": name}, end))


def test_parameters_that_switch_declarations_on_are_honoured() -> None:
    for spec in (
        {"type": "passive", "declare_on_detection": True},
        {"type": "rectangular-wave", "declare_at_max": True},
        {"type": "policy", "action": {"declare": "position"}},
    ):
        check_scenario(_scenario(spec, "first_declaration"))
    for spec in (
        {"type": "passive"},
        {"type": "rectangular-wave"},
        {"type": "policy", "action": {"declare": "none"}},
    ):
        with pytest.raises(ConfigError, match="never declares"):
            check_scenario(_scenario(spec, "first_declaration"))


def test_teams_answer_for_their_members() -> None:
    team = {"type": "per-agent", "member": {"type": "surge-cast"}}
    with pytest.raises(ConfigError) as err:
        check_scenario(_scenario(team, "first_declaration"))
    assert err.value.field == "task.end" and "'per-agent'" in err.value.problem
    team["member"] = {"type": "passive", "declare_on_detection": True}
    check_scenario(_scenario(team, "all_groups"))


def test_every_searcher_answers_with_a_bool() -> None:
    for e in registry.entries("searcher"):
        assert isinstance(e.build(e.params()).may_declare(), bool), e.name
