"""Scenarios: typed, YAML round-tripping experiment settings, and the built-in paper settings.

Built-in scenarios are the YAML files under ``odorloc/papers/<paper>/scenarios/`` (each paper
package ships its own) and ``odorloc/scenarios/builtin/``; they are found by file, so adding one
is adding its file.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from odorloc.core.errors import ConfigError
from odorloc.scenarios.config import Component, Scenario

__all__ = ["DEFAULT_SCENARIO", "Component", "Scenario", "builtin_names", "get_scenario"]

#: The scenario ``odorloc run`` uses when given none.
DEFAULT_SCENARIO = "indoor-ventilated"


def _builtin_files() -> dict[str, Path]:
    root = Path(str(resources.files("odorloc")))
    files = sorted((root / "papers").glob("*/scenarios/*.yaml"))
    files += sorted((root / "scenarios" / "builtin").glob("*.yaml"))
    out: dict[str, Path] = {}
    for f in files:
        if f.stem in out:
            raise RuntimeError(f"two built-in scenarios named {f.stem!r}: {out[f.stem]}, {f}")
        out[f.stem] = f
    return out


def builtin_names() -> list[str]:
    """Names of the built-in scenarios."""
    return sorted(_builtin_files())


def builtin_path(name: str) -> Path:
    """File of the built-in scenario ``name``; :class:`ConfigError` if there is none."""
    files = _builtin_files()
    if name not in files:
        known = ", ".join(sorted(files))
        raise ConfigError("scenario", f"unknown scenario {name!r} (built-in: {known})")
    return files[name]


def get_scenario(name_or_path: str | Path) -> Scenario:
    """A built-in scenario by name, or a scenario file by path (see
    :func:`odorloc.scenarios.loading.load_scenario`)."""
    from odorloc.scenarios.loading import load_scenario

    return load_scenario(name_or_path)
