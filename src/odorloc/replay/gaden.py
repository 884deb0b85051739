"""GADEN simulations in and out: read GADEN's filament logs, wind files and occupancy grid as a
replayed plume and wind, and write our 3-D filament plume in the same format.

The format, as GADEN's player reads it (GADEN 2.x; version-1 logs are read too):

``<sim>/iteration_<i>``
    One zlib stream per saved frame (``results_time_step`` seconds apart). Decompressed:
    ``int32`` version major, ``int32`` minor; the environment description (``int32 x 3`` cell
    counts, ``float32 x 3`` lower corner in m, ``float32 x 3`` upper corner in m, ``float32``
    cell size in m); ``float32 x 3`` source position (m); ``int32`` gas type; ``float64`` moles
    of gas per filament; ``float64`` moles of all gases per cm^3; ``int32`` wind index; then one
    record per live filament: ``int32`` filament id, ``float64 x 3`` centre (m), ``float64``
    sigma (cm). Little-endian, packed.
``<sim>/wind/wind_iteration_<w>``
    Raw ``float64`` arrays U, V, W (m/s), one value per cell, x index fastest
    (``i + j nx + k nx ny``).
``OccupancyGrid3D.csv``
    Text: ``#env_min(m) x y z``, ``#env_max(m) x y z``, ``#num_cells nx ny nz``,
    ``#cell_size(m) c``, then per height ``k`` one line per ``i`` with the ``ny`` states
    (0 free, 1 obstacle, 2 outlet) of ``j = 0 .. ny-1``, and a line ``;`` after each height.

Concentration at ``x`` (ppm), GADEN's player rule: every filament within ``5 sigma`` whose centre
has line of sight to ``x`` through free cells adds
``moles / ((2 pi)^(3/2) sigma^3) exp(-r^2 / (2 sigma^2)) / moles_all * 1e6`` (``r`` and ``sigma``
in cm). Wind at ``x``: the value of the cell containing ``x``.

Frames are decoded one at a time, when the replay reaches them (a long log never sits in memory
whole); frame ``k`` is shown from ``k * frame_dt`` to ``(k + 1) * frame_dt`` seconds.
"""

from __future__ import annotations

import math
import re
import struct
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field
from scipy.spatial import cKDTree

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.geometry.arena import Arena
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel

__all__ = [
    "FILAMENT_DTYPE",
    "GadenFrame",
    "GadenHeader",
    "GadenParams",
    "GadenPlume",
    "GadenSimulation",
    "GadenWind",
    "GadenWriter",
    "read_occupancy",
    "record_gaden",
    "write_occupancy",
]

#: One filament record of a log: id, centre (m), sigma (cm); packed, 36 bytes.
FILAMENT_DTYPE = np.dtype(
    [("id", "<i4"), ("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("sigma", "<f8")]
)
#: Version-2 header: version, cells, lower, upper, cell size, source, gas, moles, moles of all
#: gases per cm^3 (then the ``int32`` wind index).
_V2_PRE = struct.Struct("<ii3i3f3ff3fidd")
_V2_HEAD = struct.Struct("<ii3i3f3ff3fiddi")
#: Version-1 header: version, lower, upper (float64), cells, cell size x 3, source, gas, moles.
_V1_HEAD = struct.Struct("<i3d3d3i3d3diddi")
#: GADEN's player counts a filament up to this many sigmas away.
CUTOFF_SIGMAS = 5.0
_VERSION = (2, 4)
#: Moles of all gases per cm^3 at 1 atm and 298 K (ideal gas, R = 82.057338 cm^3 atm/(mol K)).
AIR_MOLES_CM3 = 1.0 / (82.057338 * 298.0)


@dataclass(frozen=True)
class GadenHeader:
    """The environment and gas constants of a GADEN log (identical in every frame)."""

    version: tuple[int, int]
    num_cells: tuple[int, int, int]
    lower: tuple[float, float, float]
    upper: tuple[float, float, float]
    cell_size: float
    source: tuple[float, float, float]
    gas_type: int
    moles_per_filament: float
    moles_all_per_cm3: float

    @property
    def ppm_factor(self) -> float:
        """``1e6 moles / moles_all``: a filament's ppm is this times its normalised kernel in
        cm^-3."""
        return 1e6 * self.moles_per_filament / self.moles_all_per_cm3


@dataclass(frozen=True, eq=False)
class GadenFrame:
    """One decoded frame: its wind index and filaments (centres in m, sigma in cm)."""

    wind_index: int
    ids: np.ndarray
    positions: np.ndarray
    sigma_cm: np.ndarray


def _fail(path: Path, problem: str) -> ConfigError:
    return ConfigError("path", f"{path}: {problem}")


def _decompress(path: Path) -> bytes:
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise _fail(path, f"cannot read ({exc.strerror})") from None
    d = zlib.decompressobj()
    try:
        data = d.decompress(raw) + d.flush()
    except zlib.error as exc:
        raise _fail(path, f"corrupted frame file (zlib: {exc})") from None
    if not d.eof:
        raise _fail(path, "truncated frame file (the zlib stream ends early)")
    return data


def parse_frame(path: Path, data: bytes) -> tuple[GadenHeader, GadenFrame]:
    """Header and filaments of one decompressed frame; :class:`ConfigError` when malformed."""
    if len(data) < 4:
        raise _fail(path, "truncated frame (no version)")
    (major,) = struct.unpack_from("<i", data, 0)
    if major == 1:
        head = _V1_HEAD
        if len(data) < head.size:
            raise _fail(path, "truncated frame header")
        v = head.unpack_from(data, 0)
        header = GadenHeader(
            (1, 0), tuple(v[7:10]), tuple(v[1:4]), tuple(v[4:7]), float(v[10]),
            tuple(v[13:16]), int(v[16]), float(v[17]), float(v[18]),
        )  # fmt: skip
        wind = int(v[19])
    elif major == 2:
        head = _V2_HEAD
        if len(data) < head.size:
            raise _fail(path, "truncated frame header")
        v = head.unpack_from(data, 0)
        header = GadenHeader(
            (2, int(v[1])), tuple(v[2:5]), tuple(v[5:8]), tuple(v[8:11]), float(v[11]),
            tuple(v[12:15]), int(v[15]), float(v[16]), float(v[17]),
        )  # fmt: skip
        wind = int(v[18])
    else:
        raise _fail(path, f"unknown log version {major} (expected 1 or 2)")
    body = len(data) - head.size
    if body % FILAMENT_DTYPE.itemsize:
        raise _fail(
            path,
            f"truncated frame: {body} bytes of filament records is not a multiple of "
            f"{FILAMENT_DTYPE.itemsize}",
        )
    rec = np.frombuffer(data, FILAMENT_DTYPE, offset=head.size)
    pos = np.column_stack([rec["x"], rec["y"], rec["z"]])
    sig = rec["sigma"].astype(float)
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(sig)) and np.all(sig > 0)):
        raise _fail(path, "corrupted frame: non-finite filament or sigma <= 0")
    cells = np.asarray(header.num_cells)
    if np.any(cells < 1) or not header.cell_size > 0 or header.moles_all_per_cm3 <= 0:
        raise _fail(path, "corrupted frame header (cell counts, cell size or gas constants)")
    return header, GadenFrame(wind, rec["id"].copy(), pos, sig)


# ---------------------------------------------------------------------- occupancy
def read_occupancy(path: str | Path) -> tuple[np.ndarray, np.ndarray, float]:
    """GADEN ``OccupancyGrid3D.csv``: ``(states (nx, ny, nz) uint8, lower (3,), cell size)``."""
    p = Path(path)
    try:
        lines = p.read_text().splitlines()
    except OSError as exc:
        raise _fail(p, f"cannot read occupancy grid ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise _fail(p, "not a GADEN occupancy grid (not a text file)") from None
    try:
        lo = np.array(lines[0].split()[1:4], float)
        n = [int(float(v)) for v in lines[2].split()[1:4]]
        cell = float(lines[3].split()[1])
        if not (lines[0].startswith("#env_min") and lines[2].startswith("#num_cells")):
            raise ValueError
    except (IndexError, ValueError):
        raise _fail(p, "not a GADEN occupancy grid (header lines #env_min .. #cell_size)") from None
    nx, ny, nz = n
    grid = np.zeros((nx, ny, nz), np.uint8)
    i = k = 0
    for lineno, line in enumerate(lines[4:], start=5):
        s = line.strip()
        if s == ";":
            k += 1
            i = 0
            continue
        if not s:
            continue
        vals = s.split()
        if k >= nz or i >= nx or len(vals) != ny:
            raise _fail(p, f"line {lineno}: expected {ny} cell states of x row {i}, height {k}")
        grid[i, :, k] = np.array(vals, np.uint8)
        i += 1
    if k < nz:
        raise _fail(p, f"has {k} of {nz} heights (truncated)")
    return grid, lo, cell


def write_occupancy(
    path: str | Path, states: np.ndarray, lower: Sequence[float], cell: float
) -> Path:
    """Write ``states (nx, ny, nz)`` (0 free, 1 obstacle, 2 outlet) as ``OccupancyGrid3D.csv``."""
    p = Path(path)
    g = np.asarray(states, np.uint8)
    nx, ny, nz = g.shape
    lo = np.asarray(lower, float)
    hi = lo + np.array(g.shape) * cell
    with p.open("w") as fh:
        fh.write(f"#env_min(m) {lo[0]:g} {lo[1]:g} {lo[2]:g}\n")
        fh.write(f"#env_max(m) {hi[0]:g} {hi[1]:g} {hi[2]:g}\n")
        fh.write(f"#num_cells {nx} {ny} {nz}\n")
        fh.write(f"#cell_size(m) {cell:g}\n")
        for k in range(nz):
            for i in range(nx):
                fh.write(" ".join(str(int(v)) for v in g[i, :, k]) + " \n")
            fh.write(";\n")
    return p


# ---------------------------------------------------------------------- simulation (lazy)
_ITER = re.compile(r"^iteration_(\d+)$")


class GadenSimulation:
    """A GADEN results folder, read lazily (one frame and one wind field decoded at a time).

    Parameters
    ----------
    folder : str or Path
        The ``results_location`` of GADEN's filament simulator (``iteration_<i>`` files and a
        ``wind/`` folder).
    occupancy : str or Path, optional
        ``OccupancyGrid3D.csv`` of the environment, for the line-of-sight rule (without it every
        filament inside the bounds is seen).
    first_iteration : int
        First iteration shown (GADEN's player ``initial_iteration``).
    """

    def __init__(
        self,
        folder: str | Path,
        occupancy: str | Path | None = None,
        first_iteration: int = 0,
    ) -> None:
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise _fail(self.folder, "simulation folder does not exist")
        found = {}
        for f in self.folder.iterdir():
            m = _ITER.match(f.name)
            if m:
                found[int(m.group(1))] = f
        self.iterations = sorted(i for i in found if i >= first_iteration)
        if not self.iterations:
            raise _fail(self.folder, f"no iteration_<i> files from iteration {first_iteration}")
        # frame j is shown at j * dt: a gap would shift every later frame in time
        gap = next((i for j, i in enumerate(self.iterations) if i != self.iterations[0] + j), None)
        if gap is not None:
            missing = self.iterations[0] + self.iterations.index(gap)
            raise _fail(self.folder, f"iteration_{missing} is missing (iterations must follow on)")
        self._files = found
        self.header, first = parse_frame(self._files[self.iterations[0]], self._read(0))
        self._cache: tuple[int, GadenFrame] = (0, first)
        self._wind_cache: tuple[int, np.ndarray] | None = None
        h = self.header
        self.lower = np.asarray(h.lower, float)
        self.upper = np.asarray(h.upper, float)
        self.shape = tuple(int(v) for v in h.num_cells)
        self.cell = float(h.cell_size)
        self.occupancy: np.ndarray | None = None
        if occupancy is not None:
            states, lo, _cell = read_occupancy(occupancy)
            if states.shape != self.shape or not np.allclose(lo, self.lower, atol=1e-4):
                raise _fail(
                    Path(occupancy),
                    f"grid {states.shape} at {lo.tolist()} does not match the log's "
                    f"{self.shape} at {self.lower.tolist()}",
                )
            self.occupancy = states != 0
        self.wind_file(first.wind_index)  # the first frame's wind must exist

    def _read(self, k: int) -> bytes:
        return _decompress(self._files[self.iterations[k]])

    @property
    def n_frames(self) -> int:
        """Number of frames from ``first_iteration`` on."""
        return len(self.iterations)

    def frame(self, k: int) -> GadenFrame:
        """Frame ``k`` (decoded now unless it is the one decoded last)."""
        if self._cache[0] != k:
            path = self._files[self.iterations[k]]
            header, fr = parse_frame(path, self._read(k))
            if header.num_cells != self.header.num_cells or header.lower != self.header.lower:
                raise _fail(path, "environment differs from the first frame's")
            self._cache = (k, fr)
        return self._cache[1]

    def frames(self) -> Iterator[GadenFrame]:
        """Every frame in order, decoded one at a time."""
        for k in range(self.n_frames):
            yield self.frame(k)

    def verify(self) -> int:
        """Decode every frame and its wind once (one at a time); return the number of frames."""
        for fr in self.frames():
            self.wind(fr.wind_index)
        return self.n_frames

    def wind_file(self, index: int) -> Path:
        """Path of wind file ``index``; :class:`ConfigError` when missing."""
        p = self.folder / "wind" / f"wind_iteration_{index}"
        if not p.is_file():
            raise _fail(p, "wind file is missing")
        return p

    def wind(self, index: int) -> np.ndarray:
        """Wind field ``index`` as ``(nx, ny, nz, 3)`` m/s (decoded now unless cached)."""
        if self._wind_cache is None or self._wind_cache[0] != index:
            p = self.wind_file(index)
            n = int(np.prod(self.shape))
            raw = np.fromfile(p, "<f8")
            if raw.size != 3 * n:
                raise _fail(p, f"wind file holds {raw.size} values, expected 3 x {n} cells")
            # x index fastest in the file: (3, nz, ny, nx) viewed as (nx, ny, nz, 3), no copy
            nx, ny, nz = self.shape
            field = raw.reshape(3, nz, ny, nx).transpose(3, 2, 1, 0)
            if not np.all(np.isfinite(field)):
                raise _fail(p, "corrupted wind file: non-finite values")
            self._wind_cache = (index, field)
        return self._wind_cache[1]

    # ------------------------------------------------------------------ queries
    def cell_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cell indices ``(Q, 3)`` of points and whether they lie inside the bounds ``(Q,)``."""
        idx = np.floor((points - self.lower) / self.cell).astype(np.intp)
        inside = np.all((points >= self.lower) & (points <= self.upper), axis=1)
        return np.clip(idx, 0, np.asarray(self.shape) - 1), inside

    def free(self, points: np.ndarray) -> np.ndarray:
        """``True`` where points are inside the bounds and in a free cell, ``(Q,)``."""
        idx, inside = self.cell_of(points)
        if self.occupancy is None:
            return inside
        return inside & ~self.occupancy[idx[:, 0], idx[:, 1], idx[:, 2]]

    def line_of_sight(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """GADEN's visibility rule for pairs ``(P, 3)``: both ends free and every sample of the
        segment (at most half a cell apart) in a free cell."""
        ok = self.free(a) & self.free(b)
        if self.occupancy is None or not ok.any():
            return ok
        sel = np.flatnonzero(ok)
        d = np.linalg.norm(b[sel] - a[sel], axis=1)
        n = np.maximum(np.ceil(d / (0.5 * self.cell)).astype(np.intp), 1)
        owner = np.repeat(np.arange(len(sel)), n - 1)
        if owner.size:
            start = np.cumsum(n - 1) - (n - 1)
            step = np.arange(owner.size) - np.repeat(start, n - 1) + 1
            s = (step / np.repeat(n, n - 1))[:, None]
            pts = a[sel][owner] + s * (b[sel] - a[sel])[owner]
            blocked = ~self.free(pts)
            bad = np.zeros(len(sel), bool)
            np.logical_or.at(bad, owner[blocked], True)
            ok[sel[bad]] = False
        return ok

    def concentration(self, k: int, points: np.ndarray) -> np.ndarray:
        """Concentration (ppm) of frame ``k`` at ``(Q, 3)`` points (GADEN's player rule)."""
        fr = self.frame(k)
        q = len(points)
        out = np.zeros(q)
        if len(fr.sigma_cm) == 0 or q == 0:
            return out
        sig_m = fr.sigma_cm / 100.0
        reach = CUTOFF_SIGMAS * float(sig_m.max())
        tree = cKDTree(fr.positions)
        pairs = cKDTree(points).sparse_distance_matrix(tree, reach, output_type="ndarray")
        if len(pairs) == 0:
            return out
        i, j, r = pairs["i"], pairs["j"], pairs["v"]
        keep = r < CUTOFF_SIGMAS * sig_m[j]
        i, j, r = i[keep], j[keep], r[keep]
        vis = self.line_of_sight(points[i], fr.positions[j])
        i, j, r = i[vis], j[vis], r[vis]
        s = fr.sigma_cm[j]
        r_cm = 100.0 * r
        c = (2.0 * math.pi) ** -1.5 * s**-3 * np.exp(-0.5 * (r_cm / s) ** 2)
        out += np.bincount(i, weights=c * self.header.ppm_factor, minlength=q)
        return out

    def wind_at(self, k: int, points: np.ndarray) -> np.ndarray:
        """Wind of frame ``k`` at ``(Q, 3)`` points (value of the containing cell), m/s."""
        field = self.wind(self.frame(k).wind_index)
        idx, inside = self.cell_of(points)
        v = field[idx[:, 0], idx[:, 1], idx[:, 2]]
        return np.where(inside[:, None], v, 0.0)


# ---------------------------------------------------------------------- plume and wind
class GadenParams(Params):
    """Parameters of :class:`GadenPlume` and :class:`GadenWind`.

    Attributes
    ----------
    path : str
        GADEN results folder (``iteration_<i>`` files and ``wind/``).
    extra_paths : list of str
        Further simulations of the same environment (GADEN runs one per source); their
        concentrations add up, the wind is the first one's.
    occupancy : str, optional
        ``OccupancyGrid3D.csv`` for the line-of-sight rule.
    frame_dt : float, seconds
        Time between saved frames (GADEN's ``results_time_step``).
    first_iteration : int
        First iteration played.
    loop : bool
        Past the last frame start again from the first (else hold the last).
    verify : bool
        Decode every frame once when loading, so a corrupted file is reported before the run.
    """

    path: str = Field(json_schema_extra={"file_path": True})
    extra_paths: list[str] = Field(default_factory=list, json_schema_extra={"file_path": True})
    occupancy: str | None = Field(None, json_schema_extra={"file_path": True})
    frame_dt: Positive = 0.5
    first_iteration: int = Field(0, ge=0)
    loop: bool = False
    verify: bool = False


def _open(params: GadenParams) -> list[GadenSimulation]:
    sims = [
        GadenSimulation(p, params.occupancy, params.first_iteration)
        for p in [params.path, *params.extra_paths]
    ]
    for s in sims[1:]:
        if s.shape != sims[0].shape or not np.allclose(s.lower, sims[0].lower):
            raise ConfigError("extra_paths", f"{s.folder} is not the same environment")
    if params.verify:
        for s in sims:
            s.verify()
    return sims


def _frame_index(t: float, frame_dt: float, n: int, loop: bool) -> int:
    k = math.floor(t / frame_dt + 1e-9)
    if loop:
        return k % n
    return min(max(k, 0), n - 1)


def _check_arena(arena: Arena, sim: GadenSimulation, field: str) -> None:
    if arena.dim != 3:
        raise ConfigError(field, "GADEN simulations are 3-D; the arena is 2-D")
    inside = np.all(arena.lo >= sim.lower - 1e-6) and np.all(arena.hi <= sim.upper + 1e-6)
    if not inside:
        raise ConfigError(
            field,
            f"arena {arena.lo.tolist()}..{arena.hi.tolist()} exceeds the simulation's bounds "
            f"{sim.lower.tolist()}..{sim.upper.tolist()}",
        )


class GadenWind(WindModel):
    """The wind of a GADEN simulation (the frame's wind file, value of the containing cell)."""

    Params = GadenParams
    deterministic = True

    def __init__(
        self, params: GadenParams, arena: Arena, sims: list[GadenSimulation] | None = None
    ):
        super().__init__(arena)
        self.params = params
        self.sims = sims if sims is not None else _open(params)
        _check_arena(arena, self.sims[0], "world.wind.path")

    def _velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        s = self.sims[0]
        k = _frame_index(t, self.params.frame_dt, s.n_frames, self.params.loop)
        return s.wind_at(k, points)


class GadenPlume(PlumeModel):
    """A GADEN simulation played back as a plume (see the module docstring).

    Concentrations are in ppm; :meth:`encounter_rate` is the concentration (no rate model).
    """

    Params = GadenParams

    def __init__(
        self,
        params: GadenParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source] | None = None,
    ) -> None:
        shared = isinstance(wind, GadenWind) and wind.params == params
        self.sims = wind.sims if shared else _open(params)
        _check_arena(arena, self.sims[0], "world.plume.path")
        src = (
            sources if sources else [Source(position=s.header.source, rate=1.0) for s in self.sims]
        )
        super().__init__(arena, wind, src)
        self.params = params

    @property
    def frame_index(self) -> int:
        """Index of the frame shown at the current time."""
        return _frame_index(self.t, self.params.frame_dt, self.sims[0].n_frames, self.params.loop)

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        k = self.frame_index
        out = self.sims[0].concentration(k, points)
        for s in self.sims[1:]:
            out += s.concentration(min(k, s.n_frames - 1), points)
        return out

    def frame(self) -> dict[str, np.ndarray]:
        fr = self.sims[0].frame(self.frame_index)
        # As a filament frame of our own plume (same kernel, 5-sigma cutoff; no line of sight).
        return {
            "model": np.array("filament"),
            "positions": fr.positions.copy(),
            "sigma2": (fr.sigma_cm / 100.0) ** 2,
            "amount": np.full(len(fr.sigma_cm), self.sims[0].header.ppm_factor * 1e-6),
            "cutoff": np.array(CUTOFF_SIGMAS),
        }


# ---------------------------------------------------------------------- writer
class GadenWriter:
    """Writes frames of a 3-D filament plume in GADEN's log format (one file per frame).

    Parameters
    ----------
    folder : str or Path
        Results folder to create (``iteration_<i>``, ``wind/wind_iteration_<w>``).
    arena : Arena
        3-D arena: bounds, cell size (its resolution) and obstacles (written as the occupancy
        grid ``OccupancyGrid3D.csv`` beside the frames).
    source : (3,) sequence of float, metres
    amount : float
        Amount per filament of our plume (its kernel integral, concentration units x m^3); the
        gas constants are chosen so GADEN's ppm equals our concentration.
    gas_type : int
        GADEN gas code (0 ethanol, 1 methane, ...).
    """

    def __init__(
        self,
        folder: str | Path,
        arena: Arena,
        source: Sequence[float],
        amount: float,
        gas_type: int = 0,
    ) -> None:
        if arena.dim != 3:
            raise ConfigError("arena", "GADEN logs are 3-D")
        self.folder = Path(folder)
        (self.folder / "wind").mkdir(parents=True, exist_ok=True)
        self.arena = arena
        self.shape = tuple(int(v) for v in arena.grid_shape)
        # ppm = moles / (moles_all (2 pi)^1.5 sigma_m^3) exp(...): moles / moles_all = amount
        self._head = _V2_PRE.pack(
            *_VERSION,
            *self.shape,
            *arena.lo.astype(np.float32),
            *arena.hi.astype(np.float32),
            float(arena.resolution),
            *np.asarray(source, np.float32),
            int(gas_type),
            float(amount) * AIR_MOLES_CM3,
            AIR_MOLES_CM3,
        )
        occ = np.zeros(self.shape, np.uint8) if arena.occ is None else arena.occ.astype(np.uint8)
        write_occupancy(self.folder / "OccupancyGrid3D.csv", occ, arena.lo, arena.resolution)
        self.n_frames = 0
        self.n_winds = 0
        self._last_wind: np.ndarray | None = None
        axes = arena.cell_centers()
        g = np.meshgrid(*axes, indexing="ij")
        # cell centres in the file's order (x fastest)
        self._centres = np.column_stack([a.ravel(order="F") for a in g])

    def write_wind(self, wind: WindModel) -> int:
        """Sample ``wind`` at the cell centres; write a new wind file unless it is unchanged.
        Returns the index of the wind file in force."""
        v = wind.velocity(self._centres)
        if self._last_wind is not None and np.array_equal(v, self._last_wind):
            return self.n_winds - 1
        p = self.folder / "wind" / f"wind_iteration_{self.n_winds}"
        np.ascontiguousarray(v.T, "<f8").tofile(p)
        self._last_wind = v
        self.n_winds += 1
        return self.n_winds - 1

    def write_frame(self, positions: np.ndarray, sigma: np.ndarray, wind_index: int) -> Path:
        """Write one frame: filament centres ``(F, 3)`` m and widths ``sigma (F,)`` m."""
        rec = np.zeros(len(sigma), FILAMENT_DTYPE)
        rec["id"] = np.arange(len(sigma))
        rec["x"], rec["y"], rec["z"] = positions[:, 0], positions[:, 1], positions[:, 2]
        rec["sigma"] = 100.0 * np.asarray(sigma, float)
        blob = self._head + struct.pack("<i", int(wind_index)) + rec.tobytes()
        p = self.folder / f"iteration_{self.n_frames}"
        p.write_bytes(zlib.compress(blob))
        self.n_frames += 1
        return p


def record_gaden(
    scenario: Any,
    world_seed: int,
    folder: str | Path,
    duration: float,
    frame_dt: float = 0.5,
) -> GadenWriter:
    """Simulate a 3-D filament-plume scenario's world and write it as a GADEN simulation.

    The world is prepared as an episode with ``world_seed`` would see it (same warm-up); a frame
    is written every ``frame_dt`` seconds for ``duration`` seconds, one at a time.
    """
    from odorloc.engine.episode import control_substeps, prepare_world
    from odorloc.plume.filament import FilamentPlume

    world, rng, _ = prepare_world(scenario, world_seed)
    if not isinstance(world.plume, FilamentPlume) or world.arena.dim != 3:
        raise ConfigError("world.plume", "record_gaden writes a 3-D filament plume")
    _, _, wdt = control_substeps(scenario)
    n_sub = round(frame_dt / wdt)
    if n_sub < 1 or abs(n_sub * wdt - frame_dt) > 1e-9:
        raise ConfigError("frame_dt", f"must be a multiple of the world step {wdt:g} s")
    plume = world.plume
    w = GadenWriter(folder, world.arena, plume.source_positions[0], plume.params.amount)
    for k in range(math.floor(duration / frame_dt + 1e-9) + 1):
        if k:
            for _ in range(n_sub):
                world.step(wdt, rng)
        wi = w.write_wind(world.wind)
        w.write_frame(plume.positions, np.sqrt(plume.sigma2), wi)
    return w
