"""``odorloc reproduce muc-osl``: the multi-UAV paper's evaluation (Sect. VI) in two worlds.

Four sweeps (:mod:`.sweeps`) x the paper's four algorithms (Col-PF with reversible PUGL moves)
and PUGL as printed (``muc-osl-printed``, ``col-pf-printed``), with common random numbers, in
the rate world (``muc-osl-3d``, Figs. 4-7) and at Fig. 9's settings in the filament world
(``muc-osl-filament-3d``, replayed to every algorithm; the estimators keep their rate model);
MUC-OSL without eq. 16 at every point of the rate world and at the default point of the
filament world. Stores ``rate``, ``rate-particles``, ``rate-ablation``,
``rate-ablation-particles`` (the ablation off the default point), ``filament``,
``filament-particles`` (``--only rate``: the first four). The search time is
``reach_fly_hover_turn_time`` (the first UAV within 2 m; failures at the limit), the energy
``team_movement_energy``. Besides a :class:`~odorloc.experiments.point_reports.PointsReproduction`'s
outputs: Tables 2 and 3, the filament world at 8 minutes, the statements judged
(:mod:`.claims`), Fig. 3 and the mechanism of eq. 16.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.registry import register
from odorloc.experiments import point_reports as R
from odorloc.experiments.claims import Claim, Points
from odorloc.experiments.reproduction import Figure, ReproductionParams, Table
from odorloc.experiments.store import agent_values
from odorloc.experiments.variants import Sweep, restrict
from odorloc.papers.muc_osl import reference as ref
from odorloc.papers.muc_osl import sweeps as S
from odorloc.papers.muc_osl.claims import LABELS, evaluate_claims
from odorloc.scenarios import get_scenario

__all__ = ["COLUMNS", "MucOslReproduction", "uav_rows"]

SCENARIO, FILAMENT, FILAMENT_EPISODES = "muc-osl-3d", "muc-osl-filament-3d", 5
ALL = (*S.ROWS, S.NO_ENV_PU)
#: The rate world runs MUC-OSL without eq. 16 at every point of its sweeps; the filament world
#: at its default point only.
RATE_METHODS = ALL
#: Episodes per variant of the mechanism figure.
MECHANISM_EPISODES = 12
COLORS = {"muc-osl": "tab:red", "col-inf": "tab:blue", "col-pf": "tab:green"}
COLORS |= {"adap-pp": "tab:orange", "muc-osl-printed": "tab:pink"}
COLORS |= {"col-pf-printed": "tab:olive", S.NO_ENV_PU: "tab:purple"}
#: The measures of a cell (:class:`~odorloc.experiments.claims.Cells`): the row columns.
COLUMNS = {"time": "reach_fly_hover_turn_time", "energy": "team_movement_energy"}
COLUMNS |= {"hover": "team_hover_time", "turn": "team_turn_time"}
FIGURES = {"area": "fig4_area.png", "uavs": "fig5_uavs.png", "radius": "fig6_radius.png"}
FIGURES |= {"particles": "fig7_particles.png"}
NOTE2 = "team_hover_time, team_turn_time, path_length, team_movement_energy (eqs. 4-6)"
NOTE3 = (
    "nums/msg: float64 numbers per exchange; k nums/iter: thousands of numbers processed per "
    "UAV iteration\n(estimator + planner; eq. 7 counts 64 bits each)."
)
STATEMENTS = {
    "area": "paper: MST falls and SR rises as the area shrinks; MUC-OSL best at every area;\n"
    "Col-Inf the most sensitive; at 100x200x50 MUC-OSL 24 %, Col-Inf fails",
    "uavs": "paper: MST falls and SR rises with more UAVs, levelling off beyond 5; MUC-OSL\n"
    "always best; Adap-PP better than Col-PF with few UAVs",
    "radius": "paper: Col-PF poor at small radii against Adap-PP; Col-PF and MUC-OSL improve\n"
    "from 5 to 20 m and level off beyond 20 m (4 UAVs)",
    "particles": "paper: MST falls and SR rises with more particles; MUC-OSL steady with SR\n"
    "near 1 beyond 160; Col-PF better than Adap-PP with few particles",
}


def uav_rows(df: Any, limit: float) -> Any:
    """Rows with the paper's search time set to ``limit`` (s) where nobody reached."""
    out = df.assign(**{c: math.nan for c in (*COLUMNS.values(), "success") if c not in df})
    reached = out["success"].astype("boolean").fillna(False).astype(bool)
    out[COLUMNS["time"]] = np.where(reached, out[COLUMNS["time"]], limit)
    return out


def _per_agent(h: Any, key: str, weighted: bool = False) -> Any:
    """Per episode, the UAVs' sum of a per-agent value (NaN if none); ``weighted``: per message."""
    v, none = agent_values(h, key), np.full(len(h), math.nan)
    if not weighted:
        return np.where(v.isna().all(axis=1), none, np.nansum(v.to_numpy(float), axis=1))
    w = agent_values(h, "messages_sent").reindex(columns=v.columns).to_numpy(float)
    n = np.nansum(w, axis=1)  # messages sent per episode
    return np.divide(np.nansum(v.to_numpy(float) * w, axis=1), n, out=none, where=n > 0)


@register("reproduction", "muc-osl", ReproductionParams, "MUC-OSL: Sect. VI, Figs. 4-7 and 9")
class MucOslReproduction(R.PointsReproduction):
    """The four sweeps in two worlds (module docstring). ``time_limit`` (s): a shorter episode
    limit (tests; the "8 minutes" are read at it when shorter); ``values``: run only these
    values of each sweep; ``filament``, ``fig3``: include the filament world, draw Fig. 3."""

    name = "muc-osl"
    paper = "muc-osl-multi-uav.txt"
    citations = (ref.CITATION,)
    summary = "MUC-OSL, its baselines and PUGL as printed: four sweeps, two worlds"
    default_episodes = 8
    paper_episodes = 200
    paper_episodes_note = "of the rate world: add --only rate, or the filament world runs 200 too"
    report_paired = False
    cell_summary = False
    methods, extra_methods, names, colors = S.ROWS, (S.NO_ENV_PU,), LABELS, COLORS
    columns, statements, default_point, categorical = COLUMNS, STATEMENTS, S.DEFAULT, ("area",)
    figure_files = FIGURES

    def __init__(
        self,
        params: ReproductionParams | None = None,
        time_limit: float | None = None,
        values: Mapping[str, Sequence[Any]] | None = None,
        filament: bool = True,
        fig3: bool = True,
    ) -> None:
        super().__init__(params)
        self.fig3, self.time_limit = fig3, time_limit
        self.limit = float(time_limit or get_scenario(SCENARIO).limits.time)
        self.at = min(ref.FILAMENT_AT, self.limit)
        self.rate_sweeps = restrict(S.SWEEPS, values)
        self.filament_sweeps = restrict(S.fig9_settings(), values, strict=False) if filament else []
        self.note = (
            "SR: success rate % [95 % Wilson]; MST: mean search time s [95 % bootstrap], "
            f"failures at {self.limit:g} s;\nsearch time: reach_fly_hover_turn_time (fly + hover "
            "+ turn of the first UAV within 2 m)."
        )

    def worlds(self) -> list[R.World]:
        return [
            R.World(
                "rate", SCENARIO, self.rate_sweeps, self.default_episodes, methods=RATE_METHODS
            ),
            R.World(
                "filament",
                FILAMENT,
                self.filament_sweeps,
                FILAMENT_EPISODES,
                True,
                False,
                "fig9_filament.png",
            ),
        ]

    def sweep_files(self, world: R.World, episodes: int, seed: int) -> dict[str, dict[str, Any]]:
        common = {} if self.time_limit is None else {"limits.time": float(self.time_limit)}
        ablation = [{"name": "muc-osl", "label": S.NO_ENV_PU, "params": S.NO_ENV_PU_PARAMS}]
        files = S.sweep_files(
            world.scenario,
            world.sweeps,
            episodes,
            seed,
            replay=world.replay,
            extra_searchers=ablation,
            scenario_params=common,
            name=f"muc-osl {world.name}",
        )
        if S.NO_ENV_PU in world.methods:
            # parts of their own: a study stored before keeps its stores and resumes
            files |= S.ablation_files(
                world.scenario,
                world.sweeps,
                episodes,
                seed,
                replay=world.replay,
                scenario_params=common,
                name=f"muc-osl {world.name}",
            )
        return files

    def cell_of(self, world: R.World, point: Any, method: str) -> tuple[str, str]:
        return S.cell_of(world.scenario, point, method)

    def rows(self, df: Any) -> Any:
        return uav_rows(df, self.limit)

    def reference(self) -> dict[str, dict[str, Any]]:
        """The paper's success rates at 100 x 200 x 50 m (its only per-point numbers)."""
        s = next((sw for sw in self.rate_sweeps if sw.key == "area"), None)
        if s is None or (100.0, 200.0, 50.0) not in s.values:
            return {}
        at = s.setting((100.0, 200.0, 50.0))
        return {
            "/".join(S.cell_of(SCENARIO, at, a)): {"success_rate": v, "source": "Sect. VI.2.1"}
            for a, v in ref.LARGEST_AREA_SUCCESS.items()
        }

    def _run_sweeps(self, world: str) -> list[Sweep]:
        """A world's sweeps as run (cut to the default point by ``points="default"``)."""
        return next((list(w.sweeps) for w in self._worlds() if w.name == world), [])

    def claims(self, points: Mapping[str, Points], seed: int) -> list[Claim]:
        if "rate" not in points:
            return []
        fil = points.get("filament")
        rate_sweeps, filament_sweeps = self._run_sweeps("rate"), self._run_sweeps("filament")
        return evaluate_claims(points["rate"], rate_sweeps, fil, filament_sweeps, self.at, seed)

    def extra_tables(self, df: Any, points: Mapping[str, Points], seed: int) -> list[Table]:
        out = []
        if "filament" in points and len(points["filament"].one(S.DEFAULT, "muc-osl")):
            run = self._run_sweeps("filament")
            settings = list(dict.fromkeys(s for sw in run for s in sw.settings()))
            out.append(
                R.success_by_table(
                    "filament_sr8",
                    f"Filament world (Fig. 9): success % by {self.at / 60:g} min / overall",
                    points["filament"],
                    settings,
                    S.Setting.where,
                    S.ROWS,
                    LABELS,
                    self.at,
                    "paper (MUC-OSL): about 90 % at 8 min in 100x60x30 m; above 80 % with more "
                    "than 3 UAVs",
                )
            )
        for world, scenario in (("rate", SCENARIO), ("filament", FILAMENT)):
            g = uav_rows(df[df["world_key"] == scenario], self.limit)
            if len(g) and world in points:
                out += self._default_tables(g[g["world_key"] == scenario], world)
        return out

    def _default_tables(self, g: Any, world: str) -> list[Table]:
        """Tables 2 and 3 at the default point of one world."""
        g = g.copy().assign(
            kj=g[COLUMNS["energy"]] / 1e3,
            nums=_per_agent(g, "numbers_per_message", weighted=True),
            per_iter=_per_agent(g, "compute_bits") / 64 / _per_agent(g, "iterations"),
        )
        move = {"hover s": ("team_hover_time", 1, 0), "turn s": ("team_turn_time", 1, 0)}
        move |= {"distance m": ("path_length", 1, 0), "E_M kJ": ("kj", 1, 0)}
        res = {"nums/msg": ("nums", 1, 0), "kB/ep": ("bytes", 1e-3, 1)}
        res |= {"k nums/iter": ("per_iter", 1e-3, 1), "E_T mJ": ("energy_comm", 1e3, 2)}
        res |= {"E_C J": ("energy_compute", 1, 1)}
        table2 = {a: "/".join(f"{v:.0f}" for v in r.values()) for a, r in ref.TABLE2.items()}
        table3 = {a: r["numbers"] for a, r in ref.TABLE3.items()}
        what = (
            f"Table 2, {world} world: team movement per episode (paper: h/t/d/E)",
            f"Table 3, {world} world: communication and computation (paper: numbers)",
        )
        return [
            R.means_table(f"{world}_table2", what[0], g, ALL, LABELS, move, table2, NOTE2),
            R.means_table(f"{world}_table3", what[1], g, ALL, LABELS, res, table3, NOTE3),
        ]

    def extra_figures(self, df: Any, points: Mapping[str, Points], seed: int) -> list[Figure]:
        figs = [
            Figure(
                "mechanism_eq16.png",
                "The particles' mean along the wind axis against the iteration: PUGL's moves as "
                "printed, reversible, and without eq. 16 (default point)",
                lambda p: _mechanism(seed, p, MECHANISM_EPISODES, self.time_limit),
            )
        ]
        if self.fig3:
            figs.append(
                Figure(
                    "fig3_team_3d.png",
                    "Fig. 3: UAV paths, cue points (open circles) and each UAV's particles at "
                    "four moments of one MUC-OSL episode",
                    lambda p: _fig3(seed, p, self.time_limit),
                )
            )
        return figs


def _scenario(time_limit: float | None, searcher: dict[str, Any]) -> Any:
    sc = get_scenario(SCENARIO).with_overrides({"searcher": searcher})
    return sc if time_limit is None else sc.with_overrides({"limits.time": float(time_limit)})


def _fig3(seed: int, path: Path, time_limit: float | None = None) -> None:
    from odorloc.experiments.traces import record_first_success
    from odorloc.viz.team3d import animate_team_3d, plot_team_3d

    ep, res = record_first_success(_scenario(time_limit, {"type": "muc-osl"}), seed)
    m, rec = res.metrics, res.recording
    outcome = f"reached at {m['search_time']:.0f} s" if m["success"] else "not reached"
    rec.meta["title"] = f"MUC-OSL, 3 UAVs, muc-osl-3d episode {ep} (seed {seed}): {outcome}"
    plot_team_3d(rec, path)
    animate_team_3d(rec, path.with_name("fig3_team_3d.gif"))


def _mechanism(seed: int, path: Path, episodes: int, time_limit: float | None = None) -> None:
    """The particles' mean along the wind (``y``; the wind blows towards ``-y``) after each UAV
    iteration, ``episodes`` default-point episodes per variant."""
    from odorloc.experiments.figures import trace_figure
    from odorloc.experiments.traces import diagnostic_traces

    variants = {
        "as printed": ({"type": "muc-osl-printed"}, "muc-osl-printed"),
        "reversible": ({"type": "muc-osl"}, "muc-osl"),
        "without eq. 16": ({"type": "muc-osl", **S.NO_ENV_PU_PARAMS}, S.NO_ENV_PU),
    }
    traces = {
        label: diagnostic_traces(
            _scenario(time_limit, searcher), episodes, seed, "estimate_y", "iteration"
        )
        for label, (searcher, _) in variants.items()
    }
    sc = get_scenario(SCENARIO)
    trace_figure(
        traces,
        path,
        f"MUC-OSL's particles along the wind: {episodes} default-point episodes per variant, "
        f"root seed {seed}",
        "UAV iteration",
        "particles' mean y (m); upwind is +y",
        {label: COLORS[key] for label, (_, key) in variants.items()},
        {"source": sc.world.sources[0].position[1], "upwind wall": sc.world.arena.upper[1]},
    )
