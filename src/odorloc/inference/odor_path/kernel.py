"""The per-window loop of the dynamic-window odor-path map (odor-path paper, eqs. 12-17).

:func:`dw_kernel` is the loop form of the estimator's batched NumPy pass plus the maximum over
windows; it is compiled with numba when the ``fast`` extra is installed (:data:`HAVE_NUMBA`).
The NumPy batch of :class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator` is the
reference; both start from the same NumPy axis terms and give the same patch to the bit, so the
same seed gives the same D-S episode with or without numba.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from odorloc.core.jit import HAVE_NUMBA, jit

__all__ = ["HAVE_NUMBA", "axis_kernel", "axis_kernel_fast", "dw_kernel", "dw_kernel_fast"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def axis_kernel(
    center: FloatArray,
    var: FloatArray,
    k: FloatArray,
    lo_x: float,
    lo_y: float,
    a: float,
    nx: int,
    ny: int,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The windows' boxes and axis terms as the estimator's NumPy prelude computes them (point
    kernel), all but the exponentials.

    Every operation is the one the NumPy code applies, in the same order, so the results are the
    same to the bit; the exponentials of ``arg`` are left to NumPy (``fx = coef_x exp(arg_x)``).

    Returns
    -------
    boxes : (R, 4) int ndarray
        ``(ix0, ix1, iy0, iy1)`` (empty: ``ix1 == ix0`` or ``iy1 == iy0``).
    qx, arg_x : (R, Bx) ndarray
        ``d^2 / v`` (eq. 12) and ``-0.5 d^2 / v`` (eq. 11) at the cells of each box.
    qy, arg_y : (R, By) ndarray
    coef : (R, 2) ndarray
        ``a / sqrt(2 pi v)`` per axis.
    """
    n_r = k.shape[0]
    boxes = np.zeros((n_r, 4), np.intp)
    coef = np.empty((n_r, 2))
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
    qx = np.empty((n_r, bx))
    arg_x = np.empty((n_r, bx))
    qy = np.empty((n_r, by))
    arg_y = np.empty((n_r, by))
    for r in range(n_r):
        for ax in range(2):
            q = qx if ax == 0 else qy
            arg = arg_x if ax == 0 else arg_y
            c = center[r, ax]
            v = var[r, ax]
            for i in range(q.shape[1]):
                cell = min(boxes[r, 2 * ax] + i, shape[ax] - 1)
                d = (lows[ax] + (cell + 0.5) * a) - c
                q[r, i] = d * d / v
                arg[r, i] = -0.5 * d * d / v
    return boxes, qx, qy, arg_x, arg_y, coef


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
    The estimator computes the axis terms with NumPy for both paths; the sums run cell by cell
    in row order as the batch's running sum does, and the normalisation divides as it does, so
    the patch is the batch's to the bit.
    """
    n_r = lim.shape[0]
    n_cells = np.zeros(n_r, np.intp)
    totals = np.ones(n_r)
    for r in range(n_r):
        sx = boxes[r, 1] - boxes[r, 0]
        sy = boxes[r, 3] - boxes[r, 2]
        if sx <= 0 or sy <= 0:
            continue
        total = 0.0
        count = 0
        for i in range(sx):
            for j in range(sy):
                if qx[r, i] + qy[r, j] <= lim[r]:  # eq. (12)
                    total += fx[r, i] * fy[r, j]
                    count += 1
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
        for i in range(boxes[r, 1] - i0):
            for j in range(boxes[r, 3] - j0):
                if qx[r, i] + qy[r, j] <= lim[r]:
                    v = fx[r, i] * fy[r, j]
                    if normalise:
                        v = v / totals[r]
                    pi = i0 + i - ux0
                    pj = j0 + j - uy0
                    if v > patch[pi, pj]:  # eq. (17): max over t_r
                        patch[pi, pj] = v
    return n_cells, patch, ux0, uy0


def _warm(kernel: Any) -> None:
    """One call on a single window, with the argument types the estimator passes."""
    box = np.array([[0, 2, 0, 2]], np.intp)
    two = np.ones((1, 2))
    kernel(box, two, two, two, two, np.full(1, 4.0), True)


def _warm_axes(kernel: Any) -> None:
    one = np.ones(1)
    kernel(np.ones((1, 2)), np.ones((1, 2)), one, 0.0, 0.0, 0.5, 4, 4)


# compiled and cached across processes (odorloc.core.jit); the functions themselves without numba
dw_kernel_fast = jit(dw_kernel, warmup=_warm, nogil=True)
axis_kernel_fast = jit(axis_kernel, warmup=_warm_axes, nogil=True)
