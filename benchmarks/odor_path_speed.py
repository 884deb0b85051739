"""Speed of the dynamic-window odor-path map against the full-grid computation, and of one
Dempster-Shafer grid update.

Setting of the odor-path paper (section V): 10 m x 10 m, a = 5 cm, M = 40 000 cells, records
every 0.5 s, t_thr = 10 s (20 sub-windows). The wind record meanders in speed (0.5-1 m/s) and
direction with sensor noise of 0.05 m/s per axis (velocity variances of a few 1e-3 m^2/s^2, as in
the paper's experiments); a noisier record (0.15 m/s) is timed as well.

Each online step (store one record, compute the map) is timed by both methods on the same
records, and the maps are checked equal at every step. Two full-grid references: ``full``
(:meth:`~odorloc.inference.odor_path.OdorPathEstimator.path_map_full`) evaluates the separable
Gaussian of eq. 11 as a product of one row and one column of exponentials, as a good dense
implementation does; ``cell`` evaluates eq. 11 cell by cell as printed, one exponential per
cell and window, the computation the paper's dynamic window avoids. Both speed-ups are like for
like: our map made dense (``+dense``), though the D-S update consumes the patch itself
(``window ms``). With numba installed, the compiled and the NumPy maps of the same records are
also compared at every step, and a third full grid is timed: the separable full grid compiled
with numba, as fast as we can make it (the implementation gain set apart from the dynamic
window's). It still evaluates every cell for every window, in one pass per window that masks
(eq. 12), normalises by one reciprocal and keeps the maximum (eq. 17); the window's sum comes
from each row's run of cells inside the ellipse and running sums of the column factors, in
``O(nx + ny)``. The two-pass form timed before (the cells and their sum, then the maximum) is
shown for information. Prints a table of medians and one final line
``RESULT odor_path_ms=<x> speedup_vs_full=<y> speedup_vs_per_cell=<w> ds_update_ms=<z>
maps_bit_equal=<yes|no|n/a> speedup_vs_full_compiled=<v> speedup_vs_full_two_pass=<u>``
(``nan`` without numba).
``maps_bit_equal`` keeps its name from when the compiled map was the NumPy batch's to the bit;
it now says whether the compiled (fused) and the NumPy maps agree at every step: the same cells,
and every value within 1e-12 relative (:func:`maps_agree`).

Run: ``python benchmarks/odor_path_speed.py [--instances 40]``
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from odorloc.inference.evidence.dempster_shafer import DSGrid, DSParams
from odorloc.inference.odor_path import HAVE_NUMBA, CellGrid, OdorPathEstimator, OdorPathParams
from odorloc.planning.uncertainty_route import UncertaintyRouteParams, UncertaintyRoutePlanner

DT = 0.5

MapEntry = tuple[int, int, np.ndarray]


def wind_record(rng: np.random.Generator, n: int, noise: float) -> np.ndarray:
    """``(n, 2)`` wind, m/s: slow speed/direction meander plus per-record sensor noise."""
    t = DT * np.arange(n)
    phase = rng.uniform(0, 2 * np.pi, 2)
    speed = 0.75 + 0.25 * np.sin(2 * np.pi * t / 40.0 + phase[0])
    theta = rng.uniform(-np.pi, np.pi) + 0.25 * np.sin(2 * np.pi * t / 25.0 + phase[1])
    u = np.column_stack([speed * np.cos(theta), speed * np.sin(theta)])
    return u + rng.normal(0.0, noise, (n, 2))


def median_ms(samples: list[float]) -> float:
    return float(np.median(samples)) * 1e3


def maps_agree(a: list[MapEntry], b: list[MapEntry], rtol: float = 1e-12) -> bool:
    """Whether two runs' maps agree at every step: the same cells (non-zero values) and every
    value within ``rtol`` relative. A map is ``(ix0, iy0, values)``: its box in the grid."""
    if len(a) != len(b):
        return False
    for (ax, ay, av), (bx, by, bv) in zip(a, b, strict=True):
        x0, y0 = min(ax, bx), min(ay, by)
        x1 = max(ax + av.shape[0], bx + bv.shape[0])
        y1 = max(ay + av.shape[1], by + bv.shape[1])
        da = np.zeros((max(x1 - x0, 0), max(y1 - y0, 0)))
        db = np.zeros_like(da)
        da[ax - x0 : ax - x0 + av.shape[0], ay - y0 : ay - y0 + av.shape[1]] = av
        db[bx - x0 : bx - x0 + bv.shape[0], by - y0 : by - y0 + bv.shape[1]] = bv
        if not np.array_equal(da > 0, db > 0):
            return False
        if np.any(np.abs(da - db) > rtol * np.abs(da)):
            return False
    return True


def per_cell_map(est: OdorPathEstimator) -> np.ndarray:
    """The full-grid map with eq. 11 evaluated cell by cell as printed (one exponential per cell
    and window): the computation the paper's dynamic window is designed to avoid (point
    kernel, normalised windows, as the benchmark's estimators)."""
    w = est.window_arrays()
    out = np.zeros(est.grid.shape)
    a = est.grid.cell_size
    xc, yc = est.grid.x_centers(), est.grid.y_centers()
    for r in range(len(w.t_r)):
        var, k = w.var[r], w.k[r]
        if k < 0.0:
            continue
        dx = xc - w.center[r, 0]
        dy = yc - w.center[r, 1]
        q = (dx * dx / var[0])[:, None] + (dy * dy / var[1])[None, :]
        s = a * a / (2.0 * np.pi * np.sqrt(var[0] * var[1])) * np.exp(-0.5 * q)
        s = np.where(q <= 2.0 * k, s, 0.0)  # eq. (12)
        total = s.sum()
        if total > 0:
            np.maximum(out, s / total, out=out)
    return out


def _window_into(
    xc: np.ndarray, yc: np.ndarray, cx: float, cy: float, vx: float, vy: float, lim: float,
    coef: float, s: np.ndarray,
) -> float:  # fmt: skip
    """One window of eq. 11-12 on every cell into ``s`` ``(nx, ny)``; returns its sum."""
    fy = np.empty(yc.size)
    qy = np.empty(yc.size)
    for j in range(yc.size):
        d = yc[j] - cy
        qy[j] = d * d / vy
        fy[j] = np.exp(-0.5 * qy[j])
    total = 0.0
    for i in range(xc.size):
        d = xc[i] - cx
        qx = d * d / vx
        f = coef * np.exp(-0.5 * qx)
        row = s[i]
        for j in range(yc.size):
            v = f * fy[j] if qx + qy[j] <= lim else 0.0
            row[j] = v
            total += v
    return total


def _compiled(fn: Any, **options: Any) -> Any:
    """``fn`` compiled with numba, without its cache on disk (``fn`` itself without numba).

    This script runs as ``__main__`` and is imported by the tests under another name; a cached
    kernel that calls another one looks that one up in the module it was first compiled in.
    The references compile in a second or two, counted in the warm-up."""
    if not HAVE_NUMBA:
        return fn
    import numba

    return numba.njit(**options)(fn)


# a reference, not the tested maps: its sums may run in any order (vectorised)
_window_into_fast = _compiled(_window_into, fastmath={"reassoc", "nsz"})


def _full_grid(
    xc: np.ndarray, yc: np.ndarray, center: np.ndarray, var: np.ndarray, k: np.ndarray, a: float
) -> np.ndarray:
    """The separable full grid (point kernel, normalised windows) in one pass over the cells
    per window: every cell of every window is evaluated, masked by eq. 12 and kept by eq. 17's
    maximum without a branch. The window's sum needs no pass of its own: each row's cells
    inside the ellipse are one run of columns, and the row's share is its factor times a
    difference of running sums of the column factors."""
    nx, ny = xc.size, yc.size
    out = np.zeros((nx, ny))
    qx = np.empty(nx)
    fx = np.empty(nx)
    qy = np.empty(ny)
    fy = np.empty(ny)
    cum = np.empty(ny + 1)
    for r in range(k.size):
        if k[r] < 0.0:
            continue
        lim = 2.0 * k[r]
        vx, vy = var[r, 0], var[r, 1]
        coef = a * a / (2.0 * np.pi * np.sqrt(vx * vy))
        for i in range(nx):
            d = xc[i] - center[r, 0]
            qx[i] = d * d / vx
            fx[i] = coef * np.exp(-0.5 * qx[i])
        s = 0.0
        cum[0] = 0.0
        for j in range(ny):
            d = yc[j] - center[r, 1]
            qy[j] = d * d / vy
            fy[j] = np.exp(-0.5 * qy[j])
            s += fy[j]
            cum[j + 1] = s
        total = _window_sum_fast(qx, fx, qy, cum, lim)
        if not total > 0.0:
            continue
        inv = 1.0 / total
        for i in range(nx):
            f = fx[i] * inv
            qi = qx[i]
            o = out[i]
            for j in range(ny):
                v = f * fy[j] if qi + qy[j] <= lim else 0.0
                old = o[j]
                o[j] = v if v > old else old
    return out


def _window_sum(
    qx: np.ndarray, fx: np.ndarray, qy: np.ndarray, cum: np.ndarray, lim: float
) -> float:
    """Sum of ``fx[i] fy[j]`` over the cells with ``qx[i] + qy[j] <= lim`` (eq. 12), in
    ``O(nx + ny)``; ``cum`` ``(ny + 1,)`` holds the running sums of ``fy``.

    ``qx`` and ``qy`` fall towards their smallest element and rise after it (squared
    distances, and rounding keeps that order), so row ``i``'s cells are the columns
    ``[lo, hi)`` around ``qy``'s smallest, and the run only narrows from the row of ``qx``'s
    smallest outwards: two pointers that move inwards, each side of that row once."""
    nx, ny = qx.size, qy.size
    im = int(np.argmin(qx))
    jm = int(np.argmin(qy))
    total = 0.0
    for first, stop, step in ((im, nx, 1), (im - 1, -1, -1)):
        lo, hi = 0, ny
        for i in range(first, stop, step):
            qi = qx[i]
            if not qi + qy[jm] <= lim:
                break  # this row has no cell, nor has any further out
            while not qi + qy[lo] <= lim:
                lo += 1
            while not qi + qy[hi - 1] <= lim:
                hi -= 1
            total += fx[i] * (cum[hi] - cum[lo])
    return total


def _full_grid_two_pass(
    xc: np.ndarray, yc: np.ndarray, center: np.ndarray, var: np.ndarray, k: np.ndarray, a: float
) -> np.ndarray:
    """The separable full grid in two passes per window: its cells and their sum, then the
    normalised values (one reciprocal) and the maximum; the compiled reference as this
    benchmark timed it before (for information)."""
    out = np.zeros((xc.size, yc.size))
    s = np.empty((xc.size, yc.size))
    for r in range(k.size):
        if k[r] < 0.0:
            continue
        coef = a * a / (2.0 * np.pi * np.sqrt(var[r, 0] * var[r, 1]))
        total = _window_into_fast(
            xc, yc, center[r, 0], center[r, 1], var[r, 0], var[r, 1], 2.0 * k[r], coef, s
        )
        if not total > 0.0:
            continue
        inv = 1.0 / total
        for i in range(xc.size):
            row = s[i]
            o = out[i]
            for j in range(yc.size):
                v = row[j] * inv
                old = o[j]
                o[j] = v if v > old else old
    return out


_window_sum_fast = _compiled(_window_sum)
_full_grid_fast = _compiled(_full_grid)
_full_grid_two_pass_fast = _compiled(_full_grid_two_pass)


def time_odor_path(
    noise: float, instances: int, backend: str, seed: int, compiled_full: bool = False
) -> dict[str, float]:
    """Median times of one online step (store a record, compute the map) by both methods.

    Two estimators receive the same long record; after the first 21 records every further
    record is one timed step, so each step sees a new wind history and robot position (a third
    estimator repeats our steps untimed to keep the maps, see the comment below). With
    ``compiled_full`` the compiled full grids are timed too (``nb_ms``, and ``nb_two_ms`` for
    the one in two passes per window; NaN otherwise). ``maps`` holds our map at every step.
    """
    rng = np.random.default_rng(seed)
    params = OdorPathParams(cell_size=0.05, t_thr=10.0, backend=backend)
    fast = OdorPathEstimator(params, (0, 0), (10, 10))
    full = OdorPathEstimator(params, (0, 0), (10, 10))
    n = 21 + instances
    winds = wind_record(rng, n, noise)
    # robot placed so the 10 s path (up to ~10 m) mostly stays in the map
    pos = np.array([5.0, 5.0]) + rng.uniform(-2, 2, (n, 2))
    for i in range(21):
        fast.update(i * DT, pos[i], winds[i], 1.0)
        full.update(i * DT, pos[i], winds[i], 1.0)
    # Each method runs its own loop so that neither pays for the other's cache traffic, and
    # the timed loop keeps nothing: a map kept there would take fresh memory at every step
    # (page faults: a third of a step's time on this machine), which the full grids' loop,
    # keeping none of its maps, does not pay.
    fast_t, fast_dense_t = [], []
    for i in range(21, n):
        t0 = time.perf_counter()
        fast.update(i * DT, pos[i], winds[i], 1.0)
        patch = fast.path_patch()
        t1 = time.perf_counter()
        patch.to_dense()
        t2 = time.perf_counter()
        fast_t.append(t1 - t0)
        fast_dense_t.append(t2 - t0)
    # the same steps again, untimed, for the maps compared (the same records: the same maps)
    again = OdorPathEstimator(params, (0, 0), (10, 10))
    patches, cells = [], []
    for i in range(n):
        again.update(i * DT, pos[i], winds[i], 1.0)
        if i >= 21:
            patches.append(again.path_patch())
            cells.append(sum(w.n_cells for w in again.windows()))
    full_t, cell_t, nb_t, two_t, max_err = [], [], [], [], 0.0
    xc, yc = full.grid.x_centers(), full.grid.y_centers()
    for i, patch in zip(range(21, n), patches, strict=True):
        t0 = time.perf_counter()
        full.update(i * DT, pos[i], winds[i], 1.0)
        t1 = time.perf_counter()
        ref = full.path_map_full()
        t2 = time.perf_counter()
        by_cell = per_cell_map(full)
        t3 = time.perf_counter()
        full_t.append(t2 - t0)
        cell_t.append((t1 - t0) + (t3 - t2))  # the same update, then the per-cell map
        max_err = max(max_err, float(np.abs(by_cell - ref).max()))
        if compiled_full:
            # both compiled full grids start from the same windows, computed once (timed)
            t4 = time.perf_counter()
            w = full.window_arrays()
            t5 = time.perf_counter()
            compiled = _full_grid_fast(xc, yc, w.center, w.var, w.k, full.grid.cell_size)
            t6 = time.perf_counter()
            before = _full_grid_two_pass_fast(xc, yc, w.center, w.var, w.k, full.grid.cell_size)
            t7 = time.perf_counter()
            nb_t.append((t1 - t0) + (t6 - t4))
            two_t.append((t1 - t0) + (t5 - t4) + (t7 - t6))
            max_err = max(max_err, float(np.abs(compiled - ref).max()))
            max_err = max(max_err, float(np.abs(before - ref).max()))
        dense = patch.to_dense()
        if not np.array_equal(dense > 0, ref > 0):
            raise AssertionError("dynamic-window map and full-grid map differ in support")
        max_err = max(max_err, float(np.abs(dense - ref).max()))
    if max_err > 1e-12:
        raise AssertionError(f"dynamic-window map differs from the full grid by {max_err:g}")
    return {
        "fast_ms": median_ms(fast_t),
        "fast_dense_ms": median_ms(fast_dense_t),
        "full_ms": median_ms(full_t),
        "cell_ms": median_ms(cell_t),
        "nb_ms": median_ms(nb_t) if nb_t else float("nan"),
        "nb_two_ms": median_ms(two_t) if two_t else float("nan"),
        "cells": float(np.median(cells)),
        "max_err": max_err,
        "maps": [(p.ix0, p.iy0, p.values) for p in patches],
    }


def time_ds(grid: CellGrid, repeats: int, seed: int) -> dict[str, float]:
    """Median times of one D-S update with a dense map and with a patch, and of one plan."""
    rng = np.random.default_rng(seed)
    lo = np.asarray(grid.lower)
    hi = np.asarray(grid.upper)
    est = OdorPathEstimator(OdorPathParams(cell_size=grid.cell_size), tuple(lo), tuple(hi))
    winds = wind_record(rng, 21, 0.05)
    pos = lo + 0.7 * (hi - lo)
    for i in range(21):
        est.update(i * DT, pos, winds[i], 1.0)
    patch = est.path_patch()
    dense = patch.to_dense()
    ds = DSGrid(DSParams(), est.grid)
    planner = UncertaintyRoutePlanner(UncertaintyRouteParams(step_range=0.25))
    dense_t, patch_t, plan_t = [], [], []
    for k in range(repeats):
        det = bool(k % 3 == 0)
        t0 = time.perf_counter()
        ds.update(dense, det)
        t1 = time.perf_counter()
        ds.update(patch, det)
        t2 = time.perf_counter()
        planner.route(ds, patch, pos, rng)
        t3 = time.perf_counter()
        dense_t.append(t1 - t0)
        patch_t.append(t2 - t1)
        plan_t.append(t3 - t2)
    return {
        "dense_ms": median_ms(dense_t),
        "patch_ms": median_ms(patch_t),
        "plan_ms": median_ms(plan_t),
        "cells": float(grid.n_cells),
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=40, help="timed online steps per setting")
    ap.add_argument("--seed", type=int, default=2024)
    args = ap.parse_args(argv)

    # compile (numba) and warm up outside the timings
    t0 = time.perf_counter()
    time_odor_path(0.05, 2, "auto", args.seed + 99, compiled_full=HAVE_NUMBA)
    warm = time.perf_counter() - t0

    backends = ["auto", "numpy"] if HAVE_NUMBA else ["numpy"]
    rows = []
    for noise in (0.05, 0.15):
        for backend in backends:
            nb = HAVE_NUMBA and backend == "auto"
            r = time_odor_path(noise, args.instances, backend, args.seed, compiled_full=nb)
            name = "numba" if backend == "auto" and HAVE_NUMBA else "numpy"
            rows.append((noise, name, r))

    print("Odor-path map update, M = 40 000 (10 m x 10 m, a = 5 cm), 20 sub-windows")
    print(f"(medians over {args.instances} online steps; warm-up incl. compile {warm:.2f} s)")
    head = (
        f"{'noise m/s':>9} {'kernel':>7} {'sum|DW|':>8} {'window ms':>10} "
        f"{'+dense ms':>10} {'full ms':>9} {'cell ms':>9} {'vs full':>8} {'vs cell':>8} "
        f"{'max |diff|':>11}"
    )
    print(head)
    print("-" * len(head))
    for noise, name, r in rows:
        print(
            f"{noise:>9.2f} {name:>7} {r['cells']:>8.0f} {r['fast_ms']:>10.3f} "
            f"{r['fast_dense_ms']:>10.3f} {r['full_ms']:>9.2f} {r['cell_ms']:>9.2f} "
            f"{r['full_ms'] / r['fast_dense_ms']:>7.0f}x "
            f"{r['cell_ms'] / r['fast_dense_ms']:>7.0f}x "
            f"{r['max_err']:>11.1e}"
        )

    if HAVE_NUMBA:
        print()
        print("The separable full grid compiled with numba: one pass over the cells per window")
        print("(its sum from row runs), and two passes (cells and sum, then the maximum) as")
        print("timed before")
        head = (
            f"{'noise m/s':>9} {'full nb ms':>11} {'ours +dense':>12} {'ratio':>7} "
            f"{'2-pass ms':>10} {'ratio':>7}"
        )
        print(head)
        print("-" * len(head))
        for noise, name, r in rows:
            if name == "numba":
                ratio = r["nb_ms"] / r["fast_dense_ms"]
                two = r["nb_two_ms"] / r["fast_dense_ms"]
                print(
                    f"{noise:>9.2f} {r['nb_ms']:>11.3f} {r['fast_dense_ms']:>12.3f} {ratio:>6.1f}x "
                    f"{r['nb_two_ms']:>10.3f} {two:>6.1f}x"
                )
        print()

    # the same records through both kernels (time_odor_path's seed does not depend on them)
    bit_equal = "n/a"
    if HAVE_NUMBA:
        maps = {(noise, name): r["maps"] for noise, name, r in rows}
        same = [maps_agree(maps[noise, "numba"], maps[noise, "numpy"]) for noise in (0.05, 0.15)]
        bit_equal = "yes" if all(same) else "no"
        print(
            "compiled and NumPy maps agree at every step (same cells, within 1e-12 relative): "
            f"{bit_equal}"
        )
    else:
        print("compiled and NumPy maps not compared (numba is not installed)")

    print()
    print("Dempster-Shafer grid update (eqs. 1-4) and one route plan (eq. 7)")
    head = f"{'grid':>34} {'cells':>7} {'dense ms':>9} {'patch ms':>9} {'plan ms':>8}"
    print(head)
    print("-" * len(head))
    ds_rows = [
        ("odor-path map 10 x 10 m, a = 5 cm", CellGrid((0.0, 0.0), 0.05, (200, 200))),
        ("D-S search area 14 x 20 m, a = 10 cm", CellGrid((18.7, 40.3), 0.1, (140, 200))),
    ]
    ds_results = []
    for label, grid in ds_rows:
        d = time_ds(grid, 50, args.seed)
        ds_results.append(d)
        print(
            f"{label:>34} {d['cells']:>7.0f} {d['dense_ms']:>9.3f} "
            f"{d['patch_ms']:>9.3f} {d['plan_ms']:>8.3f}"
        )

    main_row = rows[0][2]
    # the full grid as fast as we can make it (compiled): the like-for-like bound of the
    # dynamic window's own gain
    nb_full = main_row.get("nb_ms", float("nan"))
    nb_two = main_row.get("nb_two_ms", float("nan"))
    print()
    print(
        f"RESULT odor_path_ms={main_row['fast_ms']:.3f} "
        f"speedup_vs_full={main_row['full_ms'] / main_row['fast_dense_ms']:.1f} "
        f"speedup_vs_per_cell={main_row['cell_ms'] / main_row['fast_dense_ms']:.1f} "
        f"ds_update_ms={ds_results[0]['dense_ms']:.3f} maps_bit_equal={bit_equal} "
        f"speedup_vs_full_compiled={nb_full / main_row['fast_dense_ms']:.1f} "
        f"speedup_vs_full_two_pass={nb_two / main_row['fast_dense_ms']:.1f}"
    )


if __name__ == "__main__":
    main()
