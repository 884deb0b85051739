"""Shared fixtures: small, fast scenarios built from plain dicts."""

from __future__ import annotations

import os
from typing import Any

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


def small_scenario_dict(searcher: str = "zigzag", **searcher_params: Any) -> dict[str, Any]:
    """A 10 m x 5 m room, uniform wind, Gaussian plume; 30 s episodes."""
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


@pytest.fixture
def small_scenario():
    from odorloc.scenarios import Scenario

    return Scenario.from_dict(small_scenario_dict())
