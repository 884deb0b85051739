"""Named registry of components, so scenarios can refer to them by name (``"filament"``).

Each family (``"wind"``, ``"plume"``, ``"searcher"``, ...) maps a name to a parameter model and a
builder. Scenario files then read ``{type: filament, ...params}`` and the registry validates the
parameters with the component's own model, so errors name the exact field.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pydantic

from odorloc.errors import ConfigError, format_validation_error
from odorloc.params import Params


@dataclass(frozen=True)
class Entry:
    """A registered component: its parameter model, builder and one-line description."""

    family: str
    name: str
    params: type[Params]
    build: Callable[..., Any]
    summary: str


_REGISTRY: dict[str, dict[str, Entry]] = {}


def register(
    family: str, name: str, params: type[Params], summary: str = ""
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Class/function decorator registering ``build`` under ``family/name``.

    The decorated object is called as ``build(params, **context)`` by :func:`build`.
    """

    def deco(obj: Callable[..., Any]) -> Callable[..., Any]:
        fam = _REGISTRY.setdefault(family, {})
        if name in fam and fam[name].build is not obj:
            raise RuntimeError(f"{family} {name!r} registered twice")
        doc = summary or ((obj.__doc__ or "").strip().splitlines() or [""])[0]
        fam[name] = Entry(family, name, params, obj, doc)
        return obj

    return deco


def _load_all() -> None:
    # Importing the component packages registers their members.
    import odorloc.components  # noqa: F401


def names(family: str) -> list[str]:
    """Sorted names registered in ``family``."""
    _load_all()
    return sorted(_REGISTRY.get(family, {}))


def entry(family: str, name: str, field: str = "type") -> Entry:
    """The registry entry ``family/name``; a :class:`ConfigError` naming ``field`` if unknown."""
    _load_all()
    fam = _REGISTRY.get(family, {})
    if name not in fam:
        known = ", ".join(sorted(fam)) or "none"
        raise ConfigError(field, f"unknown {family} model {name!r} (known: {known})")
    return fam[name]


def make_params(family: str, name: str, values: dict[str, Any], field: str = "") -> Params:
    """Validate ``values`` against the parameter model of ``family/name``."""
    e = entry(family, name, field=f"{field}.type" if field else "type")
    try:
        return e.params.model_validate(values)
    except pydantic.ValidationError as err:
        line = format_validation_error(err, prefix=field)
        fld, _, problem = line.partition(": ")
        raise ConfigError(fld, problem) from None


def entries(family: str) -> list[Entry]:
    """All entries of ``family`` sorted by name."""
    _load_all()
    return [v for _, v in sorted(_REGISTRY.get(family, {}).items())]
