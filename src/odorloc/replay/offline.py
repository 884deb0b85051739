"""Estimators replayed offline over a recorded log (a bag, or any stream of observations).

A single-agent estimator (registry family ``estimator``: ``particle-filter``, ``grid-filter``,
``ds-map``, ``odor-path``, ...) is fed the log's observations one control period at a time; the
robot in the log went where it went, so nothing moves. A searcher's name works too when the
searcher composes an estimator (:meth:`~odorloc.searchers.base.Searcher.estimation`): its
estimator and measurement model are replayed with the searcher's parameters (``pf-entropy``
replays its particle filter, ``ds-mapping`` / ``ds-rectangular-wave`` their D-S map).
``odor-path`` sums the odor-path maps of the readings with a detection (where the detected air
came from).

::

    log = BagLog("run.bag", "topics.yaml")
    rec = replay_estimator(log.observations(), log.context(), "pf-entropy")
    plot_belief_map(rec, "belief.png")

The result is an ordinary :class:`~odorloc.engine.recorder.Recording` (path, readings, belief
snapshots every ``belief_every`` seconds and at the end, and the estimate as a declaration the
first time the estimator's stopping rule holds), so every plot of recordings applies.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Observation, SearchContext
from odorloc.engine.recorder import Recording
from odorloc.inference.estimator import Estimator
from odorloc.models.base import MeasurementModel

__all__ = ["check_estimator", "replay_estimator", "resolve_estimator", "snapshot"]


def snapshot(belief: Any) -> dict[str, np.ndarray]:
    """A belief's arrays (a grid belief's carry the grid's extent, ``lower`` and ``upper``)."""
    return dict(belief.snapshot())


def check_estimator(name: str, field: str = "estimator") -> None:
    """Refuse a name that is neither a registered estimator nor a registered searcher
    (:class:`ConfigError` naming ``field``), before any log is read."""
    if name not in registry.names("estimator"):
        registry.entry("searcher", name, field=field)


def resolve_estimator(
    estimator: str | Estimator,
    params: Mapping[str, Any] | None = None,
    model: Mapping[str, Any] | None = None,
) -> tuple[Estimator, MeasurementModel | None, str]:
    """The estimator to replay, its measurement model and its name.

    Parameters
    ----------
    estimator : str or Estimator
        An estimator (built, or a registry name) or the name of a searcher composing one.
    params : dict, optional
        Parameters of the named estimator or searcher.
    model : dict, optional
        The measurement model, ``{type: name, **params}``; default: the searcher's, else the
        estimator's ``default_model``.

    Raises
    ------
    ConfigError
        Naming ``estimator`` for an unknown name or a searcher without an estimator,
        ``model`` for an estimator that needs a model and has none.
    """
    values = dict(params or {})
    built: MeasurementModel | None = None
    if isinstance(estimator, Estimator):
        est, name = estimator, type(estimator).__name__
    elif estimator in registry.names("estimator"):
        ref = registry.ComponentRef(type=estimator, **values)
        est, name = ref.build("estimator", field="estimator"), estimator
    else:
        ref = registry.ComponentRef(type=estimator, **values)
        searcher = ref.build("searcher", field="estimator")
        parts = searcher.estimation()
        if parts is None:
            raise ConfigError("estimator", f"searcher {estimator!r} composes no estimator")
        (est, built), name = parts, estimator
    if model is not None:
        built = registry.ComponentRef(**dict(model)).build("model", field="model")
    elif built is None and est.needs_model:
        spec = type(est).default_model
        if spec is None:
            raise ConfigError("model", f"{name} needs a measurement model")
        built = registry.ComponentRef(**dict(spec)).build("model", field="model")
    return est, built, name


def replay_estimator(
    observations: Iterable[Observation],
    ctx: SearchContext,
    estimator: str | Estimator = "pf-entropy",
    params: Mapping[str, Any] | None = None,
    *,
    model: Mapping[str, Any] | None = None,
    seed: int = 0,
    belief_every: float = 10.0,
    sources: np.ndarray | None = None,
    name: str = "log",
) -> Recording:
    """Feed a log to an estimator and record its belief.

    Parameters
    ----------
    observations : iterable of Observation
        One per period, single agent (e.g. :meth:`~odorloc.replay.bag.BagLog.observations`);
        consumed as a stream.
    ctx : SearchContext
        What the estimator may know (arena, period, threshold).
    estimator : str or Estimator
        An estimator registry name (``particle-filter``, ``ds-map``, ``odor-path``, ...), a
        searcher composing one (``pf-entropy``, ``ds-mapping``, ...) or a built estimator.
    params : dict, optional
        The estimator's (or searcher's) parameters.
    model : dict, optional
        The measurement model (default: the searcher's, else the estimator's default).
    seed : int
        Seed of the estimator's random stream.
    belief_every : float, seconds
        Interval of belief snapshots (the last belief is always kept).
    sources : (S, d) ndarray, optional
        True sources, if known (scored and drawn).
    name : str
        Name recorded in the recording's metadata.

    Returns
    -------
    Recording
    """
    est, mdl, est_name = resolve_estimator(estimator, params, model)
    rng = np.random.default_rng(seed)
    est.reset(ctx, mdl, rng)
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
        est.update(o)
        if not declared and est.converged():
            declared.append(np.atleast_2d(est.estimate()))
        t.append(o.t)
        pos.append(o.position)
        gas.append(o.gas)
        det.append(o.detection)
        wind.append(o.wind)
        b = est.belief()
        if b is not None:
            last = (o.t, b)
            if o.t >= next_snap - 1e-9:
                beliefs.append((o.t, {**snapshot(b), "agent": np.array(-1)}))
                next_snap = o.t + belief_every
    if not t:
        raise ConfigError("log", "no observations (not one full period of data)")
    if last is not None and (not beliefs or beliefs[-1][0] != last[0]):
        beliefs.append((last[0], {**snapshot(last[1]), "agent": np.array(-1)}))
    src = np.zeros((0, d)) if sources is None else np.atleast_2d(np.asarray(sources, float))
    lo, hi = ctx.arena.lo, ctx.arena.hi
    decl = np.vstack(declared) if declared else np.zeros((0, d))
    meta: dict[str, Any] = {
        "scenario": name,
        "searcher": est_name,
        "steps": len(t),
        "detections": int(np.sum(det)),
    }
    if len(src) and beliefs:
        m = _belief_mean(beliefs[-1][1])
        if m is not None:
            meta["loc_error"] = float(np.min(np.linalg.norm(src[:, : len(m)] - m, axis=1)))
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
