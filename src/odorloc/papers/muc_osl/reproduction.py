"""``odorloc reproduce muc-osl``: MUC-OSL against its three baselines on ``muc-osl-3d``.

Three UAVs in 100 x 60 x 30 m (source [10, 30, 25], wind towards -y), the four algorithms of the
paper (MUC-OSL, Col-Inf, Col-PF, Adap-PP: compositions of a per-UAV estimator and planner,
:mod:`odorloc.searchers.uav_team`), ``episodes`` runs each with common random numbers (episode
``i`` of every algorithm faces the same world and gives every UAV the same random stream), and
MUC-OSL without the upwind particle moves of eq. 16 (``muc-osl-no-env-pu``) as an ablation.

Tables: success rate and search time with intervals (the search time of an episode is the
flying + hovering + turning time of the first UAV within the reach radius, Sect. VI.1), the
team's movement as in Table 2 (hover time, turn time, distance, movement energy), the
computation and communication energy, and what one exchange carries (Table 3) with the bytes of
an episode. Figures: the paper's Fig. 3 (paths, cue points and particles at four moments of one
MUC-OSL episode), its animation, and the comparison with intervals.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.core.seeds import episode_seeds
from odorloc.experiments.reproduction import Figure, Reproduction, ReproductionParams, Table, fmt
from odorloc.papers.muc_osl.reference import ALGORITHMS, TABLE2, TABLE3

__all__ = ["MucOslReproduction", "add_uav_search_time", "record_episode"]

SCENARIO = "muc-osl-3d"
#: MUC-OSL without the upwind particle moves of eq. 16 (an ablation shown beside the four).
NO_ENV_PU = "muc-osl-no-env-pu"
NO_ENV_PU_PARAMS = {"estimator": {"type": "col-pf", "env_pu": "off"}}
LABELS = {
    "muc-osl": "MUC-OSL",
    "col-inf": "Col-Inf",
    "col-pf": "Col-PF",
    "adap-pp": "Adap-PP",
    NO_ENV_PU: "MUC-OSL -env",
}
#: Labels of the comparison figure's bars.
BAR_LABELS = {**LABELS, NO_ENV_PU: "MUC-OSL\nno env-pu"}
ROWS = (*ALGORITHMS, NO_ENV_PU)


#: Team metrics the tables and figures read (absent from a store of failed episodes).
TEAM_METRICS = (
    "reach_fly_time",
    "reach_hover_time",
    "reach_turn_time",
    "energy_fly",
    "energy_hover",
    "energy_turn",
    "energy_compute",
    "energy_comm",
    "team_hover_time",
    "team_turn_time",
)


def add_uav_search_time(df: Any, limit: float = 1200.0) -> Any:
    """Rows with ``uav_search_time``: flying + hovering + turning time (s) of the first UAV to
    reach the source (Sect. VI.1), ``limit`` for episodes where none did; and ``movement_kj``,
    the team's movement energy ``E_M`` (eqs. 4-6) in kJ."""
    out = df.copy()
    for name in TEAM_METRICS:
        # a store of failed episodes has none of the team's metrics: NaN, never a KeyError
        if name not in out:
            out[name] = math.nan
    busy = out["reach_fly_time"] + out["reach_hover_time"] + out["reach_turn_time"]
    reached = out["success"].fillna(False).astype(bool)
    out["uav_search_time"] = np.where(reached, busy, limit)
    out["movement_kj"] = (out["energy_fly"] + out["energy_hover"] + out["energy_turn"]) / 1e3
    return out


def _numbers_per_message(g: Any) -> float:
    cols = [c for c in g.columns if c.startswith("numbers_per_message")]
    sent = [c.replace("numbers_per_message", "messages_sent") for c in cols]
    tot = sum(float((g[s] * g[c]).sum()) for c, s in zip(cols, sent, strict=True) if s in g)
    n = sum(float(g[s].sum()) for s in sent if s in g)
    return tot / n if n else math.nan


def _particles_mean(g: Any) -> float:
    cols = [c for c in g.columns if c.startswith("particles_mean")]
    return float(np.nanmean(g[cols].to_numpy(float))) if cols else math.nan


@register("reproduction", "muc-osl", ReproductionParams, "MUC-OSL vs Col-Inf, Col-PF, Adap-PP")
class MucOslReproduction(Reproduction):
    """The four algorithms on ``muc-osl-3d`` with 3 UAVs (Sect. VI.2 and VI.4)."""

    name = "muc-osl"
    paper = "muc-osl-multi-uav.txt"
    summary = "MUC-OSL vs Col-Inf, Col-PF and Adap-PP: 3 UAVs in 100 x 60 x 30 m (Tables 2-3)"
    default_episodes = 40
    paper_episodes = 200

    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        return {
            "name": "muc-osl reproduction",
            "seed": seed,
            "episodes": episodes,
            "keep_episodes": [0],
            "scenarios": [{"name": SCENARIO}],
            "searchers": [
                *({"name": a} for a in ALGORITHMS),
                {"name": "muc-osl", "label": NO_ENV_PU, "params": NO_ENV_PU_PARAMS},
            ],
        }

    def reference(self) -> dict[str, dict[str, Any]]:
        return {
            f"{SCENARIO}/{a}": {**TABLE2[a], "source": "Table 2"} for a in ("muc-osl", "col-inf")
        }

    def tables(self, df: Any, seed: int) -> list[Table]:
        from odorloc.experiments import stats

        ok = add_uav_search_time(df[df["status"] != "error"])
        rows, move, res = [], [], []
        for i, a in enumerate(ROWS):
            g = ok[ok["searcher"] == a]
            if not len(g):
                continue
            n = len(g)
            k = int(g["success"].astype(bool).sum())
            lo, hi = stats.wilson_interval(k, n)
            rng = np.random.default_rng([seed, i])
            succ = g[g["success"].astype(bool)]
            t_s = succ["uav_search_time"].to_numpy(float)
            t_lo, t_hi = stats.bootstrap_ci(t_s, rng)
            t_all = g["uav_search_time"].to_numpy(float)
            a_lo, a_hi = stats.bootstrap_ci(t_all, rng)
            decl = g["declared"].astype(bool)
            rows.append(
                [
                    LABELS[a],
                    str(n),
                    f"{fmt(100 * k / n, 0)} [{fmt(100 * lo, 0)}, {fmt(100 * hi, 0)}]",
                    f"{fmt(t_s.mean() if t_s.size else math.nan, 0)} "
                    f"[{fmt(t_lo, 0)}, {fmt(t_hi, 0)}]",
                    f"{fmt(t_all.mean(), 0)} [{fmt(a_lo, 0)}, {fmt(a_hi, 0)}]",
                    fmt(float(succ["search_time"].mean()) if len(succ) else math.nan, 0),
                    f"{fmt(100 * decl.mean(), 0)}",
                    fmt(float(g.loc[decl, "loc_error"].mean()) if decl.any() else math.nan, 1),
                ]
            )
            e_m = g["movement_kj"].to_numpy(float)
            e_lo, e_hi = stats.bootstrap_ci(e_m, rng)
            per_m = float(e_m.sum() / g["path_length"].sum()) if g["path_length"].sum() else 0.0
            ref = TABLE2.get(a)
            move.append(
                [
                    LABELS[a],
                    fmt(float(g["team_hover_time"].mean()), 0),
                    fmt(float(g["team_turn_time"].mean()), 0),
                    fmt(float(g["path_length"].mean()), 0),
                    f"{fmt(e_m.mean(), 0)} [{fmt(e_lo, 0)}, {fmt(e_hi, 0)}]",
                    fmt(per_m, 2),
                    "-"
                    if ref is None
                    else f"{ref['hover_time']:.0f}/{ref['turn_time']:.0f}"
                    f"/{ref['distance']:.0f}/{ref['energy_kj']:.0f}",
                ]
            )
            per_exchange = _numbers_per_message(g)
            res.append(
                [
                    LABELS[a],
                    fmt(per_exchange, 0),
                    TABLE3.get(a, {}).get("numbers", "-"),
                    fmt(float(g["bytes"].mean()) / 1e3, 1),
                    fmt(float(g["energy_comm"].mean()) * 1e3, 2),
                    fmt(float(g["energy_compute"].mean()), 2),
                    fmt(_particles_mean(g), 0),
                ]
            )
        note = self._saving_note(ok)
        return [
            Table(
                "comparison",
                "3 UAVs in 100 x 60 x 30 m: success and search time (95 % intervals)",
                ["algorithm", "n", "success %", "time s", "all s", "clock s", "decl %", "err m"],
                rows,
                note="time: flying + hovering + turning time of the first UAV within 2 m of the\n"
                "source (successes); all: failures count 1200 s; clock: episode time of the\n"
                "successes (idle time between moves included); decl: episodes with a declaration,\n"
                "err: its distance from the source; brackets: 95 % intervals (Wilson, bootstrap);\n"
                "MUC-OSL -env: MUC-OSL without the upwind particle moves of eq. 16.",
            ),
            Table(
                "movement",
                "Team movement per episode (Table 2)",
                ["algorithm", "hover s", "turn s", "distance m", "E_M kJ", "kJ/m", "paper h/t/d/E"],
                move,
                note=note,
            ),
            Table(
                "resources",
                "Computation and communication (Table 3)",
                ["algorithm", "numbers/msg", "paper", "kB/episode", "E_T mJ", "E_C J", "particles"],
                res,
            ),
        ]

    @staticmethod
    def _saving_note(ok: Any) -> str:
        a = ok[ok["searcher"] == "muc-osl"].set_index("episode")["movement_kj"]
        b = ok[ok["searcher"] == "col-inf"].set_index("episode")["movement_kj"]
        common = a.index.intersection(b.index)
        if not len(common):
            return ""
        ma, mb = float(a[common].mean()), float(b[common].mean())
        return (
            f"team totals per episode; movement energy MUC-OSL vs Col-Inf over {len(common)}\n"
            f"paired episodes: {ma:.0f} vs {mb:.0f} kJ ({100 * (ma - mb) / mb:+.1f} %; paper "
            "-8.44 %);\nkJ/m: movement energy per metre flown (hovers and turns included)."
        )

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        ok = add_uav_search_time(df[df["status"] != "error"])
        return [
            Figure(
                "comparison.png",
                "Success rate and search time of the four algorithms (95 % intervals)",
                lambda p: _comparison_figure(ok, seed, p),
            ),
            Figure(
                "fig3_team_3d.png",
                "Fig. 3: UAV paths, cue points (open circles) and each UAV's particles at four "
                "moments of one MUC-OSL episode",
                lambda p: _fig3(seed, p),
            ),
        ]


def record_episode(searcher: str, seed: int, episode: int, belief_stride: int = 5) -> Any:
    """The recorded episode ``episode`` of ``searcher`` on ``muc-osl-3d`` under root ``seed``."""
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario

    sc = cell_scenario({"scenario": SCENARIO, "searcher": searcher})
    sc = sc.model_copy(
        update={"recording": sc.recording.model_copy(update={"belief_stride": belief_stride})}
    )
    return run_episode(sc, *episode_seeds(seed, SCENARIO, episode), record=True)


def _fig3(seed: int, path: Path) -> None:
    from odorloc.viz.team3d import animate_team_3d, plot_team_3d

    res = None
    for ep in range(10):
        res = record_episode("muc-osl", seed, ep)
        if res.metrics["success"]:
            break
    assert res is not None and res.recording is not None
    rec = res.recording
    m = res.metrics
    outcome = f"reached at {m['search_time']:.0f} s" if m["success"] else "not reached"
    rec.meta["title"] = f"MUC-OSL, 3 UAVs, muc-osl-3d episode {ep} (seed {seed}): {outcome}"
    plot_team_3d(rec, path)
    animate_team_3d(rec, path.with_name("fig3_team_3d.gif"))


def _comparison_figure(ok: Any, seed: int, path: Path) -> None:
    import matplotlib.pyplot as plt

    from odorloc.experiments import stats

    fig, axes = plt.subplots(1, 2, figsize=(11, 3.9))
    names, sr, srlo, srhi, mt, mtlo, mthi = [], [], [], [], [], [], []
    for i, a in enumerate(ROWS):
        g = ok[ok["searcher"] == a]
        if not len(g):
            continue
        k, n = int(g["success"].astype(bool).sum()), len(g)
        lo, hi = stats.wilson_interval(k, n)
        t = g.loc[g["success"].astype(bool), "uav_search_time"].to_numpy(float)
        tlo, thi = stats.bootstrap_ci(t, np.random.default_rng([seed, i]))
        names.append(BAR_LABELS[a])
        sr.append(100 * k / n)
        srlo.append(100 * lo)
        srhi.append(100 * hi)
        mt.append(t.mean() if t.size else math.nan)
        mtlo.append(tlo)
        mthi.append(thi)
    x = np.arange(len(names))
    for ax, v, lo, hi, lab in (
        (axes[0], sr, srlo, srhi, "success rate (%)"),
        (axes[1], mt, mtlo, mthi, "search time of successes (s)"),
    ):
        v_, lo_, hi_ = (np.asarray(u, float) for u in (v, lo, hi))
        err = [np.nan_to_num(np.maximum(v_ - lo_, 0)), np.nan_to_num(np.maximum(hi_ - v_, 0))]
        ax.bar(x, v_, color=["tab:red", "tab:blue", "tab:green", "tab:orange", "0.6"][: len(x)])
        ax.errorbar(x, v_, yerr=err, fmt="none", ecolor="k", capsize=4)
        ax.set_xticks(x, names)
        ax.set_ylabel(lab)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylim(0, 100)
    n = int(ok.groupby("searcher").size().min()) if len(ok) else 0
    fig.suptitle(f"muc-osl-3d, 3 UAVs, {n} episodes per algorithm (95 % intervals)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
