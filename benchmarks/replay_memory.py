"""Peak memory of reading long logs: a 10 000-frame GADEN simulation and a 10 000-period bag.

Both readers stream: a GADEN replay decodes the frame it shows (one at a time), a bag log yields
one observation per period. Side by side in one run: the peak Python/NumPy allocation while
playing every frame (tracemalloc) against the size of the whole log decoded at once, an
estimate computed as frames x filaments x record size plus the wind grid (``gaden_whole_mb_est``;
it is not allocated). The bag part needs the ``ros`` extra (rosbags); without it the bag is
skipped (``bag_peak_mb=nan``).

The last line is ``RESULT gaden_frames=<n> gaden_peak_mb=<x> gaden_whole_mb_est=<y>
bag_periods=<n> bag_peak_mb=<z>``.

    .venv/bin/python benchmarks/replay_memory.py [--frames 10000] [--filaments 500]
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from odorloc.geometry.arena import Arena
from odorloc.replay.gaden import FILAMENT_DTYPE, GadenParams, GadenPlume, GadenWind, GadenWriter


class _Uniform:
    def velocity(self, p: np.ndarray) -> np.ndarray:
        return np.tile([0.5, 0.0, 0.0], (len(p), 1))


def gaden(folder: Path, frames: int, filaments: int) -> dict[str, float]:
    arena = Arena((0.0, 0.0, 0.0), (10.0, 6.0, 3.0), 0.1)
    w = GadenWriter(folder, arena, (1.0, 3.0, 1.5), amount=1.0)
    wi = w.write_wind(_Uniform())
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    for _ in range(frames):
        pos = rng.uniform([0.5, 0.5, 0.5], [9.5, 5.5, 2.5], (filaments, 3))
        w.write_frame(pos, rng.uniform(0.05, 0.3, filaments), wi)
    t_write = time.perf_counter() - t0
    disk = sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
    params = GadenParams(path=str(folder), occupancy=str(folder / "OccupancyGrid3D.csv"))
    tracemalloc.start()
    t0 = time.perf_counter()
    wind = GadenWind(params, arena)
    plume = GadenPlume(params, arena, wind)
    plume.reset(np.random.default_rng(0))
    q = np.array([[5.0, 3.0, 1.5], [2.0, 3.0, 1.5]])
    total = 0.0
    for _ in range(frames):
        total += float(plume.concentration(q).sum()) + float(wind.velocity(q).sum())
        plume.step(0.5, np.random.default_rng(0))
    t_play = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    whole = frames * filaments * FILAMENT_DTYPE.itemsize + wind.sims[0].wind(0).nbytes
    return {"write_s": t_write, "play_s": t_play, "disk_mb": disk / 1e6,
            "whole_mb_est": whole / 1e6, "peak_mb": peak / 1e6}  # fmt: skip


def bag(folder: Path, periods: int) -> dict[str, float]:
    from odorloc.engine.recorder import Recording
    from odorloc.replay.bag import BagLog, write_bag

    t = np.arange(periods) * 0.5
    ang = np.linspace(0, 20 * np.pi, periods)
    pos = np.column_stack([5 + 3 * np.cos(ang), 3 + 2 * np.sin(ang)])[:, None, :]
    rec = Recording(
        t=t, positions=pos, gas=np.abs(np.sin(ang))[:, None],
        detection=np.zeros((periods, 1), bool),
        wind=np.tile([0.5, 0.0], (periods, 1))[:, None, :], diagnostics={}, beliefs=[],
        plume_t=np.zeros(0), plume_frames=np.zeros((0, 1, 1)), plume_extent=np.zeros(4),
        sources=np.zeros((0, 2)), declared=np.zeros((0, 2)), occupancy=None,
        arena_bounds=np.array([[0, 0], [10, 6]]),
    )  # fmt: skip
    mapping = {"gas": {"topic": "/gas", "threshold": 0.5}, "anemometer": {"topic": "/wind"},
               "pose": {"topic": "/pose"}}  # fmt: skip
    path = folder / "log"
    write_bag(path, rec, mapping, gas_rate=3)
    disk = sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
    tracemalloc.start()
    t0 = time.perf_counter()
    n = sum(1 for _ in BagLog(path, mapping).observations())
    t_read = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert n == periods, (n, periods)
    return {"read_s": t_read, "disk_mb": disk / 1e6, "peak_mb": peak / 1e6, "messages": 5 * periods}


def have_rosbags() -> bool:
    """Whether the bag reader's extra (rosbags) can be imported."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        return False
    return True


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--filaments", type=int, default=500)
    args = ap.parse_args(argv)
    # asked before the long GADEN part, so a missing extra does not end the run in a traceback
    with_bag = have_rosbags()
    if not with_bag:
        print(
            "bag: skipped, rosbags is not installed (pip install 'odorloc[ros]')",
            file=sys.stderr,
        )
    tmp = Path(tempfile.mkdtemp(prefix="odorloc-replay-mem-"))
    try:
        g = gaden(tmp / "gaden", args.frames, args.filaments)
        nan = math.nan
        b = bag(tmp, args.frames) if with_bag else {"read_s": nan, "disk_mb": nan, "peak_mb": nan}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"GADEN log: {args.frames} frames x {args.filaments} filaments, "
          f"{g['disk_mb']:.0f} MB on disk (written in {g['write_s']:.0f} s)")  # fmt: skip
    # computed from the sizes (frames x filaments x record size + the wind grid), not allocated
    print(f"  all frames decoded at once, estimated    {g['whole_mb_est']:8.1f} MB "
          "(frames x filaments x record size)")  # fmt: skip
    print(f"  peak allocation while playing them all   {g['peak_mb']:8.1f} MB "
          f"({g['play_s']:.0f} s, 2 concentration and wind queries per frame)")  # fmt: skip
    if with_bag:
        print(
            f"bag: {args.frames} periods ({b['messages']} messages), {b['disk_mb']:.1f} MB on disk"
        )
        print(
            f"  peak allocation while streaming it       {b['peak_mb']:8.1f} MB "
            f"({b['read_s']:.0f} s)"
        )
    else:
        print("bag: not measured (rosbags is not installed)")
    print("(timings on a shared machine)")
    print(
        f"RESULT gaden_frames={args.frames} gaden_peak_mb={g['peak_mb']:.1f} "
        f"gaden_whole_mb_est={g['whole_mb_est']:.1f} bag_periods={args.frames} "
        f"bag_peak_mb={b['peak_mb']:.1f}"
    )


if __name__ == "__main__":
    main()
