"""Base class of all component parameters.

Parameters are immutable, validated pydantic models: unknown keys are rejected (a typo is an error,
not a silently ignored setting) and every value error names the field.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field


def _refuse_bool(v: Any) -> Any:
    if isinstance(v, bool):
        raise ValueError(f"must be a number, not {str(v).lower()}")
    return v


_NUMBER_NOT_BOOL = BeforeValidator(_refuse_bool)


def _is_number(annotation: Any) -> bool:
    """``int``, ``float`` or either ``| None``: a field where true/false would be read as 1/0."""
    if annotation in (int, float):
        return True
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return len(args) == 1 and args[0] in (int, float)
    return False


class Params(BaseModel):
    """Frozen, validated parameter set of a component.

    Numeric fields (``int``, ``float``, optionally ``None``) refuse ``true``/``false``: pydantic
    would read them as 1 and 0, so ``n_particles: true`` would silently run one particle.
    """

    model_config = ConfigDict(
        frozen=True, extra="forbid", arbitrary_types_allowed=True, defer_build=True
    )

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        refuse_bools_as_numbers(cls)


def refuse_bools_as_numbers(cls: type[BaseModel]) -> None:
    """Make the numeric fields of the model ``cls`` refuse ``true``/``false`` (call it from
    ``__pydantic_init_subclass__``; :class:`Params` does)."""
    changed = False
    for f in cls.model_fields.values():
        guarded = any(getattr(m, "func", None) in (_refuse_bool, _not_bool) for m in f.metadata)
        if _is_number(f.annotation) and not guarded:
            f.metadata.append(_NUMBER_NOT_BOOL)
            changed = True
    # with ``defer_build`` the schema is made at first use, from the fields as changed here
    if changed and cls.__pydantic_complete__:
        cls.model_rebuild(force=True)


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
