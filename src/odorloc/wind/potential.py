"""Steady, obstacle-aware indoor flow: incompressible potential flow on the occupancy grid.

The velocity is ``u = -grad phi`` with ``lap phi = 0`` in the free cells of the arena's occupancy
grid, solved once at construction by finite volumes (one unknown per free cell, scipy sparse
direct solve):

* walls and obstacle faces: ``d phi / dn = 0`` (no flow through them);
* inlets (a fan, a supply vent): prescribed inflow speed on a boundary segment;
* outlets: ``phi = 0`` on the segment (the flow leaves wherever it likes along it), or a
  prescribed outflow speed (then inflow and outflow must balance, the potential is pinned at
  one cell).

Velocities live on cell faces (a staggered grid), so the discrete divergence of every free cell
vanishes to solver precision. Inside a cell the velocity is interpolated with the lowest-order
Raviart-Thomas rule (``u_x`` linear in x between the cell's left and right faces, ``u_y`` linear
in y between its bottom and top faces): the normal velocity at a wall or obstacle face is then
exactly zero, the interpolated field is divergence free inside every cell, and obstacle cells
(all faces closed) have zero velocity.

Optional time variation (``modulation``): ``"scale"`` multiplies the whole field by
``1 + speed_std * x(t)`` (clipped at 0), which keeps it divergence free and wall-tangent;
``"rotate"`` additionally rotates every vector by a bounded direction swing (as in
:class:`~odorloc.wind.meander.MeanderWind`), an approximation that breaks the no-through-flow
condition at walls while the swing is non-zero. ``x(t)`` is second-order coloured noise.

In 3D arenas the flow is extruded: a cell column is blocked if any of its cells is occupied,
and the vertical component is the constant ``vertical``.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import scipy.sparse as sp
from pydantic import field_validator, model_validator
from scipy.ndimage import label
from scipy.sparse.linalg import spsolve

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.wind.base import WindModel
from odorloc.wind.meander import SecondOrderNoise, SwingMode, swing

Side = Literal["left", "right", "bottom", "top"]


class Opening(Params):
    """A boundary segment where air enters (inlet) or leaves (outlet).

    side : {"left", "right", "bottom", "top"}
        Arena face (``left`` is x = lower x, ``bottom`` is y = lower y).
    interval : (2,) tuple of float, metres, optional
        Coordinate range along that face (y for left/right, x for bottom/top); whole face when
        omitted. A boundary face belongs to the opening when its centre lies in the interval.
    speed : float, m/s, optional
        Normal speed through the opening. Required for inlets; for outlets ``None`` means
        ``phi = 0`` (free outflow distribution).
    """

    side: Side
    interval: tuple[Finite, Finite] | None = None
    speed: NonNegative | None = None

    @model_validator(mode="after")
    def _check(self) -> Opening:
        if self.interval is not None and self.interval[1] <= self.interval[0]:
            raise ValueError("interval must be (start, end) with end > start")
        return self


class PotentialWindParams(Params):
    """Parameters of :class:`PotentialWind`.

    inlets : tuple of Opening
        At least one, each with a ``speed`` > 0. Default: the whole left face at 1 m/s.
    outlets : tuple of Opening
        At least one. Default: the whole right face with ``phi = 0``.
    modulation : {"none", "scale", "rotate"}
        Optional coloured-noise time variation (module docstring).
    speed_std : float
        Relative standard deviation of the speed factor (dimensionless).
    direction_swing : float, degrees
        Swing amplitude for ``rotate``.
    swing_mode : {"tanh", "clip", "gaussian"}
        How the noise maps to the direction deviation, as for the meander wind.
    frequency, frequency_factor, damping
        Second-order noise settings (Hz, multiplier, damping ratio).
    vertical : float, m/s
        Constant vertical component in 3D arenas.
    """

    inlets: tuple[Opening, ...] = (Opening(side="left", speed=1.0),)
    outlets: tuple[Opening, ...] = (Opening(side="right"),)
    modulation: Literal["none", "scale", "rotate"] = "none"
    speed_std: NonNegative = 0.1
    direction_swing: NonNegative = 10.0
    swing_mode: SwingMode = "tanh"
    frequency: Positive = 0.05
    frequency_factor: Positive = 1.0
    damping: Positive = 0.7
    vertical: Finite = 0.0

    @field_validator("inlets")
    @classmethod
    def _check_inlets(cls, v: tuple[Opening, ...]) -> tuple[Opening, ...]:
        if not v:
            raise ValueError("at least one inlet is required")
        for k, o in enumerate(v):
            if o.speed is None or o.speed <= 0:
                raise ValueError(f"inlet {k} needs a speed > 0")
        return v

    @field_validator("outlets")
    @classmethod
    def _check_outlets(cls, v: tuple[Opening, ...]) -> tuple[Opening, ...]:
        if not v:
            raise ValueError("at least one outlet is required")
        return v


_AXIS = {"left": 0, "right": 0, "bottom": 1, "top": 1}


@register("wind", "potential", PotentialWindParams, "steady potential flow around obstacles")
class PotentialWind(WindModel):
    """Incompressible, irrotational steady flow from inlets to outlets around obstacles.

    Attributes
    ----------
    ux : (nx + 1, ny) ndarray, m/s
        x velocity on the x-faces of the occupancy grid.
    uy : (nx, ny + 1) ndarray, m/s
        y velocity on the y-faces.
    phi : (nx, ny) ndarray
        Velocity potential (NaN in blocked cells), m^2/s.
    """

    def __init__(self, params: PotentialWindParams, arena: Arena) -> None:
        super().__init__(arena)
        self.params = params
        self.deterministic = params.modulation == "none"
        occ = arena.occ
        shape = arena.grid_shape[:2]
        if occ is None:
            blocked = np.zeros(shape, bool)
        else:
            blocked = occ.any(axis=2) if occ.ndim == 3 else occ.copy()
        self.fluid = ~blocked
        self.h = float(arena.resolution)
        self.nx, self.ny = shape
        self._in_faces: list[tuple[str, np.ndarray, float]] = []
        self._out_faces: list[tuple[str, np.ndarray, float | None]] = []
        taken: dict[str, np.ndarray] = {}
        for kind, lst, store in (
            ("inlets", params.inlets, self._in_faces),
            ("outlets", params.outlets, self._out_faces),
        ):
            for k, o in enumerate(lst):
                mask = self._opening_mask(o, f"wind.{kind}[{k}]")
                prev = taken.get(o.side)
                if prev is not None and np.any(prev & mask):
                    raise ConfigError(f"wind.{kind}[{k}].interval", "overlaps another opening")
                taken[o.side] = mask if prev is None else prev | mask
                store.append((o.side, mask, o.speed))
        self._solve()
        self.noise = SecondOrderNoise(
            2, 2.0 * math.pi * params.frequency * params.frequency_factor, params.damping
        )

    # ------------------------------------------------------------------ set-up
    def _opening_mask(self, o: Opening, field: str) -> np.ndarray:
        """Boolean mask over the boundary faces of ``o.side`` that belong to the opening."""
        ax = 1 - _AXIS[o.side]  # the axis running along the face
        lo, hi = self.arena.lower[ax], self.arena.upper[ax]
        n = self.ny if ax == 1 else self.nx
        centres = lo + (np.arange(n) + 0.5) * self.h
        if o.interval is None:
            mask = np.ones(n, bool)
        else:
            a, b = o.interval
            if a < lo - 1e-9 or b > hi + 1e-9:
                raise ConfigError(f"{field}.interval", f"must lie within [{lo:g}, {hi:g}]")
            mask = (centres >= a - 1e-9) & (centres <= b + 1e-9)
        mask &= self._edge_cells(o.side)
        if not mask.any():
            raise ConfigError(f"{field}.interval", "covers no open boundary face")
        return mask

    def _edge_cells(self, side: str) -> np.ndarray:
        f = self.fluid
        return {"left": f[0, :], "right": f[-1, :], "bottom": f[:, 0], "top": f[:, -1]}[side]

    @staticmethod
    def _edge_index(side: str, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
        """Cell indices ``(i, j)`` along a side, in the order of :meth:`_opening_mask`."""
        if side == "left":
            return np.zeros(ny, np.intp), np.arange(ny)
        if side == "right":
            return np.full(ny, nx - 1, np.intp), np.arange(ny)
        if side == "bottom":
            return np.arange(nx), np.zeros(nx, np.intp)
        return np.arange(nx), np.full(nx, ny - 1, np.intp)

    def _solve(self) -> None:
        nx, ny, h, f = self.nx, self.ny, self.h, self.fluid
        idx = -np.ones((nx, ny), np.intp)
        idx[f] = np.arange(int(f.sum()))
        n = int(f.sum())
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []
        b = np.zeros(n)
        # Interior faces between two free cells: outward velocity (phi_c - phi_n) / h.
        for a_, b_ in (
            (idx[:-1, :][f[:-1, :] & f[1:, :]], idx[1:, :][f[:-1, :] & f[1:, :]]),
            (idx[:, :-1][f[:, :-1] & f[:, 1:]], idx[:, 1:][f[:, :-1] & f[:, 1:]]),
        ):
            rows += [a_, b_, a_, b_]
            cols += [a_, b_, b_, a_]
            one = np.full(a_.shape, 1.0 / h)
            vals += [one, one, -one, -one]
        dirichlet = np.zeros(n, bool)
        for side, mask, speed in self._in_faces:
            i, j = self._edge_index(side, nx, ny)
            np.add.at(b, idx[i[mask], j[mask]], speed)
        for side, mask, speed in self._out_faces:
            i, j = self._edge_index(side, nx, ny)
            c = idx[i[mask], j[mask]]
            if speed is None:
                rows.append(c)
                cols.append(c)
                vals.append(np.full(c.shape, 2.0 / h))
                dirichlet[c] = True
            else:
                np.add.at(b, c, -speed)
        A = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        ).tolil()
        # Each connected free region without a phi = 0 face has phi defined up to a constant:
        # pin one cell. For the region holding the openings this needs balanced fluxes.
        lab, nlab = label(f)
        lab_flat = lab[f]
        for k in range(1, nlab + 1):
            members = np.flatnonzero(lab_flat == k)
            if dirichlet[members].any():
                continue
            net = b[members].sum()
            if abs(net) > 1e-9 * (np.abs(b[members]).sum() + 1e-300):
                raise ConfigError(
                    "wind.outlets",
                    f"inflow and prescribed outflow do not balance ({net * h:+.4g} m^2/s); "
                    "give an outlet without speed (phi = 0) or balance the speeds",
                )
            c0 = members[0]
            A.rows[c0] = [c0]
            A.data[c0] = [1.0]
            b[c0] = 0.0
        phi_free = spsolve(A.tocsr(), b)
        phi = np.full((nx, ny), np.nan)
        phi[f] = phi_free
        self.phi = phi
        # Face velocities u = -grad phi.
        ux = np.zeros((nx + 1, ny))
        uy = np.zeros((nx, ny + 1))
        both = f[:-1, :] & f[1:, :]
        ux[1:-1, :][both] = ((phi[:-1, :] - phi[1:, :]) / h)[both]
        both = f[:, :-1] & f[:, 1:]
        uy[:, 1:-1][both] = ((phi[:, :-1] - phi[:, 1:]) / h)[both]
        sign = {"left": 1.0, "bottom": 1.0, "right": -1.0, "top": -1.0}
        for side, mask, speed in self._in_faces:
            self._set_faces(ux, uy, side, mask, sign[side] * speed)
        for side, mask, speed in self._out_faces:
            i, j = self._edge_index(side, nx, ny)
            if speed is None:
                out = 2.0 * phi[i[mask], j[mask]] / h
            else:
                out = np.full(int(mask.sum()), speed)
            self._set_faces(ux, uy, side, mask, -sign[side] * out)
        self.ux, self.uy = ux, uy

    @staticmethod
    def _set_faces(
        ux: np.ndarray, uy: np.ndarray, side: str, mask: np.ndarray, value: np.ndarray | float
    ) -> None:
        if side == "left":
            ux[0, mask] = value
        elif side == "right":
            ux[-1, mask] = value
        elif side == "bottom":
            uy[mask, 0] = value
        else:
            uy[mask, -1] = value

    # ------------------------------------------------------------------ diagnostics
    def divergence(self) -> np.ndarray:
        """Discrete divergence of the face velocities per cell, ``(nx, ny)`` 1/s."""
        return (np.diff(self.ux, axis=0) + np.diff(self.uy, axis=1)) / self.h

    def inflow_rate(self) -> float:
        """Volume flux entering through the inlets per unit height, m^2/s."""
        return self._opening_flux(self._in_faces, inward=True)

    def outflow_rate(self) -> float:
        """Volume flux leaving through the outlets per unit height, m^2/s."""
        return self._opening_flux(self._out_faces, inward=False)

    def _opening_flux(self, faces: list, inward: bool) -> float:
        sign = {"left": 1.0, "bottom": 1.0, "right": -1.0, "top": -1.0}
        total = 0.0
        for side, mask, _ in faces:
            vals = {
                "left": self.ux[0, :],
                "right": self.ux[-1, :],
                "bottom": self.uy[:, 0],
                "top": self.uy[:, -1],
            }[side][mask]
            s = sign[side] if inward else -sign[side]
            total += float(np.sum(s * vals)) * self.h
        return total

    # ------------------------------------------------------------------ dynamics
    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        if not self.deterministic:
            self.noise.reset(rng)

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        if not self.deterministic:
            self.noise.step(dt, rng)

    def base_velocity(self, points: np.ndarray) -> np.ndarray:
        """The steady (unmodulated) potential flow at ``(Q, d)`` points, ``(Q, d)`` m/s."""
        lo = self.arena.lo[:2]
        g = (points[:, :2] - lo) / self.h
        g[:, 0] = np.clip(g[:, 0], 0.0, self.nx)
        g[:, 1] = np.clip(g[:, 1], 0.0, self.ny)
        i = np.minimum(g[:, 0].astype(np.intp), self.nx - 1)
        j = np.minimum(g[:, 1].astype(np.intp), self.ny - 1)
        s = g[:, 0] - i
        r = g[:, 1] - j
        out = np.zeros((len(points), 2))
        out[:, 0] = (1 - s) * self.ux[i, j] + s * self.ux[i + 1, j]
        out[:, 1] = (1 - r) * self.uy[i, j] + r * self.uy[i, j + 1]
        return out

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        v = self.base_velocity(points)
        p = self.params
        if p.modulation != "none":
            x = self.noise.value
            v = v * max(0.0, 1.0 + p.speed_std * float(x[0]))
            if p.modulation == "rotate":
                a = math.radians(float(swing(x[1], p.direction_swing, p.swing_mode)))
                c, s = math.cos(a), math.sin(a)
                v = np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])
        if self.dim == 3:
            v = np.column_stack([v, np.full(len(v), p.vertical)])
        return v

    def state(self) -> dict[str, np.ndarray]:
        return {} if self.deterministic else {"noise": self.noise.state.copy()}
