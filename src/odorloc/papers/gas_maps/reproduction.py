"""``odorloc reproduce gas-maps``: four gas maps x three exploration paths x two worlds.

Per world (``indoor-ventilated``: the ventilated room, 300 s; ``two-sources-farrell``: two
sources in a meandering flow, 900 s) each episode's flow is recorded once and replayed to three
exploration paths: the lawn-mower (``rectangular-wave``, lanes 0.5 m / 2 m apart, as many rounds
as the time allows), a correlated ``random-walk`` and the D-S route (``ds-mapping``, which may end
the mission early by its own stop rule). The scenarios end at their time limit (``task.end:
limits``: the two other paths never declare); a path's mission ends at its first declaration, so
its readings and its truth stop there. Every path's readings (one per 0.5 s) are mapped by each
member of the ``gas_map`` family on the cells of the recorded plume frames (0.1 m indoors, 0.5 m
in the Farrell world) and scored against the plume's concentration averaged over the mission
(frames every 1 s / 2 s):

* the readings are split into 10 s stretches of the path; every fifth stretch is held out for the
  NLPD and never enters a map;
* each member's free parameters are chosen by cross-validated NLPD on the remaining readings
  (up to 4 folds of 10 s stretches): the kernel width among 1, 2, 4 and 8 cells for the kernel
  methods; the neighbour information among 0.5, 5, 50 and 500 and a fresh reading's information
  among 1, 10, 100 and 1000 for the GMRF (both in units of the largest reading^-2); the other
  parameters are the members' defaults (all of them in an episode too short for two folds); the
  cell size is fixed by the truth's cells;
* RMSE and the KL divergence of the normalised maps are taken over the free cells of the task's
  search region (the whole room indoors); the peak distance is the mean over the sources of the
  distance to the nearest of the map's K separated maxima (K sources, separated by the
  scenario's success radius).

The tables give the mean and a 95 % bootstrap interval over episodes per world x path x map, and
which map scores best on each path; the figures show episode 0's mean and standard deviation maps
beside the time-averaged truth.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from odorloc.core.registry import register
from odorloc.experiments.reproduction import (
    Citation,
    Figure,
    Reproduction,
    ReproductionParams,
    Table,
)

__all__ = [
    "CITATIONS",
    "METHODS",
    "PATHS",
    "WORLDS",
    "GasMapsReproduction",
    "gas_group",
    "map_episode",
    "mission_end",
]

CITATIONS = (
    Citation(
        authors="Lilienthal, A. J.; Reggente, M.; Trincavelli, M.; Blanco, J. L.; Gonzalez, J.",
        title=(
            "A statistical approach to gas distribution modelling with mobile robots - the "
            "Kernel DM+V algorithm"
        ),
        venue="IEEE/RSJ International Conference on Intelligent Robots and Systems (IROS), 570-576",
        year=2009,
        doi="10.1109/IROS.2009.5354304",
    ),
    Citation(
        authors="Reggente, M.; Lilienthal, A. J.",
        title=(
            "Using local wind information for gas distribution mapping in outdoor environments "
            "with a mobile robot"
        ),
        venue="IEEE Sensors 2009, 1715-1720",
        year=2009,
        doi="10.1109/ICSENS.2009.5398498",
    ),
    Citation(
        authors="Asadi, S.; Fan, H.; Hernandez Bennetts, V.; Lilienthal, A. J.",
        title="Time-dependent gas distribution modelling",
        venue="Robotics and Autonomous Systems 96, 157-170",
        year=2017,
        doi="10.1016/j.robot.2017.05.012",
    ),
    Citation(
        authors="Monroy, J. G.; Blanco, J.-L.; Gonzalez-Jimenez, J.",
        title="Time-variant gas distribution mapping with obstacle information",
        venue="Autonomous Robots 40(1), 1-16",
        year=2016,
        doi="10.1007/s10514-015-9437-0",
    ),
)
"""The papers of the four maps: Kernel DM+V, Kernel DM+V/W, TD Kernel DM+V and the GMRF map."""

#: world label -> scenario, time limit (s), map cell (m), truth frame period (s), path settings
WORLDS: dict[str, dict[str, Any]] = {
    "indoor": {
        "scenario": "indoor-ventilated",
        "time": 300.0,
        "cell": 0.1,
        "frame_every": 1.0,
        "paths": {
            "lawn-mower": ("rectangular-wave", {"lane_spacing": 0.5, "rounds": 20}),
            "random-walk": ("random-walk", {}),
            "ds-route": ("ds-mapping", {"cell_size": 0.25}),
        },
    },
    "farrell": {
        "scenario": "two-sources-farrell",
        "time": 900.0,
        "cell": 0.5,
        "frame_every": 2.0,
        "paths": {
            "lawn-mower": ("rectangular-wave", {"lane_spacing": 2.0, "rounds": 20}),
            "random-walk": ("random-walk", {}),
            "ds-route": ("ds-mapping", {}),
        },
    },
}
PATHS = ("lawn-mower", "random-walk", "ds-route")

#: map label -> registry name and the candidates of its cross-validated parameters (kernel
#: widths in cells)
METHODS: dict[str, tuple[str, dict[str, tuple[float, ...]]]] = {
    "kernel-dmv": ("kernel-dmv", {"kernel_width": (1.0, 2.0, 4.0)}),
    "kernel-dmvw": ("kernel-dmvw", {"kernel_width": (1.0, 2.0, 4.0)}),
    "td-kernel-dmv": ("td-kernel-dmv", {"kernel_width": (1.0, 2.0, 4.0)}),
    "gmrf": (
        "gmrf",
        {
            "prior_information": (0.5, 5.0, 50.0, 500.0),
            "observation_information": (1.0, 10.0, 100.0),
        },
    ),
}
SCORES = ("rmse", "kl", "nlpd", "peak_distance")
HOLD_BLOCK = 10.0  # s, the stretches of path held out together
HOLD_EVERY = 5  # every fifth stretch is held out
CV_FOLDS = 4


def col(method: str, score: str) -> str:
    """The row column of ``score`` for map ``method``."""
    return f"{method.replace('-', '_')}_{score}"


def _world(task: Any) -> dict[str, Any]:
    return WORLDS[str(task.cell.get("scenario_label"))]


def _prepare(sc: Any, task: Any) -> Any:
    # every reading, and plume frames on the map's cells (the truth); no belief snapshots
    w = _world(task)
    every = max(1, round(w["frame_every"] / sc.limits.control_dt))
    rc = sc.recording.model_copy(
        update={
            "stride": 1,
            "plume_stride": every,
            "plume_grid": 1.0 / w["cell"],
            "belief_stride": 10**9,
        }
    )
    return sc.model_copy(update={"recording": rc})


def mission_end(rec: Any) -> float | None:
    """Time of the recording's first declaration, s (``None``: it never declared)."""
    ends = [float(e["t"]) for e in rec.meta.get("events", []) if e.get("kind") == "declaration"]
    return min(ends) if ends else None


def map_episode(
    rec: Any,
    sc: Any,
    cell: float,
    chosen: dict[str, dict[str, float]] | None = None,
) -> dict[str, Any]:
    """Every map of one recorded episode: the truth, the held-out readings and per map label
    its built map, chosen parameters and scores (``chosen``: the parameters per map label, no
    cross-validation). The mission ends at the path's first declaration (the D-S route's stop
    rule): readings and plume frames after it are left out."""
    from odorloc.experiments.gas_maps import (
        arena_of,
        frame_grid,
        readings_from_recording,
        score_map,
        time_averaged_truth,
    )
    from odorloc.inference.gas_map import build_gas_map, time_blocks
    from odorloc.inference.gas_map.selection import select_parameters

    grid, truth = time_averaged_truth(rec)
    arena = arena_of(rec)
    readings = readings_from_recording(rec)
    until = mission_end(rec)
    if until is not None:
        readings = readings.subset(readings.t <= until)
        frames = np.asarray(rec.plume_t, float) <= until
        if frames.any():
            grid, truth = frame_grid(rec), np.asarray(rec.plume_frames, float)[frames].mean(0)
    fold = time_blocks(readings, HOLD_BLOCK, HOLD_EVERY)
    train, held = readings.subset(fold != 0), readings.subset(fold == 0)
    region = sc.task.region
    mask = grid.region_mask(region) if region is not None else np.ones(grid.shape, bool)
    out: dict[str, Any] = {"grid": grid, "truth": truth, "mask": mask, "readings": readings}
    # as many folds as the training readings hold stretches, up to CV_FOLDS
    stretches = np.unique(np.floor((train.t - train.t.min()) / HOLD_BLOCK)) if len(train) else []
    folds = min(CV_FOLDS, len(stretches))
    for label, (name, cands) in METHODS.items():
        given = (chosen or {}).get(label, {})
        if given and all(math.isfinite(given.get(k, math.nan)) for k in cands):
            best = {k: given[k] for k in cands}
        elif folds < 2:
            best = {}  # too short an episode to cross-validate: the member's defaults
        else:
            grid_cands = {
                k: [v * (cell if k == "kernel_width" else 1.0) for v in vs]
                for k, vs in cands.items()
            }
            best = select_parameters(
                name, train, lambda _c: grid, grid_cands, {}, folds, HOLD_BLOCK, arena
            ).best
        gm = build_gas_map(name, **best)
        gm.start(grid, arena)
        gm.update(train.positions, train.values, wind=train.wind, t=train.t)
        scores = score_map(gm, truth, rec.sources, held, mask, separation=sc.task.success_radius)
        used = gm.params.model_dump()
        out[label] = {"map": gm, "params": {k: used[k] for k in cands}, "scores": scores}
    return out


def _extras(task: Any, res: Any, rows: dict[str, dict[str, Any]]) -> dict[str, Any]:
    from odorloc.experiments.runner import cell_scenario

    t0 = time.process_time()
    rec = res.recording
    maps = map_episode(rec, cell_scenario(task.cell), _world(task)["cell"])
    row: dict[str, Any] = {"n_readings": len(maps["readings"])}
    for label in METHODS:
        entry = maps[label]
        for k, v in entry["params"].items():
            row[col(label, k)] = float(v)
        for k, v in entry["scores"].items():
            row[col(label, k)] = float(v)
    row["mapping_cpu_time"] = time.process_time() - t0
    return row


def gas_group(tasks: list[Any]) -> list[dict[str, Any]]:
    """One flow replayed to the three paths, each path's readings mapped and scored."""
    from odorloc.experiments.runner import run_replay_group

    return run_replay_group(tasks, record=True, extras=_extras, prepare=_prepare)


def _interval(x: Any, rng: np.random.Generator) -> tuple[float, float, float]:
    from odorloc.experiments.stats import bootstrap_ci

    a = np.asarray(x, float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return math.nan, math.nan, math.nan
    lo, hi = bootstrap_ci(a, rng)
    return float(a.mean()), lo, hi


def _num(x: float) -> str:
    digits = 0 if abs(x) >= 10 else 1 if abs(x) >= 1 else 2
    return f"{x:.{digits}f}"


def _cell_text(m: float, lo: float, hi: float) -> str:
    if not math.isfinite(m):
        return "-"
    if not math.isfinite(lo):
        return _num(m)
    return f"{_num(m)} [{_num(lo)}, {_num(hi)}]"


@register("reproduction", "gas-maps", ReproductionParams, "gas maps x paths x two worlds")
class GasMapsReproduction(Reproduction):
    """Kernel DM+V, DM+V/W, TD Kernel DM+V and the GMRF map on three paths, two worlds."""

    name = "gas-maps"
    paper = "Lilienthal 2009, Reggente 2009, Asadi 2017, Monroy 2016"
    citations = CITATIONS
    summary = "gas maps (Kernel DM+V, DM+V/W, TD, GMRF) x 3 paths x 2 worlds vs the truth"
    default_episodes = 20
    paper_episodes = 30
    paper_episodes_note = "no paper runs this comparison; 30 episodes narrow the intervals"
    report_paired = False
    cell_summary = False
    success_label = "not used: the maps are scored against the time-averaged truth"
    worlds: ClassVar[tuple[str, ...]] = tuple(WORLDS)

    def __init__(
        self, params: ReproductionParams | None = None, time_limit: float | None = None
    ) -> None:
        super().__init__(params)
        self.time_limit = time_limit

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        n = self.default_episodes if episodes is None else int(episodes)
        out = {}
        for world, w in WORLDS.items():
            limit = w["time"] if self.time_limit is None else float(self.time_limit)
            out[world] = {
                "name": f"gas-maps {world}",
                "seed": seed,
                "episodes": n,
                "replay": True,
                "keep_episodes": [0],
                "scenarios": [
                    {
                        "name": w["scenario"],
                        "label": world,
                        # the maps are compared, not declarations: every path runs to the limit
                        "params": {"limits.time": limit, "task.end": "limits"},
                    }
                ],
                "searchers": [
                    {"name": name, "label": label, "params": dict(params)}
                    for label, (name, params) in w["paths"].items()
                ],
            }
        return out

    def group_fn(self) -> Any:
        return gas_group

    def tables(self, df: Any, seed: int) -> list[Table]:
        rng = np.random.default_rng(seed)
        heads = ["RMSE", "KL nats", "NLPD", "peak→src m"]
        tables, wins, params = [], [], []
        for world in WORLDS:
            rows = []
            for path in PATHS:
                g = _rows(df, world, path)
                means: dict[str, dict[str, float]] = {}
                for label in METHODS:
                    cells = []
                    for score in SCORES:
                        m, lo, hi = _interval(g.get(col(label, score), []), rng)
                        means.setdefault(score, {})[label] = m
                        cells.append(_cell_text(m, lo, hi))
                    rows.append([path, label, *cells])
                    for key in METHODS[label][1]:
                        chosen = np.asarray(g.get(col(label, key), []), float)
                        chosen = chosen[np.isfinite(chosen)]
                        values, counts = np.unique(chosen, return_counts=True)
                        pairs = zip(values, counts, strict=True)
                        text = ", ".join(f"{v:g}: {c}" for v, c in pairs)
                        params.append([world, path, label, key, text])
                best = []
                for score in SCORES:
                    ok = {k: v for k, v in means.get(score, {}).items() if math.isfinite(v)}
                    best.append(min(ok, key=ok.__getitem__) if ok else "-")
                wins.append([world, path, str(len(g)), *best])
            tables.append(
                Table(
                    f"scores_{world}",
                    f"{WORLDS[world]['scenario']}: maps against the time-averaged truth, mean "
                    "[95 % interval] over episodes",
                    ["path", "map", *heads],
                    rows,
                    left=2,
                    note="RMSE and KL over the search region's free cells; NLPD of held-out "
                    "stretches of the path; peak→src: source to the nearest map maximum",
                )
            )
        tables.append(
            Table(
                "best",
                "Best map per world and path (lowest mean)",
                ["world", "path", "n", *heads],
                wins,
                left=2,
            )
        )
        tables.append(
            Table(
                "selected",
                "Parameters chosen by cross-validated NLPD (value: episodes)",
                ["world", "path", "map", "parameter", "chosen (value: episodes)"],
                params,
                left=5,
                console=False,
            )
        )
        return tables

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        figs = []
        cache: dict[str, dict[str, Any]] = {}

        def maps_of(world: str) -> dict[str, Any]:
            if world not in cache:
                cache[world] = _episode0(df, out / f"{world}.sqlite", world)
            return cache[world]

        for world in WORLDS:
            for kind in ("mean", "std"):
                figs.append(
                    Figure(
                        f"gas_maps_{world}_{kind}.png",
                        f"{WORLDS[world]['scenario']}, episode 0: each path's "
                        f"{'mean' if kind == 'mean' else 'standard deviation'} maps beside the "
                        "time-averaged truth",
                        lambda p, w=world, k=kind: _map_figure(maps_of(w), w, k, p),
                    )
                )
        figs.append(
            Figure(
                "gas_maps_scores.png",
                "RMSE and NLPD per world, path and map (mean and 95 % interval over episodes)",
                lambda p: _score_figure(df, p, seed),
            )
        )
        return figs


def _rows(df: Any, world: str, path: str) -> Any:
    if not len(df) or "scenario" not in df or "searcher" not in df:
        return df.iloc[0:0]
    g = df[(df.scenario == world) & (df.searcher == path)]
    if "status" in g:
        g = g[g.status == "ok"]
    return g


def _episode0(df: Any, store_path: Path, world: str) -> dict[str, Any]:
    """Episode 0 of every path of ``world``: its recording's maps (from the stored arrays)."""
    from odorloc.engine.recorder import Recording
    from odorloc.experiments.runner import cell_scenario
    from odorloc.experiments.store import ResultStore

    out: dict[str, Any] = {}
    if not store_path.is_file():
        return out
    with ResultStore(store_path, readonly=True) as store:
        for path in PATHS:
            g = _rows(df, world, path)
            g = g[g.episode == 0] if len(g) else g
            if not len(g):
                continue
            arrays = store.arrays(str(g.iloc[0].cell_id), 0)
            if arrays is None:
                continue
            rec = Recording.from_arrays(arrays)
            if rec.plume_frames.ndim != 3 or not len(rec.plume_frames):
                continue
            sc = cell_scenario({"scenario": WORLDS[world]["scenario"]})
            row = g.iloc[0]
            # the parameters the episode's cross-validation chose (stored with its row)
            chosen = {
                m: {k: float(row.get(col(m, k), math.nan)) for k in METHODS[m][1]} for m in METHODS
            }
            out[path] = {"rec": rec, **map_episode(rec, sc, WORLDS[world]["cell"], chosen)}
    return out


def _map_figure(maps: dict[str, Any], world: str, kind: str, target: Path) -> None:
    import matplotlib.pyplot as plt

    from odorloc.viz.gas_map import draw_cells

    rows = [p for p in PATHS if p in maps]
    ncols = 1 + len(METHODS)
    if not rows:
        fig, ax = plt.subplots(figsize=(6, 2))
        ax.text(0.5, 0.5, "no stored episode 0 to draw", ha="center", va="center")
        ax.set_axis_off()
        fig.savefig(target, dpi=100)
        plt.close(fig)
        return
    first = maps[rows[0]]
    grid, mask = first["grid"], first["mask"]
    xs, ys = grid.x_centers()[mask.any(axis=1)], grid.y_centers()[mask.any(axis=0)]
    cx, cy = grid.cells[:2]
    box = (xs.min() - cx, xs.max() + cx, ys.min() - cy, ys.max() + cy)
    aspect = (box[3] - box[2]) / max(box[1] - box[0], 1e-9)
    w = 2.6
    fig, axes = plt.subplots(
        len(rows), ncols, figsize=(w * ncols, w * aspect * len(rows) + 0.8), squeeze=False
    )
    from matplotlib import colors

    for r, path in enumerate(rows):
        e = maps[path]
        truth = e["truth"]
        if kind == "mean":
            fields = [truth, *(e[m]["map"].mean() for m in METHODS)]
            top = max(float(np.percentile(f[mask], 99.5)) for f in fields)
            norm = colors.Normalize(0.0, top if top > 0 else 1.0)
        else:
            fields = [truth, *(np.sqrt(e[m]["map"].predictive_variance()) for m in METHODS)]
            tops = [float(np.percentile(f[mask], 99.0)) for f in fields[1:]]
            norm = colors.Normalize(0.0, max(max(tops), 1e-9))
        names = ["time-averaged truth", *METHODS]
        for c, (name, field) in enumerate(zip(names, fields, strict=True)):
            ax = axes[r, c]
            cmap = "viridis" if (kind == "mean" or c == 0) else "magma"
            use = norm
            if kind != "mean" and c == 0:
                use = colors.Normalize(0.0, max(float(truth[mask].max()), 1e-9))
            blocked = e[METHODS_FIRST]["map"].blocked
            im = draw_cells(ax, grid, field, cmap=cmap, norm=use, blocked=blocked)
            pos = e["rec"].positions[:, 0, :]
            if c == 0:
                ax.plot(pos[:, 0], pos[:, 1], "-", color="tab:red", lw=0.4, alpha=0.8)
            src = e["rec"].sources
            ax.plot(src[:, 0], src[:, 1], "*", color="gold", mec="k", ms=9)
            if c > 0:
                est = e[name]["map"].estimate()
                ax.plot(est[:, 0], est[:, 1], "x", color="white", mew=1.5, ms=6)
                s = e[name]["scores"]
                ax.set_title(f"{name}\nRMSE {s['rmse']:.2g}, NLPD {s['nlpd']:.2g}", fontsize=7)
            else:
                ax.set_title(f"{path}: truth (path in red)", fontsize=7)
            ax.set_xlim(box[0], box[1])
            ax.set_ylim(box[2], box[3])
            ax.tick_params(labelsize=6)
            if c in (0, ncols - 1):
                fig.colorbar(im, ax=ax, shrink=0.75).ax.tick_params(labelsize=6)
    what = "mean maps" if kind == "mean" else "standard deviation of a new reading"
    fig.suptitle(f"{WORLDS[world]['scenario']}, episode 0: {what}", fontsize=9)
    fig.tight_layout()
    fig.savefig(target, dpi=100)
    plt.close(fig)


METHODS_FIRST = next(iter(METHODS))


def _score_figure(df: Any, target: Path, seed: int) -> None:
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(seed)
    fig, axes = plt.subplots(2, len(WORLDS), figsize=(5.2 * len(WORLDS), 6.4), squeeze=False)
    offsets = np.linspace(-0.3, 0.3, len(METHODS))
    for j, world in enumerate(WORLDS):
        for i, score in enumerate(("rmse", "nlpd")):
            ax = axes[i, j]
            for k, label in enumerate(METHODS):
                for p, path in enumerate(PATHS):
                    g = _rows(df, world, path)
                    m, lo, hi = _interval(g.get(col(label, score), []), rng)
                    if not math.isfinite(m):
                        continue
                    err = None
                    if math.isfinite(lo):
                        err = [[max(m - lo, 0.0)], [max(hi - m, 0.0)]]
                    ax.errorbar(
                        p + offsets[k], m, yerr=err, fmt="o", color=f"C{k}", ms=4, capsize=2,
                        label=label if p == 0 else None,
                    )  # fmt: skip
            ax.set_xticks(range(len(PATHS)), PATHS, fontsize=8)
            ax.set_ylabel(score.upper(), fontsize=8)
            ax.set_title(WORLDS[world]["scenario"], fontsize=9)
            ax.grid(alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="lower center", ncol=len(METHODS), fontsize=8)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(target, dpi=100)
    plt.close(fig)
