"""Reproduction of the D-S multi-source mapping paper (registered by :mod:`.reproduce`).

Dynamic route (``ds-mapping``) versus the predefined rectangular wave (``ds-rectangular-wave``,
5 rounds, 2 m lanes), both building the same Dempster-Shafer map, in the ``two-sources-farrell``
scenario. As in the paper (section 4.1), the flow is recorded once per episode as a movie (plume
frames and the 15 x 15 wind every control period, :func:`odorloc.plume.replay.record_movie`)
and both routes run on its replay, so they face exactly the same plume and wind. Both routes
share the map parameters and the motion protocol of :mod:`odorloc.searchers.ds_mapping`
(stop-and-go sampling: one period moving at up to 0.5 m/s, one period standing still, which
gives the paper's 0.25 m/s average on the wave); the wave restarts every round from its first
corner like the paper's (1060.8 m for five rounds), and the dynamic route moves to one of the
neighbouring cells at each decision.

Per episode the table reports the time, the distance travelled, the residual uncertainty
``sum X_i`` over the search region (eq. 5), the distance from each true source to the nearest
mapped source and the mapped sources farther than ``success_radius`` from both true sources
(false sources), whether the searcher declared (planner stop rule / end of its rounds) or hit the
time limit.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.experiments.reproduce import _fmt, _register

#: The paper's numbers (sections 4.2-4.3): time s, distance m, residual sum of X.
DS_PAPER = {
    "ds-mapping": {"time": 2500.0, "distance": 496.1, "residual": 157.1, "source": "Sec. 4.3"},
    "ds-rectangular-wave": {
        "time": 4283.5,
        "distance": 1060.8,
        "residual": 254.1,
        "source": "Sec. 4.2 (5 rounds)",
    },
}
#: Scenes of Figs. 1-2: (time s, distance m, residual uncertainty).
DS_PAPER_SCENES = {
    "ds-rectangular-wave": [
        (781.5, 193.5, 1089.0),
        (2532.5, 627.1, 374.6),
        (4283.5, 1060.8, 254.1),
    ],
    "ds-mapping": [(400.0, 97.4, 1317.4), (800.0, 183.8, 683.0), (2500.0, 496.1, 157.1)],
}
SCENARIO = "two-sources-farrell"
SEARCHERS: dict[str, dict[str, Any]] = {
    "ds-rectangular-wave": {
        "type": "ds-rectangular-wave",
        "rounds": 5,
        "lane_spacing": 2.0,
        "lanes_along": "y",
    },
    "ds-mapping": {"type": "ds-mapping"},
}
_BELIEF_STRIDE = 40  # one map snapshot every 20 s of the recorded episode


@dataclass(frozen=True)
class _Task:
    """What :meth:`ResultStore.add` needs to file a row."""

    cell: dict[str, Any]
    cell_index: int
    cell_id: str
    world_key: str
    episode: int
    config_hash: str
    world_seed: int
    agent_seed: int


def _scenario(
    searcher: dict[str, Any], time_limit: float | None = None, max_speed: float | None = None
) -> Any:
    from odorloc.scenarios import Scenario, get_scenario

    sc = get_scenario(SCENARIO)
    data = sc.to_dict()
    shared = {k: v for k, v in data["searcher"].items() if k in ("cell_size",)}
    data["searcher"] = {**shared, **searcher}
    if time_limit is not None:
        data["limits"]["time"] = float(time_limit)
    if max_speed is not None:
        data["platform"]["max_speed"] = float(max_speed)
    return Scenario.from_dict(data)


def record_scenario_movie(sc: Any, world_seed: int, duration: float | None = None) -> Any:
    """Record the flow an episode of ``sc`` with ``world_seed`` would see, as a movie.

    The world is warmed up exactly as :func:`odorloc.engine.episode.run_episode` does, then a
    frame (plume state and the wind on the Farrell node grid) is stored every control period
    for ``duration`` seconds (default the time limit).

    Returns
    -------
    odorloc.plume.replay.Movie
    """
    from odorloc.engine.episode import episode_generators
    from odorloc.plume.replay import record_movie
    from odorloc.scenarios.build import build_world

    world = build_world(sc)
    rng_world = episode_generators(world_seed, 0)[0]  # the world stream ignores the agent seed
    T = sc.limits.control_dt
    n_sub = max(1, round(T / sc.world.dt))
    wdt = T / n_sub
    world.reset(rng_world)
    for _ in range(round(sc.world.warmup / wdt)):
        world.step(wdt, rng_world)
    nodes = sc.world.wind.values.get("nodes", (15, 15))
    return record_movie(
        world,
        float(duration if duration is not None else sc.limits.time),
        T,
        rng_world,
        dt=wdt,
        wind_shape=tuple(int(n) for n in nodes),
    )


def replay_built(sc: Any, movie: Any) -> tuple[Any, Any]:
    """``(scenario, built)`` running ``sc`` on the replay of ``movie`` (no warm-up: the movie
    starts where the recorded world's warm-up ended)."""
    from odorloc.plume.replay import ReplayParams, ReplayPlume, ReplayWind
    from odorloc.scenarios import Scenario
    from odorloc.scenarios.build import build
    from odorloc.world.world import World

    data = sc.to_dict()
    data["world"]["warmup"] = 0.0
    data["world"]["wind"] = {"type": "replay"}
    data["world"]["plume"] = {"type": "replay"}
    sc_r = Scenario.from_dict(data)
    live = build(sc)  # sensors, platform and searcher of the scenario
    arena = live.world.arena
    wind = ReplayWind(ReplayParams(), arena, movie=movie)
    plume = ReplayPlume(ReplayParams(), arena, wind, live.world.plume.sources, movie=movie)
    live.world = World(arena, wind, plume)
    live.scenario = sc_r
    return sc_r, live


def map_errors(
    row: dict[str, Any], sources: np.ndarray, radius: float, kind: str = "mapped", tag: str = ""
) -> dict[str, Any]:
    """Per-source errors of the mapped positions ``{kind}_x_k, {kind}_y_k`` in ``row``.

    Returns ``source_error_i{tag}`` (distance from true source ``i`` to the nearest mapped
    source, NaN if none), ``map_false_sources{tag}`` (mapped sources farther than ``radius``
    from every true source) and ``map_success{tag}`` (every true source within ``radius``).
    """
    k = int(row.get("mapped_sources", 0) or 0)
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


def _seed_job(args: tuple[int, int, float | None, bool, float | None]) -> dict[str, Any]:
    """Record one movie and run both searchers on it; returns rows (and recordings)."""
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.sweep import episode_seeds

    episode, root, max_speed, keep, time_limit = args
    # the sweep's seed derivation: both routes of an episode share the world seed
    world_seed, agent_seed = episode_seeds(root, SCENARIO, episode)
    t0 = time.perf_counter()
    base = _scenario(SEARCHERS["ds-mapping"], time_limit, max_speed)
    movie = record_scenario_movie(base, world_seed)
    movie_wall = time.perf_counter() - t0
    out: dict[str, Any] = {"episode": episode, "seeds": (world_seed, agent_seed), "rows": {}}
    out["recordings"] = {}
    baseline_residual = math.nan
    for label, searcher in SEARCHERS.items():
        sc = _scenario(searcher, time_limit, max_speed)
        # every episode keeps its per-step diagnostics; map snapshots only for the figures
        stride = _BELIEF_STRIDE if keep else 10**9
        sc = sc.model_copy(
            update={
                "recording": sc.recording.model_copy(
                    update={"belief_stride": stride, "plume_stride": 10**9 if not keep else 200}
                )
            }
        )
        sc_r, built = replay_built(sc, movie)
        res = run_episode(sc_r, world_seed, agent_seed, built=built, record=True)
        row = dict(res.metrics)
        row.update(map_errors(row, res.sources, sc.success_radius))
        row.update(map_errors(row, res.sources, sc.success_radius, "upwind", "_upwind"))
        row.update(map_errors(row, res.sources, sc.success_radius, "peak", "_peak"))
        row.update(map_errors(row, res.sources, sc.success_radius, "centroid", "_centroid"))
        if res.recording is not None:
            for k, (t_scene, _, _) in enumerate(DS_PAPER_SCENES[label]):
                row[f"scene_residual_{k}"] = residual_at(res.recording, t_scene)
        if label == "ds-rectangular-wave":
            baseline_residual = float(row["residual_uncertainty"])
        elif res.recording is not None:
            t_eq, d_eq = time_to_residual(res.recording, baseline_residual)
            row.update(time_to_baseline_residual=t_eq, distance_to_baseline_residual=d_eq)
        row.update(status="ok", error="", movie_wall_time=movie_wall, replay=True)
        out["rows"][label] = ({"type": sc.searcher.type, **sc.searcher.values}, row)
        if keep and res.recording is not None:
            grid = built.searcher.mapper.grid
            out["recordings"][label] = {
                "recording": res.recording,
                "final": (row["search_time"], grid.snapshot()),
                "lower": grid.grid.lower,
                "upper": grid.grid.upper,
                "region": built.searcher.mapper.region,
            }
    del movie
    return out


def _save_flow0(out: Path, recs: dict[str, Any]) -> None:
    """Keep flow 0's recordings and final maps on disk (the figures of a resumed run)."""
    for label, e in recs.items():
        e["recording"].save(out / f"flow0-{label}.npz")
        t_final, snap = e["final"]
        np.savez_compressed(
            out / f"flow0-{label}-map.npz",
            t_final=np.float64(t_final),
            lower=np.asarray(e["lower"], float),
            upper=np.asarray(e["upper"], float),
            region=np.asarray(e["region"], float),
            **snap,
        )


def _load_flow0(out: Path) -> dict[str, Any]:
    """What :func:`_save_flow0` wrote, or ``{}`` if any file is missing."""
    from odorloc.engine.recorder import Recording

    recs: dict[str, Any] = {}
    for label in SEARCHERS:
        rp, mp = out / f"flow0-{label}.npz", out / f"flow0-{label}-map.npz"
        if not (rp.is_file() and mp.is_file()):
            return {}
        with np.load(mp) as z:
            snap = {k: z[k] for k in ("m_s", "m_n", "m_u")}
            region = z["region"]
            recs[label] = {
                "recording": Recording.load(rp),
                "final": (float(z["t_final"]), snap),
                "lower": tuple(z["lower"]),
                "upper": tuple(z["upper"]),
                "region": ((region[0, 0], region[0, 1]), (region[1, 0], region[1, 1])),
            }
    return recs


def _mean_sd(x: Any) -> tuple[float, float]:
    a = np.asarray(x, float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return math.nan, math.nan
    return float(a.mean()), float(a.std(ddof=1)) if a.size > 1 else 0.0


def _ms(x: Any, d: int = 1) -> str:
    m, s = _mean_sd(x)
    return f"{_fmt(m, d)} ± {_fmt(s, d)}"


@_register(
    "ds-multi-source",
    "ds-multi-source-mapping.txt",
    "Sec. 4 and Figs. 1-2: D-S map with dynamic route vs rectangular wave, two sources",
)
def reproduce_ds(
    out: Path,
    episodes: int = 10,
    workers: int = 2,
    seed: int = 2024,
    progress: bool = True,
    time_limit: float | None = None,
    max_speed: float | None = None,
) -> dict[str, Any]:
    """Run the D-S reproduction; write table, figures and report into ``out``.

    Parameters
    ----------
    out : Path
        Output folder. Each finished flow is committed to ``results.sqlite`` there at once;
        running again with the same settings resumes (flows already stored are kept; more
        ``episodes`` extends the run).
    episodes : int
        Recorded flows (seeds); both routes run on each.
    workers : int
        Worker processes (one flow per task).
    seed : int
        Root seed (episode ``i`` uses :func:`~odorloc.experiments.sweep.episode_seeds`).
    progress : bool
        Print a line per finished flow.
    time_limit : float, optional
        Override the scenario's time limit, seconds (tests and quick looks).
    max_speed : float, optional
        Override the robot's speed limit, m/s (default the paper's 0.5 m/s; with the default
        stop-and-go sampling the robot averages about half of it, like the paper's robot on
        the rectangular wave: 1060.8 m in 4283.5 s).
    """
    import pandas as pd
    from rich.console import Console
    from rich.table import Table

    from odorloc.experiments.report import write_report
    from odorloc.experiments.store import ResultStore

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    console = Console(width=230)
    t_start = time.perf_counter()
    # ---- durable rows: every flow is committed as soon as it finishes; a rerun resumes
    store_path = out / "results.sqlite"
    spec = {
        "name": "ds-multi-source reproduction",
        "seed": seed,
        "scenario": SCENARIO,
        "searchers": SEARCHERS,
        "time_limit": time_limit,
        "max_speed": max_speed,
    }
    chash = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:16]
    cell_ids = {label: f"{SCENARIO}/{label}" for label in SEARCHERS}
    with ResultStore(store_path) as store:
        store.bind(chash)
        done = store.done_keys()
        recs = _load_flow0(out) if all((c, 0) in done for c in cell_ids.values()) else {}
        todo = [
            ep
            for ep in range(episodes)
            if not all((c, ep) in done for c in cell_ids.values()) or (ep == 0 and not recs)
        ]
        if progress and episodes - len(todo):
            console.print(f"resuming: {episodes - len(todo)} flow(s) already stored")
        jobs = [(ep, seed, max_speed, ep == 0, time_limit) for ep in todo]

        def _file(r: dict[str, Any]) -> None:
            for ci, (label, (sp, row)) in enumerate(r["rows"].items()):
                cell = {
                    "scenario": SCENARIO,
                    "searcher": label,
                    "searcher_params": sp,
                    "replay": True,
                }
                ep = r["episode"]
                task = _Task(cell, ci, cell_ids[label], str(ep), ep, chash, *r["seeds"])
                store.add(task, row)  # an episode already stored is kept as it was
            if r["recordings"]:
                _save_flow0(out, r["recordings"])
                recs.update(r["recordings"])
            if progress:
                console.print(f"flow {r['episode']} done ({time.perf_counter() - t_start:.0f} s)")

        if workers <= 1 or len(jobs) <= 1:
            for j in jobs:
                _file(_seed_job(j))
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                # committed in the order they finish, so a kill loses only running flows
                for fut in as_completed([pool.submit(_seed_job, j) for j in jobs]):
                    _file(fut.result())
        wall = time.perf_counter() - t_start
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pandas fragmentation notice on wide extras
            df = store.frame()
    df = df[df.episode < episodes]
    df = df.sort_values(["searcher", "episode"])

    # ---- table beside the paper
    t = Table(title="D-S multi-source mapping: ours (mean ± sd over flows) vs paper")
    cols = (
        "method",
        "n",
        "declared",
        "time s",
        "paper s",
        "distance m",
        "paper m",
        "residual ΣX",
        "paper ΣX",
        "initial ΣX",
        "err src1 m",
        "err src2 m",
        "both found",
        "false srcs",
        "upwind-end err 1/2 m",
        "both (upwind)",
        "both (peak)",
        "both (centroid)",
    )
    for c in cols:
        t.add_column(c, justify="right")
    summary_rows = []
    for label in SEARCHERS:
        g = df[df.searcher == label]
        ref = DS_PAPER[label]
        both = int(g["map_success"].fillna(False).astype(bool).sum())
        both_up = int(g["map_success_upwind"].fillna(False).astype(bool).sum())
        both_pk = int(g["map_success_peak"].fillna(False).astype(bool).sum())
        both_ct = int(g["map_success_centroid"].fillna(False).astype(bool).sum())
        row = {
            "method": label,
            "n": len(g),
            "declared": int(g["declared"].fillna(False).astype(bool).sum()),
            "time": _mean_sd(g.search_time),
            "distance": _mean_sd(g.path_length),
            "residual": _mean_sd(g.residual_uncertainty),
            "initial": _mean_sd(g.initial_uncertainty),
            "err0": _mean_sd(g.source_error_0),
            "err1": _mean_sd(g.source_error_1),
            "both_found": both,
            "false": _mean_sd(g.map_false_sources),
            "err0_upwind": _mean_sd(g.source_error_0_upwind),
            "err1_upwind": _mean_sd(g.source_error_1_upwind),
            "both_found_upwind": both_up,
            "err0_peak": _mean_sd(g.source_error_0_peak),
            "err1_peak": _mean_sd(g.source_error_1_peak),
            "both_found_peak": both_pk,
            "both_found_centroid": both_ct,
        }
        summary_rows.append(row)
        t.add_row(
            label,
            str(len(g)),
            str(row["declared"]),
            _ms(g.search_time),
            _fmt(ref["time"]),
            _ms(g.path_length),
            _fmt(ref["distance"]),
            _ms(g.residual_uncertainty),
            _fmt(ref["residual"]),
            _fmt(row["initial"][0], 0),
            _ms(g.source_error_0, 2),
            _ms(g.source_error_1, 2),
            f"{both}/{len(g)}",
            _ms(g.map_false_sources),
            f"{_fmt(row['err0_upwind'][0], 2)} / {_fmt(row['err1_upwind'][0], 2)}",
            f"{both_up}/{len(g)}",
            f"{both_pk}/{len(g)}",
            f"{both_ct}/{len(g)}",
        )
    console.print(t)
    console.print(f"wall time {wall:.0f} s on {workers} worker(s)")
    dyn = df[df.searcher == "ds-mapping"].set_index("episode")
    rw = df[df.searcher == "ds-rectangular-wave"].set_index("episode")
    paired = pd.DataFrame(
        {
            "time_ratio": dyn.search_time / rw.search_time,
            "distance_ratio": dyn.path_length / rw.path_length,
            "residual_ratio": dyn.residual_uncertainty / rw.residual_uncertainty,
        }
    )
    if "time_to_baseline_residual" in dyn:
        paired["equal_residual_time_ratio"] = dyn.time_to_baseline_residual / rw.search_time
        paired["equal_residual_distance_ratio"] = dyn.distance_to_baseline_residual / rw.path_length
    console.print(
        "paired dynamic / rectangular-wave ratios (per flow): "
        + ", ".join(f"{c} {_ms(paired[c], 2)}" for c in paired.columns)
        + "; paper: time 0.58, distance 0.47, residual 0.62"
    )

    if "time_to_baseline_residual" in dyn:
        eq_t = paired["equal_residual_time_ratio"]
        eq_d = paired["equal_residual_distance_ratio"]
        console.print(
            "at the wave's final residual ΣX "
            f"({_ms(rw.residual_uncertainty)}) the dynamic route had used "
            f"{_ms(eq_t, 2)} of the wave's time and {_ms(eq_d, 2)} of its distance "
            f"(below 1 in {int((eq_t < 1).sum())}/{len(eq_t)} flows; never reached in "
            f"{int(eq_t.isna().sum())})"
        )

    # ---- residual uncertainty at the paper's scenes (Figs. 1-2)
    st = Table(title="ΣX over the search region at the paper's scenes (mean ± sd over flows)")
    for c in ("method", "scene", "time s", "ours ΣX", "paper ΣX"):
        st.add_column(c, justify="right")
    for label in SEARCHERS:
        g = df[df.searcher == label]
        for k, (t_scene, _, x_paper) in enumerate(DS_PAPER_SCENES[label]):
            col = f"scene_residual_{k}"
            ours = _ms(g[col], 1) if col in g else "-"
            st.add_row(label, "abc"[k], _fmt(t_scene), ours, _fmt(x_paper))
    console.print(st)

    # ---- figures
    figs: list[Path] = []
    if recs:
        figs.append(_state_map_figure(recs, out))
        figs.append(_uncertainty_figure(recs, out))
    figs.append(odor_path_figure(out / "odor_path_calm_gusty.png"))

    reference = {
        label: {"mean_time": ref["time"], "source": ref["source"]}
        for label, ref in DS_PAPER.items()
    }
    df.to_csv(out / "results.csv", index=False)
    pd.DataFrame(
        [
            {k: (v[0] if isinstance(v, tuple) else v) for k, v in r.items()}
            | {f"{k}_sd": v[1] for k, v in r.items() if isinstance(v, tuple)}
            for r in summary_rows
        ]
    ).to_csv(out / "summary.csv", index=False)
    paired.to_csv(out / "paired.csv")
    with ResultStore(store_path, readonly=True) as store, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = write_report(
            store, out / "report.html", title="ds-multi-source reproduction", reference=reference
        )
    for p in [*figs, report]:
        console.print(f"wrote {p}")
    return {
        "results": df,
        "summary": summary_rows,
        "paired": paired,
        "figures": figs,
        "report": report,
        "wall_time": wall,
    }


# ------------------------------------------------------------------------------- figures
def _snapshots(entry: dict[str, Any], label: str) -> list[tuple[float, dict[str, np.ndarray]]]:
    """Three map snapshots like the paper's scenes (Figs. 1-2)."""
    rec = entry["recording"]
    snaps = [(t, b) for t, b in rec.beliefs if "m_s" in b]
    final = entry["final"]
    if label == "ds-rectangular-wave" and "waypoint" in rec.diagnostics:
        # end of rounds 1 and 3, at the round's last corner like the paper's scenes (before
        # the way back): the waypoint index reaches 1/5 and 3/5 of all waypoints (the index
        # counts the waypoints reached; it ends at their number)
        wp = rec.diagnostics["waypoint"]
        per_round = wp.max() / SEARCHERS["ds-rectangular-wave"]["rounds"] if wp.size else 1.0
        wanted = [rec.t[min(np.searchsorted(wp, r * per_round), len(wp) - 1)] for r in (1, 3)]
    else:
        wanted = [400.0, 800.0]
    picks = []
    for w in wanted:
        if snaps:
            i = int(np.argmin([abs(t - w) for t, _ in snaps]))
            picks.append(snaps[i])
    picks.append(final)
    return picks


def _state_map_figure(recs: dict[str, Any], out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch, Rectangle

    from odorloc.inference.dempster_shafer import cell_uncertainty

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
            ax.add_patch(Rectangle((rx0, ry0), rx1 - rx0, ry1 - ry0, fill=False, ec="gold", lw=2))
            d = float(np.sum(np.linalg.norm(np.diff(pos[:, :2], axis=0), axis=1)))
            x = cell_uncertainty(ms, mn, snap["m_u"])
            # only the region's cells count (those of the map's margin are ignored, as in
            # the paper and in the table)
            xc = lo[0] + (np.arange(ms.shape[0]) + 0.5) * (hi[0] - lo[0]) / ms.shape[0]
            yc = lo[1] + (np.arange(ms.shape[1]) + 0.5) * (hi[1] - lo[1]) / ms.shape[1]
            inside = ((xc >= rx0) & (xc <= rx1))[:, None] & ((yc >= ry0) & (yc <= ry1))[None, :]
            x = np.where(inside, x, 0.0)
            ax.set_title(f"{label}\nt = {t:.0f} s, {d:.0f} m, ΣX = {x.sum():.0f}", fontsize=9)
            ax.set_xlim(rx0 - 1.0, rx1 + 1.0)
            ax.set_ylim(ry0 - 1.0, ry1 + 1.0)
            ax.set_aspect("equal")
    handles = [
        Patch(color="0.6", label="unknown"),
        Patch(fc="white", ec="k", label="free"),
        Patch(color="black", label="occupied by a source"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=3)
    fig.suptitle("D-S state maps at three moments (cf. paper Figs. 1-2); red stars: true sources")
    p = out / "state_maps.png"
    fig.savefig(p, dpi=100)
    plt.close(fig)
    return p


def _uncertainty_figure(recs: dict[str, Any], out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.6))
    colors = {"ds-mapping": "tab:red", "ds-rectangular-wave": "tab:blue"}
    for label, entry in recs.items():
        rec = entry["recording"]
        if "total_uncertainty" in rec.diagnostics:
            ax.plot(
                rec.t,
                rec.diagnostics["total_uncertainty"],
                color=colors.get(label),
                label=f"{label} (ours, flow 0)",
            )
        pts = np.array(DS_PAPER_SCENES[label])
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
    p = out / "uncertainty_vs_time.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return p


def synthetic_wind_record(
    n: int,
    dt: float,
    speed: float,
    direction_std_deg: float,
    rng: np.random.Generator,
    correlation_time: float = 5.0,
) -> np.ndarray:
    """A wind record ``(n, 2)`` m/s whose direction follows an Ornstein-Uhlenbeck process.

    Mean ``speed`` along +x; the direction's stationary standard deviation is
    ``direction_std_deg`` and its correlation time ``correlation_time`` seconds; the speed
    fluctuates by 10 % of the same process.
    """
    a = math.exp(-dt / correlation_time)
    s = math.radians(direction_std_deg)
    th = np.empty(n)
    sp = np.empty(n)
    th[0] = rng.normal(0.0, s)
    sp[0] = speed
    for i in range(1, n):
        th[i] = a * th[i - 1] + math.sqrt(1 - a * a) * rng.normal(0.0, s)
        sp[i] = speed * (
            1.0 + 0.1 * (a * (sp[i - 1] / speed - 1.0) + math.sqrt(1 - a * a) * rng.normal())
        )
    return np.column_stack([sp * np.cos(th), sp * np.sin(th)])


def odor_path_figure(path: Path, seed: int = 7) -> Path:
    """Odor-path maps with their sub-window ellipses for a calm and a gusty wind record.

    Like Figs. 4-5 of the odor-path paper: a 10 m x 10 m map of 5 cm cells, the robot at
    (8, 5) m, 10 s of wind (20 records at 0.5 s) with direction standard deviation 5 deg
    (calm) and 35 deg (gusty).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import PowerNorm
    from matplotlib.patches import Ellipse

    from odorloc.inference.odor_path import OdorPathEstimator, OdorPathParams

    rng = np.random.default_rng(seed)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    for ax, (name, std) in zip(axes, (("calm", 5.0), ("gusty", 35.0)), strict=True):
        est = OdorPathEstimator(OdorPathParams(cell_size=0.05), (0.0, 0.0), (10.0, 10.0))
        wind = synthetic_wind_record(21, 0.5, 0.5, std, rng)
        for i, u in enumerate(wind):
            est.update(0.5 * i, (8.0, 5.0), u, 1.0)
        pi = est.path_map()
        var = est.wind_variance()
        # a power norm: the newest windows hold pi ~ 1, the oldest a few per cent
        im = ax.imshow(
            pi.T,
            origin="lower",
            extent=(0, 10, 0, 10),
            cmap="viridis",
            norm=PowerNorm(0.35, vmin=0.0, vmax=max(float(pi.max()), 1e-12)),
        )
        for w in est.windows():
            if w.n_cells:
                ax.add_patch(
                    Ellipse(
                        tuple(w.center),
                        2 * w.semi_axes[0],
                        2 * w.semi_axes[1],
                        fill=False,
                        ec="w",
                        lw=0.6,
                    )
                )
        ax.plot(8.0, 5.0, "o", color="red", mec="k")
        ax.set_title(
            f"{name}: direction sd {std:.0f} deg, wind var ({var[0]:.1e}, {var[1]:.1e}) m²/s²",
            fontsize=9,
        )
        fig.colorbar(im, ax=ax, shrink=0.8, label="π (odor-path probability)")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.suptitle(
        "Odor-path probability maps and sub-window ellipses (cf. odor-path paper Figs. 4-5)"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
