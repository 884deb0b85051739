"""Scenarios: typed, YAML round-tripping experiment settings, and the built-in paper settings.

Built-in scenarios are the YAML files under ``odorloc/papers/<paper>/scenarios/`` (each paper
package ships its own) and ``odorloc/scenarios/builtin/``; they are found by file, so adding one
is adding its file.
"""

from __future__ import annotations

from pathlib import Path

from odorloc.scenarios.catalog import builtin_names, builtin_path
from odorloc.scenarios.config import Component, Scenario

__all__ = [
    "DEFAULT_SCENARIO",
    "Component",
    "Scenario",
    "builtin_names",
    "builtin_path",
    "get_scenario",
]

#: The scenario ``odorloc run`` uses when given none.
DEFAULT_SCENARIO = "indoor-ventilated"


def get_scenario(name_or_path: str | Path) -> Scenario:
    """A built-in scenario by name, or a scenario file by path (see
    :func:`odorloc.scenarios.loading.load_scenario`)."""
    from odorloc.scenarios.loading import load_scenario

    return load_scenario(name_or_path)
