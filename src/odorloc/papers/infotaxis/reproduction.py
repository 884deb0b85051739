"""``odorloc reproduce single-agent``: every single-agent strategy on three continuous worlds.

The infotaxis family on grid beliefs (``infotaxis``, ``space-aware-infotaxis``, ``entrotaxis``,
``greedy``, ``mean-distance``) and on particles (``particle-infotaxis``) against the reactive
rules (``surge-cast``, ``surge-spiral``, ``spiral``, ``chemotaxis``, ``anemotaxis``,
``fluxotaxis``) in

- ``farrell``: the filament plume of ``two-sources-farrell`` with its first source only (a
  Farrell-style meandering 1 m/s flow; 0.5 m/s robot from (33, 40), 16 m from the source);
- ``indoor``: the ventilated room ``indoor-ventilated`` (0.22 m/s robot, 4.2 m from the source);
- ``uav3d``: the 3-D rate world ``muc-osl-3d`` with one UAV (encounter counts of the Vergassola
  plume, 28 m from the source, which is 20 m higher and downwind of the start), with a sensor
  radius of 1 m (:data:`UAV3D_SENSOR_RADIUS`; the multi-UAV reproduction's teams use the
  calibrated 3.5 m of the scenario).

Every episode ends when the agent comes within the world's reach radius of the source (1 m,
0.3 m, 4 m: success), or at the time limit (600 s, 600 s, 1200 s). The filament flows are
recorded once per episode and replayed to every strategy (the sweep's ``replay``), and the rate
world is steady, so episode ``i`` of every strategy faces the same plume. Reported per world and
strategy: success rate (Wilson 95 % interval), mean time and path length of the successes
(bootstrap 95 % intervals).

Settings (the searchers' knowledge of each world, :data:`SEARCHER_PARAMS`): the model-based
strategies use the Vergassola rate model of detections fitted to each filament world by
:func:`~odorloc.papers.infotaxis.calibration.fit_detection_model` (:data:`FITTED_MODELS`, the
values it gave on 300 s of each world's flow at world seed 99), and the world's own model in the
rate world; belief cells of 1 m, 0.2 m and 2 m; the reactive rules' casting and spiral scales
follow the size of each world. No world setting is changed for any strategy.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.experiments.reproduction import Figure, Reproduction, ReproductionParams, Table, fmt

__all__ = [
    "FAMILIES",
    "FITTED_MODELS",
    "SEARCHER_PARAMS",
    "STRATEGIES",
    "WORLDS",
    "SingleAgentReproduction",
    "prepare",
    "single_agent_group",
]

#: Sensor radius (m) of the ``uav3d`` world and its model: the scenario's first value, kept for
#: this comparison of single-agent strategies.
UAV3D_SENSOR_RADIUS = 1.0

#: World label -> base scenario and its overrides.
WORLDS: dict[str, dict[str, Any]] = {
    "farrell": {
        "name": "two-sources-farrell",
        "params": {
            "world.sources": [{"position": [20.0, 50.0], "rate": 10.0}],
            "task.end": "reach",
            "task.reach_radius": 1.0,
            "limits.time": 600.0,
        },
    },
    "indoor": {
        "name": "indoor-ventilated",
        "params": {"task.end": "reach", "task.reach_radius": 0.3, "limits.time": 600.0},
    },
    "uav3d": {
        "name": "muc-osl-3d",
        "params": {
            "agents.starts": [[10.0, 10.0, 5.0]],
            "task.end": "reach",
            "task.reach_radius": 4.0,
            "world.plume.sensor_radius": UAV3D_SENSOR_RADIUS,
        },
    },
}

#: Detection models fitted to the filament worlds (``calibration.fit_detection_model`` on its
#: default grid ``calibration.FIT_GRID``, D in 0.01..10 m^2/s, tau in 5..5000 s, Q in 0.1..100:
#: 300 s of flow at seed 99, probes at the centres of 1 m / 0.2 m cells over the arena). The
#: room's fit lies on the edge of that grid (smoke fills the room: the rate model fits it badly).
FITTED_MODELS: dict[str, dict[str, Any]] = {
    "farrell": {
        "type": "vergassola",
        "Q": 1.0,
        "V": 1.048,
        "D": 2.0,
        "tau": 20.0,
        "sensor_radius": 0.1,
    },
    "indoor": {
        "type": "vergassola",
        "Q": 10.0,
        "V": 0.190,
        "D": 0.01,
        "tau": 5000.0,
        "sensor_radius": 0.05,
    },
    # the world's own model (the multi-UAV paper's table, a = 1 m as in the world above)
    "uav3d": {"type": "vergassola", "sensor_radius": UAV3D_SENSOR_RADIUS},
}

GRID_POLICIES = ("infotaxis", "space-aware-infotaxis", "entrotaxis", "greedy", "mean-distance")
REACTIVE = ("surge-cast", "surge-spiral", "spiral", "chemotaxis", "anemotaxis", "fluxotaxis")
STRATEGIES = (*GRID_POLICIES, "particle-infotaxis", *REACTIVE)
FAMILIES = {s: "infotaxis family" for s in (*GRID_POLICIES, "particle-infotaxis")} | {
    s: "reactive" for s in REACTIVE
}

_GRID = {
    "farrell": {"cell_size": 1.0, "found_radius": 1.0},
    "indoor": {"cell_size": 0.2, "found_radius": 0.3},
    "uav3d": {"cell_size": 2.0, "found_radius": 4.0, "n_classes": 4},
}
_PARTICLE = {
    "farrell": {"step": 1.0, "found_radius": 1.0},
    "indoor": {"step": 0.2, "found_radius": 0.3},
    "uav3d": {"step": 2.0, "found_radius": 4.0, "n_classes": 4},
}
_CAST = {
    "farrell": {"amplitude": 1.0, "max_amplitude": 8.0},
    "indoor": {"amplitude": 0.3, "max_amplitude": 1.5},
    "uav3d": {"amplitude": 4.0, "max_amplitude": 20.0, "elevation_deg": 30.0},
}
_SURGE = {"farrell": 8, "indoor": 4, "uav3d": 5}
_SPIRAL = {
    "farrell": {"initial_step": 1.0, "step_increment": 0.4},
    "indoor": {"initial_step": 0.3, "step_increment": 0.15},
    "uav3d": {"initial_step": 4.0, "step_increment": 2.0},
}


def _searcher_params(world: str) -> dict[str, dict[str, Any]]:
    model = FITTED_MODELS[world]
    out: dict[str, dict[str, Any]] = {}
    grid, part = dict(_GRID[world]), dict(_PARTICLE[world])
    classes = {"n_classes": grid.pop("n_classes")} if "n_classes" in grid else {}
    for s in GRID_POLICIES:
        out[s] = {"model": model, "estimator": {**grid, "reading": classes}}
    step = part.pop("step")
    part.pop("n_classes", None)
    out["particle-infotaxis"] = {
        "model": model,
        "estimator": {"n_particles": 500, **part, "reading": classes},
        "planner": {"candidates": {"step": step}},
    }
    cast = _CAST[world]
    sp = _SPIRAL[world]
    out["surge-cast"] = {"surge_steps": _SURGE[world], "cast": dict(cast)}
    out["surge-spiral"] = {"surge_steps": _SURGE[world], "spiral": dict(sp), "cast": dict(cast)}
    out["spiral"] = dict(sp)
    for s in ("chemotaxis", "anemotaxis", "fluxotaxis"):
        out[s] = {"cast": dict(cast)}
    return out


#: World label -> strategy -> searcher parameters.
SEARCHER_PARAMS: dict[str, dict[str, dict[str, Any]]] = {w: _searcher_params(w) for w in WORLDS}


def prepare(sc: Any, task: Any) -> Any:
    """The strategy's settings for its world; light recording except for kept episodes."""
    from odorloc.scenarios.config import Scenario

    world = str(task.cell["scenario_label"])
    data = sc.to_dict()
    kind = data["searcher"]["type"]
    own = dict(task.cell.get("searcher_params") or {})
    data["searcher"] = {"type": kind, **SEARCHER_PARAMS[world].get(kind, {}), **own}
    keep = bool(task.keep_arrays)
    data["recording"] = {
        **data["recording"],
        "belief_stride": 20 if keep else 10**9,
        "plume_stride": 40 if keep else 10**9,
    }
    return Scenario.from_dict(data)


#: Worlds whose flow is recorded once and replayed to every strategy. The rate world is steady
#: and analytic (every strategy faces the same plume anyway), and a replayed plume has no
#: encounter rate of its own (it would read its concentration as one), so it runs live.
REPLAYED = ("farrell", "indoor")


def single_agent_group(tasks: list[Any]) -> list[dict[str, Any]]:
    """One flow per world and episode for every strategy, each with its world's settings."""
    from odorloc.experiments.runner import run_live_group, run_replay_group

    if not tasks or str(tasks[0].cell["scenario_label"]) in REPLAYED:
        return run_replay_group(tasks, prepare=prepare)
    return run_live_group(tasks, prepare=prepare)


@register("reproduction", "single-agent", ReproductionParams, "single-agent strategies compared")
class SingleAgentReproduction(Reproduction):
    """The infotaxis family against the reactive rules on three continuous worlds."""

    name = "single-agent"
    paper = "infotaxis (Vergassola et al. 2007; Loisy & Eloy 2022)"
    summary = "infotaxis family vs reactive rules: filament, indoor and 3-D rate worlds"
    default_episodes = 12
    paper_episodes = 100
    paper_episodes_note = "no paper fixes one; 100 narrows the success intervals to about 10 %"

    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        return {
            "name": "single-agent comparison",
            "seed": seed,
            "episodes": episodes,
            "replay": True,
            "keep_episodes": [0],
            "scenarios": [
                {"name": w["name"], "label": label, "params": w["params"]}
                for label, w in WORLDS.items()
            ],
            "searchers": [{"name": s} for s in STRATEGIES],
        }

    def group_fn(self) -> Any:
        return single_agent_group

    @staticmethod
    def summary_table(df: Any, seed: int) -> Any:
        """Per world and strategy: success and the intervals of time and path length
        (:func:`~odorloc.experiments.stats.outcome_table`), with each strategy's family."""
        from odorloc.experiments.stats import outcome_table

        summ = outcome_table(df, ("scenario", "searcher"), seed)
        summ = summ.rename(columns={"scenario": "world", "searcher": "strategy"})
        summ.insert(2, "family", [FAMILIES.get(s, "") for s in summ["strategy"]])
        return summ

    def tables(self, df: Any, seed: int) -> list[Table]:
        summ = self.summary_table(df, seed)
        out = []
        for world in WORLDS:
            g = summ[summ.world == world]
            if not len(g):
                continue
            rows = []
            for s in STRATEGIES:
                r = g[g.strategy == s]
                if not len(r):
                    continue
                r = r.iloc[0]
                rows.append(
                    [
                        s,
                        str(int(r.n)),
                        f"{fmt(100 * r.success_rate, 0)} [{fmt(100 * r.success_lo, 0)}, "
                        f"{fmt(100 * r.success_hi, 0)}]",
                        f"{fmt(r.mean_time)} [{fmt(r.time_lo)}, {fmt(r.time_hi)}]",
                        f"{fmt(r.mean_path)} [{fmt(r.path_lo)}, {fmt(r.path_hi)}]",
                        fmt(100 * r.detected, 0),
                    ]
                )
            out.append(
                Table(
                    f"single_agent_{world}",
                    f"{world}: success % [95% CI], time s and path m of successes [95% CI]",
                    ["strategy", "n", "success %", "time s", "path m", "detected %"],
                    rows,
                )
            )
        fam = []
        for world in WORLDS:
            g = summ[summ.world == world]
            for f in ("infotaxis family", "reactive"):
                h = g[g.family == f]
                if not len(h):
                    continue
                best = h.sort_values("success_rate", ascending=False).iloc[0]
                fam.append(
                    [
                        world,
                        f,
                        fmt(100 * h.success_rate.mean(), 0),
                        f"{best.strategy} ({fmt(100 * best.success_rate, 0)})",
                    ]
                )
        out.append(
            Table(
                "single_agent_families",
                "Families: mean success % over their strategies, and the best strategy",
                ["world", "family", "mean success %", "best (success %)"],
                fam,
            )
        )
        return out

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        summ = self.summary_table(df, seed)
        return [
            Figure(
                "single_agent_success_time.png",
                "Success rate, mean time and path length of the successes per strategy and world "
                "(95 % intervals; red: infotaxis family, blue: reactive rules)",
                lambda p: _figure(summ, p),
            )
        ]


def _figure(summ: Any, path: Path) -> None:
    from odorloc.viz.backend import pyplot

    plt = pyplot()

    worlds = list(WORLDS)
    fig, axes = plt.subplots(3, len(worlds), figsize=(4.6 * len(worlds), 10.2), sharey="row")
    colours = {"infotaxis family": "tab:red", "reactive": "tab:blue"}
    for j, w in enumerate(worlds):
        g = (
            summ[summ.world == w]
            .set_index("strategy")
            .reindex(list(STRATEGIES))
            .dropna(subset=["n"])
        )
        y = np.arange(len(g))
        c = [colours[FAMILIES[s]] for s in g.index]
        sr = 100 * g.success_rate.to_numpy(float)
        err = [
            np.maximum(sr - 100 * g.success_lo.to_numpy(float), 0),
            np.maximum(100 * g.success_hi.to_numpy(float) - sr, 0),
        ]
        axes[0, j].barh(y, sr, xerr=err, color=c, alpha=0.8, capsize=2)
        axes[0, j].set_xlim(0, 105)
        axes[0, j].set_title(w)
        axes[0, j].set_xlabel("success rate (%)")
        t = g.mean_time.to_numpy(float)
        terr = [
            np.nan_to_num(np.maximum(t - g.time_lo.to_numpy(float), 0)),
            np.nan_to_num(np.maximum(g.time_hi.to_numpy(float) - t, 0)),
        ]
        axes[1, j].barh(y, np.nan_to_num(t), xerr=terr, color=c, alpha=0.8, capsize=2)
        axes[1, j].set_xlabel("mean time of successes (s)")
        pl = g.mean_path.to_numpy(float)
        perr = [
            np.nan_to_num(np.maximum(pl - g.path_lo.to_numpy(float), 0)),
            np.nan_to_num(np.maximum(g.path_hi.to_numpy(float) - pl, 0)),
        ]
        axes[2, j].barh(y, np.nan_to_num(pl), xerr=perr, color=c, alpha=0.8, capsize=2)
        axes[2, j].set_xlabel("mean path length of successes (m)")
        for ax in axes[:, j]:
            ax.set_yticks(y)
            ax.set_yticklabels(list(g.index), fontsize=8)
            ax.invert_yaxis()
            ax.grid(axis="x", alpha=0.3)
    handles = [plt.Rectangle((0, 0), 1, 1, color=v, alpha=0.8) for v in colours.values()]
    fig.legend(handles, list(colours), loc="upper center", ncol=2, fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=110)
    plt.close(fig)
