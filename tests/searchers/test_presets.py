"""Presets: searcher names bound to parameter sets of a recipe (the infotaxis family)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from odorloc.cli import app
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import run_episode
from odorloc.scenarios import get_scenario
from odorloc.searchers.infotaxis import InfotaxisSearcher
from odorloc.searchers.preset import BUILTIN, load_presets

FAMILY = {
    "entrotaxis": "predictive-entropy",
    "space-aware-infotaxis": "space-aware",
    "greedy": "greedy",
    "mean-distance": "mean-distance",
}


@pytest.mark.parametrize(("name", "reward"), FAMILY.items())
def test_the_family_are_presets_of_infotaxis(name: str, reward: str) -> None:
    assert name in BUILTIN
    e = registry.entry("searcher", name)
    assert e.build is InfotaxisSearcher and "(preset of infotaxis)" in e.summary
    p = registry.make_params("searcher", name, {})
    assert p.planner.type == "lattice" and p.planner.values["reward"] == {"type": reward}
    # a setting given for the preset keeps its other settings
    q = registry.make_params("searcher", name, {"planner": {"selection": {"ties": "random"}}})
    assert q.planner.values["reward"] == {"type": reward}
    assert q.planner.values["selection"] == {"ties": "random"}


def test_a_preset_runs_as_its_written_out_form() -> None:
    sc = get_scenario("lattice-isotropic-2d").with_overrides({"limits.time": 40.0})
    written = {"type": "infotaxis", "planner": {"reward": {"type": "predictive-entropy"}}}
    model = sc.searcher.values["model"]
    runs = [
        run_episode(
            sc.with_overrides({"searcher": {**spec, "model": model}}),
            *episode_seeds(4, "preset", 0),
            record=True,
        )
        for spec in ({"type": "entrotaxis"}, written)
    ]
    a, b = (r.recording for r in runs)
    assert a is not None and b is not None
    np.testing.assert_array_equal(a.positions, b.positions)
    assert runs[0].metrics["steps"] == runs[1].metrics["steps"]
    assert runs[0].metrics["termination"] == runs[1].metrics["termination"]


def test_components_lists_the_presets() -> None:
    out = CliRunner().invoke(app, ["components"], env={"COLUMNS": "200"})
    assert out.exit_code == 0
    for name in FAMILY:
        assert name in out.output
    assert "preset of infotaxis" in out.output


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("name: p1\nbase: infotaxis\nextra: 1\n", "preset p1.yaml"),
        ("name: p2\nparams: {}\n", "preset p2.yaml"),
        ("name: p3\nbase: nothing\n", "preset p3.base"),
        ("name: p4\nbase: infotaxis\nparams: [1, 2]\n", "preset p4.params"),
        (
            "name: p5\nbase: infotaxis\nparams: {planner: {reward: {type: nope}}}\n",
            "preset p5.planner.reward.type",
        ),
    ],
)
def test_bad_preset_files_are_refused(tmp_path: Path, text: str, field: str) -> None:
    stem = field.split()[1].split(".")[0]
    (tmp_path / f"{stem}.yaml").write_text(text)
    with pytest.raises(ConfigError) as ei:
        load_presets(tmp_path)
    assert ei.value.field == field
    assert stem not in registry.names("searcher")
