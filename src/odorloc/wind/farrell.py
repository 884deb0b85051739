"""Farrell et al. (2002) style time-varying wind field on a coarse grid.

The horizontal velocity lives on an ``nx x ny`` node grid spanning the arena (15 x 15 by default,
as in the flow "movies" of the Dempster-Shafer multi-source paper). Following Farrell's
filament-model paper:

* the four corner nodes carry ``mean + coloured noise`` (each component an independent
  second-order noise channel, :class:`~odorloc.wind.meander.SecondOrderNoise`);
* every other boundary node is the linear interpolation of the two corners of its edge, so the
  boundary noise is correlated along the boundary;
* interior nodes evolve by the viscous advection equation
  ``u_t = -(u . grad) u + (K_x / 2) u_xx + (K_y / 2) u_yy`` (same for ``v``), integrated with
  explicit sub-steps whose size respects the advective (CFL) and diffusive stability limits
  (first-order upwind advection, central diffusion).

Velocities at arbitrary points are bilinear interpolations of the nodes (points outside the arena
are clipped onto it). In 3D the field is layered: the same horizontal field at every height plus a
constant vertical component ``vertical``.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field, field_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.wind.base import WindModel
from odorloc.wind.meander import SecondOrderNoise

MAX_SUBSTEPS_PER_SECOND = 10_000
"""Most explicit sub-steps a Farrell wind may need per simulated second at its mean field. The
built-in scenarios need about 2; a grid fine for its diffusivity (the diffusive limit falls with
the square of the node spacing) needs millions per control period and never finishes."""


class FarrellWindParams(Params):
    """Parameters of :class:`FarrellWind`.

    speed : float, m/s
        Mean wind speed (1.0 m/s in the multi-source paper).
    direction : float, degrees
        Mean direction the wind blows towards (0 = +x).
    noise_std : float, m/s
        Stationary standard deviation of each corner velocity component.
    frequency : float, Hz
        Natural frequency of the corner noise; ``frequency_factor`` multiplies it.
    frequency_factor : float
        Multiplier of ``frequency`` (1, 2, 3: standard, twice, treble frequency).
    damping : float
        Damping ratio of the corner noise.
    diffusivity : (2,) tuple of float, m^2/s
        ``(K_x, K_y)`` of the viscous term (the equation uses ``K / 2``).
    nodes : (2,) tuple of int
        Grid nodes along x and y (>= 3 each), boundaries included.
    courant : float
        Safety factor (< 1) applied to the stability limit of the explicit sub-steps.
    vertical : float, m/s
        Constant vertical component in 3D arenas.
    """

    speed: NonNegative = 1.0
    direction: Finite = 0.0
    noise_std: NonNegative = 0.3
    frequency: Positive = 0.02
    frequency_factor: Positive = 1.0
    damping: Positive = 0.7
    diffusivity: tuple[Positive, Positive] = (1.0, 1.0)
    nodes: tuple[int, int] = (15, 15)
    courant: float = Field(0.5, gt=0.0, le=1.0)
    vertical: Finite = 0.0

    @field_validator("nodes")
    @classmethod
    def _check_nodes(cls, v: tuple[int, int]) -> tuple[int, int]:
        if min(v) < 3 or max(v) > 1000:
            raise ValueError("must be between 3 and 1000 along each axis")
        return v

    @property
    def mean(self) -> np.ndarray:
        """Mean horizontal velocity ``(2,)``, m/s."""
        a = math.radians(self.direction)
        return self.speed * np.array([math.cos(a), math.sin(a)])


def advect_diffuse_step(
    u: np.ndarray, v: np.ndarray, dx: float, dy: float, kx: float, ky: float, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """One explicit step of ``q_t = -(u q_x + v q_y) + kx/2 q_xx + ky/2 q_yy`` for ``q = u, v``.

    Interior nodes only; boundary nodes are returned unchanged. Upwind differences for the
    advection, central differences for the diffusion.

    Parameters
    ----------
    u, v : (nx, ny) ndarray, m/s
    dx, dy : float, metres
    kx, ky : float, m^2/s
    dt : float, seconds

    Returns
    -------
    (u_new, v_new) : (nx, ny) ndarrays, m/s
    """
    uc = u[1:-1, 1:-1]
    vc = v[1:-1, 1:-1]
    out = []
    for q in (u, v):
        qc = q[1:-1, 1:-1]
        qxm = (qc - q[:-2, 1:-1]) / dx
        qxp = (q[2:, 1:-1] - qc) / dx
        qym = (qc - q[1:-1, :-2]) / dy
        qyp = (q[1:-1, 2:] - qc) / dy
        adv = np.where(uc > 0, uc * qxm, uc * qxp) + np.where(vc > 0, vc * qym, vc * qyp)
        lap = 0.5 * kx * (qxp - qxm) / dx + 0.5 * ky * (qyp - qym) / dy
        qn = q.copy()
        qn[1:-1, 1:-1] = qc + dt * (lap - adv)
        out.append(qn)
    return out[0], out[1]


@register("wind", "farrell", FarrellWindParams, "Farrell 2002 coarse-grid time-varying wind")
class FarrellWind(WindModel):
    """Time-varying, spatially smooth wind field with coloured-noise boundary conditions."""

    def __init__(self, params: FarrellWindParams, arena: Arena) -> None:
        super().__init__(arena)
        self.params = params
        nx, ny = params.nodes
        self.x = np.linspace(arena.lower[0], arena.upper[0], nx)
        self.y = np.linspace(arena.lower[1], arena.upper[1], ny)
        self.dx = float(self.x[1] - self.x[0])
        self.dy = float(self.y[1] - self.y[0])
        # Corner order: (x0,y0), (x1,y0), (x0,y1), (x1,y1); channels 0-3 u, 4-7 v.
        self.noise = SecondOrderNoise(
            8, 2.0 * math.pi * params.frequency * params.frequency_factor, params.damping
        )
        self._check_substeps()
        self._s = np.linspace(0.0, 1.0, nx)[:, None]
        self._r = np.linspace(0.0, 1.0, ny)[None, :]
        self.u, self.v = self._bilinear_from_corners()

    # ------------------------------------------------------------------ boundary
    def corners(self) -> np.ndarray:
        """Corner velocities ``(4, 2)`` m/s: mean plus coloured noise."""
        n = self.params.noise_std * self.noise.value
        return self.params.mean[None, :] + np.column_stack([n[:4], n[4:]])

    def _bilinear_from_corners(self) -> tuple[np.ndarray, np.ndarray]:
        c = self.corners()
        s, r = self._s, self._r
        fields = []
        for k in range(2):
            c00, c10, c01, c11 = c[:, k]
            fields.append(
                (1 - s) * (1 - r) * c00 + s * (1 - r) * c10 + (1 - s) * r * c01 + s * r * c11
            )
        return fields[0], fields[1]

    def _apply_boundary(self) -> None:
        bu, bv = self._bilinear_from_corners()
        # On the boundary the bilinear form reduces to linear interpolation along each edge.
        for q, b in ((self.u, bu), (self.v, bv)):
            q[0, :], q[-1, :], q[:, 0], q[:, -1] = b[0, :], b[-1, :], b[:, 0], b[:, -1]

    # ------------------------------------------------------------------ dynamics
    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self.noise.reset(rng)
        self.u, self.v = self._bilinear_from_corners()

    def _stability_rate(self, um: float, vm: float) -> float:
        """``|u|/dx + |v|/dy + K_x/dx^2 + K_y/dy^2``, 1/s, for the largest speeds ``um, vm``
        (m/s): the explicit scheme's stability limit is ``courant`` over it."""
        kx, ky = self.params.diffusivity
        return um / self.dx + vm / self.dy + kx / self.dx**2 + ky / self.dy**2

    def _check_substeps(self) -> None:
        """Refuse a grid, diffusivity and courant factor that need more than
        :data:`MAX_SUBSTEPS_PER_SECOND` sub-steps per simulated second.

        The mean field is the least any field of these parameters needs (the corner noise only
        adds speed), so nothing that would run is refused.
        """
        p = self.params
        mx, my = np.abs(p.mean)
        per_second = self._stability_rate(float(mx), float(my)) / p.courant
        if per_second > MAX_SUBSTEPS_PER_SECOND:
            raise ConfigError(
                "nodes",
                f"{p.nodes[0]}x{p.nodes[1]} nodes ({self.dx:.3g} x {self.dy:.3g} m apart) with "
                f"diffusivity {p.diffusivity[0]:g}, {p.diffusivity[1]:g} m^2/s and courant "
                f"{p.courant:g} need {per_second:.3g} stability sub-steps per simulated second "
                f"(at most {MAX_SUBSTEPS_PER_SECOND}): use fewer nodes, a lower diffusivity or "
                "a larger courant",
            )

    def max_substep(self) -> float:
        """Largest stable explicit sub-step for the current field, seconds."""
        um = float(np.abs(self.u).max())
        vm = float(np.abs(self.v).max())
        return self.params.courant / self._stability_rate(um, vm)

    def substeps(self, dt: float) -> int:
        """Explicit sub-steps a step of ``dt`` seconds takes from the current field."""
        return max(1, math.ceil(dt / self.max_substep()))

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        self.noise.step(dt, rng)
        self._apply_boundary()
        kx, ky = self.params.diffusivity
        n = self.substeps(dt)
        h = dt / n
        for _ in range(n):
            self.u, self.v = advect_diffuse_step(self.u, self.v, self.dx, self.dy, kx, ky, h)

    # ------------------------------------------------------------------ queries
    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        nx, ny = self.params.nodes
        fx = (points[:, 0] - self.x[0]) / self.dx
        fy = (points[:, 1] - self.y[0]) / self.dy
        fx = np.clip(fx, 0.0, nx - 1.0)
        fy = np.clip(fy, 0.0, ny - 1.0)
        i = np.minimum(fx.astype(np.intp), nx - 2)
        j = np.minimum(fy.astype(np.intp), ny - 2)
        s = fx - i
        r = fy - j
        out = np.empty_like(points)
        for k, q in enumerate((self.u, self.v)):
            out[:, k] = (
                (1 - s) * (1 - r) * q[i, j]
                + s * (1 - r) * q[i + 1, j]
                + (1 - s) * r * q[i, j + 1]
                + s * r * q[i + 1, j + 1]
            )
        if self.dim == 3:
            out[:, 2] = self.params.vertical
        return out

    def state(self) -> dict[str, np.ndarray]:
        return {"u": self.u.copy(), "v": self.v.copy(), "noise": self.noise.state.copy()}
