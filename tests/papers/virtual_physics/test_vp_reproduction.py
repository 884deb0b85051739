"""The virtual-physics reproduction's machinery on a short run: one recorded flow replayed to
every rule and start, the extra columns, the tables and the figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.experiments.reproduction import get
from odorloc.experiments.store import ResultStore
from odorloc.experiments.sweep import expand_cells, load_sweep, run_sweep
from odorloc.papers.virtual_physics.analysis import calibrated_rate, steady_report
from odorloc.papers.virtual_physics.reproduction import (
    VARIANTS,
    WIDE_STARTS,
    VirtualPhysicsReproduction,
    vp_group,
)
from odorloc.scenarios import get_scenario

#: Chemotaxis at treble frequency, mean time per start as the paper quotes it (Sec. 3.1), s.
TREBLE = {"P1": 1040.0, "P2": 870.0, "P3": 1160.0, "P4": 920.0, "P5": 970.0, "P6": 1090.0}


def test_the_sweep_crosses_rules_frequencies_and_starts_on_shared_flows() -> None:
    r = get("virtual-physics")
    spec = load_sweep(r.sweep(2, 2024))
    cells = expand_cells(spec)
    assert len(cells) == 3 * 6 * len(VARIANTS)
    flows = {"vp[frequency=1]", "vp[frequency=2]", "vp[frequency=3]"}
    assert spec.replay and {c.flow_key for c in cells} == flows
    # every variant's label names its rule, and the rule is what it runs
    for c in cells:
        member = c.spec["searcher_params"]["member"]
        assert member["rule"] == c.spec["searcher_label"].split("-")[0]
    # the start study: the fast rules from ten more start pairs, on the same flows
    wide = expand_cells(load_sweep(r.sweeps(None, 2024)["starts"]))
    assert len(wide) == 3 * len(WIDE_STARTS) * 2
    assert {c.flow_key for c in wide} == flows
    sc = get_scenario("virtual-physics-two-groups")
    for name in WIDE_STARTS:
        a, b = (int(v) for v in name[1:].split("-"))
        assert [tuple(p) for p in sc.agents.start_sets[name]] == [(18.0, a), (18.0, b)]


def test_the_paper_reference_holds_each_cell_to_its_own_start_and_frequency() -> None:
    r = get("virtual-physics")
    cells = {c.cell_id: c for c in expand_cells(load_sweep(r.sweep(1, 0)))}
    refs = r.reference()
    assert set(refs) <= set(cells)
    assert {cells[k].spec["searcher_label"] for k in refs} == {"chemotaxis", "anemotaxis"}
    assert len(refs) == 2 * 3 * 6  # two rules with quoted numbers, every frequency and start
    for key, entry in refs.items():
        label = cells[key].spec["searcher_label"]
        start = cells[key].swept["scenario.start_set"]
        freq = cells[key].swept["scenario.frequency"]
        if label == "anemotaxis":
            assert entry["success_rate"] == (0.0 if start == "P4" else 1.0)  # Sec. 3.2
            assert "mean_time" not in entry  # its frequency is not stated
        else:
            assert entry["success_rate"] == 1.0
            if freq == 3:  # Sec. 3.1, treble frequency, per start
                assert entry["mean_time"] == TREBLE[start]
            else:
                assert "mean_time" not in entry  # only a mean pooled over the starts is quoted


@pytest.mark.parametrize(
    "bad", [True, False, np.bool_(True), "40", 0, 0.0, -5.0, math.nan, math.inf, -math.inf]
)
def test_a_time_limit_that_is_not_a_positive_number_of_seconds_is_refused(bad: object) -> None:
    with pytest.raises(ConfigError, match="number of seconds") as err:
        VirtualPhysicsReproduction(time_limit=bad)  # type: ignore[arg-type]
    assert err.value.field == "time_limit"


def test_a_valid_time_limit_shortens_every_cell() -> None:
    assert VirtualPhysicsReproduction().time_limit is None
    for ok in (40, 40.0, np.float32(40.0)):
        r = VirtualPhysicsReproduction(time_limit=ok)
        assert r.time_limit == 40.0
        cells = expand_cells(load_sweep(r.sweep(1, 0)))
        assert {c.spec["scenario_params"]["limits.time"] for c in cells} == {40.0}


def test_a_short_run_gives_rows_tables_and_figures(tmp_path) -> None:
    r = get("virtual-physics")
    spec = r.sweep(1, 7)
    spec["scenarios"][0]["params"] = {"limits.time": 40.0}
    spec["scenarios"][0]["grid"] = {"frequency": [3]}
    spec["scenarios"][0]["agent_grid"] = {"start_set": ["P1", "P3"]}
    spec["searchers"] = [s for s in spec["searchers"] if s["label"] in ("chemotaxis", "fluxotaxis")]
    store = tmp_path / "r.sqlite"
    df = run_sweep(spec, store, workers=1, progress=False, group_fn=vp_group)
    assert len(df) == 4 and (df["status"] == "ok").all()
    assert (df["group_size"] == 4).all()  # one flow for both rules and both starts
    assert df["movie_wall_time"].nunique() == 1
    for col in ("same_source", "reached_both", "closest_A_0", "source_A", "dwell_B"):
        assert col in df
    assert np.isfinite(df["closest_A_0"]).all()
    r.map_seconds = 2.0  # a short flux map: the machinery, not the numbers
    tables = r.tables(df, 7)
    names = ["rules", "starts_success", "starts_time", "variants", "approach"]
    assert [t.name for t in tables] == [*names, "declaration_geometry", "plume_check"]
    with ResultStore(store, readonly=True) as st:
        assert st.arrays(str(df.cell_id.iloc[0]), 0) is not None  # treble episode 0 is kept
        figs = r.figures(df, st, tmp_path, 7)
        names = {f.name for f in figs}
        assert {"paths_chemotaxis.png", "search_time_fluxotaxis.png", "episode.gif"} <= names
        assert {"flux_map.png", "plume_check.png"} <= names
        for f in figs:
            if f.name in (
                "paths_fluxotaxis.png",
                "search_time_chemotaxis.png",
                "flux_map.png",
                "plume_check.png",
                "variants.png",
            ):
                f.draw(tmp_path / f.name)
                assert (tmp_path / f.name).stat().st_size > 10_000


def test_the_release_rate_is_calibrated_to_the_paper_thresholds() -> None:
    sc = get_scenario("virtual-physics-two-groups")
    rate = sc.world.sources[0].rate
    # the scenario's rate is the calibration's (two significant digits)
    assert abs(rate / calibrated_rate(sc) - 1.0) < 0.02
    rep = steady_report(sc)
    for i in (0, 1):
        assert 4.5 < rep[f"flux_{i}"] / rep["phi_T"] < 5.5  # the criterion
        assert 2.0 < rep[f"peak_{i}"] / rep["rho_T"] < 20.0  # concentrations of order rho_T
    assert rep["flux_downwind_max"] < 0.0  # no emitter-like outflow inside the plume
    assert rep["core_start"] > rep["rho_T"]  # the plume core at the start line is detectable


def test_the_paper_package_imports_no_matplotlib() -> None:
    """pyplot is imported only by the functions that draw (issue 28): loading the package, as
    the registry's discovery does, leaves matplotlib alone."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "import odorloc.papers.virtual_physics.reproduction\n"
        "import odorloc.papers.virtual_physics.figures, odorloc.papers.virtual_physics.analysis\n"
        "import odorloc.viz.formations\n"
        "import odorloc.viz.fields, odorloc.viz.sweeps, odorloc.experiments.groups\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
