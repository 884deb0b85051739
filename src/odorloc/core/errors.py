"""Exceptions raised on invalid input.

Every error names the offending field so that the command line can print one clear line.
"""

from __future__ import annotations

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


def format_validation_error(err: pydantic.ValidationError, prefix: str = "") -> str:
    """One line naming the first invalid field of a pydantic error (and how many more there are)."""
    errors = err.errors()
    first = errors[0]
    parts = list(first["loc"])
    if first.get("type") == "component":
        # a nested component's own error: its field continues the path
        parts += str(first["ctx"]["field"]).split(".")
    loc = ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in parts)
    loc = loc.replace(".[", "[")
    if prefix:
        loc = f"{prefix}.{loc}" if loc else prefix
    msg = str(first["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    more = f" (and {len(errors) - 1} more problem(s))" if len(errors) > 1 else ""
    return f"{loc or '<root>'}: {msg}{more}"
