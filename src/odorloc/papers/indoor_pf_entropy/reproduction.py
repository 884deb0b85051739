"""``odorloc reproduce indoor-pf-entropy``: Table 1 and Fig. 8 of the indoor PF paper.

Five start points x three methods x ``episodes``: the PF + entropy searcher with the default
convergence reading, the same searcher with the paper's test read literally
(``pf-entropy-literal``: weighted variance as a trace <= 0.5 and a 0.5 m estimate circle), and the
gradient-bionic hybrid baseline, in the ``indoor-ventilated`` room. Common random numbers: episode
``i`` of every method at a start faces the same plume.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.core.seeds import episode_seeds
from odorloc.experiments.reproduction import (
    Figure,
    Reproduction,
    ReproductionParams,
    Table,
    fmt,
)
from odorloc.papers.indoor_pf_entropy.reference import TABLE1
from odorloc.viz.intervals import errorbar_lengths

__all__ = ["PF_LITERAL", "PF_LITERAL_PARAMS", "IndoorReproduction", "table1_wall_time"]

SCENARIO = "indoor-ventilated"
#: The paper's convergence test read literally (see ``PFEntropyParams``).
PF_LITERAL = "pf-entropy-literal"
PF_LITERAL_PARAMS = {"variance": "trace", "r_err": 0.5}
METHODS = ("pf-entropy", PF_LITERAL, "gradient-bionic")


def _world_key(start_index: int) -> str:
    return f"{SCENARIO}[start_index={start_index}]"


def table1_wall_time(workers: int = 2, episodes: int = 50, out: Path | None = None) -> float:
    """Wall time (s) of the Table 1 run: 2 starts x ``episodes`` PF episodes on ``workers``."""
    import tempfile
    import time

    from odorloc.experiments.sweep import run_sweep

    spec = {
        "name": "indoor table 1",
        "seed": 2024,
        "episodes": episodes,
        "scenarios": [{"name": SCENARIO, "grid": {"start_index": [2, 4]}}],
        "searchers": [{"name": "pf-entropy"}],
    }
    with tempfile.TemporaryDirectory() as d:
        store = Path(out or d) / "table1.sqlite"
        t0 = time.perf_counter()
        run_sweep(spec, store, workers=workers, progress=False)
        return time.perf_counter() - t0


@register("reproduction", "indoor-pf-entropy", ReproductionParams, "Table 1 and Fig. 8")
class IndoorReproduction(Reproduction):
    """PF + entropy vs the gradient-bionic hybrid in the ventilated room (Table 1, Fig. 8)."""

    name = "indoor-pf-entropy"
    paper = "indoor-pf-entropy.txt"
    summary = "Table 1 and Fig. 8: PF + entropy vs gradient-bionic hybrid in the ventilated room"
    default_episodes = 50
    paper_episodes = 50

    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        return {
            "name": "indoor-pf-entropy reproduction",
            "seed": seed,
            "episodes": episodes,
            "keep_arrays": False,
            "scenarios": [{"name": SCENARIO, "grid": {"start_index": [0, 1, 2, 3, 4]}}],
            "searchers": [
                {"name": "pf-entropy"},
                {"name": "pf-entropy", "label": PF_LITERAL, "params": PF_LITERAL_PARAMS},
                {"name": "gradient-bionic"},
            ],
        }

    def reference(self) -> dict[str, dict[str, Any]]:
        return {
            f"{_world_key(i)}/pf-entropy": {
                "success_rate": ref["success_rate"],
                "mean_time": ref["mean_time"],
                "source": "Table 1",
            }
            for i, ref in TABLE1.items()
        }

    @staticmethod
    def _summary(df: Any, seed: int) -> Any:
        from odorloc.experiments import stats

        summ = stats.summarize(df, seed=seed)
        summ["start_index"] = summ["scenario.start_index"].astype(int)
        return summ

    def tables(self, df: Any, seed: int) -> list[Table]:
        summ = self._summary(df, seed)

        def cell(idx: int, method: str) -> Any:
            sel = summ[(summ.start_index == idx) & (summ.searcher == method)]
            return sel.iloc[0] if len(sel) else None

        def rate(r: Any) -> str:
            if r is None:
                return "-"
            return f"{fmt(100 * r.success_rate, 0)} [{fmt(100 * r.success_lo, 0)}, " + (
                f"{fmt(100 * r.success_hi, 0)}]"
            )

        def mtime(r: Any, d: int = 0) -> str:
            if r is None:
                return "-"
            return f"{fmt(r.mean_time, d)} [{fmt(r.mean_time_lo, d)}, {fmt(r.mean_time_hi, d)}]"

        t1 = []
        for idx, ref in TABLE1.items():
            for method in METHODS:
                r = cell(idx, method)
                pf = method == "pf-entropy"
                t1.append(
                    [
                        f"({ref['start'][0]:.2f}, {ref['start'][1]:.2f})",
                        method,
                        str(int(r.n)) if r is not None else "0",
                        rate(r),
                        fmt(100 * ref["success_rate"], 0) if pf else "-",
                        mtime(r),
                        fmt(ref["mean_time"], 0) if pf else "-",
                        fmt(r.mean_loc_error, 2) if r is not None else "-",
                    ]
                )
        f8 = []
        for idx in range(5):
            cells = [cell(idx, m) for m in METHODS]
            dist = cells[0].mean_start_distance if cells[0] is not None else math.nan
            row = [str(idx), fmt(dist, 2)]
            for r in cells:
                row += [rate(r), fmt(r.mean_time) if r is not None else "-"]
            f8.append(row)
        head8 = ["start", "distance m"]
        for m in METHODS:
            head8 += [f"{m} success %", f"{m} time s"]
        return [
            Table(
                "table1",
                "Indoor PF + entropy: Table 1 (simulation), ours vs paper",
                [
                    "start",
                    "method",
                    "n",
                    "success % [CI]",
                    "paper %",
                    "time s [CI]",
                    "paper s",
                    "error m",
                ],
                t1,
                note="95 % intervals: Wilson for the success rate, bootstrap for the mean time of "
                "successful episodes; error m: mean localisation error",
                left=2,
            ),
            Table(
                "fig8",
                "Fig. 8: success % [95% CI] and mean time of successes (s) vs start distance",
                head8,
                f8,
                console=False,
            ),
        ]

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        summ = self._summary(df, seed)
        return [
            Figure(
                "fig8_time_success_vs_distance.png",
                "Search time and success rate against start distance (95 % intervals), paper "
                "Table 1 as stars",
                lambda p: _fig8(summ, p),
            ),
            Figure(
                "particle_snapshots.png",
                "Particles at the first detection, mid-search and the end of one PF episode "
                "from the farthest start",
                lambda p: _episode_figures(seed, p),
            ),
        ]


def _errorbar(center: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """Non-negative error-bar lengths (see :func:`odorloc.viz.intervals.errorbar_lengths`)."""
    return list(errorbar_lengths(center, lo, hi))


def _fig8(summ: Any, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    styles = {
        "pf-entropy": ("tab:red", "o", "PF + entropy"),
        PF_LITERAL: ("tab:orange", "^", "PF + entropy, paper-literal convergence"),
        "gradient-bionic": ("tab:blue", "s", "gradient-bionic hybrid"),
    }
    for searcher, (col, mk, label) in styles.items():
        g = summ[summ.searcher == searcher].sort_values("mean_start_distance")
        if not len(g):
            continue
        d = g.mean_start_distance.to_numpy()
        t = g.mean_time.to_numpy(float)
        axes[0].errorbar(
            d,
            t,
            yerr=_errorbar(t, g.mean_time_lo, g.mean_time_hi),
            color=col,
            marker=mk,
            capsize=3,
            label=label,
        )
        sr = 100 * g.success_rate.to_numpy(float)
        axes[1].errorbar(
            d,
            sr,
            yerr=_errorbar(sr, 100 * g.success_lo, 100 * g.success_hi),
            color=col,
            marker=mk,
            capsize=3,
            label=label,
        )
    for i, ref in TABLE1.items():
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
        ax.grid(alpha=0.3)
    # one legend below both panels: inside either one it hides points (the hybrid's success
    # rates and the paper's times sit where a corner legend would go)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
    fig.suptitle("Indoor ventilated room: search time and success vs start distance (95 % CI)")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _episode_figures(seed: int, path: Path) -> None:
    """Particle snapshots (``path``), entropy curve and traces of one PF episode of the sweep
    (the first successful one of the farthest start, episodes 0-9)."""
    import matplotlib.pyplot as plt

    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario
    from odorloc.viz.episode import plot_traces

    sc = cell_scenario({"scenario": SCENARIO, "scenario_params": {"start_index": 4}})
    sc = sc.model_copy(update={"recording": sc.recording.model_copy(update={"belief_stride": 1})})
    res = None
    for ep in range(10):
        res = run_episode(sc, *episode_seeds(seed, _world_key(4), ep), record=True)
        if res.metrics["success"]:
            break
    assert res is not None and res.recording is not None
    rec = res.recording
    rec.meta.update(searcher="pf-entropy")
    beliefs = [(t, b) for t, b in rec.beliefs if "positions" in b]
    if not beliefs:
        raise RuntimeError("no particle belief recorded (the robot never detected)")
    picks = [beliefs[0], beliefs[len(beliefs) // 2], beliefs[-1]]
    names_ = [
        "at first detection",
        "mid-search",
        "at declaration" if res.metrics["declared"] else "at the end",
    ]
    fig, axes = plt.subplots(1, 3, figsize=(9.5, 5.2), sharey=True)
    b = rec.arena_bounds
    sca = None
    for ax, (t, snap), nm in zip(axes, picks, names_, strict=True):
        k = max(int(np.searchsorted(rec.t, t, side="right")), 1)
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
            *rec.sources[0, :2], "*", color="gold", mec="k", ms=15, label="true source", zorder=6
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
    fig.savefig(path, dpi=110)
    plt.close(fig)
    if "entropy" in rec.diagnostics:
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        ax.plot(rec.t, rec.diagnostics["entropy"], color="tab:purple")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("posterior entropy (nats)")
        ax.set_title("Information entropy of the source posterior over one episode")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(path.parent / "entropy_curve.png", dpi=110)
        plt.close(fig)
    plot_traces(rec, path.parent / "traces.png")
