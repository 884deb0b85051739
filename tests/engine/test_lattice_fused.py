"""A whole compiled episode of ``lattice-infotaxis`` against the engine's loop with it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import run_episode
from odorloc.scenarios import get_scenario

MEASURED = {"wall_time", "wall_per_step_ms", "world_fraction", "searcher_fraction"}


def _fused(name: str, policy: str = "infotaxis", **over: object):  # type: ignore[no-untyped-def]
    base = get_scenario(name)
    data = {"searcher": {"type": "lattice-infotaxis", "policy": policy,
                         "model": dict(base.searcher.model)}}  # fmt: skip
    data.update(over)
    return base.with_overrides(data)


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _events(res):  # type: ignore[no-untyped-def]
    return [
        (e.t, e.kind, e.agent, e.source, None if e.position is None else tuple(e.position),
         e.detail)
        for e in res.events
    ]  # fmt: skip


def _compare(sc, key: str, episodes: int) -> set[str]:  # type: ignore[no-untyped-def]
    """Rows, events and sources of the compiled episodes equal the loop's; the ends seen."""
    ends = set()
    for e in range(episodes):
        seeds = episode_seeds(7, key, e)
        fast = run_episode(sc, *seeds, record=False)
        loop = run_episode(sc, *seeds, record=False, fused=False)
        ra, rb = fast.metrics.row(), loop.metrics.row()
        assert list(ra) == list(rb)
        diff = {k: (ra[k], rb[k]) for k in ra if k not in MEASURED and not _same(ra[k], rb[k])}
        assert not diff, (e, diff)
        assert math.isnan(ra["world_fraction"]) and ra["wall_time"] > 0
        assert ra["searcher_fraction"] == 1.0
        assert _events(fast) == _events(loop)
        np.testing.assert_array_equal(fast.sources, loop.sources)
        ends.add(ra["termination"])
    return ends


POLICIES = ["infotaxis", "space-aware-infotaxis", "greedy", "mean-distance"]


@pytest.mark.parametrize("policy", POLICIES)
def test_compiled_episode_is_the_loops_episode(policy: str) -> None:
    """Every column (the measured times apart), event and source of 25 episodes per policy."""
    ends = _compare(_fused("lattice-isotropic-2d", policy), "lattice-isotropic-2d", 25)
    assert "reached" in ends


def test_compiled_episode_ends_by_the_step_cap_and_the_stuck_rule() -> None:
    short = _fused("lattice-isotropic-2d", **{"limits.time": 6.0})
    assert "time_limit" in _compare(short, "lattice-isotropic-2d", 12)
    stuck = _fused("lattice-isotropic-2d", "mean-distance", **{"task.stuck_limit": 0})
    assert "stuck" in _compare(stuck, "lattice-isotropic-2d", 12)


def test_compiled_episode_in_3d() -> None:
    sc = _fused("lattice-isotropic-3d", **{"limits.time": 25.0})
    assert _compare(sc, "lattice-isotropic-3d", 4)


def test_recorded_episodes_take_the_loop() -> None:
    """A recording needs the loop: the same row, and the recording is there."""
    sc = _fused("lattice-isotropic-2d")
    seeds = episode_seeds(1, "lattice-isotropic-2d", 0)
    rec = run_episode(sc, *seeds, record=True)
    fast = run_episode(sc, *seeds, record=False)
    assert rec.recording is not None and fast.recording is None
    assert rec.metrics["steps"] == fast.metrics["steps"]
    assert not math.isnan(rec.metrics["world_fraction"])


def test_the_searcher_refuses_another_model() -> None:
    base = get_scenario("lattice-isotropic-2d")
    other = {"type": "lattice-infotaxis", "model": {"type": "vergassola"}}
    with pytest.raises(ConfigError, match=r"searcher\.model"):
        run_episode(base.with_overrides({"searcher": other}), *episode_seeds(0, "x", 0))
