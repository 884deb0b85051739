"""Steady Gaussian plume (the time-averaged plume of the indoor particle-filter paper).

For a source of rate ``Q`` in a wind of speed ``u`` blowing along the unit vector ``e``, with
downwind distance ``x = (p - s) . e > 0``, horizontal cross-wind offset ``y`` and height offset
``z`` (3D), the concentration is (the Gaussian plume of eq. 3, indoor-pf-entropy paper)::

    C = Q / (2 pi sigma_y sigma_z u) * exp(-y^2 / (2 sigma_y^2)) * Z(z)

and ``0`` upwind (``x <= 0``). In 2D the plane through the source height is modelled, so
``Z = 1`` (this is the paper's formula exactly). In 3D ``Z = exp(-z^2 / (2 sigma_z^2))`` plus,
with ground reflection, the image term ``exp(-(z_s + z_r - 2 z_g)^2 / (2 sigma_z^2))`` for a
ground at the arena floor ``z_g``. Several sources superpose.

The widths grow downwind either by eddy diffusion (``spread="diffusion"``,
``sigma^2 = sigma0^2 + 2 K x / u``) or by a power law (``spread="power"``,
``sigma^2 = sigma0^2 + (a x^b)^2``); ``sigma0`` keeps the plume finite at the source.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from odorloc.params import Params, Positive
from odorloc.plume.base import PlumeModel
from odorloc.registry import register
from odorloc.wind.base import WindModel
from odorloc.world.arena import Arena
from odorloc.world.sources import Source


class GaussianParams(Params):
    """Parameters of :class:`GaussianPlume`.

    Attributes
    ----------
    spread : "diffusion" | "power"
        Width law (see module docstring).
    sigma0 : float, metres
        Width at the source.
    K : float, m^2/s
        Eddy diffusivity (``spread="diffusion"``), cross-wind and vertical.
    a_y, b_y, a_z, b_z : float
        Power-law coefficients (``spread="power"``), ``sigma = a x^b`` with ``x`` in metres.
    min_speed : float, m/s
        Wind speeds below this are raised to it (the formula diverges as ``u -> 0``).
    ground_reflection : bool
        3D only: add the image source below the arena floor.
    """

    spread: Literal["diffusion", "power"] = "diffusion"
    sigma0: Positive = 0.1
    K: Positive = 0.05
    a_y: Positive = 0.2
    b_y: Positive = 0.9
    a_z: Positive = 0.12
    b_z: Positive = 0.85
    min_speed: Positive = 0.05
    ground_reflection: bool = True


def gaussian_plume(
    points: np.ndarray,
    src: np.ndarray,
    rates: np.ndarray,
    winds: np.ndarray,
    params: GaussianParams,
    ground: float = 0.0,
) -> np.ndarray:
    """Steady Gaussian-plume concentration of several sources.

    Parameters
    ----------
    points : (Q, d) ndarray, metres
    src : (S, d) ndarray, metres
        Source positions.
    rates : (S,) ndarray
        Release rates ``Q`` (amount/s).
    winds : (S, d) ndarray, m/s
        Wind velocity at each source; its horizontal part sets the downwind direction and speed.
    params : GaussianParams
    ground : float, metres
        Floor height for the 3D reflection term.

    Returns
    -------
    (Q,) ndarray
        Concentration (amount per m^3; in 2D the source-height plane).
    """
    dim = points.shape[1]
    out = np.zeros(len(points))
    p = params
    for s, q, w in zip(src, rates, winds, strict=True):
        horiz = np.array(w[:2], float)
        u = float(np.hypot(*horiz))
        e = horiz / u if u > 0 else np.array([1.0, 0.0])
        u = max(u, p.min_speed)
        rel = points - s
        x = rel[:, 0] * e[0] + rel[:, 1] * e[1]
        y = -rel[:, 0] * e[1] + rel[:, 1] * e[0]
        down = x > 0
        xd = np.where(down, x, 0.0)
        if p.spread == "diffusion":
            sy2 = p.sigma0**2 + 2.0 * p.K * xd / u
            sz2 = sy2
        else:
            sy2 = p.sigma0**2 + (p.a_y * xd**p.b_y) ** 2
            sz2 = p.sigma0**2 + (p.a_z * xd**p.b_z) ** 2
        c = q / (2.0 * np.pi * np.sqrt(sy2 * sz2) * u) * np.exp(-0.5 * y**2 / sy2)
        if dim == 3:
            zr = points[:, 2]
            zt = np.exp(-0.5 * (zr - s[2]) ** 2 / sz2)
            if p.ground_reflection:
                zt = zt + np.exp(-0.5 * (zr + s[2] - 2.0 * ground) ** 2 / sz2)
            c = c * zt
        out += np.where(down, c, 0.0)
    return out


@register("plume", "gaussian", GaussianParams, "steady Gaussian plume (indoor PF paper), 2D/3D")
class GaussianPlume(PlumeModel):
    """Steady Gaussian plume; follows the current wind at each source and the source rates.

    The downwind direction and speed are read from ``wind.velocity`` at each source position on
    construction/reset and after every step, so a slowly turning wind turns the plume (it stays
    the steady solution for the current wind). Rates are ``source.rate_at(t)``.
    """

    def __init__(
        self,
        params: GaussianParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        self._src = self.source_positions
        self._sync()

    def _sync(self) -> None:
        self._winds = self.wind.velocity(self._src)
        self._rates = self.source_rates()

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return gaussian_plume(
            points, self._src, self._rates, self._winds, self.params, self.arena.lower[-1]
        )

    def frame(self) -> dict[str, np.ndarray]:
        return {
            "model": np.array("gaussian"),
            "src": self._src.copy(),
            "rates": self._rates.copy(),
            "winds": self._winds.copy(),
            "ground": np.array(self.arena.lower[-1]),
            "params": np.array(self.params.model_dump_json()),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        params = GaussianParams.model_validate_json(str(frame["params"]))
        return gaussian_plume(
            points,
            np.asarray(frame["src"], float),
            np.asarray(frame["rates"], float),
            np.asarray(frame["winds"], float),
            params,
            float(frame["ground"]),
        )
