"""Units and formats of the metrics, and the documentation that lists them."""

from __future__ import annotations

from pathlib import Path

from odorloc.experiments.display import METRICS, agent_table, format_metric

DOC = Path(__file__).resolve().parents[2] / "docs" / "outputs.md"


def test_the_outputs_page_lists_every_metric_with_its_unit() -> None:
    rows = {
        line.split("|")[1].strip().strip("`"): line.split("|")[2].strip()
        for line in DOC.read_text().splitlines()
        if line.startswith("| `")
    }
    for name, fm in METRICS.items():
        assert rows.get(name) == (fm.unit or "–"), name


def test_no_metric_is_ever_shown_in_scientific_notation() -> None:
    for name in METRICS:
        for v in (1e-9, 0.5, 1234.5, 9.87e12, -3.2e7):
            assert "e" not in format_metric(name, v).lower().replace("-", ""), (name, v)


def test_per_agent_values_are_a_column_per_agent_or_their_range() -> None:
    few = {0: {"cues": 3, "declaration_time": 12.34}, 1: {"cues": 5}}
    headers, rows = agent_table(few)
    assert headers == ["metric", "agent 0", "agent 1"]
    assert rows == [["cues", "3", "5"], ["declaration_time (s)", "12.3", "-"]]
    many = {a: {"declaration_time": float(a)} for a in range(10)}
    many[9]["declaration_time"] = float("nan")
    headers, rows = agent_table(many, max_columns=6)
    assert headers == ["metric", "agents", "min", "mean", "max"]
    assert rows == [["declaration_time (s)", "9", "0.0", "4.0", "8.0"]]
    assert agent_table({}) == ([], [])
