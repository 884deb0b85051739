"""Plain helpers shared by the tests: small, fast scenarios built from plain dicts.

Importable from every test folder (``pythonpath = ["tests"]`` in ``pyproject.toml``).
"""

from __future__ import annotations

import math
from typing import Any

from odorloc.experiments.runner import ROW_DEFAULTS
from odorloc.experiments.store import ResultStore
from odorloc.experiments.sweep import config_hash, expand_tasks, load_sweep

#: Searchers of these helpers that never declare: their scenarios end at the limits (a scenario
#: that ends on a declaration refuses them when it is loaded).
NEVER_DECLARE = ("zigzag", "random-walk")


def small_scenario_dict(searcher: str = "zigzag", **searcher_params: Any) -> dict[str, Any]:
    """A 10 m x 5 m room, uniform wind, Gaussian plume; 30 s episodes (ending at the limits
    for a searcher that never declares, else on the first declaration)."""
    end = "limits" if searcher in NEVER_DECLARE else "first_declaration"
    return {
        "name": "test-room",
        "world": {
            "arena": {"lower": [0.0, 0.0], "upper": [10.0, 5.0], "resolution": 0.1},
            "sources": [{"position": [1.0, 2.5], "rate": 1.0}],
            "wind": {"type": "uniform", "velocity": [0.5, 0.0]},
            "plume": {"type": "gaussian"},
            "dt": 0.25,
        },
        "platform": {"type": "holonomic", "max_speed": 0.5},
        "agents": {"starts": [[8.0, 2.0]]},
        "searcher": {"type": searcher, **searcher_params},
        "task": {"end": end},
        "limits": {"control_dt": 0.5, "time": 30.0},
        "recording": {"plume_stride": 10},
    }


def filament_scenario_dict(searcher: str = "zigzag", **searcher_params: Any) -> dict[str, Any]:
    """Same room with a time-varying filament plume (so the world is random)."""
    d = small_scenario_dict(searcher, **searcher_params)
    d["world"]["plume"] = {"type": "filament"}
    d["world"]["sources"] = [{"position": [1.0, 2.5], "rate": 20.0}]
    d["world"]["warmup"] = 10.0
    d["world"]["dt"] = 0.1
    return d


def _degenerate_row(kind: str, i: int) -> dict[str, Any]:
    row = dict(ROW_DEFAULTS)
    row.update(status="ok", error="", termination="time_limit", wall_time=0.1)
    if kind == "all-errors":
        row.update(status="error", error="RuntimeError: boom")
    elif kind == "no-success":
        row.update(success=False, search_time=600.0, path_length=10.0, declared=False)
    elif kind == "nan-times":
        row.update(success=True, declared=True, termination="declared", search_time=math.nan)
    elif kind == "one-each":
        # a single success: every bootstrap interval is the point itself or NaN
        row.update(success=i % 2 == 0, declared=True, search_time=100.0 + i, loc_error=0.1)
        row.update(path_length=20.0, start_distance=4.0, termination="declared")
        row.update(
            map_success=i % 2 == 0,
            residual_uncertainty=50.0,
            initial_uncertainty=3360.0,
            mapped_sources=1,
            mapped_x_0=20.0,
            mapped_y_0=50.0,
        )
    return row


def fake_run_sweep(kind: str) -> Any:
    """A stand-in for ``run_sweep`` that stores degenerate rows of one ``kind`` (one-each,
    no-success, all-errors, nan-times) instead of running episodes."""

    def run_sweep(spec: Any, store_path: Any, **kw: Any) -> Any:
        s = load_sweep(spec)
        tasks = expand_tasks(s, episodes=1)
        with ResultStore(store_path) as st:
            st.bind(config_hash(s), s)
            for i, t in enumerate(tasks):
                st.add(t, _degenerate_row(kind, i))
            return st.frame()

    return run_sweep
