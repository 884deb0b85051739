"""``odorloc reproduce source-terms``: searches over a source-term posterior, its calibration,
and several sources beside the D-S map.

Three sweeps, each stored on its own:

- ``search``: infotaxis and entrotaxis with 4, 8 and 16 move directions and a lawn-mower
  (``ste-search`` with the planners of :mod:`odorloc.planning.source_term`) in
  ``ste-gaussian`` (the Park & Oh setting) and ``ste-vergassola-3d``: success (a declared
  position within the success radius), search time, the error of the final posterior mean, the
  release-rate error (the factor ``exp|log q_hat - log q|``), and whether the final 95 %
  credible region and rate interval contain the truth;
- ``calibration``: ``ste-calibration``, the truth drawn from the estimator's prior and read
  along a fixed route: the coverage of the 95 % regions (with Wilson intervals) and the
  probability-integral-transform values of the truth (flat histograms when calibrated);
- ``multi``: the D-S map's dynamic route (``ds-mapping``) in ``two-sources-farrell`` and
  ``ste-three-sources-farrell``; the readings of each flight are also fed to a multi-source
  posterior (:data:`MULTI_STE`: up to 4 sources, birth/death moves), and both source sets are
  scored against the truth by the Earth Mover's Distance, the sources found within the success
  radius and the false ones (one-to-one matching).

The search and calibration episodes keep their recordings (the posterior snapshots are
thinned to a few hundred particles); the tables then score each final posterior against the
source and rate drawn with the episode's world seed (:func:`truth_columns`). The D-S flights are
run by :func:`ste_group`, which feeds each flight's readings to the multi-source posterior.
"""

from __future__ import annotations

import dataclasses
import math
import time
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.experiments.reproduction import (
    Citation,
    Figure,
    Reproduction,
    ReproductionParams,
    Table,
    check_time_limit,
    fmt,
)

__all__ = ["CITATIONS", "MULTI_STE", "SourceTermsReproduction", "score_posterior", "ste_group"]

CITATIONS = (
    Citation(
        authors="Park, M.; Ladosz, P.; Oh, H.",
        title=(
            "Source Term Estimation Using Deep Reinforcement Learning With Gaussian Mixture "
            "Model Feature Extraction for Mobile Sensors"
        ),
        venue="IEEE Robotics and Automation Letters",
        year=2022,
        note="volume, pages and DOI not checked against the publisher",
    ),
    Citation(
        authors="Hutchinson, M.; Oh, H.; Chen, W.-H.",
        title=(
            "Entrotaxis as a strategy for autonomous search and source reconstruction in "
            "turbulent conditions"
        ),
        venue="Information Fusion 42, 179-189",
        year=2018,
        doi="10.1016/j.inffus.2017.10.009",
    ),
    Citation(
        authors="Staples, M.; Hugenholtz, C.; Serrano-Ramirez, A.; Barchyn, T. E.; Gao, M.",
        title="A Comparison of Multiple Odor Source Localization Algorithms",
        venue="Sensors 23(10), 4799",
        year=2023,
        doi="10.3390/s23104799",
    ),
)
"""The benchmark setting of ``ste-gaussian``, entrotaxis, and the multi-source comparison."""

SEARCH_SCENARIOS = ("ste-gaussian", "ste-vergassola-3d")
MULTI_SCENARIOS = ("two-sources-farrell", "ste-three-sources-farrell")
CALIBRATION = "ste-calibration"
FIGURE_CELL = ("ste-gaussian", "entrotaxis-8")


def _searchers() -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for policy in ("infotaxis", "entrotaxis"):
        for n in (4, 8, 16):
            out[f"{policy}-{n}"] = {
                "planner": {"type": f"ste-{policy}", "directions": n, "vertical": True}
            }
    out["lawnmower"] = {"planner": {"type": "ste-lawnmower", "spacing": 8.0}}
    return out


SEARCHERS = _searchers()

MULTI_STE: dict[str, Any] = {
    "stride": 8,
    "model": {
        "reading": "detection",
        "spread": "diffusion",
        "K": 0.3,
        "sigma0": 0.3,
        "noise_std": 1.0,
        "relative_noise": 1.0,
        "miss": 0.2,
        "false_alarm": 0.005,
    },
    "estimator": {
        "n_particles": 1500,
        "max_sources": 4,
        "min_sources": 1,
        "source_count": "poisson",
        "source_count_mean": 1.0,
        "rate": {"type": "log-uniform", "low": 1.0, "high": 1000.0},
        "dispersion": {"type": "log-uniform", "low": 0.3, "high": 3.0},
        "wind_average": 8,
    },
}
"""The multi-source posterior fed a D-S flight's readings: every ``stride``-th reading (4 s; the
flights last over an hour), binary detections of a Gaussian plume of unknown dispersion, with
the intermittency of a filament plume read as a 20 % chance of missing the signal and noise as
large as the signal (``relative_noise`` 1); up to four sources under a Poisson(1) count prior
(the parsimony that keeps a source per detection streak out)."""


# ---------------------------------------------------------------------- truth-aware columns
def score_posterior(snap: dict[str, np.ndarray], truth: np.ndarray, rate: float) -> dict[str, Any]:
    """Columns of a final single-source posterior snapshot against the true source ``truth``
    ``(d,)`` and release ``rate``: the error of the mean, the rate-error factor, coverage of the
    95 % region and interval, and the PIT values (posterior probability below the truth)."""
    from odorloc.inference.source_terms import SourceTermBelief

    b = SourceTermBelief.from_snapshot(snap)
    region = b.credible_region(0.95)
    w = b.weights
    lq = b.theta[:, b.layout.log_rate_column(0)]
    out: dict[str, Any] = {
        "true_rate": float(rate),
        "pos_error": float(np.linalg.norm(b.mean - truth)),
        "rate_factor": float(math.exp(abs(float(w @ lq) - math.log(rate)))),
        "covered_position": region.contains(truth),
        "covered_rate": region.contains_rate(rate),
        "pit_rate": float(w @ (lq < math.log(rate))),
    }
    for a, v in zip("xyz", truth, strict=False):
        out[f"pit_{a}"] = float(w @ (b.positions[:, "xyz".index(a)] < v))
    return out


def _ran(df: Any, scenarios: tuple[str, ...]) -> bool:
    """Whether the results hold an episode of any of ``scenarios``."""
    return bool(len(df)) and "scenario" in df and bool(df["scenario"].isin(scenarios).any())


def _multi_columns(sc: Any, res: Any, seed: int) -> dict[str, Any]:
    """The D-S map's and the multi-source posterior's source sets against the truth."""
    from odorloc.geometry.point_sets import earth_movers_distance, match_sources
    from odorloc.inference.source_terms import SourceTermEstimator, SourceTermParams
    from odorloc.models.source_term import GaussianSourceTermModel, GaussianSourceTermParams
    from odorloc.replay.recorded import recording_observations
    from odorloc.scenarios.build import build, search_context

    true = np.asarray(res.sources, float)[:, :2]
    radius = sc.task.success_radius
    m = res.metrics
    k = int(m.get("mapped_sources", 0) or 0)
    ds = np.array([[m[f"mapped_x_{i}"], m[f"mapped_y_{i}"]] for i in range(k)]).reshape(-1, 2)
    stride = int(MULTI_STE["stride"])
    ctx = search_context(sc, build(sc))
    ctx = dataclasses.replace(ctx, dt=ctx.dt * stride)
    est = SourceTermEstimator(SourceTermParams(**MULTI_STE["estimator"]))
    model = GaussianSourceTermModel(GaussianSourceTermParams(**MULTI_STE["model"]))
    est.reset(ctx, model, np.random.default_rng(seed))
    for o in recording_observations(res.recording, 0, stride):
        est.update(o)
    found = est.sources()
    ste = np.zeros((0, 2)) if found is None else found.positions[:, :2]
    out: dict[str, Any] = {"true_sources": len(true)}
    for tag, pts in (("ds", ds), ("ste", ste)):
        hit, false = match_sources(pts, true, radius)
        out.update(
            {
                f"{tag}_emd": earth_movers_distance(pts, true),
                f"{tag}_found": hit,
                f"{tag}_false": false,
                f"{tag}_count": len(pts),
            }
        )
    for i, p in enumerate(ste[:8]):
        out[f"ste_x_{i}"], out[f"ste_y_{i}"] = float(p[0]), float(p[1])
    if found is not None:
        pk = found.count_probability
        out["ste_count_prob"] = float(pk[len(true)]) if len(true) < len(pk) else 0.0
    return out


def _label(task: Any) -> str:
    return str(task.cell.get("searcher_label", task.cell.get("searcher")))


def _run(task: Any) -> dict[str, Any]:
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import ROW_DEFAULTS, cell_scenario

    t0 = time.perf_counter()
    row = dict(ROW_DEFAULTS)
    try:
        sc = cell_scenario(task.cell)
        rc = sc.recording.model_copy(update={"plume_stride": 10**9, "belief_stride": 10**9})
        res = run_episode(
            sc.model_copy(update={"recording": rc}), task.world_seed, task.agent_seed, record=True
        )
        row.update(res.metrics)
        row.update(status="ok", error="")
        row.update(_multi_columns(sc, res, task.agent_seed))
    except Exception as exc:  # one bad episode must not stop the group
        row = dict(ROW_DEFAULTS)
        row.update(status="error", error=f"{type(exc).__name__}: {exc}")
        row["traceback"] = traceback.format_exc()
    row["wall_time"] = time.perf_counter() - t0
    return row


def ste_group(tasks: list[Any]) -> list[dict[str, Any]]:
    """Run the D-S flights of one flow live (one searcher per flow: no movie is needed) with
    the multi-source columns (module docstring)."""
    return [_run(t) for t in tasks]


def truth_columns(df: Any, out: Path | None) -> Any:
    """``df`` with the columns that need the truth (:func:`score_posterior`) for the search
    and calibration episodes whose recording the stores in ``out`` keep: the final posterior
    snapshot, and the source and rate drawn with the episode's world seed."""
    import json

    import pandas as pd

    from odorloc.engine.episode import prepare_world
    from odorloc.engine.recorder import Recording
    from odorloc.experiments.runner import cell_scenario
    from odorloc.experiments.store import ResultStore

    if out is None or "sweep" not in df or not len(df):
        return df
    extra: dict[int, dict[str, Any]] = {}
    for sweep in ("search", "calibration"):
        path = Path(out) / f"{sweep}.sqlite"
        if not path.is_file():
            continue
        with ResultStore(path, readonly=True) as store:
            for i, r in df[(df.sweep == sweep) & (df.status == "ok")].iterrows():
                arrays = store.arrays(str(r.cell_id), int(r.episode))
                if arrays is None:
                    continue
                snaps = [s for _, s in Recording.from_arrays(arrays).beliefs if "theta" in s]
                if not snaps:
                    continue
                sc = cell_scenario(json.loads(r.cell))
                src = prepare_world(sc, int(r.world_seed))[0].plume.sources[0]
                extra[i] = score_posterior(snaps[-1], np.asarray(src.position), src.rate)
    if not extra:
        return df
    return df.join(pd.DataFrame.from_dict(extra, orient="index"))


# ---------------------------------------------------------------------- tables
def _num(g: Any, col: str) -> np.ndarray:
    import pandas as pd

    if col not in g:
        return np.zeros(0)
    v = pd.to_numeric(g[col], errors="coerce").to_numpy(float)
    return v[np.isfinite(v)]


def _frac(g: Any, col: str) -> str:
    if col not in g:
        return f"0/{len(g)}"
    v = g[col].astype("boolean").fillna(False)
    return f"{int(v.sum())}/{len(g)}"


def _med(x: np.ndarray, d: int = 1) -> str:
    return fmt(float(np.median(x)) if len(x) else math.nan, d)


def _mean_sd(x: np.ndarray, d: int = 1) -> str:
    if not len(x):
        return "-"
    sd = float(np.std(x, ddof=1)) if len(x) > 1 else 0.0
    return f"{fmt(float(np.mean(x)), d)} ± {fmt(sd, d)}"


def _search_table(df: Any) -> Table:
    rows = []
    for scen in SEARCH_SCENARIOS:
        for label in SEARCHERS:
            g = df[(df.scenario == scen) & (df.searcher == label) & (df.status == "ok")]
            if not len(g):
                continue
            ok = g[g.success.astype("boolean").fillna(False)] if "success" in g else g[:0]
            rows.append(
                [
                    scen.removeprefix("ste-"),
                    label,
                    str(len(g)),
                    _frac(g, "success"),
                    _med(_num(ok, "search_time"), 0),
                    _med(_num(g, "pos_error"), 2),
                    _med(_num(g, "rate_factor"), 2),
                    _frac(g, "covered_position"),
                    _frac(g, "covered_rate"),
                ]
            )
    return Table(
        "search",
        "Searches over the source-term posterior (medians over episodes)",
        ["world", "method", "n", "success", "time s", "pos err m", "rate ×", "cov pos", "cov q"],
        rows,
        left=2,
        note="success: declared within the success radius; time: of the successes; pos err: "
        "final posterior mean; rate ×: exp|log q̂ - log q|; cov: the final 95 % region / rate "
        "interval contains the truth",
    )


def _calibration_table(df: Any) -> Table:
    from odorloc.experiments.stats import wilson_interval

    g = df[(df.scenario == CALIBRATION) & (df.status == "ok")]
    rows = []
    both = None
    if "covered_position" in g and "covered_rate" in g:
        both = g.covered_position.astype("boolean").fillna(False) & g.covered_rate.astype(
            "boolean"
        ).fillna(False)
    for name, col in (
        ("position, 95 % HPD region", "covered_position"),
        ("release rate, 95 % interval", "covered_rate"),
        ("both", None),
    ):
        if col is None:
            k = int(both.sum()) if both is not None else 0
        else:
            k = int(g[col].astype("boolean").fillna(False).sum()) if col in g else 0
        n = len(g)
        lo, hi = wilson_interval(k, n) if n else (math.nan, math.nan)
        rate = 100.0 * k / n if n else math.nan
        rows.append([name, f"{k}/{n}", fmt(rate, 1), f"[{fmt(100 * lo, 1)}, {fmt(100 * hi, 1)}]"])
    return Table(
        "calibration",
        "Calibration: the truth inside the posterior's 95 % regions (ste-calibration)",
        ["region", "covered", "%", "Wilson 95 % CI"],
        rows,
        note=f"median readings {_med(_num(g, 'readings'), 0)}, median region radius "
        f"{_med(_num(g, 'region_radius'), 2)} m, median position error "
        f"{_med(_num(g, 'pos_error'), 2)} m; target: 90-98 % of episodes",
    )


def _multi_table(df: Any) -> Table:
    rows = []
    for scen in MULTI_SCENARIOS:
        g = df[(df.scenario == scen) & (df.status == "ok")]
        if not len(g):
            continue
        n_true = _med(_num(g, "true_sources"), 0)
        for tag, name in (("ds", "D-S map"), ("ste", "STE posterior")):
            rows.append(
                [
                    scen.removeprefix("ste-").removesuffix("-farrell"),
                    name,
                    str(len(g)),
                    _mean_sd(_num(g, f"{tag}_emd"), 2),
                    f"{_mean_sd(_num(g, f'{tag}_found'), 1)} / {n_true}",
                    _mean_sd(_num(g, f"{tag}_false"), 1),
                    _mean_sd(_num(g, f"{tag}_count"), 1),
                ]
            )
    return Table(
        "multi",
        "Several sources: the D-S map and the STE posterior on the same flights",
        ["world", "method", "n", "EMD m", "found / true", "false", "sources"],
        rows,
        left=2,
        note="EMD: Earth Mover's Distance between the mapped / estimated source set and the "
        "truth (equal masses); found: true sources matched within the success radius (one to "
        "one); false: the other mapped sources. Both use the ds-mapping flight's readings.",
    )


# ---------------------------------------------------------------------- figures
def _marginal_figure(df: Any, path: Path) -> None:
    import json

    from odorloc.engine.episode import prepare_world, run_episode
    from odorloc.experiments.runner import cell_scenario
    from odorloc.viz.source_terms import plot_posterior_marginals

    scen, label = FIGURE_CELL
    g = df[(df.scenario == scen) & (df.searcher == label) & (df.episode == 0)]
    if not len(g) or "cell" not in g:
        _blank(path, f"no episode 0 of {scen} / {label}")
        return
    r = g.iloc[0]
    # the stored episode again, with a posterior snapshot every other second
    sc = cell_scenario(json.loads(r.cell))
    rc = sc.recording.model_copy(update={"belief_stride": 2, "plume_stride": 10**9})
    res = run_episode(sc.model_copy(update={"recording": rc}), int(r.world_seed), int(r.agent_seed))
    src = prepare_world(sc, int(r.world_seed))[0].plume.sources[0]
    wind = np.asarray(sc.world.wind.values["velocity"], float)
    truth = {
        "x": float(src.position[0]),
        "y": float(src.position[1]),
        "log_rate": float(src.rate),
        "speed": float(np.hypot(wind[0], wind[1])),
        "direction": math.degrees(math.atan2(wind[1], wind[0])),
    }
    assert res.recording is not None
    plot_posterior_marginals(
        res.recording.beliefs,
        path,
        truth,
        title=f"{scen}, {label}, episode 0 ({res.metrics['termination']} at "
        f"{res.metrics['search_time']:.0f} s): posterior marginals (blue: density per time)",
    )


def _blank(path: Path, text: str) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 2))
    ax.axis("off")
    ax.text(0.5, 0.5, text, ha="center", va="center")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _pit_figure(df: Any, path: Path) -> None:
    from odorloc.viz.source_terms import plot_pit_histograms

    g = df[(df.scenario == CALIBRATION) & (df.status == "ok")]
    pits = {name: _num(g, f"pit_{name}") for name in ("x", "y", "rate")}
    plot_pit_histograms(
        pits, path, title=f"ste-calibration, {len(g)} episodes: truth's rank in the posterior"
    )


def _multi_figure(df: Any, path: Path) -> None:
    import matplotlib.pyplot as plt

    from odorloc.experiments.runner import cell_scenario

    fig, axes = plt.subplots(1, len(MULTI_SCENARIOS), figsize=(5.2 * len(MULTI_SCENARIOS), 6.0))
    for ax, scen in zip(np.atleast_1d(axes), MULTI_SCENARIOS, strict=True):
        sc = cell_scenario({"scenario": scen})
        (x0, y0), (x1, y1) = sc.task.region
        ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="gold", lw=2))
        true = np.array([s.position for s in sc.world.sources])
        ax.plot(true[:, 0], true[:, 1], "*", color="red", mec="k", ms=16, label="true source")
        g = df[(df.scenario == scen) & (df.episode == 0) & (df.status == "ok")]
        if len(g):
            r = g.iloc[0]
            k = int(r.get("mapped_sources", 0) or 0)
            ds = [(r.get(f"mapped_x_{i}"), r.get(f"mapped_y_{i}")) for i in range(k)]
            ste = [(r.get(f"ste_x_{i}"), r.get(f"ste_y_{i}")) for i in range(8)]
            for pts, mk, col, lab in (
                (ds, "s", "tab:blue", "D-S map"),
                (ste, "X", "tab:orange", "STE posterior"),
            ):
                a = np.array([p for p in pts if np.all(np.isfinite(np.asarray(p, float)))], float)
                if len(a):
                    ax.plot(a[:, 0], a[:, 1], mk, color=col, mec="k", ms=10, label=lab)
        ax.set_xlim(x0 - 1, x1 + 1)
        ax.set_ylim(y0 - 1, y1 + 1)
        ax.set_aspect("equal")
        ax.set_title(f"{scen}, flow 0", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


@register("reproduction", "source-terms", ReproductionParams, "source-term estimation searches")
class SourceTermsReproduction(Reproduction):
    """Searches over a source-term posterior, calibration, and several sources (module
    docstring)."""

    name = "source-terms"
    paper = "Park & Oh RA-L 2022; Hutchinson et al. 2018; Sensors 2023 23(10) 4799"
    citations = CITATIONS
    summary = "source-term searches, 95 % coverage, several sources beside the D-S map"
    default_episodes = 6
    paper_episodes = 200
    paper_episodes_note = (
        "the calibration runs its 200 episodes by default; --episodes N sets every sweep to "
        "N, and --only calibration runs that sweep alone"
    )
    report_paired = False
    cell_summary = False
    success_label = "a declared position within the scenario's success radius"

    def __init__(self, params: ReproductionParams | None = None, time_limit: float | None = None):
        super().__init__(params)
        self.time_limit = check_time_limit(time_limit)
        self._out: Path | None = None
        self._cache: tuple[Any, Any] | None = None

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        n = {"search": 6, "calibration": 200, "multi": 1}
        if episodes is not None:
            n = dict.fromkeys(n, int(episodes))
        multi: dict[str, Any] = {}
        if self.time_limit is not None:
            multi["limits.time"] = float(self.time_limit)
        return {
            "search": {
                "name": "source-terms search",
                "seed": seed,
                "episodes": n["search"],
                "keep_arrays": True,
                "scenarios": [{"name": s} for s in SEARCH_SCENARIOS],
                "searchers": [
                    {"name": "ste-search", "label": k, "params": v} for k, v in SEARCHERS.items()
                ],
            },
            "calibration": {
                "name": "source-terms calibration",
                "seed": seed,
                "episodes": n["calibration"],
                "keep_arrays": True,
                "scenarios": [{"name": CALIBRATION}],
                "searchers": [{"name": "ste-search", "label": "lawnmower-route"}],
            },
            "multi": {
                "name": "source-terms several sources",
                "seed": seed,
                "episodes": n["multi"],
                "replay": True,
                "scenarios": [{"name": s, "params": multi} for s in MULTI_SCENARIOS],
                "searchers": [{"name": "ds-mapping"}],
            },
        }

    def run(self, out: Path, *args: Any, **kwargs: Any) -> Any:
        """:meth:`Reproduction.run`, remembering ``out``: the tables read the final posteriors
        from its stores (:func:`truth_columns`)."""
        self._out = Path(out)
        return super().run(out, *args, **kwargs)

    def group_fn(self) -> Any:
        return ste_group

    def tables(self, df: Any, seed: int) -> list[Table]:
        if not len(df) or "scenario" not in df:
            return []
        df = self._scored(df, self._out)
        # the tables of the sweeps that ran (`--only` runs some): no empty table
        parts = [
            (SEARCH_SCENARIOS, _search_table),
            ((CALIBRATION,), _calibration_table),
            (MULTI_SCENARIOS, _multi_table),
        ]
        return [table(df) for names, table in parts if _ran(df, names)]

    def _scored(self, df: Any, out: Path | None) -> Any:
        """:func:`truth_columns` once per result frame (the tables and figures share it)."""
        key = (id(df), len(df), str(out))
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, truth_columns(df, out))
        return self._cache[1]

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        df = self._scored(df, out) if len(df) and "scenario" in df else df
        figures = [
            Figure(
                "posterior_marginals.png",
                "Posterior marginals of position, release rate and wind over one ste-gaussian "
                "episode (entrotaxis, 8 directions)",
                lambda p: _marginal_figure(df, p),
            ),
            Figure(
                "calibration_pit.png",
                "Calibration: the truth's posterior rank (PIT) over the ste-calibration episodes",
                lambda p: _pit_figure(df, p),
            ),
            Figure(
                "several_sources.png",
                "Several sources, flow 0: D-S mapped sources and the STE posterior's",
                lambda p: _multi_figure(df, p),
            ),
        ]
        # the figures of the sweeps that ran (`--only` runs some): no empty figure
        ran = [(FIGURE_CELL[0],), (CALIBRATION,), MULTI_SCENARIOS]
        return [f for f, names in zip(figures, ran, strict=True) if _ran(df, names)]
