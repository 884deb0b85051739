"""The experiments toolkit for paper reproductions: intervals, verdicts, paired cells, the usual
statements, sweeps over a paper's points, and diagnostic traces."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest

from odorloc.core.errors import ConfigError
from odorloc.experiments.claims import (
    Cells,
    Points,
    PointSummary,
    best_everywhere,
    bootstrap,
    combine,
    paired_difference,
    pct_text,
    rate_verdict,
    relative_change,
    slope,
    slope_difference,
    summarize_point,
    summary_texts,
    sweep_rows,
    trend_claims,
    verdict,
)
from odorloc.experiments.stats import wilson_interval
from odorloc.experiments.sweep import expand_cells, load_sweep
from odorloc.experiments.variants import Sweep, WorldVariant, restrict, variant_sweeps


def test_slope_of_exact_lines_and_verdicts() -> None:
    x = [1.0, 2.0, 4.0]
    means = np.array([[1.0, 3.0, 7.0], [5.0, 5.0, 5.0]])
    np.testing.assert_allclose(slope(x, means, [3, 3, 3]), [2.0, 0.0])
    assert np.isnan(slope([2.0], means[:, :1], [4])[0])
    assert verdict(0.1, 0.5, +1) == "held"
    assert verdict(-0.5, -0.1, +1) == "not held"
    assert verdict(-0.1, 0.5, +1) == "undecided"
    assert verdict(-0.5, -0.1, -1) == "held"
    assert verdict(0.8, 0.9, +1, 0.75) == "held" and verdict(0.5, 0.7, +1, 0.75) == "not held"
    assert verdict(math.nan, 1.0, +1) == "undecided"
    assert combine(["held", "held"]) == "held"
    assert combine(["held", "undecided"]) == "undecided"
    assert combine(["held", "not held", "undecided"]) == "not held"
    # a success rate against a margin, by its Wilson interval
    assert rate_verdict(95, 100, 0.8) == "held" and rate_verdict(10, 100, 0.8) == "not held"
    assert rate_verdict(0, 100, 0.05, -1) == "held" and rate_verdict(0, 0, 0.5) == "undecided"
    assert pct_text(6, 24).startswith("25 % [") and pct_text(0, 0) == "-"


def test_bootstrap_interval_covers_a_known_mean() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(10.0, 2.0, 400)
    v, lo, hi = bootstrap(lambda a: a[0].mean(axis=1), [x], np.random.default_rng(2))
    assert v == pytest.approx(x.mean())
    half = 1.96 * 2.0 / math.sqrt(400)
    assert lo == pytest.approx(x.mean() - half, abs=0.05)
    assert hi == pytest.approx(x.mean() + half, abs=0.05)
    assert math.isnan(bootstrap(lambda a: a[0].mean(axis=1), [np.zeros(0)], rng)[0])
    # coverage: over 300 samples of 40 from N(10, 2^2) the 95 % interval holds the true mean
    # in about 94 % of them (the percentile interval of a mean runs slightly short at n = 40);
    # the binomial standard error of the fraction is 1.3 %, so [0.90, 0.98] allows 3 of them
    hits = 0
    for _ in range(300):
        sample = rng.normal(10.0, 2.0, 40)
        _, lo, hi = bootstrap(lambda a: a[0].mean(axis=1), [sample], rng, n_boot=1000)
        hits += lo <= 10.0 <= hi
    assert 0.90 <= hits / 300 <= 0.98


def test_point_summary() -> None:
    g = pd.DataFrame({"success": [True, True, False, False], "time": [100.0, 300.0, 1200, 1200]})
    p = summarize_point(g, np.random.default_rng(0))
    assert (p.n, p.k, p.sr) == (4, 2, 0.5)
    assert p.mst == pytest.approx(700.0) and p.mst_success == pytest.approx(200.0)
    assert p.mst_lo <= 700.0 <= p.mst_hi
    assert (p.sr_lo, p.sr_hi) == pytest.approx(wilson_interval(2, 4))


@dataclass(frozen=True)
class Point:
    size: int = 1


def _rows(n: int = 40) -> pd.DataFrame:
    """Method ``a`` succeeds always and faster with the size; ``b`` in half of the episodes,
    at a constant time; episodes paired by index in each world ``w<size>``."""
    frames = []
    for size in (1, 2, 4):
        for m in ("a", "b"):
            ok = np.ones(n, bool) if m == "a" else np.arange(n) % 2 == 0
            t = np.where(ok, 100.0 - 10 * size if m == "a" else 200.0, 1000.0)
            frames.append(
                pd.DataFrame(
                    {
                        "world_key": f"w{size}",
                        "searcher": m,
                        "episode": np.arange(n),
                        "status": "ok",
                        "success": ok,
                        "t": t,
                        "e": np.full(n, 90.0 if m == "a" else 100.0),
                    }
                )
            )
    return pd.concat(frames, ignore_index=True)


def _points() -> Points:
    return Points(Cells(_rows(), {"time": "t", "energy": "e"}), lambda p, m: (f"w{p.size}", m))


def test_cells_pair_episodes_and_read_missing_columns_as_nan() -> None:
    data = _points()
    x = data.paired(Point(2), ["a", "b"], "time")
    assert x.shape == (40, 2) and np.all(x[:, 0] == 80.0)
    g = Cells(_rows(), {"time": "t", "other": "nope"}).get("w1", "a")
    assert list(g.columns) == ["success", "time", "other"] and g["other"].isna().all()
    assert len(data.one(Point(8), "a")) == 0
    # an error row is left out
    rows = _rows()
    rows.loc[0, "status"] = "error"
    assert len(Cells(rows, {"time": "t"}).get("w1", "a")) == 39
    with pytest.raises(ValueError, match="share a world"):
        Points(data.cells, lambda p, m: (m, m)).paired(Point(), ["a", "b"], "time")


def test_the_usual_statements_on_made_up_episodes() -> None:
    data, rng = _points(), np.random.default_rng(0)
    pts = [Point(s) for s in (1, 2, 4)]
    ours, v = best_everywhere(data, pts, "a", ["b"], "success", rng, {"a": "A", "b": "B"})
    assert v == "held" and ours.startswith("best at 3 of 3 points")
    _, v = best_everywhere(data, pts, "b", ["a"], "time", rng, {}, higher=False)
    assert v == "not held"
    v, lo, hi, n = relative_change(data, Point(1), "a", "b", "energy", rng)
    assert (v, lo, hi, n) == pytest.approx((-0.1, -0.1, -0.1, 40))
    d, lo, hi = paired_difference(data, pts, "a", "b", "time", rng)
    assert lo <= d <= hi and d < 0
    s, lo, hi = slope_difference(data, [1, 2, 4], lambda v: Point(v), "a", "b", "time", rng)
    assert s == pytest.approx(-10.0) and lo <= s <= hi
    claims = trend_claims(
        data, [1, 2, 4], lambda v: Point(v), ["a"], 2, "size", "unit", "Fig. X", rng, {}, "w"
    )
    c = {c.statement: c.verdict for c in claims}
    assert c["MST falls with more size (all 1)"] == "held"
    assert c["SR rises with more size (all 1)"] == "undecided"  # always 100 %: no slope
    sr, _, long = sweep_rows(data, [1, 4], lambda v: Point(v), str, ["a", "b"], 0, 500.0, ["w"])
    assert sr[0][0] == "1" and sr[0][1].startswith("100 [")
    assert len(long) == 4 and long[3][:5] == ["w", "4", "b", "40", "20"]
    assert long[3][-1] == "50.0"  # half of b succeeded by 500 s


def test_sweeps_restrict_and_variant_sweep_files() -> None:
    sweeps = [
        Sweep("size", "Fig. 1", "size", (1, 2, 4), Point(), "size"),
        Sweep("area", "Fig. 2", "area", ((1.0, 2.0), (3.0, 4.0)), Point(), "size"),
    ]
    assert sweeps[0].setting(4) == Point(4) and sweeps[1].tick((3.0, 4.0)) == "3x4"
    cut = restrict(sweeps, {"size": [4], "area": [[3.0, 4.0]]})
    assert [s.values for s in cut] == [(4,), ((3.0, 4.0),)]
    assert restrict(sweeps, None) == sweeps and restrict(sweeps, {"size": [2]})[0].values == (2,)
    with pytest.raises(ConfigError, match=r"^values: unknown sweep key 'nope'"):
        restrict(sweeps, {"nope": [1]})
    with pytest.raises(ConfigError, match=r"^values\.size: 3 is not a value"):
        restrict(sweeps, {"size": [3]})
    with pytest.raises(ConfigError, match=r"^values\.size: must be a list"):
        restrict(sweeps, {"size": "4"})
    # not strict: a value the sweep lacks is left out, and a sweep left with none
    assert [s.values for s in restrict(sweeps, {"size": [3, 4]}, strict=False)] == [(4,)]
    assert restrict(sweeps, {"size": [3]}, strict=False) == []
    worlds = [WorldVariant(), WorldVariant("[r=0]", {"agents.comm_radius": 0.0}), WorldVariant()]
    files = variant_sweeps(
        "muc-osl-3d",
        worlds,
        [{"name": "col-inf"}],
        2,
        7,
        base_searchers=[{"name": "col-inf", "label": "x", "params": {"declare_spread": 2.0}}],
        common={"limits.time": 30.0},
    )
    main, base = load_sweep(files[""]), load_sweep(files["base"])
    keys = sorted(c.world_key for c in expand_cells(main))
    assert keys == ["muc-osl-3d", "muc-osl-3d[r=0]"]  # the duplicate world runs once
    assert [c.world_key for c in expand_cells(base)] == ["muc-osl-3d"]
    assert all(s.params["limits.time"] == 30.0 for s in main.scenarios)


def test_summary_texts_give_a_dash_where_nothing_is_defined() -> None:
    nan = math.nan
    assert summary_texts(PointSummary(4, 1, 0.25, 0.05, 0.7, 300.0, 200.0, 400.0, 100.0)) == (
        "25 [5, 70]",
        "300 [200, 400]",
    )
    # successes whose time was not recorded: the rate stands, the time is undefined
    assert summary_texts(PointSummary(1, 1, 1.0, 0.2, 1.0, nan, nan, nan, nan)) == (
        "100 [20, 100]",
        "-",
    )
    assert summary_texts(PointSummary(0, 0, nan, nan, nan, nan, nan, nan, nan)) == ("-", "-")
