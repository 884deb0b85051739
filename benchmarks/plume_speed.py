"""Speed of the filament plume against pompy 0.1.1 (a public Python Farrell puff model).

Run: ``python benchmarks/plume_speed.py [--quick] [--rounds 3]``.

Both models use the same 50 m x 20 m arena, a 21 x 21 wind grid carrying a uniform 1 m/s wind
(pompy's ``WindModel`` with its boundary noise switched off; ours interpolates the same grid),
the same time step and puff release rates, 2D puff dispersion, and are pre-filled with the same
puffs (positions and sizes) spread along the plume so that the live count starts (and stays) near
200, 1 000 and 5 000; both take the same untimed warm-up steps and the same timed steps, and the
speed-up is per puff-step. pompy needs NumPy < 2, so it runs in a throwaway virtual environment
(``.bench-venv``, created on demand) in a subprocess. Only the plume update is timed; pompy's
wind update is excluded, including the refit of its interpolating splines, which pompy defers
to the first velocity query after each wind update.

The two sides are timed side by side in time: for each of ``--rounds`` rounds and each count,
ours (a fresh plume in this process) then pompy (a fresh plume in a subprocess of its own, its
imports done before the plume is built), each from the same puffs with the same warm-up; the
fastest round of each side and count is kept, so a slow spell of a shared machine cannot fall on
one side only.

Also measured: a 1 000-point concentration query over 5 000 filaments, and the peak memory of a
100 000-point grid query over 20 000 filaments (in a fresh subprocess, via ``ru_maxrss`` minus
the baseline after setup).

The last line is ``RESULT speedup_vs_pompy_1000=<x> query_ms_1000x5000=<y> query_peak_mb=<z>
speedup_vs_pompy_200=<a> speedup_vs_pompy_5000=<b>`` (speed-ups ``nan`` when pompy could not run).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
VENV = ROOT / ".bench-venv"
LENGTH, HALF_WIDTH, SOURCE_X = 50.0, 10.0, 2.0
SPEED = 1.0
DT = 0.05
COUNTS = (200, 1000, 5000)
SIGMA0, GAMMA, NOISE = 0.1, 0.01, 0.2


#: untimed steps before the timed ones, on both sides
WARMUP = 5
#: seed of the puffs both models start from at every count
PREFILL_SEED = 0


def release_rate(n_live: int) -> float:
    """Puffs/s keeping ``n_live`` puffs in steady state (lifetime = travel time to the edge)."""
    return n_live * SPEED / (LENGTH - SOURCE_X)


def prefill(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` puffs of uniform age along the mean plume: centres ``(n, 2)`` and ``sigma^2``."""
    age = rng.uniform(0.0, (LENGTH - SOURCE_X - 1.0) / SPEED, n)
    pos = np.column_stack([SOURCE_X + SPEED * age, NOISE * np.sqrt(age) * rng.standard_normal(n)])
    pos[:, 1] = np.clip(pos[:, 1], -HALF_WIDTH + 0.01, HALF_WIDTH - 0.01)
    return pos, SIGMA0**2 + GAMMA * age


# ---------------------------------------------------------------------- pompy side
POMPY_SNIPPET = textwrap.dedent(
    """
    import json, sys, time
    import numpy as np
    from pompy import models

    cfg = json.loads(sys.stdin.read())
    L, W, X0, dt = cfg["length"], cfg["half_width"], cfg["source_x"], cfg["dt"]
    out = {}
    for n, rate, steps in cfg["runs"]:
        rs = np.random.RandomState(0)
        region = models.Rectangle(0.0, L, -W, W)
        wind = models.WindModel(region, 21, 21, u_av=cfg["speed"], v_av=0.0,
                                noise_gain=0.0, rng=rs)
        plume = models.PlumeModel(region, (X0, 0.0, 0.0), wind, model_z_disp=False,
                                  centre_rel_diff_scale=cfg["noise"],
                                  puff_init_rad=cfg["sigma0"], puff_spread_rate=cfg["gamma"],
                                  puff_release_rate=rate, init_num_puffs=0,
                                  max_num_puffs=10 * n + 100, rng=rs)
        pos = np.asarray(cfg["prefill"][str(n)]["pos"])
        s2 = np.asarray(cfg["prefill"][str(n)]["s2"])
        plume.puffs = [models.Puff(x, y, 0.0, r) for (x, y), r in zip(pos, s2)]
        for _ in range(cfg["warmup"]):  # untimed, as ours
            wind.update(dt)
            wind.velocity_at_pos(X0, 0.0)
            plume.update(dt)
        total, live = 0.0, 0
        for _ in range(steps):
            wind.update(dt)
            # pompy's wind update only marks its splines stale and the first velocity query
            # refits them: that is wind-update work, so it is done here, before the timing
            wind.velocity_at_pos(X0, 0.0)
            t0 = time.perf_counter()
            plume.update(dt)
            total += time.perf_counter() - t0
            live += len(plume.puffs)
        out[str(n)] = {"step_s": total / steps, "live": live / steps}
    print(json.dumps(out))
    """
)


def ensure_pompy() -> tuple[Path | None, str]:
    """Path of the benchmark venv's python with pompy 0.1.1, or ``None`` and the reason."""
    py = VENV / "bin" / "python"
    check = [str(py), "-c", "import pompy, numpy; assert numpy.__version__ < '2'"]
    if py.exists() and subprocess.run(check, capture_output=True).returncode == 0:
        return py, ""
    try:
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True, capture_output=True)
        subprocess.run(
            [str(py), "-m", "pip", "install", "-q", "numpy<2", "scipy", "pompy==0.1.1"],
            check=True,
            capture_output=True,
            text=True,
        )
    except (subprocess.CalledProcessError, OSError) as exc:
        detail = getattr(exc, "stderr", "") or str(exc)
        return None, f"could not install pompy 0.1.1: {detail.strip().splitlines()[-1:]}"
    if subprocess.run(check, capture_output=True).returncode != 0:
        return None, "pompy installed but not importable"
    return py, ""


def time_pompy(py: Path, steps: dict[int, int]) -> dict[int, dict[str, float]]:
    """pompy's mean plume-update time and live puffs per count in ``steps`` (one subprocess)."""
    pre = {}
    for n in steps:
        # the very puffs build_ours starts from (a generator of its own per count)
        pos, s2 = prefill(n, np.random.default_rng(PREFILL_SEED))
        pre[str(n)] = {"pos": pos.tolist(), "s2": s2.tolist()}
    cfg = {
        "length": LENGTH,
        "half_width": HALF_WIDTH,
        "source_x": SOURCE_X,
        "dt": DT,
        "speed": SPEED,
        "noise": NOISE,
        "sigma0": SIGMA0,
        "gamma": GAMMA,
        "runs": [[n, release_rate(n), steps[n]] for n in steps],
        "warmup": WARMUP,
        "prefill": pre,
    }
    res = subprocess.run(
        [str(py), "-c", POMPY_SNIPPET],
        input=json.dumps(cfg),
        capture_output=True,
        text=True,
        check=True,
    )
    data = json.loads(res.stdout.strip().splitlines()[-1])
    return {int(k): v for k, v in data.items()}


# ---------------------------------------------------------------------- our side
def build_ours(n: int, seed: int = PREFILL_SEED):
    from odorloc.geometry.arena import Arena
    from odorloc.plume import FilamentParams, FilamentPlume, ReplayWind
    from odorloc.plume.replay import Movie, ReplayParams
    from odorloc.plume.sources import Source

    arena = Arena.box((0.0, -HALF_WIDTH), (LENGTH, HALF_WIDTH), resolution=0.5)
    axes = [np.linspace(0.0, LENGTH, 21), np.linspace(-HALF_WIDTH, HALF_WIDTH, 21)]
    field = np.zeros((1, 21, 21, 2))
    field[..., 0] = SPEED
    # A one-frame movie is simply a 21 x 21 gridded wind, interpolated like pompy's.
    movie = Movie(
        times=np.zeros(1),
        frames=[{"model": np.array("none")}],
        wind_axes=axes,
        wind=field,
        arena_lower=arena.lo,
        arena_upper=arena.hi,
        resolution=arena.resolution,
        source_positions=np.array([[SOURCE_X, 0.0]]),
        source_rates=np.array([release_rate(n)]),
    )
    wind = ReplayWind(ReplayParams(), arena, movie=movie)
    params = FilamentParams(
        sigma0=SIGMA0, gamma=GAMMA, noise_std=NOISE, integrator="euler", max_filaments=10 * n + 100
    )
    plume = FilamentPlume(
        params, arena, wind, [Source(position=(SOURCE_X, 0.0), rate=release_rate(n))]
    )
    pos, s2 = prefill(n, np.random.default_rng(seed))
    plume.positions, plume.sigma2, plume.amount = pos, s2, np.ones(n)
    return plume


def time_ours(n: int, steps: int) -> dict[str, float]:
    plume = build_ours(n)
    rng = np.random.default_rng(1)
    for _ in range(WARMUP):
        plume.step(DT, rng)
    total, live = 0.0, 0
    for _ in range(steps):
        t0 = time.perf_counter()
        plume.step(DT, rng)
        total += time.perf_counter() - t0
        live += plume.n_filaments
    return {"step_s": total / steps, "live": live / steps}


def time_query(n_points: int = 1000, n_fil: int = 5000, repeats: int = 20) -> float:
    """Median wall time of a concentration query, milliseconds."""
    plume = build_ours(n_fil)
    rng = np.random.default_rng(2)
    pts = np.column_stack(
        [rng.uniform(0, LENGTH, n_points), rng.uniform(-HALF_WIDTH, HALF_WIDTH, n_points)]
    )
    plume.concentration(pts)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        plume.concentration(pts)
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


MEMORY_SNIPPET = textwrap.dedent(
    """
    import resource, sys, time
    import numpy as np
    sys.path.insert(0, sys.argv[1])
    import plume_speed as ps
    plume = ps.build_ours(20000)
    nx, ny = 500, 200
    gx = np.linspace(0, ps.LENGTH, nx)
    gy = np.linspace(-ps.HALF_WIDTH, ps.HALF_WIDTH, ny)
    pts = np.stack(np.meshgrid(gx, gy, indexing="ij"), -1).reshape(-1, 2)
    plume.concentration(pts[:10])
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    c = plume.concentration(pts)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print((peak - base) / 1024.0, dt, c.shape[0])
    """
)


def query_memory() -> tuple[float, float]:
    """Peak extra resident memory (MB) and time (s) of the 100k x 20k grid query."""
    env = dict(os.environ)
    res = subprocess.run(
        [sys.executable, "-c", MEMORY_SNIPPET, str(Path(__file__).parent)],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    mb, sec, _ = res.stdout.split()
    return float(mb), float(sec)


def ns_per_puff_step(row: dict[str, float]) -> float:
    """Per puff-step, as the live counts of the two models drift apart a little."""
    return 1e9 * row["step_s"] / row["live"]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer timed steps")
    ap.add_argument(
        "--rounds", type=int, default=3, help="alternating rounds per count (fastest kept)"
    )
    args = ap.parse_args(argv)
    steps = {200: 100, 1000: 40, 5000: 10} if not args.quick else {200: 20, 1000: 10, 5000: 3}
    py, why = ensure_pompy()
    # the same untimed and timed steps on both sides, one side right after the other
    ours: dict[int, list[float]] = {n: [] for n in COUNTS}
    theirs: dict[int, list[float]] = {n: [] for n in COUNTS}
    for _ in range(max(args.rounds, 1)):
        for n in COUNTS:
            ours[n].append(ns_per_puff_step(time_ours(n, steps[n])))
            if py is None:
                continue
            try:
                theirs[n].append(ns_per_puff_step(time_pompy(py, {n: steps[n]})[n]))
            except subprocess.CalledProcessError as exc:
                # a comparison with some rounds missing on one side would not be like for like
                py, why = None, f"pompy run failed: {exc.stderr.strip().splitlines()[-1:]}"
                theirs = {k: [] for k in COUNTS}
    print(f"filament plume step, dt = {DT} s, 21x21 wind grid, 2D dispersion")
    print(f"{len(ours[COUNTS[0]])} alternating rounds per count, fastest of each side")
    print(
        f"{'puffs':>7} | {'ours ns/puff/step':>17} | {'pompy ns/puff/step':>18} | {'speed-up':>8}"
    )
    speedups = {}
    for n in COUNTS:
        o = min(ours[n])
        if theirs[n]:
            p = min(theirs[n])
            speedups[n] = p / o
            print(f"{n:>7} | {o:>17.1f} | {p:>18.1f} | {speedups[n]:>7.1f}x")
        else:
            print(f"{n:>7} | {o:>17.1f} | {'n/a':>18} | {'n/a':>8}")
    if why:
        print(f"pompy not timed: {why}")
    q_ms = time_query()
    mem_mb, mem_s = query_memory()
    print(f"concentration query, 1 000 points x 5 000 filaments: {q_ms:.2f} ms (median)")
    print(
        f"grid query, 100 000 points x 20 000 filaments: {mem_s:.2f} s, "
        f"peak extra memory {mem_mb:.0f} MB"
    )
    s200, s1000, s5000 = (speedups.get(n, math.nan) for n in COUNTS)
    print(
        f"RESULT speedup_vs_pompy_1000={s1000:.1f} query_ms_1000x5000={q_ms:.2f} "
        f"query_peak_mb={mem_mb:.0f} speedup_vs_pompy_200={s200:.1f} "
        f"speedup_vs_pompy_5000={s5000:.1f}"
    )


if __name__ == "__main__":
    main()
