"""Intervals and paired tests against closed forms, an independent implementation and coverage."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from odorloc.core.errors import ConfigError
from odorloc.experiments import stats


def test_wilson_known_values():
    # 0/10 at 95 %: upper bound z^2/(n+z^2) = 0.2775 (closed form for k = 0)
    z = sps.norm.ppf(0.975)
    lo, hi = stats.wilson_interval(0, 10)
    assert lo == 0.0
    assert hi == pytest.approx(z**2 / (10 + z**2), abs=1e-12)
    assert hi == pytest.approx(0.2775, abs=1e-4)
    # against SciPy's independent implementation
    for k, n in [(47, 50), (45, 50), (1, 3), (50, 50), (7, 200)]:
        ref = sps.binomtest(k, n).proportion_ci(0.95, method="wilson")
        assert stats.wilson_interval(k, n) == pytest.approx((ref.low, ref.high), abs=1e-12)
    ref = sps.binomtest(30, 40).proportion_ci(0.9, method="wilson")
    assert stats.wilson_interval(30, 40, 0.9) == pytest.approx((ref.low, ref.high), abs=1e-12)
    lo, hi = stats.wilson_interval(np.array([0, 5]), np.array([0, 10]))
    assert (lo[0], hi[0]) == (0.0, 1.0) and lo[1] < 0.5 < hi[1]
    with pytest.raises(ConfigError):
        stats.wilson_interval(5, 3)
    with pytest.raises(ConfigError):
        stats.wilson_interval(1, 3, level=1.5)


def test_wilson_coverage():
    # exact coverage: sum of Binomial(n, p) probabilities of the k whose interval holds p
    n = 50
    k = np.arange(n + 1)
    lo, hi = stats.wilson_interval(k, np.full_like(k, n))
    z = sps.norm.ppf(0.975)
    ph = k / n
    wald_lo, wald_hi = ph - z * np.sqrt(ph * (1 - ph) / n), ph + z * np.sqrt(ph * (1 - ph) / n)
    ps = np.linspace(0.05, 0.95, 91)
    cover = np.array([sps.binom.pmf(k, n, p)[(lo <= p) & (p <= hi)].sum() for p in ps])
    wald = np.array([sps.binom.pmf(k, n, p)[(wald_lo <= p) & (p <= wald_hi)].sum() for p in ps])
    assert 0.94 <= cover.mean() <= 0.96  # nominal 0.95 on average
    assert cover.min() > 0.89
    assert wald.mean() < cover.mean() and wald[ps >= 0.9].mean() < 0.9  # Wald fails near 1
    # simulation agrees with the exact value at p = 0.9
    rng = np.random.default_rng(1)
    draws = rng.binomial(n, 0.9, size=20000)
    sim = np.mean((lo[draws] <= 0.9) & (hi[draws] >= 0.9))
    assert sim == pytest.approx(cover[np.argmin(abs(ps - 0.9))], abs=0.005)


def test_bootstrap_mean_interval():
    rng = np.random.default_rng(2)
    x = rng.normal(10.0, 2.0, size=400)
    lo, hi = stats.bootstrap_ci(x, np.random.default_rng(0), "mean")
    # close to the t interval for a large normal sample
    se = x.std(ddof=1) / math.sqrt(x.size)
    t = sps.t.ppf(0.975, x.size - 1)
    assert lo == pytest.approx(x.mean() - t * se, abs=0.25 * se)
    assert hi == pytest.approx(x.mean() + t * se, abs=0.25 * se)
    # seeded: same generator seed, same interval
    assert stats.bootstrap_ci(x, np.random.default_rng(0), "mean") == (lo, hi)
    # one value says nothing of the spread: no interval rather than one of zero width
    assert all(math.isnan(v) for v in stats.bootstrap_ci([3.0], np.random.default_rng(0)))
    assert all(math.isnan(v) for v in stats.bootstrap_ci([], np.random.default_rng(0)))
    mlo, mhi = stats.bootstrap_ci(x, np.random.default_rng(0), "median")
    # the sample median's standard error is sqrt(pi / 2) sigma / sqrt(n) = 0.125, so the 95 %
    # interval is about 0.49 wide around the median
    assert mlo < np.median(x) < mhi
    assert 0.3 < mhi - mlo < 0.75


@pytest.mark.slow
def test_bootstrap_coverage():
    rng = np.random.default_rng(3)
    mu, hits, reps = 4.0, 0, 400
    for _ in range(reps):
        x = rng.exponential(mu, size=60)
        lo, hi = stats.bootstrap_ci(x, rng, "mean", n_boot=1000)
        hits += lo <= mu <= hi
    # percentile bootstrap on skewed data undercovers slightly; nominal 0.95
    assert 0.89 <= hits / reps <= 0.98


def test_mcnemar_exact_closed_form():
    # b = 10, c = 2: p = 2 * P(X <= 2), X ~ Bin(12, 1/2) = 2 * (1 + 12 + 66) / 4096
    assert stats.mcnemar_exact(10, 2) == pytest.approx(2 * 79 / 4096, rel=1e-12)
    assert stats.mcnemar_exact(0, 0) == 1.0
    assert stats.mcnemar_exact(3, 3) == pytest.approx(1.0)


def _df(cells: dict[str, dict[str, np.ndarray]], world: str = "w") -> pd.DataFrame:
    parts = []
    for i, (cid, cols) in enumerate(cells.items()):
        n = len(next(iter(cols.values())))
        d = pd.DataFrame(cols)
        d["cell_id"], d["cell_index"], d["world_key"] = cid, i, world
        d["episode"] = np.arange(n)
        d["status"] = "ok"
        d["searcher"] = cid.split("/")[-1]
        d["scenario"] = world
        parts.append(d)
    return pd.concat(parts, ignore_index=True)


def test_paired_comparison_uses_pairs():
    rng = np.random.default_rng(4)
    base = rng.normal(100.0, 30.0, size=40)  # large between-world spread
    a = base + 2.0 + rng.normal(0, 0.5, 40)  # a is slower by 2 s in every world
    b = base
    df = _df(
        {
            "w/a": {"search_time": a, "success": np.ones(40, bool)},
            "w/b": {"search_time": b, "success": np.ones(40, bool)},
        }
    )
    r = stats.paired_comparison(df, "w/a", "w/b", "search_time")
    assert r["n_pairs"] == 40 and r["test"] == "wilcoxon"
    assert r["mean_diff"] == pytest.approx(np.mean(a - b))
    assert r["diff_lo"] < 2.0 < r["diff_hi"]
    assert r["p_value"] < 1e-6
    # an unpaired test cannot see the 2 s difference behind the 30 s spread
    assert sps.mannwhitneyu(a, b).pvalue > 0.05
    t = stats.paired_comparison(df, "w/a", "w/b", "search_time", test="t")
    assert t["p_value"] == pytest.approx(sps.ttest_rel(a, b).pvalue)
    # an episode in error is dropped from the pairs
    df.loc[(df["cell_id"] == "w/b") & (df["episode"] == 0), "status"] = "error"
    assert stats.paired_comparison(df, "w/a", "w/b")["n_pairs"] == 39


def test_newcombe_paired_interval() -> None:
    # A succeeded and B failed in all 3 pairs: Wilson gives [w, 1] for 3/3 and [0, 1 - w] for
    # 0/3, the correlation is undefined (0), so the lower end is 1 - sqrt(2) (1 - w)
    w, _ = stats.wilson_interval(3, 3)
    lo, hi = stats.paired_proportion_ci(0, 3, 0, 0)
    assert lo == pytest.approx(1 - math.sqrt(2) * (1 - w)) and hi == 1.0
    assert 0.1 < lo < 0.4  # far from the zero-width [1, 1] a bootstrap gives
    # antisymmetric in A and B, and empty without pairs
    lo2, hi2 = stats.paired_proportion_ci(4, 1, 6, 9)
    assert stats.paired_proportion_ci(4, 6, 1, 9) == pytest.approx((-hi2, -lo2))
    assert all(math.isnan(v) for v in stats.paired_proportion_ci(0, 0, 0, 0))
    # coverage near the nominal 95 % for 30 correlated pairs
    rng = np.random.default_rng(3)
    probs = np.array([0.45, 0.2, 0.1, 0.25])  # both, only A, only B, neither
    true = probs[1] - probs[2]
    hits = 0
    for _ in range(2000):
        c = rng.multinomial(30, probs)
        lo, hi = stats.paired_proportion_ci(*c)
        hits += lo <= true <= hi
    assert 0.93 <= hits / 2000 <= 0.985


def test_paired_success_mcnemar_and_world_check():
    sa = np.array([1] * 12 + [0] * 8, bool)
    sb = np.array([1] * 2 + [0] * 10 + [0] * 8, bool)  # 10 discordant for a, 0 for b
    df = _df(
        {
            "w/a": {"success": sa, "search_time": np.ones(20)},
            "w/b": {"success": sb, "search_time": np.ones(20)},
        }
    )
    r = stats.paired_comparison(df, "w/a", "w/b", "success")
    assert r["test"] == "mcnemar"
    assert r["p_value"] == pytest.approx(stats.mcnemar_exact(10, 0))
    assert r["mean_diff"] == pytest.approx(0.5)
    other = _df({"v/c": {"success": sa, "search_time": np.ones(20)}}, world="v")
    with pytest.raises(ConfigError, match="do not share worlds"):
        stats.paired_comparison(pd.concat([df, other]), "w/a", "v/c")
    comp = stats.compare_searchers(df)
    assert len(comp) == 2 and set(comp["metric"]) == {"success", "search_time"}


def test_compare_searchers_is_every_paired_comparison_of_a_world():
    rng = np.random.default_rng(3)
    parts = []
    for k, w in enumerate(("u", "v")):
        cells = {
            f"{w}/{s}": {"success": rng.random(12) < 0.6, "search_time": rng.uniform(5, 50, 12)}
            for s in ("a", "b", "c")
        }
        part = _df(cells, world=w)
        part["cell_index"] += 3 * k
        parts.append(part)
    df = pd.concat(parts, ignore_index=True)
    df.loc[3, "status"] = "error"  # dropped from its pairs
    comp = stats.compare_searchers(df, seed=5)
    assert len(comp) == 2 * 3 * 2  # two worlds, three pairs each, two metrics
    for row in comp.to_dict("records"):
        a, b = row["cell_a"], row["cell_b"]
        assert a.split("/")[0] == b.split("/")[0] == row["world_key"]
        one = stats.paired_comparison(df, a, b, row["metric"], seed=5)
        for k, v in one.items():
            same = row[k] == v or (isinstance(v, float) and math.isnan(v) and math.isnan(row[k]))
            assert same, (a, b, row["metric"], k)


def test_summarize_and_width():
    succ = np.array([True] * 8 + [False] * 2)
    times = np.arange(10, dtype=float) * 10.0
    df = _df({"w/a": {"success": succ, "search_time": times, "loc_error": np.full(10, 0.2)}})
    df.loc[9, "status"] = "error"
    s = stats.summarize(df).iloc[0]
    assert s.n == 9 and s.errors == 1 and s.successes == 8
    assert s.success_rate == pytest.approx(8 / 9)
    assert (s.success_lo, s.success_hi) == pytest.approx(stats.wilson_interval(8, 9))
    assert s.mean_time == pytest.approx(np.mean(times[:8]))
    assert s.median_time == pytest.approx(np.median(times[:8]))
    # times 0, 10, ..., 70 s: standard error 8.7 s, so a 95 % interval reaches 10-25 s each side
    assert 10.0 < s.mean_time - s.mean_time_lo < 25.0
    assert 10.0 < s.mean_time_hi - s.mean_time < 25.0
    assert s.mean_loc_error == pytest.approx(0.2)
    w = stats.interval_width(df, "success")
    assert w == pytest.approx(s.success_hi - s.success_lo)
    assert stats.interval_width(df.iloc[:0], "success") == math.inf
    assert stats.interval_width(df, "search_time") > 0
    with pytest.raises(ConfigError):
        stats.interval_width(df, "energy")
