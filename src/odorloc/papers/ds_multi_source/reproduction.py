"""``odorloc reproduce ds-multi-source``: dynamic route vs rectangular wave (D-S paper, Sec. 4).

Dynamic route (``ds-mapping``) versus the predefined rectangular wave (``ds-rectangular-wave``, 5
rounds, 2 m lanes), both building the same Dempster-Shafer map, in ``two-sources-farrell``. As in
the paper (Sec. 4.1) each flow is recorded once as a movie and both routes run on its replay
(the sweep's ``replay`` option), so they face exactly the same plume and wind.

Per episode the row adds: the residual uncertainty ``sum X_i`` at the paper's scene times
(``scene_residual_k``), the distance from each true source to the nearest mapped source under
each source rule (``source_error_i[_rule]``) and the mapped sources farther than the success
radius from both (``map_false_sources``), and, for the dynamic route, the time and distance at
which its map first reached the wave's final residual on the same flow
(``time_to_baseline_residual``, ``distance_to_baseline_residual``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from odorloc.core.registry import register
from odorloc.experiments.reproduction import (
    Figure,
    Reproduction,
    ReproductionParams,
    Table,
    check_time_limit,
    fmt,
)
from odorloc.experiments.stats import mean_sd
from odorloc.inference.evidence.mapper import RULES as MAP_RULES
from odorloc.inference.evidence.mapper import DSMapParams
from odorloc.papers.ds_multi_source.reference import (
    CITATION,
    ODOR_PATH_CITATION,
    PAPER,
    RATIOS,
    SCENES,
)

__all__ = ["DSReproduction", "ds_group", "map_errors", "residual_at", "time_to_residual"]

SCENARIO = "two-sources-farrell"
WAVE = "ds-rectangular-wave"
DYNAMIC = "ds-mapping"
SEARCHERS: dict[str, dict[str, Any]] = {
    WAVE: {"rounds": 5, "lane_spacing": 2.0, "lanes_along": "y"},
    DYNAMIC: {},
}
RULES = ("", *MAP_RULES)
"""Source rules reported: the default ('') and each named one."""
_BELIEF_STRIDE = 40  # one map snapshot every 20 s of a kept episode


def map_errors(
    row: dict[str, Any], sources: np.ndarray, radius: float, kind: str = "mapped", tag: str = ""
) -> dict[str, Any]:
    """Per-source errors of the mapped positions ``{kind}_x_k, {kind}_y_k`` in ``row``.

    Returns ``source_error_i{tag}`` (distance from true source ``i`` to the nearest mapped
    source, NaN if none), ``map_false_sources{tag}`` (mapped sources farther than ``radius``
    from every true source) and ``map_success{tag}`` (every true source within ``radius``).
    The number of positions is ``mapped_sources`` for ``kind="mapped"``, else ``{kind}_n``.
    """
    count = row.get("mapped_sources" if kind == "mapped" else f"{kind}_n", 0)
    k = int(count or 0)
    mapped = np.array([[row[f"{kind}_x_{i}"], row[f"{kind}_y_{i}"]] for i in range(k)])
    out: dict[str, Any] = {}
    if k:
        d = np.linalg.norm(mapped.reshape(-1, 2)[:, None, :] - sources[None, :, :2], axis=2)
        near = d.min(axis=0)
        out[f"map_false_sources{tag}"] = int(np.sum(d.min(axis=1) > radius))
    else:
        near = np.full(len(sources), math.nan)
        out[f"map_false_sources{tag}"] = 0
    for i, v in enumerate(near):
        out[f"source_error_{i}{tag}"] = float(v)
    out[f"map_success{tag}"] = bool(k and np.all(near <= radius))
    return out


def time_to_residual(rec: Any, target: float) -> tuple[float, float]:
    """``(time s, distance m)`` at which a recording's ``total_uncertainty`` first reaches
    ``target`` (NaN if never)."""
    tu = rec.diagnostics.get("total_uncertainty")
    if tu is None or not np.isfinite(target):
        return math.nan, math.nan
    hit = np.flatnonzero(tu <= target)
    if hit.size == 0:
        return math.nan, math.nan
    k = int(hit[0])
    steps = np.linalg.norm(np.diff(rec.positions[: k + 1, 0, :2], axis=0), axis=1)
    return float(rec.t[k]), float(steps.sum())


def residual_at(rec: Any, t: float) -> float:
    """``sum X`` of a recording at time ``t``, seconds (its last value if it ended before)."""
    tu = rec.diagnostics.get("total_uncertainty")
    if tu is None or len(tu) == 0:
        return math.nan
    k = int(np.searchsorted(rec.t, t, side="right")) - 1
    return float(tu[min(max(k, 0), len(tu) - 1)])


def _label(task: Any) -> str:
    return str(task.cell.get("searcher_label", task.cell.get("searcher")))


def _prepare(sc: Any, task: Any) -> Any:
    # every episode keeps its per-step diagnostics; map snapshots only where arrays are kept
    keep = bool(task.keep_arrays)
    return sc.model_copy(
        update={
            "recording": sc.recording.model_copy(
                update={
                    "belief_stride": _BELIEF_STRIDE if keep else 10**9,
                    "plume_stride": 200 if keep else 10**9,
                }
            )
        }
    )


def ds_extras(task: Any, res: Any, rows: dict[str, dict[str, Any]]) -> dict[str, Any]:
    from odorloc.experiments.runner import cell_scenario

    radius = cell_scenario(task.cell).task.success_radius
    row = dict(res.metrics)
    out: dict[str, Any] = {}
    for rule in RULES:
        kind = rule or "mapped"
        out.update(map_errors(row, res.sources, radius, kind, f"_{rule}" if rule else ""))
    label = _label(task)
    rec = res.recording
    if rec is not None:
        for k, (t_scene, _, _) in enumerate(SCENES[label]):
            out[f"scene_residual_{k}"] = residual_at(rec, t_scene)
    if label == DYNAMIC and rec is not None:
        base = next((r for cid, r in rows.items() if cid.endswith(f"/{WAVE}")), None)
        # a failed wave episode's row has no mapping columns: the dynamic route's own row
        # stays valid, only its comparison with the wave is missing
        target = float(base.get("residual_uncertainty", math.nan)) if base else math.nan
        t_eq, d_eq = time_to_residual(rec, target)
        out.update(time_to_baseline_residual=t_eq, distance_to_baseline_residual=d_eq)
    return out


def _wave_of(probe: Any) -> Any:
    """The wave's task of ``probe``'s flow (run again when a resumed group lacks it)."""
    from dataclasses import replace

    cell = {**probe.cell, "searcher": WAVE, "searcher_label": WAVE}
    cell["searcher_params"] = dict(SEARCHERS[WAVE])
    cell_id = probe.cell_id.rsplit("/", 1)[0] + f"/{WAVE}"
    return replace(probe, cell=cell, cell_id=cell_id, keep_arrays=False)


def ds_group(tasks: list[Any]) -> list[dict[str, Any]]:
    """Run one flow's group: the wave first (its final residual is the dynamic route's target).

    If the group lacks the wave (a resumed run that stored only it), the wave's episode is run
    again to get its residual; it is not stored twice.
    """
    from odorloc.experiments.runner import run_with_reference

    return run_with_reference(
        tasks,
        lambda t: _label(t) == WAVE,
        _wave_of,
        record=True,
        extras=ds_extras,
        prepare=_prepare,
    )


def _ms(x: Any, d: int = 1) -> str:
    m, s = mean_sd(x)
    return f"{fmt(m, d)} ± {fmt(s, d)}"


def _stopped(g: Any) -> str:
    """Flows that ended by the route's own rule (the stop rule or the last round)."""
    return f"{int((g.termination == 'declared').sum())}/{len(g)}"


def _count(g: Any, col: str) -> str:
    if col not in g:
        return f"0/{len(g)}"
    hits = pd.to_numeric(g[col], errors="coerce").fillna(0.0) > 0.5
    return f"{int(hits.sum())}/{len(g)}"


@register("reproduction", "ds-multi-source", ReproductionParams, "Sec. 4 and Figs. 1-2")
class DSReproduction(Reproduction):
    """D-S map with the dynamic route vs the rectangular wave, two sources, replayed flows."""

    name = "ds-multi-source"
    paper = "ds-multi-source-mapping.txt"
    citations = (CITATION, ODOR_PATH_CITATION)
    summary = "Sec. 4 and Figs. 1-2: D-S map with dynamic route vs rectangular wave, two sources"
    default_episodes = 10
    paper_episodes = 1
    success_column = "map_success"
    success_label = (
        "both true sources have a mapped source within the scenario's success radius in the "
        "final map, whether the route's stop rule declared it or the time limit ended the "
        "mission (the paper's criterion: both sources appear in the map)"
    )

    def __init__(
        self,
        params: ReproductionParams | None = None,
        time_limit: float | None = None,
        max_speed: float | None = None,
    ) -> None:
        super().__init__(params)
        self.time_limit = check_time_limit(time_limit)
        self.max_speed = max_speed

    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        overrides: dict[str, Any] = {}
        if self.time_limit is not None:
            overrides["limits.time"] = float(self.time_limit)
        if self.max_speed is not None:
            overrides["platform.max_speed"] = float(self.max_speed)
        return {
            "name": "ds-multi-source reproduction",
            "seed": seed,
            "episodes": episodes,
            "replay": True,
            "keep_episodes": [0],
            "scenarios": [{"name": SCENARIO, "params": overrides}],
            "searchers": [{"name": k, "params": v} for k, v in SEARCHERS.items()],
        }

    def group_fn(self) -> Any:
        return ds_group

    def reference(self) -> dict[str, dict[str, Any]]:
        return {k: {"mean_time": v["time"], "source": v["source"]} for k, v in PAPER.items()}

    def tables(self, df: Any, seed: int) -> list[Table]:
        import pandas as pd

        # rows of failed episodes carry none of the mapping columns: read them as missing
        needed = [
            "search_time",
            "path_length",
            "residual_uncertainty",
            "initial_uncertainty",
            "time_to_baseline_residual",
            "distance_to_baseline_residual",
            "source_error_0",
            "source_error_1",
            "stop_rule_time",
            *[f"map_false_sources{('_' + r) if r else ''}" for r in RULES],
            *[f"map_success{('_' + r) if r else ''}" for r in RULES],
            *[f"scene_residual_{k}" for k in range(3)],
        ]
        df = df.assign(**{c: np.nan for c in needed if c not in df.columns})
        df = df.sort_values(["searcher", "episode"])
        compact, wide = [], []
        for label in SEARCHERS:
            g = df[df.searcher == label]
            ref = PAPER[label]
            compact.append(
                [
                    label,
                    str(len(g)),
                    _ms(g.search_time, 0),
                    _ms(g.path_length, 0),
                    _ms(g.residual_uncertainty, 0),
                    _count(g, "map_success"),
                    _stopped(g),
                    _ms(g.map_false_sources),
                ]
            )
            compact.append(
                [
                    f"  paper, {ref['source'].split(' (')[0]}",
                    "1",
                    fmt(ref["time"]),
                    fmt(ref["distance"]),
                    fmt(ref["residual"]),
                    "both",
                    "yes",
                    "some",
                ]
            )
            wide.append(
                [
                    label,
                    str(len(g)),
                    _count(g, "declared"),
                    _stopped(g),
                    _ms(g.search_time - g.stop_rule_time, 0),
                    _ms(g.search_time),
                    _ms(g.path_length),
                    _ms(g.residual_uncertainty),
                    fmt(mean_sd(g.initial_uncertainty)[0], 0),
                    _ms(g.source_error_0, 2),
                    _ms(g.source_error_1, 2),
                    *[
                        cell
                        for r in MAP_RULES
                        for cell in (
                            _count(g, f"map_success_{r}"),
                            _ms(g.get(f"map_false_sources_{r}", [])),
                        )
                    ],
                ]
            )
        rule = DSMapParams().source_rule
        tables = [
            Table(
                "summary",
                "D-S mapping, ours (mean ± sd over flows) vs paper",
                ["method", "n", "time s", "distance m", "ΣX", "both found", "stopped", "false"],
                compact,
                note=f"both found: each true source has a mapped source within the success "
                f"radius in the final map (source rule {rule!r}); stopped: flows whose route "
                "ended by its own rule (else the time limit); false: mapped sources farther "
                "from both",
            ),
            Table(
                "summary_wide",
                "D-S mapping: every column (mean ± sd over flows)",
                [
                    "method",
                    "n",
                    "declared",
                    "stopped",
                    "visits s",
                    "time s",
                    "distance m",
                    "residual ΣX",
                    "initial ΣX",
                    "err src1 m",
                    "err src2 m",
                    *[h for r in MAP_RULES for h in (f"both ({r})", f"false ({r})")],
                ],
                wide,
                note="visits s: time from eq. 7's stop rule to the end of the mission (the dynamic "
                "route's visits to its mapped sources)",
                console=False,
            ),
        ]
        dyn = df[df.searcher == DYNAMIC].set_index("episode")
        rw = df[df.searcher == WAVE].set_index("episode")
        paired = pd.DataFrame(
            {
                "time": dyn.search_time / rw.search_time,
                "distance": dyn.path_length / rw.path_length,
                "residual": dyn.residual_uncertainty / rw.residual_uncertainty,
            }
        )
        if "time_to_baseline_residual" in dyn:
            paired["equal-residual time"] = dyn.time_to_baseline_residual / rw.search_time
            paired["equal-residual distance"] = dyn.distance_to_baseline_residual / rw.path_length
        rows = []
        for c in paired.columns:
            v = paired[c]
            paper = RATIOS.get(c)
            below = int((v < 1).sum())
            rows.append([c, _ms(v, 2), f"{below}/{int(v.notna().sum())}", fmt(paper, 2)])
        tables.append(
            Table(
                "paired",
                "Paired per flow, dynamic / wave (paper: ratios of its single run)",
                ["ratio", "ours", "below 1", "paper"],
                rows,
                note="equal-residual: the dynamic route's time and distance when its map first "
                "reached the wave's final ΣX on the same flow",
            )
        )
        scenes = []
        for label in SEARCHERS:
            g = df[df.searcher == label]
            for k, (t_scene, _, x_paper) in enumerate(SCENES[label]):
                col = f"scene_residual_{k}"
                ours = _ms(g[col], 0) if col in g else "-"
                scenes.append([label, "abc"[k], fmt(t_scene), ours, fmt(x_paper)])
        tables.append(
            Table(
                "scenes",
                "ΣX over the search region at the paper's scenes (Figs. 1-2)",
                ["method", "scene", "time s", "ours ΣX", "paper ΣX"],
                scenes,
            )
        )
        return tables

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        from odorloc.papers.odor_path.figures import odor_path_figure

        recs = _flow0(df, store)
        figs = []
        if recs:
            figs += [
                Figure(
                    "state_maps.png",
                    "D-S state maps at three moments of flow 0 (cf. paper Figs. 1-2)",
                    lambda p: _state_map_figure(recs, p),
                ),
                Figure(
                    "uncertainty_vs_time.png",
                    "Residual uncertainty ΣX against time, flow 0, with the paper's scenes",
                    lambda p: _uncertainty_figure(recs, p),
                ),
            ]
        figs.append(
            Figure(
                "odor_path_calm_gusty.png",
                "Odor-path maps and sub-window ellipses, calm and gusty wind (odor-path paper "
                "Figs. 4-5)",
                odor_path_figure,
            )
        )
        return figs


def _flow0(df: Any, store: Any) -> dict[str, Any]:
    """Flow 0's recordings and final maps per route, from the store's kept arrays."""
    from odorloc.engine.recorder import Recording
    from odorloc.experiments.runner import cell_scenario
    from odorloc.geometry.regions import check_region
    from odorloc.inference.evidence.mapper import DSMapParams, DSMapper

    out: dict[str, Any] = {}
    for label in SEARCHERS:
        g = df[(df.searcher == label) & (df.episode == 0)]
        if not len(g):
            continue
        arrays = store.arrays(str(g.iloc[0].cell_id), 0)
        if arrays is None:
            continue
        rec = Recording.from_arrays(arrays)
        maps = [(t, b) for t, b in rec.beliefs if "m_s" in b]
        if not maps:
            continue
        sc = cell_scenario({"scenario": SCENARIO})
        region = check_region(sc.task.region)
        mapper = DSMapper(DSMapParams(), region, sc.limits.control_dt)
        row = g.iloc[0]
        n = int(row.get("mapped_sources", 0) or 0) if "mapped_sources" in g else 0
        mapped = [(row.get(f"mapped_x_{k}"), row.get(f"mapped_y_{k}")) for k in range(n)]
        out[label] = {
            "recording": rec,
            "final": maps[-1],
            "lower": mapper.grid.grid.lower,
            "upper": mapper.grid.grid.upper,
            "region": region,
            "mapped": np.array([m for m in mapped if np.all(np.isfinite(m))], float),
        }
    return out


def _snapshots(entry: dict[str, Any], label: str) -> list[tuple[float, dict[str, np.ndarray]]]:
    """Three map snapshots like the paper's scenes (Figs. 1-2)."""
    rec = entry["recording"]
    snaps = [(t, b) for t, b in rec.beliefs if "m_s" in b]
    if label == WAVE and "waypoint" in rec.diagnostics:
        # end of rounds 1 and 3, at the round's last corner like the paper's scenes (before
        # the way back): the waypoint index reaches 1/5 and 3/5 of all waypoints
        wp = rec.diagnostics["waypoint"]
        per_round = wp.max() / SEARCHERS[WAVE]["rounds"] if wp.size else 1.0
        wanted = [rec.t[min(np.searchsorted(wp, r * per_round), len(wp) - 1)] for r in (1, 3)]
    else:
        wanted = [400.0, 800.0]
    picks = []
    for w in wanted:
        if snaps:
            i = int(np.argmin([abs(t - w) for t, _ in snaps]))
            picks.append(snaps[i])
    picks.append(entry["final"])
    return picks


def _state_map_figure(recs: dict[str, Any], path: Path) -> None:
    from matplotlib.colors import ListedColormap

    from odorloc.viz.backend import pyplot

    plt = pyplot()
    from matplotlib.patches import Patch, Rectangle

    from odorloc.inference.evidence.dempster_shafer import cell_uncertainty

    cmap = ListedColormap(["0.6", "white", "black"])  # unknown, free, occupied
    labels = list(recs)
    fig, axes = plt.subplots(len(labels), 3, figsize=(12, 5.2 * len(labels)), squeeze=False)
    for r, label in enumerate(labels):
        entry = recs[label]
        rec = entry["recording"]
        lo, hi = entry["lower"], entry["upper"]
        (rx0, ry0), (rx1, ry1) = entry["region"]
        for c, (t, snap) in enumerate(_snapshots(entry, label)):
            ax = axes[r, c]
            ms, mn = snap["m_s"], snap["m_n"]
            state = np.zeros(ms.shape, int)
            state[(mn >= 0.5) & (mn > ms)] = 1
            state[(ms >= 0.5) & (ms > mn)] = 2
            ax.imshow(
                state.T,
                origin="lower",
                extent=(lo[0], hi[0], lo[1], hi[1]),
                cmap=cmap,
                vmin=0,
                vmax=2,
                interpolation="nearest",
            )
            k = int(np.searchsorted(rec.t, t, side="right"))
            pos = rec.positions[:k, 0]
            ax.plot(pos[:, 0], pos[:, 1], "-", color="tab:green", lw=0.6)
            if len(pos):
                ax.plot(*pos[-1, :2], "o", color="tab:green", mec="k")
            ax.plot(rec.sources[:, 0], rec.sources[:, 1], "*", color="red", mec="k", ms=13)
            mapped = entry.get("mapped", np.zeros((0, 2)))
            if c == 2 and len(mapped):
                ax.plot(mapped[:, 0], mapped[:, 1], "X", color="tab:orange", mec="k", ms=10)
            ax.add_patch(Rectangle((rx0, ry0), rx1 - rx0, ry1 - ry0, fill=False, ec="gold", lw=2))
            d = float(np.sum(np.linalg.norm(np.diff(pos[:, :2], axis=0), axis=1)))
            x = cell_uncertainty(ms, mn, snap["m_u"])
            # only the region's cells count (those of the map's margin are ignored, as in the
            # paper and in the table)
            xc = lo[0] + (np.arange(ms.shape[0]) + 0.5) * (hi[0] - lo[0]) / ms.shape[0]
            yc = lo[1] + (np.arange(ms.shape[1]) + 0.5) * (hi[1] - lo[1]) / ms.shape[1]
            inside = ((xc >= rx0) & (xc <= rx1))[:, None] & ((yc >= ry0) & (yc <= ry1))[None, :]
            x = np.where(inside, x, 0.0)
            ax.set_title(f"{label}\nt = {t:.0f} s, {d:.0f} m, ΣX = {x.sum():.0f}", fontsize=9)
            ax.set_xlim(rx0 - 1.0, rx1 + 1.0)
            ax.set_ylim(ry0 - 1.0, ry1 + 1.0)
            ax.set_aspect("equal")
    from matplotlib.lines import Line2D

    rule = DSMapParams().source_rule
    handles = [
        Patch(color="0.6", label="unknown"),
        Patch(fc="white", ec="k", label="free"),
        Patch(color="black", label="occupied by a source"),
        Line2D([], [], ls="", marker="*", color="red", mec="k", ms=12, label="true source"),
        Line2D(
            [],
            [],
            ls="",
            marker="X",
            color="tab:orange",
            mec="k",
            ms=9,
            label=f"mapped source at the end ({rule} rule)",
        ),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=5)
    fig.suptitle("D-S state maps at three moments (cf. paper Figs. 1-2)")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _uncertainty_figure(recs: dict[str, Any], path: Path) -> None:
    from odorloc.viz.backend import pyplot

    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7, 3.6))
    colors = {DYNAMIC: "tab:red", WAVE: "tab:blue"}
    for label, entry in recs.items():
        rec = entry["recording"]
        if "total_uncertainty" in rec.diagnostics:
            ax.plot(
                rec.t,
                rec.diagnostics["total_uncertainty"],
                color=colors.get(label),
                label=f"{label} (ours, flow 0)",
            )
        pts = np.array(SCENES[label])
        ax.plot(
            pts[:, 0],
            pts[:, 2],
            "*",
            color=colors.get(label),
            mec="k",
            ms=11,
            label=f"{label} (paper scenes)",
        )
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Σ X over the search region")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
