"""Vergassola rate plume: the rate model of :mod:`odorloc.models.vergassola` as simulated truth.

:meth:`VergassolaPlume.encounter_rate` is the rate ``R`` of :func:`~odorloc.models.vergassola.
vergassola_rate` summed over the sources; :meth:`VergassolaPlume.concentration` is the
concentration whose diffusive absorption by the sensor gives that rate (Smoluchowski):
``c = R / (4 pi D a)`` in 3D and ``c = R ln(lambda / a) / (2 pi D)`` in 2D. Estimators use
:class:`~odorloc.models.vergassola.VergassolaModel`, whose parameters may differ from the plume's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive, Vector
from odorloc.core.registry import register
from odorloc.core.timestep import TimeStepped
from odorloc.geometry.arena import Arena
from odorloc.models.vergassola import (
    correlation_length,
    rate_exponent,
    unit_direction,
    vergassola_rate,
)
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel
from odorloc.wind.uniform import UniformWind


class VergassolaParams(Params):
    """Parameters of :class:`VergassolaPlume` (defaults: multi-UAV paper's table).

    The release rate ``Q`` is each source's ``rate`` (the paper uses ``Q = 5``).

    Attributes
    ----------
    V : float or None, m/s
        Mean wind speed; ``None`` uses the speed of the wind model's spatial mean. With a
        uniform world wind of another speed the plume is refused (one wind, stated twice).
    D : float, m^2/s
        Isotropic effective diffusivity.
    tau : float, s
        Particle lifetime.
    sensor_radius : float, metres
        Sensor radius ``a`` (must be below ``lambda`` in 2D).
    wind_direction : (d,) tuple of float or None
        Direction the wind blows towards (normalised). ``None`` follows the wind model's spatial
        mean velocity (updated every step), falling back to ``-y`` (the paper's eq. 1) when the
        wind is calm.
    """

    V: Positive | None = 1.0
    D: Positive = 1.0
    tau: Positive = 100.0
    sensor_radius: Positive = 1.0
    wind_direction: Vector | None = None


@register("plume", "vergassola", VergassolaParams, "Vergassola rate model (infotaxis), 2D/3D")
class VergassolaPlume(PlumeModel):
    """Steady Vergassola rate model; :meth:`encounter_rate` is the rate ``R``.

    Several sources add their rates.
    """

    def __init__(
        self,
        params: VergassolaParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        if params.wind_direction is not None and len(params.wind_direction) != self.dim:
            raise ConfigError("plume.wind_direction", f"needs {self.dim} components")
        if params.V is not None and isinstance(wind, UniformWind):
            # the direction follows world.wind and the speed is V: one wind, stated twice,
            # must agree (the anemometers read world.wind)
            u = wind.mean_velocity()
            speed = math.sqrt(float(u.dot(u)))
            if speed > 0.0 and not math.isclose(speed, params.V, rel_tol=1e-9):
                raise ConfigError(
                    "plume.V",
                    f"is {params.V:g} m/s, but world.wind blows at {speed:g} m/s: set V to the "
                    "wind's speed, or V: null to follow world.wind",
                )
        self._src = self.source_positions
        self._rate_key: tuple[float, bytes, bytes, bytes] | None = None
        self._sync()
        if self.dim == 2 and self.length <= params.sensor_radius:
            raise ConfigError(
                "plume.sensor_radius", f"must be below lambda = {self.length:.3g} m in 2D"
            )

    def _sources_changed(self) -> None:
        self._src = self.source_positions
        self._sync()

    def step(self, dt: float, rng: np.random.Generator) -> None:
        if self.wind.steady and self._constant_release:
            # nothing the rate depends on changes with time: only the clock ticks
            TimeStepped.step(self, dt, rng)
            return
        super().step(dt, rng)

    def _sync(self) -> None:
        p = self.params
        self._constant_release = all(s.modulation.kind == "constant" for s in self.sources)
        mean = self.wind.mean_velocity()
        # |mean| as numpy.linalg.norm computes it, without its call overhead (every world step)
        speed = math.sqrt(float(mean.dot(mean)))
        self.V = float(p.V) if p.V is not None else speed
        if p.wind_direction is not None:
            e = np.asarray(p.wind_direction, float)
        elif speed > 1e-12:
            e = mean
        else:
            e = np.zeros(self.dim)
            e[1] = -1.0
        self.direction = e / math.sqrt(float(e.dot(e)))
        self._q = self.source_rates()
        key = (self.V, self.direction.tobytes(), self._q.tobytes(), self._src.tobytes())
        if key != self._rate_key:
            # the constants of the rate, recomputed only when the wind, a release rate or a
            # source position (a source drawn anew for an episode) changed
            self._rate_key = key
            self._e = unit_direction(self.direction, self.dim)
            self._lam = correlation_length(self.V, p.D, p.tau)
            self._aq = p.sensor_radius * np.asarray(self._q, float)
            # per source: position, s . e and a Q, for the one-point rate
            se = self._src @ self._e
            self._rows = list(zip(self._src.tolist(), se.tolist(), self._aq.tolist(), strict=True))

    @property
    def length(self) -> float:
        """Correlation length ``lambda``, metres."""
        return correlation_length(self.V, self.params.D, self.params.tau)

    def _encounter_rate(self, points: np.ndarray) -> np.ndarray:
        p = self.params
        if self.dim == 3 and len(points) <= 8 and len(self._rows) <= 8:
            return self._rate_at_points(points)
        if self.dim == 3:
            # vergassola_rate with the constants of the current step and no input checks (the
            # sensors ask for one point per agent and step)
            expo, r = rate_exponent(
                points, self._src, self._e, V=self.V, D=p.D, lam=self._lam, a=p.sensor_radius
            )
            return (self._aq * np.exp(expo) / r).sum(axis=1)
        return vergassola_rate(
            points,
            self._src,
            self._q,
            V=self.V,
            D=p.D,
            tau=p.tau,
            a=p.sensor_radius,
            direction=self.direction,
        ).sum(axis=1)

    def _rate_at_points(self, points: np.ndarray) -> np.ndarray:
        """The 3-D rate at a few ``(Q, 3)`` points summed over the sources, ``(Q,)``.

        The sensors ask for one point per agent and step; this is :func:`~odorloc.models.
        vergassola.rate_exponent` and the sum over sources operation by operation in Python
        floats (the same IEEE results: sums of three squares and of the sources in order,
        ``x . e`` from one BLAS call, NumPy's ``exp``) without a dozen array calls on a few
        elements.
        """
        a = self.params.sensor_radius
        a2 = a * a
        adv = self.V / (2.0 * self.params.D)
        inv_lam = 1.0 / self._lam
        xe = (points @ self._e).tolist()
        expos, radii = [], []
        for (x0, x1, x2), xe_q in zip(points.tolist(), xe, strict=True):
            for (s0, s1, s2), se, _ in self._rows:
                d0, d1, d2 = x0 - s0, x1 - s1, x2 - s2
                r2 = d0 * d0 + d1 * d1 + d2 * d2
                r = math.sqrt(r2 if r2 >= a2 else a2)
                expo = (xe_q - se) * adv
                expo -= r * inv_lam
                expos.append(expo)
                radii.append(r)
        grow = np.exp(expos).tolist()
        n_src = len(self._rows)
        out = np.empty(len(points))
        for q in range(len(points)):
            total = 0.0
            for j, (_, _, aq) in enumerate(self._rows):
                i = q * n_src + j
                total += (aq * grow[i]) / radii[i]
            out[q] = total
        return out

    def _to_concentration(self, rate: np.ndarray) -> np.ndarray:
        p = self.params
        if self.dim == 3:
            return rate / (4.0 * np.pi * p.D * p.sensor_radius)
        return rate * np.log(self.length / p.sensor_radius) / (2.0 * np.pi * p.D)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return self._to_concentration(self._encounter_rate(points))

    def frame(self) -> dict[str, np.ndarray]:
        p = self.params
        return {
            "model": np.array("vergassola"),
            "src": self._src.copy(),
            "q": self._q.copy(),
            "V": np.array(self.V),
            "D": np.array(p.D),
            "tau": np.array(p.tau),
            "a": np.array(p.sensor_radius),
            "direction": self.direction.copy(),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        V, D, tau, a = (float(frame[k]) for k in ("V", "D", "tau", "a"))
        rate = vergassola_rate(
            points,
            np.asarray(frame["src"], float),
            np.asarray(frame["q"], float),
            V=V,
            D=D,
            tau=tau,
            a=a,
            direction=np.asarray(frame["direction"], float),
        ).sum(axis=1)
        if points.shape[1] == 3:
            return rate / (4.0 * np.pi * D * a)
        return rate * np.log(correlation_length(V, D, tau) / a) / (2.0 * np.pi * D)
