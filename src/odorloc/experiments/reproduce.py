"""Reproductions of the papers' headline comparisons in odorloc's own simulator.

Each reproduction is a sweep (stored, resumable) plus the paper's reference numbers, a printed
side-by-side table, the paper's figures and an HTML report. Absolute numbers differ from the
papers (our simulator is not theirs); what must hold is the ordering of the methods, the
ballpark and the paper's own success criteria.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.errors import ConfigError


@dataclass(frozen=True)
class Reproduction:
    """A registered paper reproduction."""

    name: str
    paper: str
    summary: str
    run: Callable[..., dict[str, Any]]


_REPRODUCTIONS: dict[str, Reproduction] = {}


def _register(name: str, paper: str, summary: str) -> Callable[[Callable[..., Any]], Any]:
    def deco(fn: Callable[..., dict[str, Any]]) -> Callable[..., dict[str, Any]]:
        _REPRODUCTIONS[name] = Reproduction(name, paper, summary, fn)
        return fn

    return deco


def names() -> list[str]:
    """Registered reproduction names."""
    _load()
    return sorted(_REPRODUCTIONS)


def get(name: str) -> Reproduction:
    """A reproduction by name; :class:`ConfigError` naming it if unknown."""
    _load()
    if name not in _REPRODUCTIONS:
        raise ConfigError("paper", f"unknown reproduction {name!r} (known: {', '.join(names())})")
    return _REPRODUCTIONS[name]


def _load() -> None:
    from odorloc.experiments import reproduce_ds  # noqa: F401


# ============================================================================ indoor PF paper
#: Table 1 of the indoor PF paper (simulation): start -> (mean time s, success rate, n).
INDOOR_TABLE1 = {
    2: {"start": (2.15, 3.60), "mean_time": 110.0, "success_rate": 0.94, "n": 50},
    4: {"start": (2.40, 4.55), "mean_time": 120.0, "success_rate": 0.90, "n": 50},
}


def table1_wall_time(workers: int = 2, episodes: int = 50, out: Path | None = None) -> float:
    """Wall time (s) of the Table 1 run: 2 starts x ``episodes`` PF episodes on ``workers``."""
    import tempfile
    import time

    from odorloc.experiments.sweep import run_sweep

    spec = {
        "name": "indoor table 1",
        "seed": 2024,
        "episodes": episodes,
        "scenarios": [{"name": "indoor-ventilated", "grid": {"start_index": [2, 4]}}],
        "searchers": [{"name": "pf-entropy"}],
    }
    with tempfile.TemporaryDirectory() as d:
        store = Path(out or d) / "table1.sqlite"
        t0 = time.perf_counter()
        run_sweep(spec, store, workers=workers, progress=False)
        return time.perf_counter() - t0


def indoor_table1() -> float:
    """Hook for ``benchmarks/pf_speed.py``: the Table 1 wall time on 2 workers."""
    return table1_wall_time(workers=2)


#: The paper's convergence test read literally: weighted variance (trace, m^2) <= 0.5 and all
#: last 20 estimates within 0.5 m of their mean. The default ``pf-entropy`` uses the RMS radius
#: and a 0.25 m estimate circle instead (see its docstring); both are reported side by side.
PF_LITERAL = "pf-entropy-literal"
PF_LITERAL_PARAMS = {"variance": "trace", "r_err": 0.5}
INDOOR_METHODS = ("pf-entropy", PF_LITERAL, "gradient-bionic")


def _fmt(x: float, d: int = 1) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{d}f}"


@_register(
    "indoor-pf-entropy",
    "indoor-pf-entropy.txt",
    "Table 1 and Fig. 8: PF + entropy vs gradient-bionic hybrid in the ventilated room",
)
def reproduce_indoor(
    out: Path,
    episodes: int = 50,
    workers: int = 2,
    seed: int = 2024,
    progress: bool = True,
) -> dict[str, Any]:
    """Run the indoor reproduction; write table, figures and report into ``out``."""
    from rich.console import Console
    from rich.table import Table

    from odorloc.experiments import stats
    from odorloc.experiments.report import write_report
    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import run_sweep

    out.mkdir(parents=True, exist_ok=True)
    console = Console(width=150)
    spec = {
        "name": "indoor-pf-entropy reproduction",
        "seed": seed,
        "episodes": episodes,
        "keep_arrays": False,
        "scenarios": [{"name": "indoor-ventilated", "grid": {"start_index": [0, 1, 2, 3, 4]}}],
        "searchers": [
            {"name": "pf-entropy"},
            {"name": "pf-entropy", "label": PF_LITERAL, "params": PF_LITERAL_PARAMS},
            {"name": "gradient-bionic"},
        ],
    }
    store_path = out / "results.sqlite"
    df = run_sweep(spec, store_path, workers=workers, progress=progress)
    summ = stats.summarize(df, seed=seed)
    summ["start_index"] = summ["scenario.start_index"].astype(int)

    def cell(idx: int, method: str) -> Any:
        return summ[(summ.start_index == idx) & (summ.searcher == method)].iloc[0]

    def rate(r: Any) -> str:
        return f"{100 * r.success_rate:.0f} [{100 * r.success_lo:.0f}, {100 * r.success_hi:.0f}]"

    # ---- Table 1 side by side with the paper
    t = Table(title="Indoor PF + entropy: Table 1 (simulation), ours vs paper")
    for col in (
        "start",
        "method",
        "n",
        "success % [95 % CI]",
        "paper success %",
        "mean time s [95 % CI]",
        "paper time s",
        "mean error m",
    ):
        t.add_column(col, justify="right")
    for idx, ref in INDOOR_TABLE1.items():
        for method in INDOOR_METHODS:
            r = cell(idx, method)
            is_pf = method == "pf-entropy"
            t.add_row(
                f"({ref['start'][0]:.2f}, {ref['start'][1]:.2f})",
                method,
                str(int(r.n)),
                rate(r),
                f"{100 * ref['success_rate']:.0f}" if is_pf else "-",
                f"{_fmt(r.mean_time)} [{_fmt(r.mean_time_lo)}, {_fmt(r.mean_time_hi)}]",
                f"{ref['mean_time']:.0f}" if is_pf else "-",
                _fmt(r.mean_loc_error, 2),
            )
    console.print(t)

    # ---- Fig. 8: by start distance
    f8 = Table(title="Fig. 8: success % [95 % CI] and mean time of successes (s) vs start distance")
    f8.add_column("start", justify="right")
    f8.add_column("distance m", justify="right")
    for method in INDOOR_METHODS:
        f8.add_column(f"{method} success", justify="right")
        f8.add_column(f"{method} time", justify="right")
    for idx in range(5):
        cells = [cell(idx, m) for m in INDOOR_METHODS]
        row = [str(idx), _fmt(cells[0].mean_start_distance, 2)]
        for r in cells:
            row += [rate(r), _fmt(r.mean_time)]
        f8.add_row(*row)
    console.print(f8)
    paired = stats.compare_searchers(df, seed=seed)
    figs = _indoor_figures(summ, out)
    figs += _indoor_episode_figures(out, seed)
    reference = {
        f"indoor-ventilated[start_index={i}]/pf-entropy": {
            "success_rate": ref["success_rate"],
            "mean_time": ref["mean_time"],
            "source": "Table 1",
        }
        for i, ref in INDOOR_TABLE1.items()
    }
    with ResultStore(store_path, readonly=True) as store:
        store.to_csv(out / "results.csv")
        store.to_parquet(out / "results.parquet")
        report = write_report(
            store, out / "report.html", title="indoor-pf-entropy reproduction", reference=reference
        )
    summ.to_csv(out / "summary.csv", index=False)
    paired.to_csv(out / "paired.csv", index=False)
    for p in [*figs, report]:
        console.print(f"wrote {p}")
    return {"summary": summ, "paired": paired, "figures": figs, "report": report}


def _indoor_figures(summ: Any, out: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    styles = {
        "pf-entropy": ("tab:red", "o", "PF + entropy"),
        PF_LITERAL: ("tab:orange", "^", "PF + entropy, paper-literal convergence"),
        "gradient-bionic": ("tab:blue", "s", "gradient-bionic hybrid"),
    }
    for searcher, (col, mk, label) in styles.items():
        g = summ[summ.searcher == searcher].sort_values("mean_start_distance")
        d = g.mean_start_distance.to_numpy()
        axes[0].errorbar(
            d,
            g.mean_time,
            yerr=[g.mean_time - g.mean_time_lo, g.mean_time_hi - g.mean_time],
            color=col,
            marker=mk,
            capsize=3,
            label=label,
        )
        axes[1].errorbar(
            d,
            100 * g.success_rate,
            yerr=[100 * (g.success_rate - g.success_lo), 100 * (g.success_hi - g.success_rate)],
            color=col,
            marker=mk,
            capsize=3,
            label=label,
        )
    for i, ref in INDOOR_TABLE1.items():
        dist = float(np.hypot(*ref["start"]))
        axes[0].plot(dist, ref["mean_time"], "k*", ms=11, label="paper Table 1" if i == 2 else None)
        axes[1].plot(
            dist, 100 * ref["success_rate"], "k*", ms=11, label="paper Table 1" if i == 2 else None
        )
    axes[0].set_xlabel("start distance to source (m)")
    axes[0].set_ylabel("mean search time of successes (s)")
    axes[1].set_xlabel("start distance to source (m)")
    axes[1].set_ylabel("success rate (%)")
    axes[1].set_ylim(0, 105)
    axes[1].axhline(90, color="0.6", ls=":", lw=1)
    for ax in axes:
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle("Indoor ventilated room: search time and success vs start distance (95 % CI)")
    fig.tight_layout()
    p = out / "fig8_time_success_vs_distance.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return [p]


def _indoor_episode_figures(out: Path, seed: int) -> list[Path]:
    """Particle snapshots, entropy curve and traces of one PF episode from the farthest start."""
    import matplotlib.pyplot as plt

    from odorloc.engine.episode import run_episode, seeds_for
    from odorloc.experiments.runner import cell_scenario
    from odorloc.viz.episode import plot_traces

    sc = cell_scenario({"scenario": "indoor-ventilated", "scenario_params": {"start_index": 4}})
    sc = sc.model_copy(update={"recording": sc.recording.model_copy(update={"belief_stride": 1})})
    res = None
    for ep in range(10):  # the first successful episode illustrates the method best
        res = run_episode(sc, *seeds_for(seed, ep), record=True)
        if res.metrics["success"]:
            break
    assert res is not None and res.recording is not None
    rec = res.recording
    rec.meta.update(searcher="pf-entropy")
    paths = []
    beliefs = [(t, b) for t, b in rec.beliefs if "positions" in b]
    if beliefs:
        picks = [beliefs[0], beliefs[len(beliefs) // 2], beliefs[-1]]
        names_ = [
            "at first detection",
            "mid-search",
            "at declaration" if res.metrics["declared"] else "at the end",
        ]
        fig, axes = plt.subplots(1, 3, figsize=(9.5, 5.2), sharey=True)
        b = rec.arena_bounds
        for ax, (t, snap), nm in zip(axes, picks, names_, strict=True):
            k = int(np.searchsorted(rec.t, t, side="right"))
            w = snap["weights"]
            sca = ax.scatter(
                snap["positions"][:, 0],
                snap["positions"][:, 1],
                c=w / w.max(),
                s=5,
                cmap="cool",
                vmin=0,
                vmax=1,
                zorder=3,
            )
            ax.plot(
                rec.positions[:k, 0, 0],
                rec.positions[:k, 0, 1],
                "-",
                color="tab:green",
                lw=1.5,
                label="robot path",
                zorder=4,
            )
            ax.plot(*rec.positions[k - 1, 0, :2], "o", color="tab:green", mec="k", zorder=5)
            ax.plot(
                *rec.sources[0, :2],
                "*",
                color="gold",
                mec="k",
                ms=15,
                label="true source",
                zorder=6,
            )
            mean = (w[:, None] * snap["positions"]).sum(0) / w.sum()
            ax.plot(*mean[:2], "X", color="red", mec="k", ms=11, label="estimate", zorder=6)
            ax.set_xlim(b[0, 0], b[1, 0])
            ax.set_ylim(b[0, 1], b[1, 1])
            ax.set_aspect("equal")
            ax.set_title(f"{nm}: t = {t:.1f} s")
            ax.set_xlabel("x (m)")
        axes[0].set_ylabel("y (m)")
        axes[0].legend(fontsize=7, loc="upper left")
        fig.colorbar(sca, ax=axes, shrink=0.7, label="particle weight / max")
        p = out / "particle_snapshots.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
    if "entropy" in rec.diagnostics:
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        ax.plot(rec.t, rec.diagnostics["entropy"], color="tab:purple")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("posterior entropy (nats)")
        ax.set_title("Information entropy of the source posterior over one episode")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        p = out / "entropy_curve.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
    p = out / "traces.png"
    plot_traces(rec, p)
    paths.append(p)
    return paths
