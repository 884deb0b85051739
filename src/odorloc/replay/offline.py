"""Estimators replayed offline over a recorded log (a bag, or any stream of observations).

Any registered searcher with a belief is an estimator here: it is fed the log's observations
step by step and its commands are ignored (the robot in the log went where it went). So the
particle filter of ``pf-entropy``, the Dempster-Shafer map of ``ds-mapping`` /
``ds-rectangular-wave`` and any future estimator replay the same way. ``odor-path`` is the
odor-path estimator alone: the sum, over the readings with a detection, of their odor-path maps
(where the detected air came from), normalised into a grid belief.

::

    log = BagLog("run.bag", "topics.yaml")
    rec = replay_estimator(log.observations(), log.context(), "pf-entropy")
    plot_belief_map(rec, "belief.png")

The result is an ordinary :class:`~odorloc.engine.recorder.Recording` (path, readings, belief
snapshots every ``belief_every`` seconds and at the end), so every plot of recordings applies.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Declaration, Observation, SearchContext
from odorloc.engine.episode import score_declaration
from odorloc.engine.recorder import Recording
from odorloc.inference.belief import GridBelief
from odorloc.inference.odor_path.estimator import OdorPathEstimator, OdorPathParams
from odorloc.searchers.base import Belief, Searcher

__all__ = ["OdorPathMap", "check_estimator", "edge_tolerance", "replay_estimator", "snapshot"]


class OdorPathMap:
    """Odor-path maps of the detections, summed over the log (odor-path paper, section IV).

    Parameters
    ----------
    params : OdorPathParams, optional
        Cell size, ``t_thr``, noise scale ... (``dt`` is set to the log's period). Default: the
        estimator's defaults with 0.25 m cells and cell-integrated kernels, so that a map summed
        over a whole log is smooth at the scale of a robot's step.
    """

    def __init__(self, params: OdorPathParams | None = None) -> None:
        self.params = params or OdorPathParams(cell_size=0.25, kernel="cell")

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """Start over for a log with context ``ctx``."""
        p = self.params.model_copy(update={"dt": ctx.dt})
        lo, hi = ctx.arena.lower[:2], ctx.arena.upper[:2]
        self.estimator = OdorPathEstimator(p, lo, hi)
        self.accum = np.zeros(self.estimator.grid.shape)
        self.n_detections = 0

    def act(self, observations: list[Observation], rng: np.random.Generator) -> Any:
        """Record one period; accumulate its path map when it has a detection."""
        o = observations[0]
        self.estimator.update(o.t, o.position[:2], o.wind[:2], 1.0 if o.detection else 0.0)
        if o.detection:
            self.accum += self.estimator.path_map()
            self.n_detections += 1
        return None

    def beliefs(self) -> dict[int, Belief]:
        """The normalised accumulated map (none before the first detection)."""
        total = float(self.accum.sum())
        if total <= 0:
            return {}
        return {-1: GridBelief(self.estimator.grid, self.accum / total)}

    def source_estimates(self) -> None:
        """None: the estimate is the map's mean (as for any belief without sources of its own)."""
        return None


def snapshot(belief: Any) -> dict[str, np.ndarray]:
    """A belief's arrays (a grid belief's carry the grid's extent, ``lower`` and ``upper``)."""
    return dict(belief.snapshot())


def check_estimator(name: str, field: str = "estimator") -> None:
    """Refuse an estimator name that is neither ``odor-path`` nor a registered searcher
    (:class:`ConfigError` naming ``field``), before any log is read."""
    if name != "odor-path":
        registry.entry("searcher", name, field=field)


def _build(estimator: str | Searcher | OdorPathMap, params: Mapping[str, Any] | None) -> Any:
    if not isinstance(estimator, str):
        return estimator
    if estimator == "odor-path":
        try:
            values = {"cell_size": 0.25, "kernel": "cell", **dict(params or {})}
            return OdorPathMap(OdorPathParams(**values))
        except Exception as exc:
            raise ConfigError("estimator", f"odor-path parameters: {exc}") from None
    ref = registry.ComponentRef(type=estimator, **dict(params or {}))
    return ref.build("searcher", field="estimator")


def replay_estimator(
    observations: Iterable[Observation],
    ctx: SearchContext,
    estimator: str | Searcher | OdorPathMap = "pf-entropy",
    params: Mapping[str, Any] | None = None,
    *,
    seed: int = 0,
    belief_every: float = 10.0,
    sources: np.ndarray | None = None,
    name: str = "log",
    success_radius: float = 0.5,
    edge: float | None = None,
) -> Recording:
    """Feed a log to an estimator and record its belief and its source estimates.

    The estimate is the estimator's own sources when it has them
    (:meth:`~odorloc.searchers.base.Searcher.source_estimates`: the mapped sources of
    ``ds-mapping``), else the mean of its last belief. It is stored in the recording's
    ``meta``: ``estimates`` (``(K, d)``, metres), ``estimate_kind`` (``"sources"`` or
    ``"belief mean"``), ``search_area`` (``[lower, upper]``) and ``on_edge`` (indices of the
    estimates within ``edge`` of the search area's boundary: a source beyond the area would
    put them there). With known ``sources`` it is scored like an episode's declaration
    (:func:`~odorloc.engine.episode.score_declaration`): ``loc_error`` (the mean over true
    sources of the distance to the nearest estimate, metres), ``sources_found`` and
    ``false_sources`` within ``success_radius``.

    Parameters
    ----------
    observations : iterable of Observation
        One per period, single agent (e.g. :meth:`~odorloc.replay.bag.BagLog.observations`);
        consumed as a stream.
    ctx : SearchContext
        What the estimator may know (arena, period, threshold).
    estimator : str or object
        A searcher registry name (``pf-entropy``, ``ds-mapping``, ...), ``odor-path``, or a
        built searcher.
    params : dict, optional
        The estimator's parameters.
    seed : int
        Seed of the estimator's random stream.
    belief_every : float, seconds
        Interval of belief snapshots (the last belief is always kept).
    sources : (S, d) ndarray, optional
        True sources, if known (scored and drawn).
    name : str
        Name recorded in the recording's metadata.
    success_radius : float, metres
        A true source is found by an estimate this close.
    edge : float, metres, optional
        How close to the search area's boundary an estimate is "on its edge" (default
        :func:`edge_tolerance`).

    Returns
    -------
    Recording
    """
    est = _build(estimator, params)
    rng = np.random.default_rng(seed)
    est.reset(ctx, rng)
    d = ctx.dim
    t: list[float] = []
    pos: list[np.ndarray] = []
    gas: list[float] = []
    det: list[bool] = []
    wind: list[np.ndarray] = []
    beliefs: list[tuple[float, dict[str, np.ndarray]]] = []
    declared: list[np.ndarray] = []
    next_snap = 0.0
    last: tuple[float, Any] | None = None
    for o in observations:
        if len(o.position) != d:
            raise ConfigError("dim", f"observation has {len(o.position)} components, not {d}")
        action = est.act([o], rng)
        if action is not None:
            for decl in action.declarations:
                declared.append(np.atleast_2d(Declaration(decl.positions).positions))
        t.append(o.t)
        pos.append(o.position)
        gas.append(o.gas)
        det.append(o.detection)
        wind.append(o.wind)
        current = dict(est.beliefs())
        if current:
            last = (o.t, current)
            if o.t >= next_snap - 1e-9:
                for agent, b in current.items():
                    beliefs.append((o.t, {**snapshot(b), "agent": np.array(int(agent))}))
                next_snap = o.t + belief_every
    if not t:
        raise ConfigError("log", "no observations (not one full period of data)")
    if last is not None and (not beliefs or beliefs[-1][0] != last[0]):
        for agent, b in last[1].items():
            beliefs.append((last[0], {**snapshot(b), "agent": np.array(int(agent))}))
    src = np.zeros((0, d)) if sources is None else np.atleast_2d(np.asarray(sources, float))
    lo, hi = ctx.arena.lo, ctx.arena.hi
    decl = np.vstack(declared) if declared else np.zeros((0, d))
    meta: dict[str, Any] = {
        "scenario": name,
        "searcher": estimator if isinstance(estimator, str) else type(estimator).__name__,
        "steps": len(t),
        "detections": int(np.sum(det)),
    }
    estimates, kind = _estimates(est, beliefs, d)
    meta["estimates"] = estimates.tolist()
    meta["estimate_kind"] = kind
    meta["search_area"] = [list(map(float, lo)), list(map(float, hi))]
    tol = edge_tolerance(ctx) if edge is None else float(edge)
    meta["edge_tolerance"] = tol
    meta["on_edge"] = [
        i
        for i, e in enumerate(estimates)
        if np.any(e[:2] - np.asarray(lo[:2]) <= tol) or np.any(np.asarray(hi[:2]) - e[:2] <= tol)
    ]
    if len(src) and len(estimates):
        _, err, found, false = score_declaration(
            estimates, src[:, : estimates.shape[1]], success_radius
        )
        meta.update(loc_error=err, sources_found=found, false_sources=false)
        meta["success_radius"] = float(success_radius)
    return Recording(
        t=np.asarray(t, float),
        positions=np.asarray(pos, float).reshape(len(t), 1, d),
        gas=np.asarray(gas, float).reshape(len(t), 1),
        detection=np.asarray(det, bool).reshape(len(t), 1),
        wind=np.asarray(wind, float).reshape(len(t), 1, d),
        diagnostics={},
        beliefs=beliefs,
        plume_t=np.zeros(0),
        plume_frames=np.zeros((0, 1, 1), np.float32),
        plume_extent=np.array([lo[0], hi[0], lo[1], hi[1]]),
        sources=src,
        declared=decl,
        occupancy=None,
        arena_bounds=np.array([lo, hi]),
        meta=meta,
    )


def _belief_mean(snap: dict[str, np.ndarray]) -> np.ndarray | None:
    """Mean position of a belief snapshot (particles or a grid with its extent)."""
    if "positions" in snap and "weights" in snap:
        w = np.asarray(snap["weights"], float)
        return (w / w.sum()) @ np.asarray(snap["positions"], float)
    if "prob" in snap and "lower" in snap:
        p = np.asarray(snap["prob"], float)
        lo, hi = np.asarray(snap["lower"]), np.asarray(snap["upper"])
        axes = [
            lo[a] + (np.arange(p.shape[a]) + 0.5) * (hi[a] - lo[a]) / p.shape[a]
            for a in range(p.ndim)
        ]
        grids = np.meshgrid(*axes, indexing="ij")
        total = p.sum()
        if total <= 0 or not math.isfinite(total):
            return None
        return np.array([float((g * p).sum() / total) for g in grids])
    return None


def edge_tolerance(ctx: SearchContext) -> float:
    """How close (metres) to the search area's boundary an estimate counts as on its edge: 5 %
    of the area's shorter horizontal side, and at least one cell of the arena's grid (an
    estimate in a map's outermost cell is on the edge)."""
    size = np.asarray(ctx.arena.upper[:2], float) - np.asarray(ctx.arena.lower[:2], float)
    return float(max(0.05 * float(size.min()), ctx.arena.resolution))


def _estimates(
    est: Any, beliefs: list[tuple[float, dict[str, np.ndarray]]], d: int
) -> tuple[np.ndarray, str]:
    """``(K, d')`` source estimates of a replayed estimator and what they are."""
    own = est.source_estimates()
    if own is not None:
        own = np.asarray(own, float)
        if own.size == 0:
            return np.zeros((0, own.shape[-1] if own.ndim == 2 else 2)), "sources"
        return np.atleast_2d(own), "sources"
    if not beliefs:
        return np.zeros((0, d)), "belief mean"
    final = [b for b in beliefs if b[0] == beliefs[-1][0]]
    m = _belief_mean(final[-1][1])
    return (np.zeros((0, d)) if m is None else m[None, :]), "belief mean"
