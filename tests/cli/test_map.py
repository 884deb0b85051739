"""``odorloc map``: a recording or a bag mapped offline; bad input is one line, exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from helpers import filament_scenario_dict
from odorloc.cli import app
from odorloc.engine.episode import run_episode
from odorloc.engine.recorder import Recording
from odorloc.scenarios import Scenario


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    d = filament_scenario_dict("rectangular-wave", lane_spacing=1.0)
    d["limits"]["time"] = 40.0
    d["recording"] = {"plume_stride": 4, "plume_grid": 4.0}
    res = run_episode(Scenario.from_dict(d), 5, 6, record=True)
    path = tmp_path_factory.mktemp("rec") / "recording.npz"
    res.recording.save(path)
    return path


def _map(*args: str):
    return CliRunner().invoke(app, ["map", *args])


def test_map_a_recording_on_the_truths_cells(recording, tmp_path) -> None:
    out = tmp_path / "m"
    r = _map(str(recording), "--method", "gmrf", "--out", str(out))
    assert r.exit_code == 0, r.output
    assert "against the time-averaged truth: RMSE" in r.stdout
    assert "source 0:" in r.stdout and "map maximum 0:" in r.stdout
    assert max(len(line) for line in r.stdout.splitlines()) <= 80
    z = np.load(out / "gas-map.npz")
    assert z["mean"].shape == (40, 20) and np.all(np.isfinite(z["variance"]))
    assert (out / "gas-map.png").stat().st_size > 0


def test_map_with_a_cell_size_and_selected_kernel_width(recording, tmp_path) -> None:
    out = tmp_path / "m"
    r = _map(
        str(recording),
        "--method",
        "kernel-dmvw",
        "--cell-size",
        "0.5",
        "--set",
        "wind_scale=0.2",
        "--select",
        "kernel_width=[0.25, 0.5, 1.0]",
        "--out",
        str(out),
    )
    assert r.exit_code == 0, r.output
    assert "selected by cross-validated NLPD: kernel_width=" in r.stdout
    assert "truth" not in r.stdout  # other cells than the recorded frames': not scored
    assert np.load(out / "gas-map.npz")["mean"].shape == (20, 10)


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["--method", "nosuch"], "error: --method: unknown gas_map 'nosuch'"),
        (["--set", "kernel_width=-1"], "error: --set kernel_width: must be a finite number > 0"),
        (["--set", "kernel_width"], "error: --set: expected KEY=VALUE"),
        (["--set", "bogus=1"], "error: --set bogus: "),
        (["--cell-size", "0"], "error: --cell-size: must be a finite number > 0"),
        (["--select", "kernel_width=0.3"], "error: --select kernel_width: needs a list"),
        (["--select", "kernel_width=[0.3, -1]"], "error: --set kernel_width: "),
        (["--agent", "3"], "error: agent: 3 is not an agent of the recording"),
        (["--topics", "t.yaml"], "error: --topics: is for bags"),
    ],
)
def test_bad_options_are_one_line_and_write_nothing(recording, tmp_path, args, expect) -> None:
    out = tmp_path / "never"
    r = _map(str(recording), *args, "--out", str(out))
    assert r.exit_code == 2, r.output
    assert r.stderr.startswith(expect), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output
    assert not out.exists()


def test_bad_sources_are_one_line(tmp_path) -> None:
    (tmp_path / "junk.npz").write_bytes(b"not an npz")
    (tmp_path / "folder").mkdir()
    for src, expect in (
        (tmp_path / "nope.npz", "error: source: "),
        (tmp_path / "junk.npz", "error: source: "),
        (tmp_path / "folder", "error: --topics: a bag needs"),
    ):
        r = _map(str(src), "--out", str(tmp_path / "o"))
        assert r.exit_code == 2 and r.stderr.startswith(expect), r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


def test_map_a_bag(recording, tmp_path) -> None:
    pytest.importorskip("rosbags", reason="bags need the ros extra")
    import yaml

    from odorloc.replay.bag import write_bag

    mapping = {
        "period": 0.5,
        "dim": 2,
        "gas": {"topic": "/gas", "field": "data", "threshold": 0.5},
        "anemometer": {"topic": "/anemometer", "field": "vector"},
        "pose": {"topic": "/odom", "field": "pose"},
        "arena": {"lower": [0.0, 0.0], "upper": [10.0, 5.0]},
        "sources": [[1.0, 2.5]],
    }
    rec = Recording.load(recording)
    write_bag(tmp_path / "b", rec, mapping)
    topics = tmp_path / "topics.yaml"
    topics.write_text(yaml.safe_dump(mapping))
    out = tmp_path / "m"
    r = _map(str(tmp_path / "b"), "--topics", str(topics), "--out", str(out))
    assert r.exit_code == 0, r.output
    assert r.stdout.startswith(f"{len(rec.t)} readings, kernel-dmv")
    assert "source 0:" in r.stdout
