"""Figures of a source-term posterior."""

from __future__ import annotations

import numpy as np

from odorloc.inference.source_terms import SourceTermBelief
from odorloc.models.source_term import ThetaLayout
from odorloc.viz.source_terms import plot_pit_histograms, plot_posterior_marginals


def test_marginals_and_pit_figures_are_written(tmp_path) -> None:
    rng = np.random.default_rng(0)
    lay = ThetaLayout(2, speed=True, direction=True)
    snaps = []
    for k, t in enumerate(np.arange(0.0, 20.0, 2.0)):
        s = 5.0 / (k + 1)
        th = np.column_stack(
            [
                rng.normal(10, s, 300),
                rng.normal(20, s, 300),
                rng.normal(-1.0, 0.1 * s, 300),
                rng.normal(2.0, 0.1 * s, 300),
                rng.normal(np.pi - 0.05, 0.1, 300),  # straddles +-180 degrees
            ]
        )
        snaps.append((t, SourceTermBelief.of(th, np.zeros(300), lay).snapshot()))
    truth = {
        "x": 10.0,
        "y": 20.0,
        "log_rate": float(np.exp(-1.0)),
        "speed": 2.0,
        "direction": 177.0,
    }
    p = plot_posterior_marginals(snaps, tmp_path / "m.png", truth, title="test")
    assert p.is_file() and p.stat().st_size > 10_000
    q = plot_pit_histograms({"x": rng.random(50), "rate": np.array([np.nan])}, tmp_path / "p.png")
    assert q.is_file()
