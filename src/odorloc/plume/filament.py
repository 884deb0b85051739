"""Filament (puff) plume after Farrell et al. (2002), with GADEN-compatible parameters.

Each source releases odor filaments: Gaussian puffs whose centre is carried by the wind plus a
white-noise relative displacement and whose width grows as ``sigma^2 = sigma0^2 + gamma * age``.
The instantaneous concentration is the sum of the filaments' Gaussian kernels.

State is kept as structure-of-arrays (centres ``(F, d)``, squared widths ``(F,)``, amounts
``(F,)``) in age order, oldest first, so every step is a handful of vectorised NumPy operations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import Field
from scipy.spatial import cKDTree

from odorloc.core.errors import ConfigError
from odorloc.core.jit import HAVE_NUMBA, jit
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel

#: NumPy backend: upper bound on the candidate (point, filament) pairs held at once by a query.
PAIR_BUDGET = 4_000_000
#: Widths of filaments grouped in one culling pass differ by at most this factor.
_SIGMA_CLASS_RATIO = 1.3


class FilamentParams(Params):
    """Parameters of :class:`FilamentPlume`.

    Release rates (filaments per second) are the sources' ``rate`` (times their modulation).

    Attributes
    ----------
    sigma0 : float, metres
        Initial filament width (standard deviation of its Gaussian kernel).
    gamma : float, m^2/s
        Width growth rate: ``sigma^2 = sigma0^2 + gamma * age`` (GADEN ``filament_growth_gamma``,
        converted from cm^2/s).
    noise_std : float, m/sqrt(s)
        Relative (centre-line) dispersion: each step displaces a filament centre by
        ``noise_std * sqrt(dt)`` standard deviation per axis, so the position variance after an
        age ``a`` is ``noise_std^2 * a`` whatever ``dt`` is.
    amount : float, concentration units x m^d
        Amount of odor per filament (its kernel integrates to ``amount``).
    cutoff : float, sigmas
        A filament contributes nothing beyond ``cutoff`` standard deviations.
    max_filaments : int
        Cap on live filaments; when exceeded the oldest are dropped first.
    release : "poisson" | "deterministic"
        ``poisson``: ``Poisson(rate * dt)`` filaments per source and step; ``deterministic``: a
        per-source accumulator releases ``floor`` of the accumulated ``rate * dt``.
    integrator : "euler" | "midpoint"
        Advection of filament centres with the wind at the centre (Euler) or at the midpoint of
        the Euler step (second order in space; the wind is read at the current time).
    sensor_radius : float, metres
        Radius of the sensing disc/sphere used by :meth:`FilamentPlume.encounter_rate`.
    """

    sigma0: Positive = 0.1
    gamma: NonNegative = 0.01
    noise_std: NonNegative = 0.1
    amount: Positive = 1.0
    cutoff: float = Field(default=4.0, ge=1.0, le=10.0)
    max_filaments: int = Field(default=100_000, ge=1, le=10_000_000)
    release: Literal["poisson", "deterministic"] = "poisson"
    integrator: Literal["euler", "midpoint"] = "midpoint"
    sensor_radius: Positive = 0.1

    @classmethod
    def from_gaden(
        cls,
        *,
        initial_std_cm: float,
        growth_gamma_cm2: float,
        noise_std_m: float,
        ppm_center: float,
        time_step: float,
        dim: int = 3,
        **extra: object,
    ) -> FilamentParams:
        """Parameters from GADEN's filament settings.

        GADEN gives the initial width in cm, the growth in cm^2/s, the centre noise as a
        per-step standard deviation in metres for its simulation ``time_step`` (s) and the
        concentration at the centre of a new filament in ppm. The noise is converted to
        m/sqrt(s) and the amount chosen so that a new filament peaks at ``ppm_center``.
        """
        sigma0 = initial_std_cm / 100.0
        return cls(
            sigma0=sigma0,
            gamma=growth_gamma_cm2 / 1e4,
            noise_std=noise_std_m / float(np.sqrt(time_step)),
            amount=ppm_center * (2.0 * np.pi * sigma0**2) ** (dim / 2.0),
            **extra,
        )


def _gauss_norm(sigma2: np.ndarray, dim: int) -> np.ndarray:
    """``1 / ((2 pi)^(d/2) sigma^d)`` for squared widths ``sigma2``."""
    return (2.0 * np.pi * sigma2) ** (-0.5 * dim)


def filament_concentration(
    points: np.ndarray,
    positions: np.ndarray,
    sigma2: np.ndarray,
    amount: np.ndarray,
    cutoff: float,
    pair_budget: int = PAIR_BUDGET,
    backend: Literal["auto", "numpy", "numba"] = "auto",
) -> np.ndarray:
    """Sum of truncated Gaussian filament kernels at query points.

    A filament of amount ``m`` and width ``sigma`` adds
    ``m / ((2 pi)^(d/2) sigma^d) * exp(-r^2 / (2 sigma^2))`` where ``r < cutoff * sigma``.

    Parameters
    ----------
    points : (Q, d) ndarray, metres
    positions : (F, d) ndarray, metres
        Filament centres.
    sigma2 : (F,) ndarray, m^2
        Squared filament widths.
    amount : (F,) ndarray
        Filament amounts.
    cutoff : float
        Truncation radius in standard deviations.
    pair_budget : int
        NumPy backend: maximum number of candidate pairs held at once (memory bound).
    backend : "auto" | "numpy" | "numba"
        ``numba`` runs a compiled cell-list kernel (memory ``O(Q + F)``); ``numpy`` the k-d tree
        version; ``auto`` uses numba when it is installed. Both give the same values up to
        round-off.

    Returns
    -------
    (Q,) ndarray
        Concentration (amount per m^d).
    """
    q, f = len(points), len(positions)
    if f == 0 or q == 0 or q * f <= 50_000:
        return _concentration_numpy(points, positions, sigma2, amount, cutoff, pair_budget)
    kernel = _numba_kernel() if backend != "numpy" else None
    if kernel is None:
        if backend == "numba":
            raise ModuleNotFoundError("numba is not installed (pip install odorloc[fast])")
        return _concentration_numpy(points, positions, sigma2, amount, cutoff, pair_budget)
    return _concentration_cells(kernel, points, positions, sigma2, amount, cutoff)


def _concentration_cells(
    kernel,
    points: np.ndarray,
    positions: np.ndarray,
    sigma2: np.ndarray,
    amount: np.ndarray,
    cutoff: float,
) -> np.ndarray:
    """Cell-list evaluation: points are binned once, each filament visits nearby cells."""
    q, dim = points.shape
    lo = points.min(axis=0)
    extent = points.max(axis=0) - lo
    radius = cutoff * np.sqrt(sigma2)
    # Cells of about a typical kernel radius (measured fastest), never many more cells than points.
    h = max(float(np.median(radius)), 1e-9)
    while np.prod(np.floor(extent / h) + 1) > 4 * q + 64:
        h *= 1.5
    dims = (np.floor(extent / h) + 1).astype(np.int64)
    key = np.minimum(np.floor((points - lo) / h).astype(np.int64), dims - 1)
    cell = key[:, 0]
    for a in range(1, dim):
        cell = cell * dims[a] + key[:, a]
    order = np.argsort(cell, kind="stable")
    start = np.zeros(int(np.prod(dims)) + 1, np.int64)
    np.cumsum(np.bincount(cell, minlength=int(np.prod(dims))), out=start[1:])
    pts3 = np.zeros((q, 3))
    pts3[:, :dim] = points[order]
    pos3 = np.zeros((len(positions), 3))
    pos3[:, :dim] = positions
    lo3 = np.zeros(3)
    lo3[:dim] = lo
    dims3 = np.ones(3, np.int64)
    dims3[:dim] = dims
    coef = amount * _gauss_norm(sigma2, dim)
    acc = np.zeros(q)
    kernel(pts3, start, lo3, float(h), dims3, pos3, sigma2, coef, float(cutoff) ** 2, acc)
    out = np.empty(q)
    out[order] = acc
    return out


def _range(x: float, r: float, lo: float, h: float, n: int) -> tuple[int, int]:
    """Cells ``[i0, i1]`` of an axis (origin ``lo``, cell ``h``, ``n`` cells) within ``r`` of
    ``x``."""
    i0 = int(np.floor((x - r - lo) / h))
    i1 = int(np.floor((x + r - lo) / h))
    return max(i0, 0), min(i1, n - 1)


def _cell_kernel(pts, start, lo, h, dims, pos, sigma2, coef, cut2, out):  # pragma: no cover
    """Add every filament's truncated Gaussian to the binned points within its cutoff."""
    ny, nz = dims[1], dims[2]
    for j in range(pos.shape[0]):
        lim = cut2 * sigma2[j]
        r = np.sqrt(lim)
        inv = 0.5 / sigma2[j]
        px, py, pz = pos[j, 0], pos[j, 1], pos[j, 2]
        x0, x1 = _range(px, r, lo[0], h, dims[0])
        y0, y1 = _range(py, r, lo[1], h, ny)
        z0, z1 = _range(pz, r, lo[2], h, nz)
        cj = coef[j]
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                base = (ix * ny + iy) * nz
                for k in range(start[base + z0], start[base + z1 + 1]):
                    dx = pts[k, 0] - px
                    dy = pts[k, 1] - py
                    dz = pts[k, 2] - pz
                    d2 = dx * dx + dy * dy + dz * dz
                    if d2 < lim:
                        out[k] += cj * np.exp(-d2 * inv)


def _warm_cells(kernel: Any) -> None:
    """One call on a single point and filament, with the argument types of
    :func:`_concentration_cells`."""
    one = np.ones(1)
    kernel(
        np.zeros((1, 3)),
        np.array([0, 1], np.int64),
        np.zeros(3),
        1.0,
        np.ones(3, np.int64),
        np.zeros((1, 3)),
        one,
        one,
        9.0,
        np.zeros(1),
    )


def _advance_kernel(
    start, u, z, span, old_s2, old_amount, s0sq, amount0, gamma, noise, lo, hi, max_f
):  # type: ignore[no-untyped-def]  # pragma: no cover
    """A filament step after its draws, as :meth:`FilamentPlume._advance` computes it in NumPy:
    centres ``start + span u (+ noise sqrt(span) z)``, the ones outside the arena dropped, then
    the oldest beyond ``max_f``; widths ``sigma^2 + gamma span``. Returns the new centres,
    squared widths and amounts."""
    f, d = start.shape
    n_old = old_s2.shape[0]
    new = np.empty((f, d))
    keep = np.empty(f, np.bool_)
    kept = 0
    for i in range(f):
        inside = True
        for a in range(d):
            x = start[i, a] + span[i] * u[i, a]
            if noise > 0.0:
                x = x + (noise * math.sqrt(span[i])) * z[i, a]
            new[i, a] = x
            if not (x >= lo[a] and x <= hi[a]):
                inside = False
        keep[i] = inside
        if inside:
            kept += 1
    skip = kept - max_f if kept > max_f else 0
    m = kept - skip
    pos = np.empty((m, d))
    s2 = np.empty(m)
    am = np.empty(m)
    j = 0
    for i in range(f):
        if not keep[i]:
            continue
        if skip > 0:
            skip -= 1
            continue
        for a in range(d):
            pos[j, a] = new[i, a]
        s2[j] = (old_s2[i] if i < n_old else s0sq) + gamma * span[i]
        am[j] = old_amount[i] if i < n_old else amount0
        j += 1
    return pos, s2, am


def _warm_advance(kernel: Any) -> None:
    """One call with the argument types :meth:`FilamentPlume._advance` uses."""
    one = np.zeros((1, 2))
    kernel(
        one,
        one,
        one,
        np.ones(1),
        np.zeros(0),
        np.zeros(0),
        0.01,
        1.0,
        0.01,
        0.1,
        np.zeros(2),
        np.ones(2),
        10,
    )


if HAVE_NUMBA:
    # module-level kernels (the helper first: the kernel resolves it as a global when it
    # compiles), so the cache hits in every later process (see odorloc.core.jit)
    _range = jit(_range)
    _cell_kernel = jit(_cell_kernel, warmup=_warm_cells)
    _advance_kernel = jit(_advance_kernel, warmup=_warm_advance)


def _numba_kernel():
    """The compiled cell-list kernel, or ``None`` without numba."""
    return _cell_kernel if HAVE_NUMBA else None


def _concentration_numpy(
    points: np.ndarray,
    positions: np.ndarray,
    sigma2: np.ndarray,
    amount: np.ndarray,
    cutoff: float,
    pair_budget: int = PAIR_BUDGET,
) -> np.ndarray:
    """NumPy/SciPy reference of :func:`filament_concentration`.

    Filaments are grouped by width (ratio <= 1.3 within a group); per group, point/filament
    pairs closer than the group's cutoff radius are found with k-d trees and the kernels are
    evaluated on those pairs only. Query points are processed in spatially compact chunks sized
    so that at most ``pair_budget`` candidate pairs can exist at once.
    """
    q, dim = points.shape
    out = np.zeros(q)
    f = len(positions)
    if f == 0 or q == 0:
        return out
    # Small problems: one dense block is cheaper than building trees.
    if q * f <= 50_000:
        d2 = ((points[:, None, :] - positions[None, :, :]) ** 2).sum(axis=2)
        w = np.where(d2 < cutoff**2 * sigma2, np.exp(-0.5 * d2 / sigma2), 0.0)
        return w @ (amount * _gauss_norm(sigma2, dim))
    order = np.argsort(sigma2, kind="stable")
    s2s = sigma2[order]
    cls = np.floor(0.5 * np.log(s2s / s2s[0]) / np.log(_SIGMA_CLASS_RATIO)).astype(np.intp)
    bounds = np.flatnonzero(np.diff(cls)) + 1
    starts = np.concatenate([[0], bounds])
    stops = np.concatenate([bounds, [f]])
    groups = []
    for a, b in zip(starts, stops, strict=True):
        idx = order[a:b]
        radius = cutoff * float(np.sqrt(s2s[b - 1]))
        groups.append((cKDTree(positions[idx]), idx, radius))
    # Per-filament factors, so that each pair costs one gather, one exp and one multiply.
    coef = amount * _gauss_norm(sigma2, dim)
    inv = 0.5 / sigma2
    lim = 0.5 * cutoff**2
    # Chunks small enough that even if every filament of a group reached every point of the
    # chunk, no more than ``pair_budget`` pairs would exist: memory is bounded in all cases.
    largest = max(len(g[1]) for g in groups)
    chunk = max(1, pair_budget // largest)
    if q > chunk:
        # Spatially sorted points make chunk trees compact (fewer pairs per chunk).
        lo = points.min(axis=0)
        cell = max(float(np.max(points.max(axis=0) - lo)) / 64.0, 1e-12)
        key = np.floor((points - lo) / cell).astype(np.int64)
        pkey = key[:, 0]
        for a in range(1, dim):
            pkey = pkey * 65 + key[:, a]
        porder = np.argsort(pkey, kind="stable")
    else:
        porder = np.arange(q)
    for a in range(0, q, chunk):
        sel = porder[a : a + chunk]
        ptree = cKDTree(points[sel])
        acc = np.zeros(len(sel))
        for tree, idx, r in groups:
            pairs = ptree.sparse_distance_matrix(tree, r, output_type="ndarray")
            if len(pairs) == 0:
                continue
            j = idx[pairs["j"]]
            arg = pairs["v"] ** 2 * inv[j]
            w = np.where(arg < lim, coef[j] * np.exp(-arg), 0.0)
            acc += np.bincount(pairs["i"], weights=w, minlength=len(sel))
        out[sel] = acc
    return out


@register("plume", "filament", FilamentParams, "Farrell/GADEN filament (puff) plume, 2D/3D")
class FilamentPlume(PlumeModel):
    """Filament (puff) plume (Farrell et al. 2002; GADEN-compatible parameters).

    Step (``dt``), in order:

    1. release ``Poisson(rate(t + dt/2) * dt)`` new filaments per source (or, with
       ``release="deterministic"``, the whole part of a per-source accumulator of
       ``rate * dt``); each gets a uniform random age ``a`` in ``[0, dt)`` and during this step
       moves and grows for ``a`` instead of ``dt``, so releases do not clump at step boundaries;
    2. advect every centre over its time span ``s`` (``dt``, or ``a``) with the current wind,
       Euler or midpoint, plus ``noise_std * sqrt(s) * N(0, I)`` (dispersion independent of
       ``dt``);
    3. obstacles: a filament whose step would end in, or pass through, an obstacle cell stays
       where it was for this step (it still grows; the noise lets it slide along the wall in
       later steps); filaments leaving the arena are removed;
    4. grow: ``sigma^2 += gamma * s``;
    5. if more than ``max_filaments`` are alive, drop the oldest.

    Kernels are not clipped at walls: near an obstacle some odor "leaks" into the occupied
    cells' volume (only the filament centres are kept out).

    :meth:`encounter_rate` is the expected number of filaments per second passing through the
    sensor's cross-section (a segment of length ``2a`` in 2D, a disc of area ``pi a^2`` in 3D,
    ``a = sensor_radius``): ``|u(x)| * A * n(x)``, where ``n`` is the filament number density
    obtained by smearing each filament centre with its own Gaussian kernel.
    """

    def __init__(
        self,
        params: FilamentParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        self._src = self.source_positions
        self._clear()

    def _sources_changed(self) -> None:
        self._src = self.source_positions
        self._clear()

    # ------------------------------------------------------------------ state
    def _clear(self) -> None:
        d = self.dim
        self.positions = np.zeros((0, d))
        self.sigma2 = np.zeros(0)
        self.amount = np.zeros(0)
        self._accum = np.zeros(len(self.sources))

    @property
    def n_filaments(self) -> int:
        """Number of live filaments."""
        return len(self.sigma2)

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self._clear()

    def _blocked(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """``True`` where the segment start->end touches an obstacle cell, ``(F,)``."""
        arena = self.arena
        if arena.occ is None or len(start) == 0:
            return np.zeros(len(start), bool)
        step = float(np.sqrt(((end - start) ** 2).sum(axis=1).max()))
        # Check the end point, plus intermediate points when steps are longer than half a cell.
        n = max(1, int(np.ceil(step / (0.5 * arena.resolution))))
        blocked = np.zeros(len(start), bool)
        for k in range(1, n + 1):
            p = start + (k / n) * (end - start)
            inside = arena.contains(p)
            idx = arena.cell_index(p)
            blocked |= inside & arena.occ[tuple(idx.T)]
        return blocked

    def _advection(self, pos: np.ndarray, dtc: np.ndarray) -> np.ndarray:
        """The wind that carries each centre over its ``dtc`` ``(F, 1)``: at the centre (Euler)
        or at the Euler step's midpoint."""
        u = self.wind.velocity(pos)
        if self.params.integrator == "midpoint":
            u = self.wind.velocity(pos + 0.5 * dtc * u)
        return u

    def _move(self, pos: np.ndarray, dt: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """New centres after advection + relative dispersion over per-filament ``dt`` ``(F,)``."""
        p = self.params
        dtc = np.asarray(dt, float)[:, None]
        u = self._advection(pos, dtc)
        new = pos + dtc * u
        if p.noise_std > 0:
            new += (p.noise_std * np.sqrt(dtc)) * rng.standard_normal(pos.shape)
        return new

    def check_step(self, dt: float) -> None:
        """Refuse a source that would release more filaments in one step than may be alive
        (at its peak, modulation included)."""
        self._check_release(np.array([s.peak_rate for s in self.sources]) * dt, dt)

    def _check_release(self, released: np.ndarray, dt: float) -> None:
        """Refuse more filaments released in one step (``released``, per source) than
        ``max_filaments``: the arrays of one step alone would be huge, or the count overflow."""
        if released.size and not released.max() <= self.params.max_filaments:
            k = int(np.argmax(released))
            raise ConfigError(
                f"world.sources[{k}].rate",
                f"releases {released[k]:.3g} filaments in one {dt:g} s step; at most "
                f"world.plume.max_filaments ({self.params.max_filaments})",
            )

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        p = self.params
        arena = self.arena
        rates = np.array([s.rate_at(self.t + 0.5 * dt) for s in self.sources]) * dt
        # scenarios are checked when built (check_step); this guards other step sizes
        self._check_release(rates, dt)
        if p.release == "poisson":
            counts = rng.poisson(rates)
        else:
            self._accum += rates
            counts = np.floor(self._accum + 1e-12).astype(np.intp)
            self._accum -= counts
        total = int(counts.sum())
        n_old = self.n_filaments
        if n_old + total == 0:
            return
        # New filaments join the step with their release age; one wind query serves all.
        age = rng.uniform(0.0, dt, total)
        start = np.concatenate([self.positions, np.repeat(self._src, counts, axis=0)])
        span = np.concatenate([np.full(n_old, dt), age])
        if HAVE_NUMBA and arena.occ is None:
            # the same draws and the same arithmetic in one compiled pass (equal to the bit)
            u = self._advection(start, span[:, None])
            noisy = p.noise_std > 0
            z = rng.standard_normal(start.shape) if noisy else np.zeros((0, self.dim))
            self.positions, self.sigma2, self.amount = _advance_kernel(
                start,
                np.array(u, float, order="C"),
                z,
                span,
                self.sigma2,
                self.amount,
                p.sigma0**2,
                p.amount,
                p.gamma,
                p.noise_std if noisy else 0.0,
                np.array(arena.lo, float),
                np.array(arena.hi, float),
                p.max_filaments,
            )
            return
        new = self._move(start, span, rng)
        if arena.occ is not None:
            blocked = self._blocked(start, new)
            if blocked.any():
                new[blocked] = start[blocked]
        keep = arena.contains(new)
        sigma2 = np.concatenate([self.sigma2, np.full(total, p.sigma0**2)]) + p.gamma * span
        amount = np.concatenate([self.amount, np.full(total, p.amount)])
        if not keep.all():
            new, sigma2, amount = new[keep], sigma2[keep], amount[keep]
        extra = len(sigma2) - p.max_filaments
        if extra > 0:
            new, sigma2, amount = new[extra:], sigma2[extra:], amount[extra:]
        self.positions, self.sigma2, self.amount = new, sigma2, amount

    # ------------------------------------------------------------------ queries
    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return filament_concentration(
            points, self.positions, self.sigma2, self.amount, self.params.cutoff
        )

    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        a = self.params.sensor_radius
        area = 2.0 * a if self.dim == 2 else np.pi * a * a
        density = filament_concentration(
            points, self.positions, self.sigma2, np.ones(self.n_filaments), self.params.cutoff
        )
        speed = np.linalg.norm(self.wind.velocity(points), axis=1)
        return speed * area * density

    def frame(self) -> dict[str, np.ndarray]:
        return {
            "model": np.array("filament"),
            "positions": self.positions.copy(),
            "sigma2": self.sigma2.copy(),
            "amount": self.amount.copy(),
            "cutoff": np.array(float(self.params.cutoff)),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        return filament_concentration(
            points,
            np.asarray(frame["positions"], float),
            np.asarray(frame["sigma2"], float),
            np.asarray(frame["amount"], float),
            float(frame["cutoff"]),
        )
