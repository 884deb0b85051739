"""Sweep ``agent_grid``: agent placements that share their scenario cell's flow."""

from __future__ import annotations

import pytest

from _stub_episode import stub_episode
from odorloc.core.errors import ConfigError
from odorloc.experiments.sweep import (
    config_hash,
    episode_seeds,
    expand_cells,
    expand_tasks,
    hashed_content,
    load_sweep,
    run_sweep,
)

GROUPS: list[list[tuple[str, str, int]]] = []


def _spec(**scenario):
    return {
        "seed": 5,
        "episodes": 2,
        "scenarios": [{"name": "toy", **scenario}],
        "searchers": [{"name": "a"}, {"name": "b"}],
    }


def test_placements_share_the_flow_key_and_world_seeds() -> None:
    spec = load_sweep(
        _spec(grid={"frequency": [1, 3]}, agent_grid={"start_set": ["P1", "P2", "P3"]})
    )
    cells = expand_cells(spec)
    assert len(cells) == 2 * 3 * 2
    assert len({c.cell_id for c in cells}) == len(cells)
    assert cells[0].cell_id == 'toy[frequency=1,start_set="P1"]/a'
    assert cells[0].world_key == 'toy[frequency=1,start_set="P1"]'
    assert {c.flow_key for c in cells} == {"toy[frequency=1]", "toy[frequency=3]"}
    assert cells[0].swept == {"scenario.frequency": 1, "scenario.start_set": "P1"}
    tasks = expand_tasks(spec)
    by = {}
    for t in tasks:
        by.setdefault((t.flow_key, t.episode), set()).add((t.world_seed, t.agent_seed))
    # every placement and searcher of a flow and episode gets the same seeds
    assert all(len(v) == 1 for v in by.values())
    assert len({next(iter(v)) for v in by.values()}) == 4
    ws = episode_seeds(5, "toy[frequency=3]", 1)
    assert next(iter(by[("toy[frequency=3]", 1)])) == ws


def test_sweeps_without_agent_grid_keep_their_keys_and_hash() -> None:
    spec = load_sweep(_spec(grid={"x": [1, 2]}))
    cells = expand_cells(spec)
    assert all(c.flow_key == c.world_key for c in cells)
    assert "agent_grid" not in hashed_content(spec)["scenarios"][0]
    with_grid = load_sweep(_spec(grid={"x": [1, 2]}, agent_grid={"start_index": [0]}))
    assert config_hash(with_grid) != config_hash(spec)


def test_agent_grid_takes_only_placements() -> None:
    with pytest.raises(ConfigError) as ei:
        load_sweep(_spec(agent_grid={"limits.time": [10.0, 20.0]}))
    assert ei.value.field == "scenarios[0].agent_grid"
    with pytest.raises(ConfigError) as ei:
        load_sweep(_spec(grid={"start_set": ["P1"]}, agent_grid={"start_set": ["P2"]}))
    assert "both" in ei.value.problem
    load_sweep(_spec(agent_grid={"agents.heading": [0.0, 1.0], "start_index": [1]}))


def _group(tasks):
    GROUPS.append([(t.flow_key, t.cell_id, t.episode) for t in tasks])
    return [stub_episode(t) for t in tasks]


def test_replay_records_one_flow_for_every_placement(tmp_path) -> None:
    GROUPS.clear()
    spec = {
        **_spec(grid={"frequency": [1, 3]}, agent_grid={"start_set": ["P1", "P2"]}),
        "replay": True,
    }
    df = run_sweep(
        spec,
        tmp_path / "r.sqlite",
        workers=1,
        progress=False,
        validate=False,
        episode_fn=stub_episode,
        group_fn=_group,
    )
    assert len(df) == 2 * 2 * 2 * 2
    assert len(GROUPS) == 2 * 2  # (flow key, episode) groups
    for g in GROUPS:
        assert len({k for k, _, _ in g}) == 1 and len({e for _, _, e in g}) == 1
        assert len(g) == 4  # two placements x two searchers


def test_agent_grid_refuses_drawn_sources() -> None:
    from odorloc.experiments.sweep import validate_names

    spec = load_sweep(
        {
            "seed": 1,
            "episodes": 1,
            "scenarios": [
                {
                    "name": "virtual-physics-two-groups",
                    "params": {"world.source_draw": {"type": "uniform"}},
                    "agent_grid": {"start_set": ["P1"]},
                }
            ],
            "searchers": [{"name": "passive"}],
        }
    )
    with pytest.raises(ConfigError) as ei:
        validate_names(spec)
    assert ei.value.field == "scenarios[0].agent_grid"
