"""The HTML report: self-contained, and rendered by a real headless browser."""

from __future__ import annotations

import io
import math
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from _stub_episode import stub_episode
from odorloc.core.errors import ConfigError
from odorloc.experiments.report import report_main, write_report
from odorloc.experiments.store import ResultStore
from odorloc.experiments.sweep import run_sweep

SPEC = {
    "name": "report-demo",
    "seed": 5,
    "episodes": 20,
    "keep_episodes": [0, 3],
    "scenarios": [{"name": "toy", "grid": {"scale": [1.0, 1.5]}}],
    "searchers": [
        {"name": "a", "params": {"skill": 0.8, "trajectory": True, "fail_on": [7]}},
        {"name": "b", "params": {"skill": 1.6, "trajectory": True}},
    ],
}


def _gif(arrays: dict, info: dict) -> bytes:
    """A tiny two-frame animation standing in for the package's episode renderer."""
    pos = np.asarray(arrays["positions"])
    frames = []
    for i in (len(pos) // 2, len(pos) - 1):
        im = Image.new("RGB", (120, 90), "white")
        px = im.load()
        for x, y in pos[: i + 1]:
            u, v = int(60 + 8 * x) % 120, int(45 + 8 * y) % 90
            px[u, v] = (200, 30, 30)
        frames.append(im)
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=200, loop=0)
    return buf.getvalue()


@pytest.fixture(scope="module")
def store_path(tmp_path_factory):
    p = tmp_path_factory.mktemp("rep") / "results.sqlite"
    run_sweep(SPEC, p, workers=1, episode_fn=stub_episode, progress=False)
    return p


def _write(store_path: Path, out: Path) -> str:
    with ResultStore(store_path, readonly=True) as st:
        write_report(
            st,
            out,
            reference={"b": {"success_rate": 0.9, "mean_time": 110.0, "source": "Table 1"}},
            episodes=[("toy[scale=1.0]/a", 0), ("toy[scale=1.5]/b", 3), ("toy[scale=1.0]/b", 99)],
            renderer=lambda arrays, info: (
                _gif(arrays, info) if info["cell_id"].endswith("/a") else None
            ),
        )
    return out.read_text()


def test_page_is_self_contained(store_path, tmp_path):
    page = _write(store_path, tmp_path / "r.html")
    # no network: every src is inline data, no external stylesheet or script
    assert not re.search(r"""(src|href)=["'](?!data:)""", page)
    assert "<link" not in page and "http://" not in page and "https://" not in page
    assert page.count("data:image/gif;base64,") == 1  # renderer used where it returned a GIF
    assert page.count("data:image/png;base64,") >= 4  # figures + a static trajectory
    assert "no trajectory stored" in page  # episode 99 does not exist
    for heading in (
        "Summary per cell",
        "Paired comparisons",
        "Comparison with the paper",
        "Figures",
        "Errors",
    ):
        assert heading in page
    assert "RuntimeError: stub failure in episode 7" in page
    assert "report-demo" in page


@pytest.fixture
def few_stills(monkeypatch):
    """A viewer of four episodes: the tests using it are not about the viewer, whose stills
    (one figure per kept episode) would dominate their time."""
    from odorloc.experiments import report

    monkeypatch.setattr(report, "MAX_VIEWER", 4)


def test_report_main_and_csv_input(store_path, tmp_path, few_stills):
    out = report_main(store_path, tmp_path / "m.html")
    assert out.read_text().count("<table>") >= 3
    with ResultStore(store_path, readonly=True) as st:
        csv = st.to_csv(tmp_path / "r.csv")
    page = write_report(csv, tmp_path / "c.html").read_text()
    assert "Summary per cell" in page and "Episode viewer" not in page
    with pytest.raises(ConfigError):
        report_main(tmp_path / "missing.sqlite", tmp_path / "x.html")


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1280,2000",
]


@pytest.mark.browser
def test_page_renders_in_headless_chromium(store_path, tmp_path):
    exe = _chromium()
    if exe is None:
        pytest.skip("chromium not installed (apt-get install -y chromium): browser check skipped")
    html_path = tmp_path / "report.html"
    _write(store_path, html_path)
    url = html_path.resolve().as_uri()
    with tempfile.TemporaryDirectory() as prof:
        dom = subprocess.run(
            [
                exe,
                *_FLAGS,
                f"--user-data-dir={prof}",
                "--virtual-time-budget=5000",
                "--dump-dom",
                url,
            ],
            capture_output=True,
            text=True,
            timeout=90,
            check=True,
        ).stdout
    m = re.search(
        r'data-rendered="images=(\d+)/(\d+) tables=(\d+) episodes=(\d+) sections=([\w,-]*)"',
        dom,
    )
    assert m, "the page's load script did not run"
    loaded, total, tables, episodes = map(int, m.groups()[:4])
    assert total >= 8 and loaded == total, f"only {loaded}/{total} images decoded"
    assert tables >= 6
    # every section has a visible heading, in the page's order
    sections = m.group(5).split(",")
    assert sections == [
        "settings", "summary", "paired", "paper", "figures", "viewer", "errors"
    ], sections  # fmt: skip
    # the picker offers every episode asked for and shows one at a time
    assert episodes == 3
    assert len(re.findall(r'class="episode" data-key="e\d" style="display: block;"', dom)) == 1
    assert len(re.findall(r'class="episode" data-key="e\d" style="display: none;"', dom)) == 2
    shot = tmp_path / "shot.png"
    with tempfile.TemporaryDirectory() as prof:
        subprocess.run(
            [exe, *_FLAGS, f"--user-data-dir={prof}", f"--screenshot={shot}", url],
            capture_output=True,
            timeout=90,
            check=True,
        )
    im = np.asarray(Image.open(shot).convert("L"), float)
    assert im.shape == (2000, 1280)
    # not blank: plenty of non-white pixels and real contrast (text, tables, plots)
    assert (im < 200).mean() > 0.02 and im.std() > 20


def test_unreadable_blob_is_reported_in_the_page(store_path, tmp_path, few_stills) -> None:
    """One stored array blob that cannot be read is named in the viewer; the rest of the page
    (tables, figures, the other episodes) is still written."""
    import sqlite3

    broken = tmp_path / "broken.sqlite"
    shutil.copy(store_path, broken)
    con = sqlite3.connect(broken)
    cid, ep = con.execute("SELECT cell_id, episode FROM arrays ORDER BY rowid LIMIT 1").fetchone()
    con.execute(
        "UPDATE arrays SET npz = ? WHERE cell_id = ? AND episode = ?", (b"not an npz", cid, ep)
    )
    con.commit()
    con.close()
    out = report_main(broken, tmp_path / "r.html", renderer=None)
    html = out.read_text()
    assert "stored arrays unreadable" in html and cid in html
    assert "Summary per cell" in html and html.count("data:image/png;base64,") >= 2


def test_report_of_a_store_leaves_its_folder_alone(store_path, tmp_path, few_stills) -> None:
    """Reading a cleanly closed store creates no -wal/-shm files next to it."""
    src = tmp_path / "s"
    src.mkdir()
    shutil.copy(store_path, src / "results.sqlite")
    before = sorted(p.name for p in src.iterdir())
    report_main(src / "results.sqlite", tmp_path / "r.html", renderer=None)
    assert sorted(p.name for p in src.iterdir()) == before


def test_paper_comparison_gives_no_verdict_where_the_paper_or_the_data_give_no_number() -> None:
    import pandas as pd

    from odorloc.experiments.report import paper_section

    summ = pd.DataFrame(
        {
            "cell_id": ["w/a", "w/b"],
            "searcher": ["a", "b"],
            "success_rate": [0.5, 0.0],
            "success_lo": [0.3, 0.0],
            "success_hi": [0.7, 0.2],
            "mean_time": [100.0, math.nan],
            "mean_time_lo": [90.0, math.nan],
            "mean_time_hi": [110.0, math.nan],
        }
    )
    page = paper_section(
        summ,
        {
            "a": {"success_rate": 0.5, "mean_time": math.nan, "source": "Fig. 1"},
            "b": {"success_rate": 0.0, "mean_time": 300.0, "source": "Fig. 2"},
        },
    )
    # a paper time of NaN is no claim; no success to time is no evidence either way
    assert "time outside CI" not in page
    assert "no time to compare" in page and page.count("success within CI") == 2


def test_progress_counts_a_nan_success_as_the_store_does() -> None:
    from types import SimpleNamespace

    from odorloc.experiments.progress import SweepProgress

    p = SweepProgress(enabled=False)
    task = SimpleNamespace(cell_id="c")
    for value in (math.nan, None, True, 1.0, 0.0):
        p.advance(task, {"success": value, "status": "ok"})
    assert p.counts("c") == (5, 2, 0)


SMALL = {
    "name": "report-settings",
    "seed": 11,
    "episodes": 3,
    "keep_arrays": True,
    "scenarios": [{"name": "toy", "params": {"time_limit": 300.0}, "grid": {"scale": [1.0, 2.0]}}],
    "searchers": [{"name": "a", "params": {"skill": 1.2, "trajectory": True}}],
}


@pytest.fixture(scope="module")
def small_store(tmp_path_factory):
    p = tmp_path_factory.mktemp("small") / "results.sqlite"
    run_sweep(SMALL, p, workers=1, episode_fn=stub_episode, progress=False)
    return p


def test_settings_say_what_was_run(small_store, tmp_path) -> None:
    from odorloc import __version__
    from odorloc.experiments.provenance import machine

    with ResultStore(small_store, readonly=True) as st:
        runs = st.runs()
    assert len(runs) == 1 and runs[0]["added"] == 6 and runs[0]["odorloc_version"] == __version__
    page = report_main(small_store, tmp_path / "r.html", renderer=None).read_text()
    settings = page[page.index('<h2 id="settings">') : page.index('<h2 id="summary">')]
    text = " ".join(re.sub(r"<[^>]+>", " ", settings).split())
    assert "root seed 11" in text and "episodes per cell 3 asked, 3 stored" in text
    assert f"odorloc version {__version__}" in text and machine() in text.replace("&#x27;", "'")
    assert re.search(r"wall time \d+\.\d s over 1 run", text)
    # the scenario with its fixed and swept overrides; the searcher's parameters as given,
    # with a note where defaults cannot be filled in (the stub's names are not registered)
    assert "time_limit = 300.0" in text and "scale = [1.0, 2.0]" in text
    assert "skill: 1.2" in text and "defaults not resolvable here" in text


def test_searcher_parameters_are_resolved_with_their_defaults(tmp_path) -> None:
    import yaml

    from helpers import small_scenario_dict
    from odorloc.experiments.report import _resolved_searcher
    from odorloc.searchers.simple import ZigzagParams

    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(small_scenario_dict("zigzag")))
    got = _resolved_searcher(
        {"scenario": str(f), "searcher": "zigzag", "searcher_params": {"angle_deg": 70.0}}
    )
    assert got == {"type": "zigzag", **ZigzagParams(angle_deg=70.0).model_dump()}


def test_the_viewer_offers_every_kept_episode_and_the_new_figures(small_store, tmp_path) -> None:
    page = report_main(small_store, tmp_path / "r.html", renderer=None).read_text()
    options = re.findall(r'<option value="(e\d+)">([^<]+)</option>', page)
    assert len(options) == 6 and options[0][1] == "toy[scale=1.0]/a, episode 0"
    assert page.count('class="episode" data-key=') == 6
    for caption in (
        "Success rate per cell with its Wilson 95 % interval",
        "Success against time per cell",
        "Distributions per cell",
    ):
        assert caption in page


def test_per_agent_values_have_their_own_section(small_store, tmp_path) -> None:
    """Per-agent values (the store's long table) are shown per cell, one column per agent, each
    the mean over the cell's episodes; a CSV export shows them from the table beside it."""
    sweep = {
        "name": "team",
        "seed": 2,
        "episodes": 2,
        "scenarios": [{"name": "toy"}],
        "searchers": [{"name": "team", "params": {"agents": 3}}],
    }
    store = tmp_path / "results.sqlite"
    run_sweep(sweep, store, workers=1, episode_fn=stub_episode, progress=False)

    def section(page: str) -> str:
        part = re.split(r"<h2 |<script>", page[page.index('<h2 id="agents">') + 4 :])[0]
        return " ".join(re.sub(r"<[^>]+>", " ", part).split())

    text = section(report_main(store, tmp_path / "r.html", renderer=None).read_text())
    # episodes 0 and 1: agent a has cues a and a + 1, mean a + 0.5
    assert "agent 0 agent 1 agent 2" in text
    assert "cues 0.500 1.500 2.500" in text
    assert "declaration_time (s) 10.0 20.0 30.0" in text
    with ResultStore(store, readonly=True) as st:
        csv = st.to_csv(tmp_path / "results.csv")
    assert section(report_main(csv, tmp_path / "c.html", renderer=None).read_text()) == text
    # a store without per-agent values has no such section
    plain = report_main(small_store, tmp_path / "p.html", renderer=None).read_text()
    assert 'id="agents"' not in plain
