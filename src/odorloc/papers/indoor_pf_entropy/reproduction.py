"""``odorloc reproduce indoor-pf-entropy``: Table 1 and Fig. 8 of the indoor PF paper.

Five start points x three methods x ``episodes``: the PF + entropy searcher with the default
convergence reading, the same searcher with the paper's test read literally
(``pf-entropy-literal``: weighted variance as a trace <= 0.5 and a 0.5 m estimate circle), and the
gradient-bionic hybrid baseline, in the ``indoor-ventilated`` room. Common random numbers: episode
``i`` of every method at a start faces the same plume. A third table gives the posterior entropy
of both PF methods at the first detection and at the end (the paper's Figs. 5 and 7 show it
falling), and the particle snapshots run one stored PF episode again with every belief recorded.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
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
#: The paper's convergence test read literally (see ``ParticleFilterParams.stopping``).
PF_LITERAL = "pf-entropy-literal"
PF_LITERAL_PARAMS = {"estimator": {"stopping": {"variance": "trace", "r_err": 0.5}}}
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
            Table(
                "entropy",
                "Posterior entropy (nats) at PF initialisation and at the end, ours vs paper",
                [
                    "start",
                    "method",
                    "n",
                    "start nats [CI]",
                    "end nats [CI]",
                    "fell % [CI]",
                    "paper",
                ],
                _entropy_rows(df, seed),
                note="Episodes whose filter started (the robot detected); start: the posterior "
                "at the first detection, end: when the episode ended; 95 % intervals: "
                "bootstrap for the means, Wilson for the share of episodes where it fell. The "
                "paper shows it falling (Figs. 5, 7, 15, 16) but gives no values",
                left=2,
            ),
        ]

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        summ = self._summary(df, seed)
        pick = snapshot_episode(df)
        which = (
            f"stored episode {pick[1]} of {pick[0]}"
            if pick is not None
            else "no stored PF episode of the farthest start"
        )
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
                f"from the farthest start ({which}, run again with every belief recorded)",
                lambda p: episode_figures(df, store.path, p),
            ),
        ]


def _fig8(summ: Any, path: Path) -> None:
    from odorloc.viz.backend import pyplot

    plt = pyplot()

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
            yerr=errorbar_lengths(t, g.mean_time_lo, g.mean_time_hi),
            color=col,
            marker=mk,
            capsize=3,
            label=label,
        )
        sr = 100 * g.success_rate.to_numpy(float)
        axes[1].errorbar(
            d,
            sr,
            yerr=errorbar_lengths(sr, 100 * g.success_lo, 100 * g.success_hi),
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


#: The searcher and start of the particle snapshots: the PF from the farthest start, as in the
#: paper's Figs. 13/14 (start 4 is (2.40, 4.55)).
SNAPSHOT_SEARCHER = "pf-entropy"
SNAPSHOT_START = 4
#: Bootstrap stream of the entropy table (apart from the per-cell streams of the summary).
_ENTROPY_STREAM = 8


def _entropy_rows(df: Any, seed: int) -> list[list[str]]:
    """Rows of the entropy table: both PF methods, over all starts and per start.

    Only episodes with both ``entropy_init`` and ``entropy_end`` finite count (the filter
    starts at the first detection), so start and end are means over the same episodes.

    Parameters
    ----------
    df : pandas.DataFrame
        Stored rows (``searcher``, ``status``, ``scenario.start_index`` and, when any PF
        episode ran its filter, ``entropy_init`` / ``entropy_end`` in nats).
    seed : int
        Root seed; the bootstrap draws from ``Generator([seed, stream, row])``.

    Returns
    -------
    list of list of str
        ``start, method, n, mean start [CI], mean end [CI], fell % [CI], paper`` per row.
    """
    from odorloc.experiments.stats import bootstrap_ci, wilson_interval

    rows = []
    have = {"searcher", "status", "scenario.start_index"} <= set(df.columns)
    j = 0
    for method in METHODS[:2]:
        for idx in ("all", *range(5)):
            if have:
                sel = df[(df["searcher"] == method) & (df["status"] != "error")]
                if idx != "all":
                    sel = sel[sel["scenario.start_index"].astype(float) == idx]
            else:
                sel = df.iloc[:0]
            h0, h1 = (
                (np.asarray(sel[c], float) if c in sel.columns else np.full(len(sel), np.nan))
                for c in ("entropy_init", "entropy_end")
            )
            both = np.isfinite(h0) & np.isfinite(h1)
            h0, h1 = h0[both], h1[both]
            n = int(both.sum())
            rng = np.random.default_rng([int(seed), _ENTROPY_STREAM, j])
            j += 1
            cells = []
            for h in (h0, h1):
                lo, hi = bootstrap_ci(h, rng)
                cells.append(f"{fmt(h.mean(), 2)} [{fmt(lo, 2)}, {fmt(hi, 2)}]" if n else "-")
            k = int((h1 < h0).sum())
            flo, fhi = wilson_interval(k, n)
            fell = f"{fmt(100 * k / n, 0)} [{fmt(100 * flo, 0)}, {fmt(100 * fhi, 0)}]" if n else "-"
            rows.append([str(idx), method, str(n), *cells, fell, "falls"])
    return rows


def snapshot_episode(df: Any) -> tuple[str, int] | None:
    """``(cell_id, episode)`` of the stored episode the particle snapshots show.

    The first stored success of :data:`SNAPSHOT_SEARCHER` from :data:`SNAPSHOT_START`, else
    its first stored episode that ran (drawn "at the end"); ``None`` if there is none.
    """
    need = {"searcher", "status", "scenario.start_index", "cell_id", "episode", "success"}
    if not need <= set(df.columns):
        return None
    sel = df[
        (df["searcher"] == SNAPSHOT_SEARCHER)
        & (df["status"] != "error")
        & (df["scenario.start_index"].astype(float) == SNAPSHOT_START)
    ].sort_values("episode")
    if not len(sel):
        return None
    won = sel[sel["success"].astype("boolean").fillna(False).astype(bool)]
    r = (won if len(won) else sel).iloc[0]
    return str(r["cell_id"]), int(r["episode"])


def episode_figures(df: Any, store: Path, path: Path) -> list[str]:
    """Particle snapshots (``path``), entropy curve and traces of one stored episode.

    The episode is :func:`snapshot_episode`'s pick among the stored rows ``df``: it is run
    once more with the seeds and cell its row holds (:mod:`odorloc.experiments.rerun`), now
    with every belief recorded, which the batch does not keep. No other episode runs.

    Parameters
    ----------
    df : pandas.DataFrame
        The reproduction's stored rows.
    store : path
        Its results store (``.sqlite``), which holds the episode's cell and seeds.
    path : path
        Where the snapshots go; ``entropy_curve.png`` and ``traces.png`` go beside it.

    Returns
    -------
    list of str
        The compared metrics in which the new run differs from the stored row (see
        :func:`~odorloc.experiments.rerun.differences`; empty when it repeated). They are
        also named on the figure.

    Raises
    ------
    RuntimeError
        No stored episode to draw, or one whose robot never detected.
    """
    from odorloc.viz.backend import pyplot

    plt = pyplot()

    from odorloc.experiments.rerun import differences, rerun, stored_episode
    from odorloc.viz.episode import plot_traces

    pick = snapshot_episode(df)
    if pick is None:
        raise RuntimeError(
            f"no stored {SNAPSHOT_SEARCHER} episode of start {SNAPSHOT_START} ran without error"
        )
    stored = stored_episode(store, *pick, field="store")
    _, res = rerun(stored, recording={"belief_stride": 1})
    changed = differences(stored, res.metrics)
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
    fig.suptitle(
        f"{stored.cell_id}, episode {stored.episode}"
        + (f" (differs from the stored row in {', '.join(changed)})" if changed else "")
    )
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
    return changed
