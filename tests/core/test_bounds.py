"""Every count and size has a documented range: no integer setting of any registered component,
of a scenario or of a sweep is unbounded above (a typo such as ``n_particles: 1e11`` must be
refused, not allocated)."""

from __future__ import annotations

import typing

import annotated_types
import pytest
from pydantic import BaseModel

from odorloc.core import registry
from odorloc.experiments.sweep import SweepSpec
from odorloc.scenarios.config import Scenario

#: Integer lists that hold indices, checked against their context instead of a fixed bound.
INDEX_LISTS = {"Scenario.agents.groups.agents", "SweepSpec.keep_episodes"}


def _has_int(ann: typing.Any) -> bool:
    if ann is int:
        return True
    return any(_has_int(a) for a in typing.get_args(ann) if a is not type(None))


def _unbounded(model: type[BaseModel], prefix: str, seen: set[type]) -> list[str]:
    if model in seen:
        return []
    seen.add(model)
    out = []
    for name, f in model.model_fields.items():
        ann = f.annotation
        where = f"{prefix}.{name}"
        upper = [m for m in f.metadata if isinstance(m, annotated_types.Le | annotated_types.Lt)]
        if _has_int(ann) and not upper and ann is not bool and where not in INDEX_LISTS:
            validators = getattr(model, "__pydantic_decorators__", None)
            checked = validators is not None and any(
                name in d.info.fields for d in validators.field_validators.values()
            )
            if not checked:
                out.append(where)
        for a in (ann, *typing.get_args(ann)):
            if isinstance(a, type) and issubclass(a, BaseModel):
                out += _unbounded(a, where, seen)
    return out


def _models() -> list[tuple[str, type[BaseModel]]]:
    out: list[tuple[str, type[BaseModel]]] = [("Scenario", Scenario), ("SweepSpec", SweepSpec)]
    for fam in registry.families():
        out += [(f"{fam}/{e.name}", e.params) for e in registry.entries(fam)]
    return out


@pytest.mark.parametrize(("name", "model"), _models(), ids=[n for n, _ in _models()])
def test_every_integer_setting_has_an_upper_bound(name: str, model: type[BaseModel]) -> None:
    assert _unbounded(model, name, set()) == []


@pytest.mark.parametrize(
    ("family", "name", "values", "field"),
    [
        ("searcher", "pf-entropy", {"estimator": {"n_particles": 1e11}}, "estimator.n_particles"),
        ("plume", "filament", {"max_filaments": 10**12}, "max_filaments"),
        ("wind", "farrell", {"nodes": [10**6, 15]}, "nodes"),
        ("searcher", "ds-rectangular-wave", {"rounds": 10**9}, "rounds"),
    ],
)
def test_huge_counts_are_refused(family: str, name: str, values: dict, field: str) -> None:
    from odorloc.core.errors import ConfigError

    with pytest.raises(ConfigError) as ei:
        registry.make_params(family, name, values)
    assert ei.value.field == field
