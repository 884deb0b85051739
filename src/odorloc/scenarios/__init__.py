"""Scenarios: typed, YAML round-tripping experiment settings, and the built-in paper settings."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from odorloc.errors import ConfigError
from odorloc.scenarios.config import Component, Scenario

__all__ = ["DEFAULT_SCENARIO", "Component", "Scenario", "builtin_names", "get_scenario"]

#: The scenario ``odorloc run`` uses when given none.
DEFAULT_SCENARIO = "indoor-ventilated"


def _builtin_dir() -> Path:
    return Path(str(resources.files("odorloc.scenarios") / "builtin"))


def builtin_names() -> list[str]:
    """Names of the built-in scenarios."""
    return sorted(p.stem for p in _builtin_dir().glob("*.yaml"))


def get_scenario(name_or_path: str | Path) -> Scenario:
    """A built-in scenario by name, or a scenario file by path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists():
        return Scenario.from_yaml(p)
    f = _builtin_dir() / f"{name_or_path}.yaml"
    if not f.exists():
        known = ", ".join(builtin_names())
        raise ConfigError("scenario", f"unknown scenario {str(name_or_path)!r} (built-in: {known})")
    return Scenario.from_yaml(f)
