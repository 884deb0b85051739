"""Named registry of components, so scenarios can refer to them by name (``"filament"``).

Each family (``"wind"``, ``"plume"``, ``"searcher"``, ``"reproduction"``, ...) maps a name to a
parameter model and a builder. Scenario files then read ``{type: filament, ...params}`` and the
registry validates the parameters with the component's own model, so errors name the exact field.

Where components come from
--------------------------
- **Discovery**: every module of the component packages (:data:`PACKAGES`) is imported the first
  time the registry is asked anything, and each module registers its members with
  :func:`register`. Adding a component is adding its file; no list of imports is kept by hand.
- **Plugins**: distributions may declare modules under the entry-point group
  ``odorloc.components`` (``[project.entry-points."odorloc.components"] mine = "mypkg.mod"``);
  they are imported the same way.
- **Import paths**: a ``type`` of the form ``"package.module:ClassName"`` names a class directly.
  The class must carry its parameter model as the class attribute ``Params``.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any

import pydantic
from pydantic import AfterValidator, BaseModel, ConfigDict
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.params import Params

__all__ = [
    "ENTRY_POINT_GROUP",
    "PACKAGES",
    "ComponentRef",
    "Entry",
    "Ref",
    "RefFamily",
    "entries",
    "entry",
    "make_params",
    "names",
    "ref_family",
    "register",
]

#: Packages whose modules are imported to discover components (in dependency order).
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
    "odorloc.papers",
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
_LOADED = False


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


def _import_tree(package: str) -> None:
    pkg = importlib.import_module(package)
    path = getattr(pkg, "__path__", None)
    if path is None:
        return
    for info in pkgutil.walk_packages(path, prefix=f"{package}."):
        importlib.import_module(info.name)


def _load_all() -> None:
    """Import every component module once (discovery), then the plugins' modules."""
    global _LOADED
    if _LOADED:
        return
    _LOADED = True
    try:
        for package in PACKAGES:
            _import_tree(package)
        for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            _import_tree(ep.value.split(":")[0])
    except BaseException:
        _LOADED = False
        raise


def family_base(family: str) -> type | None:
    """The most specific class every registered member of ``family`` derives from (``None``
    when they share nothing but ``object``)."""
    _load_all()
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
    _load_all()
    return sorted(_REGISTRY.get(family, {}))


def entry(family: str, name: str, field: str = "type") -> Entry:
    """The registry entry ``family/name``; a :class:`ConfigError` naming ``field`` if unknown."""
    if ":" in name:
        return _from_path(family, name, field)
    _load_all()
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
    _load_all()
    return [v for _, v in sorted(_REGISTRY.get(family, {}).items())]


def families() -> list[str]:
    """Every family with at least one member."""
    _load_all()
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


@dataclass(frozen=True)
class RefFamily:
    """Marks a ``Ref(family)`` field with the registry family of its component (read by
    :func:`ref_family`, e.g. to document and resolve nested components)."""

    family: str


def Ref(family: str) -> Any:
    """Annotated :class:`ComponentRef` type validated against ``family`` (see the class)."""
    return Annotated[ComponentRef, RefFamily(family), AfterValidator(_ref_checker(family))]


def ref_family(field: FieldInfo) -> str | None:
    """The family of a ``Ref(family)`` parameter field (also of ``Ref(family) | None`` and
    lists of them), else ``None``."""

    def find(metadata: Any, annotation: Any) -> str | None:
        for meta in metadata:
            if isinstance(meta, RefFamily):
                return meta.family
        if typing.get_origin(annotation) is Annotated:
            inner, *more = typing.get_args(annotation)
            return find(more, inner)
        for arg in typing.get_args(annotation):
            fam = find((), arg)
            if fam is not None:
                return fam
        return None

    return find(field.metadata, field.annotation)
