"""The benchmarks' own checks: both sides of a ratio get the same inputs and the same untimed
work, the RESULT lines carry what they claim, and a missing optional extra stops a benchmark
with one line instead of a traceback. No benchmark is timed here."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path
from types import ModuleType, SimpleNamespace

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name: str) -> ModuleType:
    """A benchmark script as a fresh module (the folder is not a package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------- plume_speed
FAKE_POMPY = """
import os

import numpy as np


def _log(what):
    with open(os.environ["FAKE_POMPY_LOG"], "a") as f:
        f.write(what + "\\n")


class Rectangle:
    def __init__(self, x0, x1, y0, y1):
        self.box = (x0, x1, y0, y1)

    def contains(self, x, y):
        x0, x1, y0, y1 = self.box
        return x0 <= x <= x1 and y0 <= y <= y1


class Puff:
    def __init__(self, x, y, z, r_sq):
        self.x, self.y, self.z, self.r_sq = x, y, z, r_sq


class WindModel:
    def __init__(self, region, nx, ny, u_av, v_av, noise_gain, rng):
        self.u = (u_av, v_av)
        self.stale = True

    def update(self, dt):
        self.stale = True  # as pompy: the splines are refitted at the next query

    def velocity_at_pos(self, x, y):
        self.stale = False
        return np.array(self.u)


class PlumeModel:
    def __init__(self, region, source, wind, model_z_disp, centre_rel_diff_scale,
                 puff_init_rad, puff_spread_rate, puff_release_rate, init_num_puffs,
                 max_num_puffs, rng):
        self.region, self.wind, self.puffs = region, wind, []

    def update(self, dt):
        if self.wind.stale:
            _log("spline refit inside the plume update")
        for p in self.puffs:
            v = self.wind.velocity_at_pos(p.x, p.y)
            p.x += v[0] * dt
        self.puffs = [p for p in self.puffs if self.region.contains(p.x, p.y)]
"""


@pytest.fixture
def fake_pompy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A stand-in ``pompy.models`` on the path of child processes; returns its log file."""
    pkg = tmp_path / "fake" / "pompy"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "models.py").write_text(FAKE_POMPY)
    log = tmp_path / "pompy.log"
    monkeypatch.setenv("PYTHONPATH", str(pkg.parent))
    monkeypatch.setenv("FAKE_POMPY_LOG", str(log))
    return log


def test_plume_speed_pompy_starts_from_our_puffs(monkeypatch: pytest.MonkeyPatch) -> None:
    ps = load("plume_speed")
    sent: dict = {}

    def fake_run(cmd: list[str], input: str, **kw: object) -> SimpleNamespace:
        sent.update(json.loads(input))
        rows = {str(n): {"step_s": 1.0, "live": float(n)} for n in ps.COUNTS}
        return SimpleNamespace(stdout=json.dumps(rows))

    monkeypatch.setattr(ps.subprocess, "run", fake_run)
    ps.time_pompy(Path(sys.executable), dict.fromkeys(ps.COUNTS, 1))
    for n in ps.COUNTS:
        ours = ps.build_ours(n)
        theirs = sent["prefill"][str(n)]
        assert np.array_equal(np.asarray(theirs["pos"]), ours.positions), n
        assert np.array_equal(np.asarray(theirs["s2"]), ours.sigma2), n


def test_plume_speed_pompy_wind_refit_not_timed(fake_pompy: Path) -> None:
    ps = load("plume_speed")
    out = ps.time_pompy(Path(sys.executable), dict.fromkeys(ps.COUNTS, 2))
    assert set(out) == set(ps.COUNTS)
    # every timed (and warm-up) plume update found the wind's splines already refitted
    assert not fake_pompy.exists(), fake_pompy.read_text()


def test_plume_speed_alternates_the_sides_and_keeps_each_fastest_round(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    ps = load("plume_speed")
    order: list[tuple[str, int]] = []
    # ours 2 ns per puff-step at best, pompy 30: each side's last round is its fastest
    ns = {"ours": [4.0, 3.0, 2.0], "pompy": [50.0, 40.0, 30.0]}
    slow = {(side, n): iter(v) for side, v in ns.items() for n in ps.COUNTS}

    def row(side: str, n: int) -> dict[str, float]:
        order.append((side, n))
        return {"step_s": next(slow[side, n]) * 1e-9 * n, "live": float(n)}

    monkeypatch.setattr(ps, "ensure_pompy", lambda: (Path(sys.executable), ""))
    monkeypatch.setattr(ps, "time_ours", lambda n, steps: row("ours", n))
    monkeypatch.setattr(ps, "time_pompy", lambda py, steps: {n: row("pompy", n) for n in steps})
    monkeypatch.setattr(ps, "time_query", lambda: 1.0)
    monkeypatch.setattr(ps, "query_memory", lambda: (1.0, 1.0))
    ps.main(["--quick", "--rounds", "3"])
    assert order == [(side, n) for _ in range(3) for n in ps.COUNTS for side in ("ours", "pompy")]
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert keys["speedup_vs_pompy_1000"] == "15.0"


# ---------------------------------------------------------------------- optional extras
def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_numba_cache_without_numba_stops_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from odorloc.core import jit

    nc = load("numba_cache")
    monkeypatch.setattr(jit, "HAVE_NUMBA", False)

    def no_child(*a: object, **k: object) -> None:
        pytest.fail("a child process was started although there is nothing to compile")

    monkeypatch.setattr(nc.subprocess, "run", no_child)
    with pytest.raises(SystemExit) as stop:
        nc.main(["--repeats", "1"])
    assert stop.value.code == 2
    assert "odorloc[fast]" in _one_line(capsys.readouterr().err)


def test_numba_cache_times_the_same_episode_twice_and_flags_each_mode_over_target(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import re

    from odorloc.core import jit

    nc = load("numba_cache")
    # the warm episode repeats the first one's seeds: the ratio is the start-up cost alone
    calls = re.findall(r"run_episode\(sc, ([^)]*)\)", nc.CHILD)
    assert len(calls) == 2 and calls[0] == calls[1]
    monkeypatch.setattr(jit, "HAVE_NUMBA", True)
    first = {"cold": 5.0, "cached": 2.8, "run": 1.2, "worker": 1.1}
    monkeypatch.setattr(
        nc,
        "run",
        lambda mode, cache: {"start": 0.1, "first": first[mode], "second": 1.0, "misses": 0},
    )
    nc.main(["--repeats", "1"])
    rows = {ln.split()[0]: ln for ln in capsys.readouterr().out.splitlines()}
    assert rows["cold"].endswith("(over target)") and rows["cached"].endswith("(over target)")
    assert "over target" not in rows["run"] + rows["worker"]


def test_env_speed_without_rl_extra_stops_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "gymnasium", None)
    monkeypatch.setitem(sys.modules, "odorloc.envs", None)
    es = load("env_speed")
    with pytest.raises(SystemExit) as stop:
        es.main(["--rounds", "1"])
    assert stop.value.code == 2
    assert "odorloc[rl]" in _one_line(capsys.readouterr().err)


def test_env_speed_result_carries_every_case(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    es = load("env_speed")
    # bare, environment seconds and steps: 10 % over the bare step alone, 80 % for the team
    fake = {"indoor-ventilated": 1.1, "two-sources-farrell": 1.2, "muc-osl-3d": 1.8}
    monkeypatch.setattr(
        es, "lockstep", lambda name, acts, r, n, radio: (1.0, fake[name] - 0.5 * radio, 100)
    )
    monkeypatch.setattr(es, "batched", lambda rounds, quick: {"batched_vs_sync": 2.0})
    monkeypatch.setattr(es, "encounter", lambda rounds, quick: {"encounter_batched_vs_loop": 3.0})
    es.main(["--rounds", "1"])
    result = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in result.split()[1:])
    assert keys["env_overhead"] == "0.100"
    assert keys["env_overhead_farrell"] == "0.200"
    assert keys["pz_overhead"] == "0.800"
    assert keys["pz_bare_ms"] == "10.000"
    assert keys["pz_adapter_overhead"] == "0.300"
    assert keys["batched_vs_sync"] == "2.00"
    assert keys["encounter_batched_vs_loop"] == "3.00"


def test_env_speed_batched_reports_every_batch_size(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    es = load("env_speed")
    # the batched env for real on small batches; the single-env vectors faked (slow to build)
    monkeypatch.setattr(es, "BATCHES", (1, 8))
    monkeypatch.setattr(es, "gym_vector_rate", lambda kind, b, steps, seed: 100.0)
    monkeypatch.setattr(es, "encounter_single_rate", lambda b, steps, seed, team: 50.0 + team)
    es.main(["--rounds", "1", "--quick", "--no-adapters"])
    result = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in result.split()[1:])
    assert float(keys["lattice_steps_per_s_8"]) > 0
    assert keys["sync_steps_per_s"] == "100"
    assert float(keys["batched_vs_sync"]) == pytest.approx(
        float(keys["lattice_steps_per_s_8"]) / 100, rel=1e-2
    )
    # the encounter-rate world: the team at every batch size, one UAV at the largest
    assert float(keys["encounter_steps_per_s_1"]) > 0
    assert keys["encounter_loop_steps_per_s"] == "51"
    assert float(keys["encounter_batched_vs_loop"]) == pytest.approx(
        float(keys["encounter_steps_per_s_8"]) / 51, rel=1e-2
    )
    assert float(keys["encounter_solo_vs_sync"]) == pytest.approx(
        float(keys["encounter_solo_steps_per_s_8"]) / 50, rel=1e-2
    )


def test_replay_memory_without_rosbags_skips_the_bag(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "rosbags", None)
    rm = load("replay_memory")
    rm.main(["--frames", "3", "--filaments", "5"])
    out = capsys.readouterr()
    result = out.out.strip().splitlines()[-1]
    assert result.startswith("RESULT gaden_frames=3 ")
    # computed from the sizes, not measured: the key says so
    assert " gaden_whole_mb_est=" in result and " gaden_whole_mb=" not in result
    assert "bag_peak_mb=nan" in result
    assert "odorloc[ros]" in _one_line(out.err)


# ---------------------------------------------------------------------- muc_osl_speed
def test_muc_osl_speed_episodes_timed_in_pairs_after_a_warm_up(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from odorloc.core.seeds import episode_seeds

    ms = load("muc_osl_speed")
    calls: list[tuple[str, int, int]] = []
    clock = [0.0]
    # per backend and play: the first of each backend pays a one-off second (a kernel load);
    # the second play of episode 0 on "numpy" is slower (a busy machine), the third faster
    cost = {("numpy", 1): 0.5, ("numpy", 2): 0.2}

    def fake_episode(sc: object, world: int, agent: int, record: bool) -> SimpleNamespace:
        b = sc.searcher.planner["backend"]  # type: ignore[attr-defined]
        plays = sum(1 for c in calls if c[0] == b)
        clock[0] += 1.0 if plays == 0 else cost.get((b, plays), 0.25)
        calls.append((b, world, agent))
        return SimpleNamespace(metrics={"steps": 10, "success": True, "wall_time": 0.0})

    monkeypatch.setattr(ms, "run_episode", fake_episode)
    monkeypatch.setattr(ms.time, "perf_counter", lambda: clock[0])
    out = ms.episode_rows("col-inf", ("numpy", "numba"), 2, repeats=3)
    w0, w1 = episode_seeds(2024, "muc-osl-3d", 0), episode_seeds(2024, "muc-osl-3d", 1)
    warm = calls[:2]
    assert [c[0] for c in warm] == ["numpy", "numba"] and all(c[1:] not in (w0, w1) for c in warm)
    # episode by episode, the backends' order reversed at each repeat
    assert [c[0] for c in calls[2:8]] == ["numpy", "numba", "numba", "numpy", "numpy", "numba"]
    assert [c[1:] for c in calls[2:8]] == [w0] * 6
    assert [c[1:] for c in calls[8:]] == [w1] * 6
    assert out["numpy"][0] == pytest.approx([0.2, 0.25])
    assert out["numba"][0] == pytest.approx([0.25, 0.25])
    assert out["numpy"][1] == out["numba"][1] == [{"steps": 10, "success": True}] * 2


def test_muc_osl_speed_refuses_repeats_that_differ(monkeypatch: pytest.MonkeyPatch) -> None:
    ms = load("muc_osl_speed")
    plays = [0]

    def fake_episode(sc: object, world: int, agent: int, record: bool) -> SimpleNamespace:
        plays[0] += 1
        return SimpleNamespace(metrics={"steps": plays[0], "wall_time": 0.0})

    monkeypatch.setattr(ms, "run_episode", fake_episode)
    with pytest.raises(RuntimeError, match="differs between repeats"):
        ms.episode_rows("col-inf", ("numpy",), 1, repeats=2)


def test_muc_osl_speed_loops_agree_with_the_vector_code() -> None:
    from odorloc.inference.belief import ParticleBelief
    from odorloc.inference.particles.team_estimators import ColPFEstimator, ColPFParams
    from odorloc.planning.base import Pose

    ms = load("muc_osl_speed")
    case, ctx, rng = ms.sample_case(), ms.context(), np.random.default_rng(1)
    model = ms.VergassolaModel(ms.VergassolaModelParams(sensor_radius=ms.A, backend="numpy"))
    w0 = np.exp(case["lw"])
    mean0 = w0 @ case["x"]
    cov0 = ((case["x"] - mean0) * w0[:, None]).T @ (case["x"] - mean0)
    est = ColPFEstimator(
        ColPFParams(
            n_particles=ms.N,
            resample_threshold=0.0,
            env_pu="off",
            adaptive_count=False,
            col_pu=False,
        )
    )
    est.reset(ctx, model, rng, n=ms.N)
    est.pf.replace(case["x"], case["lw"])
    est.fit = (mean0, cov0)
    est.update(ms.Measurement(case["count"], case["pos"], 1.0, 1000, ms.WIND), case["inbox"], rng)
    ref_w = ms.colpf_weights_loop(case, (mean0, cov0))
    np.testing.assert_allclose(est.pf.weights, ref_w, rtol=1e-9, atol=1e-15)

    bound = model.bind(dt=1.0, direction=ms.WIND)
    params = ms.AdaptivePlannerParams(l_max=4, tail_mass=1e-300, backend="numpy")
    planner = ms._planner(params, ctx, model, case["hist"])
    belief = ParticleBelief(case["x"], case["lw"])
    plan = planner.plan(
        belief, Pose(case["pos"], conditions={"dt": 1.0, "direction": ms.WIND}), rng
    )
    z = bound.outcome_probabilities(case["pos"] + planner.steps, case["x"]).shape[1]
    k, length, rewards = ms.adap_pp_loop(case, params.h1_scale, params.h2_scale, 4, z)
    finite = np.isfinite(rewards)
    assert plan.index == k and plan.extra["length"] == length
    np.testing.assert_allclose(-plan.scores[finite], rewards[finite], rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("count", [1.0, 0.0])
def test_muc_osl_speed_colpf_loop_is_the_whole_update(count: float) -> None:
    """From the same seed the loop ends where the timed printed update ends: resampled, N_s
    particles moved upwind, col-pu only without the own cue."""
    from odorloc.inference.particles.team_estimators import ColPFEstimator, ColPFParams

    ms = load("muc_osl_speed")
    case, ctx, rng = {**ms.sample_case(), "count": count}, ms.context(), np.random.default_rng(1)
    model = ms.VergassolaModel(ms.VergassolaModelParams(sensor_radius=ms.A, backend="numpy"))
    w0 = np.exp(case["lw"])
    mean0 = w0 @ case["x"]
    fit = (mean0, ((case["x"] - mean0) * w0[:, None]).T @ (case["x"] - mean0))
    params = ColPFParams(n_particles=ms.N, n_max=ms.N, pugl_move="printed")
    est = ColPFEstimator(params)
    est.reset(ctx, model, rng, n=ms.N)
    diff = ms.colpf_update_agreement(est, case, fit)
    assert diff["agree"], diff
    n_s = round(ms.N * (1 - (case["k"] / 800) ** 1.8) ** 4)  # eq. 15
    assert diff["n_s"] == n_s
    ref = ms.colpf_update_loop(case, fit, params, np.random.default_rng(7))
    no_col = ColPFParams(n_particles=ms.N, n_max=ms.N, col_pu=False, pugl_move="printed")
    alone = ms.colpf_update_loop(case, fit, no_col, np.random.default_rng(7))
    assert (alone["x"] == ref["x"]) == (count > 0)
    with pytest.raises(ValueError, match="printed"):
        ms.colpf_update_loop(case, fit, ColPFParams(n_particles=ms.N), np.random.default_rng(7))


# ---------------------------------------------------------------------- odor_path_speed
def _fake_odor_path_rows(map_of: dict[str, float]):
    def fake(
        noise: float, instances: int, backend: str, seed: int, compiled_full: bool = False
    ) -> dict:
        name = "numba" if backend == "auto" else "numpy"
        return {
            "fast_ms": 1.0,
            "fast_dense_ms": 1.0,
            "full_ms": 2.0,
            "cell_ms": 3.0,
            "nb_ms": 1.5 if compiled_full else float("nan"),
            "nb_two_ms": 3.0 if compiled_full else float("nan"),
            "cells": 10.0,
            "max_err": 0.0,
            "maps": [(1, 2, np.full((2, 3), map_of[name]))] * instances,
        }

    return fake


@pytest.mark.parametrize(
    ("numpy_map", "result"), [(0.25, "yes"), (0.25 * (1 + 1e-15), "yes"), (0.2501, "no")]
)
def test_odor_path_speed_reports_whether_kernels_agree(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    numpy_map: float,
    result: str,
) -> None:
    ops = load("odor_path_speed")
    monkeypatch.setattr(ops, "HAVE_NUMBA", True)
    monkeypatch.setattr(
        ops, "time_odor_path", _fake_odor_path_rows({"numba": 0.25, "numpy": numpy_map})
    )
    ds = {"dense_ms": 1.0, "patch_ms": 1.0, "plan_ms": 1.0, "cells": 1.0}
    monkeypatch.setattr(ops, "time_ds", lambda grid, repeats, seed: ds)
    ops.main(["--instances", "2"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert last.startswith("RESULT ") and keys["maps_bit_equal"] == result
    # the compiled full grids (one pass 1.5 ms, two passes 3 ms) over our dense map (1 ms)
    assert keys["speedup_vs_full_compiled"] == "1.5"
    assert keys["speedup_vs_full_two_pass"] == "3.0"


def _odor_path_windows(seed: int, noise: float, lower=(0.0, 0.0), upper=(10.0, 10.0)):
    """Window arrays and the reference full-grid map over a benchmark-like record."""
    ops = load("odor_path_speed")
    from odorloc.inference.odor_path import OdorPathEstimator, OdorPathParams

    rng = np.random.default_rng(seed)
    est = OdorPathEstimator(OdorPathParams(cell_size=0.05, t_thr=10.0), lower, upper)
    winds = ops.wind_record(rng, 30, noise)
    mid = 0.5 * (np.asarray(lower) + np.asarray(upper))
    pos = mid + rng.uniform(-2, 2, (30, 2))
    for i in range(30):
        est.update(i * ops.DT, pos[i], winds[i], 1.0)
    return est, est.window_arrays(), est.path_map_full()


@pytest.mark.parametrize(
    ("seed", "noise", "upper"),
    [(1, 0.05, (10.0, 10.0)), (2, 0.15, (10.0, 10.0)), (3, 0.4, (10.0, 10.0)),
     (4, 0.15, (4.0, 3.0))],
)  # fmt: skip
def test_odor_path_speed_full_grids_equal_the_reference(seed, noise, upper) -> None:
    """Both compiled full grids give ``path_map_full``'s map: the same cells, values within
    1e-12 (a small grid cuts the windows at its edges)."""
    ops = load("odor_path_speed")
    est, w, ref = _odor_path_windows(seed, noise, upper=upper)
    xc, yc = est.grid.x_centers(), est.grid.y_centers()
    for grid in (ops._full_grid_fast, ops._full_grid_two_pass_fast):
        got = grid(xc, yc, w.center, w.var, w.k, est.grid.cell_size)
        assert np.array_equal(got > 0, ref > 0)
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)


def test_odor_path_speed_window_sum_counts_each_cell_of_the_ellipse_once() -> None:
    """The row-run sum equals the sum over a brute-force mask, for ellipses inside the grid,
    cut by its edges, reduced to a single cell, and outside it (zero)."""
    ops = load("odor_path_speed")
    rng = np.random.default_rng(5)
    x = np.arange(40) * 0.1 + 0.05
    y = np.arange(30) * 0.1 + 0.05
    for cx, cy, vx, vy, lim in [
        (2.0, 1.5, 0.3, 0.1, 2.0),
        (0.0, 3.0, 0.5, 0.5, 4.0),  # cut by two edges
        (2.05, 1.55, 1e-4, 1e-4, 1.0),  # one cell
        (9.0, 9.0, 0.1, 0.1, 1.0),  # outside the grid
        (2.0, 1.5, 1e3, 1e3, 1.0),  # covers the whole grid
    ]:
        qx, qy = (x - cx) ** 2 / vx, (y - cy) ** 2 / vy
        fx, fy = rng.uniform(0.1, 1.0, x.size), rng.uniform(0.1, 1.0, y.size)
        cum = np.concatenate([[0.0], np.cumsum(fy)])
        mask = qx[:, None] + qy[None, :] <= lim
        brute = float((np.outer(fx, fy) * mask).sum())
        got = ops._window_sum_fast(qx, fx, qy, cum, lim)
        assert got == pytest.approx(brute, rel=1e-13, abs=0.0)


def test_odor_path_speed_map_comparison_follows_the_maps() -> None:
    """Both kernels' maps of the same records agree (the fused map within 1e-12 of the
    batch's), other records' do not; a change in the last bit passes, a cell more or less,
    a box shifted or a larger difference do not."""
    ops = load("odor_path_speed")
    if not ops.HAVE_NUMBA:
        pytest.skip("numba is not installed")
    a = ops.time_odor_path(0.05, 2, "auto", 11)
    b = ops.time_odor_path(0.05, 2, "numpy", 11)
    c = ops.time_odor_path(0.05, 2, "numpy", 12)
    assert len(a["maps"]) == 2
    assert ops.maps_agree(a["maps"], b["maps"])
    assert not ops.maps_agree(a["maps"], c["maps"])
    assert not ops.maps_agree(a["maps"], b["maps"][:1])
    x = np.array([[0.0, 0.5, 0.25], [0.125, 0.5, 0.0]])
    last_bit = x.copy()
    last_bit[0, 1] = np.nextafter(0.5, 1.0)
    more = x.copy()
    more[1, 2] = np.nextafter(0.0, 1.0)
    far = x.copy()
    far[1, 1] *= 1 + 1e-10
    # the same map in a larger box (a zero border) agrees; moved by a cell it does not
    padded = np.pad(x, 1)
    assert ops.maps_agree([(3, 4, x)], [(3, 4, last_bit)])
    assert ops.maps_agree([(3, 4, x)], [(2, 3, padded)])
    assert not ops.maps_agree([(3, 4, x)], [(3, 5, x)])
    assert not ops.maps_agree([(3, 4, x)], [(3, 4, more)])
    assert not ops.maps_agree([(3, 4, x)], [(3, 4, far)])


# ---------------------------------------------------------------------- infotaxis_vs_otto
def test_infotaxis_vs_otto_has_no_speedup_when_otto_did_not_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("OTTO_PYTHON", raising=False)
    monkeypatch.delenv("OTTO_SRC", raising=False)
    ivo = load("infotaxis_vs_otto")
    ivo.main(["--no-statistics", "--states", "2", "--rounds", "1", "--out", str(tmp_path)])
    out = capsys.readouterr().out.strip().splitlines()
    keys = dict(kv.split("=") for kv in out[-1].split()[1:])
    assert keys["decision_source"] == "none"
    assert keys["identical_19"] == keys["identical_37"] == "n/a"
    # the note's OTTO times come from another machine: printed for information, no ratio
    assert math.isnan(float(keys["decision_speedup_19"]))
    assert math.isnan(float(keys["decision_speedup_37"]))
    assert math.isnan(float(keys["step_speedup_53"]))
    assert keys["step_identical_53"] == "n/a"
    assert any(line.startswith("for information only") for line in out)


def test_infotaxis_vs_otto_has_no_speedup_when_otto_fails_in_a_later_round(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    ivo = load("infotaxis_vs_otto")
    calls = []

    def flaky_otto(python: str, src: str, work: Path, states: int, seed: int) -> dict | None:
        calls.append(1)
        if len(calls) > 1:
            return None
        result = {}
        for n in ivo.SETTINGS:
            beliefs, agents, sources, hits = ivo.our_states(n, states, seed)
            path = work / f"otto_{n}.npz"
            np.savez_compressed(path, beliefs=beliefs, agents=agents, sources=sources, hits=hits)
            ones = [1.0] * states
            result[str(n)] = {"times": ones, "env": ones, "choices": [0] * states, "states": path}
        return result

    monkeypatch.setattr(ivo, "run_otto", flaky_otto)
    ours_calls = []
    real = ivo.our_decisions
    monkeypatch.setattr(ivo, "our_decisions", lambda *a: ours_calls.append(1) or real(*a))
    args = ["--no-statistics", "--states", "2", "--rounds", "3", "--out", str(tmp_path)]
    ivo.main([*args, "--otto-python", "python", "--otto-src", "src"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert keys["decision_source"] == "partial"
    assert math.isnan(float(keys["decision_speedup_19"]))
    assert math.isnan(float(keys["decision_speedup_37"]))
    assert keys["identical_19"].endswith("/2")
    assert math.isnan(float(keys["step_speedup_37"]))
    # ours stopped with OTTO: one round on each side, every setting
    assert len(calls) == 2 and len(ours_calls) == len(ivo.SETTINGS)


# ---------------------------------------------------------------------- pf_speed
def test_pf_speed_result_carries_a_failed_check(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    pfs = load("pf_speed")
    loop = pfs.update_loop
    monkeypatch.setattr(pfs, "update_loop", lambda case, params: loop(case, params) + 1e-3)
    pfs.main(["--repeat", "1", "--no-table1"])
    out = capsys.readouterr().out.strip().splitlines()
    keys = dict(kv.split("=") for kv in out[-1].split()[1:])
    assert keys["agree"] == "no"
    assert math.isfinite(float(keys["pf_update_speedup"]))
    # the agree column says NO (a slow cold run may add "(over target)" after it)
    assert any(line.startswith("PF update") and "NO" in line.split() for line in out)


# ---------------------------------------------------------------------- live against replayed
def _ticking() -> SimpleNamespace:
    """A stand-in ``time`` module whose clocks advance one second per reading."""
    clock = [0.0]

    def tick() -> float:
        clock[0] += 1.0
        return clock[0]

    return SimpleNamespace(process_time=tick, perf_counter=tick)


@pytest.mark.parametrize(("shift", "result"), [(0.0, "yes"), (1e-9, "no")])
def test_virtual_physics_speed_result_carries_the_live_replay_check(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], shift: float, result: str
) -> None:
    vps = load("virtual_physics_speed")
    path = np.zeros((3, 12, 2))
    metrics = {"termination": "time_limit", "success": False, "steps": 2}

    def fake_episode(sc: object, world: int, agent: int, **kw: object) -> SimpleNamespace:
        # the replayed episode (run on the replay's components) strays by ``shift``
        p = path + (shift if kw.get("built") is not None else 0.0)
        return SimpleNamespace(recording=SimpleNamespace(positions=p), metrics=metrics)

    monkeypatch.setattr(vps, "time", _ticking())
    monkeypatch.setattr(vps, "record_flow", lambda sc, seed: "movie")
    monkeypatch.setattr(vps, "on_replay", lambda sc, movie: (sc, "built"))
    monkeypatch.setattr(vps, "searcher_step_times", lambda movie, sc, seeds: ([1.0], [1.0]))
    monkeypatch.setattr(vps, "run_episode", fake_episode)
    vps.main(["--skip-reproduction", "--limit", "1"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert keys["same_rows"] == result
    assert math.isfinite(float(keys["replay_speedup"]))


def test_virtual_physics_speed_reports_the_mean_step(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    vps = load("virtual_physics_speed")
    path = np.zeros((3, 12, 2))
    metrics = {"termination": "time_limit", "success": False, "steps": 2}
    monkeypatch.setattr(vps, "time", _ticking())
    monkeypatch.setattr(vps, "record_flow", lambda sc, seed: "movie")
    monkeypatch.setattr(vps, "on_replay", lambda sc, movie: (sc, "built"))
    # cheap holding steps after a declaration pull the median below the mean
    cpu = [1.0, 1.0, 1.0, 9.0]
    monkeypatch.setattr(vps, "searcher_step_times", lambda movie, sc, seeds: (cpu, cpu))
    monkeypatch.setattr(
        vps,
        "run_episode",
        lambda sc, w, a, **kw: SimpleNamespace(
            recording=SimpleNamespace(positions=path), metrics=metrics
        ),
    )
    vps.main(["--skip-reproduction", "--limit", "1"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert keys["vp_step_ms"] == "3.000"
    assert keys["vp_step_ms_median"] == "1.000"


@pytest.mark.parametrize(("replayed_steps", "result"), [(10, "yes"), (11, "no")])
def test_muc_osl_budget_result_carries_the_live_replay_check(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    replayed_steps: int,
    result: str,
) -> None:
    mob = load("muc_osl_budget")
    row = {"status": "ok", "success": True}
    clock = _ticking()
    monkeypatch.setattr(mob, "_clock", lambda: (clock.process_time(), clock.perf_counter()))
    monkeypatch.setattr(mob, "run_task", lambda task: {**row, "steps": 10})
    # the timed sample needs only an ok status; the live episodes below all take 10 steps
    monkeypatch.setattr(
        mob, "run_replay_group", lambda tasks: [{**row, "steps": replayed_steps} for _ in tasks]
    )
    monkeypatch.setattr(mob, "cell_scenario", lambda cell: None)
    monkeypatch.setattr(
        mob,
        "run_episode",
        lambda sc, w, a, record: SimpleNamespace(metrics={"success": True, "steps": 10}),
    )
    mob.main(["--stride", "1000", "--stride-groups", "1000"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    assert keys["same_rows"] == result


def test_muc_osl_budget_projects_every_method_at_its_own_cost(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """With the printed readings three times as costly as the rest, the projection of the
    rate world at 200 episodes is the exact cost of its cells, every method and the paper's
    four apart: a sample that saw one method only would miss it."""
    from odorloc.experiments.reproduction import Reproduction
    from odorloc.experiments.sweep import expand_cells, load_sweep
    from odorloc.papers.muc_osl.reproduction import MucOslReproduction
    from odorloc.papers.muc_osl.sweeps import ALGORITHMS

    mob = load("muc_osl_budget")
    cost = {"muc-osl-printed": 3.0, "col-pf-printed": 3.0}
    spent = [0.0]

    def run_task(task):
        spent[0] += cost.get(Reproduction.method_of(task.cell), 1.0)
        return {"status": "ok", "success": True, "steps": 10}

    def replay(tasks):
        spent[0] += 1.0  # the filament part's own clock readings (not projected here)
        return [{"status": "ok", "success": True, "steps": 10} for _ in tasks]

    def live(*args, **kwargs):
        spent[0] += 1.0
        return SimpleNamespace(metrics={"success": True, "steps": 10})

    monkeypatch.setattr(mob, "_clock", lambda: (spent[0], spent[0]))
    monkeypatch.setattr(mob, "run_task", run_task)
    monkeypatch.setattr(mob, "run_replay_group", replay)
    monkeypatch.setattr(mob, "cell_scenario", lambda cell: None)
    monkeypatch.setattr(mob, "run_episode", live)
    mob.main(["--stride", "5", "--stride-groups", "1000"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    keys = dict(kv.split("=") for kv in last.split()[1:])
    rate = [
        c
        for name, spec in MucOslReproduction().sweeps(None, 2024).items()
        if name.startswith("rate")
        for c in expand_cells(load_sweep(spec))
    ]
    methods = [Reproduction.method_of(c) for c in rate]
    every = sum(cost.get(m, 1.0) for m in methods) * 200 / 2 / 60
    paper = sum(1.0 for m in methods if m in ALGORITHMS) * 200 / 2 / 60
    assert float(keys["full_rate_min"]) == pytest.approx(every, abs=0.05)
    assert float(keys["paper_rate_min"]) == pytest.approx(paper, abs=0.05)


# ---------------------------------------------------------------------- gas_map_speed
def test_gas_map_speed_quick_run_checks_both_references(
    capsys: pytest.CaptureFixture[str],
) -> None:
    gms = load("gas_map_speed")
    gms.main(["--quick", "--repeats", "1"])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("RESULT ")
    fields = dict(kv.split("=") for kv in last.split()[1:])
    assert fields["maps_equal"] == "yes"
    for key in ("kernel_dmv_s", "kernel_dmv_loop_s", "gmrf_solve_s", "gmrf_loop_s"):
        assert math.isfinite(float(fields[key])) and float(fields[key]) > 0
    assert set(fields) >= {"kernel_dmv_ratio", "gmrf_ratio", "targets_met", "gmrf_variance_s"}


# ---------------------------------------------------------------------- infotaxis_vs_otto
def test_otto_benchmark_compiled_steps_replay_recorded_states() -> None:
    """Without OTTO: states of our own compiled episodes, replayed by the timed compiled step,
    give back the recorded choices' moves (the hits fed, the decisions taken afresh)."""
    ov = load("infotaxis_vs_otto")
    beliefs, agents, sources, hits = ov.our_states(19, 30, seed=5)
    assert beliefs.shape == (30, 19, 19) and agents.shape == sources.shape == (30, 2)
    np.testing.assert_allclose(beliefs.reshape(30, -1).sum(axis=1), 1.0, rtol=1e-12)
    choices, times = ov.our_steps(beliefs, agents, sources, hits, 19, seed=5)
    assert len(choices) == len(times) == 30
    # the move each recorded state was followed by: the next agent cell of the same episode
    for i in range(29):
        if hits[i] >= 0:
            step = agents[i + 1] - agents[i]
            a = choices[i]
            expected = np.zeros(2, int)
            expected[a // 2] = 1 if a % 2 else -1
            np.testing.assert_array_equal(step, expected)


# ---------------------------------------------------------------------- bench_budget
def test_bench_budget_quick_mode(capsys: pytest.CaptureFixture[str]) -> None:
    """The quick mode runs one task and ends with a RESULT line of what it measured; the
    standard tier's estimate scales each task by its episode counts and shortened limits."""
    mod = load("bench_budget")
    result = mod.main(["--quick"])
    out = capsys.readouterr().out
    assert out.strip().splitlines()[-1].startswith("RESULT tier=quick ")
    assert result["tasks"] == 1 and result["rows"] == 1
    from odorloc.experiments.bench import load_suite

    suite = load_suite()
    farrell = suite.task("two-sources-farrell")
    n = farrell.episodes["standard"] / farrell.episodes["quick"]
    assert mod.scale(farrell, "quick", "standard") == pytest.approx(n * 5000.0 / 600.0)
    lattice = suite.task("otto-19x19")
    assert mod.scale(lattice, "quick", "standard") == pytest.approx(1000 / 20)
