"""Named registry of components, so scenarios can refer to them by name (``"filament"``).

Each family (``"wind"``, ``"plume"``, ``"searcher"``, ``"resampler"``, ...) maps a name to a
parameter model and a builder. Scenario files then read ``{type: filament, ...params}`` and the
registry validates the parameters with the component's own model, so errors name the exact field.

Where components come from
--------------------------
- **Discovery**: the modules of the component packages (:data:`PACKAGES`) register their members
  with :func:`register` when they are imported. The first question about a family imports only
  the modules whose source registers a member of that family (a text scan of the package files,
  which imports nothing), so asking for a plume loads the plumes and what they need, not the
  searchers. Adding a component is adding its file; no list of imports is kept by hand.
- **Higher layers** name further packages with :func:`include` (the experiments layer includes
  ``odorloc.papers`` for the family ``"reproduction"``); the core itself never imports them.
- **Plugins**: distributions may declare modules under the entry-point group
  ``odorloc.components`` (``[project.entry-points."odorloc.components"] mine = "mypkg.mod"``);
  they are imported in full the first time any family is asked for.
- **Import paths**: a ``type`` of the form ``"package.module:ClassName"`` names a class directly.
  The class must carry its parameter model as the class attribute ``Params``.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import pkgutil
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Annotated, Any

import pydantic
from pydantic import AfterValidator, BaseModel, ConfigDict
from pydantic_core import PydanticCustomError

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.params import Params

__all__ = [
    "ENTRY_POINT_GROUP",
    "PACKAGES",
    "ComponentRef",
    "Entry",
    "Ref",
    "entries",
    "entry",
    "families",
    "family_base",
    "include",
    "load_all",
    "make_params",
    "names",
    "register",
]

#: Packages whose modules are scanned to discover components (in dependency order). Papers are
#: not among them: the layers that use reproductions and paper scenarios find those themselves.
PACKAGES = (
    "odorloc.models",
    "odorloc.wind",
    "odorloc.plume",
    "odorloc.sensors",
    "odorloc.platforms",
    "odorloc.inference",
    "odorloc.planning",
    "odorloc.behaviours",
    "odorloc.searchers",
)
ENTRY_POINT_GROUP = "odorloc.components"


@dataclass(frozen=True)
class Entry:
    """A registered component: its parameter model, builder and one-line description."""

    family: str
    name: str
    params: type[Params]
    build: Callable[..., Any]
    summary: str


_REGISTRY: dict[str, dict[str, Entry]] = {}
#: Further packages named by higher layers with :func:`include` (scanned like :data:`PACKAGES`).
_INCLUDED: list[str] = []
#: Families whose modules have been imported, and whether everything has been.
_LOADED: set[str] = set()
_LOADED_ALL: list[bool] = []
_PLUGINS_LOADED: list[bool] = []
#: Module name -> the families its source registers (``None``: unknown, import it for any).
_SCAN: dict[str, frozenset[str] | None] = {}
_SCANNED: set[str] = set()

# ``register("family"`` with a literal family, as in ``@register("plume", "filament", ...)``
_REGISTERS = re.compile(r"\bregister\(\s*(?:family\s*=\s*)?([\"'])([A-Za-z0-9_.\-]+)\1")
_ANY_REGISTER = re.compile(r"\bregister\(")


def register(
    family: str, name: str, params: type[Params], summary: str = ""
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Class/function decorator registering ``build`` under ``family/name``.

    The decorated object is called as ``build(params, *context)`` by the scenario builder.
    Registering the same object twice is harmless; two objects under one name is an error.
    """

    def deco(obj: Callable[..., Any]) -> Callable[..., Any]:
        fam = _REGISTRY.setdefault(family, {})
        if name in fam and fam[name].build is not obj:
            raise RuntimeError(f"{family} {name!r} registered twice")
        doc = summary or ((obj.__doc__ or "").strip().splitlines() or [""])[0]
        fam[name] = Entry(family, name, params, obj, doc)
        return obj

    return deco


def _modules(package: str) -> Iterator[tuple[str, str | None]]:
    """``(module name, source)`` of every module under ``package``, found without importing
    any of them (``source`` is ``None`` when only compiled files exist)."""
    spec = importlib.util.find_spec(package)
    if spec is None:
        raise ModuleNotFoundError(f"no package {package!r}", name=package)
    yield package, _source(spec)
    todo = [(package, list(spec.submodule_search_locations or []))]
    while todo:
        prefix, path = todo.pop()
        for info in pkgutil.iter_modules(path, prefix=f"{prefix}."):
            sub = info.module_finder.find_spec(info.name, None)  # type: ignore[call-arg]
            if sub is None:
                continue
            yield info.name, _source(sub)
            if info.ispkg:
                todo.append((info.name, list(sub.submodule_search_locations or [])))


def _source(spec: importlib.machinery.ModuleSpec) -> str | None:
    try:
        return spec.loader.get_source(spec.name)  # type: ignore[union-attr]
    except (AttributeError, ImportError, OSError, UnicodeDecodeError):
        return None


def _families_in(source: str | None) -> frozenset[str] | None:
    """Families a module's source registers; ``None`` if it may register others the scan cannot
    read (compiled only, or ``register`` called with a computed family)."""
    if source is None:
        return None
    found = [m.group(2) for m in _REGISTERS.finditer(source)]
    if len(found) != len(_ANY_REGISTER.findall(source)):
        return None
    return frozenset(found)


def _scan() -> None:
    for package in (*PACKAGES, *_INCLUDED):
        if package in _SCANNED:
            continue
        for name, source in _modules(package):
            _SCAN[name] = _families_in(source)
        _SCANNED.add(package)


def _load_plugins() -> None:
    if _PLUGINS_LOADED:
        return
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        _import_tree(ep.value.split(":")[0])
    _PLUGINS_LOADED.append(True)


def _import_tree(package: str) -> None:
    pkg = importlib.import_module(package)
    path = getattr(pkg, "__path__", None)
    if path is None:
        return
    for info in pkgutil.walk_packages(path, prefix=f"{package}."):
        importlib.import_module(info.name)


def _load(family: str) -> None:
    """Import the modules that register members of ``family`` (once), then the plugins."""
    if family in _LOADED or _LOADED_ALL:
        return
    _scan()
    for name, fams in list(_SCAN.items()):
        if fams is None or family in fams:
            importlib.import_module(name)
    _load_plugins()
    _LOADED.add(family)


def load_all() -> None:
    """Import every module of the component packages, the included ones and the plugins (what
    a process about to run many episodes does once, e.g. to load every compiled kernel)."""
    if _LOADED_ALL:
        return
    _scan()
    for name in list(_SCAN):
        importlib.import_module(name)
    _load_plugins()
    _LOADED_ALL.append(True)


def include(package: str) -> None:
    """Add ``package`` to discovery: its modules are scanned and imported like those of
    :data:`PACKAGES`. A higher layer calls this for the packages whose members it uses (the
    experiments layer for the papers' reproductions); families already loaded are loaded again
    from the new package at their next lookup."""
    if package in PACKAGES or package in _INCLUDED:
        return
    _INCLUDED.append(package)
    _LOADED.clear()
    _LOADED_ALL.clear()


def family_base(family: str) -> type | None:
    """The most specific class every registered member of ``family`` derives from (``None``
    when they share nothing but ``object``)."""
    _load(family)
    members = [e.build for e in _REGISTRY.get(family, {}).values() if isinstance(e.build, type)]
    if not members:
        return None
    # one member says nothing of what the family requires beyond its parents
    mro = members[0].__mro__[1:] if len(members) == 1 else members[0].__mro__
    for base in mro:
        if base is not object and all(issubclass(m, base) for m in members):
            return base
    return None


def _from_path(family: str, ref: str, field: str) -> Entry:
    mod_name, _, attr = ref.partition(":")
    if not mod_name or not attr:
        raise ConfigError(field, f"{ref!r} is not 'package.module:Class'")
    try:
        obj = getattr(importlib.import_module(mod_name), attr)
    except (ImportError, AttributeError, TypeError, ValueError) as exc:
        raise ConfigError(field, f"cannot import {ref!r} ({exc})") from None
    params = getattr(obj, "Params", None)
    if not (isinstance(params, type) and issubclass(params, Params)):
        raise ConfigError(field, f"{ref!r} has no parameter model (a class attribute 'Params')")
    base = family_base(family)
    if base is not None and not (isinstance(obj, type) and issubclass(obj, base)):
        raise ConfigError(field, f"{ref!r} is not a {family} (not a {base.__name__})")
    doc = ((obj.__doc__ or "").strip().splitlines() or [""])[0]
    return Entry(family, ref, params, obj, doc)


def names(family: str) -> list[str]:
    """Sorted names registered in ``family``."""
    _load(family)
    return sorted(_REGISTRY.get(family, {}))


def entry(family: str, name: str, field: str = "type") -> Entry:
    """The registry entry ``family/name``; a :class:`ConfigError` naming ``field`` if unknown."""
    if ":" in name:
        return _from_path(family, name, field)
    _load(family)
    fam = _REGISTRY.get(family, {})
    if name not in fam:
        known = ", ".join(sorted(fam)) or "none"
        raise ConfigError(field, f"unknown {family} {name!r} (known: {known})")
    return fam[name]


def make_params(family: str, name: str, values: dict[str, Any], field: str = "") -> Params:
    """Validate ``values`` against the parameter model of ``family/name``."""
    e = entry(family, name, field=f"{field}.type" if field else "type")
    try:
        return e.params.model_validate(values)
    except pydantic.ValidationError as err:
        line = format_validation_error(err, prefix=field, model=e.params)
        fld, _, problem = line.partition(": ")
        raise ConfigError(fld, problem) from None


def entries(family: str) -> list[Entry]:
    """All entries of ``family`` sorted by name."""
    _load(family)
    return [v for _, v in sorted(_REGISTRY.get(family, {}).items())]


def families() -> list[str]:
    """Every family with at least one member."""
    load_all()
    return sorted(_REGISTRY)


class ComponentRef(BaseModel):
    """A reference to a registered component inside another's parameters: ``type`` plus the
    component's own parameters, e.g. ``resampler: {type: roulette, max_children: 5}``.

    Declare such a field as ``Ref("resampler")`` so that the parameters are checked against the
    family's registry when the enclosing parameters are validated (errors name the full path).
    """

    model_config = ConfigDict(frozen=True, extra="allow")
    type: str

    @property
    def values(self) -> dict[str, Any]:
        """The parameters without ``type``."""
        return dict(self.model_extra or {})

    def params(self, family: str, field: str = "") -> Params:
        """The validated parameters of ``family/type``."""
        return make_params(family, self.type, self.values, field=field)

    def build(self, family: str, *args: Any, field: str = "") -> Any:
        """Construct the component: ``builder(params, *args)``."""
        return entry(family, self.type, field=f"{field}.type" if field else "type").build(
            self.params(family, field), *args
        )


def _ref_checker(family: str) -> Any:
    def check(v: ComponentRef) -> ComponentRef:
        try:
            make_params(family, v.type, v.values)
        except ConfigError as exc:
            raise PydanticCustomError(
                "component", "{problem}", {"field": exc.field, "problem": exc.problem}
            ) from None
        return v

    return check


def Ref(family: str) -> Any:
    """Annotated :class:`ComponentRef` type validated against ``family`` (see the class)."""
    return Annotated[ComponentRef, AfterValidator(_ref_checker(family))]
