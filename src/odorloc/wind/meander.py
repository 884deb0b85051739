"""Spatially uniform wind whose speed and direction meander as coloured (second-order) noise.

The building block is :class:`SecondOrderNoise`: independent channels of a damped oscillator
driven by white noise,

    x'' + 2 zeta omega x' + omega^2 x = q xi(t),

scaled so that ``x`` has unit stationary variance. It is advanced with the *exact* discretisation
of the linear SDE (state transition ``F = expm(A dt)`` and process covariance
``Q = P - F P F^T`` with ``P`` the stationary covariance), so its statistics (variance,
autocorrelation) do not depend on the step ``dt``.

The virtual-physics paper drives its inflow with "a constant 5 m/s velocity but varied directions
between +-22.5 deg" at "standard / twice / treble frequency". Here the direction is
``direction + swing(x)`` with a bounded swing (``tanh`` by default, so the deviation never leaves
``+-direction_swing``) and the frequency multiplier is ``frequency_factor`` (1, 2, 3), which scales
the noise's natural frequency ``omega = 2 pi frequency frequency_factor``.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from scipy.linalg import expm

from odorloc.core.params import Finite, NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.wind.base import WindModel

SwingMode = Literal["tanh", "clip", "gaussian"]


class SecondOrderNoise:
    """Independent channels of unit-variance second-order coloured noise.

    Parameters
    ----------
    channels : int
        Number of independent channels.
    omega : float, rad/s
        Natural (angular) frequency of the oscillator.
    damping : float
        Damping ratio ``zeta`` (> 0); ``0.7`` gives a smooth, barely oscillating signal.

    Notes
    -----
    The stationary covariance of ``(x, x')`` is ``diag(1, omega^2)`` for every ``zeta > 0``.
    The autocorrelation of ``x`` at lag ``s`` (``zeta < 1``) is
    ``exp(-zeta omega s) (cos(w_d s) + zeta omega / w_d sin(w_d s))`` with
    ``w_d = omega sqrt(1 - zeta^2)`` (see :meth:`autocorrelation`).
    """

    def __init__(self, channels: int, omega: float, damping: float) -> None:
        if channels < 1:
            raise ValueError("channels must be >= 1")
        if not (math.isfinite(omega) and omega > 0):
            raise ValueError("omega must be a finite number > 0")
        if not (math.isfinite(damping) and damping > 0):
            raise ValueError("damping must be a finite number > 0")
        self.channels = channels
        self.omega = float(omega)
        self.damping = float(damping)
        self._A = np.array([[0.0, 1.0], [-(self.omega**2), -2.0 * damping * self.omega]])
        self._P = np.diag([1.0, self.omega**2])
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.state = np.zeros((channels, 2))

    def transition(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F, L)`` with ``F = expm(A dt)`` and ``L L^T = P - F P F^T``."""
        key = float(dt)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        F = expm(self._A * dt)
        Q = self._P - F @ self._P @ F.T
        Q = 0.5 * (Q + Q.T)
        # eigh tolerates the nearly singular Q of very small steps, where Cholesky may fail.
        lam, V = np.linalg.eigh(Q)
        L = V * np.sqrt(np.clip(lam, 0.0, None))
        if len(self._cache) > 64:
            self._cache.clear()
        self._cache[key] = (F, L)
        return F, L

    def reset(self, rng: np.random.Generator) -> None:
        """Draw the state from the stationary distribution."""
        z = rng.standard_normal((self.channels, 2))
        self.state = z * np.array([1.0, self.omega])

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Advance every channel exactly by ``dt`` seconds."""
        F, L = self.transition(dt)
        z = rng.standard_normal((self.channels, 2))
        self.state = self.state @ F.T + z @ L.T

    @property
    def value(self) -> np.ndarray:
        """Current unit-variance signal of each channel, ``(channels,)``."""
        return self.state[:, 0]

    def autocorrelation(self, lag: float | np.ndarray) -> np.ndarray:
        """Theoretical autocorrelation of :attr:`value` at ``lag`` seconds (``zeta != 1``)."""
        s = np.abs(np.asarray(lag, float))
        z, w = self.damping, self.omega
        if z < 1.0:
            wd = w * math.sqrt(1.0 - z * z)
            return np.exp(-z * w * s) * (np.cos(wd * s) + z * w / wd * np.sin(wd * s))
        if z == 1.0:
            return np.exp(-w * s) * (1.0 + w * s)
        r = math.sqrt(z * z - 1.0)
        l1, l2 = w * (z - r), w * (z + r)
        return (l2 * np.exp(-l1 * s) - l1 * np.exp(-l2 * s)) / (l2 - l1)


def swing(x: np.ndarray, amplitude: float, mode: SwingMode) -> np.ndarray:
    """Map unit-variance noise ``x`` to a direction deviation (same units as ``amplitude``).

    ``tanh``: ``amplitude * tanh(x)``, strictly within ``+-amplitude`` (standard deviation
    about 0.63 ``amplitude``). ``clip``: ``clip(amplitude * x / 2, -amplitude, amplitude)``, a
    Gaussian swing of std ``amplitude / 2`` cut at two standard deviations. ``gaussian``:
    ``amplitude * x``, unbounded, ``amplitude`` is the standard deviation.
    """
    if mode == "tanh":
        return amplitude * np.tanh(x)
    if mode == "clip":
        return np.clip(0.5 * amplitude * x, -amplitude, amplitude)
    return amplitude * x


class MeanderWindParams(Params):
    """Parameters of :class:`MeanderWind`.

    speed : float, m/s
        Mean horizontal wind speed.
    direction : float, degrees
        Mean direction the wind blows towards (0 = +x, counter-clockwise).
    direction_swing : float, degrees
        Swing amplitude of the direction (its bound for ``swing_mode`` ``tanh``/``clip``, its
        standard deviation for ``gaussian``). 22.5 deg as in the virtual-physics paper.
    swing_mode : {"tanh", "clip", "gaussian"}
        How the unit-variance noise maps to the direction deviation (see :func:`swing`).
    speed_std : float, m/s
        Standard deviation of the speed fluctuation (the speed is clipped at 0).
    vertical, vertical_std : float, m/s
        Mean and standard deviation of the vertical component (3D arenas only).
    frequency : float, Hz
        Natural frequency of the "standard" fluctuation.
    frequency_factor : float
        Multiplier of ``frequency``: 1, 2, 3 for the paper's standard / twice / treble frequency.
    damping : float
        Damping ratio of the second-order noise.
    """

    speed: NonNegative = 1.0
    direction: Finite = 0.0
    direction_swing: NonNegative = 22.5
    swing_mode: SwingMode = "tanh"
    speed_std: NonNegative = 0.0
    vertical: Finite = 0.0
    vertical_std: NonNegative = 0.0
    frequency: Positive = 0.05
    frequency_factor: Positive = 1.0
    damping: Positive = 0.7

    @property
    def omega(self) -> float:
        """Natural angular frequency ``2 pi frequency frequency_factor``, rad/s."""
        return 2.0 * math.pi * self.frequency * self.frequency_factor


@register("wind", "meander", MeanderWindParams, "uniform wind with coloured-noise meander")
class MeanderWind(WindModel):
    """Uniform wind whose speed and direction follow second-order coloured noise.

    Three independent noise channels drive the direction, the speed and (3D) the vertical
    component. In 3D the meander is horizontal; the vertical component is
    ``vertical + vertical_std * x``.
    """

    def __init__(self, params: MeanderWindParams, arena: Arena) -> None:
        super().__init__(arena)
        self.params = params
        self.noise = SecondOrderNoise(3, params.omega, params.damping)

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self.noise.reset(rng)

    def _advance(self, dt: float, rng: np.random.Generator) -> None:
        self.noise.step(dt, rng)

    def current(self) -> np.ndarray:
        """The current wind vector, ``(d,)`` m/s."""
        p = self.params
        x = self.noise.value
        theta = math.radians(p.direction + float(swing(x[0], p.direction_swing, p.swing_mode)))
        speed = max(0.0, p.speed + p.speed_std * float(x[1]))
        u = [speed * math.cos(theta), speed * math.sin(theta)]
        if self.dim == 3:
            u.append(p.vertical + p.vertical_std * float(x[2]))
        return np.asarray(u)

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        return np.broadcast_to(self.current(), points.shape).copy()

    def state(self) -> dict[str, np.ndarray]:
        return {"noise": self.noise.state.copy()}
