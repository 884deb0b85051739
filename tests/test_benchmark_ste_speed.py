"""The source-term speed benchmark's own checks (no timing is tested)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "ste_speed.py"


def _load():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("bench_ste_speed", BENCH)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _result(out: str) -> dict[str, str]:
    last = out.strip().splitlines()[-1]
    assert last.startswith("RESULT ")
    return dict(kv.split("=") for kv in last.split()[1:])


def test_quick_run_reports_every_operation_and_agrees(capsys: pytest.CaptureFixture[str]) -> None:
    bench = _load()
    bench.main(["--quick"])
    keys = _result(capsys.readouterr().out)
    for k in ("ste_update_ms", "mcmc_sweep_ms", "entrotaxis_ms", "mcmc_sweep_20k_ms"):
        assert math.isfinite(float(keys[k]))
    assert keys["agree"] == "yes"


def test_a_loop_that_disagrees_is_reported(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    bench = _load()
    loop = bench.loop_update
    monkeypatch.setattr(bench, "loop_update", lambda case: loop(case) + 1e-3)
    bench.main(["--quick"])
    out = capsys.readouterr().out
    assert _result(out)["agree"] == "no"
    assert any(line.startswith("update") and "NO" in line.split() for line in out.splitlines())
