"""The compiled loops of the dynamic-window odor-path map (odor-path paper, eqs. 10-17).

The estimator's map (point kernel) is one call of :func:`path_kernel` on a workspace it
allocates once (:func:`path_workspace`): the sub-windows, eq. (13)'s logarithm, the axis terms
with a vectorised exponential (:func:`exp_nonpositive`), each window's cells and sum, and the
maximum over the windows; :func:`paint` writes a patch into a reused dense map. The NumPy batch
of :class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator` is the reference: the fused
map equals it within a few units in the last place (its exponentials, logarithm, sums and
normalisation round differently; see :func:`path_kernel`).

:func:`window_kernel`, :func:`axis_kernel` and :func:`dw_kernel` compute the sub-windows, the
axis terms and the window pass as the NumPy code does, operation for operation, with NumPy's
exponentials and logarithms between them: the estimator's :meth:`window_arrays` and
:meth:`windows` use them, and give the NumPy batch's numbers to the bit. Everything is compiled
with numba when it is installed (:data:`HAVE_NUMBA`).
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
    "dw_kernel",
    "dw_kernel_fast",
    "exp_nonpositive",
    "exp_nonpositive_fast",
    "paint",
    "paint_fast",
    "path_kernel",
    "path_kernel_fast",
    "path_meta",
    "path_workspace",
    "window_fill",
    "window_kernel",
    "window_kernel_fast",
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


def paint(canvas: FloatArray, last: IntArray, values: FloatArray, ix0: int, iy0: int) -> None:
    """Write a patch into a full map that holds the previous one.

    ``canvas`` ``(nx, ny)`` is zero outside the box ``last`` ``(ix0, ix1, iy0, iy1)``; after
    the call it holds ``values`` at ``(ix0, iy0)`` and zeros elsewhere, and ``last`` is the new
    box. Only the two boxes are written, never the whole map.
    """
    bx, by = values.shape
    ix1 = ix0 + bx
    iy1 = iy0 + by
    # slices, not element loops: an element index from a run that may start anywhere keeps
    # its negative-index test, which stops the compiler turning the loops into block moves
    for i in range(last[0], last[1]):
        row = canvas[i]
        if ix0 <= i < ix1:
            # the new patch overwrites its own columns
            end = min(last[3], iy0)
            if end > last[2]:
                row[last[2] : end] = 0.0
            start = max(last[2], iy1)
            if last[3] > start:
                row[start : last[3]] = 0.0
        elif last[3] > last[2]:
            row[last[2] : last[3]] = 0.0
    for i in range(bx):
        canvas[ix0 + i, iy0:iy1] = values[i]
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
paint_fast = jit(paint, warmup=_warm_paint, nogil=True)


# ------------------------------------------------------------------------ the fused map
# exp(x) = 2^k exp(r), x = k ln 2 + r, |r| <= ln(2) / 2 (Cody and Waite's reduction; ln 2 split
# so that k ln2_hi is exact for |k| < 2^20)
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
# 1 / n! for n = 13 .. 2: the Taylor series of exp(r) truncated after r^13 (|r|^14 / 14! is
# below 5e-18 for |r| <= ln(2) / 2)
_C13 = 1.0 / 6227020800.0
_C12 = 1.0 / 479001600.0
_C11 = 1.0 / 39916800.0
_C10 = 1.0 / 3628800.0
_C9 = 1.0 / 362880.0
_C8 = 1.0 / 40320.0
_C7 = 1.0 / 5040.0
_C6 = 1.0 / 720.0
_C5 = 1.0 / 120.0
_C4 = 1.0 / 24.0
_C3 = 1.0 / 6.0
_C2 = 0.5


def exp_nonpositive(x: FloatArray, out: FloatArray, bits: NDArray[np.int64]) -> None:
    """``out[i] = exp(x[i])`` for ``x[i] <= 0``, in loops the compiler vectorises.

    A compiled call of the C library's ``exp`` is one scalar call per argument (several times
    NumPy's vectorised exponential); this form (argument reduction by ``ln 2``, a degree-13
    polynomial, the power of two built from its bits) runs several arguments per instruction.
    Within one unit in the last place of NumPy's value (tested); arguments below -708, whose
    results are subnormal, go to the C library's ``exp``.

    Parameters
    ----------
    x : (n,) ndarray
        Arguments, ``<= 0``.
    out : (n,) ndarray
        Results (not ``x`` itself: the subnormal range reads ``x`` again).
    bits : (>= n,) int64 ndarray
        Scratch: the power of two each result is scaled by.
    """
    n = x.shape[0]
    tiny = False
    for i in range(n):
        xi = x[i]
        tiny |= xi < -708.0
        xi = max(xi, -708.0)  # 2^k stays a normal number
        k = np.int64(xi * _INV_LN2 - 0.5)  # nearest (ties up): x <= 0 truncates upwards
        kf = np.float64(k)
        r = (xi - kf * _LN2_HI) - kf * _LN2_LO
        p = _C13
        p = p * r + _C12
        p = p * r + _C11
        p = p * r + _C10
        p = p * r + _C9
        p = p * r + _C8
        p = p * r + _C7
        p = p * r + _C6
        p = p * r + _C5
        p = p * r + _C4
        p = p * r + _C3
        p = p * r + _C2
        p = p * r + 1.0
        p = p * r + 1.0
        out[i] = p
        bits[i] = (k + 1023) << 52
    scale = bits[:n].view(np.float64)
    for i in range(n):
        out[i] = out[i] * scale[i]
    if tiny:
        for i in range(n):
            if x[i] < -708.0:
                out[i] = np.exp(x[i])


def path_workspace(capacity: int, nx: int, ny: int) -> FloatArray:
    """The scratch array :func:`path_kernel` works in, for up to ``capacity`` records on an
    ``(nx, ny)`` grid (allocated once, reused every map): floats, then integers stored in
    the float words."""
    return np.empty(_ws_floats(capacity, nx, ny) + capacity * (6 + 3 * nx + ny) + 8)


def _ws_floats(capacity: int, nx: int, ny: int) -> int:
    return capacity * (9 + 3 * (nx + ny) + ny + 1)


def path_kernel(
    tt: FloatArray,
    ww: FloatArray,
    pp: FloatArray,
    c: int,
    oldest: int,
    par: FloatArray,
    ws: FloatArray,
) -> FloatArray:
    """The odor-path patch at record ``c`` in one call (eqs. 10-17, point kernel).

    The sub-windows as :func:`window_fill` computes them, eq. (13)'s logarithm, the boxes as
    :func:`axis_boxes`, the axis terms with :func:`exp_nonpositive`, each window's cells and
    sum, and the maximum over the windows (eq. 17).

    Parameters
    ----------
    tt, ww, pp : (n,), (n, 2), (n, 2) ndarray
        Record buffer: times (s), winds (m/s), positions (m).
    c, oldest : int
        Buffer index of ``t_c`` and of the oldest stored record.
    par : (17,) ndarray
        The estimator's settings in one array (each argument adds to a call's dispatch):
        ``dt0`` (s, the oldest stored record's interval), ``x0``, ``y0``, ``a`` (m), the fixed
        variances ``(2,)`` (m^2/s^2), ``min_var`` (m^2/s^2), ``tau`` (s), ``eta``, ``t_thr``
        (s), the time tolerance (s), then ``interval``, ``snap``, ``fixed``, ``normalise``
        (non-zero: true) and the grid's cells per axis ``nx``, ``ny`` (see
        :func:`window_kernel`). The windows start at the oldest stored record at or after
        ``tt[c] - t_thr - tolerance``.
    ws : ndarray
        :func:`path_workspace` for at least ``c - oldest`` records and the grid. Its first
        four integers (:func:`path_meta`) are written: the grid index ``(ix0, iy0)`` of
        ``patch[0, 0]`` and the robot's cell.

    Returns
    -------
    patch : (bx, by) ndarray
        The map in the union of the boxes of the windows with cells (``(0, 0)``: none).

    Notes
    -----
    What differs from the NumPy batch, each by a few units in the last place: the exponentials
    (:func:`exp_nonpositive`) and the logarithm (the C library's), a window's sum (each row's
    cells summed as the difference of two running sums of the column factors, then the rows
    in order) and the normalisation (one reciprocal per window). The ellipse test of eq. (12)
    is the batch's, on ``k`` from that logarithm: a cell's membership can differ only where it
    is within rounding of the ellipse's edge.

    Each row of a window is one run of cells (see :func:`dw_kernel`). Its ends are first
    placed from the ellipse's chord (all rows at once, vectorised), then moved cell by cell
    while the exact test of eq. (12) says so (rounding moves them by a cell at most, so these
    loops rarely turn); the writes loop over whole rows of the box with the run as a mask, so
    that no loop's length depends on a row's data (a mispredicted loop exit on every row would
    cost more than the masked cells).
    """
    nmax = max(c - oldest, 0)
    limit = tt[c] - par[9] - par[10]
    nx = np.intp(par[15])
    ny = np.intp(par[16])
    wsf = ws[: _ws_floats_fast(nmax, nx, ny)]
    end = ws.shape[0] - 4
    wsi = ws[end - nmax * (6 + 3 * nx + ny) - 4 : end].view(np.intp)
    meta = ws[end:].view(np.intp)
    # the float workspace: per window, then per axis cell
    t_r = wsf[:nmax]
    k = wsf[nmax : 2 * nmax]
    scale = wsf[2 * nmax : 3 * nmax]
    center = wsf[3 * nmax : 5 * nmax].reshape((nmax, 2))
    var = wsf[5 * nmax : 7 * nmax].reshape((nmax, 2))
    coef = wsf[7 * nmax : 9 * nmax].reshape((nmax, 2))
    cells = wsf[9 * nmax :]
    boxes = wsi[: 4 * nmax].reshape((nmax, 4))
    off = wsi[4 * nmax : 6 * nmax + 1]
    ints = wsi[6 * nmax + 4 :]
    meta[0] = 0
    meta[1] = 0
    n_r = window_fill_fast(
        tt, ww, pp, limit, c, oldest, par[0], par[11] != 0, par[12] != 0, par[1], par[2],
        par[3], par[13] != 0, par[4:6], par[6], par[7], par[8], t_r, center, var, k, meta[2:4],
    )  # fmt: skip
    for r in range(n_r):
        k[r] = np.log(k[r])  # eq. (13)
    x0 = par[1]
    y0 = par[2]
    a = par[3]
    for r in range(n_r):
        for j in range(4):
            boxes[r, j] = 0
    axis_boxes_fast(center, var, k, n_r, x0, y0, a, nx, ny, boxes, coef)
    # every window's axis terms in one run: x of window r at [off[r], off[r + 1]), y at
    # [off[n_r + r], off[n_r + r + 1])
    off[0] = 0
    for ax in range(2):
        for r in range(n_r):
            m = ax * n_r + r
            off[m + 1] = off[m] + boxes[r, 2 * ax + 1] - boxes[r, 2 * ax]
    n_cells = off[2 * n_r]
    n_y = n_cells - off[n_r]
    q = cells[:n_cells]
    arg = cells[n_cells : 2 * n_cells]
    f = cells[2 * n_cells : 3 * n_cells]
    prefix = cells[3 * n_cells : 3 * n_cells + n_y + n_r]
    for ax in range(2):
        low = x0 if ax == 0 else y0
        for r in range(n_r):
            m = ax * n_r + r
            start = boxes[r, 2 * ax]
            cc = center[r, ax]
            v = var[r, ax]
            o = off[m]
            for i in range(off[m + 1] - o):
                d = (low + (start + i + 0.5) * a) - cc
                qq = d * d / v  # eq. (12)
                q[o + i] = qq
                arg[o + i] = -0.5 * qq  # eq. (11)
    exp_nonpositive_fast(arg, f, ints[:n_cells])
    for ax in range(2):
        for r in range(n_r):
            m = ax * n_r + r
            cf = coef[r, ax]
            for i in range(off[m], off[m + 1]):
                f[i] = cf * f[i]
    # per row of a window: where its run of cells starts and ends in the box
    run_lo = ints[: off[n_r]]
    run_hi = ints[off[n_r] : 2 * off[n_r]]
    normalise = par[14] != 0
    ux0, ux1, uy0, uy1 = 1 << 62, 0, 1 << 62, 0
    for r in range(n_r):
        scale[r] = 0.0
        sx = boxes[r, 1] - boxes[r, 0]
        sy = boxes[r, 3] - boxes[r, 2]
        if sx <= 0 or sy <= 0:
            continue
        qx = q[off[r] : off[r + 1]]
        fx = f[off[r] : off[r + 1]]
        qy = q[off[n_r + r] : off[n_r + r + 1]]
        fy = f[off[n_r + r] : off[n_r + r + 1]]
        # running sums of the column factors: a row's sum is the difference of two
        p0 = off[n_r + r] - off[n_r] + r
        cum = prefix[p0 : p0 + sy + 1]
        s = 0.0
        cum[0] = 0.0
        for j in range(sy):
            s += fy[j]
            cum[j + 1] = s
        lr = 2.0 * k[r]
        lo_r = run_lo[off[r] : off[r + 1]]
        hi_r = run_hi[off[r] : off[r + 1]]
        vy = var[r, 1]
        mid = (center[r, 1] - y0) / a - 0.5 - boxes[r, 2]  # the centre, in box cells
        # each row's run from the ellipse's chord
        for i in range(sx):
            h = np.sqrt(max(lr - qx[i], 0.0) * vy) / a
            lo = min(max(np.ceil(mid - h), 0.0), float(sy))
            hi = min(max(np.floor(mid + h) + 1.0, lo), float(sy))
            lo_r[i] = np.intp(lo)
            hi_r[i] = np.intp(hi)
        near = min(max(np.intp(np.floor(mid + 0.5)), 0), sy - 1)
        total = 0.0
        count = 0
        for i in range(sx):
            qi = qx[i]
            lo = lo_r[i]
            hi = hi_r[i]
            if hi <= lo:
                lo = near
                hi = near
            # the exact test of eq. (12) at the run's ends
            while lo > 0 and qi + qy[lo - 1] <= lr:
                lo -= 1
            while lo < hi and not qi + qy[lo] <= lr:
                lo += 1
            while hi < sy and qi + qy[hi] <= lr:
                hi += 1
            while hi > lo and not qi + qy[hi - 1] <= lr:
                hi -= 1
            lo_r[i] = lo
            hi_r[i] = hi
            total += fx[i] * (cum[hi] - cum[lo])
            count += hi - lo
        if count > 0 and total > 0.0:
            scale[r] = 1.0 / total if normalise else 1.0
            ux0 = min(ux0, boxes[r, 0])
            ux1 = max(ux1, boxes[r, 1])
            uy0 = min(uy0, boxes[r, 2])
            uy1 = max(uy1, boxes[r, 3])
    if ux1 <= ux0:
        return np.zeros((0, 0))
    patch = np.zeros((ux1 - ux0, uy1 - uy0))
    for r in range(n_r):
        sc = scale[r]
        if sc == 0.0:
            continue
        i0 = boxes[r, 0] - ux0
        j0 = boxes[r, 2] - uy0
        sy = boxes[r, 3] - boxes[r, 2]
        fx = f[off[r] : off[r + 1]]
        fy = f[off[n_r + r] : off[n_r + r + 1]]
        lo_r = run_lo[off[r] : off[r + 1]]
        hi_r = run_hi[off[r] : off[r + 1]]
        for i in range(boxes[r, 1] - boxes[r, 0]):
            lo = lo_r[i]
            hi = hi_r[i]
            fs = fx[i] * sc
            out = patch[i0 + i, j0 : j0 + sy]
            for j in range(sy):
                val = fs * fy[j]
                val = val if lo <= j < hi else 0.0
                old = out[j]
                out[j] = val if val > old else old  # eq. (17): max over t_r
    meta[0] = ux0
    meta[1] = uy0
    return patch


def _warm_path(kernel: Any) -> None:
    """The fused map on a two-record history, with the argument types the estimator passes."""
    t = np.arange(3.0)
    w = np.ones((3, 2))
    par = np.array([1.0, 0, 0, 0.5, 1e-3, 1e-3, 1e-4, 1.0, 1e-3, 10.0, 1e-9, 1, 0, 0, 1, 4, 4])
    kernel(t, w, w, 2, 0, par, path_workspace(3, 4, 4))


def path_meta(ws: FloatArray) -> IntArray:
    """The integers :func:`path_kernel` writes at the end of ``ws``: ``(ix0, iy0)`` of the
    patch and the robot's cell ``(ix, iy)``."""
    return ws[-4:].view(np.intp)


exp_nonpositive_fast = jit(exp_nonpositive, nogil=True)
_ws_floats_fast = jit(_ws_floats, nogil=True)
path_kernel_fast = jit(path_kernel, warmup=_warm_path, nogil=True)
