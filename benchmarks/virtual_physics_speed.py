"""Virtual-physics speed: the formation controller's time per control step, what replaying a
recorded flow saves, and the wall time of the default reproduction.

Side by side in one run:

- **vp_step_ms**: searcher time (both formations, 12 robots, the ``per-group`` team) per control
  step, measured around ``searcher.act`` over replayed episodes of each rule (CPU time of this
  process, so other jobs on a shared machine do not inflate it; wall time is printed too): the
  largest over the rules of the mean (total time / steps). The median is printed and reported
  too (``vp_step_ms_median``), but understates the cost: the steps in which a group holds
  after declaring are cheap;
- **replay_speedup**: the wall time of one episode with the live Eulerian plume over the same
  episode (same seeds, same result) on the replay of its recorded flow; the recording itself is
  timed separately, since a reproduction pays it once per flow for every rule and start. The
  replay is bit-exact, so the two episodes must agree: the same positions bit for bit and the
  same outcome (``same_rows``);
- **reproduction_min**: wall minutes of ``odorloc reproduce virtual-physics`` with its default
  episode count on 2 workers, in a temporary folder (``--skip-reproduction`` leaves it out). The
  CPU minutes of its episodes and flow recordings, divided by the 2 workers, are printed beside
  it: what the run takes when the 2 cores are not shared.

    .venv/bin/python benchmarks/virtual_physics_speed.py [--skip-reproduction]
        [--reproduction-out DIR]

The last line is machine-readable::

    RESULT vp_step_ms=<x> reproduction_min=<y> replay_speedup=<z> same_rows=<yes|no>
           vp_step_ms_median=<m>
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import Episode, run_episode
from odorloc.engine.replay import on_replay, record_flow
from odorloc.scenarios import get_scenario

SCENARIO = "virtual-physics-two-groups"
RULES = ("chemotaxis", "anemotaxis", "fluxotaxis")
#: metrics in which the live and the replayed episode must agree (besides every position)
OUTCOME = ("termination", "success", "steps")


def _scenario(rule: str, start: str, frequency: int, limit: float):
    sc = get_scenario(SCENARIO).with_start_set(start)
    return sc.with_overrides(
        {
            "searcher.member": {"type": "virtual-physics", "rule": rule},
            "frequency": frequency,
            "limits.time": limit,
        }
    )


def searcher_step_times(movie, sc, seeds) -> tuple[list[float], list[float]]:
    """CPU and wall ms of ``searcher.act`` for every control step of one replayed episode."""
    sc_r, built = on_replay(sc, movie)
    ep = Episode(sc_r, built=built, record=False)
    obs = ep.reset(*seeds)
    s = built.searcher
    s.reset(ep.context, ep.agent_rng)
    cpu, wall = [], []
    while not ep.done:
        c0, w0 = time.process_time(), time.perf_counter()
        action = s.act(obs, ep.agent_rng)
        cpu.append(1e3 * (time.process_time() - c0))
        wall.append(1e3 * (time.perf_counter() - w0))
        obs = ep.step(action, s).observations
    return cpu, wall


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-reproduction", action="store_true")
    ap.add_argument("--limit", type=float, default=400.0, help="episode time limit, s")
    ap.add_argument(
        "--reproduction-out",
        type=Path,
        default=None,
        help="keep the reproduction's output here (a new folder; default a temporary one)",
    )
    args = ap.parse_args(argv)
    print(f"cores: {os.cpu_count()}, load average: {os.getloadavg()[0]:.1f}")

    # one flow (treble frequency) for the searcher timings and the replay comparison
    sc = _scenario("fluxotaxis", "P1", 3, args.limit)
    seeds = episode_seeds(2024, "bench-vp", 0)
    c0, w0 = time.process_time(), time.perf_counter()
    movie = record_flow(sc, seeds[0])
    rec_wall, rec_cpu = time.perf_counter() - w0, time.process_time() - c0

    print(f"\nsearcher.act per control step (12 robots, two formations), {args.limit:.0f} s limit")
    print(
        f"{'rule':<12} {'steps':>6} {'CPU ms mean':>12} {'CPU ms median':>14} "
        f"{'wall ms mean':>13} {'wall ms median':>15}"
    )
    means, medians = [], []
    for rule in RULES:
        cpu, wall = searcher_step_times(movie, _scenario(rule, "P1", 3, args.limit), seeds)
        means.append(statistics.fmean(cpu))
        medians.append(statistics.median(cpu))
        print(
            f"{rule:<12} {len(cpu):6d} {means[-1]:12.3f} {medians[-1]:14.3f} "
            f"{statistics.fmean(wall):13.3f} {statistics.median(wall):15.3f}"
        )
    # the mean is what the steps cost in total; the cheap holding steps pull the median down
    vp_step = max(means)
    vp_step_median = max(medians)
    print(f"largest over the rules (CPU): mean {vp_step:.3f} ms, median {vp_step_median:.3f} ms")

    # the same episode live and replayed, side by side (alternating, best of 2 each)
    live_w, live_c, rep_w, rep_c = [], [], [], []
    diff = 0.0
    same = True
    for _ in range(2):
        c0, w0 = time.process_time(), time.perf_counter()
        live = run_episode(sc, *seeds, record=True)
        live_w.append(time.perf_counter() - w0)
        live_c.append(time.process_time() - c0)
        sc_r, built = on_replay(sc, movie)
        c0, w0 = time.process_time(), time.perf_counter()
        rep = run_episode(sc_r, *seeds, built=built, record=True)
        rep_w.append(time.perf_counter() - w0)
        rep_c.append(time.process_time() - c0)
        a, b = live.recording.positions, rep.recording.positions
        k = min(len(a), len(b))
        gap = float(np.abs(a[:k] - b[:k]).max()) if len(a) == len(b) else math.inf
        diff = max(diff, gap)
        same &= gap == 0.0 and all(live.metrics[m] == rep.metrics[m] for m in OUTCOME)
    speedup = min(live_w) / min(rep_w)
    steps = live.metrics["steps"]
    print(f"\none episode (fluxotaxis, P1, treble), {steps} control steps")
    print(f"{'':<26} {'wall s':>8} {'CPU s':>8}")
    print(f"{'live Eulerian plume':<26} {min(live_w):8.2f} {min(live_c):8.2f}")
    print(f"{'replayed flow':<26} {min(rep_w):8.2f} {min(rep_c):8.2f}")
    print(f"{'recording the flow (once)':<26} {rec_wall:8.2f} {rec_cpu:8.2f}")
    print(
        f"replay speed-up {speedup:.1f}x (CPU {min(live_c) / min(rep_c):.1f}x); "
        f"largest position difference live vs replayed {diff:.2g} m; "
        f"same episode: {'yes' if same else 'NO'}"
    )

    repro_min = math.nan
    if not args.skip_reproduction:
        from odorloc.experiments.reproduction import get

        r = get("virtual-physics")
        keep = args.reproduction_out
        if keep is not None and keep.exists() and any(keep.iterdir()):
            ap.error(f"--reproduction-out {keep} is not empty (a resumed run is not a timing)")
        with tempfile.TemporaryDirectory() as d:
            w0 = time.perf_counter()
            out = r.run(keep or Path(d), workers=2, progress=False)
            repro_min = (time.perf_counter() - w0) / 60.0
            df = out.results
        # one flow recording per sweep, frequency and episode
        groups = df.drop_duplicates(["sweep", "scenario.frequency", "episode"])
        cpu = float(df["cpu_time"].sum() + groups["movie_cpu_time"].sum())
        print(
            f"\ndefault reproduction ({r.default_episodes} episodes per cell, {len(df)} episodes, "
            f"2 workers): {repro_min:.1f} min wall; {cpu / 60:.1f} CPU min in episodes and flow "
            f"recordings = {cpu / 120:.1f} min on 2 unshared cores"
        )
    print(
        f"RESULT vp_step_ms={vp_step:.3f} reproduction_min={repro_min:.1f} "
        f"replay_speedup={speedup:.1f} same_rows={'yes' if same else 'no'} "
        f"vp_step_ms_median={vp_step_median:.3f}"
    )


if __name__ == "__main__":
    main()
