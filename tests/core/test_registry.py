"""Discovery: a family's lookup imports what registers that family and nothing of a higher
layer; papers are found by the experiments layer; plugins and import paths keep working."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from odorloc.core import registry
from odorloc.core.errors import ConfigError


def _fresh(code: str, tmp_path: Path | None = None) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON object as its last line."""
    env = None
    if tmp_path is not None:
        import os

        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    r = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


#: One fresh interpreter answers every question about what a lookup imports, in this order.
_SCRIPT = """
import json, sys
from odorloc.core import registry

def loaded():
    return sorted(m for m in sys.modules if m == "odorloc" or m.startswith("odorloc."))

def heavy():
    return sorted(
        m for m in sys.modules
        if m.split(".")[0] in ("matplotlib", "pandas")
        or m.startswith(("odorloc.experiments", "odorloc.papers", "odorloc.viz"))
    )

out = {"plume": registry.names("plume"), "plume_mods": loaded(), "plume_heavy": heavy()}
from odorloc.scenarios import builtin_names, get_scenario
out["scenarios"] = builtin_names()
get_scenario("indoor-ventilated")
out["scenario_papers"] = [m for m in loaded() if m.startswith("odorloc.papers")]
out["lazy"] = {f: registry.names(f) for f in FAMILIES}
out["full"] = {f: registry.names(f) for f in registry.families()}
out["reproductions_in_core"] = registry.names("reproduction")
from odorloc.experiments import reproduction as rp
out["reproductions"] = rp.names_of_reproductions()
print(json.dumps(out))
"""

_FAMILIES = [
    "model",
    "wind",
    "source_draw",
    "gas_sensor",
    "anemometer",
    "platform",
    "resampler",
    "team_estimator",
    "step_planner",
    "searcher",
]


@pytest.fixture(scope="module")
def fresh() -> dict:
    return _fresh(_SCRIPT.replace("FAMILIES", repr(_FAMILIES)))


def test_a_plume_lookup_loads_the_plumes_and_nothing_above_them(fresh: dict) -> None:
    assert {"filament", "gaussian", "vergassola"} <= set(fresh["plume"])
    assert len(fresh["plume_mods"]) <= 40, fresh["plume_mods"]
    assert fresh["plume_heavy"] == []
    # nothing of the decision layers either: a plume needs no searcher
    mods = fresh["plume_mods"]
    assert not [m for m in mods if m.startswith(("odorloc.searchers", "odorloc.planning"))]


def test_builtin_scenarios_are_found_without_importing_a_paper(fresh: dict) -> None:
    names = set(fresh["scenarios"])
    assert {"indoor-ventilated", "two-sources-farrell", "lattice-isotropic-2d"} <= names
    assert fresh["scenario_papers"] == []


def test_every_family_member_is_found_by_a_family_lookup(fresh: dict) -> None:
    """What a family's lookup finds is what importing everything finds (the scan of the
    sources misses no member)."""
    lazy = {"plume": fresh["plume"], **fresh["lazy"]}
    for fam, names in fresh["full"].items():
        got = lazy.get(fam)
        if got is None:  # a family added since: looked up alone in its own process
            got = _fresh(
                f"import json\nfrom odorloc.core import registry\n"
                f"print(json.dumps({{'n': registry.names({fam!r})}}))"
            )["n"]
        assert got == names, fam


def test_the_papers_are_found_by_the_experiments_layer(fresh: dict) -> None:
    """The core never lists a reproduction; the experiments layer's lookup finds all of them."""
    assert fresh["reproductions_in_core"] == []
    assert {"indoor-pf-entropy", "ds-multi-source", "single-agent"} <= set(fresh["reproductions"])


def test_an_entry_point_plugin_is_discovered(tmp_path: Path) -> None:
    """A distribution declaring a module under ``odorloc.components`` has its members found."""
    (tmp_path / "myplume").mkdir()
    (tmp_path / "myplume" / "__init__.py").write_text("")
    (tmp_path / "myplume" / "flat.py").write_text(
        textwrap.dedent(
            """
            from odorloc.core.params import Params
            from odorloc.core.registry import register

            class FlatParams(Params):
                level: float = 1.0

            @register("plume", "flat-test-plugin", FlatParams)
            class Flat:
                def __init__(self, params, *args):
                    self.params = params
            """
        )
    )
    info = tmp_path / "myplume-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: myplume\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[odorloc.components]\nflat = myplume.flat\n")
    out = _fresh(
        """
        import json
        from odorloc.core import registry
        e = registry.entry("plume", "flat-test-plugin")
        print(json.dumps({"names": registry.names("plume"),
                          "level": registry.make_params("plume", e.name, {}).level}))
        """,
        tmp_path,
    )
    assert "flat-test-plugin" in out["names"] and "filament" in out["names"]
    assert out["level"] == 1.0


def test_an_import_path_names_a_class_directly() -> None:
    e = registry.entry("searcher", "odorloc.searchers.uav_team:MucOslTeam")
    assert e.params is registry.entry("searcher", "muc-osl").params
    with pytest.raises(ConfigError, match="not a searcher"):
        registry.entry("searcher", "odorloc.plume.source_draw:UniformSourceDraw")
    with pytest.raises(ConfigError, match="cannot import"):
        registry.entry("searcher", "odorloc.nosuch:Thing")


def test_an_unknown_name_lists_the_known_ones() -> None:
    with pytest.raises(ConfigError, match=r"unknown plume 'nosuch' \(known: eulerian, filament"):
        registry.entry("plume", "nosuch")
