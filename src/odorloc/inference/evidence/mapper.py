"""The D-S map of several sources: odor-path maps fused by Dempster's rule (D-S paper).

:class:`DSMapper` bundles two parts so that any motion strategy can build the same map (the
estimator ``ds-map``, :class:`DSMapEstimator`, holds one):

* :class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator` turns the robot's wind
  record into the air-mass path map ``pi`` of the air now at the robot (odor-path paper,
  eqs. 10-17);
* :class:`~odorloc.inference.evidence.dempster_shafer.DSGrid` fuses every reading -- detection
  *and* non-detection -- through that map with Dempster's rule (D-S paper, eqs. 1-4).

Readings of the paper (each configurable, :class:`DSMapParams`):

* Map extent. The grid covers the search region grown by ``map_margin`` (default one cell: the
  paper's maps mark cells outside the work area too, which "should be ignored"); only the
  region's cells count in ``sum X``, in planning and in the mapped sources. The paper does not
  give its cell size, but its residual sums bound it: they exceed ``3 M`` (total ignorance,
  ``q m(U) = 3`` per cell) unless the region has more than 439 cells, so cells must be below
  about 0.8 m; 0.5 m is the default.
* Reading. The binarised gas reading is the event ``D`` or ``notD``; the anemometer reading is
  the air velocity in the world frame (eq. 1, odor-path paper). Without ``preprocess`` the map
  of a reading is computed at its own record (the simulated sensor has no delay unless
  configured).
* Source estimates. The paper leaves declaration open ("some other methods should be considered
  next to declare the mapped odor sources"). The map is not changed by any of them;
  ``source_rule`` only reads it. ``likelihood`` (default) scores candidate source cells by how
  well they explain every fused reading: a reading detects with probability ``1 - (1 - eps)
  prod_c (1 - alpha pi_c)`` over the chosen source cells ``c`` (a noisy-OR of the sources its
  air-mass path ``pi`` passed, plus false alarms), and sources are added greedily, each the
  occupied cell (``m(S) >= source_min_mass``) with the largest gain in log-likelihood given
  those already chosen, until the gain falls below ``source_min_gain`` times the first one. A
  cell whose detections an upwind source already explains gains little (plume footprints
  downwind of a source are not sources), two sources side by side across the wind are found even
  where their footprints join into one region, and cells within ``source_exclusion`` (along,
  across the mean wind) of a chosen source are not candidates. Once a route has taken a close
  look at its mapped sources (:meth:`DSMapper.start_close_look`, by the dynamic route's
  visits), each visited likelihood source is re-placed along its own strip by the readings of
  that look alone (:meth:`DSMapper.refined`): readings taken metres downwind of a source cannot
  tell where along those metres it lies, and, being many, would otherwise place it just upwind
  of the nearest of them. The region rules read the connected regions with
  ``m(S) >= source_min_mass``, one estimate each: ``peak`` the region's strongest cell, ranked
  by the exactly stored doubt ``m(notS) + m(U)`` because long runs of detections round ``m(S)``
  to exactly 1.0; ``centroid`` the ``m(S)``-weighted centroid; ``upwind`` the centroid of the
  region's upwind end. A region
  is the footprint of where the robot detected (the source plus the plume downwind of it), so
  the centroid is pulled downwind, the peak may lie inside the footprint, and two joined
  footprints give one estimate; the README compares the rules.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator
from scipy import ndimage

from odorloc.core.errors import ConfigError
from odorloc.core.params import NonNegative, Params, Positive
from odorloc.core.registry import register
from odorloc.core.types import Declaration, Observation, Region, SearchContext
from odorloc.geometry.regions import check_region, narrow_box, resolve_region
from odorloc.inference.belief import GridBelief
from odorloc.inference.estimator import Estimator
from odorloc.inference.evidence.dempster_shafer import DSGrid, DSParams, EvidenceSource
from odorloc.inference.odor_path.estimator import OdorPathEstimator, OdorPathParams, PathPatch
from odorloc.models.base import MeasurementModel
from odorloc.sensors.preprocessing import OnlinePreprocessor, PreprocessorParams

__all__ = [
    "RULES",
    "DSMapEstimator",
    "DSMapParams",
    "DSMapper",
    "EvidenceBelief",
    "ReadingLog",
    "as_distribution",
    "evidence_belief",
]

FloatArray = NDArray[np.float64]


class DSMapParams(Params):
    """Parameters of the D-S map (shared by every searcher that builds one).

    Attributes
    ----------
    cell_size : float, metres
        Side of an evidence/path-map cell (0.5 m; see the module notes).
    map_margin : float, metres, optional
        The map covers the search region grown by this margin on every side; default one cell
        (see the module notes).
    region : ((x0, y0), (x1, y1)), optional
        Search region, metres; default the task's region, else the arena bounds.
    t_thr : float, seconds
        Wind history that opens sub-windows (odor-path paper: 10 s).
    noise_time_scale : float, seconds
        ``tau`` of the path-map variance ``(t_c - t_r) tau sigma_u^2`` (odor-path estimator).
    min_variance : float, m^2/s^2
        Floor on the wind-velocity variance per axis.
    kernel : {"point", "cell"}
        Path-map kernel (odor-path paper eq. 11 or the exact cell integral).
    ds : DSParams
        Belief-mass and uncertainty parameters (mu_D 0.9, mu_notD 1.0, zeta 0.6, rho 0.5, q 3).
    source_min_mass : float
        ``m(S)`` a cell needs to belong to a mapped source, in (0, 1].
    source_min_cells : int
        Smallest connected region counted as a mapped source.
    source_rule : {"likelihood", "peak", "centroid", "upwind"}
        How mapped sources are placed (see the module notes): ``"likelihood"`` (default) the
        cells that best explain the readings, chosen greedily; one estimate per connected
        region for the others: the centre of its cell with the largest ``m(S)``
        (``"peak"``), its ``m(S)``-weighted centroid (``"centroid"``, the paper's maps are
        read by eye), or the weighted centroid of its cells within ``upwind_depth`` of its
        most upwind cell along the mean recorded wind (``"upwind"``).
    source_hit_rate : float
        ``alpha`` of the likelihood rule: probability that a reading detects when all the
        air it samples passed a source cell (``pi = 1``), in (0, 1).
    source_false_alarm : float
        ``eps`` of the likelihood rule: probability of a detection no mapped source explains,
        in (0, 1).
    source_min_gain : float
        The likelihood rule stops when the next source's log-likelihood gain is below this
        fraction of the first source's, in (0, 1].
    source_exclusion : (along, across), metres
        Cells closer than these distances along and across the mean recorded wind to a chosen
        source are not candidates for the next one (the likelihood rule).
    max_sources : int
        Most sources the likelihood rule places.
    upwind_depth : float, metres
        Depth of the upwind end used by ``source_rule="upwind"``.
    path_normalise : {"window", "total"}
        ``pi`` as the odor-path estimator gives it (each sub-window normalised, the maximum
        over windows: odor-path paper eq. 17; default), or that map divided by its sum so that
        ``sum_i pi_i = 1`` (``"total"``: "the probability that the air mass arrived at the
        robot comes from the cell C_i", D-S paper section 2.2, read as one distribution; each
        reading then carries far less mass, see the README).
    preprocess : PreprocessorParams, optional
        Run the readings through the odor-path paper's pre-processing (eqs. 1-5: delay
        alignment, moving baseline, signal intensity) before fusing them, for a sensor that
        lags like the paper's PID. Each aligned reading is fused with the position and wind of
        the period it belongs to; its detection is ``intensity >= intensity_threshold``. Its
        ``period`` must be the control period (one reading per period). ``None`` (default)
        fuses every reading at once with the sensor's own detection.
    intensity_threshold : float
        Signal intensity ``s`` (eq. 5) that counts as a detection with ``preprocess``.
    """

    cell_size: Positive = 0.5
    map_margin: NonNegative | None = None
    region: Region | None = None
    t_thr: Positive = 10.0
    noise_time_scale: Positive = 1.0
    min_variance: Positive = 1e-4
    kernel: Literal["point", "cell"] = "point"
    ds: DSParams = DSParams()
    source_min_mass: float = Field(0.5, gt=0.0, le=1.0)
    source_min_cells: int = Field(1, ge=1, le=1_000_000)
    source_rule: Literal["likelihood", "peak", "centroid", "upwind"] = "likelihood"
    upwind_depth: Positive = 1.5
    source_hit_rate: float = Field(0.8, gt=0.0, lt=1.0)
    source_false_alarm: float = Field(0.02, gt=0.0, lt=1.0)
    source_min_gain: float = Field(0.15, gt=0.0, le=1.0)
    source_exclusion: tuple[NonNegative, NonNegative] = (3.0, 1.0)
    max_sources: int = Field(8, ge=1, le=100)
    path_normalise: Literal["window", "total"] = "window"
    preprocess: PreprocessorParams | None = None
    intensity_threshold: Positive = 0.1

    @model_validator(mode="after")
    def _check(self) -> DSMapParams:
        if self.region is not None:
            check_region(self.region, "region")
        return self


def as_distribution(patch: PathPatch) -> PathPatch:
    """The path map divided by its sum (unchanged if empty)."""
    total = float(patch.values.sum()) if patch.values.size else 0.0
    if total <= 0:
        return patch
    return PathPatch(patch.ix0, patch.iy0, patch.values / total, patch.grid, patch.ref_cell)


@dataclass(frozen=True, eq=False)
class EvidenceBelief(GridBelief):
    """The D-S map as a belief, with what a route planner weighs.

    Attributes
    ----------
    uncertainty : (nx, ny) ndarray
        Cell uncertainty ``X_i`` (eq. 5).
    path : PathPatch or None
        The air-mass path map of the reading fused last (``None``: none yet).
    region : ((x0, y0), (x1, y1))
        The search region, metres.
    """

    uncertainty: FloatArray | None = None
    path: PathPatch | None = None
    region: Region | None = None


def evidence_belief(
    grid: DSGrid, path: PathPatch | None, region: Region | None = None
) -> EvidenceBelief:
    """The belief of a D-S grid (:meth:`DSGrid.belief`) with its uncertainty and ``path``."""
    b = grid.belief()
    return EvidenceBelief(b.grid, b.prob, b.extra, grid.uncertainty(), path, region)


class DSMapper:
    """Odor-path estimator + Dempster-Shafer grid: the map both mapping searchers build.

    Parameters
    ----------
    params : DSMapParams
    region : ((x0, y0), (x1, y1)), metres
        Search region (uncertainty and sources are reported over it).
    dt : float, seconds
        Record period (the control period).

    Raises
    ------
    ConfigError
        If no cell centre of the map lies inside ``region`` (cells too large for it), or if the
        pre-processing's period differs from ``dt``.
    """

    def __init__(self, params: DSMapParams, region: Region, dt: float) -> None:
        self.params = params
        self.region = region
        m = params.cell_size if params.map_margin is None else params.map_margin
        lower = (region[0][0] - m, region[0][1] - m)
        upper = (region[1][0] + m, region[1][1] + m)
        self.estimator = OdorPathEstimator(
            OdorPathParams(
                cell_size=params.cell_size,
                t_thr=params.t_thr,
                dt=dt,
                noise_time_scale=params.noise_time_scale,
                min_variance=params.min_variance,
                kernel=params.kernel,
            ),
            lower,
            upper,
        )
        self.grid = DSGrid(params.ds, self.estimator.grid)
        if not self.grid.grid.region_mask(region).any():
            # with no cell of the region the map has nothing to report: sum X stays 0, the
            # route stops at once and no source can ever be mapped
            raise ConfigError(
                "searcher.cell_size",
                f"{params.cell_size:g} m cells leave no cell centre inside the search region "
                f"{region}",
            )
        self.n_detections = 0
        self.n_readings = 0
        self.wind_sum = np.zeros(2)
        self.initial_uncertainty = self.total_uncertainty()
        self.last_patch: PathPatch | None = None
        if params.preprocess is not None and not math.isclose(
            params.preprocess.period, dt, rel_tol=1e-9
        ):
            # the pre-processor takes one reading per call and counts the delay in its own
            # periods (k = int(tau / dt_c), eq. 2): any other period would align each reading
            # with the wrong record
            raise ConfigError(
                "searcher.preprocess.period",
                f"must equal the control period {dt:g} s, got {params.preprocess.period:g} s",
            )
        self._pre = OnlinePreprocessor(params.preprocess) if params.preprocess else None
        self._pending: deque[tuple[float, np.ndarray]] = deque()
        self._log = ReadingLog(self.grid.grid.shape)
        self._likely: tuple[int, FloatArray, FloatArray] | None = None
        # first reading of a route's close look at its mapped sources and the cells it read
        # from (see :meth:`start_close_look` and :meth:`refined`)
        self._close_since: int | None = None
        self._visited = np.zeros(self.grid.grid.shape, bool)

    def update(
        self,
        t: float,
        position: np.ndarray,
        wind: np.ndarray,
        detected: bool,
        reading: float | None = None,
    ) -> PathPatch | None:
        """Fuse one reading: record it, compute its air-mass path map, update the grid.

        Parameters
        ----------
        t : float, seconds
        position : (d,) ndarray, metres
            Sensor position (the first two components are used).
        wind : (d,) ndarray, m/s
            Anemometer reading, world frame.
        detected : bool
            Detection (eq. 4-a) or non-detection (eq. 4-b), D-S paper.
        reading : float, optional
            The raw gas reading (needed with ``preprocess``).

        Returns
        -------
        PathPatch or None
            The air-mass path map ``pi`` of the reading fused now; with ``preprocess``, of the
            aligned reading of ``delay`` seconds ago (``None`` until the first one is due).
        """
        if self._pre is None:
            return self._fuse(t, position, wind, detected)
        if reading is None:
            raise ConfigError("reading", "the pre-processing needs the raw gas reading")
        self._pending.append((float(t), np.asarray(position, float)[:2].copy()))
        sample = self._pre.update(float(reading), np.asarray(wind, float)[:2])
        if sample is None:
            return None
        t_j, pos_j = self._pending.popleft()
        det = sample.intensity >= self.params.intensity_threshold
        return self._fuse(t_j, pos_j, sample.wind, bool(det))

    def _fuse(self, t: float, position: np.ndarray, wind: np.ndarray, detected: bool) -> PathPatch:
        pos = np.asarray(position, float)[:2]
        u = np.asarray(wind, float)[:2]
        self.estimator.update(t, pos, u, 1.0 if detected else 0.0)
        # The path map is the same for both events; only the masses differ (eq. 4).
        patch = self.estimator.path_patch()
        if self.params.path_normalise == "total":
            patch = as_distribution(patch)
        self.add_reading(patch, detected, u)
        return patch

    def add_reading(self, patch: PathPatch, detected: bool, wind: np.ndarray) -> None:
        """Fuse one reading whose air-mass path map is ``patch`` (eq. 4) and log it.

        Parameters
        ----------
        patch : PathPatch
            The reading's path map on this map's grid.
        detected : bool
        wind : (2,) ndarray, m/s
            The reading's wind (summed for the mean wind direction).
        """
        self.grid.update(patch, bool(detected))
        self._log.add(patch, bool(detected))
        self.n_readings += 1
        self.n_detections += int(bool(detected))
        self.wind_sum += np.asarray(wind, float)[:2]
        self.last_patch = patch

    def start_close_look(self, since: int | None = None) -> None:
        """From now on place the visited sources by the readings from index ``since`` (default:
        the next reading) on (:meth:`refined`): a route's close look at its mapped sources."""
        self._close_since = self.n_readings if since is None else int(since)

    def mark_visited(self, cell: tuple[int, ...]) -> None:
        """The close look has read from ``cell`` (index of the map's grid)."""
        self._visited[cell] = True

    @property
    def visited(self) -> NDArray[np.bool_]:
        """Cells the close look has read from, ``(nx, ny)`` bool (read-only view)."""
        v = self._visited.view()
        v.setflags(write=False)
        return v

    def total_uncertainty(self) -> float:
        """``sum_i X_i`` over the search region (eq. 5)."""
        return self.grid.total_uncertainty(self.region)

    def sources(self) -> list[EvidenceSource]:
        """Mapped sources inside the search region, heaviest first (``m(S)`` centroids)."""
        return self.grid.sources(
            min_mass=self.params.source_min_mass,
            min_cells=self.params.source_min_cells,
            region=self.region,
        )

    def _regions(self) -> tuple[NDArray[np.intp], list[int]]:
        """Connected ``m(S) >= source_min_mass`` regions in the search region: the label image
        and the labels of those with ``source_min_cells`` cells or more, heaviest first (the
        order of :meth:`sources`)."""
        p = self.params
        mask = (self.grid.m_s >= p.source_min_mass) & self.grid.grid.region_mask(self.region)
        labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
        kept = []
        for lab in range(1, n + 1):
            cells = labels == lab
            if np.count_nonzero(cells) >= p.source_min_cells:
                kept.append((float(self.grid.m_s[cells].sum()), lab))
        kept.sort(key=lambda v: -v[0])
        return labels, [lab for _, lab in kept]

    def upwind_ends(self) -> FloatArray:
        """``(K, 2)`` upwind-end positions of the mapped regions, same order as :meth:`sources`.

        For each connected region the ``m(S)``-weighted centroid of its cells within
        ``upwind_depth`` metres (along the mean recorded wind) of its most upwind cell.
        """
        g = self.grid.grid
        labels, kept = self._regions()
        norm = float(np.hypot(*self.wind_sum))
        u = self.wind_sum / norm if norm > 0 else np.array([1.0, 0.0])
        centres = g.centers()
        along = centres @ u  # metres downwind
        out = []
        for lab in kept:
            cells = labels == lab
            tip = cells & (along <= along[cells].min() + self.params.upwind_depth)
            wt = np.where(tip, self.grid.m_s, 0.0)
            out.append((wt[..., None] * centres).sum((0, 1)) / wt.sum())
        return np.array(out).reshape(-1, 2)

    def peaks(self) -> FloatArray:
        """``(K, 2)`` centre of the cell with the largest ``m(S)`` of each mapped region, same
        order as :meth:`sources` (ranked by ``m(notS) + m(U)``, see below; exact ties: the
        first cell in index order)."""
        labels, kept = self._regions()
        if not kept:
            return np.zeros((0, 2))
        # m(S) = 1 - (m(notS) + m(U)) rounds to exactly 1.0 in every cell of a long run of
        # detections, which would leave the choice to index order; the doubt m(notS) + m(U) is
        # stored separately and keeps ranking those cells by their evidence
        doubt = self.grid.m_n + self.grid.m_u
        pos = ndimage.minimum_position(doubt, labels, kept)
        return self.grid.grid.center(np.array(pos)).reshape(-1, 2)

    def likelihood_sources(self) -> tuple[FloatArray, FloatArray]:
        """``(K, 2)`` source positions of the likelihood rule and their ``(K,)`` gains (nats),
        strongest first (see the module notes; cached until the next reading)."""
        if self._likely is not None and self._likely[0] == self.n_readings:
            return self._likely[1], self._likely[2]
        p = self.params
        g = self.grid.grid
        cand = (self.grid.m_s >= p.source_min_mass) & g.region_mask(self.region)
        norm = float(np.hypot(*self.wind_sum))
        u = self.wind_sum / norm if norm > 0 else np.array([1.0, 0.0])
        cells, gains = self._log.greedy_sources(
            cand,
            g.centers().reshape(-1, 2),
            alpha=p.source_hit_rate,
            eps=p.source_false_alarm,
            min_gain=p.source_min_gain,
            exclusion=p.source_exclusion,
            wind=u,
            max_sources=p.max_sources,
        )
        pos = g.centers().reshape(-1, 2)[cells].reshape(-1, 2)
        self._likely = (self.n_readings, pos, gains)
        return pos, gains

    def refined(
        self, positions: FloatArray, since: int, visited: NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """``(K', 2)`` each likelihood source re-placed by the readings from index ``since`` on.

        A source is moved to the mapped cell of its own strip (within ``source_exclusion[0]`` along
        the mean wind and half a cell across) that best explains those readings alone (the same
        noisy-OR gain, one source); a source they do not bear on (no positive gain), or whose own
        cell is not ``visited`` (``(nx, ny)`` mask, default every cell), stays. A source re-placed
        within ``source_exclusion`` of a stronger one kept before it is dropped, as the greedy rule
        would not have chosen it. This is how the readings a route takes up a mapped plume, close to
        where its source may lie, place that source, instead of being outweighed by the many
        readings taken far downwind, which cannot tell where along the plume it is.

        Parameters
        ----------
        positions : (K, 2) ndarray, metres
            Sources of the likelihood rule.
        since : int
            Index of the first reading of the close look.
        visited : (nx, ny) bool ndarray, optional
            Cells the route read from during the close look.
        """
        p = self.params
        g = self.grid.grid
        centres = g.centers().reshape(-1, 2)
        occupied = ((self.grid.m_s >= p.source_min_mass) & g.region_mask(self.region)).ravel()
        u = self._mean_wind()
        across = np.array([-u[1], u[0]])
        out: list[FloatArray] = []
        for xy in np.asarray(positions, float).reshape(-1, 2):
            d = centres - xy
            # the source's own strip along the wind: readings a route took up a neighbouring
            # plume must not pull it across
            near = (np.abs(d @ u) <= p.source_exclusion[0]) & (
                np.abs(d @ across) <= 0.5 * g.cell_size * (1.0 + 1e-9)
            )
            own = int(g.index(xy[None])[0] @ np.array([g.shape[1], 1]))
            if visited is not None and not visited.ravel()[own]:
                if not any(_excluded(xy - v, u, p.source_exclusion) for v in out):
                    out.append(xy)
                continue
            cells, _ = self._log.greedy_sources(
                (occupied & near).reshape(g.shape),
                centres,
                alpha=p.source_hit_rate,
                eps=p.source_false_alarm,
                min_gain=p.source_min_gain,
                exclusion=p.source_exclusion,
                wind=u,
                max_sources=1,
                since=since,
            )
            new = centres[int(cells[0])] if len(cells) else xy
            if not any(_excluded(new - v, u, p.source_exclusion) for v in out):
                out.append(new)
        return np.array(out).reshape(-1, 2)

    def _mean_wind(self) -> FloatArray:
        norm = float(np.hypot(*self.wind_sum))
        return self.wind_sum / norm if norm > 0 else np.array([1.0, 0.0])

    def source_positions(self) -> FloatArray:
        """``(K, 2)`` mapped source positions by ``source_rule`` (strongest first)."""
        return self.positions_by_rule(self.params.source_rule)

    def positions_by_rule(self, rule: str) -> FloatArray:
        """``(K, 2)`` mapped source positions under ``rule`` (one of ``source_rule``'s)."""
        if rule == "likelihood":
            pos = self.likelihood_sources()[0]
            if self._close_since is not None:
                pos = self.refined(pos, self._close_since, self._visited)
            # no reading explains a mapped region (e.g. masses set without readings): the
            # regions' own peaks rather than nothing
            return pos if len(pos) else self.peaks()
        if rule == "upwind":
            return self.upwind_ends()
        if rule == "peak":
            return self.peaks()
        if rule == "centroid":
            return np.array([s.position for s in self.sources()]).reshape(-1, 2)
        raise ConfigError("source_rule", f"unknown rule {rule!r}")

    def declaration(self) -> Declaration:
        """The mapped sources as a declaration (see the module notes for the empty case)."""
        found = self.source_positions()
        if len(found):
            return Declaration(found, confidence=1.0)
        ms = np.where(self.grid.grid.region_mask(self.region), self.grid.m_s, -1.0)
        best = np.unravel_index(int(np.argmax(ms)), ms.shape)
        return Declaration(self.grid.grid.center(np.array(best)), confidence=0.0)

    def final_metrics(self) -> dict[str, float]:
        """Row fields: residual/initial uncertainty, mapped-source count and positions.

        ``mapped_sources`` and ``mapped_x_k, mapped_y_k`` follow ``source_rule``
        (``mapped_mass_k`` is the ``m(S)`` sum of the region each lies in); for every rule
        ``R`` in :data:`RULES`, ``R_n`` and ``R_x_k, R_y_k`` are its estimates of the same map.
        """
        out: dict[str, float] = {
            "residual_uncertainty": self.total_uncertainty(),
            "initial_uncertainty": self.initial_uncertainty,
            "detections": float(self.n_detections),
            "max_conflict": float(self.grid.max_conflict),
            "mapped_regions": float(len(self.sources())),
        }
        labels, kept = self._regions()
        mass = {lab: float(self.grid.m_s[labels == lab].sum()) for lab in kept}
        g = self.grid.grid
        for rule in RULES:
            pos = self.positions_by_rule(rule)
            out[f"{rule}_n"] = float(len(pos))
            for k, xy in enumerate(pos):
                out[f"{rule}_x_{k}"] = float(xy[0])
                out[f"{rule}_y_{k}"] = float(xy[1])
            if rule == self.params.source_rule:
                out["mapped_sources"] = float(len(pos))
                for k, xy in enumerate(pos):
                    out[f"mapped_x_{k}"] = float(xy[0])
                    out[f"mapped_y_{k}"] = float(xy[1])
                    ij = tuple(g.index(np.asarray(xy)[None])[0])
                    out[f"mapped_mass_{k}"] = mass.get(int(labels[ij]), 0.0)
        return out


def _excluded(d: FloatArray, wind: FloatArray, exclusion: tuple[float, float]) -> bool:
    """Whether offset ``d`` (metres) lies within ``exclusion`` (along, across ``wind``)."""
    return bool(
        abs(float(d @ wind)) <= exclusion[0]
        and abs(float(d[0] * -wind[1] + d[1] * wind[0])) <= exclusion[1]
    )


RULES = ("likelihood", "peak", "centroid", "upwind")
"""Every source rule (``DSMapParams.source_rule``)."""


class ReadingLog:
    """Every fused reading's air-mass path map and outcome, for the likelihood source rule.

    Stored flat (cell index, ``pi`` as float32, reading index) in buffers that grow by
    doubling: a 5000 s mission at 0.5 s with a 100-cell path map is about 10 MB.

    Parameters
    ----------
    shape : (nx, ny)
        The map's grid.
    """

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        self.n = 0
        self.size = 0
        self._cells = np.zeros(1024, np.int32)
        self._pi = np.zeros(1024, np.float32)
        self._rid = np.zeros(1024, np.int32)
        self._det: list[bool] = []

    def add(self, patch: PathPatch, detected: bool) -> None:
        """Append one reading."""
        v = patch.values
        by = v.shape[1]
        nz = np.flatnonzero(v.ravel() > 0)
        m = nz.size
        if self.size + m > self._cells.size:
            cap = max(2 * self._cells.size, self.size + m)
            for name in ("_cells", "_pi", "_rid"):
                old = getattr(self, name)
                new = np.zeros(cap, old.dtype)
                new[: self.size] = old[: self.size]
                setattr(self, name, new)
        ii, jj = np.divmod(nz, by)
        sl = slice(self.size, self.size + m)
        self._cells[sl] = (patch.ix0 + ii) * self.shape[1] + (patch.iy0 + jj)
        self._pi[sl] = np.minimum(v.ravel()[nz], 1.0)
        self._rid[sl] = self.n
        self._det.append(bool(detected))
        self.size += m
        self.n += 1

    def greedy_sources(
        self,
        candidates: NDArray[np.bool_],
        centres: FloatArray,
        *,
        alpha: float,
        eps: float,
        min_gain: float,
        exclusion: tuple[float, float],
        wind: FloatArray,
        max_sources: int,
        since: int = 0,
    ) -> tuple[NDArray[np.intp], FloatArray]:
        """Flat indices of the greedily chosen source cells and their gains (nats).

        Only readings with index ``since`` or later count (default all).

        Each step adds the candidate cell ``c`` maximising
        ``sum_r log P(d_r | S + c) - log P(d_r | S)`` under the noisy-OR model of the module
        notes; a reading that does not pass ``c`` contributes nothing, a non-detection that
        does contributes ``log(1 - alpha pi_r(c))`` whatever ``S`` is.
        """
        n_cells = self.shape[0] * self.shape[1]
        if self.n == 0 or not candidates.any():
            return np.zeros(0, np.intp), np.zeros(0)
        cells = self._cells[: self.size]
        pi = self._pi[: self.size].astype(float)
        rid = self._rid[: self.size]
        det = np.asarray(self._det, bool)[rid]
        keep = candidates.ravel()[cells] & (rid >= since)
        cells, pi, rid, det = cells[keep], pi[keep], rid[keep], det[keep]
        miss = 1.0 - alpha * pi  # the chance a source at the cell leaves the reading clean
        nd_term = np.log(miss)
        q = np.ones(self.n)  # prod over chosen sources of (1 - alpha pi_r) per reading
        free = candidates.ravel().copy()
        across = np.array([-wind[1], wind[0]])
        chosen: list[int] = []
        gains: list[float] = []
        for _ in range(max_sources):
            if not free.any():
                break
            qe = (1.0 - eps) * q[rid]
            det_term = np.log((1.0 - qe * miss) / (1.0 - qe))
            gain = np.bincount(cells, weights=np.where(det, det_term, nd_term), minlength=n_cells)
            gain = np.where(free, gain, -np.inf)
            c = int(np.argmax(gain))
            best = float(gain[c])
            if not (best > 0.0) or (gains and best < min_gain * gains[0]):
                break
            chosen.append(c)
            gains.append(best)
            on = cells == c
            np.multiply.at(q, rid[on], miss[on])
            d = centres - centres[c]
            near = (np.abs(d @ wind) <= exclusion[0]) & (np.abs(d @ across) <= exclusion[1])
            free &= ~near
            free[c] = False
        return np.asarray(chosen, np.intp), np.asarray(gains)


# ---------------------------------------------------------------------- the estimator
@register("estimator", "ds-map", DSMapParams, "Dempster-Shafer map of several sources (D-S paper)")
class DSMapEstimator(Estimator):
    """The D-S map of several sources as an estimator: :class:`DSMapper` over the search region
    (``region``, else the task's, else the arena), one reading per control period.

    The map is horizontal: it is drawn over the first two axes and its estimates (the mapped
    sources by ``source_rule``) are ``(K, 2)``, hence ``dims = (2,)``. The route-specific parts
    of the map (its grid, the path map of each fused reading, the close look at mapped sources)
    are those of :attr:`mapper`.
    """

    params: DSMapParams
    Params = DSMapParams
    dims = (2,)
    needs_model = False

    def __init__(self, params: DSMapParams | None = None) -> None:
        super().__init__(params or DSMapParams())

    def reset(
        self, ctx: SearchContext, model: MeasurementModel | None, rng: np.random.Generator
    ) -> None:
        """A blank map over the search region.

        Raises
        ------
        ConfigError
            If ``t_thr`` is shorter than the control period (no air-mass path could ever be
            mapped) or the region does not overlap the arena.
        """
        p = self.params
        if p.t_thr < ctx.dt * (1.0 - 1e-9):
            # one record per control period: a shorter span holds no earlier record, so no
            # sub-window DW(t_r, t_c) ever opens and the map stays blank (odor-path paper, eq. 16)
            raise ConfigError(
                "searcher.t_thr",
                f"{p.t_thr:g} s is shorter than the control period {ctx.dt:g} s: no air-mass "
                "path could ever be mapped",
            )
        region = resolve_region(ctx, p.region)
        if p.region is not None:
            # the robot could never read there: the map would stay blank and its sources be
            # declared outside the world (the region is horizontal: the first two axes count)
            narrow_box(ctx.arena.lower[:2], ctx.arena.upper[:2], region, "searcher.region")
        self.mapper = DSMapper(p, region, ctx.dt)
        self.fused: PathPatch | None = None

    def update(self, observation: Observation) -> None:
        """Fuse the reading (or, with ``preprocess``, the aligned reading now due)."""
        o = observation
        self.fused = self.mapper.update(o.t, o.position, o.wind, o.detection, o.gas)

    def belief(self) -> EvidenceBelief:
        """The map: ``prob`` from ``m(S)``, the masses as extra layers, the cell uncertainty,
        the path map of the reading fused at the last update and the search region."""
        return evidence_belief(self.mapper.grid, self.fused, self.mapper.region)

    def estimate(self) -> np.ndarray:
        """The mapped sources by ``source_rule``, ``(K, 2)`` metres, strongest first."""
        return self.mapper.source_positions()

    def diagnostics(self) -> dict[str, float]:
        """``total_uncertainty`` (eq. 5 summed over the region) and ``mapped_regions``."""
        return {
            "total_uncertainty": self.mapper.total_uncertainty(),
            "mapped_regions": float(len(self.mapper.sources())),
        }

    def final_metrics(self) -> dict[str, float]:
        """:meth:`DSMapper.final_metrics`."""
        return self.mapper.final_metrics()
