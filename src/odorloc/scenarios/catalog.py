"""The built-in scenarios: YAML files found by name under the paper packages
(``odorloc/papers/<paper>/scenarios/``) and ``odorloc/scenarios/builtin/``."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from odorloc.core.errors import ConfigError

__all__ = ["builtin_names", "builtin_path"]


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
