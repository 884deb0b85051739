"""Virtual-structure formation forces: robots held on a ring around a virtual leader.

The virtual-physics paper (``shared/papers/virtual-physics-multi-group.txt``, Sec. 2.2.2.1) keeps
each group of robots in a regular polygon (a hexagon for six robots) around a *virtual robot* at
``x_c`` with the virtual structure force of robot ``k`` (eq. 1)::

    F_k = sum_{i != k} k_r q_k q_i / d_ki^2 (x_k - x_i) / d_ki
          - k_s (x_k - x_c) (|x_k - x_c|^2 - r^2)

(unit charges ``q = 1`` repel each other; the ring term pulls a robot onto the circle of radius
``r``), normalised to a unit vector (eq. 2), and every robot steps ``s2`` along it (eq. 8). The
force is minus the gradient of the robot's potential::

    U_k = sum_{i != k} k_r / d_ki + k_s / 4 (|x_k - x_c|^2 - r^2)^2

which :func:`structure_potential` evaluates. Because eq. 2 keeps only the direction, a robot
stepping a fixed ``s2`` never settles: at the equilibrium the unit force still has length 1 and
the robot jumps ``s2`` back and forth across it. ``step_rule="capped"`` (the default) therefore
reads ``s2`` as the longest step: each robot moves along its unit force by the length among
``s2, s2/2, s2/4, ...`` (or 0) that lowers its own potential most, the others held where they
are (a line search along eq. 2's direction). Far from the ring that is the paper's full ``s2``
step; near it the step shrinks and the polygon settles. ``step_rule="fixed"`` is the literal
reading.

While the virtual robot moves, a ring stiff enough to hold the radius drags each robot towards
the nearest point of the moved ring, which lies behind it: robots stepping by eq. 8 alone bunch
up on the trailing side of their leader. :func:`structure_step` can therefore carry the robots
with the virtual robot's own step first (``carry``) and correct the shape with what is left of
``s2`` -- the structure moves with its leader, as in virtual-structure control.

The ring radius ``r`` is where the ring term vanishes; the charges push every robot slightly
outside it. For a regular ``K``-gon of radius ``R`` the outward charge force is
``k_r / (4 R^2) sum_{j=1}^{K-1} 1 / sin(pi j / K)`` and the ring's pull ``k_s R (R^2 - r^2)``, so
:func:`equilibrium_radius` solves for the radius the formation settles at.

:class:`FluxDeclaration` is the paper's source declaration (Sec. 2.2.3, after Zarzhitsky et al.):
the total mass flux through the formation (:func:`odorloc.behaviours.taxis.mass_flux`) exceeds
``Phi_T`` in ``n_s`` steps, read three ways, while the robots surround their centre
(:func:`formation_shape`); :func:`declaration_series` applies it to many formations' flux series
at once.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odorloc.core.errors import ConfigError

__all__ = [
    "DeclarationReading",
    "FluxDeclaration",
    "FormationShape",
    "StepRule",
    "declaration_series",
    "equilibrium_radius",
    "formation_shape",
    "hexagon_errors",
    "regular_polygon",
    "structure_force",
    "structure_potential",
    "structure_step",
]

FloatArray = NDArray[np.float64]
StepRule = Literal["capped", "fixed"]
_EPS = 1e-12
#: Step lengths tried by the capped rule: s2 * 2^-j, j = 0..11 (down to s2 / 2048), and 0.
_HALVINGS = 12


def _pairs(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Differences ``x_k - x_i`` ``(K, K, d)`` and distances ``(K, K)`` (inf on the diagonal)."""
    diff = x[:, None, :] - x[None, :, :]
    dist = np.sqrt(np.einsum("kid,kid->ki", diff, diff))
    np.fill_diagonal(dist, np.inf)
    return diff, dist


def structure_force(
    positions: ArrayLike, centre: ArrayLike, radius: float, k_r: float, k_s: float
) -> FloatArray:
    """The virtual structure force of every robot (eq. 1), not normalised.

    Parameters
    ----------
    positions : (K, d) array_like, metres
        Robot positions.
    centre : (d,) array_like, metres
        The virtual robot ``x_c``.
    radius : float, metres
        Ring radius ``r``.
    k_r, k_s : float
        Gains of the charge and ring terms (unit charges).

    Returns
    -------
    (K, d) ndarray
        Force on each robot (units of ``k_r / m^2``). Two robots at the same point exert no force
        on each other (their direction is undefined).
    """
    x = np.atleast_2d(np.asarray(positions, float))
    c = np.asarray(centre, float)
    diff, dist = _pairs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.where(dist > _EPS, k_r / dist**3, 0.0)
    charges = np.einsum("ki,kid->kd", coef, diff)
    rel = x - c
    rho2 = np.einsum("kd,kd->k", rel, rel)
    ring = -k_s * rel * (rho2 - radius * radius)[:, None]
    return charges + ring


def structure_potential(
    positions: ArrayLike, centre: ArrayLike, radius: float, k_r: float, k_s: float
) -> FloatArray:
    """Each robot's own potential ``U_k`` ``(K,)`` whose negative gradient is eq. 1's force."""
    x = np.atleast_2d(np.asarray(positions, float))
    c = np.asarray(centre, float)
    _, dist = _pairs(x)
    rel = x - c
    rho2 = np.einsum("kd,kd->k", rel, rel)
    with np.errstate(divide="ignore"):
        charges = (k_r / np.maximum(dist, _EPS)).sum(axis=1)
    return charges + 0.25 * k_s * (rho2 - radius * radius) ** 2


def structure_step(
    positions: ArrayLike,
    centre: ArrayLike,
    radius: float,
    k_r: float,
    k_s: float,
    step: float,
    rule: StepRule = "capped",
    carry: ArrayLike | None = None,
) -> FloatArray:
    """Displacement of every robot for one step of eq. 8, ``(K, d)`` metres.

    Each robot moves along its unit structure force (eq. 2) by ``step`` (``s2``) with
    ``rule="fixed"``, or with ``rule="capped"`` by the length among ``step * 2^-j`` and 0 that
    lowers its own potential most with the other robots held in place (see the module
    docstring). A robot whose force vanishes does not move.

    Parameters
    ----------
    positions : (K, d) array_like, metres
    centre : (d,) array_like, metres
        The virtual robot after its own step.
    radius, k_r, k_s : float
        Ring radius (m) and gains of eq. 1.
    step : float, metres
        Longest step of a robot (``s2``).
    rule : {"capped", "fixed"}
    carry : (d,) array_like, metres, optional
        The virtual robot's displacement of this step. When given, the robots are first carried
        with it (the structure moves with its leader) and the structure step uses what is left
        of ``step``, so that no robot moves farther than ``step``. Without it (eq. 8 literally) a
        ring stiff enough to hold the radius lets the robots of a moving formation bunch up
        behind their leader.
    """
    x = np.atleast_2d(np.asarray(positions, float))
    c = np.asarray(centre, float)
    if step < 0 or not math.isfinite(step):
        raise ConfigError("step", f"must be a finite number >= 0, got {step}")
    base = np.zeros(x.shape[1])
    if carry is not None:
        base = np.asarray(carry, float).reshape(-1)
        step = max(step - math.sqrt(float(base @ base)), 0.0)
        x = x + base
    diff, dist = _pairs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.where(dist > _EPS, k_r / dist**3, 0.0)
    rel = x - c
    rho2 = np.einsum("kd,kd->k", rel, rel)
    f = np.einsum("ki,kid->kd", coef, diff) - k_s * rel * (rho2 - radius * radius)[:, None]
    norm = np.sqrt(np.einsum("kd,kd->k", f, f))
    moving = norm > _EPS
    u = np.zeros_like(f)
    u[moving] = f[moving] / norm[moving, None]
    if rule == "fixed":
        return base + u * step
    if rule != "capped":
        raise ConfigError("step_rule", f"unknown rule {rule!r} (capped, fixed)")
    # Robot k's potential after a step of length l along u_k, the others held where they are:
    # |x_k + l u_k - x_i|^2 = d_ki^2 + 2 l (x_k - x_i).u_k + l^2 |u_k|^2, and the same for the
    # ring distance, so every candidate length costs only (K, K) arithmetic.
    lengths = step * np.concatenate([0.5 ** np.arange(_HALVINGS), [0.0]])[:, None, None]
    uu = moving.astype(float)[None, :, None]
    b = np.einsum("kid,kd->ki", diff, u)[None]
    d2 = dist[None] ** 2 + 2.0 * lengths * b + lengths**2 * uu  # (L, K, K), inf on the diagonal
    charges = (k_r / np.sqrt(np.maximum(d2, _EPS * _EPS))).sum(axis=2)
    r2 = rho2[None, :] + 2.0 * lengths[:, :, 0] * np.einsum("kd,kd->k", rel, u)[None, :]
    r2 = r2 + lengths[:, :, 0] ** 2 * uu[:, :, 0]
    pot = charges + 0.25 * k_s * (r2 - radius * radius) ** 2
    best = np.argmin(pot, axis=0)  # ties go to the longest step
    return base + u * lengths[best, 0, 0][:, None]


def regular_polygon(centre: ArrayLike, radius: float, n: int, phase: float = 0.0) -> FloatArray:
    """Vertices ``(n, 2)`` of a regular ``n``-gon of circumradius ``radius`` around ``centre``."""
    a = phase + 2.0 * math.pi * np.arange(n) / n
    return np.asarray(centre, float)[:2] + radius * np.column_stack([np.cos(a), np.sin(a)])


def equilibrium_radius(n: int, radius: float, k_r: float, k_s: float) -> float:
    """Circumradius (m) at which a regular ``n``-gon is in equilibrium under eq. 1.

    Solves ``k_s R (R^2 - r^2) = k_r / (4 R^2) sum_j 1 / sin(pi j / n)`` for ``R >= r`` by
    bisection (one robot: ``R = r``).
    """
    if n < 2:
        return float(radius)
    s = float(np.sum(1.0 / np.sin(np.pi * np.arange(1, n) / n)))

    def excess(R: float) -> float:
        return k_s * R * (R * R - radius * radius) - k_r * s / (4.0 * R * R)

    lo, hi = radius, 2.0 * radius
    while excess(hi) < 0:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if excess(mid) < 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class FormationShape:
    """How a formation sits around its centre.

    Attributes
    ----------
    radii : (K,) ndarray, metres
        Distance of each robot from the centre.
    sides : (K,) ndarray, metres
        Distances between robots adjacent in angle around the centre (K >= 2; empty otherwise).
    max_gap : float, rad
        Largest angle between robots adjacent around the centre (``2 pi`` for one robot).
    """

    radii: FloatArray
    sides: FloatArray
    max_gap: float

    def surrounds(self, radius: float, tolerance: float = 0.5) -> bool:
        """``True`` when the robots enclose the centre: no angular gap of pi or more and every
        robot within ``radius * (1 +- tolerance)`` of it."""
        if len(self.radii) < 3:
            return False
        lo, hi = radius * (1.0 - tolerance), radius * (1.0 + tolerance)
        return bool(
            self.max_gap < math.pi and np.all(self.radii >= lo) and np.all(self.radii <= hi)
        )


def formation_shape(positions: ArrayLike, centre: ArrayLike) -> FormationShape:
    """Radii, sides and the largest angular gap of robots around ``centre`` (2-D)."""
    x = np.atleast_2d(np.asarray(positions, float))[:, :2]
    rel = x - np.asarray(centre, float)[:2]
    radii = np.linalg.norm(rel, axis=1)
    if len(x) < 2:
        return FormationShape(radii, np.zeros(0), 2.0 * math.pi)
    ang = np.arctan2(rel[:, 1], rel[:, 0])
    order = np.argsort(ang)
    a = ang[order]
    gaps = np.diff(np.concatenate([a, [a[0] + 2.0 * math.pi]]))
    ring = x[order]
    sides = np.linalg.norm(ring - np.roll(ring, -1, axis=0), axis=1)
    return FormationShape(radii, sides, float(gaps.max()))


DeclarationReading = Literal["consecutive", "window", "mean"]


class FluxDeclaration:
    """The paper's source declaration (Sec. 2.2.3): the total flux "consistently exceeds" a
    threshold "in a given number of steps n_s", read one of three ways.

    The sentence (after Zarzhitsky et al.) is: "if the robots surround a suspected emitter, and
    the total mass flux measured by the sensor grid consistently exceeds some small,
    empirically-determined threshold Phi_T in a given number of steps n_s, then the robots have
    localized the emitter". A step *counts* when the robots surround their centre and the total
    flux exceeds ``threshold``. The readings of "consistently ... in n_s steps":

    - ``"consecutive"``: ``n_s`` counting steps in a row (a step that does not count starts
      afresh);
    - ``"window"``: ``n_s`` counting steps among the last ``window`` (``window >= n_s``): the
      flux exceeds the threshold in ``n_s`` steps of one stretch of the search, not necessarily
      adjacent ones;
    - ``"mean"``: the mean total flux over the last ``n_s`` steps exceeds the threshold, every one
      of them with the robots surrounding their centre.

    Parameters
    ----------
    threshold : float
        ``Phi_T`` (readings x m/s; kg/m^2 s in the paper's units).
    steps : int
        ``n_s`` (>= 1).
    reading : {"consecutive", "window", "mean"}
    window : int, optional
        Length of the window of ``"window"`` (default ``3 n_s``; at least ``n_s``).
    """

    def __init__(
        self,
        threshold: float,
        steps: int,
        reading: DeclarationReading = "consecutive",
        window: int | None = None,
    ) -> None:
        if steps < 1:
            raise ConfigError("n_s", f"must be >= 1, got {steps}")
        if not math.isfinite(threshold):
            raise ConfigError("phi_T", "must be finite")
        if reading not in ("consecutive", "window", "mean"):
            raise ConfigError("reading", f"unknown reading {reading!r} (consecutive, window, mean)")
        m = 3 * int(steps) if window is None else int(window)
        if m < steps:
            raise ConfigError("window", f"must be at least n_s = {steps}, got {m}")
        self.threshold = float(threshold)
        self.steps = int(steps)
        self.reading: DeclarationReading = reading
        self.window = m if reading == "window" else int(steps)
        self.count = 0
        self._flux: deque[float] = deque(maxlen=self.window)
        self._counts: deque[bool] = deque(maxlen=self.window)
        self._run = 0

    def reset(self) -> None:
        """Start counting afresh."""
        self.count = 0
        self._run = 0
        self._flux.clear()
        self._counts.clear()

    def update(self, total_flux: float, surrounds: bool = True) -> bool:
        """Feed one step; ``True`` once the reading's condition holds (see the class docstring).

        :attr:`count` is then the number of steps that count towards it: the run of counting
        steps (``consecutive``), the counting steps in the window (``window``) or the steps of
        the current run of surrounding steps, at most ``n_s`` (``mean``).
        """
        counts = bool(surrounds and total_flux > self.threshold)
        self._flux.append(float(total_flux))
        self._counts.append(counts)
        if self.reading == "consecutive":
            self.count = self.count + 1 if counts else 0
            return self.count >= self.steps
        if self.reading == "window":
            self.count = sum(self._counts)
            return self.count >= self.steps
        self._run = self._run + 1 if surrounds else 0
        self.count = min(self._run, self.steps)
        if self.count < self.steps:
            return False
        return float(np.mean(list(self._flux)[-self.steps :])) > self.threshold


def declaration_series(
    total_flux: ArrayLike,
    threshold: float,
    steps: int,
    reading: DeclarationReading = "consecutive",
    window: int | None = None,
    surrounds: ArrayLike | None = None,
) -> NDArray[np.bool_]:
    """Where a :class:`FluxDeclaration` fed each column of ``total_flux`` would fire.

    Parameters
    ----------
    total_flux : (T, M) array_like
        Total flux of ``M`` formations over ``T`` steps.
    threshold, steps, reading, window
        As :class:`FluxDeclaration`.
    surrounds : (T, M) array_like of bool, optional
        Whether the robots surround their centre (default: always).

    Returns
    -------
    (T, M) bool ndarray
        ``True`` at every step at which :meth:`FluxDeclaration.update` would return ``True``
        (a declaration stops a formation; here the counting goes on, so the fraction of steps
        with ``True`` measures how readily a formation held there would declare).
    """
    flux = np.atleast_2d(np.asarray(total_flux, float))
    sur = np.ones(flux.shape, bool) if surrounds is None else np.asarray(surrounds, bool)
    ref = FluxDeclaration(threshold, steps, reading, window)  # validates the settings
    counts = sur & (flux > ref.threshold)
    T = len(flux)

    def trailing_sum(x: np.ndarray, n: int) -> np.ndarray:
        c = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0)
        lag = np.maximum(np.arange(1, T + 1) - n, 0)
        return c[1:] - c[lag]

    if reading == "consecutive":
        return trailing_sum(counts.astype(float), ref.steps) >= ref.steps
    if reading == "window":
        return trailing_sum(counts.astype(float), ref.window) >= ref.steps
    full = trailing_sum(sur.astype(float), ref.steps) >= ref.steps
    return full & (trailing_sum(flux, ref.steps) / ref.steps > ref.threshold)


def hexagon_errors(positions: Sequence[Sequence[float]], centre: ArrayLike) -> tuple[float, float]:
    """``(largest relative deviation of a side from the mean side, of a radius from the mean
    radius)`` of a formation: 0 for a regular polygon."""
    shape = formation_shape(positions, centre)
    side_err = float(np.max(np.abs(shape.sides / shape.sides.mean() - 1.0)))
    rad_err = float(np.max(np.abs(shape.radii / shape.radii.mean() - 1.0)))
    return side_err, rad_err
