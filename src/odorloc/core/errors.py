"""Exceptions raised on invalid input.

Every error names the offending field so that the command line can print one clear line.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import pydantic


class OdorlocError(Exception):
    """Base class of the library's own errors."""


class ConfigError(OdorlocError, ValueError):
    """An invalid parameter or configuration value.

    Parameters
    ----------
    field : str
        Dotted path of the offending field, e.g. ``"plume.sources[0].position"``.
    problem : str
        What is wrong with it, in a few words.
    """

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"{field}: {problem}")


def join_field(prefix: str, field: str) -> str:
    """``field`` (named relative to a component) as a path under ``prefix``, without doubling.

    ``join_field("world.arena", "upper") == "world.arena.upper"``; a field that already starts
    with the prefix, or with the prefix's last part (``"arena.upper"`` under ``"world.arena"``),
    is not prefixed twice.
    """
    if not prefix:
        return field
    if not field or field == "<root>":
        return prefix
    if field == prefix or field.startswith((f"{prefix}.", f"{prefix}[")):
        return field
    last = prefix.rsplit(".", 1)[-1]
    if field == last or field.startswith((f"{last}.", f"{last}[")):
        return f"{prefix}{field[len(last) :]}"
    return f"{prefix}.{field}" if not field.startswith("[") else f"{prefix}{field}"


def _fields_at(model: Any, loc: Sequence[Any]) -> list[str] | None:
    """Field names of the pydantic model reached from ``model`` along ``loc`` (``None`` if the
    path leaves typed models, e.g. into a free-form mapping)."""
    import typing

    from pydantic import BaseModel

    def models_of(ann: Any) -> list[Any]:
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            return [ann]
        return [m for a in typing.get_args(ann) for m in models_of(a)]

    current: Any = model
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return None
        f = current.model_fields.get(str(part))
        if f is None:
            return None
        found = models_of(f.annotation)
        if len(found) != 1:
            return None
        current = found[0]
    if isinstance(current, type) and issubclass(current, BaseModel):
        if current.model_config.get("extra") == "allow":
            return None
        return [k for k, f in current.model_fields.items() if not f.exclude]
    return None


def format_validation_error(
    err: pydantic.ValidationError, prefix: str = "", model: Any = None
) -> str:
    """One line naming the first invalid field of a pydantic error (and how many more there are).

    With ``model`` (the validated class), an unknown key lists the known ones.
    """
    errors = err.errors()
    first = errors[0]
    parts = list(first["loc"])
    inner = (first.get("ctx") or {}).get("error")
    if first.get("type") == "component":
        # a nested component's own error: its field continues the path
        parts += str(first["ctx"]["field"]).split(".")
    loc = ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in parts)
    loc = loc.replace(".[", "[")
    msg = str(first["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    if isinstance(inner, ConfigError):
        # a validator raised a field error of its own: its field continues the path
        loc = join_field(loc, inner.field) if loc else inner.field
        msg = inner.problem
    if prefix:
        loc = join_field(prefix, loc) if loc else prefix
    if first.get("type") == "extra_forbidden":
        known = _fields_at(model, parts[:-1]) if model is not None else None
        msg = "unknown setting" + (f" (known: {', '.join(known)})" if known else "")
    more = f" (and {len(errors) - 1} more problem(s))" if len(errors) > 1 else ""
    return f"{loc or '<root>'}: {msg}{more}"
