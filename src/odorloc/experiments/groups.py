"""Per-group columns of an episode of a team of groups with leaders (e.g. formations).

:func:`group_columns` reads an episode result of a ``per-group`` team whose members report their
leader's position as the diagnostics ``vr_x<suffix>``/``vr_y<suffix>``
(:class:`~odorloc.viz.formations.GroupView`) and gives, per group ``g`` and source ``i``:

- ``source_<g>``, ``error_<g>``: the source nearest the group's declaration and how far (-1,
  NaN when it did not declare); ``first_declared``: the source of the first declaration;
  ``same_declared``: two groups declared nearest to one source;
- ``closest_<g>_<i>``: the leader's closest approach to each source; ``reached_both``: two
  groups came within ``radius`` of different sources; ``same_source``: every leader ended
  nearest to one source, within ``same_reach`` of it;
- ``dwell_<g>``: after the leader first came within ``region`` of a source, the fraction of
  steps it stayed there; ``reversal_<g>``: the fraction of its moves from then on that reversed
  the previous one (near 1 in a 2-cycle);
- ``first_found``, ``second_found``: when the first and the second source were found.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from odorloc.viz.formations import GroupView, leader_path

__all__ = ["approach", "group_columns"]


def approach(path: np.ndarray, sources: np.ndarray, region: float) -> tuple[float, float]:
    """``(dwell, reversal)`` of a leader's path ``(N, 2)`` after it first came within
    ``region`` m of one of ``sources`` ``(S, 2)`` (NaN when it never did)."""
    d = np.linalg.norm(path[:, None, :] - sources[None, :, :], axis=2).min(axis=1)
    inside = np.flatnonzero(d <= region)
    if inside.size == 0:
        return math.nan, math.nan
    k = int(inside[0])
    steps = np.diff(path[k:], axis=0)
    moving = np.linalg.norm(steps, axis=1) > 1e-9
    dots = np.einsum("kd,kd->k", steps[1:], steps[:-1])[moving[1:] & moving[:-1]]
    return float(np.mean(d[k:] <= region)), float(np.mean(dots < 0)) if dots.size else math.nan


def group_columns(
    res: Any, groups: list[GroupView], radius: float, region: float, same_reach: float
) -> dict[str, Any]:
    """The columns of the module docstring for one episode result ``res``."""
    sources = np.asarray(res.sources, float)[:, :2]
    out: dict[str, Any] = {"first_declared": -1}
    hits: list[int] = []
    for d in res.declarations:  # in the order they were made
        if d.group is None:
            continue
        dist = np.linalg.norm(sources - d.positions[0][None, :2], axis=1)
        i = int(np.argmin(dist))
        g = int(d.group)
        name = groups[g].name if g < len(groups) else str(g)
        out[f"source_{name}"], out[f"error_{name}"] = i, float(dist[i])
        if not hits:
            out["first_declared"] = i
        hits.append(i)
    out["same_declared"] = bool(len(hits) >= 2 and len(set(hits)) < len(hits))
    reached: list[set[int]] = []
    ended: list[tuple[int, float]] = []
    for g in groups:
        out.setdefault(f"source_{g.name}", -1)
        out.setdefault(f"error_{g.name}", math.nan)
        vr = leader_path(res.recording, g.suffix) if res.recording is not None else np.zeros((0, 2))
        if not len(vr):
            reached.append(set())
            continue
        d = np.linalg.norm(vr[:, None, :] - sources[None, :, :], axis=2)
        for i in range(len(sources)):
            out[f"closest_{g.name}_{i}"] = float(d[:, i].min())
        reached.append({i for i in range(len(sources)) if d[:, i].min() <= radius})
        ended.append((int(np.argmin(d[-1])), float(d[-1].min())))
        out[f"dwell_{g.name}"], out[f"reversal_{g.name}"] = approach(vr, sources, region)
    out["same_source"] = bool(
        len(ended) >= 2
        and len({i for i, _ in ended}) == 1
        and all(x <= same_reach for _, x in ended)
    )
    out["reached_both"] = bool(
        len(reached) >= 2 and any(i != j for i in reached[0] for j in reached[1])
    )
    found = sorted(
        t
        for t in (float(res.metrics.get(f"found_time_{i}", math.nan)) for i in range(len(sources)))
        if math.isfinite(t)
    )
    out["first_found"] = found[0] if found else math.nan
    out["second_found"] = found[1] if len(found) > 1 else math.nan
    return out
