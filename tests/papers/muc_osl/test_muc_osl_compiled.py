"""MUC-OSL episodes on the compiled path: the same seed gives the same episode whatever the
backend or the number of worker processes (the random numbers come from the episode's
Generators; the kernels only compute)."""

from __future__ import annotations

import json

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import run_episode
from odorloc.experiments.sweep import run_sweep
from odorloc.scenarios import get_scenario
from odorloc.searchers.uav_team import SENSOR_RADIUS

#: a short search (about twenty iterations per UAV)
LIMITS = {"limits.time": 150.0}
#: metric columns that are wall-clock times
TIMING = ("wall_time", "wall_per_step_ms", "world_fraction", "searcher_fraction")


def _searcher(backend: str) -> dict:
    return {
        "type": "muc-osl",
        "model": {"type": "vergassola", "sensor_radius": SENSOR_RADIUS, "backend": backend},
        "planner": {"type": "adap-pp", "backend": backend},
    }


def _same(a: float, b: float) -> bool:
    """Equal, NaN equal to NaN."""
    return a == b or (a != a and b != b)


def test_compiled_and_numpy_episodes_make_the_same_moves() -> None:
    """The compiled and the NumPy path from the same seeds: the same hover points, the same
    counts, iterations, particle counts and bytes (the kernels agree within round-off, 1e-9
    relative; over a short search no decision lies that close to a tie)."""
    sc = get_scenario("muc-osl-3d").with_overrides(LIMITS)
    seeds = episode_seeds(3, "muc-osl-3d", 0)
    res = {
        b: run_episode(sc.with_overrides({"searcher": _searcher(b)}), *seeds, record=True)
        for b in ("numpy", "numba")
    }
    a, b = res["numpy"], res["numba"]
    np.testing.assert_array_equal(a.recording.positions, b.recording.positions)
    for key in ("steps", "bytes", "path_length", "first_detection_time", "energy"):
        assert _same(a.metrics[key], b.metrics[key]), key
    for key in ("cues", "iterations", "particles_mean", "accept_env", "messages_sent"):
        assert [v[key] for v in a.metrics.agents.values()] == [
            v[key] for v in b.metrics.agents.values()
        ], key


def test_the_same_seed_gives_the_same_episode_on_any_number_of_workers(tmp_path) -> None:
    """Two episodes of a sweep in this process and on two worker processes, and each again by
    ``run_episode`` from its seeds: the same rows."""
    spec = {
        "name": "muc-osl-workers",
        "seed": 11,
        "episodes": 2,
        "scenarios": [{"name": "muc-osl-3d", "params": {"limits.time": 60.0}}],
        "searchers": [{"name": "muc-osl"}],
    }
    rows = {}
    for workers in (1, 2):
        df = run_sweep(spec, tmp_path / f"w{workers}.sqlite", workers=workers, progress=False)
        rows[workers] = df.sort_values("episode")
    skip = (*TIMING, "finished_at", "extra")
    keep = [c for c in rows[1].columns if c not in skip]
    one, two = rows[1][keep].reset_index(drop=True), rows[2][keep].reset_index(drop=True)
    assert one.equals(two)
    for a, b in zip(rows[1]["extra"], rows[2]["extra"], strict=True):
        a, b = json.loads(a), json.loads(b)
        assert {k: v for k, v in a.items() if k not in TIMING} == {
            k: v for k, v in b.items() if k not in TIMING
        }
    sc = get_scenario("muc-osl-3d").with_overrides(
        {"limits.time": 60.0, "searcher": {"type": "muc-osl"}}
    )
    for _, row in one.iterrows():
        m = run_episode(sc, int(row.world_seed), int(row.agent_seed)).metrics
        assert m["steps"] == row.steps and m["bytes"] == row.bytes
        assert m["energy"] == row.energy
