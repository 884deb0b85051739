"""Base class of all component parameters.

Parameters are immutable, validated pydantic models: unknown keys are rejected (a typo is an error,
not a silently ignored setting) and every value error names the field.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

from odorloc.core.errors import ConfigError


def _refuse_bool(v: Any) -> Any:
    if isinstance(v, bool):
        raise ValueError(f"must be a number, not {str(v).lower()}")
    return v


def _is_guard(meta: Any) -> bool:
    """Whether the validator ``meta`` refuses true/false already."""
    func = getattr(meta, "func", None)
    return func in (_refuse_bool, _not_bool, no_bools) or getattr(func, "refuses_bools", False)


def _union_args(annotation: Any) -> tuple[Any, ...] | None:
    """The members of a union other than ``None``; ``None`` if ``annotation`` is no union."""
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        return tuple(a for a in typing.get_args(annotation) if a is not type(None))
    return None


def _unguarded(annotation: Any) -> Any:
    """``annotation`` without its ``Annotated`` wrapper; ``None`` if that wrapper already
    refuses true/false (its own validator then reports it)."""
    if typing.get_origin(annotation) is Annotated:
        if any(_is_guard(m) for m in annotation.__metadata__):
            return None
        return typing.get_args(annotation)[0]
    return annotation


def _holds_numbers(annotation: Any) -> bool:
    """Whether values of ``annotation`` have numbers where true/false would be read as 1/0:
    ``int``, ``float`` (constrained or optional), and lists, tuples and dicts of them."""
    annotation = _unguarded(annotation)
    if annotation in (int, float):
        return True
    members = _union_args(annotation)
    if members is not None:
        return len(members) == 1 and _holds_numbers(members[0])
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (list, tuple):
        return any(_holds_numbers(a) for a in args if a is not Ellipsis)
    if origin is dict and len(args) == 2:
        return _holds_numbers(args[1])
    return False


def _find_bool(annotation: Any, value: Any, at: str = "") -> tuple[str, bool] | None:
    """The first true/false in ``value`` where ``annotation`` expects a number, as its place
    (``""`` the value itself, ``"[0][1]"`` an item) and the bool; ``None`` if there is none."""
    annotation = _unguarded(annotation)
    members = _union_args(annotation)
    if members is not None:
        return _find_bool(members[0], value, at) if len(members) == 1 else None
    if annotation in (int, float):
        return (at, value) if isinstance(value, bool) else None
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (list, tuple) and args and isinstance(value, list | tuple):
        if origin is list or args[-1] is Ellipsis:
            items: Any = [args[0]] * len(value)
        else:
            items = args  # a fixed tuple; a wrong length is pydantic's own error
        for i, (a, v) in enumerate(zip(items, value, strict=False)):
            found = _find_bool(a, v, f"{at}[{i}]")
            if found is not None:
                return found
    elif origin is dict and len(args) == 2 and isinstance(value, dict):
        for k, v in value.items():
            found = _find_bool(args[1], v, f"{at}.{k}")
            if found is not None:
                return found
    return None


def _bool_refuser(annotation: Any) -> BeforeValidator:
    """A validator refusing true/false wherever ``annotation`` expects a number."""

    def _refuse_bool_items(v: Any) -> Any:
        found = _find_bool(annotation, v)
        if found is None:
            return v
        at, b = found
        problem = f"must be a number, not {str(b).lower()}"
        # an item is named by its index under the field ("world.arena.lower[0]")
        raise ConfigError(at, problem) if at else ValueError(problem)

    _refuse_bool_items.refuses_bools = True  # type: ignore[attr-defined]
    return BeforeValidator(_refuse_bool_items)


class Params(BaseModel):
    """Frozen, validated parameter set of a component.

    Numeric fields (``int``, ``float``, optionally ``None``, and lists and tuples of them)
    refuse ``true``/``false``: pydantic would read them as 1 and 0, so ``n_particles: true``
    would silently run one particle.
    """

    model_config = ConfigDict(
        frozen=True, extra="forbid", arbitrary_types_allowed=True, defer_build=True
    )

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        changed = merge_partial_components(cls)
        refuse_bools_as_numbers(cls, changed)


class Configured:
    """Base of a part configured by a :class:`Params` model (a reward, a stopping rule, ...):
    the class names its model as ``Params`` and keeps its parameters in ``params`` (the model's
    defaults when the constructor gets ``None``)."""

    params: Params
    Params: ClassVar[type[Params]]

    def __init__(self, params: Params | None = None) -> None:
        self.params = params if params is not None else type(self).Params()


def refuse_bools_as_numbers(cls: type[BaseModel], changed: bool = False) -> None:
    """Make the numeric fields of the model ``cls`` refuse ``true``/``false`` (call it from
    ``__pydantic_init_subclass__``; :class:`Params` does). ``changed``: the caller changed the
    fields already (the schema must be made again)."""
    for f in cls.model_fields.values():
        if _holds_numbers(f.annotation) and not any(_is_guard(m) for m in f.metadata):
            f.metadata.append(_bool_refuser(f.annotation))
            changed = True
    # with ``defer_build`` the schema is made at first use, from the fields as changed here
    if changed and cls.__pydantic_complete__:
        cls.model_rebuild(force=True)


def merge_dicts(default: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """``given`` laid over ``default``: a nested dict without a ``type`` merges into the
    default's dict of the same key; any other value (a dict naming a ``type`` included)
    replaces it."""
    out = dict(default)
    for k, v in given.items():
        old = out.get(k)
        if isinstance(v, dict) and "type" not in v and isinstance(old, dict):
            out[k] = merge_dicts(old, v)
        else:
            out[k] = v
    return out


def _component_default(f: Any) -> dict[str, Any] | None:
    """The default of a component field (``type`` plus parameters) as a dict, else ``None``."""
    default = f.default_factory() if f.default_factory is not None else f.default
    if not isinstance(default, BaseModel) or "type" not in type(default).model_fields:
        return None
    return default.model_dump(mode="python")


def _merger(default: dict[str, Any]) -> BeforeValidator:
    def merge(v: Any) -> Any:
        if isinstance(v, dict) and "type" not in v:
            return merge_dicts(default, v)
        return v

    merge.merges_components = True  # type: ignore[attr-defined]
    return BeforeValidator(merge)


def _is_merger(meta: Any) -> bool:
    return bool(getattr(getattr(meta, "func", None), "merges_components", False))


def merge_partial_components(cls: type[BaseModel]) -> bool:
    """Let a component field of ``cls`` (a ``Ref``) be given without its ``type``: such a dict
    is laid over the field's default (:func:`merge_dicts`), so that
    ``estimator: {n_particles: 500}`` changes one setting of the default estimator and keeps
    the others. A dict naming a ``type`` replaces the default whole, as before. Returns
    whether a field was changed."""
    changed = False
    for f in cls.model_fields.values():
        if any(
            getattr(m, "func", None) is not None and getattr(m.func, "merges_components", False)
            for m in f.metadata
        ):
            continue  # inherited from a parent model that has it already
        default = _component_default(f)
        if default is not None:
            f.metadata.insert(0, _merger(default))
            changed = True
    return changed


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be finite")
    return v


def _positive(v: float) -> float:
    if not (math.isfinite(v) and v > 0):
        raise ValueError("must be a finite number > 0")
    return v


def _nonneg(v: float) -> float:
    if not (math.isfinite(v) and v >= 0):
        raise ValueError("must be a finite number >= 0")
    return v


def _finite_vec(v: tuple[float, ...]) -> tuple[float, ...]:
    if not all(math.isfinite(x) for x in v):
        raise ValueError("all components must be finite")
    return v


Finite = Annotated[float, AfterValidator(_finite)]
"""A finite float."""
Positive = Annotated[float, AfterValidator(_positive)]
"""A finite float > 0."""
NonNegative = Annotated[float, AfterValidator(_nonneg)]
"""A finite float >= 0."""


def no_bools(v: Any) -> Any:
    """Refuse true/false among a point's components (YAML would make them 1 and 0)."""
    if isinstance(v, list | tuple) and any(isinstance(x, bool) for x in v):
        raise ValueError("components must be numbers, not true/false")
    return v


Vector = Annotated[tuple[float, ...], BeforeValidator(no_bools), AfterValidator(_finite_vec)]


def _not_bool(v: Any) -> Any:
    if isinstance(v, bool):
        raise ValueError(f"must be an integer, got {str(v).lower()}")
    return v


Seed = Annotated[int, BeforeValidator(_not_bool), Field(ge=0, lt=2**63)]
"""A root seed: an integer in ``[0, 2**63)`` (``true``/``false`` refused, not read as 1/0)."""
"""A tuple of finite floats (a point or a vector; 2 or 3 components)."""
