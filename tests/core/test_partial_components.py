"""A component field given without its ``type`` changes some settings of its default."""

from __future__ import annotations

import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, merge_dicts
from odorloc.core.registry import ComponentRef, Ref, make_params


def test_merge_dicts_rules() -> None:
    default = {"type": "a", "x": 1, "part": {"type": "p", "y": 2, "z": 3}}
    # a dict without a type merges, at every depth
    assert merge_dicts(default, {"part": {"y": 5}}) == {
        "type": "a",
        "x": 1,
        "part": {"type": "p", "y": 5, "z": 3},
    }
    # a dict naming a type replaces the part, a value replaces a value
    assert merge_dicts(default, {"part": {"type": "q"}, "x": 2})["part"] == {"type": "q"}
    assert merge_dicts(default, {"x": 2})["x"] == 2
    assert default["part"]["y"] == 2  # the default is left alone


class _Holder(Params):
    resampler: Ref("resampler") = ComponentRef(type="roulette", max_children=3)


def test_a_component_field_merges_a_dict_without_type() -> None:
    h = _Holder.model_validate({"resampler": {"child_variance": 0.1}})
    assert h.resampler.type == "roulette"
    assert h.resampler.values == {"max_children": 3, "child_variance": 0.1}
    # naming the type replaces the default whole, as before
    h = _Holder.model_validate({"resampler": {"type": "roulette"}})
    assert h.resampler.values == {}
    # the merged parameters are checked against the component, naming the field
    with pytest.raises(ConfigError) as ei:
        make_params("searcher", "pf-entropy", {"estimator": {"resampler": {"max_children": 0}}})
    assert ei.value.field == "estimator.resampler.max_children"
    with pytest.raises(ConfigError) as ei:
        make_params("searcher", "pf-entropy", {"estimator": {"n_particles": True}})
    assert ei.value.field == "estimator.n_particles"
