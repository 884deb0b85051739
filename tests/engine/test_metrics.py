"""The typed metrics record: core columns cannot be overwritten, per-agent values stay per
agent, and searcher phases are recorded as text."""

from __future__ import annotations

import pickle
from typing import Any, ClassVar

import numpy as np
import pytest

from helpers import small_scenario_dict
from odorloc.core.params import Params
from odorloc.core.types import Action, Command
from odorloc.engine.episode import run_episode
from odorloc.engine.metrics import EpisodeMetrics, MetricsError
from odorloc.engine.recorder import Recording
from odorloc.scenarios import Scenario
from odorloc.searchers.base import Searcher


def test_extra_columns_cannot_overwrite_core_ones() -> None:
    m = EpisodeMetrics({"success": True, "search_time": 12.5}, {"cues": 3})
    assert dict(m) == {"success": True, "search_time": 12.5, "cues": 3}
    assert list(m) == ["success", "search_time", "cues"]  # core first
    m["cues"] = 4  # an extra column may be updated
    m["resamples"] = 2.0
    assert m.extra == {"cues": 4, "resamples": 2.0}
    with pytest.raises(MetricsError, match="'success' is a core metric"):
        m["success"] = False
    with pytest.raises(MetricsError, match=r"searcher\.search_time"):
        m.add({"search_time": 0.0}, source="searcher")
    with pytest.raises(MetricsError, match=r"extra\.success"):
        EpisodeMetrics({"success": True}, {"success": False})
    with pytest.raises(MetricsError, match="cannot be removed"):
        del m["success"]
    assert m["success"] is True and m["search_time"] == 12.5


def test_per_agent_values_are_checked_and_survive_a_pickle() -> None:
    m = EpisodeMetrics({"bytes": 0}, agents={1: {"cues": 2}, 0: {"cues": 1}})
    assert m.agent_rows() == [(0, "cues", 1), (1, "cues", 2)]
    assert "cues" not in m  # never a column of the row
    back = pickle.loads(pickle.dumps(m))
    assert back == m and back.agents == m.agents and back.core == m.core
    with pytest.raises(MetricsError, match="agent id 'a'"):
        EpisodeMetrics({}, agents={"a": {"cues": 1}})  # type: ignore[dict-item]
    with pytest.raises(MetricsError, match=r"agent metrics\[0\]"):
        EpisodeMetrics({}, agents={0: [1, 2]})  # type: ignore[dict-item]


class _Cheater(Searcher):
    """Holds still and claims a success in its extra columns."""

    Params: ClassVar[type[Params]] = Params

    def act(self, observations: Any, rng: np.random.Generator) -> Action:
        return Action([Command.hold() for _ in observations])

    def final_metrics(self) -> dict[str, Any]:
        return {"success": True}


def test_a_searcher_column_named_like_a_core_one_is_refused() -> None:
    d = small_scenario_dict()
    d["limits"]["time"] = 2.0
    sc = Scenario.from_dict(d)
    with pytest.raises(MetricsError, match=r"extra\.success"):
        run_episode(sc, 1, 2, searcher=_Cheater())


def test_a_team_keeps_each_members_columns_per_agent() -> None:
    d = small_scenario_dict("per-agent", member={"type": "spiral"})
    d["agents"] = {"starts": [[8.0, 2.0], [8.0, 3.0]]}
    d["limits"]["time"] = 5.0
    res = run_episode(Scenario.from_dict(d), 3, 4)
    agents = res.metrics.agents
    assert set(agents) == {0, 1}
    assert all({"spiral_restarts", "proximity_best"} <= set(v) for v in agents.values())
    # the row holds the episode's columns only: nothing per member, no agent id in a name
    assert "spiral_restarts" not in res.metrics
    assert not [k for k in res.metrics if k.endswith("_1")]
    assert res.recording is not None
    assert res.recording.meta["agent_metrics"].keys() == {"0", "1"}


def test_phases_are_recorded_as_text(tmp_path) -> None:
    d = small_scenario_dict("surge-cast")
    d["limits"]["time"] = 10.0
    rec = run_episode(Scenario.from_dict(d), 1, 2, record=True).recording
    assert rec is not None
    phase = rec.diagnostics["phase"]
    assert phase.dtype.kind == "U" and len(phase) == len(rec.t)
    assert set(phase.tolist()) <= {"cast", "track", "spiral"}
    back = Recording.load(rec.save(tmp_path / "r.npz"))
    assert back.diagnostics["phase"].tolist() == phase.tolist()


def test_a_diagnostic_may_not_switch_between_text_and_numbers() -> None:
    from odorloc.engine.recorder import Recorder

    class Probe:
        def __init__(self) -> None:
            self.values: list[Any] = ["cast", 1.0]

        def diagnostics(self) -> dict[str, Any]:
            return {"phase": self.values.pop(0)}

        def beliefs(self) -> dict[int, Any]:
            return {}

    sc = Scenario.from_dict(small_scenario_dict())
    from odorloc.scenarios.build import build

    b = build(sc)
    rec = Recorder(sc, b.world.arena, np.array([[1.0, 2.5]]))
    from odorloc.core.types import Observation

    obs = [Observation(0, 0.0, np.array([8.0, 2.0]), 0.0, 0.0, False, np.zeros(2))]
    probe = Probe()
    rec.final_pose(0.0, obs, probe)
    with pytest.raises(TypeError, match="'phase' mixes text and numbers"):
        rec.final_pose(0.5, obs, probe)
