"""``odorloc reproduce virtual-physics``: two formations, two sources, three plume-tracing rules.

The paper's experiment (Sec. 3): two groups of six robots in ``virtual-physics-two-groups`` with
chemotaxis, anemotaxis or fluxotaxis as their virtual robots' goal force, at standard, twice and
treble frequency (the scenario's ``frequency`` knob), from the start sets P1-P6; other readings
of the text and ablations in the same run (:data:`VARIANTS`). The sweep ``starts`` runs
anemotaxis and fluxotaxis from ten more start pairs on the start line (:data:`WIDE_STARTS`).
Each (frequency, episode) flow is recorded once and replayed to every variant and start. Rows
carry the per-group columns of :func:`~odorloc.experiments.groups.group_columns`. The outputs
also hold the declaration's geometry (:func:`~.analysis.flux_maps`, ``flux_map.png``) and the
plume beside the closed-form solution (:func:`~.analysis.plume_check`, ``plume_check.png``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.experiments.reproduction import (
    Figure,
    Reproduction,
    ReproductionParams,
    Table,
    check_time_limit,
    fmt,
)
from odorloc.papers.virtual_physics import reference as ref
from odorloc.papers.virtual_physics.figures import select

__all__ = ["RULES", "VARIANTS", "VirtualPhysicsReproduction", "vp_extras", "vp_group"]

SCENARIO = "virtual-physics-two-groups"
RULES = ("chemotaxis", "anemotaxis", "fluxotaxis")
FREQUENCIES = (1, 2, 3)
FREQ_NAMES = {1: "standard", 2: "twice", 3: "treble"}
STARTS = tuple(ref.START_SETS)
#: Label -> (the formation's parameters besides the rule its label begins with, what it is).
VARIANTS: dict[str, tuple[dict[str, Any], str]] = {
    "chemotaxis": ({"rule": "chemotaxis"}, "eq. 3"),
    "anemotaxis": ({"rule": "anemotaxis"}, "eq. 4"),
    "fluxotaxis": ({"rule": "fluxotaxis"}, "eqs. 5-6"),
    "chemotaxis-consecutive": ({"declaration": {"reading": "consecutive"}}, "reading"),
    "chemotaxis-point": ({"target": "point"}, "reading: goal point"),
    "chemotaxis-no-bypass": ({"forbidden_area": False, "rotary": False}, "ablation"),
    "chemotaxis-no-repulsion": ({"repulsion": False}, "ablation"),
    "fluxotaxis-no-bypass": ({"forbidden_area": False, "rotary": False}, "ablation"),
    "anemotaxis-wait": ({"outside": "wait"}, "reading: wait"),
    "fluxotaxis-wait": ({"outside": "wait"}, "reading: wait"),
    "anemotaxis-best": ({"declaration": {"point": "best"}}, "ablation: best robot"),
    "anemotaxis-clear": ({"escape": "clear"}, "reading: escape once clear"),
    "anemotaxis-wide-circle": ({"r_T": 2.4}, "ablation: r_T = 8 r, near the other source"),
    "fluxotaxis-point": ({"target": "point"}, "reading: goal point"),
}
#: Start pairs of the ``starts`` sweep: y of the virtual robots of A and B at x = 18 m.
WIDE_STARTS = tuple(
    ["y2-6", "y2-10", "y2-14", "y2-18", "y6-10", "y6-14", "y6-18", "y10-14", "y10-18", "y14-18"]
)
WIDE_RULES = ("anemotaxis", "fluxotaxis")
#: Both groups' final virtual robots within this distance (m) of one source: "same end".
SAME_SOURCE_REACH = 3.0
#: Distance (m) from a source within which the flux map shows the declaration firing.
REGION = 0.3
FIGURE_FREQUENCY, ANIMATION = 3, ("fluxotaxis", "P3")
MAP_SECONDS = 200.0  # of each frequency's flux map
_KEEP = (*RULES, "chemotaxis-no-bypass", "fluxotaxis-no-bypass")


def _label(task: Any) -> str:
    return str(task.cell.get("searcher_label", task.cell.get("searcher")))


def _setting(task: Any, key: str) -> Any:
    return (task.cell.get("scenario_params") or {}).get(key)


def _prepare(sc: Any, task: Any) -> Any:
    # every step of the virtual robots is recorded (chemotaxis' 2-cycle has a period of two
    # steps); plume frames only for the paths figures, densely for the animated episode
    paths = task.keep_arrays and _setting(task, "frequency") == FIGURE_FREQUENCY
    animated = paths and (_label(task), _setting(task, "start_set")) == ANIMATION
    upd = {"stride": 1, "plume_stride": 4 if animated else (100 if paths else 10**9)}
    return sc.model_copy(update={"recording": sc.recording.model_copy(update=upd)})


def vp_extras(task: Any, res: Any, rows: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Per-episode columns (:func:`~odorloc.experiments.groups.group_columns`)."""
    from odorloc.experiments.groups import group_columns
    from odorloc.experiments.runner import cell_scenario
    from odorloc.viz.formations import groups_of

    sc = cell_scenario(task.cell)
    return group_columns(res, groups_of(sc), sc.task.success_radius, REGION, SAME_SOURCE_REACH)


def vp_group(tasks: list[Any]) -> list[dict[str, Any]]:
    """One flow's group: record the flow once, replay it to every variant and start. Episode 0
    is stored for the paths figures (figure frequency) and, for chemotaxis, at every frequency
    (its virtual robots drawn on the flux maps)."""
    from odorloc.experiments.runner import run_replay_group

    def keeps(t: Any) -> bool:
        label, figure = _label(t), _setting(t, "frequency") == FIGURE_FREQUENCY
        return bool(t.keep_arrays) and (label == "chemotaxis" or (figure and label in _KEEP))

    adjusted = [replace(t, keep_arrays=keeps(t)) for t in tasks]
    return run_replay_group(adjusted, record=True, extras=vp_extras, prepare=_prepare)


# ---------------------------------------------------------------------- tables
def _ci(g: Any, stat: tuple[str, ...], seed: int) -> str:
    """``value [lo, hi]`` of a rate or mean (:func:`~odorloc.experiments.cells.stat_interval`)."""
    from odorloc.experiments.cells import stat_interval

    v, lo, hi, _ = stat_interval(g, stat, seed)
    return "-" if not math.isfinite(v) else f"{fmt(v, 0)} [{fmt(lo, 0)}, {fmt(hi, 0)}]"


def _ok(g: Any) -> Any:  # the successful episodes
    return g[g["success"].fillna(False).astype(bool)]


def _frac(g: Any, col: str, value: Any = True) -> str:
    return f"{int((g[col] == value).sum())}/{len(g)}" if col in g and len(g) else "-"


def _mean_of(g: Any, cols: tuple[str, ...]) -> float:
    a = np.concatenate([np.asarray(g[c], float) for c in cols if c in g] or [np.zeros(0)])
    return float(np.nanmean(a)) if np.isfinite(a).any() else math.nan


def _time(g: Any) -> str:  # pandas' mean of no rows is NaN, shown "-"
    return fmt(_ok(g)["search_time"].astype(float).mean(), 0)


NOTES = {
    "rules": "[95% intervals: Wilson, bootstrap] freq: 1 standard, 2 twice, 3 treble; time: of "
    "the episodes that found both; reached: the virtual robots came within the success radius of "
    f"different sources; dwell: % of steps within {REGION:g} m of a source after getting there",
    "starts_success": "paper: chemotaxis 100 % everywhere; anemotaxis 0 % from P4, else 100 %",
    "starts_time": "paper c.3: chemotaxis, treble (Sec. 3.1); a.: anemotaxis (Sec. 3.2)",
    "variants": "reached: the groups came within the success radius of different sources; same "
    f"end: both groups ended within {SAME_SOURCE_REACH:g} m of one source",
    "starts_wide": "one src: both groups ended within 3 m of one source; up 1st: the upwind "
    "source (1, 11) was declared first (the paper's explanation of the P4 failure)",
    "approach": "reversing near 100 %: a 2-cycle, the virtual robot stepping back and forth",
    "declaration_geometry": "centre x: mean downwind offset of the region; >0.45 m: farther "
    "than 0.45 m from the source (the flanks, where the advective flux exceeds Phi_T too)",
    "plume_check": "closed form: the steady solution with D, and with D + U h / 2 along the wind",
}
#: Table name -> (title, headers separated by "|"; ``{...}`` filled in by :func:`_table`).
TABLES = {
    "rules": (
        "Both sources declared: ours (6 starts pooled) vs paper",
        "rule|freq|n|success %|paper|time s|paper s|reached|dwell %",
    ),
    "starts_success": ("Per start: successes/n (rule.frequency)", "start|{cols}|paper c/a %"),
    "starts_time": ("Per start: mean time of the successes, s", "start|{cols}|paper c.3|a."),
    "variants": (
        "Every variant, frequencies and starts pooled",
        "variant|n|success %|time s|reached|same end|what",
    ),
    "starts_wide": ("More starts (y of A-B at x = 18 m), frequencies pooled", "start|{wide}"),
    "approach": (
        f"After first coming within {REGION:g} m of a source",
        "rule|freq|dwell %|reversing %",
    ),
    "declaration_geometry": (
        "Where a formation held still would declare (>= half of the steps)",
        "freq|source|area m2|centre x m|max % >0.45 m|area >0.45 m",
    ),
    "plume_check": (
        "Steady plume at the upwind source, 1 m from the inflow",
        "quantity|Eulerian|inflow -4 m|closed D={D}|closed D={Da}",
    ),
}


def _table(name: str, rows: list[list[str]], **fill: str) -> Table:
    title, heads = TABLES[name]
    return Table(name, title, heads.format(**fill).split("|"), rows, note=NOTES.get(name, ""))


CAPTIONS = {
    "variants.png": "Readings of the text and ablations (all frequencies and starts pooled)",
    "flux_map.png": "The declaration's geometry: how often a formation held at each offset from "
    "a source would declare, per source and frequency, with the chemotaxis virtual robots' paths",
    "plume_check.png": "Steady plume around the upwind source, 1 m from the inflow, vs the "
    "closed-form solution",
    "episode.gif": f"{ANIMATION[0]} from {ANIMATION[1]}, treble frequency, episode 0",
}


@register("reproduction", "virtual-physics", ReproductionParams, "Sec. 3 and Figs. 5-10")
class VirtualPhysicsReproduction(Reproduction):
    """Two virtual-physics formations, two sources: three rules x three frequencies x six starts."""

    name = "virtual-physics"
    paper = "virtual-physics-multi-group.txt"
    citations = (ref.CITATION,)
    summary = (
        "Sec. 3 and Figs. 5-10: chemotaxis, anemotaxis, fluxotaxis formations, 3 frequencies x "
        "6 starts, readings and ablations, 10 more starts, the declaration's geometry"
    )
    default_episodes = 2
    paper_episodes = 1
    cell_summary = False  # the compact tables say it better
    map_seconds = MAP_SECONDS  # of the flux maps (shorter in tests)

    def __init__(
        self, params: ReproductionParams | None = None, time_limit: float | None = None
    ) -> None:
        """``time_limit`` (s): a shorter episode limit for tests or a first look (default the
        scenario's ``limits.time``, 1200 s); refused unless a finite number > 0."""
        super().__init__(params)
        self.time_limit = check_time_limit(time_limit)
        self._analysis: dict[str, Any] = {}

    def _spec(self, n: int, seed: int, starts: tuple[str, ...], labels: tuple[str, ...]) -> Any:
        fixed = {} if self.time_limit is None else {"params": {"limits.time": self.time_limit}}
        scenario = {"name": SCENARIO, "label": "vp", "grid": {"frequency": list(FREQUENCIES)}}
        scenario["agent_grid"] = {"start_set": list(starts)}
        member = {
            lab: {"type": "virtual-physics", "rule": lab.split("-")[0], **VARIANTS[lab][0]}
            for lab in labels
        }
        return {
            "name": "virtual-physics reproduction",
            "seed": seed,
            "episodes": n,
            "replay": True,
            "keep_episodes": [0],
            "scenarios": [{**scenario, **fixed}],
            "searchers": [
                {"name": "per-group", "label": lab, "params": {"member": member[lab]}}
                for lab in labels
            ],
        }

    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        """The paper's experiment: every variant x frequency x start set P1-P6."""
        return self._spec(episodes, seed, STARTS, tuple(VARIANTS))

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        n = self.default_episodes if episodes is None else int(episodes)
        wide = self._spec(n, seed, WIDE_STARTS, WIDE_RULES)
        return {"results": self.sweep(n, seed), "starts": wide}

    def group_fn(self) -> Any:
        return vp_group

    def reference(self) -> dict[str, dict[str, Any]]:
        """The paper's numbers per cell (:mod:`.reference`): success rates per start (Secs.
        3.1-3.2), chemotaxis' mean time per start at treble frequency (Sec. 3.1)."""
        from odorloc.experiments.sweep import expand_cells, load_sweep

        out: dict[str, dict[str, Any]] = {}
        for cell in expand_cells(load_sweep(self.sweep(1, 0))):
            label = str(cell.spec.get("searcher_label"))
            if label not in ref.SUCCESS:
                continue
            start = str(cell.swept["scenario.start_set"])
            entry = {"success_rate": float(ref.SUCCESS[label][start]), "source": ref.SOURCE[label]}
            if label == "chemotaxis" and int(cell.swept["scenario.frequency"]) == 3:
                entry["mean_time"] = ref.CHEMOTAXIS_TREBLE_BY_START[start]
            out[cell.cell_id] = entry
        return out

    def analysis(self, seed: int) -> dict[str, Any]:
        """The flux maps (world seed ``seed``) and the plume check, computed once per run."""
        from odorloc.papers.virtual_physics.analysis import flux_maps, plume_check

        if self._analysis.get("seed") != seed:
            maps = flux_maps(FREQUENCIES, self.map_seconds, seed)
            self._analysis = {"seed": seed, "maps": maps, "plume": plume_check()}
        return self._analysis

    def tables(self, df: Any, seed: int) -> list[Table]:
        res = df[df["sweep"] == "results"] if "sweep" in df else df
        rules, approach, success, times, variants, wide = [], [], [], [], [], []
        for label in RULES:
            for f in FREQUENCIES:
                g = select(res, label, f)
                fast = f"<{ref.FAST_RULES_BOUND:.0f}"
                paper_s = fmt(ref.CHEMOTAXIS_TIME.get(f), 0) if label == "chemotaxis" else fast
                dwell, rev = (_mean_of(g, (f"{k}_A", f"{k}_B")) for k in ("dwell", "reversal"))
                rules.append([label, str(f), str(len(g)), _ci(g, ("rate", "success"), seed)])
                rules[-1] += [
                    ref.paper_success(label),
                    _ci(g, ("mean", "search_time", "success"), seed),
                ]
                rules[-1] += [paper_s]
                rules[-1] += [_frac(g, "reached_both"), fmt(100 * dwell, 0)]
                approach.append([label, str(f), fmt(100 * dwell, 0), fmt(100 * rev, 0)])
        for s in STARTS:
            cells = [select(res, r, f, s) for r in RULES for f in FREQUENCIES]
            paper = [fmt(100 * ref.SUCCESS[r][s], 0) for r in ("chemotaxis", "anemotaxis")]
            success.append([s, *(f"{len(_ok(g))}/{len(g)}" for g in cells), "/".join(paper)])
            anem = ref.ANEMOTAXIS_BY_START.get(s)
            paper = [fmt(ref.CHEMOTAXIS_TREBLE_BY_START[s], 0), fmt(anem, 0) if anem else "fail"]
            times.append([s, *(_time(g) for g in cells), *paper])
        for label, (_, what) in VARIANTS.items():
            g = select(res, label)
            variants.append([label, str(len(g)), _ci(g, ("rate", "success"), seed)])
            variants[-1] += [_ci(g, ("mean", "search_time", "success"), seed)]
            variants[-1] += [_frac(g, "reached_both"), _frac(g, "same_source"), what]
        starts = df[df["sweep"] == "starts"] if "sweep" in df else df.iloc[:0]
        for s in WIDE_STARTS if len(starts) else ():
            wide.append([s])
            for label in WIDE_RULES:
                g = select(starts, label, start=s)
                wide[-1] += [f"{len(_ok(g))}/{len(g)}", _frac(g, "same_source")]
                wide[-1] += [_frac(g, "first_declared", 0)]
        cols = "|".join(f"{r[:4]}.{f}" for r in RULES for f in FREQUENCIES)
        wide_cols = "|".join(
            f"{r[:4]}. {c}" for r in WIDE_RULES for c in ("ok", "one src", "up 1st")
        )
        rows = {"rules": rules, "starts_success": success, "starts_time": times}
        rows.update(variants=variants, starts_wide=wide, approach=approach)
        return [
            _table(n, r, cols=cols, wide=wide_cols) for n, r in rows.items() if r
        ] + self._geometry(seed)

    def _geometry(self, seed: int) -> list[Table]:
        a = self.analysis(seed)
        maps, off = a["maps"], a["maps"]["offsets"]
        X, Y = np.meshgrid(off, off, indexing="ij")
        far = np.hypot(X, Y) > 0.45
        rows = []
        for f in FREQUENCIES:
            for i, s in enumerate(maps["sources"]):
                m = maps["maps"][f][i]["declares"]
                fires = m >= 0.5
                cx = float((X * fires).sum() / max(fires.sum(), 1))
                area = (off[1] - off[0]) ** 2 * np.array([fires.sum(), (fires & far).sum()])
                rows.append([str(f), f"({s[0]:g}, {s[1]:g})", fmt(area[0], 2), fmt(cx, 2)])
                rows[-1] += [fmt(100 * m[far].max(), 0), fmt(area[1], 2)]
        p = a["plume"]
        check = [[r[0], *(f"{v:.3g}" for v in r[1:])] for r in p["rows"]]
        return [
            _table("declaration_geometry", rows),
            _table("plume_check", check, D=f"{p['D']:g}", Da=f"{p['D_along']:g}"),
        ]

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        from odorloc.experiments.recordings import kept_recordings
        from odorloc.papers.virtual_physics import figures as vf
        from odorloc.viz.fields import declaration_map_figure
        from odorloc.viz.formations import relative_paths

        res = df[df["sweep"] == "results"] if "sweep" in df else df
        a = self.analysis(seed)
        paths = {}
        for f in FREQUENCIES:
            where = {"searcher": "chemotaxis", "scenario.frequency": float(f)}
            recs = kept_recordings(res, store, where, "scenario.start_set")
            paths[f] = relative_paths(list(recs.values()), vf.groups(), a["maps"]["sources"], 1.2)
        specs: list[tuple[str, str, Any]] = []
        for k, lab in enumerate(RULES):
            where = {"searcher": lab, "scenario.frequency": float(FIGURE_FREQUENCY)}
            recs = kept_recordings(res, store, where, "scenario.start_set")
            cap = f"{lab}: both groups' paths, treble frequency, episode 0 (cf. Fig. {5 + 2 * k})"
            specs.append((f"paths_{lab}.png", cap, partial(vf.paths_figure, recs, lab)))
            cap = f"{lab}: mean time to find both sources by start and frequency (Fig. {6 + 2 * k})"
            fn = partial(vf.search_time_figure, res, lab, seed=seed)
            specs.append((f"search_time_{lab}.png", cap, fn))
        draw = {
            "variants.png": lambda p: vf.ablation_figure(
                res, p, seed, tuple(VARIANTS), SAME_SOURCE_REACH
            ),
            "flux_map.png": lambda p: declaration_map_figure(
                a["maps"], paths, p, radius=0.5, column=FREQ_NAMES
            ),
            "plume_check.png": lambda p: vf.plume_check_figure(a["plume"], p),
        }
        where = {"searcher": ANIMATION[0], "scenario.frequency": float(FIGURE_FREQUENCY)}
        anim = kept_recordings(res, store, where, "scenario.start_set").get(ANIMATION[1])
        if anim is not None:
            draw["episode.gif"] = lambda p: vf.animate_formations(anim, p)
        return [Figure(*s) for s in specs] + [Figure(n, CAPTIONS[n], fn) for n, fn in draw.items()]
