"""Component documentation read from the registry: every parameter of every component has a
type, a default and a doc line; units come from the numpydoc ``name : type, unit`` lines."""

from __future__ import annotations

import pytest

from odorloc.core import describe, registry
from odorloc.core.errors import ConfigError
from odorloc.core.params import Params

FAMILIES = registry.families()


@pytest.mark.parametrize("family", FAMILIES)
def test_every_parameter_of_every_component_is_documented(family: str) -> None:
    for name in registry.names(family):
        doc = describe.describe(family, name)
        assert doc.description or doc.summary, f"{family}/{name}: no description"
        for p in doc.params:
            where = f"{family}/{name}.{p.name}"
            assert p.doc, f"{where}: no doc line in the parameter model's docstring"
            assert p.type and p.default, where
            for text in (p.doc, p.type, p.unit, doc.description):
                assert "``" not in text and ":class:`" not in text, where


def test_units_types_and_defaults_of_known_components() -> None:
    def params(family: str, name: str) -> dict:
        by = {p.name: p for p in describe.describe(family, name).params}
        assert len(by) == len(registry.entry(family, name).params.model_fields)
        return by

    model = params("model", "pang-farrell")
    assert model["sensor_area"].unit == "m^2"
    assert model["min_wind_variance"].unit == "m^2/s^2"
    stopping = params("stopping_rule", "dual-convergence")
    assert stopping["r_err"].unit == "metres"
    assert stopping["variance"].type == '{"trace", "radius", "max_axis"}'
    pf = params("estimator", "particle-filter")
    assert pf["n_particles"].type == "int >= 2, <= 10000000"
    assert pf["n_particles"].default == "1000"
    assert pf["resampler"].type == "component (resampler)"
    assert pf["resampler"].default == "{type: roulette}"
    searcher = params("searcher", "pf-entropy")
    assert searcher["step_length"].type == "float or None"
    assert searcher["step_length"].default == "null"
    assert searcher["step_length"].unit == "metres"
    # a nested component's default with its settings
    assert searcher["model"].default.startswith("{type: pang-farrell, sensor_area: 0.1")
    assert model["sensor_area"].summary.endswith("(eq. 10).")  # not cut at the abbreviation


def test_docstring_entries_read_units_and_skip_other_sections() -> None:
    doc = """Summary line.

    Parameters
    ----------
    a, b : float, m/s
        Two speeds.
    c : {"x", "y, z"}, optional
        A choice whose values hold commas.
    d : tuple of float, metres, optional
        A point,
        on two lines.

    Returns
    -------
    e : float
        Not a parameter.
    """
    got = describe.docstring_entries(doc)
    assert got["a"] == got["b"] == ("float", "m/s", "Two speeds.")
    assert got["c"][:2] == ('{"x", "y, z"}', "")
    assert got["d"] == ("tuple of float", "metres", "A point, on two lines.")
    assert "e" not in got


def test_inherited_parameters_keep_their_docs() -> None:
    class Base(Params):
        """Base.

        Attributes
        ----------
        x : float, s
            Inherited.
        """

        x: float = 1.0

    class Child(Base):
        """Child."""

        y: int = 2

    got = describe.class_entries(Child)
    assert got["x"] == ("float", "s", "Inherited.")


def test_markup_is_turned_into_plain_text_and_markdown() -> None:
    text = "see :class:`~odorloc.a.B` and :func:`odorloc.c.d`, ``x = 1``"
    assert describe.plain(text) == "see B and odorloc.c.d, x = 1"
    assert describe.markdown(text) == "see `B` and `odorloc.c.d`, `x = 1`"


def test_a_name_of_several_families_is_found_in_each() -> None:
    assert set(describe.find("vergassola")) == {("plume", "vergassola"), ("model", "vergassola")}
    with pytest.raises(ConfigError) as err:
        describe.find("pf-entrop")
    assert err.value.field == "name" and "pf-entropy" in err.value.problem


def test_markdown_table_has_a_row_per_parameter() -> None:
    doc = describe.describe("plume", "filament")
    md = describe.render_markdown(doc)
    rows = [line for line in md.splitlines() if line.startswith("| `")]
    assert len(rows) == len(doc.params)
    assert all(line.count(" | ") == 4 for line in rows)
