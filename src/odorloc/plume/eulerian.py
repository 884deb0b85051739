"""Eulerian advection-diffusion of concentration on a regular grid (finite volumes).

Solves ``dc/dt + div(u c) = D lap(c) + sum_s Q_s(t) delta(x - x_s)`` on the arena's grid with
explicit first-order upwind advection and central diffusion, written as face fluxes so that mass
moves only between neighbouring cells (exact conservation up to round-off).

- The wind is sampled at face centres once per :meth:`EulerianPlume.step` (the current wind).
- Each step is split into equal substeps small enough that the update is positive (no
  undershoot): with ``A`` the largest total outflow speed of a cell divided by the cell size and
  ``B = 2 d D / h^2``, the substep is ``dt_s <= 1 / (A / cfl + B)``, so ``A dt_s <= cfl`` and
  ``(A + B) dt_s <= 1``.
- Faces touching an obstacle cell carry no flux. At the arena boundary, ``boundary="open"`` lets
  air leave with its concentration and enter with zero concentration (no diffusive flux through
  the boundary); ``boundary="closed"`` blocks every boundary face.
- A source adds ``rate_at(t) * dt_s`` of mass each substep: to the cell containing it
  (``deposit="cell"``), or shared between the ``2^d`` cells around it with the weights of the
  multilinear interpolation that reads the field (``deposit="linear"``, cloud-in-cell), so that
  the centre of the released mass is the source position itself and not the centre of its cell
  (up to ``h sqrt(d) / 2`` away: a source on a cell corner sits half a cell off in every axis).

First-order upwinding adds numerical diffusion along the flow. At steady state the time step
drops out and the scheme solves the advection-diffusion equation with the diffusivity
``D + |u_a| h / 2`` along each axis ``a`` (the leading term of its truncation error):
:func:`upwind_diffusivity`. Where ``|u| h / 2`` is comparable with ``D`` the plume spreads
along the wind, and reaches upwind of its source, as if ``D`` were that much larger.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena, as_points
from odorloc.geometry.grid import CellGrid
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel


class EulerianParams(Params):
    """Parameters of :class:`EulerianPlume`.

    Attributes
    ----------
    cell : float or None, metres
        Grid cell size; ``None`` uses the arena's occupancy resolution.
    D : float, m^2/s
        Diffusivity.
    boundary : "open" | "closed"
        Arena boundary condition (see module docstring).
    cfl : float
        Target Courant number of the advective part, in (0, 1].
    max_substeps : int
        Refuse steps needing more substeps than this (a too-large ``dt`` or ``D``).
    deposit : "cell" | "linear"
        Where a source's mass goes (see module docstring).
    """

    cell: Positive | None = None
    D: NonNegative = 0.05
    boundary: Literal["open", "closed"] = "open"
    cfl: float = Field(default=0.5, gt=0.0, le=1.0)
    max_substeps: int = Field(default=100_000, ge=1, le=10_000_000)
    deposit: Literal["cell", "linear"] = "cell"


def upwind_diffusivity(D: float, speed: float, h: float) -> float:
    """Effective diffusivity (m^2/s) of the steady first-order upwind scheme along an axis on
    which the wind component is ``speed`` (m/s), for cells of size ``h`` (m): ``D + |u| h / 2``
    (see the module docstring)."""
    return float(D) + 0.5 * abs(float(speed)) * float(h)


def _sl(dim: int, axis: int, s: slice) -> tuple[slice, ...]:
    idx = [slice(None)] * dim
    idx[axis] = s
    return tuple(idx)


def grid_interpolate(
    field: np.ndarray, lower: np.ndarray, h: float, points: np.ndarray
) -> np.ndarray:
    """Multilinear interpolation of a cell-centred field at points (edge values held outside).

    ``field`` ``(n1, ..., nd)`` holds the values at the cell centres ``lower + (i + 0.5) h`` of a
    :class:`~odorloc.geometry.grid.CellGrid`; returns ``(Q,)``.
    """
    grid = CellGrid(tuple(float(v) for v in lower), float(h), field.shape)
    return grid.interpolate(field, points)


@register("plume", "eulerian", EulerianParams, "grid advection-diffusion (finite volume), 2D/3D")
class EulerianPlume(PlumeModel):
    """Finite-volume advection-diffusion plume on a regular grid (2D and 3D).

    ``c`` is the cell-average concentration (mass per m^d). :meth:`gradient` and
    :meth:`mass_flux` serve gradient- and flux-following searchers.
    """

    def __init__(
        self,
        params: EulerianParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        h = float(params.cell) if params.cell is not None else arena.resolution
        self.h = h
        self.grid = CellGrid.from_extent(arena.lower, arena.upper, h, rounding="ceil")
        self.lower = arena.lo.copy()
        self.shape = self.grid.shape
        d = self.dim
        centers = [self.grid.axis_centers(a) for a in range(d)]
        mesh = self.grid.flat_centers()
        self.solid = arena.in_obstacle(mesh).reshape(self.shape)
        self._faces: list[np.ndarray] = []
        self._open: list[np.ndarray] = []
        self._interior: list[np.ndarray] = []
        for a in range(d):
            axes = list(centers)
            axes[a] = self.lower[a] + np.arange(self.shape[a] + 1) * h
            fshape = tuple(len(x) for x in axes)
            self._faces.append(np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d))
            pad = np.pad(self.solid, [(1, 1) if b == a else (0, 0) for b in range(d)])
            blocked = pad[_sl(d, a, slice(None, -1))] | pad[_sl(d, a, slice(1, None))]
            interior = np.zeros(fshape, bool)
            interior[_sl(d, a, slice(1, -1))] = True
            if params.boundary == "closed":
                blocked = blocked | ~interior
            self._open.append((~blocked).astype(float))
            self._interior.append(interior.astype(float))
        self._sources_changed()
        self.c = np.zeros(self.shape)

    def _sources_changed(self) -> None:
        cells = self.grid.index(self.source_positions)
        for k, solid in enumerate(self.solid[tuple(cells.T)]):
            if solid:
                raise ConfigError(
                    f"world.sources[{k}].position",
                    f"lies in an obstacle cell of the {self.h:g} m grid",
                )
        self._deposits = [
            self._linear_cells(p) if self.params.deposit == "linear" else (tuple(c[:, None]), None)
            for p, c in zip(self.source_positions, cells, strict=True)
        ]

    def _linear_cells(self, point: np.ndarray) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
        """Cells around ``point`` and their multilinear weights (free cells only, summing to 1)."""
        g = (point - self.lower) / self.h - 0.5  # position in cells from the first centre
        weights: dict[tuple[int, ...], float] = {}
        for corner in itertools.product((0, 1), repeat=self.dim):
            cell, w = [], 1.0
            for a, hi in enumerate(corner):
                n = self.shape[a]
                i0 = int(np.clip(np.floor(g[a]), 0, max(n - 2, 0)))
                f = float(np.clip(g[a] - i0, 0.0, 1.0)) if n > 1 else 0.0
                cell.append(min(i0 + hi, n - 1))
                w *= f if hi else 1.0 - f
            key = tuple(cell)
            if not self.solid[key]:
                weights[key] = weights.get(key, 0.0) + w
        keys = [k for k, w in weights.items() if w > 0.0]
        w = np.array([weights[k] for k in keys])
        return tuple(np.array(keys, np.intp).T), w / w.sum()

    # ------------------------------------------------------------------ state
    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self.c = np.zeros(self.shape)

    @property
    def cell_volume(self) -> float:
        """Cell volume (area in 2D), m^d."""
        return self.grid.cell_volume

    def total_mass(self) -> float:
        """Mass on the grid (concentration x volume)."""
        return float(self.c.sum() * self.cell_volume)

    def face_velocities(self) -> list[np.ndarray]:
        """Normal wind component at every face, one array per axis (``n_a + 1`` along it), m/s."""
        out = []
        for a, pts in enumerate(self._faces):
            fshape = list(self.shape)
            fshape[a] += 1
            out.append(self.wind.velocity(pts)[:, a].reshape(fshape))
        return out

    def max_substep(self, faces: list[np.ndarray]) -> float:
        """Largest positive-preserving substep for the given face velocities, seconds."""
        d = self.dim
        out = np.zeros(self.shape)
        for a, u in enumerate(faces):
            uo = u * self._open[a]
            out += np.maximum(uo[_sl(d, a, slice(1, None))], 0.0)
            out += np.maximum(-uo[_sl(d, a, slice(None, -1))], 0.0)
        adv = float(out.max()) / self.h
        dif = 2.0 * d * self.params.D / self.h**2
        rate = adv / self.params.cfl + dif
        return np.inf if rate == 0 else 1.0 / rate

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        faces = self.face_velocities()
        n = max(1, int(np.ceil(dt / self.max_substep(faces) - 1e-9)))
        if n > self.params.max_substeps:
            raise ConfigError(
                "dt", f"{dt:g} s needs {n} substeps (> max_substeps={self.params.max_substeps})"
            )
        ds = dt / n
        d, h, D = self.dim, self.h, self.params.D
        vol = self.cell_volume
        c = self.c.copy()
        # Per axis, buffers reused by every substep: the field padded by one zero cell at both
        # ends, the face flux and the flux difference; the upwind split of the face velocities
        # and the diffusion coefficient are fixed for the whole step.
        axes = []
        for a in range(d):
            u = faces[a]
            pad_shape = list(self.shape)
            pad_shape[a] += 2
            cp = np.zeros(pad_shape)
            axes.append(
                (
                    cp,
                    cp[_sl(d, a, slice(1, -1))],
                    cp[_sl(d, a, slice(None, -1))],
                    cp[_sl(d, a, slice(1, None))],
                    np.maximum(u, 0.0),
                    np.minimum(u, 0.0),
                    np.empty(u.shape),
                    np.empty(u.shape),
                    np.empty(self.shape),
                    a,
                )
            )
        div = np.empty(self.shape)
        for k in range(n):
            div.fill(0.0)
            for _, inner, cl, cr, up, um, flux, tmp, dif, a in axes:
                inner[...] = c
                np.multiply(up, cl, out=flux)
                np.multiply(um, cr, out=tmp)
                flux += tmp
                if D > 0:
                    np.subtract(cr, cl, out=tmp)
                    tmp *= D / h
                    tmp *= self._interior[a]
                    flux -= tmp
                flux *= self._open[a]
                np.subtract(
                    flux[_sl(d, a, slice(1, None))], flux[_sl(d, a, slice(None, -1))], out=dif
                )
                div += dif
            div *= ds / h
            c -= div
            tk = self.t + (k + 0.5) * ds
            for s, (idx, w) in zip(self.sources, self._deposits, strict=True):
                q = s.rate_at(tk) * ds / vol
                c[idx] += q if w is None else q * w
        self.c = c

    # ------------------------------------------------------------------ queries
    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return self.grid.interpolate(self.c, points)

    def gradient(self, points: ArrayLike) -> np.ndarray:
        """Concentration gradient at ``(Q, d)`` points, ``(Q, d)`` (units per metre).

        Central differences of the cell field (one-sided at the grid edge), interpolated.
        """
        p = as_points(points, self.dim)
        if min(self.shape) < 2:
            return np.zeros_like(p)
        grads = np.gradient(self.c, self.h)
        grads = grads if isinstance(grads, (list, tuple)) else [grads]
        return np.stack([self.grid.interpolate(g, p) for g in grads], axis=1)

    def mass_flux(self, points: ArrayLike) -> np.ndarray:
        """Advective mass flux ``rho v`` at ``(Q, d)`` points, ``(Q, d)`` (units x m/s)."""
        p = as_points(points, self.dim)
        return self._concentration(p)[:, None] * self.wind.velocity(p)

    def frame(self) -> dict[str, np.ndarray]:
        return {
            "model": np.array("eulerian"),
            "c": self.c.copy(),
            "lower": self.lower.copy(),
            "h": np.array(self.h),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        return grid_interpolate(
            np.asarray(frame["c"], float),
            np.asarray(frame["lower"], float),
            float(frame["h"]),
            points,
        )
