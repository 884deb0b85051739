"""The one way a scenario is named, found and checked before any episode runs.

- :func:`resolve_ref` turns what a user wrote (a built-in name or a file path, possibly relative
  to the sweep file that names it) into what every process can open: a built-in name stays as
  it is, a path becomes absolute.
- :func:`load_scenario` loads it (built-in or file) through the safe reader of
  :mod:`odorloc.core.loading`.
- :func:`check_scenario` is the deep check: it builds every component (the arena and its
  obstacle file, the wind, the plume, sensors, platforms, the searcher) and resets the searcher
  on the scenario's search context, so that a scenario which cannot run fails here, with one
  :class:`~odorloc.core.errors.ConfigError` naming its field, instead of in every episode.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.scenarios.catalog import builtin_names, builtin_path
from odorloc.scenarios.config import Scenario

__all__ = [
    "DECLARATION_ENDS",
    "SCENARIO_SUFFIXES",
    "check_declares",
    "check_scenario",
    "is_file_ref",
    "load_scenario",
    "resolve_components",
    "resolve_ref",
    "scenario_name",
]

SCENARIO_SUFFIXES = (".yaml", ".yml")
"""File endings that mark a scenario reference as a file path."""


def is_file_ref(ref: str | Path) -> bool:
    """Whether ``ref`` names a scenario file (rather than a built-in scenario)."""
    s = str(ref)
    return s.endswith(SCENARIO_SUFFIXES) or "/" in s or "\\" in s


def resolve_ref(ref: str | Path, base_dir: str | Path | None = None) -> str:
    """A scenario reference every process can open.

    Parameters
    ----------
    ref : str or path
        A built-in scenario name or a scenario file path.
    base_dir : path, optional
        Folder a relative file path is relative to (a sweep file's folder); default the
        current folder.

    Returns
    -------
    str
        A built-in name unchanged, the absolute path of a file, or (neither) ``ref`` as given,
        for :func:`load_scenario` to refuse by name.
    """
    s = str(ref)
    if not is_file_ref(s) and s in builtin_names():
        return s
    p = Path(s).expanduser()
    if not p.is_absolute():
        p = Path(base_dir or ".") / p
    if is_file_ref(s) or p.exists():
        return str(p.absolute())
    return s


def load_scenario(ref: str | Path, base_dir: str | Path | None = None) -> Scenario:
    """A built-in scenario by name, or a scenario file (relative to ``base_dir``).

    Raises
    ------
    ConfigError
        ``scenario``: an unknown name or an unreadable file; otherwise the invalid field.
    """
    s = resolve_ref(ref, base_dir)
    if Path(s).is_absolute():
        return Scenario.from_yaml(s)
    return Scenario.from_yaml(builtin_path(s))


def scenario_name(ref: str | Path, base_dir: str | Path | None = None) -> str:
    """The scenario's own ``name``: the key of its seeds, whichever way it was referred to.

    A built-in name is its own name; a file gives the ``name`` field it holds, so that
    ``iv.yaml``, ``./iv.yaml``, ``/abs/iv.yaml`` and the built-in scenario the file was printed
    from (``odorloc scenarios NAME``) all key their episodes alike
    (:func:`odorloc.core.seeds.episode_seeds`).

    Raises
    ------
    ConfigError
        As :func:`load_scenario`: an unknown name, an unreadable or invalid file.
    """
    s = resolve_ref(ref, base_dir)
    if not Path(s).is_absolute():
        builtin_path(s)  # an unknown name is refused by name
        return s
    return load_scenario(s).name


def resolve_components(sc: Scenario) -> Scenario:
    """The same scenario with every component's parameters written out, defaults included
    (sub-components too: a searcher's resampler, a team's member).

    The result validates to the same parameters as ``sc``, so it runs the same episodes; it
    shows everything a scenario can set (``odorloc scenarios NAME --resolved``).
    """
    from odorloc.scenarios.config import COMPONENTS

    data = sc.to_dict()
    for path, family in COMPONENTS.items():
        node: Any = data
        *parents, last = path.split(".")
        for k in parents:
            node = node.get(k) if isinstance(node, dict) else None
        if isinstance(node, dict) and isinstance(node.get(last), dict):
            node[last] = _full_component(family, node[last], path)
    return Scenario.from_dict(data)


def _full_component(family: str, ref: dict[str, Any], field: str) -> dict[str, Any]:
    """``{type, **every parameter}`` of the component ``ref`` of ``family``."""
    from odorloc.core import registry

    values = {k: v for k, v in ref.items() if k != "type"}
    params = registry.make_params(family, ref["type"], values, field=field)
    out: dict[str, Any] = {"type": ref["type"]}
    for name, info in type(params).model_fields.items():
        if info.exclude:
            continue
        value = getattr(params, name)
        fam = registry.ref_family(info)
        if fam is not None and isinstance(value, registry.ComponentRef):
            out[name] = _full_component(fam, {"type": value.type, **value.values}, name)
        elif fam is not None and isinstance(value, list | tuple):
            out[name] = [
                _full_component(fam, {"type": v.type, **v.values}, f"{name}[{i}]")
                for i, v in enumerate(value)
            ]
        else:
            out[name] = params.model_dump(mode="python", include={name})[name]
    return out


def check_scenario(sc: Scenario, world: Any = None) -> Any:
    """Build every component of ``sc`` and reset its searcher on the search context.

    Parameters
    ----------
    sc : Scenario
    world : World, optional
        An already built world of the same world settings (sweeps build each world once and
        check every searcher cell of it against that world).

    Returns
    -------
    World
        The built world (to pass back in for the next cell of the same world).

    Raises
    ------
    ConfigError
        The first field that stops the scenario from running.
    """
    from odorloc.scenarios.build import build, build_world, prefixed, search_context

    if world is None:
        world = build_world(sc)
    if sc.world.source_draw is not None:
        drawer = sc.world.source_draw.build("source_draw", field="world.source_draw")
        prefixed("world.source_draw", drawer.check, world.arena)
    built = build(sc, world=world)
    ctx = search_context(sc, built)
    # a throwaway generator: the check must not touch any episode's stream
    prefixed("searcher", built.searcher.reset, ctx, np.random.default_rng(0))
    check_declares(sc, built.searcher)
    return world


#: Task ends that only a declaration brings about (and only a declaration can succeed in).
DECLARATION_ENDS = ("first_declaration", "all_groups")


def check_declares(sc: Scenario, searcher: Any) -> None:
    """Refuse a searcher that never declares in a scenario that ends only on a declaration.

    Such a scenario scores success by the declared positions alone, so every episode of the
    searcher would run to the time limit and fail, silently. The fix is named in the error:
    end on reaching a source (``task.end: reach`` with ``task.reach_radius``) or run a
    searcher that declares.

    Raises
    ------
    ConfigError
        ``task.end``.
    """
    if sc.task.end not in DECLARATION_ENDS or searcher.may_declare():
        return
    raise ConfigError(
        "task.end",
        f"is {sc.task.end!r}, but searcher {sc.searcher.type!r} never declares a source, so "
        "no episode could succeed: end on reaching the source instead (task.end: reach and "
        "a task.reach_radius, e.g. 0.5) or choose a searcher that declares",
    )
