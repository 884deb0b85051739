"""Record a plume and its wind as a "movie" and play it back bit-exactly.

A :class:`Movie` holds, at fixed frame times, the plume's :meth:`~PlumeModel.frame` (filament
arrays, a concentration grid or an analytic model's parameters) and the wind sampled on a coarse
node grid. :class:`ReplayPlume` and :class:`ReplayWind` play it back: at time ``t`` they show the
latest frame with time ``<= t`` (piecewise constant in time), so every searcher facing the movie
sees exactly the same plume and wind (the DS mapping paper compares exploration methods this way).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.registry import entry, register
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import multilinear
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel

FrameFn = Callable[[dict[str, np.ndarray], np.ndarray], np.ndarray]


def _frame_functions() -> dict[str, FrameFn]:
    from odorloc.plume.eulerian import EulerianPlume
    from odorloc.plume.filament import FilamentPlume
    from odorloc.plume.gaussian import GaussianPlume
    from odorloc.plume.vergassola import VergassolaPlume

    return {
        "filament": FilamentPlume.frame_concentration,
        "gaussian": GaussianPlume.frame_concentration,
        "vergassola": VergassolaPlume.frame_concentration,
        "eulerian": EulerianPlume.frame_concentration,
    }


@dataclass(eq=False)
class Movie:
    """A recorded plume + wind.

    Attributes
    ----------
    times : (T,) ndarray, seconds
        Frame times, increasing.
    frames : list of dict of ndarray
        Plume frames (each has a ``"model"`` entry naming the plume family).
    wind_axes : list of ndarray
        Node coordinates of the wind grid per axis, metres.
    wind : (T, n1, ..., nd, d) ndarray, m/s
        Wind velocity at the nodes for every frame.
    arena_lower, arena_upper : (d,) ndarray, metres
    resolution : float, metres
    occ : bool ndarray or None
        Arena occupancy grid.
    source_positions : (S, d) ndarray, metres
    source_rates : (S,) ndarray
    """

    times: np.ndarray
    frames: list[dict[str, np.ndarray]]
    wind_axes: list[np.ndarray]
    wind: np.ndarray
    arena_lower: np.ndarray
    arena_upper: np.ndarray
    resolution: float
    source_positions: np.ndarray
    source_rates: np.ndarray
    occ: np.ndarray | None = field(default=None)

    @property
    def dim(self) -> int:
        """Spatial dimension."""
        return len(self.arena_lower)

    @property
    def model(self) -> str:
        """Name of the recorded plume family."""
        return str(self.frames[0]["model"])

    def arena(self) -> Arena:
        """The recorded arena."""
        return Arena(
            tuple(self.arena_lower), tuple(self.arena_upper), float(self.resolution), self.occ
        )

    def sources(self) -> list[Source]:
        """The recorded sources (positions and nominal rates)."""
        return [
            Source(position=tuple(float(v) for v in p), rate=float(r))
            for p, r in zip(self.source_positions, self.source_rates, strict=True)
        ]

    def index(self, t: float, loop: bool = False) -> int:
        """Index of the latest frame with time ``<= t`` (the first frame before it)."""
        times = self.times
        if loop and len(times) > 1 and t > times[-1]:
            period = times[-1] - times[0] + (times[-1] - times[-2])
            t = times[0] + (t - times[0]) % period
        k = int(np.searchsorted(times, t + 1e-9 * max(1.0, abs(t)), side="right")) - 1
        return min(max(k, 0), len(times) - 1)

    def concentration(self, k: int, points: np.ndarray) -> np.ndarray:
        """Plume concentration of frame ``k`` at ``(Q, d)`` points, ``(Q,)``."""
        frame = self.frames[k]
        fn = _frame_functions().get(str(frame["model"]))
        if fn is None:
            # a plume registered elsewhere replays through its own hook
            try:
                cls = entry("plume", str(frame["model"]), field="movie").build
            except ConfigError:
                raise ConfigError(
                    "movie", f"unknown plume model {frame['model']!s} in frame {k}"
                ) from None
            fn = cls.frame_concentration
        return fn(frame, points)

    def wind_velocity(self, k: int, points: np.ndarray) -> np.ndarray:
        """Wind of frame ``k`` at ``(Q, d)`` points (multilinear on the node grid), ``(Q, d)``."""
        return multilinear(self.wind[k], self.wind_axes, points)

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> None:
        """Write the movie to an ``.npz`` file (no pickles)."""
        data: dict[str, np.ndarray] = {
            "times": self.times,
            "wind": self.wind,
            "arena_lower": self.arena_lower,
            "arena_upper": self.arena_upper,
            "resolution": np.array(self.resolution),
            "source_positions": self.source_positions,
            "source_rates": self.source_rates,
        }
        if self.occ is not None:
            data["occ"] = self.occ
        for a, ax in enumerate(self.wind_axes):
            data[f"wind_axis_{a}"] = ax
        for k, frame in enumerate(self.frames):
            for name, arr in frame.items():
                data[f"frame_{k:06d}__{name}"] = np.asarray(arr)
        np.savez_compressed(path, **data)

    @classmethod
    def load(cls, path: str | Path) -> Movie:
        """Read a movie written by :meth:`save`.

        Raises
        ------
        ConfigError
            ``path``: the file is missing, is not an ``.npz`` archive, lacks a key of the
            layout, or holds arrays whose shapes do not fit together (named in the message).
        """
        import zipfile

        p = Path(path)
        if not p.is_file():
            raise ConfigError("path", f"movie file not found: {p}")
        with p.open("rb") as fh:
            magic = fh.read(6)
        if magic.startswith(b"\x93NUMPY"):
            raise ConfigError("path", f"{p} holds one array, not a movie (.npz archive)")
        if not magic.startswith(b"PK"):
            raise ConfigError("path", f"{p} is not a movie (.npz archive)")
        try:
            z = np.load(p, allow_pickle=False)
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            reason = " ".join(str(exc).split())[:100] or type(exc).__name__
            raise ConfigError("path", f"cannot read movie {p}: {reason}") from None
        if not hasattr(z, "files"):
            raise ConfigError("path", f"{p} holds one array, not a movie (.npz archive)")
        try:
            with z:
                return cls._from_archive(z, p)
        except ConfigError:
            raise
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            reason = " ".join(str(exc).split())[:100] or type(exc).__name__
            raise ConfigError("path", f"cannot read movie {p}: {reason}") from None

    @classmethod
    def _from_archive(cls, z: Any, p: Path) -> Movie:
        keys = set(z.files)
        required = ["times", "wind", "arena_lower", "arena_upper", "resolution"]
        required += ["source_positions", "source_rates"]
        missing = [k for k in required if k not in keys]
        if missing:
            raise ConfigError("path", f"{p} is not a movie: no {', '.join(missing)}")
        times = np.asarray(z["times"], float)
        lower = np.asarray(z["arena_lower"], float)
        dim = lower.size
        if times.ndim != 1 or times.size == 0 or np.any(np.diff(times) <= 0):
            raise ConfigError("path", f"{p}: 'times' must be a non-empty increasing list")
        if dim not in (2, 3):
            raise ConfigError("path", f"{p}: 'arena_lower' must have 2 or 3 components")
        axes_missing = [f"wind_axis_{a}" for a in range(dim) if f"wind_axis_{a}" not in keys]
        if axes_missing:
            raise ConfigError("path", f"{p} is not a movie: no {', '.join(axes_missing)}")
        axes = [np.asarray(z[f"wind_axis_{a}"], float) for a in range(dim)]
        wind = np.asarray(z["wind"], float)
        want = (times.size, *(ax.size for ax in axes), dim)
        if wind.shape != want:
            raise ConfigError("path", f"{p}: 'wind' has shape {wind.shape}, expected {want}")
        frames: list[dict[str, np.ndarray]] = [{} for _ in range(times.size)]
        for key in keys:
            if key.startswith("frame_"):
                head, _, name = key.partition("__")
                k = head[6:]
                if not (name and k.isdigit() and int(k) < times.size):
                    raise ConfigError("path", f"{p}: array {key!r} is not a frame of the movie")
                frames[int(k)][name] = z[key]
        for k, frame in enumerate(frames):
            if "model" not in frame:
                raise ConfigError("path", f"{p}: frame {k} has no 'model' entry")
        return cls(
            times=times,
            frames=frames,
            wind_axes=axes,
            wind=wind,
            arena_lower=lower,
            arena_upper=np.asarray(z["arena_upper"], float),
            resolution=float(z["resolution"]),
            source_positions=z["source_positions"],
            source_rates=z["source_rates"],
            occ=z["occ"] if "occ" in keys else None,
        )


def record_movie(
    target: tuple[PlumeModel, WindModel],
    duration: float,
    frame_dt: float,
    rng: np.random.Generator,
    *,
    dt: float | None = None,
    wind_shape: Sequence[int] | None = None,
) -> Movie:
    """Step a plume and its wind and record a frame every ``frame_dt`` seconds.

    The first frame is the current state (time ``plume.t``); then ``floor(duration / frame_dt)``
    more frames follow. The wind is stepped before the plume, as in :class:`World`.

    Parameters
    ----------
    target : (plume, wind)
        What to record (:meth:`odorloc.world.world.World.record` records a world).
    duration : float, seconds
    frame_dt : float, seconds
        Frame interval; an integer multiple of ``dt``.
    rng : numpy.random.Generator
    dt : float, optional
        Simulation step, seconds (default ``frame_dt``).
    wind_shape : sequence of int, optional
        Wind nodes per axis (default 15 per horizontal axis and 5 vertically).

    Returns
    -------
    Movie
    """
    plume, wind = target
    for name, v in (("duration", duration), ("frame_dt", frame_dt)):
        if not (np.isfinite(v) and v > 0):
            raise ConfigError(name, f"must be a finite number > 0, got {v}")
    step = frame_dt if dt is None else float(dt)
    if not (np.isfinite(step) and step > 0):
        raise ConfigError("dt", f"must be a finite number > 0, got {dt}")
    nsub = round(frame_dt / step)
    if nsub < 1 or abs(nsub * step - frame_dt) > 1e-9 * frame_dt:
        raise ConfigError("frame_dt", f"must be an integer multiple of dt={step:g}")
    arena = plume.arena
    dim = arena.dim
    shape = tuple(wind_shape) if wind_shape is not None else (15, 15, 5)[:dim]
    if len(shape) != dim or min(shape) < 1:
        raise ConfigError("wind_shape", f"needs {dim} positive node counts")
    bounds = zip(arena.lower, arena.upper, shape, strict=True)
    axes = [np.linspace(lo, hi, n) for lo, hi, n in bounds]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    times, frames, winds = [], [], []

    def grab() -> None:
        times.append(plume.t)
        frames.append(plume.frame())
        winds.append(wind.velocity(nodes).reshape(*shape, dim))

    grab()
    for _ in range(int(np.floor(duration / frame_dt + 1e-9))):
        for _ in range(nsub):
            wind.step(step, rng)
            plume.step(step, rng)
        grab()
    return Movie(
        times=np.asarray(times, float),
        frames=frames,
        wind_axes=axes,
        wind=np.stack(winds),
        arena_lower=arena.lo.copy(),
        arena_upper=arena.hi.copy(),
        resolution=arena.resolution,
        source_positions=plume.source_positions,
        source_rates=np.array([s.rate for s in plume.sources], float),
        occ=None if arena.occ is None else np.array(arena.occ),
    )


class ReplayParams(Params):
    """Parameters of :class:`ReplayPlume` and :class:`ReplayWind`.

    Attributes
    ----------
    path : str or None
        ``.npz`` movie file (required unless a :class:`Movie` is passed in code); in a scenario
        file, a relative path is relative to that file's folder.
    loop : bool
        Past the last frame, start again from the first (else hold the last frame).
    """

    path: str | None = Field(None, json_schema_extra={"file_path": True})
    loop: bool = False


def _movie(params: ReplayParams, movie: Movie | None, field: str) -> Movie:
    if movie is not None:
        return movie
    if params.path is None:
        raise ConfigError(f"{field}.path", "a movie file is required")
    return Movie.load(params.path)


@register("plume", "replay", ReplayParams, "plays back a recorded plume movie")
class ReplayPlume(PlumeModel):
    """Plays a :class:`Movie` back: the concentration at time ``t`` is that of the latest frame
    ``<= t``, bit-identical to the recorded plume's at the frame times.

    ``encounter_rate`` is the concentration (the movie stores no rate model).
    """

    def __init__(
        self,
        params: ReplayParams,
        arena: Arena | None = None,
        wind: WindModel | None = None,
        sources: Sequence[Source] | None = None,
        movie: Movie | None = None,
    ) -> None:
        mv = _movie(params, movie, "plume")
        arena = arena if arena is not None else mv.arena()
        if arena.dim != mv.dim:
            raise ConfigError("plume.path", f"movie is {mv.dim}D but the arena is {arena.dim}D")
        wind = wind if wind is not None else ReplayWind(params, arena, movie=mv)
        super().__init__(arena, wind, sources if sources is not None else mv.sources())
        self.params = params
        self.movie = mv
        self.t = float(mv.times[0])

    @classmethod
    def from_movie(cls, movie: Movie, loop: bool = False) -> ReplayPlume:
        """A replay of ``movie`` in its own arena, with its sources and a :class:`ReplayWind`."""
        return cls(ReplayParams(loop=loop), movie=movie)

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self.t = float(self.movie.times[0])

    @property
    def frame_index(self) -> int:
        """Index of the frame shown at the current time."""
        return self.movie.index(self.t, self.params.loop)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return self.movie.concentration(self.frame_index, points)

    def frame(self) -> dict[str, np.ndarray]:
        return {k: np.array(v, copy=True) for k, v in self.movie.frames[self.frame_index].items()}


@register("wind", "replay", ReplayParams, "plays back the wind of a recorded movie")
class ReplayWind(WindModel):
    """The wind of a :class:`Movie`: multilinear on its node grid, piecewise constant in time."""

    deterministic = True

    def __init__(
        self, params: ReplayParams, arena: Arena | None = None, movie: Movie | None = None
    ) -> None:
        mv = _movie(params, movie, "wind")
        arena = arena if arena is not None else mv.arena()
        if arena.dim != mv.dim:
            raise ConfigError("wind.path", f"movie is {mv.dim}D but the arena is {arena.dim}D")
        super().__init__(arena)
        self.params = params
        self.movie = mv
        self.t = float(mv.times[0])

    def reset(self, rng: np.random.Generator) -> None:
        super().reset(rng)
        self.t = float(self.movie.times[0])

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        return self.movie.wind_velocity(self.movie.index(t, self.params.loop), points)
