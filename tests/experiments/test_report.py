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
    "keep_arrays": True,
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


def test_report_main_and_csv_input(store_path, tmp_path):
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
    m = re.search(r'data-rendered="images=(\d+)/(\d+) tables=(\d+)"', dom)
    assert m, "the page's load script did not run"
    loaded, total, tables = map(int, m.groups())
    assert total >= 5 and loaded == total, f"only {loaded}/{total} images decoded"
    assert tables >= 4
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


def test_unreadable_blob_is_reported_in_the_page(store_path, tmp_path) -> None:
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


def test_report_of_a_store_leaves_its_folder_alone(store_path, tmp_path) -> None:
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
