"""Every reproduction survives any stored data and completes end to end.

- Degenerate stores (one episode, no success, every episode an error, successes without a
  time, intervals that exclude their point): tables, figures and the report are still written,
  and no figure fails.
- The cheapest real run of every reproduction (``--episodes 1``) writes every figure, its
  tables and a report that embeds them.
"""

from __future__ import annotations

import re
from html import escape as html_escape
from pathlib import Path

import numpy as np
import pytest

from helpers import fake_run_sweep
from odorloc.experiments import reproduction as rp

NAMES = rp.names_of_reproductions()


@pytest.mark.parametrize("kind", ["one-each", "no-success", "all-errors", "nan-times"])
@pytest.mark.parametrize("name", NAMES)
def test_reproduction_survives_degenerate_results(name, kind, tmp_path, monkeypatch) -> None:
    import odorloc.experiments.sweep as sweep_mod

    monkeypatch.setattr(sweep_mod, "run_sweep", fake_run_sweep(kind))
    r = rp.get(name)
    if name == "indoor-pf-entropy":
        # the particle snapshots run a stored episode again (covered by the real run below and
        # tests/test_indoor.py); here every figure drawn from the stored rows must survive them
        import odorloc.papers.indoor_pf_entropy.reproduction as ind

        monkeypatch.setattr(ind, "episode_figures", lambda df, store, path: _blank(path))
    if name == "muc-osl":
        # Fig. 3 and its animation run a new episode whatever is stored (covered by the real run)
        import odorloc.papers.muc_osl.reproduction as muc

        monkeypatch.setattr(muc, "_fig3", lambda seed, path, time_limit=None: _blank(path))
        monkeypatch.setattr(muc, "_mechanism", lambda seed, path, n, time_limit=None: _blank(path))
    if hasattr(r, "map_seconds"):
        # the flux maps and the plume check read no stored row (their numbers:
        # tests/papers/virtual_physics/); a short map still draws every table and figure
        r.map_seconds = MAP_SECONDS
    out = r.run(tmp_path, episodes=1, workers=1, seed=3, progress=False)
    assert out.failed_figures == [], out.failed_figures
    assert out.report is not None and out.report.is_file()
    assert out.tables, "no tables"
    html = out.report.read_text()
    assert "could not be drawn" not in html, re.findall(r"could not be drawn[^<]*", html)
    for fig in out.figures:
        assert fig.is_file() and fig.stat().st_size > 0


def _blank(path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    fig.savefig(path)
    plt.close(fig)


def test_console_tables_fit_100_columns(tmp_path) -> None:
    """The compact console tables of every reproduction render within 100 columns, cut no
    cell short, and fold none but the long texts of tables that ask for wrapping (the
    statements with their intervals)."""
    import io

    from rich.console import Console

    for name in NAMES:
        r = rp.get(name)
        import pandas as pd

        fake = fake_run_sweep("one-each")
        parts = []
        for sweep, spec in r.sweeps(1, 1).items():
            part = fake(spec, tmp_path / f"{name}-{sweep}.sqlite")
            parts.append(part.assign(sweep=sweep))
        df = pd.concat(parts, ignore_index=True)
        for tab in r.tables(df, 1):
            if not tab.console:
                continue
            c = Console(width=rp.CONSOLE_WIDTH, record=True, file=io.StringIO())
            c.print(rp.console_table(tab))
            lines = [ln for ln in c.export_text().splitlines() if ln.strip()]
            # title (up to two lines), the header (folded at its words, as tall as its
            # tallest), one line per row; the rule is not counted
            body = [ln for ln in lines if "─" not in ln]
            shown = rp.console_headers(tab.headers, tab.rows, tab.left)
            header = max(h.count("\n") + 1 for h in shown)
            if not tab.widths:
                assert len(body) <= len(tab.rows) + 2 + header, (name, tab.name, lines)
            assert max(len(ln.rstrip()) for ln in lines) <= rp.CONSOLE_WIDTH
            assert "…" not in c.export_text(), (name, tab.name, lines)


@pytest.mark.parametrize("name", NAMES)
def test_default_sweeps_pass_the_sweep_check(name) -> None:
    """The full default run loads: every cell of every sweep passes the checks a sweep runs
    before its first episode (e.g. a scenario that ends on a declaration refuses a searcher
    that never declares)."""
    from odorloc.experiments.sweep import SweepSpec, iter_cells
    from odorloc.experiments.sweep_check import check_sweep

    for key, raw in rp.get(name).sweeps(None, 1).items():
        spec = SweepSpec.model_validate(raw)
        assert check_sweep(spec, iter_cells(spec)) >= 1, key


def test_gas_map_mission_ends_at_the_first_declaration() -> None:
    from types import SimpleNamespace

    from odorloc.papers.gas_maps.reproduction import mission_end

    events = [
        {"t": 3.0, "kind": "first_detection"},
        {"t": 41.5, "kind": "declaration"},
        {"t": 42.0, "kind": "declaration"},
        {"t": 300.0, "kind": "end"},
    ]
    assert mission_end(SimpleNamespace(meta={"events": events})) == 41.5
    assert mission_end(SimpleNamespace(meta={"events": events[:1] + events[-1:]})) is None
    assert mission_end(SimpleNamespace(meta={})) is None


#: Shorter episodes (s) for the reproductions whose single episode per cell would take minutes
#: (144 virtual-physics cells of 20 simulated minutes; every MUC-OSL sweep point in two worlds;
#: D-S mapping flights of up to 5 000 s; 36 single-agent episodes of 10-20 minutes): the path
#: from sweep to report is the same, and the searchers themselves are tested on their own
#: (tests/searchers/, tests/papers/<paper>/; the gas maps in tests/inference/test_gas_maps.py);
#: the source-term reproduction's D-S flights are cut the same way.
QUICK = {
    "virtual-physics": 40.0,
    "muc-osl": 300.0,
    "ds-multi-source": 600.0,
    "single-agent": 60.0,
    "gas-maps": 30.0,
    "source-terms": 300.0,
}


#: Sweep points kept in these tests where a reproduction takes them (``values``): two per MUC-OSL
#: sweep (lines and slopes still have two points) instead of all 29, in both worlds.
QUICK_VALUES = {
    "muc-osl": {
        "area": [(60.0, 60.0, 30.0), (100.0, 60.0, 30.0)],
        "uavs": [1, 3],
        "radius": [0.0, 10.0],
        "particles": [20, 100],
    }
}


#: Simulated seconds (s) of the flux maps of the reproductions that draw them, in these tests.
MAP_SECONDS = 2.0


def _quick(r, seconds: float):
    """``r`` with every episode cut at ``seconds``: through its own ``time_limit`` where it has
    one, else as an override of every scenario of its sweeps; its sweeps cut to
    :data:`QUICK_VALUES` where it takes ``values``."""
    import inspect

    params = inspect.signature(type(r)).parameters
    if "time_limit" in params:
        extra = (
            {"values": QUICK_VALUES[r.name]}
            if "values" in params and r.name in QUICK_VALUES
            else {}
        )
        quick = type(r)(time_limit=seconds, **extra)
        if hasattr(quick, "map_seconds"):
            quick.map_seconds = MAP_SECONDS
        return quick
    sweeps = r.sweeps

    def short(episodes, seed):
        out = sweeps(episodes, seed)
        for spec in out.values():
            for sc in spec["scenarios"]:
                sc["params"] = {**sc.get("params", {}), "limits.time": seconds}
        return out

    r.sweeps = short
    return r


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_every_reproduction_completes_with_one_episode(name, tmp_path, monkeypatch) -> None:
    """``odorloc reproduce NAME --episodes 1 --seed 1``: every figure, every table and a report
    that embeds the figures and the tables' titles."""
    if name == "muc-osl":
        # its mechanism figure from 2 episodes per variant (not 12) and Fig. 3's animation in
        # 4 frames (not 80): drawn the same way, at a fraction of the cost
        import functools

        import odorloc.papers.muc_osl.reproduction as muc
        import odorloc.viz.team3d as team3d

        monkeypatch.setattr(muc, "MECHANISM_EPISODES", 2)
        animate = functools.partial(team3d.animate_team_3d, max_frames=4)
        monkeypatch.setattr(team3d, "animate_team_3d", animate)
    if name == "virtual-physics":
        # its episode animation in 4 frames (not 120): drawn the same way (tests/viz/)
        import functools

        import odorloc.papers.virtual_physics.figures as vf

        monkeypatch.setattr(
            vf, "animate_groups", functools.partial(vf.animate_groups, max_frames=4)
        )
    r = rp.get(name)
    if name in QUICK:
        r = _quick(r, QUICK[name])
    out = r.run(tmp_path, episodes=1, workers=2, seed=1, progress=False)
    assert out.failed_figures == []
    assert out.figures and all(p.is_file() for p in out.figures)
    assert out.report is not None
    html = out.report.read_text()
    assert html.count("data:image/png;base64,") >= len(out.figures)
    for tab in out.tables:
        assert (tmp_path / f"{tab.name}.csv").is_file()
        assert html_escape(tab.title.split(" (")[0]) in html
    df = out.results
    assert len(df) and (df["status"] == "ok").all()
    if r.success_column != "success":
        col = df[r.success_column].astype("boolean").fillna(False)
        summary = next(t for t in out.tables if t.console)
        # the console counts what the report counts: in all, or per searcher on its own row
        text = " ".join(" ".join(row) for row in summary.rows)
        per_searcher = "searcher" in df and all(
            any(
                row[0].strip() == lab
                and f"{int(col[df.searcher == lab].sum())}/{int((df.searcher == lab).sum())}" in row
                for row in summary.rows
            )
            for lab in df.searcher.unique()
        )
        assert f"{int(col.sum())}/" in text or per_searcher or np.isnan(col.mean())
