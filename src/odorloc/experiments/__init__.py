"""Experiments: Monte Carlo sweeps, durable results, statistics and reports.

Typical use::

    from odorloc.experiments import run_sweep, write_report

    df = run_sweep("sweep.yaml", "results.sqlite", backend="local", workers=2)
    write_report("results.sqlite", "report.html")

Names are imported on first use, so ``import odorloc.experiments`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "EpisodeTask": "sweep",
    "SweepSpec": "sweep",
    "load_sweep": "sweep",
    "expand_cells": "sweep",
    "expand_tasks": "sweep",
    "config_hash": "sweep",
    "episode_seeds": "sweep",
    "run_sweep": "sweep",
    "ResultStore": "store",
    "open_results": "store",
    "LocalBackend": "backends",
    "DaskBackend": "backends",
    "summarize": "stats",
    "wilson_interval": "stats",
    "bootstrap_ci": "stats",
    "paired_comparison": "stats",
    "compare_searchers": "stats",
    "write_report": "report",
    "report_main": "report",
    "summary_table": "progress",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    mod = _EXPORTS.get(name)
    if mod is None:
        raise AttributeError(f"module 'odorloc.experiments' has no attribute {name!r}")
    return getattr(importlib.import_module(f"odorloc.experiments.{mod}"), name)
