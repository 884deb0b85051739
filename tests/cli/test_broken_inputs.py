"""The corpus of broken inputs (``tests/data/broken_inputs.yaml``): every case exits with code 2
before any work (no world is stepped, no episode runs: the steps are counted), prints exactly
one ``error:`` line naming the field or file and the problem (no traceback, no warning), and
changes nothing stored.

Cases run in this process through typer's ``CliRunner`` (fast: the imports are paid once);
those marked ``process: true`` (inputs that once hung or exhausted memory) run as real
``odorloc`` processes, which count their own steps the same way and stop at a generous
time-out if they hang.
"""

from __future__ import annotations

import copy
import hashlib
import shutil
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from helpers import small_scenario_dict
from odorloc.cli import app

CORPUS = Path(__file__).resolve().parents[1] / "data" / "broken_inputs.yaml"
CASES: list[dict[str, Any]] = yaml.safe_load(CORPUS.read_text())

BASE_SWEEP: dict[str, Any] = {
    "name": "corpus",
    "seed": 1,
    "episodes": 1,
    "scenarios": [{"name": "s.yaml"}],
    "searchers": [{"name": "zigzag"}],
}


def base_scenario() -> dict[str, Any]:
    """A small valid scenario (10 m x 5 m, Gaussian plume, zigzag, 30 s)."""
    return small_scenario_dict("zigzag")


# ----------------------------------------------------------------------------- file contents


def _set(data: Any, dotted: str, value: Any) -> None:
    keys = dotted.split(".")
    node = data
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    last = keys[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def _dump(d: dict[str, Any]) -> str:
    return yaml.safe_dump(d, sort_keys=False)


def _bomb(levels: int = 7) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels):
        refs = ", ".join([f"*a{i - 1}"] * 10)
        lines.append(f"a{i}: &a{i} [{refs}]")
    return "\n".join(lines) + "\n"


def _deep(n: int = 2000) -> str:
    return "[" * n + "]" * n


def _make(name: str, path: Path) -> bytes:
    """Named generators for contents too big or too binary for the YAML corpus."""
    sc = base_scenario()
    if name == "large_file":
        return (_dump(sc) + "# padding\n" * 500_000).encode()
    if name == "bigint_seed":
        return (_dump(sc).replace("name: test-room", "seed: " + "9" * 5000 + "\nname: x")).encode()
    if name == "sweep_bigint":
        return (_dump(BASE_SWEEP) + "keep_arrays: " + "1" * 4000 + "\n").encode()
    if name == "deep_scenario":
        return (_dump(sc) + "description: " + _deep() + "\n").encode()
    if name == "deep_sweep":
        d = copy.deepcopy(BASE_SWEEP)
        return (_dump(d) + "name2: " + _deep() + "\n").encode()
    if name == "sweep_bomb":
        body = "\n".join("  " + ln for ln in _bomb(9).splitlines())
        text = _dump(BASE_SWEEP).replace(
            "scenarios:\n- name: s.yaml\n", f"scenarios:\n- name: s.yaml\n  params:\n{body}\n"
        )
        return text.encode()
    if name == "scenario_bomb":
        body = "\n".join("  " + ln for ln in _bomb(6).splitlines())
        return (_dump({k: v for k, v in sc.items() if k != "searcher"})).encode() + (
            f"searcher:\n  type: zigzag\n{body}\n"
        ).encode()
    if name == "topics_bomb":
        return _bomb(9).encode()
    if name == "many_aliases":
        anchors = "\n".join(f"  k{i}: &k{i} 1" for i in range(40))
        uses = "\n".join(f"  u{i}: *k{i}" for i in range(40))
        return (_dump(sc) + f"description2:\n{anchors}\n{uses}\n").encode()
    if name == "duplicate_nested":
        return _dump(sc).replace("  dt: 0.25\n", "  dt: 0.25\n  dt: 0.5\n").encode()
    if name == "huge_string":
        return (_dump(sc) + "description: " + "x" * 200_000 + "\n").encode()
    if name == "sweep_many_cells":
        d = copy.deepcopy(BASE_SWEEP)
        d["scenarios"][0]["grid"] = {"limits.time": [float(t) for t in range(10, 210)]}
        d["searchers"][0]["grid"] = {"angle_deg": [10 + 0.1 * i for i in range(200)]}
        return _dump(d).encode()
    if name == "sweep_start_index_99":
        d = copy.deepcopy(BASE_SWEEP)
        d["scenarios"] = [{"name": "indoor-ventilated", "grid": {"start_index": [0, 99]}}]
        return _dump(d).encode()
    if name == "movie_without_wind":
        import io

        buf = io.BytesIO()
        np.savez(buf, times=np.arange(3.0), arena_lower=np.zeros(2), arena_upper=np.ones(2))
        return buf.getvalue()
    if name == "single_array":
        import io

        buf = io.BytesIO()
        np.save(buf, np.zeros(3))
        return buf.getvalue()
    if name in ("results_csv_bad_time", "results_csv_bad_episode"):
        from odorloc.experiments.store import COLUMNS

        row = {c: "x" for c in COLUMNS}
        row.update(episode=0, success=1, steps=1, bytes=0, status="ok", termination="declared")
        for c in ("path_length", "loc_error", "first_detection_time", "energy"):
            row[c] = 1.0
        row.update(start_distance=1.0, world_seed=1, agent_seed=2, cell_index=0, wall_time=1.0)
        row["search_time"] = "fast" if name == "results_csv_bad_time" else 3.0
        if name == "results_csv_bad_episode":
            row["episode"] = "first"
        head = ",".join(row)
        return (head + "\n" + ",".join(str(v) for v in row.values()) + "\n").encode()
    if name == "parquet_not_results":
        import pandas as pd

        pd.DataFrame({"x": [1, 2]}).to_parquet(path)
        return path.read_bytes()
    if name.startswith("sqlite_"):
        import sqlite3

        con = sqlite3.connect(path)
        if name == "sqlite_wrong_columns":
            con.execute("CREATE TABLE meta (a TEXT)")
            con.execute("CREATE TABLE episodes (b INTEGER)")
        elif name == "sqlite_other_tables":
            con.execute("CREATE TABLE patients (id INTEGER)")
        else:  # a database file whose only table was dropped
            con.execute("CREATE TABLE t (x INTEGER)")
            con.commit()
            con.execute("DROP TABLE t")
        con.commit()
        con.close()
        return path.read_bytes()
    raise KeyError(name)


def _content(spec: dict[str, Any], kind: str, path: Path) -> bytes:
    if "make" in spec:
        return _make(spec["make"], path)
    if "text" in spec:
        return str(spec["text"]).encode()
    if "hex" in spec:
        return bytes.fromhex(spec["hex"])
    base = spec.get("base")
    if (base is True and kind == "sweep") or base == "sweep":
        data: Any = copy.deepcopy(BASE_SWEEP)
    else:
        data = base_scenario()
    for k, v in (spec.get("set") or {}).items():
        _set(data, k, v)
    return (_dump(data) + spec.get("append", "")).encode()


def materialise(case: dict[str, Any], tmp: Path, store_template: Path) -> list[str]:
    """Write the case's files into ``tmp``; return its command line."""
    files: dict[str, tuple[dict[str, Any], str]] = {}
    if "scenario" in case:
        files["s.yaml"] = (case["scenario"], "scenario")
    if "sweep" in case:
        files["sweep.yaml"] = (case["sweep"], "sweep")
        files.setdefault("s.yaml", ({"base": True}, "scenario"))
    for name, spec in (case.get("files") or {}).items():
        files[name] = (spec, "sweep" if name.startswith("sweep") else "scenario")
    setup = case.get("setup") or []
    setup = [setup] if isinstance(setup, str) else setup
    if "store" in setup:
        shutil.copytree(store_template, tmp, dirs_exist_ok=True)
        files.setdefault("sweep.yaml", ({"base": True}, "sweep"))
    if "file" in setup:
        (tmp / "afile").write_text("a file, not a folder\n")
    for name, (spec, kind) in files.items():
        p = tmp / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(_content(spec, kind, p))
    if "args" in case:
        return [str(a).replace("{tmp}", str(tmp)) for a in case["args"]]
    if "sweep" in case or "store" in setup:
        return ["batch", str(tmp / "sweep.yaml"), "--out", str(tmp / "out"), "--no-progress"]
    return ["run", str(tmp / "s.yaml"), "--out", str(tmp / "out"), "--no-animation"]


def snapshot(root: Path) -> dict[str, str]:
    """Every file and folder under ``root`` with a hash of its bytes."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        out[rel] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


# ----------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def store_template(tmp_path_factory) -> Path:
    """A folder with the base scenario, the base sweep and its finished store in ``out/``."""
    from odorloc.experiments.sweep import run_sweep

    d = tmp_path_factory.mktemp("store")
    (d / "s.yaml").write_text(_dump(base_scenario()))
    (d / "sweep.yaml").write_text(_dump(BASE_SWEEP))
    run_sweep(d / "sweep.yaml", d / "out" / "results.sqlite", workers=1, progress=False)
    assert (d / "out" / "results.sqlite").is_file()
    return d


#: Work a refusal must not have started: world steps (warm-up, flows, episodes) and episode
#: steps, counted by wrapping the two step methods.
_COUNTED = (("odorloc.world.world", "World", "step"), ("odorloc.engine.episode", "Episode", "step"))


def _counting(method: Any, counter: list[int]) -> Any:
    def wrapped(*args: Any, **kw: Any) -> Any:
        counter[0] += 1
        return method(*args, **kw)

    return wrapped


#: The same counting inside an ``odorloc`` process: it writes the count to ``argv[1]`` at exit.
_PROCESS = """
import atexit, importlib, sys
counted = [0]
for mod, cls, name in COUNTED:
    owner = getattr(importlib.import_module(mod), cls)
    method = getattr(owner, name)
    def wrapped(*a, _m=method, **k):
        counted[0] += 1
        return _m(*a, **k)
    setattr(owner, name, wrapped)
out = sys.argv.pop(1)
atexit.register(lambda: open(out, "w").write(str(counted[0])))
from odorloc.cli import main
sys.argv[0] = "odorloc"
main()
""".replace("COUNTED", repr(_COUNTED))

#: Seconds a process case may take before it counts as hung (start-up included, on a loaded
#: machine): a guard against a hang, not a measure of speed.
PROCESS_TIMEOUT = 600


# ----------------------------------------------------------------------------- the test


def test_the_corpus_is_large_and_unique() -> None:
    ids = [c["id"] for c in CASES]
    assert len(ids) >= 100 and len(set(ids)) == len(ids)


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_broken_input(
    case: dict[str, Any], tmp_path: Path, store_template: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    args = materialise(case, tmp_path, store_template)
    before = snapshot(tmp_path)
    if case.get("process"):
        count_file = tmp_path.parent / f"{tmp_path.name}.work"
        r = subprocess.run(
            [sys.executable, "-c", _PROCESS, str(count_file), *args],
            capture_output=True,
            text=True,
            timeout=PROCESS_TIMEOUT,
            cwd=tmp_path.parent,
        )
        code, stderr, stdout = r.returncode, r.stderr, r.stdout
        work = int(count_file.read_text())
    else:
        import importlib

        counter = [0]
        for mod, cls, name in _COUNTED:
            owner = getattr(importlib.import_module(mod), cls)
            monkeypatch.setattr(owner, name, _counting(getattr(owner, name), counter))
        with warnings.catch_warnings(record=True) as caught:
            # a warning would be a second stderr line outside the test run
            warnings.simplefilter("always")
            res = CliRunner().invoke(app, args)
        if res.exception is not None and not isinstance(res.exception, SystemExit):
            raise res.exception
        code, stderr, stdout = res.exit_code, res.stderr, res.stdout
        assert not caught, [str(w.message) for w in caught]
        work = counter[0]
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert code == 2, f"exit {code}; stderr: {stderr!r}; stdout: {stdout[-500:]!r}"
    assert len(lines) == 1, f"expected one line on stderr, got: {stderr!r}"
    line = lines[0]
    assert line.startswith("error: ") and "Traceback" not in stderr
    assert case["expect"] in line, line
    for bad in case.get("forbid", []):
        assert bad not in line, line
    assert work == 0, f"refused after {work} world or episode steps"
    assert snapshot(tmp_path) == before, "the case changed a stored file"
