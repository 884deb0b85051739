"""Kernel sums of readings onto a cell grid: the inner loop of the Kernel DM+V family.

Every kernel method computes, for each cell ``k`` and a few per-reading values ``v_ij``,

    S_j^(k) = sum_i  s_i N(c_k - x_i; Sigma_i) v_ij                               (*)

with ``c_k`` the cell centre, ``x_i`` the kernel's centre for reading ``i``, ``N`` a Gaussian
density cut off where its Mahalanobis distance exceeds ``cutoff`` and ``s_i`` a per-reading
factor (a time weight). ``v = (1, r)`` gives the importance weights ``Omega`` and the weighted
readings ``R`` (Lilienthal et al. 2009, eqs. 2-3); ``v = (r - r^(k(i)))^2`` the weighted
residuals ``V`` (eq. 6).

- :func:`isotropic_sums`: ``Sigma = sigma^2 I`` (Kernel DM+V, TD Kernel DM+V). The Gaussian
  factorises over the axes, so only ``d`` short rows of exponentials are evaluated per reading;
  the accumulation over the reading's window of cells is a loop by nature and is compiled with
  numba. The NumPy pass (:func:`isotropic_sums` with ``backend="numpy"``) is the reference:
  both take the same NumPy exponentials and add the same products in the same order, so they
  agree to the bit.
- :func:`anisotropic_sums`: one covariance per reading (the wind-stretched kernel of Kernel
  DM+V/W), in NumPy.

The cut-off is a ball (an ellipsoid for :func:`anisotropic_sums`): cells whose centre is farther
than ``cutoff`` standard deviations (Mahalanobis distance) from the kernel's centre get no
weight. Readings outside the grid still weigh the cells near them.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit
from odorloc.geometry.grid import CellGrid

__all__ = ["HAVE_NUMBA", "anisotropic_sums", "gaussian_peak", "isotropic_sums"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_CHUNK_ELEMENTS = 1_000_000
"""Reading-cell pairs held at once by the NumPy passes (memory, not results: the compiled pass
uses the same chunks so that both add in the same order)."""

Backend = Literal["auto", "numpy", "numba"]


def gaussian_peak(sigma: float, dim: int) -> float:
    """Peak value ``N(0; sigma^2 I) = (2 pi sigma^2)^(-d/2)`` of the isotropic kernel, 1/m^d."""
    return float((2.0 * math.pi * sigma * sigma) ** (-0.5 * dim))


def _axis_windows(
    grid: CellGrid, centres: FloatArray, half: NDArray[np.int64]
) -> tuple[list[IntArray], list[FloatArray], list[NDArray[np.bool_]]]:
    """Per axis: the window's cell indices ``(N, W_a)``, the offsets of the cell centres from
    the kernel centres ``(N, W_a)`` (metres) and which window cells lie inside the grid."""
    lo = np.asarray(grid.lower, float)
    cells = grid.cells
    idx_l, diff_l, ok_l = [], [], []
    for a in range(grid.dim):
        own = np.floor((centres[:, a] - lo[a]) / cells[a]).astype(np.int64)
        off = np.arange(-int(half[a]), int(half[a]) + 1, dtype=np.int64)
        idx = own[:, None] + off[None, :]
        ok = (idx >= 0) & (idx < grid.shape[a])
        diff = lo[a] + (idx + 0.5) * cells[a] - centres[:, a, None]
        idx_l.append(np.where(ok, idx, 0))
        diff_l.append(diff)
        ok_l.append(ok)
    return idx_l, diff_l, ok_l


def _half_window(reach: FloatArray) -> NDArray[np.int64]:
    """Cells each side of a kernel centre's own cell that a cut-off of ``reach`` cells (per
    axis) can reach: a cell ``o`` cells away has its centre more than ``|o| - 1/2`` cells from
    any point of the centre's cell."""
    return np.floor(np.asarray(reach, float) + 0.5).astype(np.int64)


def _padded(grid: CellGrid, arrays: list[np.ndarray], fill: float | int) -> list[np.ndarray]:
    """Pad the per-axis arrays of a 2-D grid with a third axis of one window cell."""
    if grid.dim == 3:
        return arrays
    n = arrays[0].shape[0]
    extra = np.full((n, 1), fill, dtype=arrays[0].dtype)
    return [*arrays, extra]


def _check_inputs(
    grid: CellGrid, centres: FloatArray, scale: FloatArray, values: FloatArray
) -> None:
    n = len(centres)
    if centres.ndim != 2 or centres.shape[1] != grid.dim:
        raise ConfigError("position", f"expected shape (N, {grid.dim}), got {centres.shape}")
    if scale.shape != (n,) or values.ndim != 2 or values.shape[0] != n:
        raise ValueError("scale must be (N,) and values (N, m)")


def isotropic_sums(
    grid: CellGrid,
    centres: FloatArray,
    sigma: float,
    cutoff: float,
    scale: FloatArray,
    values: FloatArray,
    backend: Backend = "auto",
) -> FloatArray:
    """The sums (*) of the module docstring for ``Sigma = sigma^2 I``.

    Parameters
    ----------
    grid : CellGrid
        2-D or 3-D.
    centres : (N, d) ndarray, metres
        Kernel centres (the reading positions).
    sigma : float, metres
        Kernel width.
    cutoff : float
        Cut-off radius in units of ``sigma``.
    scale : (N,) ndarray
        Per-reading factor ``s_i`` (1 for Kernel DM+V, a time weight for TD Kernel DM+V).
    values : (N, m) ndarray
        Per-reading values ``v_ij``.
    backend : {"auto", "numpy", "numba"}
        ``auto``: the compiled loop when numba is installed.

    Returns
    -------
    (m, n_cells) ndarray
        ``S_j`` in the C order of the grid's cells.
    """
    _check_inputs(grid, centres, scale, values)
    if backend == "numba" and not HAVE_NUMBA:
        raise ConfigError(
            "backend", "numba cannot be imported (a core dependency: reinstall odorloc)"
        )
    use_numba = backend == "numba" or (backend == "auto" and HAVE_NUMBA)
    m = values.shape[1]
    out = np.zeros((m, grid.n_cells))
    if len(centres) == 0:
        return out
    half = _half_window(cutoff * sigma / grid.cells)
    idx, diff, ok = _axis_windows(grid, centres, half)
    q = [(dd / sigma) ** 2 for dd in diff]
    # The exponentials are NumPy's in both passes (the compiled loop only multiplies and adds),
    # so that both give the same bits.
    g = [np.where(o, np.exp(-0.5 * qq), 0.0) for qq, o in zip(q, ok, strict=True)]
    idx, q, g = _padded(grid, idx, 0), _padded(grid, q, 0.0), _padded(grid, g, 1.0)
    ny = grid.shape[1]
    nz = grid.shape[2] if grid.dim == 3 else 1
    s = scale * gaussian_peak(sigma, grid.dim)
    cut2 = float(cutoff) ** 2
    window = idx[0].shape[1] * idx[1].shape[1] * idx[2].shape[1]
    chunk = max(1, _CHUNK_ELEMENTS // window)
    vals = np.ascontiguousarray(values, float)
    if use_numba:
        _iso_kernel(*idx, *g, *q, s, vals, cut2, ny, nz, chunk, out)
        return out
    for c0 in range(0, len(centres), chunk):
        sl = slice(c0, c0 + chunk)
        w = g[0][sl, :, None, None] * g[1][sl, None, :, None]
        w = w * g[2][sl, None, None, :]
        qq = q[0][sl, :, None, None] + q[1][sl, None, :, None]
        qq = qq + q[2][sl, None, None, :]
        w = np.where(qq <= cut2, w, 0.0) * s[sl, None, None, None]
        flat = (idx[0][sl, :, None, None] * ny + idx[1][sl, None, :, None]) * nz
        flat = (flat + idx[2][sl, None, None, :]).ravel()
        for j in range(m):
            contrib = (w * vals[sl, j, None, None, None]).ravel()
            out[j] += np.bincount(flat, weights=contrib, minlength=grid.n_cells)
    return out


def _iso_loop(
    ix: IntArray,
    iy: IntArray,
    iz: IntArray,
    gx: FloatArray,
    gy: FloatArray,
    gz: FloatArray,
    qx: FloatArray,
    qy: FloatArray,
    qz: FloatArray,
    s: FloatArray,
    vals: FloatArray,
    cut2: float,
    ny: int,
    nz: int,
    chunk: int,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Loop form of the NumPy pass of :func:`isotropic_sums` (same products, same order)."""
    n, m = vals.shape
    n_cells = out.shape[1]
    buf = np.zeros((m, n_cells))
    for c0 in range(0, n, chunk):
        buf[:] = 0.0
        for i in range(c0, min(c0 + chunk, n)):
            for a in range(ix.shape[1]):
                for b in range(iy.shape[1]):
                    for c in range(iz.shape[1]):
                        if qx[i, a] + qy[i, b] + qz[i, c] > cut2:
                            continue
                        w = gx[i, a] * gy[i, b] * gz[i, c] * s[i]
                        k = (ix[i, a] * ny + iy[i, b]) * nz + iz[i, c]
                        for j in range(m):
                            buf[j, k] += w * vals[i, j]
        for j in range(m):
            for k in range(n_cells):
                out[j, k] += buf[j, k]


def _warm(kernel: object) -> None:
    one_i = np.zeros((1, 1), np.int64)
    one_f = np.ones((1, 1))
    kernel(  # type: ignore[operator]
        one_i, one_i, one_i, one_f, one_f, one_f, one_f, one_f, one_f,
        np.ones(1), np.ones((1, 1)), 9.0, 1, 1, 1, np.zeros((1, 1)),
    )  # fmt: skip


_iso_kernel = jit(_iso_loop, warmup=_warm)


def anisotropic_sums(
    grid: CellGrid,
    centres: FloatArray,
    covariances: FloatArray,
    cutoff: float,
    scale: FloatArray,
    values: FloatArray,
) -> FloatArray:
    """The sums (*) of the module docstring with one covariance per reading.

    Parameters
    ----------
    grid : CellGrid
    centres : (N, d) ndarray, metres
    covariances : (N, d, d) ndarray, m^2
        Symmetric positive definite.
    cutoff : float
        Cut-off Mahalanobis distance.
    scale : (N,) ndarray
    values : (N, m) ndarray

    Returns
    -------
    (m, n_cells) ndarray
    """
    _check_inputs(grid, centres, scale, values)
    d = grid.dim
    m = values.shape[1]
    out = np.zeros((m, grid.n_cells))
    n = len(centres)
    if n == 0:
        return out
    prec = np.linalg.inv(covariances)
    det = np.linalg.det(covariances)
    s = scale * (2.0 * math.pi) ** (-0.5 * d) / np.sqrt(det)
    # each axis's reach of the cut-off ellipsoid is cutoff * sqrt(Sigma_aa)
    reach = cutoff * np.sqrt(np.einsum("naa->na", covariances))
    cut2 = float(cutoff) ** 2
    # readings are taken in order of their window's size, so that a few long kernels do not
    # size the window of every reading, and as many at a time as the memory budget allows
    sizes = np.prod(2 * _half_window(reach / grid.cells) + 1, axis=1)
    order = np.argsort(sizes, kind="stable")
    sizes = sizes[order]
    start = 0
    while start < n:
        held = np.arange(1, n - start + 1) * sizes[start:]
        count = max(1, int(np.searchsorted(held, _CHUNK_ELEMENTS, side="right")))
        sel = order[start : start + count]
        half = _half_window(reach[sel].max(axis=0) / grid.cells)
        idx, diff, ok = _axis_windows(grid, centres[sel], half)
        shape = [len(sel)] + [len(i[0]) for i in idx]
        qf = np.zeros(shape)
        valid = np.ones(shape, bool)
        flat = np.zeros(shape, np.int64)
        for a in range(d):
            ea = [len(sel)] + [1] * d
            ea[a + 1] = shape[a + 1]
            da = diff[a].reshape(ea)
            valid &= ok[a].reshape(ea)
            flat = flat * grid.shape[a] + idx[a].reshape(ea)
            for b in range(d):
                eb = [len(sel)] + [1] * d
                eb[b + 1] = shape[b + 1]
                pab = prec[sel, a, b].reshape([len(sel)] + [1] * d)
                qf = qf + pab * da * diff[b].reshape(eb)
        w = np.where(valid & (qf <= cut2), np.exp(-0.5 * qf), 0.0)
        w = w * s[sel].reshape([len(sel)] + [1] * d)
        for j in range(m):
            contrib = (w * values[sel, j].reshape([len(sel)] + [1] * d)).ravel()
            out[j] += np.bincount(flat.ravel(), weights=contrib, minlength=grid.n_cells)
        start += len(sel)
    return out
