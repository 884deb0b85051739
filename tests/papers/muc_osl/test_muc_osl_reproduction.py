"""``odorloc reproduce muc-osl`` on a small point: its sweeps and stores, resuming, ``--only``,
and the same rows on a Dask cluster as on the local pool."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from odorloc.core.errors import ConfigError
from odorloc.papers.muc_osl.reproduction import MucOslReproduction
from odorloc.papers.muc_osl.sweeps import ROWS
from odorloc.scenarios import get_scenario

#: Two worlds (the default and the 4-UAV one) and one more particle count, 20 s episodes.
VALUES = {"area": [(100.0, 60.0, 30.0)], "uavs": [3], "radius": [30.0], "particles": [20, 100]}
SWEEPS = ("rate", "rate-particles", "rate-ablation", "rate-ablation-particles", "filament",
          "filament-particles")  # fmt: skip
#: At the default point alone there is no point off it for the ablation's own parts.
DEFAULT_SWEEPS = ("rate", "rate-particles", "filament", "filament-particles")
#: Columns that hold timings (they differ between any two runs).
TIMING = ["wall_time", "finished_at", "extra", "wall_per_step_ms", "world_fraction",
          "searcher_fraction", "movie_wall_time", "movie_cpu_time", "cpu_time"]  # fmt: skip


def _small() -> MucOslReproduction:
    return MucOslReproduction(time_limit=20.0, values=VALUES)


@pytest.fixture
def few_frames(monkeypatch) -> None:
    """The mechanism figure from 2 episodes per variant and Fig. 3's animation in 4 frames:
    drawn as in a full run (the figures themselves: tests/viz/), at a fraction of the cost."""
    import functools

    import odorloc.papers.muc_osl.reproduction as muc
    import odorloc.viz.team3d as team3d

    monkeypatch.setattr(muc, "MECHANISM_EPISODES", 2)
    animate = functools.partial(team3d.animate_team_3d, max_frames=4)
    monkeypatch.setattr(team3d, "animate_team_3d", animate)


def _rows(df: pd.DataFrame) -> pd.DataFrame:
    keep = df.drop(columns=[c for c in TIMING if c in df.columns])
    return keep.sort_values(["sweep", "cell_id", "episode"]).reset_index(drop=True)


def test_sweeps_of_the_reproduction() -> None:
    full = MucOslReproduction().sweeps(None, 2024)
    assert list(full) == list(SWEEPS)
    assert full["rate"]["episodes"] == 8 and full["filament"]["episodes"] == 5
    assert full["filament"]["replay"] and not full["rate"]["replay"]
    assert len(full["rate"]["scenarios"]) == 17 and len(full["filament"]["scenarios"]) == 11
    assert {s["name"] for s in full["rate"]["scenarios"]} == {"muc-osl-3d"}
    assert {s["name"] for s in full["filament"]["scenarios"]} == {"muc-osl-filament-3d"}
    labels = [s["label"] for s in full["rate-particles"]["searchers"]]
    # ten other particle counts x the four and the two printed presets, and the ablation
    assert len(labels) == 61 and "muc-osl-no-env-pu" in labels
    assert "muc-osl-printed[N=20]" in labels
    assert MucOslReproduction().sweeps(200, 1)["filament-particles"]["episodes"] == 200
    # MUC-OSL without eq. 16 at the rate world's 16 other worlds and 10 other particle counts
    ablation, counts = full["rate-ablation"], full["rate-ablation-particles"]
    assert [s["label"] for s in ablation["searchers"]] == ["muc-osl-no-env-pu"]
    assert ablation["scenarios"] == full["rate"]["scenarios"][:1] + full["rate"]["scenarios"][2:]
    assert len(counts["searchers"]) == 10 and counts["scenarios"] == full["rate"]["scenarios"][1:2]


def test_the_default_point_alone_runs_every_method_there_and_nothing_else() -> None:
    rep = MucOslReproduction()
    rep.select_points("default")
    full, cut = MucOslReproduction().sweeps(None, 2024), rep.sweeps(200, 2024)
    assert list(cut) == list(DEFAULT_SWEEPS)
    for name in ("rate", "filament"):
        # one world (the default one) with every method of the full sweep
        assert len(cut[name]["scenarios"]) == 1 and cut[name]["episodes"] == 200
        assert cut[name]["scenarios"][0] in full[name]["scenarios"]
        assert not cut[name]["scenarios"][0]["params"]  # the scenario as it is
        assert cut[name]["searchers"] == full[name]["searchers"]
    # no other particle count; the ablation stays
    labels = [s["label"] for s in cut["rate-particles"]["searchers"]]
    assert labels == ["muc-osl-no-env-pu"]


@pytest.mark.parametrize("points", ["some", ""])
def test_points_other_than_all_or_default_are_refused(tmp_path, points) -> None:
    with pytest.raises(ConfigError, match=r"^points: must be 'all' or 'default'"):
        _small().run(tmp_path / "out", episodes=1, workers=1, progress=False, points=points)
    assert not (tmp_path / "out").exists()


def test_small_run_stores_resumes_and_runs_only_some_sweeps(tmp_path, few_frames) -> None:
    rep = _small()
    first = rep.run(tmp_path, episodes=1, workers=1, progress=False)
    df = first.results
    assert set(df["sweep"]) == set(SWEEPS)
    assert (df["status"] == "ok").all(), df.loc[df["status"] != "ok", "error"].tolist()
    assert sorted(first.stores) == sorted(SWEEPS)
    # 2 worlds x 6 algorithms, + 6 particle cells and the ablation, in each world; in the rate
    # world the ablation at the other world and the other particle count too
    sizes = {"rate": 12, "rate-particles": 7, "filament": 12, "filament-particles": 7}
    sizes |= {"rate-ablation": 1, "rate-ablation-particles": 1}
    assert df.groupby("sweep").size().to_dict() == sizes
    assert df.loc[df["sweep"].str.startswith("filament"), "replay"].all()
    assert not first.failed_figures
    for name in (
        "points.csv",
        "claims_rate.csv",
        "claims_filament.csv",
        "rate_table2.csv",
        "filament_table3.csv",
        "fig5_uavs.png",
        "fig9_filament.png",
        "comparison.png",
        "mechanism_eq16.png",
        "fig3_team_3d.png",
        "report.html",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    points = pd.read_csv(tmp_path / "points.csv")
    assert set(points["world"]) == {"rate", "filament"} and (points["n"] == 1).all()
    # the ablation is a column of every rate sweep (its 5 points), not of the filament world's
    ablation = points[points["algorithm"] == "muc-osl-no-env-pu"]
    assert set(ablation["world"]) == {"rate"} and len(ablation) == 5
    assert set(points.loc[points["world"] == "filament", "algorithm"]) == set(ROWS)
    html = (tmp_path / "report.html").read_text()
    assert "Table 2, rate world" in html and "Fig. 9" in html

    rep = MucOslReproduction(time_limit=20.0, values=VALUES, fig3=False)
    again = rep.run(tmp_path, episodes=1, workers=1, progress=False)
    pd.testing.assert_frame_equal(
        again.results[["cell_id", "finished_at"]], df[["cell_id", "finished_at"]]
    )
    more = rep.run(tmp_path, episodes=2, workers=1, progress=False, only=["rate"])
    n = more.results.groupby("sweep")["episode"].nunique()
    assert n["rate"] == n["rate-particles"] == n["rate-ablation"] == 2
    assert n["filament"] == n["filament-particles"] == 1
    with pytest.raises(ConfigError, match="--only"):
        rep.run(tmp_path, episodes=1, workers=1, progress=False, only=["gaden"])


def test_some_methods_run_first_and_the_rest_resumes(tmp_path) -> None:
    """``methods`` runs those methods' cells in every sweep that has them; the same run without
    it adds only the others, and the rows are those of one run of everything."""
    rep = MucOslReproduction(time_limit=20.0, values=VALUES, fig3=False, filament=False)
    first = rep.run(tmp_path / "a", episodes=1, workers=1, progress=False,
                    methods=["col-inf", "muc-osl-no-env-pu"])  # fmt: skip
    df = first.results
    labels = set(df["searcher"])
    assert {s.split("[")[0] for s in labels} == {"col-inf", "muc-osl-no-env-pu"}
    # Col-Inf at both worlds and N = 20; the ablation at the default point, the 4-UAV world, N=20
    assert len(df) == 3 + 3 and set(df["sweep"]) == set(SWEEPS[:4])
    rest = rep.run(tmp_path / "a", episodes=1, workers=1, progress=False)
    assert len(rest.results) == 12 + 7 + 1 + 1
    whole = rep.run(tmp_path / "b", episodes=1, workers=1, progress=False)
    pd.testing.assert_frame_equal(_rows(rest.results), _rows(whole.results))


@pytest.mark.parametrize(
    ("methods", "words"),
    [(["col-infx"], "no method 'col-infx' (methods: muc-osl, col-inf"), ([], "names no method")],
)
def test_unknown_methods_are_refused_before_anything_is_written(tmp_path, methods, words):
    with pytest.raises(ConfigError) as ei:
        _small().run(tmp_path / "out", episodes=1, workers=1, progress=False, methods=methods)
    assert ei.value.field == "--methods" and words in ei.value.problem
    assert not (tmp_path / "out").exists()


def test_dask_cluster_gives_the_local_pools_rows(tmp_path, few_frames) -> None:
    """Both worlds (the filament one replays its flows) on a LocalCluster of 2 workers."""
    pytest.importorskip("distributed")
    import logging

    from distributed import LocalCluster

    rep = MucOslReproduction(
        time_limit=15.0, values={"uavs": [3], "particles": [20, 100]}, fig3=False
    )
    local = rep.run(tmp_path / "local", episodes=2, workers=2, progress=False)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=logging.ERROR
    ) as cluster:
        dask = rep.run(
            tmp_path / "dask",
            episodes=2,
            backend="dask",
            scheduler=cluster.scheduler_address,
            progress=False,
        )
    a, b = _rows(local.results), _rows(dask.results)
    # both worlds' 6 + 7 cells, and the rate world's ablation at N = 20, 2 episodes each
    assert len(a) == (2 * (6 + 7) + 1) * 2 and (a["status"] == "ok").all()
    pd.testing.assert_frame_equal(a, b)
    assert np.isfinite(a["energy"]).all()


def test_cli_names_an_unknown_sweep(tmp_path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "odorloc.cli", "reproduce", "muc-osl", "--only", "rate,gaden",
         "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "--only" in lines[0] and "gaden" in lines[0]
    assert "Traceback" not in r.stderr
    # an --only that names nothing is refused too (it ran every sweep)
    r = subprocess.run(
        [sys.executable, "-m", "odorloc.cli", "reproduce", "muc-osl", "--only", ",",
         "--out", str(tmp_path / "x")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2 and r.stderr.strip() == "error: --only: names no sweep"
    assert not (tmp_path / "x").exists()
    # a method no sweep runs, named with the ones there are
    r = subprocess.run(
        [sys.executable, "-m", "odorloc.cli", "reproduce", "muc-osl", "--methods",
         "muc-osl,colinf", "--out", str(tmp_path / "m")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().startswith("error: --methods: no method 'colinf' (methods: muc-osl,")
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "m").exists()
    # --points default needs a reproduction over points
    r = subprocess.run(
        [sys.executable, "-m", "odorloc.cli", "reproduce", "single-agent", "--points", "default",
         "--out", str(tmp_path / "y")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2 and not (tmp_path / "y").exists()
    assert r.stderr.strip() == (
        "error: --points: single-agent sweeps no points around a default one"
    )


def test_least_favourable_comparison_is_the_largest_shortfall() -> None:
    from odorloc.experiments.claims import best_everywhere
    from odorloc.papers.muc_osl.claims import LABELS, READINGS
    from odorloc.papers.muc_osl.sweeps import DEFAULT

    class Fake:
        # MUC-OSL, Col-Inf, Col-PF, Adap-PP: MUC-OSL 400 s slower than Col-Inf, 300 s than
        # Adap-PP, 100 s faster than Col-PF; and 10 points more successful than Col-PF only
        def paired(self, setting, algorithms, column):
            rng = np.random.default_rng(0)
            base = np.array(
                [900.0, 500.0, 1000.0, 600.0] if column == "time" else [0.5, 0.9, 0.4, 0.8]
            )
            return base + rng.normal(0.0, 1e-3, (40, 4))

    rng, base = np.random.default_rng(1), READINGS["muc-osl"]
    ours, v = best_everywhere(Fake(), [DEFAULT], "muc-osl", base, "time", rng, LABELS,
                              higher=False, unit=" s")  # fmt: skip
    assert "least favourable: Col-Inf" in ours and "+400 s" in ours and v == "not held"
    ours, _ = best_everywhere(Fake(), [DEFAULT], "muc-osl", base, "success", rng, LABELS,
                              scale=100.0, unit=" pts")  # fmt: skip
    assert "least favourable: Col-Inf" in ours and "-40 pts" in ours


def test_a_later_sweeps_foreign_store_stops_the_run_before_any_episode(tmp_path) -> None:
    from odorloc.experiments.store import ResultStore

    with ResultStore(tmp_path / "filament.sqlite") as other:
        other.bind("0123456789abcdef")
    with pytest.raises(ConfigError, match=r"filament.sqlite holds results of a different sweep"):
        _small().run(tmp_path, episodes=1, workers=1, progress=False)
    # the rate sweeps, which come first, did not run
    assert not (tmp_path / "rate.sqlite").exists()


def _default_point_rows(n: int = 6) -> pd.DataFrame:
    """Made-up episodes at the default point of both worlds: Col-Inf never succeeds (0 %), the
    others always do (100 %)."""
    from odorloc.papers.muc_osl.sweeps import ALGORITHMS, DEFAULT, cell_of

    frames = []
    for scenario in ("muc-osl-3d", "muc-osl-filament-3d"):
        for a in ALGORITHMS:
            world, label = cell_of(scenario, DEFAULT, a)
            ok = [a != "col-inf"] * n
            frames.append(
                pd.DataFrame(
                    {
                        "world_key": world,
                        "searcher": label,
                        "episode": np.arange(n),
                        "status": "ok",
                        "success": ok,
                        "time": [100.0 if s else 300.0 for s in ok],
                        "declared": ok,
                        "loc_error": 1.0,
                        "reach_fly_hover_turn_time": 100.0,
                        "energy_fly": 1e5,
                        "energy_hover": 1e5,
                        "energy_turn": 1e4,
                        "energy_comm": 1e-3,
                        "energy_compute": 1.0,
                        "team_movement_energy": 2.1e5,
                        "team_hover_time": 10.0,
                        "team_turn_time": 10.0,
                        "path_length": 100.0,
                        "bytes": 1000.0,
                    }
                )
            )
    return pd.concat(frames, ignore_index=True)


def test_notes_give_the_episode_limit_in_force() -> None:
    """Failures count the limit the episodes ran with, not always 20 minutes."""
    rep = MucOslReproduction(time_limit=300.0, values={"uavs": [3]}, fig3=False)
    tables = {t.name: t for t in rep.tables(_default_point_rows(), 0)}
    for name in ("rate_uavs_mst", "rate_default", "filament_default"):
        assert "300 s" in tables[name].note and "1200" not in tables[name].note, name
    assert "by 5 min" in tables["filament_sr8"].title
    # without a shorter limit, the scenario's own
    assert MucOslReproduction().limit == get_scenario("muc-osl-3d").limits.time == 1200.0


def test_success_axes_leave_room_for_0_and_100_percent(tmp_path, monkeypatch) -> None:
    """The comparison and the sweep figures show 0 % and 100 % the same way, inside the frame."""
    import matplotlib.figure

    from odorloc.experiments import figures as F
    from odorloc.experiments.claims import Cells, Points
    from odorloc.papers.muc_osl.reproduction import COLORS, COLUMNS, uav_rows
    from odorloc.papers.muc_osl.sweeps import ALGORITHMS, DEFAULT, Setting, cell_of

    limits: dict[str, list[tuple[float, float]]] = {}

    def keep_limits(fig, path, *args, **kwargs):
        limits[Path(path).stem] = [
            ax.get_ylim() for ax in fig.axes if ax.get_ylabel().startswith("success rate")
        ]

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep_limits)
    cells = Cells(uav_rows(_default_point_rows(), 300.0), COLUMNS)
    data = Points(cells, lambda s, a: cell_of("muc-osl-3d", s, a))
    entries = [(a, a, COLORS[a]) for a in ALGORITHMS]
    F.comparison_figure([("rate", data, DEFAULT)], entries, tmp_path / "comparison.png", 0, "t")
    F.sweep_figure(data, [3], lambda v: Setting(n_uavs=v), ALGORITHMS, tmp_path / "sweep.png", 0,
                   "uavs", "UAVs", {}, COLORS, limit=300.0)  # fmt: skip
    assert limits["comparison"] == limits["sweep"] == [F.SUCCESS_YLIM]
    low, high = F.SUCCESS_YLIM
    assert low < 0.0 and high > 100.0


@pytest.mark.parametrize(
    ("values", "field", "words"),
    [
        ({"uav": [3]}, "values", ["'uav'", "area, uavs, radius, particles"]),
        ({"uavs": [3], "radiuss": [5.0]}, "values", ["'radiuss'", "radius"]),
        ({"uavs": [9]}, "values.uavs", ["9", "1, 2, 3, 4, 5, 6, 7, 8"]),
        ({"area": [(10.0, 10.0, 10.0)]}, "values.area", ["(10.0, 10.0, 10.0)", "100x60x30"]),
        ({"particles": 20}, "values.particles", ["list"]),
    ],
)
def test_unknown_sweep_keys_and_values_are_refused(values, field, words) -> None:
    """A misspelt key or a value the sweep lacks is an error, not a silently smaller run."""
    with pytest.raises(ConfigError) as ei:
        MucOslReproduction(values=values)
    assert ei.value.field == field and "\n" not in str(ei.value)
    for w in words:
        assert w in ei.value.problem, (w, ei.value.problem)


def test_sweep_values_may_give_an_area_as_a_list() -> None:
    rep = MucOslReproduction(values={"area": [[100, 200, 50]], "radius": [5]})
    assert [(s.key, s.values) for s in rep.rate_sweeps] == [
        ("area", ((100.0, 200.0, 50.0),)),
        ("radius", (5.0,)),
    ]
    # 5 m is not one of Fig. 9's radii: the filament world keeps only the area
    assert [s.key for s in rep.filament_sweeps] == ["area"]


def _fig9_marks(rep: MucOslReproduction, monkeypatch, tmp_path) -> tuple[str, list[float]]:
    """Title of Fig. 9 and the x (min) of its dotted marks, drawn from made-up episodes."""
    import matplotlib.figure

    seen: dict[str, object] = {}

    def keep(fig, path, *args, **kwargs):
        seen["title"] = fig._suptitle.get_text()
        seen["marks"] = [
            float(line.get_xdata()[0])
            for ax in fig.axes
            for line in ax.lines
            if line.get_linestyle() == ":"
        ]

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    (fig9,) = [f for f in rep.figures(_default_point_rows(), None, tmp_path, 0) if "fig9" in f.name]
    fig9.draw(tmp_path / fig9.name)
    return str(seen["title"]), list(seen["marks"])  # type: ignore[arg-type]


def test_eight_minute_mark_follows_the_limit_in_force(tmp_path, monkeypatch) -> None:
    """A run shorter than 8 minutes reads the success rates at its limit and says so; Fig. 9
    then has no 8-minute mark (it would lie beyond the time axis)."""
    short = MucOslReproduction(time_limit=300.0, values={"uavs": [3]}, fig3=False)
    tables = {t.name: t for t in short.tables(_default_point_rows(), 0)}
    assert "success % by 5 min" in tables["filament_sr8"].title
    assert tables["points"].headers[-1] == "SR by 300 s %"
    title, marks = _fig9_marks(short, monkeypatch, tmp_path)
    assert marks == [] and "dotted" not in title and "8 min" not in title

    full = MucOslReproduction(values={"uavs": [3]}, fig3=False)
    tables = {t.name: t for t in full.tables(_default_point_rows(), 0)}
    assert "success % by 8 min" in tables["filament_sr8"].title
    assert tables["points"].headers[-1] == "SR by 480 s %"
    title, marks = _fig9_marks(full, monkeypatch, tmp_path)
    assert marks and set(marks) == {8.0} and "dotted: 8 min" in title


def test_filament_statements_read_before_8_minutes_are_not_refuted() -> None:
    """Read at a shorter limit, a low success rate bounds the paper's from below only."""
    from odorloc.experiments.claims import Cells, Points
    from odorloc.papers.muc_osl.claims import evaluate_claims
    from odorloc.papers.muc_osl.reproduction import COLUMNS, uav_rows
    from odorloc.papers.muc_osl.sweeps import SWEEPS, cell_of, fig9_settings

    rows = _default_point_rows()
    rows["success"] = False  # MUC-OSL (and all) never succeed
    cells = Cells(uav_rows(rows, 300.0), COLUMNS)
    rate = Points(cells, lambda s, a: cell_of("muc-osl-3d", s, a))
    fil = Points(cells, lambda s, a: cell_of("muc-osl-filament-3d", s, a))
    uavs = [s for s in SWEEPS if s.key == "uavs"]
    fil_uavs = [s for s in fig9_settings() if s.key == "uavs"]

    def verdicts(at: float) -> dict[str, str]:
        claims = evaluate_claims(rate, uavs, fil, fil_uavs, at=at, seed=0)
        return {c.statement: c.verdict for c in claims if "about 90 %" in c.statement}

    assert verdicts(480.0) == {"MUC-OSL succeeds in about 90 % by 8 min (100x60x30 m)": "not held"}
    assert verdicts(300.0) == {"MUC-OSL succeeds in about 90 % by 8 min (100x60x30 m)": "undecided"}
