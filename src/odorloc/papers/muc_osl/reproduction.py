"""``odorloc reproduce muc-osl``: the multi-UAV paper's evaluation (Sect. VI) in two worlds.

Four sweeps x four algorithms (MUC-OSL, Col-Inf, Col-PF, Adap-PP: compositions of a per-UAV
estimator and planner, :mod:`odorloc.searchers.uav_team`), with common random numbers: episode
``i`` of every algorithm at a point faces the same world and gives every UAV the same random
stream (:mod:`.sweeps` lists the points and the source placement per area).

- **rate world** (``muc-osl-3d``, the paper's simplified simulator): every point of Figs. 4-7;
- **filament world** (``muc-osl-filament-3d``, the paper's GADEN runs): a 3-D filament plume
  with the paper's GADEN parameters in a time-varying wind, a PID whose reading becomes an
  encounter count (:mod:`odorloc.sensors.pid`) and an anemometer on each UAV; the estimators
  keep their rate-model likelihood (a deliberate mismatch, as in the paper). Each flow is
  recorded once per episode and replayed to every algorithm (``replay: true``). Fig. 9's
  settings: the ends, the default and a middle value of each sweep.

MUC-OSL without the upwind particle moves of eq. 16 (``muc-osl-no-env-pu``) runs beside the four
at the default setting of both worlds as an ablation, and the paper's headline statements (best
success rate and search time, less movement energy than Col-Inf) are judged for it there too.

The reproduction is made of four sweeps, each with its own store in the output folder: ``rate``,
``rate-particles`` (the particle counts: searcher parameters on the default world), ``filament``
and ``filament-particles``; ``--only rate`` runs the first two (e.g. with ``--episodes 200``) and
shows the stored rows of the others.

Tables (console, CSV, report): success rate and mean search time with intervals per point and
algorithm, for each sweep and for the filament world (with the success rate at 8 minutes, or at
the episode limit when that is shorter); the default setting in both worlds; Table 2 (team hover
time, turn time, distance, movement energy) and Table 3 (numbers per exchange, bytes per
episode, computation per iteration); the paper's statements marked held / not held / undecided
with intervals (:mod:`.claims`); ``points.csv`` holds every number of every point. Figures:
Figs. 4-7 (MST and SR against the swept value), Fig. 9 (success against time, filament solid and
rate dashed), the default-setting comparison, and Fig. 3 (one MUC-OSL episode in 3-D) with its
animation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.registry import register
from odorloc.core.seeds import episode_seeds
from odorloc.experiments.reproduction import Figure, Reproduction, ReproductionParams, Table, fmt
from odorloc.experiments.store import agent_values
from odorloc.papers.muc_osl.analysis import Cells, add_uav_search_time, summarize_point
from odorloc.papers.muc_osl.claims import evaluate_claims, when_text
from odorloc.papers.muc_osl.reference import (
    ALGORITHMS,
    FILAMENT_AT,
    LARGEST_AREA_SUCCESS,
    TABLE2,
    TABLE3,
)
from odorloc.papers.muc_osl.sweeps import (
    DEFAULT,
    NO_ENV_PU,
    SWEEPS,
    SweepDef,
    cell_of,
    fig9_settings,
    sweep_files,
)
from odorloc.scenarios import get_scenario

__all__ = ["MucOslReproduction", "add_uav_search_time", "record_episode"]

SCENARIO = "muc-osl-3d"
FILAMENT = "muc-osl-filament-3d"
#: MUC-OSL without the upwind particle moves of eq. 16 (an ablation shown beside the four).
NO_ENV_PU_PARAMS = {"estimator": {"type": "col-pf", "env_pu": "off"}}
LABELS = {
    "muc-osl": "MUC-OSL",
    "col-inf": "Col-Inf",
    "col-pf": "Col-PF",
    "adap-pp": "Adap-PP",
    NO_ENV_PU: "MUC-OSL -env",
}
ROWS = (*ALGORITHMS, NO_ENV_PU)
#: Default episodes per point of the filament world (the rate world's is ``default_episodes``).
FILAMENT_EPISODES = 5
#: The filament world's success rates are read at 8 minutes (Sect. VI.3), s.
AT = FILAMENT_AT
#: The paper's statement for each sweep, printed under its tables.
STATEMENTS = {
    "area": "paper: MST falls and SR rises as the area shrinks, for all; MUC-OSL best at every "
    "area;\nCol-Inf the most sensitive; at 100x200x50 MUC-OSL 24 %, Col-Inf fails",
    "uavs": "paper: MST falls and SR rises with more UAVs for all four, levelling off beyond 5;\n"
    "MUC-OSL always best; Adap-PP better than Col-PF with few UAVs",
    "radius": "paper: Col-PF poor at small radii compared with Adap-PP; Col-PF and MUC-OSL "
    "improve\nfrom 5 to 20 m and level off beyond 20 m (4 UAVs)",
    "particles": "paper: MST falls and SR rises with more particles; MUC-OSL steady with SR "
    "near 1\nbeyond 160; Col-PF better than Adap-PP with few particles",
}


def _note(limit: float) -> str:
    """The note under the success-rate / search-time tables, for an episode limit in seconds."""
    return (
        "SR: success rate % [95 % Wilson]; MST: mean search time s over all episodes, failures "
        f"at {limit:g} s\n[95 % bootstrap]; search time = flying + hovering + turning time of "
        "the first UAV within 2 m."
    )


def _check_values(values: Mapping[str, Sequence[Any]]) -> dict[str, tuple[Any, ...]]:
    """``values`` checked against the paper's sweeps (:data:`SWEEPS`), areas as tuples.

    A misspelt sweep key or a value the sweep does not have would otherwise leave that part
    out without a word and run something other than what was asked for.

    Raises
    ------
    ConfigError
        Naming ``values.<key>`` (or ``values``) and listing the known keys or values.
    """
    known = {sw.key: sw for sw in SWEEPS}
    if not isinstance(values, Mapping):
        raise ConfigError("values", f"must map sweep keys to values, got {values!r}")
    out: dict[str, tuple[Any, ...]] = {}
    for key, given in values.items():
        if key not in known:
            raise ConfigError("values", f"unknown sweep key {key!r} (known: {', '.join(known)})")
        if isinstance(given, str) or not isinstance(given, Sequence):
            raise ConfigError(f"values.{key}", f"must be a list of values, got {given!r}")
        # an area may come as a list (e.g. from YAML or JSON); the sweep holds tuples
        items = tuple(tuple(v) if isinstance(v, list) else v for v in given)
        for v in items:
            if v not in known[key].values:
                ticks = ", ".join(known[key].tick(k) for k in known[key].values)
                raise ConfigError(
                    f"values.{key}", f"{v!r} is not a value of the sweep (known: {ticks})"
                )
        out[key] = items
    return out


def _restrict(sweeps: Sequence[SweepDef], values: Mapping[str, tuple[Any, ...]] | None) -> list:
    """``sweeps`` cut to the checked ``values`` (a sweep without any is left out)."""
    if values is None:
        return list(sweeps)
    out = []
    for sw in sweeps:
        keep = tuple(v for v in sw.values if v in values.get(sw.key, ()))
        if keep:
            out.append(replace(sw, values=keep))
    return out


@register("reproduction", "muc-osl", ReproductionParams, "MUC-OSL: Sect. VI, Figs. 4-7 and 9")
class MucOslReproduction(Reproduction):
    """The four sweeps x four algorithms in the rate and the filament world (module docstring).

    Parameters
    ----------
    params : ReproductionParams, optional
    time_limit : float, optional, seconds
        A shorter episode limit (tests); default the rate scenario's ``limits.time`` (20
        minutes). The tables, notes and figures count failures at this limit; below the
        paper's 8 minutes, the success rates "at 8 minutes" are read at the limit instead and
        labelled with it, and Fig. 9 has no 8-minute mark.
    values : mapping of sweep key to values, optional
        Run only these values of each sweep (tests); a sweep without any is left out (the
        filament world keeps those of Fig. 9's settings). An unknown key, or a value its sweep
        does not have, raises :class:`ConfigError` naming it.
    filament : bool
        Include the filament world.
    fig3 : bool
        Draw Fig. 3 and its animation (it runs MUC-OSL episodes until one succeeds, up to 10).
    """

    name = "muc-osl"
    paper = "muc-osl-multi-uav.txt"
    summary = "MUC-OSL vs Col-Inf, Col-PF and Adap-PP: four sweeps, rate and filament worlds"
    default_episodes = 8
    paper_episodes = 200
    paper_episodes_note = "of the rate world: add --only rate, or the filament world runs 200 too"
    report_paired = False
    cell_summary = False  # hundreds of cells: the per-point tables say it better

    def __init__(
        self,
        params: ReproductionParams | None = None,
        time_limit: float | None = None,
        values: Mapping[str, Sequence[Any]] | None = None,
        filament: bool = True,
        fig3: bool = True,
    ) -> None:
        super().__init__(params)
        self.fig3 = fig3
        self.time_limit = time_limit
        self.limit = (
            float(get_scenario(SCENARIO).limits.time) if time_limit is None else float(time_limit)
        )
        #: When the filament world's success rates are read, s: the paper's 8 minutes, or the
        #: episode limit if that is shorter (no episode runs past it).
        self.at = min(AT, self.limit)
        checked = None if values is None else _check_values(values)
        self.rate_sweeps = _restrict(SWEEPS, checked)
        self.filament_sweeps = _restrict(fig9_settings(), checked) if filament else []

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        common = {} if self.time_limit is None else {"limits.time": float(self.time_limit)}
        ablation = [{"name": "muc-osl", "label": NO_ENV_PU, "params": NO_ENV_PU_PARAMS}]
        n_rate = self.default_episodes if episodes is None else int(episodes)
        n_fil = FILAMENT_EPISODES if episodes is None else int(episodes)
        out: dict[str, dict[str, Any]] = {}
        for world, scenario, sweeps, n, replay in (
            ("rate", SCENARIO, self.rate_sweeps, n_rate, False),
            ("filament", FILAMENT, self.filament_sweeps, n_fil, True),
        ):
            if not sweeps:
                continue
            files = sweep_files(
                scenario,
                sweeps,
                n,
                seed,
                replay=replay,
                extra_searchers=ablation,
                scenario_params=common,
                name=f"muc-osl {world}",
            )
            for part, spec in files.items():
                out[f"{world}-{part}" if part else world] = spec
        return out

    def reference(self) -> dict[str, dict[str, Any]]:
        """The paper's success rates at 100 x 200 x 50 m (the only per-point numbers it gives)."""
        s = next((sw for sw in self.rate_sweeps if sw.key == "area"), None)
        if s is None or (100.0, 200.0, 50.0) not in s.values:
            return {}
        setting = s.setting((100.0, 200.0, 50.0))
        return {
            "/".join(cell_of(SCENARIO, setting, a)): {"success_rate": v, "source": "Sect. VI.2.1"}
            for a, v in LARGEST_AREA_SUCCESS.items()
        }

    # ----------------------------------------------------------------- tables
    def _cells(self, df: Any) -> Cells:
        ok = df[df["status"] != "error"] if len(df) else df
        return Cells(add_uav_search_time(ok, self.limit) if len(ok) else ok)

    def tables(self, df: Any, seed: int) -> list[Table]:
        if not len(df):
            return []
        cells = self._cells(df)
        out: list[Table] = []
        long: list[list[str]] = []
        for sw in self.rate_sweeps:
            out += self._sweep_tables(cells, SCENARIO, sw, seed, long, "rate")
        if self.filament_sweeps:
            out += self._filament_tables(cells, seed, long)
        ok = add_uav_search_time(df[df["status"] != "error"], self.limit)
        worlds = [("rate", SCENARIO)] + ([("filament", FILAMENT)] if self.filament_sweeps else [])
        for world, scenario in worlds:
            g = ok[ok["world_key"] == scenario]
            if len(g):
                out += self._default_tables(g, world, seed)
        claims = evaluate_claims(
            cells,
            SCENARIO,
            self.rate_sweeps,
            FILAMENT if self.filament_sweeps else None,
            self.filament_sweeps,
            at=self.at,
            seed=seed,
        )
        for world in ("rate", "filament"):
            rows = [c.row()[1:] for c in claims if c.world == world]
            if rows:
                out.append(
                    Table(
                        f"claims_{world}",
                        f"The paper's statements in the {world} world (95 % intervals)",
                        ["statement", "paper", "ours [95 % interval]", "verdict"],
                        rows,
                        note="held / not held: the interval lies on the claimed / the other "
                        "side; undecided: it straddles it\n(pts: percentage points of success "
                        "rate; s: seconds of mean search time).",
                        left=4,
                        widths=(5, 2, 9, 2),
                    )
                )
        out.append(
            Table(
                "points",
                "Every point: success rate and mean search time with intervals",
                [
                    "world",
                    "sweep",
                    "value",
                    "algorithm",
                    "n",
                    "successes",
                    "SR %",
                    "SR lo",
                    "SR hi",
                    "MST s",
                    "MST lo",
                    "MST hi",
                    "MST successes s",
                    f"SR {when_text(self.at)} %",
                ],
                long,
                console=False,
            )
        )
        return out

    def _sweep_tables(
        self,
        cells: Cells,
        scenario: str,
        sw: SweepDef,
        seed: int,
        long: list[list[str]],
        world: str,
    ) -> list[Table]:
        sr_rows, mst_rows = [], []
        for v in sw.values:
            s = sw.setting(v)
            sr_row, mst_row = [sw.tick(v)], [sw.tick(v)]
            for i, a in enumerate(ALGORITHMS):
                g = cells.get(*cell_of(scenario, s, a))
                p = summarize_point(g, np.random.default_rng([seed, i, len(long)]))
                sr_row.append(_pct(p))
                mst_row.append(_mst(p))
                k8 = int((g["success"] & (g["time"] <= self.at)).sum()) if len(g) else 0
                long.append(
                    [
                        world,
                        sw.key,
                        sw.tick(v),
                        a,
                        str(p.n),
                        str(p.k),
                        fmt(100 * p.sr, 1),
                        fmt(100 * p.sr_lo, 1),
                        fmt(100 * p.sr_hi, 1),
                        fmt(p.mst, 0),
                        fmt(p.mst_lo, 0),
                        fmt(p.mst_hi, 0),
                        fmt(p.mst_success, 0),
                        fmt(100 * k8 / p.n if p.n else math.nan, 1),
                    ]
                )
            sr_rows.append(sr_row)
            mst_rows.append(mst_row)
        head = [sw.xlabel.split(" (")[0], *(LABELS[a] for a in ALGORITHMS)]
        return [
            Table(
                f"{world}_{sw.key}_sr",
                f"{sw.figure}, {world} world: success rate % [95 %] against {sw.xlabel}",
                head,
                sr_rows,
            ),
            Table(
                f"{world}_{sw.key}_mst",
                f"{sw.figure}, {world} world: mean search time s [95 %] against {sw.xlabel}",
                head,
                mst_rows,
                note=f"{_note(self.limit)}\n{STATEMENTS[sw.key]}",
            ),
        ]

    def _filament_tables(self, cells: Cells, seed: int, long: list[list[str]]) -> list[Table]:
        at_rows, all_rows = [], []
        seen = []
        for sw in self.filament_sweeps:
            # the rows of points.csv; the console shows one table of the distinct settings
            self._sweep_tables(cells, FILAMENT, sw, seed, long, "filament")
            for v in sw.values:
                s = sw.setting(v)
                if s in seen:
                    continue
                seen.append(s)
                name = _setting_name(sw, v) if s != DEFAULT else "default"
                at_row, all_row = [name], [name]
                for i, a in enumerate(ALGORITHMS):
                    g = cells.get(*cell_of(FILAMENT, s, a))
                    p = summarize_point(g, np.random.default_rng([seed, 7, i, len(seen)]))
                    k8 = int((g["success"] & (g["time"] <= self.at)).sum()) if len(g) else 0
                    at_row.append(_pct_of(k8, p.n))
                    all_row.append(f"{_pct(p, brackets=False)} / {fmt(p.mst, 0)}")
                at_rows.append(at_row)
                all_rows.append(all_row)
        head = ["setting", *(LABELS[a] for a in ALGORITHMS)]
        note = (
            "paper (MUC-OSL): about 90 % at 8 min in 100x60x30 m; above 80 % with more than 3 UAVs"
        )
        if self.at < AT:
            note += (
                f"\nread at the episode limit, {when_text(self.at)}: at most the success rate "
                "at 8 min"
            )
        return [
            Table(
                "filament_sr8",
                f"Filament world: success rate % [95 %] within {when_text(self.at)} (Fig. 9)",
                head,
                at_rows,
                note=note,
            ),
            Table(
                "filament_sr_mst",
                f"Filament world: success rate % / mean search time s at {self.limit / 60:g} min",
                head,
                all_rows,
                note=_note(self.limit),
            ),
        ]

    def _default_tables(self, g: Any, world: str, seed: int) -> list[Table]:
        """The default setting in one world: comparison, Table 2, Table 3."""
        from odorloc.experiments import stats

        rows, move, res = [], [], []
        for i, a in enumerate(ROWS):
            h = g[g["searcher"] == a]
            if not len(h):
                continue
            n = len(h)
            # a missing success (NaN) is no success, as the store counts it
            reached = h["success"].astype("boolean").fillna(False).astype(bool)
            k = int(reached.sum())
            lo, hi = stats.wilson_interval(k, n)
            rng = np.random.default_rng([seed, i])
            succ = h[reached]
            t_s = succ["uav_search_time"].to_numpy(float)
            t_lo, t_hi = stats.bootstrap_ci(t_s, rng)
            t_all = h["uav_search_time"].to_numpy(float)
            a_lo, a_hi = stats.bootstrap_ci(t_all, rng)
            decl = h["declared"].astype("boolean").fillna(False).astype(bool)
            rows.append(
                [
                    LABELS[a],
                    str(n),
                    f"{fmt(100 * k / n, 0)} [{fmt(100 * lo, 0)}, {fmt(100 * hi, 0)}]",
                    f"{fmt(t_s.mean() if t_s.size else math.nan, 0)} "
                    f"[{fmt(t_lo, 0)}, {fmt(t_hi, 0)}]",
                    f"{fmt(t_all.mean(), 0)} [{fmt(a_lo, 0)}, {fmt(a_hi, 0)}]",
                    f"{fmt(100 * decl.mean(), 0)}",
                    fmt(float(h.loc[decl, "loc_error"].mean()) if decl.any() else math.nan, 1),
                ]
            )
            e_m = h["movement_kj"].to_numpy(float)
            e_lo, e_hi = stats.bootstrap_ci(e_m, rng)
            dist = float(h["path_length"].sum())
            ref = TABLE2.get(a)
            move.append(
                [
                    LABELS[a],
                    fmt(float(h["team_hover_time"].mean()), 0),
                    fmt(float(h["team_turn_time"].mean()), 0),
                    fmt(float(h["path_length"].mean()), 0),
                    f"{fmt(e_m.mean(), 0)} [{fmt(e_lo, 0)}, {fmt(e_hi, 0)}]",
                    fmt(float(e_m.sum()) / dist if dist else math.nan, 2),
                    "-"
                    if ref is None
                    else f"{ref['hover_time']:.0f}/{ref['turn_time']:.0f}"
                    f"/{ref['distance']:.0f}/{ref['energy_kj']:.0f}",
                ]
            )
            iters = _agent_sum(h, "iterations")
            bits = _agent_sum(h, "compute_bits")
            per_iter = float(bits.sum() / iters.sum()) / 64.0 if iters.sum() else math.nan
            res.append(
                [
                    LABELS[a],
                    fmt(_numbers_per_message(h), 0),
                    TABLE3.get(a, {}).get("numbers", "-"),
                    fmt(float(h["bytes"].mean()) / 1e3, 1),
                    fmt(per_iter / 1e3, 1),
                    TABLE3.get(a, {}).get("computation", "-"),
                    fmt(float(h["energy_comm"].mean()) * 1e3, 2),
                    fmt(float(h["energy_compute"].mean()), 1),
                    fmt(_particles_mean(h), 0),
                ]
            )
        return [
            Table(
                f"{world}_default",
                f"Default setting, {world} world: 3 UAVs in 100 x 60 x 30 m (95 % intervals)",
                ["algorithm", "n", "success %", "time s", "all s", "decl %", "err m"],
                rows,
                note=f"time: search time of the successes; all: failures count {self.limit:g} s; "
                "decl: episodes with a\ndeclaration, err: its distance from the source; MUC-OSL "
                "-env: MUC-OSL without eq. 16.",
            ),
            Table(
                f"{world}_table2",
                f"Table 2, {world} world: team movement per episode",
                [
                    "algorithm",
                    "hover s",
                    "turn s",
                    "distance m",
                    "E_M kJ [95 %]",
                    "kJ/m",
                    "paper h/t/d/E",
                ],
                move,
                note=_saving_note(g),
            ),
            Table(
                f"{world}_table3",
                f"Table 3, {world} world: communication and computation",
                [
                    "algorithm",
                    "nums/msg",
                    "paper",
                    "kB/ep",
                    "k nums/iter",
                    "paper",
                    "E_T mJ",
                    "E_C J",
                    "N",
                ],
                res,
                note="nums/msg: float64 numbers per exchange; kB/ep: bytes sent per episode; "
                "k nums/iter: thousands\nof numbers processed per UAV iteration (estimator + "
                "planner; eq. 7 counts 64 bits each);\nN: mean particle count.",
            ),
        ]

    # ----------------------------------------------------------------- figures
    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        from odorloc.papers.muc_osl import figures as F

        if not len(df):
            return []
        cells = self._cells(df)
        figs = []
        names = {
            "area": "fig4_area",
            "uavs": "fig5_uavs",
            "radius": "fig6_radius",
            "particles": "fig7_particles",
        }
        for sw in self.rate_sweeps:
            figs.append(
                Figure(
                    f"{names[sw.key]}.png",
                    f"{sw.figure}: mean search time and success rate against {sw.xlabel}, rate "
                    "world, four algorithms (95 % intervals)",
                    lambda p, sw=sw: F.sweep_figure(
                        cells, SCENARIO, sw, p, seed, f"{sw.figure}, rate world", limit=self.limit
                    ),
                )
            )
        if self.filament_sweeps:
            figs.append(
                Figure(
                    "fig9_filament.png",
                    "Fig. 9: success rate against time in the filament world (solid) and the "
                    "rate world (dashed), one column per sweep, one row per algorithm",
                    lambda p: F.success_time_figure(
                        cells,
                        FILAMENT,
                        self.filament_sweeps,
                        p,
                        compare=SCENARIO,
                        at=AT,
                        limit=self.limit,
                    ),
                )
            )
        worlds = [("rate world", SCENARIO)]
        if self.filament_sweeps:
            worlds.append(("filament world", FILAMENT))
        figs.append(
            Figure(
                "comparison.png",
                "Default setting: success rate and mean search time of the four algorithms and "
                "MUC-OSL without env-pu (95 % intervals)",
                lambda p: F.comparison_figure(
                    cells,
                    worlds,
                    {**LABELS, NO_ENV_PU: "MUC-OSL\nno env-pu"},
                    p,
                    seed,
                    limit=self.limit,
                ),
            )
        )
        if not self.fig3:
            return figs
        figs.append(
            Figure(
                "fig3_team_3d.png",
                "Fig. 3: UAV paths, cue points (open circles) and each UAV's particles at four "
                "moments of one MUC-OSL episode",
                lambda p: _fig3(seed, p, self.time_limit),
            )
        )
        return figs


def _setting_name(sw: SweepDef, v: Any) -> str:
    if sw.key == "area":
        return f"{sw.tick(v)} m"
    if sw.key == "uavs":
        return f"{v} UAV{'s' if v != 1 else ''}"
    if sw.key == "radius":
        return f"r = {v:g} m, {sw.base.n_uavs} UAVs"
    return f"N = {v}"


def _pct(p: Any, brackets: bool = True) -> str:
    if p.n == 0:
        return "-"
    if not brackets:
        return f"{100 * p.sr:.0f}"
    return f"{100 * p.sr:.0f} [{100 * p.sr_lo:.0f}, {100 * p.sr_hi:.0f}]"


def _pct_of(k: int, n: int) -> str:
    from odorloc.experiments import stats

    if n == 0:
        return "-"
    lo, hi = stats.wilson_interval(k, n)
    return f"{100 * k / n:.0f} [{100 * lo:.0f}, {100 * hi:.0f}]"


def _mst(p: Any) -> str:
    if p.n == 0:
        return "-"
    return f"{p.mst:.0f} [{p.mst_lo:.0f}, {p.mst_hi:.0f}]"


def _agent_sum(g: Any, key: str) -> np.ndarray:
    """Per-episode sum over the UAVs of a per-agent value (the ``agents`` column)."""
    v = agent_values(g, key).to_numpy(float)
    return np.nansum(v, axis=1) if v.shape[1] else np.zeros(len(g))


def _numbers_per_message(g: Any) -> float:
    npm = agent_values(g, "numbers_per_message")
    sent = agent_values(g, "messages_sent").reindex(columns=npm.columns).to_numpy(float)
    tot = float(np.nansum(sent * npm.to_numpy(float)))
    n = float(np.nansum(sent))
    return tot / n if n else math.nan


def _particles_mean(g: Any) -> float:
    v = agent_values(g, "particles_mean").to_numpy(float)
    return float(np.nanmean(v)) if v.size else math.nan


def _saving_note(ok: Any) -> str:
    a = ok[ok["searcher"] == "muc-osl"].set_index("episode")["movement_kj"]
    b = ok[ok["searcher"] == "col-inf"].set_index("episode")["movement_kj"]
    common = a.index.intersection(b.index)
    if not len(common):
        return ""
    ma, mb = float(a[common].mean()), float(b[common].mean())
    if not (math.isfinite(ma) and math.isfinite(mb) and mb > 0):
        return ""
    return (
        f"team totals per episode; movement energy MUC-OSL vs Col-Inf over {len(common)}\n"
        f"paired episodes: {ma:.0f} vs {mb:.0f} kJ ({100 * (ma - mb) / mb:+.1f} %; paper "
        "-8.44 %);\nkJ/m: movement energy per metre flown (hovers and turns included)."
    )


def record_episode(
    searcher: str,
    seed: int,
    episode: int,
    belief_stride: int = 5,
    time_limit: float | None = None,
) -> Any:
    """The recorded episode ``episode`` of ``searcher`` on ``muc-osl-3d`` under root ``seed``."""
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario

    cell: dict[str, Any] = {"scenario": SCENARIO, "searcher": searcher}
    if time_limit is not None:
        cell["scenario_params"] = {"limits.time": float(time_limit)}
    sc = cell_scenario(cell)
    sc = sc.model_copy(
        update={"recording": sc.recording.model_copy(update={"belief_stride": belief_stride})}
    )
    return run_episode(sc, *episode_seeds(seed, SCENARIO, episode), record=True)


def _fig3(seed: int, path: Path, time_limit: float | None = None) -> None:
    from odorloc.viz.team3d import animate_team_3d, plot_team_3d

    res = None
    for ep in range(10):
        res = record_episode("muc-osl", seed, ep, time_limit=time_limit)
        if res.metrics["success"]:
            break
    assert res is not None and res.recording is not None
    rec = res.recording
    m = res.metrics
    outcome = f"reached at {m['search_time']:.0f} s" if m["success"] else "not reached"
    rec.meta["title"] = f"MUC-OSL, 3 UAVs, muc-osl-3d episode {ep} (seed {seed}): {outcome}"
    plot_team_3d(rec, path)
    animate_team_3d(rec, path.with_name("fig3_team_3d.gif"))
