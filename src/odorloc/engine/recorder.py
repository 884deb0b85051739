"""Episode recorder: trajectory, readings, declarations, belief and plume snapshots.

Arrays are collected per step and stacked once at the end; a :class:`Recording` saves to a
single ``.npz`` file and loads back.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.geometry.arena import Arena


@dataclass
class Recording:
    """What happened in one episode.

    Attributes
    ----------
    t : (K,) ndarray, s
    positions : (K, A, d) ndarray, metres
    gas : (K, A) ndarray
    detection : (K, A) bool ndarray
    wind : (K, A, d) ndarray, m/s (anemometer readings)
    diagnostics : dict of str to (K,) ndarray
        Scalars the searcher reported each recorded step: numbers (entropy, ESS, ...; NaN where
        not reported) or text (a phase name; ``""`` where not reported).
    beliefs : list of (t, dict of arrays)
        Belief snapshots (particles and weights, or grids); each carries ``agent`` (the agent
        holding it, -1 for a central belief). The last snapshots are those at the end.
    plume_t : (F,) ndarray, s
    plume_frames : (F, nx, ny) ndarray
        Concentration on a coarse grid (a horizontal slice at source height in 3D).
    plume_extent : (4,) ndarray
        ``(xmin, xmax, ymin, ymax)`` of the frames, metres.
    sources : (S, d) ndarray, metres
    declared : (K', d) ndarray
        Declared source positions (empty if none).
    occupancy : (nx, ny) bool ndarray or None
        The arena's obstacles (slice in 3D), for plotting.
    arena_bounds : (2, d) ndarray
    meta : dict
        Scenario name, metrics and seeds; ``events`` lists the episode's events.
    """

    t: np.ndarray
    positions: np.ndarray
    gas: np.ndarray
    detection: np.ndarray
    wind: np.ndarray
    diagnostics: dict[str, np.ndarray]
    beliefs: list[tuple[float, dict[str, np.ndarray]]]
    plume_t: np.ndarray
    plume_frames: np.ndarray
    plume_extent: np.ndarray
    sources: np.ndarray
    declared: np.ndarray
    occupancy: np.ndarray | None
    arena_bounds: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Flat dict of arrays (the ``.npz`` layout; ``meta`` as a JSON string array)."""
        arrays: dict[str, np.ndarray] = {
            k: np.asarray(getattr(self, k))
            for k in (
                "t",
                "positions",
                "gas",
                "detection",
                "wind",
                "plume_t",
                "plume_frames",
                "plume_extent",
                "sources",
                "declared",
                "arena_bounds",
            )
        }
        if self.occupancy is not None:
            arrays["occupancy"] = np.asarray(self.occupancy)
        for k, v in self.diagnostics.items():
            arrays[f"diag__{k}"] = np.asarray(v)
        arrays["belief_t"] = np.array([b[0] for b in self.beliefs], float)
        for i, (_, snap) in enumerate(self.beliefs):
            for k, v in snap.items():
                arrays[f"belief{i}__{k}"] = np.asarray(v)
        arrays["meta"] = np.array(json.dumps(self.meta, default=_json_default))
        return arrays

    @classmethod
    def from_arrays(cls, data: dict[str, np.ndarray]) -> Recording:
        """Inverse of :meth:`to_arrays`."""
        diags = {k[6:]: v for k, v in data.items() if k.startswith("diag__")}
        beliefs = []
        for i, bt in enumerate(data.get("belief_t", [])):
            pre = f"belief{i}__"
            beliefs.append(
                (float(bt), {k[len(pre) :]: v for k, v in data.items() if k.startswith(pre)})
            )
        return cls(
            t=data["t"],
            positions=data["positions"],
            gas=data["gas"],
            detection=data["detection"],
            wind=data["wind"],
            diagnostics=diags,
            beliefs=beliefs,
            plume_t=data["plume_t"],
            plume_frames=data["plume_frames"],
            plume_extent=data["plume_extent"],
            sources=data["sources"],
            declared=data["declared"],
            occupancy=data.get("occupancy"),
            arena_bounds=data["arena_bounds"],
            meta=json.loads(str(data["meta"])) if "meta" in data else {},
        )

    def save(self, path: str | Path) -> Path:
        """Write the recording to one compressed ``.npz`` file."""
        path = Path(path)
        np.savez_compressed(path, **self.to_arrays())
        return path

    @classmethod
    def load(cls, path: str | Path) -> Recording:
        """Read a recording written by :meth:`save`."""
        with np.load(path, allow_pickle=False) as z:
            return cls.from_arrays({k: z[k] for k in z.files})


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


class Recorder:
    """Collects a :class:`Recording` step by step (used by the episode engine)."""

    def __init__(self, scenario: Any, arena: Arena, sources: np.ndarray) -> None:
        self.cfg = scenario.recording
        self.scenario_name = scenario.name
        self.n_agents = len(scenario.agents.starts)
        self.arena = arena
        self.sources = sources
        self._t: list[float] = []
        self._pos: list[np.ndarray] = []
        self._gas: list[list[float]] = []
        self._det: list[list[bool]] = []
        self._wind: list[np.ndarray] = []
        self._diag: dict[str, list[Any]] = {}
        self._text: set[str] = set()
        self._beliefs: list[tuple[float, dict[str, np.ndarray]]] = []
        self._plume_t: list[float] = []
        self._frames: list[np.ndarray] = []
        self._last_belief_t: float | None = None
        lo, hi = arena.lo, arena.hi
        n_per_m = self.cfg.plume_grid
        nx = int(np.clip(np.ceil((hi[0] - lo[0]) * n_per_m), 20, 300))
        ny = int(np.clip(np.ceil((hi[1] - lo[1]) * n_per_m), 20, 300))
        # cell centres: the frames are drawn as nx x ny cells over the arena's extent
        xs = lo[0] + (np.arange(nx) + 0.5) * (hi[0] - lo[0]) / nx
        ys = lo[1] + (np.arange(ny) + 0.5) * (hi[1] - lo[1]) / ny
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = [gx.ravel(), gy.ravel()]
        if arena.dim == 3:
            # A horizontal slice at the (first) source height.
            pts.append(np.full(gx.size, float(sources[0, 2])))
        self._grid = np.column_stack(pts)
        self._grid_shape = (nx, ny)
        self._extent = np.array([lo[0], hi[0], lo[1], hi[1]])

    def _row(self, t: float, obs: list[Any], probe: Any) -> None:
        self._t.append(t)
        self._pos.append(np.array([o.position for o in obs]))
        self._gas.append([o.gas for o in obs])
        self._det.append([o.detection for o in obs])
        self._wind.append(np.array([o.wind for o in obs]))
        diag = probe.diagnostics() if probe is not None else {}
        for k in set(self._diag) | set(diag):
            v = diag.get(k)
            col = self._diag.get(k)
            if col is None:
                # a diagnostic is text (a phase name) or a number, decided by its first value
                if isinstance(v, str):
                    self._text.add(k)
                col = self._diag[k] = [self._missing(k)] * (len(self._t) - 1)
            if v is None:
                col.append(self._missing(k))
            elif isinstance(v, str) != (k in self._text):
                raise TypeError(f"diagnostic {k!r} mixes text and numbers ({v!r})")
            else:
                col.append(v if k in self._text else float(v))

    def _missing(self, key: str) -> Any:
        return "" if key in self._text else np.nan

    def final_pose(self, t: float, obs: list[Any], probe: Any) -> None:
        """Record the observations an episode ended on after moving (a source reached, agents
        stuck), whatever the stride: the path ends where the agents stopped."""
        if not self._t or self._t[-1] < t:
            self._row(t, obs, probe)

    def record(
        self,
        step: int,
        t: float,
        obs: list[Any],
        platforms: list[Any],
        probe: Any,
        world: Any,
    ) -> None:
        """Record one control step (respecting the configured strides).

        ``probe`` (usually the searcher) gives ``diagnostics()`` and ``beliefs()``; ``None``
        records neither.
        """
        if step % self.cfg.stride == 0:
            self._row(t, obs, probe)
        if step % self.cfg.belief_stride == 0 and probe is not None:
            self._snapshot(t, probe)
        if step % self.cfg.plume_stride == 0:
            self._plume_t.append(t)
            c = world.plume.concentration(self._grid).reshape(self._grid_shape)
            self._frames.append(c.astype(np.float32))

    def _snapshot(self, t: float, probe: Any) -> None:
        for agent, b in dict(probe.beliefs()).items():
            if b is not None:
                self._beliefs.append((t, {**b.snapshot(), "agent": np.array(int(agent))}))
        self._last_belief_t = t

    def final_beliefs(self, t: float, probe: Any) -> None:
        """Snapshot the beliefs at the end of the episode (unless this step already did)."""
        if self._last_belief_t != t:
            self._snapshot(t, probe)

    def finish(
        self, metrics: dict[str, Any], declaration: Any, events: list[dict[str, Any]] | None = None
    ) -> Recording:
        """Stack everything into a :class:`Recording`."""
        d = self.arena.dim
        occ = self.arena.occ
        if occ is not None and occ.ndim == 3:
            k = int(self.arena.cell_index(self.sources[:1])[0, 2])
            occ = occ[:, :, k]
        declared = (
            np.asarray(declaration.positions) if declaration is not None else np.zeros((0, d))
        )
        return Recording(
            t=np.asarray(self._t),
            positions=np.asarray(self._pos, float).reshape(len(self._t), self.n_agents, d),
            gas=np.asarray(self._gas, float).reshape(len(self._t), self.n_agents),
            detection=np.asarray(self._det, bool).reshape(len(self._t), self.n_agents),
            wind=np.asarray(self._wind, float).reshape(len(self._t), self.n_agents, d),
            diagnostics={k: np.asarray(v) for k, v in self._diag.items()},
            beliefs=self._beliefs,
            plume_t=np.asarray(self._plume_t),
            plume_frames=np.asarray(self._frames),
            plume_extent=self._extent,
            sources=self.sources,
            declared=declared,
            occupancy=None if occ is None else np.asarray(occ),
            arena_bounds=np.array([self.arena.lo, self.arena.hi]),
            meta={"scenario": self.scenario_name, **metrics, "events": events or []},
        )
