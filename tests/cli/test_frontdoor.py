"""The commands a new user meets first: ``--version``, ``components NAME``,
``scenarios NAME --resolved``, the scenario list at 80 columns, help texts without markup."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import odorloc
from odorloc.cli import app
from odorloc.core import registry
from odorloc.scenarios import builtin_names, get_scenario
from odorloc.scenarios.config import COMPONENTS
from odorloc.scenarios.loading import resolve_components

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ["run", "scenarios", "components", "batch", "report", "reproduce", "replay-log"]


def test_version_is_the_package_version_and_pyproject_agrees() -> None:
    r = runner.invoke(app, ["--version"])
    assert r.exit_code == 0 and r.stdout.strip() == f"odorloc {odorloc.__version__}"
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["version"] == odorloc.__version__
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert str(cff["version"]) == odorloc.__version__ and cff["license"] == "MIT"
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")


@pytest.mark.parametrize("cmd", [[], *([c] for c in COMMANDS)])
def test_help_texts_carry_no_raw_markup(cmd: list[str]) -> None:
    r = runner.invoke(app, [*cmd, "--help"], env={"COLUMNS": "80"})
    assert r.exit_code == 0, r.output
    for raw in ("``", ":class:", ":func:", ":meth:", "\\["):
        assert raw not in r.stdout, f"{' '.join(cmd)} --help shows {raw!r}"


def test_scenarios_at_80_columns_never_cut_a_name() -> None:
    r = runner.invoke(app, ["scenarios"], env={"COLUMNS": "80"})
    assert r.exit_code == 0
    lines = r.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines), max(lines, key=len)
    firsts = {line.split()[0] for line in lines if line and not line.startswith(" ")}
    assert set(builtin_names()) <= firsts
    assert "…" not in r.stdout


def test_components_describes_every_parameter() -> None:
    r = runner.invoke(app, ["components", "pf-entropy"], env={"COLUMNS": "80"})
    assert r.exit_code == 0, r.output
    fields = registry.entry("searcher", "pf-entropy").params.model_fields
    for name in fields:
        assert re.search(rf"^  {name} : ", r.stdout, re.M), name
    assert "step_length : float or None = null  [metres]" in r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines())
    # a part the searcher names is described on its own, with its units
    r = runner.invoke(app, ["components", "pang-farrell"], env={"COLUMNS": "80"})
    assert "sensor_area : float = 0.01  [m^2]" in r.stdout
    # a name of two families shows both; an unknown one is one line, exit 2
    r = runner.invoke(app, ["components", "vergassola"])
    assert "vergassola  (plume)" in r.stdout and "vergassola  (model)" in r.stdout
    r = runner.invoke(app, ["components", "vergassola", "--family", "model"])
    assert "(plume)" not in r.stdout
    r = runner.invoke(app, ["components", "pf-entrop"])
    assert r.exit_code == 2 and r.stderr.startswith("error: name: ") and "pf-entropy" in r.stderr


def test_components_lists_every_member_uncut() -> None:
    r = runner.invoke(app, ["components"], env={"COLUMNS": "80"})
    assert r.exit_code == 0
    for fam in registry.families():
        for name in registry.names(fam):
            assert re.search(rf"^  {re.escape(name)}\s", r.stdout, re.M), name


def _ref_at(sc, path: str) -> registry.ComponentRef | None:
    node = sc.to_dict()
    for k in path.split("."):
        node = node.get(k) if isinstance(node, dict) else None
    return None if node is None else registry.ComponentRef(**node)


def _validated(family: str, ref: registry.ComponentRef) -> dict:
    """The component's validated parameters, sub-components validated in turn (so that
    ``{type: roulette}`` and ``roulette`` with its defaults written out compare equal)."""
    params = ref.params(family)
    out = {}
    for name, info in type(params).model_fields.items():
        value, fam = getattr(params, name), registry.ref_family(info)
        if fam is not None and isinstance(value, registry.ComponentRef):
            out[name] = _validated(fam, value)
        elif fam is not None and isinstance(value, list | tuple):
            out[name] = [_validated(fam, v) for v in value]
        else:
            out[name] = value
    return {"type": ref.type, **out}


@pytest.mark.parametrize("name", builtin_names())
def test_resolved_scenarios_hold_the_same_parameters(name: str) -> None:
    sc = get_scenario(name)
    full = resolve_components(sc)
    assert resolve_components(full).to_yaml() == full.to_yaml()  # nothing left to fill in
    for path, family in COMPONENTS.items():
        a, b = _ref_at(sc, path), _ref_at(full, path)
        if a is None:
            assert b is None
            continue
        assert _validated(family, a) == _validated(family, b), path
        fields = registry.entry(family, a.type).params.model_fields
        assert set(b.values) == {k for k, f in fields.items() if not f.exclude}, path


def test_running_the_resolved_output_gives_the_same_episode(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["scenarios", "lattice-isotropic-2d", "--resolved"])
    assert r.exit_code == 0, r.output
    Path("full.yaml").write_text(r.stdout)
    assert "n_classes" in r.stdout  # a searcher parameter the plain print leaves out
    for ref, out in (("lattice-isotropic-2d", "a"), ("full.yaml", "b")):
        r = runner.invoke(app, ["run", ref, "--episode", "1", "--out", out, "--no-animation"])
        assert r.exit_code == 0, r.output
    with np.load("a/recording.npz") as a, np.load("b/recording.npz") as b:
        np.testing.assert_array_equal(a["positions"], b["positions"])
        np.testing.assert_array_equal(a["gas"], b["gas"])
    r = runner.invoke(app, ["scenarios", "--resolved"])
    assert r.exit_code == 2 and r.stderr.startswith("error: --resolved: ")


def test_every_reproduction_cites_its_papers_in_full() -> None:
    from odorloc.experiments import reproduction as rp

    r = runner.invoke(app, ["reproduce", "--list"], env={"COLUMNS": "200"})
    assert r.exit_code == 0
    listed = " ".join(r.stdout.split())
    for name in rp.names_of_reproductions():
        repro = rp.get(name)
        assert repro.citations, name
        for c in repro.citations:
            assert c.title and (c.doi or c.note), f"{name}: say what is missing"
            assert c.doi == "" or c.doi.startswith("10."), c.doi
            assert f'"{c.title}"' in listed, c.title
        assert repro.reference_text().startswith("Paper")
