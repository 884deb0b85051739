"""The per-window loop of the dynamic-window odor-path map (odor-path paper, eqs. 11-17).

:func:`dw_kernel` is the loop form of the estimator's batched NumPy pass plus the maximum over
windows; it is compiled with numba when the ``fast`` extra is installed (:data:`HAVE_NUMBA`).
The NumPy batch of :class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator` is the
reference it is tested against.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odorloc.core.jit import HAVE_NUMBA, jit

__all__ = ["HAVE_NUMBA", "axis_factors", "dw_kernel", "dw_kernel_fast"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def axis_factors(
    lo: float, a: float, n0: int, n1: int, c: float, v: float, cell_kernel: bool
) -> tuple[FloatArray, FloatArray]:
    """One axis of a window: the ellipse term ``d^2 / v`` of eq. (12) and the kernel factor of
    eq. (11) for cells ``n0 .. n1 - 1`` (centres ``lo + (n + 0.5) a``, window centre ``c``,
    variance ``v`` m^2); the point form, or the exact cell integral with ``cell_kernel``."""
    q = np.empty(n1 - n0)
    f = np.empty(n1 - n0)
    s = math.sqrt(v)
    for n in range(n0, n1):
        d = (lo + (n + 0.5) * a) - c
        q[n - n0] = d * d / v
        if cell_kernel:
            f[n - n0] = 0.5 * (
                math.erfc(-(d + 0.5 * a) / s / math.sqrt(2.0))
                - math.erfc(-(d - 0.5 * a) / s / math.sqrt(2.0))
            )
        else:
            f[n - n0] = a / math.sqrt(2.0 * math.pi * v) * math.exp(-0.5 * d * d / v)
    return q, f


def dw_kernel(
    cx: FloatArray,
    cy: FloatArray,
    vx: FloatArray,
    vy: FloatArray,
    k: FloatArray,
    x0: float,
    y0: float,
    a: float,
    nx: int,
    ny: int,
    cell_kernel: bool,
    normalise: bool,
) -> tuple[IntArray, IntArray, FloatArray, int, int]:
    """Loop form of the estimator's NumPy batch plus the max over windows (eqs. 11-17).

    Compiled with numba when available; the NumPy batch is the reference it is tested against.

    Returns
    -------
    boxes : (R, 4) int ndarray
        ``(ix0, ix1, iy0, iy1)`` of each window (all zero for an empty window).
    n_cells : (R,) int ndarray
    patch : (bx, by) ndarray
        Maximum over the windows in the union of their boxes.
    ix0, iy0 : int
        Grid index of ``patch[0, 0]``.
    """
    n_r = k.shape[0]
    boxes = np.zeros((n_r, 4), np.intp)
    n_cells = np.zeros(n_r, np.intp)
    for r in range(n_r):
        if not k[r] > 0.0:
            continue
        hx = math.sqrt(2.0 * k[r] * vx[r])
        hy = math.sqrt(2.0 * k[r] * vy[r])
        i0 = min(max(int(math.ceil((cx[r] - hx - x0) / a - 0.5)) - 1, 0), nx)  # noqa: RUF046
        i1 = min(max(int(math.floor((cx[r] + hx - x0) / a - 0.5)) + 2, 0), nx)  # noqa: RUF046
        j0 = min(max(int(math.ceil((cy[r] - hy - y0) / a - 0.5)) - 1, 0), ny)  # noqa: RUF046
        j1 = min(max(int(math.floor((cy[r] + hy - y0) / a - 0.5)) + 2, 0), ny)  # noqa: RUF046
        if i1 > i0 and j1 > j0:
            boxes[r, 0] = i0
            boxes[r, 1] = i1
            boxes[r, 2] = j0
            boxes[r, 3] = j1
            n_cells[r] = 1  # provisional: box non-empty
    ux0, ux1, uy0, uy1 = nx, 0, ny, 0
    for r in range(n_r):
        if n_cells[r] > 0:
            ux0 = min(ux0, boxes[r, 0])
            ux1 = max(ux1, boxes[r, 1])
            uy0 = min(uy0, boxes[r, 2])
            uy1 = max(uy1, boxes[r, 3])
    if ux1 <= ux0:
        return boxes, n_cells * 0, np.zeros((0, 0)), 0, 0
    patch = np.zeros((ux1 - ux0, uy1 - uy0))
    for r in range(n_r):
        if n_cells[r] == 0:
            continue
        i0, i1, j0, j1 = boxes[r, 0], boxes[r, 1], boxes[r, 2], boxes[r, 3]
        qx, fx = axis_factors(x0, a, i0, i1, cx[r], vx[r], cell_kernel)
        qy, fy = axis_factors(y0, a, j0, j1, cy[r], vy[r], cell_kernel)
        lim = 2.0 * k[r]
        total = 0.0
        count = 0
        for i in range(i1 - i0):
            for j in range(j1 - j0):
                if qx[i] + qy[j] <= lim:  # eq. (12)
                    total += fx[i] * fy[j]
                    count += 1
        if count == 0 or not total > 0.0:
            n_cells[r] = 0
            continue
        n_cells[r] = count
        scale = 1.0 / total if normalise else 1.0
        for i in range(i1 - i0):
            for j in range(j1 - j0):
                if qx[i] + qy[j] <= lim:
                    v = fx[i] * fy[j] * scale
                    pi = i0 + i - ux0
                    pj = j0 + j - uy0
                    if v > patch[pi, pj]:  # eq. (17): max over t_r
                        patch[pi, pj] = v
    return boxes, n_cells, patch, ux0, uy0


def _warm(kernel: Any) -> None:
    """One call on a single window, with the argument types the estimator passes."""
    one = np.ones(1)
    for cell_kernel in (False, True):
        kernel(one, one, one, one, one, 0.0, 0.0, 0.5, 4, 4, cell_kernel, True)


if HAVE_NUMBA:
    # the kernel resolves axis_factors when it compiles, so the helper is compiled first; both
    # are cached across processes (odorloc.core.jit)
    axis_factors = jit(axis_factors, nogil=True)
    dw_kernel_fast = jit(dw_kernel, warmup=_warm, nogil=True)
else:  # pragma: no cover - exercised only without the extra
    dw_kernel_fast = dw_kernel
