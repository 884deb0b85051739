"""Presets: a searcher name bound to a parameter set of another searcher (a recipe).

A published policy that differs from a recipe only by its parts' settings (entrotaxis is
infotaxis with another reward) is a preset, not a subclass. A preset is a YAML file in
``odorloc/searchers/presets/``::

    # entrotaxis.yaml
    name: entrotaxis
    base: infotaxis
    summary: entrotaxis (Hutchinson et al. 2018)
    params:
      planner: {reward: {type: predictive-entropy}}

and is registered as the searcher ``name``: the recipe ``base`` whose parameters default to
``params`` laid over the recipe's own defaults. A scenario's settings for the preset are laid
over the preset's in turn (:func:`~odorloc.core.params.merge_dicts`: a dict without a ``type``
changes some settings of the part it names and keeps the others; a dict naming a ``type``
replaces the part). ``odorloc components`` lists presets among the searchers.

Adding a preset is adding its file. A plugin package registers its own with
:func:`register_preset` (or :func:`load_presets` of a folder) once its recipes are registered.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path
from typing import Any

import pydantic
from pydantic import model_validator

from odorloc.core import registry
from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.loading import load_yaml_mapping
from odorloc.core.params import Params, merge_dicts

__all__ = ["PRESET_DIR", "load_presets", "preset_params", "register_preset"]

#: The folder of the built-in presets.
PRESET_DIR = Path(__file__).resolve().parent / "presets"


def preset_params(name: str, base: type[Params], values: dict[str, Any]) -> type[Params]:
    """A parameter model: ``base`` whose input is laid over ``values`` first."""
    preset = dict(values)

    def apply_preset(cls: type[Params], data: Any) -> Any:
        return merge_dicts(preset, data) if isinstance(data, dict) else data

    title = "".join(w.capitalize() for w in re.split(r"[^0-9A-Za-z]+", name) if w)
    namespace = {
        "__module__": __name__,
        "__qualname__": f"{title}Params",
        "__doc__": f"Parameters of the preset ``{name}``: {base.__name__} with {preset}.",
        "apply_preset": model_validator(mode="before")(classmethod(apply_preset)),
    }
    cls = type(f"{title}Params", (base,), namespace)
    # the preset's own settings must be valid: check them now, naming the preset
    try:
        cls.model_validate({})
    except ConfigError as exc:
        raise ConfigError(f"preset {name}.{exc.field}", exc.problem) from None
    except pydantic.ValidationError as err:
        field, _, problem = format_validation_error(err, model=cls).partition(": ")
        raise ConfigError(f"preset {name}.{field}", problem) from None
    return cls


def register_preset(name: str, base: str, params: dict[str, Any], summary: str = "") -> None:
    """Register the searcher ``name``: the registered searcher ``base`` with ``params``."""
    entry = registry.entry("searcher", base, field=f"preset {name}.base")
    cls = preset_params(name, entry.params, params)
    what = summary or f"preset of {base}"
    registry.register("searcher", name, cls, f"{what} (preset of {base})")(entry.build)


def load_presets(folder: str | Path) -> list[str]:
    """Register every preset file (``*.yaml``) of ``folder``; returns their names."""
    names = []
    for path in sorted(Path(folder).glob("*.yaml")):
        data = load_yaml_mapping(path, "preset")
        unknown = set(data) - {"name", "base", "summary", "params"}
        if unknown:
            raise ConfigError(f"preset {path.name}", f"unknown keys {sorted(unknown)}")
        try:
            name, base = str(data["name"]), str(data["base"])
        except KeyError as exc:
            raise ConfigError(f"preset {path.name}", f"needs {exc.args[0]!r}") from None
        params = data.get("params") or {}
        if not isinstance(params, dict):
            raise ConfigError(f"preset {name}.params", "must be a mapping of settings")
        register_preset(name, base, params, str(data.get("summary") or ""))
        names.append(name)
    return names


def _import_recipes() -> None:
    """Import the recipe modules of this package, so that every base is registered."""
    package = importlib.import_module("odorloc.searchers")
    for info in pkgutil.iter_modules(package.__path__, "odorloc.searchers."):
        if info.name != __name__:
            importlib.import_module(info.name)


_import_recipes()
BUILTIN = load_presets(PRESET_DIR)
"""Names of the built-in presets."""
