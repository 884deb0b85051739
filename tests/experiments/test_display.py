"""Units and formats of the metrics, and the documentation that lists them."""

from __future__ import annotations

from pathlib import Path

from odorloc.experiments.display import METRICS, format_metric

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
