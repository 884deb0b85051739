"""The compiled loops of the dynamic-window odor-path map (odor-path paper, eqs. 10-17).

:func:`dw_kernel` is the loop form of the estimator's batched NumPy pass plus the maximum over
windows; :func:`window_kernel` and :func:`axis_kernel` compute the sub-windows and the axis terms
as the NumPy code does. The estimator's map runs them as three calls on arrays it allocates once
(:func:`window_pass`, :func:`axis_pass`, :func:`dw_pass`), with NumPy's logarithm and one NumPy
exponential between them; :func:`paint` writes a patch into a reused dense map. They are compiled
with numba when it is installed (:data:`HAVE_NUMBA`). The NumPy batch of
:class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator` is the reference; both paths
use NumPy's exponentials and logarithms and give the same patch to the bit, so the same seed
gives the same D-S episode with or without numba.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from odorloc.core.jit import HAVE_NUMBA, jit

__all__ = [
    "HAVE_NUMBA",
    "axis_boxes",
    "axis_fill",
    "axis_kernel",
    "axis_kernel_fast",
    "axis_pass",
    "axis_pass_fast",
    "dw_kernel",
    "dw_kernel_fast",
    "dw_pass",
    "dw_pass_fast",
    "paint",
    "paint_fast",
    "window_fill",
    "window_kernel",
    "window_kernel_fast",
    "window_pass",
    "window_pass_fast",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def window_fill(
    tt: FloatArray,
    ww: FloatArray,
    pp: FloatArray,
    limit: float,
    c: int,
    oldest: int,
    dt0: float,
    interval: bool,
    snap: bool,
    x0: float,
    y0: float,
    a: float,
    fixed: bool,
    fixed_var: FloatArray,
    min_var: float,
    tau: float,
    eta: float,
    t_r: FloatArray,
    center: FloatArray,
    var: FloatArray,
    k_arg: FloatArray,
    ref: IntArray,
) -> int:
    """:func:`window_kernel` writing into given arrays: ``t_r``, ``center``, ``var``,
    ``k_arg`` with room for ``c - oldest`` windows, ``ref`` ``(2,)``.

    Returns
    -------
    int
        Number of sub-windows ``R`` written (the first ``R`` rows).
    """
    first = c
    while first > oldest and tt[first - 1] >= limit:
        first -= 1
    n = c + 1 - first
    dts = np.empty(n)
    if first > oldest:
        for i in range(n):
            dts[i] = tt[first + i] - tt[first + i - 1]
    else:
        dts[0] = dt0
        for i in range(1, n):
            dts[i] = tt[first + i] - tt[first + i - 1]
    # suffix[i] = sum_{l >= i} U_l dt_l (eq. 10), accumulated from the newest record
    suffix = np.empty((n, 2))
    sx = 0.0
    sy = 0.0
    for i in range(n - 1, -1, -1):
        if i == n - 1:
            sx = ww[first + i, 0] * dts[i]
            sy = ww[first + i, 1] * dts[i]
        else:
            sx = sx + ww[first + i, 0] * dts[i]
            sy = sy + ww[first + i, 1] * dts[i]
        suffix[i, 0] = sx
        suffix[i, 1] = sy
    n_win = n - 1
    px = pp[c, 0]
    py = pp[c, 1]
    ix = int(np.floor((px - x0) / a))
    iy = int(np.floor((py - y0) / a))
    if snap:
        px = x0 + (ix + 0.5) * a
        py = y0 + (iy + 0.5) * a
    sig = np.empty(2)
    if fixed:
        sig[0] = fixed_var[0]
        sig[1] = fixed_var[1]
    else:
        lo = first + 1 if interval else first
        m = c + 1 - lo
        if m < 2:
            sig[0] = min_var
            sig[1] = min_var
        else:
            for ax in range(2):
                mean = 0.0
                for i in range(lo, c + 1):
                    mean = mean + ww[i, ax]
                mean = mean / m
                ss = 0.0
                for i in range(lo, c + 1):
                    d = ww[i, ax] - mean
                    ss = ss + d * d
                sig[ax] = max(ss / (m - 1), min_var)
    sig[0] = sig[0] * tau
    sig[1] = sig[1] * tau
    scale = (a * a) / (2.0 * np.pi * eta * np.sqrt(sig[0] * sig[1]))
    for r in range(n_win):
        t_r[r] = tt[first + r]
        age = tt[c] - tt[first + r]
        var[r, 0] = age * sig[0]
        var[r, 1] = age * sig[1]
        k_arg[r] = scale / age
        s = r + 1 if interval else r
        center[r, 0] = px - suffix[s, 0]
        center[r, 1] = py - suffix[s, 1]
    ref[0] = ix
    ref[1] = iy
    return n_win


def window_kernel(
    tt: FloatArray,
    ww: FloatArray,
    pp: FloatArray,
    limit: float,
    c: int,
    oldest: int,
    dt0: float,
    interval: bool,
    snap: bool,
    x0: float,
    y0: float,
    a: float,
    fixed: bool,
    fixed_var: FloatArray,
    min_var: float,
    tau: float,
    eta: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray]:
    """The sub-windows at record ``c`` as the estimator's NumPy ``window_arrays`` computes
    them, all but the logarithm of eq. (13).

    Every sum runs in NumPy's order (``cumsum`` and a reduction over the records' axis are
    sequential), so the results are the NumPy code's to the bit; ``log`` is left to NumPy
    (``k = log(k_arg)``).

    Parameters
    ----------
    tt, ww, pp : (n,), (n, 2), (n, 2) ndarray
        Record buffer: times (s), winds (m/s), positions (m).
    limit : float, s
        The windows start at the oldest stored record at or after ``limit``
        (``t_c - t_thr``, less a tolerance).
    c : int
        Buffer index of ``t_c``.
    oldest : int
        Buffer index of the oldest stored record (the windows' first: its interval is ``dt0``).
    dt0 : float, s
        Interval of the oldest stored record.
    interval, snap : bool
        ``advection == "interval"``; ``snap_to_cell``.
    x0, y0, a : float, m
        Grid origin and cell size.
    fixed : bool
        ``variance == "fixed"`` (``fixed_var``, m^2/s^2); else the sample variance floored
        at ``min_var``.
    tau : float, s
        ``noise_time_scale``.
    eta : float
        Window threshold of eq. (13).

    Returns
    -------
    t_r : (R,) ndarray, s
    center, var : (R, 2) ndarray, m and m^2
    k_arg : (R,) ndarray
        The argument of eq. (13)'s logarithm.
    ref_cell : (2,) int ndarray
    """
    n_win = max(c - oldest, 0)
    t_r = np.empty(n_win)
    center = np.empty((n_win, 2))
    var = np.empty((n_win, 2))
    k_arg = np.empty(n_win)
    ref = np.empty(2, np.intp)
    n_win = window_fill_fast(
        tt, ww, pp, limit, c, oldest, dt0, interval, snap, x0, y0, a, fixed, fixed_var,
        min_var, tau, eta, t_r, center, var, k_arg, ref,
    )  # fmt: skip
    return t_r[:n_win], center[:n_win], var[:n_win], k_arg[:n_win], ref


def axis_boxes(
    center: FloatArray,
    var: FloatArray,
    k: FloatArray,
    n_r: int,
    lo_x: float,
    lo_y: float,
    a: float,
    nx: int,
    ny: int,
    boxes: IntArray,
    coef: FloatArray,
) -> tuple[int, int]:
    """The first ``n_r`` windows' boxes into ``boxes`` ``(>= n_r, 4)`` and the kernel
    coefficients ``a / sqrt(2 pi v)`` into ``coef`` ``(>= n_r, 2)``, as the estimator's NumPy
    prelude computes them.

    Returns
    -------
    bx, by : int
        The largest box size along x and along y (the axis terms' padded widths).
    """
    lows = (lo_x, lo_y)
    shape = (nx, ny)
    bx = 0
    by = 0
    for r in range(n_r):
        valid = k[r] > 0
        kk = k[r] if valid else 0.0
        for ax in range(2):
            half = np.sqrt(2.0 * kk * var[r, ax])
            c = center[r, ax]
            i0 = int(np.ceil((c - half - lows[ax]) / a - 0.5)) - 1
            i1 = int(np.floor((c + half - lows[ax]) / a - 0.5)) + 2
            i0 = min(max(i0, 0), shape[ax])
            i1 = min(max(i1, 0), shape[ax])
            n = max(i1 - i0, 0) if valid else 0
            boxes[r, 2 * ax] = i0
            boxes[r, 2 * ax + 1] = i0 + n
            coef[r, ax] = a / np.sqrt(2.0 * np.pi * var[r, ax])
        bx = max(bx, boxes[r, 1] - boxes[r, 0])
        by = max(by, boxes[r, 3] - boxes[r, 2])
    return bx, by


def axis_fill(
    center: FloatArray,
    var: FloatArray,
    boxes: IntArray,
    lo_x: float,
    lo_y: float,
    a: float,
    nx: int,
    ny: int,
    qx: FloatArray,
    arg_x: FloatArray,
    qy: FloatArray,
    arg_y: FloatArray,
) -> None:
    """The axis terms of the windows ``r < len(qx)`` into ``qx``, ``arg_x`` ``(R, Bx)`` and
    ``qy``, ``arg_y`` ``(R, By)``: ``d^2 / v`` (eq. 12) and ``-0.5 d^2 / v`` (eq. 11) at the
    cells of each box (a padded cell repeats the grid's last cell)."""
    lows = (lo_x, lo_y)
    shape = (nx, ny)
    for r in range(qx.shape[0]):
        for ax in range(2):
            q = qx[r] if ax == 0 else qy[r]
            arg = arg_x[r] if ax == 0 else arg_y[r]
            c = center[r, ax]
            v = var[r, ax]
            start = boxes[r, 2 * ax]
            last = shape[ax] - 1
            low = lows[ax]
            for i in range(q.shape[0]):
                cell = min(start + i, last)
                d = (low + (cell + 0.5) * a) - c
                qq = d * d / v
                q[i] = qq
                # -0.5 d d / v as NumPy computes it: scaling by a power of two commutes with
                # every rounding (no subnormal distances here), so one division serves both
                arg[i] = -0.5 * qq


def axis_kernel(
    center: FloatArray,
    var: FloatArray,
    k: FloatArray,
    lo_x: float,
    lo_y: float,
    a: float,
    nx: int,
    ny: int,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
    """The windows' boxes and axis terms as the estimator's NumPy prelude computes them (point
    kernel), all but the exponentials.

    Every operation is the one the NumPy code applies, in the same order, so the results are the
    same to the bit; the exponentials of ``arg`` are left to NumPy (``fx = coef_x exp(arg_x)``).

    Returns
    -------
    boxes : (R, 4) int ndarray
        ``(ix0, ix1, iy0, iy1)`` (empty: ``ix1 == ix0`` or ``iy1 == iy0``).
    qa_x : (2, R, Bx) ndarray
        ``d^2 / v`` (eq. 12) and ``-0.5 d^2 / v`` (eq. 11) at the cells of each box along x.
    qa_y : (2, R, By) ndarray
        The same along y.
    coef : (R, 2) ndarray
        ``a / sqrt(2 pi v)`` per axis.
    """
    n_r = k.shape[0]
    boxes = np.zeros((n_r, 4), np.intp)
    coef = np.empty((n_r, 2))
    bx, by = axis_boxes_fast(center, var, k, n_r, lo_x, lo_y, a, nx, ny, boxes, coef)
    # two arrays, not four: each array handed back to Python costs more than its filling here
    qa_x = np.empty((2, n_r, bx))
    qa_y = np.empty((2, n_r, by))
    axis_fill_fast(center, var, boxes, lo_x, lo_y, a, nx, ny, qa_x[0], qa_x[1], qa_y[0], qa_y[1])
    return boxes, qa_x, qa_y, coef


def dw_kernel(
    boxes: IntArray,
    qx: FloatArray,
    qy: FloatArray,
    fx: FloatArray,
    fy: FloatArray,
    lim: FloatArray,
    normalise: bool,
) -> tuple[IntArray, FloatArray, int, int]:
    """Loop form of the estimator's NumPy batch plus the max over windows (eqs. 12-17).

    Parameters
    ----------
    boxes : (R, 4) int ndarray
        ``(ix0, ix1, iy0, iy1)`` of each window (empty: ``ix1 == ix0`` or ``iy1 == iy0``).
    qx, qy : (R, Bx), (R, By) ndarray
        Ellipse terms ``d^2 / v`` of eq. (12) along each axis of each window's box.
    fx, fy : (R, Bx), (R, By) ndarray
        Kernel factors of eq. (11) on the same cells.
    lim : (R,) ndarray
        ``2 k``: a cell is in window ``r`` when ``qx + qy <= lim[r]``.
    normalise : bool
        Divide each window by its sum.

    Returns
    -------
    n_cells : (R,) int ndarray
        Cells of each window (0: empty).
    patch : (bx, by) ndarray
        Maximum over the windows in the union of their boxes.
    ix0, iy0 : int
        Grid index of ``patch[0, 0]``.

    Notes
    -----
    The estimator computes the axis terms with NumPy's exponentials for both paths; the sums
    run cell by cell in row order as the batch's running sum does, and the normalisation
    divides as it does, so the patch is the batch's to the bit. Along a row the window's cells
    are one run: ``qy`` falls then rises along the box (``d^2 / v`` of a coordinate that grows
    cell by cell, every step rounded monotonically) and a rounded sum grows with its terms, so
    each row's run is found by counting the cells inside before and after the lowest ``qy``,
    and only its cells are summed and written.
    """
    n_r = lim.shape[0]
    n_cells = np.zeros(n_r, np.intp)
    totals = np.ones(n_r)
    rows = max(qx.shape[1], 1)
    run_lo = np.zeros((n_r, rows), np.intp)
    run_hi = np.zeros((n_r, rows), np.intp)  # exclusive; run_hi <= run_lo: an empty row
    for r in range(n_r):
        sx = boxes[r, 1] - boxes[r, 0]
        sy = boxes[r, 3] - boxes[r, 2]
        if sx <= 0 or sy <= 0:
            continue
        bottom = 0
        for j in range(1, sy):
            if qy[r, j] < qy[r, bottom]:
                bottom = j
        lr = lim[r]
        # one-dimensional views: loops over them compile to vector code (a 2-D index keeps
        # its checks in the loop)
        qyr = qy[r, :sy]
        fyr = fy[r, :sy]
        below = qyr[:bottom]
        rest = qyr[bottom:]
        # the row's run from two counts of cells inside (compares without branches: which
        # cells a row keeps changes from call to call and would defeat branch prediction)
        for i in range(sx):
            qi = qx[r, i]
            left = 0
            for j in range(bottom):
                left += qi + below[j] <= lr  # eq. (12)
            inside = left
            for j in range(sy - bottom):
                inside += qi + rest[j] <= lr
            run_lo[r, i] = bottom - left
            run_hi[r, i] = bottom - left + inside
        total = 0.0
        count = 0
        for i in range(sx):
            f = fx[r, i]
            run = fyr[run_lo[r, i] : run_hi[r, i]]
            for j in range(run.size):
                total += f * run[j]
            count += run.size
        if count > 0 and total > 0.0:
            n_cells[r] = count
            totals[r] = total
    ux0, ux1, uy0, uy1 = 1 << 62, 0, 1 << 62, 0
    for r in range(n_r):
        if n_cells[r] > 0:
            ux0 = min(ux0, boxes[r, 0])
            ux1 = max(ux1, boxes[r, 1])
            uy0 = min(uy0, boxes[r, 2])
            uy1 = max(uy1, boxes[r, 3])
    if ux1 <= ux0:
        return n_cells, np.zeros((0, 0)), 0, 0
    patch = np.zeros((ux1 - ux0, uy1 - uy0))
    for r in range(n_r):
        if n_cells[r] == 0:
            continue
        i0, j0 = boxes[r, 0], boxes[r, 2]
        t = totals[r]
        fyr = fy[r]
        for i in range(boxes[r, 1] - i0):
            f = fx[r, i]
            a = run_lo[r, i]
            b = run_hi[r, i]
            run = fyr[a:b]
            out = patch[i0 + i - ux0, j0 + a - uy0 : j0 + b - uy0]
            for j in range(b - a):
                v = f * run[j]
                if normalise:
                    v = v / t
                old = out[j]
                out[j] = v if v > old else old  # eq. (17): max over t_r
    return n_cells, patch, ux0, uy0


def window_pass(
    tt: FloatArray,
    ww: FloatArray,
    pp: FloatArray,
    limit: float,
    c: int,
    oldest: int,
    fpar: FloatArray,
    flags: IntArray,
    t_r: FloatArray,
    center: FloatArray,
    var: FloatArray,
    k_arg: FloatArray,
    ref: IntArray,
) -> int:
    """:func:`window_fill` with an estimator's fixed settings packed in two arrays (few
    arguments: each one costs the call's dispatch).

    Parameters
    ----------
    fpar : (9,) ndarray
        ``dt0`` (s), ``x0``, ``y0``, ``a`` (m), the fixed variances ``(2,)`` (m^2/s^2),
        ``min_var`` (m^2/s^2), ``tau`` (s), ``eta``.
    flags : (3,) int ndarray
        ``interval``, ``snap``, ``fixed`` (non-zero: true).

    Returns
    -------
    int
        Number of sub-windows written.
    """
    return window_fill_fast(
        tt, ww, pp, limit, c, oldest, fpar[0], flags[0] != 0, flags[1] != 0, fpar[1],
        fpar[2], fpar[3], flags[2] != 0, fpar[4:6], fpar[6], fpar[7], fpar[8], t_r, center,
        var, k_arg, ref,
    )  # fmt: skip


def axis_pass(
    center: FloatArray,
    var: FloatArray,
    k: FloatArray,
    n_r: int,
    grid_f: FloatArray,
    grid_n: IntArray,
    boxes: IntArray,
    coef: FloatArray,
    qbuf: FloatArray,
    argbuf: FloatArray,
    sizes: IntArray,
) -> int:
    """Boxes and axis terms of the first ``n_r`` windows into preallocated arrays (the
    estimator's workspace), laid out so that one NumPy ``exp`` serves both axes.

    Parameters
    ----------
    center, var, k : (>= n_r, 2), (>= n_r, 2), (>= n_r,) ndarray
        As :func:`axis_kernel`'s.
    grid_f : (3,) ndarray
        Grid origin ``(x0, y0)`` and cell size, m.
    grid_n : (2,) int ndarray
        Cells per axis.
    boxes, coef : (>= n_r, 4) int, (>= n_r, 2) ndarray
        Out: :func:`axis_boxes`'.
    qbuf, argbuf : (>= n_r (nx + ny),) ndarray
        Out: ``qx`` ``(n_r, Bx)`` then ``qy`` ``(n_r, By)`` flat, and the exponentials'
        arguments in the same layout.
    sizes : (2,) int ndarray
        Out: ``Bx``, ``By``.

    Returns
    -------
    int
        ``n_r (Bx + By)``: the length of ``argbuf`` to exponentiate.
    """
    bx, by = axis_boxes_fast(
        center, var, k, n_r, grid_f[0], grid_f[1], grid_f[2], grid_n[0], grid_n[1], boxes, coef
    )
    mx = n_r * bx
    my = n_r * by
    qx = qbuf[:mx].reshape((n_r, bx))
    qy = qbuf[mx : mx + my].reshape((n_r, by))
    arg_x = argbuf[:mx].reshape((n_r, bx))
    arg_y = argbuf[mx : mx + my].reshape((n_r, by))
    axis_fill_fast(
        center, var, boxes, grid_f[0], grid_f[1], grid_f[2], grid_n[0], grid_n[1], qx, arg_x,
        qy, arg_y,
    )  # fmt: skip
    sizes[0] = bx
    sizes[1] = by
    return mx + my


def dw_pass(
    boxes: IntArray,
    coef: FloatArray,
    k: FloatArray,
    n_r: int,
    qbuf: FloatArray,
    ebuf: FloatArray,
    sizes: IntArray,
    normalise: bool,
) -> tuple[FloatArray, int, int]:
    """:func:`dw_kernel` on :func:`axis_pass`' workspace once NumPy has exponentiated it.

    Parameters
    ----------
    boxes, coef, k, n_r, qbuf, sizes
        As after :func:`axis_pass`.
    ebuf : ndarray
        ``exp`` of :func:`axis_pass`' ``argbuf`` (may be ``argbuf`` itself: it is scaled in
        place to the kernel factors).
    normalise : bool

    Returns
    -------
    patch : (bx, by) ndarray
    ix0, iy0 : int
        As :func:`dw_kernel`'s.
    """
    bx = sizes[0]
    by = sizes[1]
    mx = n_r * bx
    my = n_r * by
    qx = qbuf[:mx].reshape((n_r, bx))
    qy = qbuf[mx : mx + my].reshape((n_r, by))
    fx = ebuf[:mx].reshape((n_r, bx))
    fy = ebuf[mx : mx + my].reshape((n_r, by))
    lim = np.empty(n_r)
    for r in range(n_r):
        # coef exp(arg): the NumPy batch's product (one rounding, either order)
        cx = coef[r, 0]
        for i in range(bx):
            fx[r, i] = fx[r, i] * cx
        cy = coef[r, 1]
        for j in range(by):
            fy[r, j] = fy[r, j] * cy
        lim[r] = 2.0 * k[r]
    _, patch, ix0, iy0 = dw_kernel_fast(boxes[:n_r], qx, qy, fx, fy, lim, normalise)
    return patch, ix0, iy0


def paint(canvas: FloatArray, last: IntArray, values: FloatArray, ix0: int, iy0: int) -> None:
    """Write a patch into a full map that holds the previous one.

    ``canvas`` ``(nx, ny)`` is zero outside the box ``last`` ``(ix0, ix1, iy0, iy1)``; after
    the call it holds ``values`` at ``(ix0, iy0)`` and zeros elsewhere, and ``last`` is the new
    box. Only the two boxes are written, never the whole map.
    """
    bx, by = values.shape
    ix1 = ix0 + bx
    iy1 = iy0 + by
    for i in range(last[0], last[1]):
        row = canvas[i]
        if ix0 <= i < ix1:
            # the new patch overwrites its own columns
            for j in range(last[2], min(last[3], iy0)):
                row[j] = 0.0
            for j in range(max(last[2], iy1), last[3]):
                row[j] = 0.0
        else:
            for j in range(last[2], last[3]):
                row[j] = 0.0
    for i in range(bx):
        row = canvas[ix0 + i]
        v = values[i]
        for j in range(by):
            row[iy0 + j] = v[j]
    last[0] = ix0
    last[1] = ix1
    last[2] = iy0
    last[3] = iy1


def _warm(kernel: Any) -> None:
    """One call on a single window, with the argument types the estimator passes."""
    box = np.array([[0, 2, 0, 2]], np.intp)
    two = np.ones((1, 2))
    kernel(box, two, two, two, two, np.full(1, 4.0), True)


def _warm_axes(kernel: Any) -> None:
    one = np.ones(1)
    kernel(np.ones((1, 2)), np.ones((1, 2)), one, 0.0, 0.0, 0.5, 4, 4)


def _warm_window(kernel: Any) -> None:
    t = np.arange(3.0)
    w = np.ones((3, 2))
    kernel(t, w, w, 0.0, 2, 0, 1.0, True, False, 0.0, 0.0, 0.5, False, np.ones(2), 1e-4, 1.0, 1e-3)


def _warm_passes(window: Any, axes: Any, dw: Any) -> None:
    """The three passes of the estimator's compiled map on a two-record history."""
    t = np.arange(3.0)
    w = np.ones((3, 2))
    fpar = np.array([1.0, 0.0, 0.0, 0.5, 1e-3, 1e-3, 1e-4, 1.0, 1e-3])
    flags = np.array([1, 0, 0], np.intp)
    t_r, center, var, k = np.empty(3), np.empty((3, 2)), np.empty((3, 2)), np.empty(3)
    boxes, coef = np.zeros((3, 4), np.intp), np.empty((3, 2))
    qbuf, argbuf, sizes = np.empty(24), np.empty(24), np.zeros(2, np.intp)
    n_r = window(t, w, w, 0.0, 2, 0, fpar, flags, t_r, center, var, k, np.zeros(2, np.intp))
    n = axes(center, var, k, n_r, fpar[1:4], np.array([4, 4], np.intp), boxes, coef, qbuf,
             argbuf, sizes)  # fmt: skip
    dw(boxes, coef, k, n_r, qbuf, np.exp(argbuf[:n], out=argbuf[:n]) if n else argbuf, sizes,
       True)  # fmt: skip


def _warm_paint(kernel: Any) -> None:
    kernel(np.zeros((4, 4)), np.zeros(4, np.intp), np.ones((2, 2)), 1, 1)


# compiled and cached across processes (odorloc.core.jit); the functions themselves without
# numba. Kernels call each other through these module globals (see odorloc.core.jit).
window_fill_fast = jit(window_fill, nogil=True)
axis_boxes_fast = jit(axis_boxes, nogil=True)
axis_fill_fast = jit(axis_fill, nogil=True)
dw_kernel_fast = jit(dw_kernel, warmup=_warm, nogil=True)
axis_kernel_fast = jit(axis_kernel, warmup=_warm_axes, nogil=True)
window_kernel_fast = jit(window_kernel, warmup=_warm_window, nogil=True)
window_pass_fast = jit(window_pass, nogil=True)
axis_pass_fast = jit(axis_pass, nogil=True)
dw_pass_fast = jit(
    dw_pass, warmup=lambda dw: _warm_passes(window_pass_fast, axis_pass_fast, dw), nogil=True
)
paint_fast = jit(paint, warmup=_warm_paint, nogil=True)
