"""How metrics are shown: their units and their number formats, shared by the console, the
report and the documentation.

Every number is written in fixed point (never ``1.2e+03``), with the unit of its metric;
counts as integers, flags as ``yes``/``no``, a missing value as ``-``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "METRICS",
    "MetricFormat",
    "agent_table",
    "explain_failure",
    "explain_reach",
    "format_metric",
    "metric_label",
]


@dataclass(frozen=True)
class MetricFormat:
    """Unit, decimals and meaning of one metric.

    Attributes
    ----------
    unit : str
        Unit symbol (empty for a dimensionless count or a flag).
    digits : int
        Decimals shown.
    meaning : str
        One line on what it measures (the documentation's table).
    """

    unit: str
    digits: int
    meaning: str


METRICS: dict[str, MetricFormat] = {
    "success": MetricFormat("", 0, "the episode met the task (see sources_found, false_sources)"),
    "termination": MetricFormat("", 0, "why the episode ended"),
    "search_time": MetricFormat(
        "s", 1, "simulated time at the end of the episode (a declaration, a reach, a limit)"
    ),
    "loc_error": MetricFormat(
        "m", 2, "mean over the true sources of the distance to the nearest declared position"
    ),
    "sources_found": MetricFormat("", 0, "true sources within success_radius of a declaration"),
    "false_sources": MetricFormat("", 0, "declared positions near no true source"),
    "declarations": MetricFormat("", 0, "declarations made"),
    "path_length": MetricFormat("m", 1, "distance travelled, summed over the agents"),
    "first_detection_time": MetricFormat("s", 1, "simulated time of the first detection"),
    "energy": MetricFormat("J", 0, "energy used, summed over the agents"),
    "bytes": MetricFormat("B", 0, "bytes sent between agents"),
    "start_distance": MetricFormat("m", 2, "distance from the nearest start to the nearest source"),
    "steps": MetricFormat("", 0, "control periods run"),
    "wall_time": MetricFormat("s", 2, "computer time of the episode"),
    "wall_per_step_ms": MetricFormat("ms", 2, "computer time per control period"),
}
"""The standard metrics (rows of ``odorloc run``, columns of the store) and their formats."""

_SUFFIX_UNITS = (("_time", "s", 1), ("_energy", "J", 0), ("_length", "m", 1), ("_error", "m", 2))


def _format_of(name: str) -> MetricFormat:
    if name in METRICS:
        return METRICS[name]
    if name.startswith("energy_"):
        return MetricFormat("J", 0, "")
    for suffix, unit, digits in _SUFFIX_UNITS:
        if name.endswith(suffix) or f"{suffix}_" in name:
            return MetricFormat(unit, digits, "")
    return MetricFormat("", 3, "")


def metric_label(name: str) -> str:
    """``"search_time (s)"``: the metric's name with its unit, if it has one."""
    unit = _format_of(name).unit
    return f"{name} ({unit})" if unit else name


def format_metric(name: str, value: Any, unit: bool = False) -> str:
    """``value`` of metric ``name`` in fixed point (``"1234.5"``; ``"1234.5 s"`` with
    ``unit``), with thousands separators from 10 000 on (``"3,412,594"``); ``-`` for a
    missing value."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    fm = _format_of(name)
    if isinstance(value, int) or (hasattr(value, "dtype") and "int" in str(value.dtype)):
        text = f"{int(value):,}" if abs(int(value)) >= 10_000 else str(int(value))
    else:
        try:
            v = float(value)
        except (TypeError, ValueError):
            return str(value)
        if math.isnan(v):
            return "-"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = f"{v:,.{fm.digits}f}" if abs(v) >= 1e4 else f"{v:.{fm.digits}f}"
    return f"{text} {fm.unit}" if unit and fm.unit else text


def explain_failure(
    metrics: dict[str, Any], n_sources: int | None = None, end: str | None = None
) -> str | None:
    """One line saying why an episode failed, from its own columns, or ``None`` for a success.

    Parameters
    ----------
    metrics : dict
        The episode's row.
    n_sources : int, optional
        True sources of the world (for "found 1 of 2").
    end : str, optional
        The scenario's ``task.end`` (``reach``: success is an agent reaching a source).
    """
    if metrics.get("success"):
        return None
    term = str(metrics.get("termination") or "")
    if end == "reach":
        return f"no agent came within reach of a source ({term})"
    if not metrics.get("declared") and not metrics.get("declarations"):
        return f"no declaration ({term or 'no termination recorded'})"
    found = metrics.get("sources_found")
    false = metrics.get("false_sources")
    parts = []
    if found is not None:
        of = f" of {n_sources}" if n_sources else ""
        parts.append(f"{int(found)}{of} source(s) found")
    if false:
        parts.append(f"{int(false)} false source(s) declared")
    err = metrics.get("loc_error")
    if err is not None and not (isinstance(err, float) and math.isnan(err)):
        parts.append(
            f"a source's nearest declaration {format_metric('loc_error', err, unit=True)} away "
            "on average"
        )
    return "; ".join(parts) + (f" ({term})" if term else "")


def explain_reach(
    metrics: dict[str, Any],
    n_sources: int,
    end: str | None,
    reach_radius: float | None,
    success_radius: float,
) -> str | None:
    """One line for a success by reaching whose declarations missed, or ``None``.

    With ``task.end: reach`` an episode succeeds when an agent comes within ``reach_radius``
    of a source, while ``sources_found`` and ``false_sources`` score the declared positions
    within ``success_radius``: a row can read "success yes, 0 found, 1 false". This says so.
    """
    if end != "reach" or not metrics.get("success") or not metrics.get("declarations"):
        return None
    found = int(metrics.get("sources_found") or 0)
    false = int(metrics.get("false_sources") or 0)
    if found >= n_sources and not false:
        return None
    reach = f" ({reach_radius:g} m)" if reach_radius is not None else ""
    return (
        f"success here is reaching: an agent came within task.reach_radius{reach} of a source; "
        f"the declarations are scored apart, within task.success_radius ({success_radius:g} m): "
        f"{found} of {n_sources} source(s) found, {false} false"
    )


MAX_AGENT_COLUMNS = 6
"""Agents shown one column each in :func:`agent_table`; a larger team is shown by its range."""


def agent_table(
    agents: Mapping[int, Mapping[str, Any]], max_columns: int = MAX_AGENT_COLUMNS
) -> tuple[list[str], list[list[str]]]:
    """Per-agent values (``{agent id: {key: value}}``: an episode's
    :attr:`~odorloc.engine.metrics.EpisodeMetrics.agents`, or means over a cell's episodes) as
    a table: one row per metric (its label with its unit), one column per agent; for more than
    ``max_columns`` agents the columns are ``agents`` (how many have the value), ``min``,
    ``mean`` and ``max`` over them.

    Returns
    -------
    headers : list of str
    rows : list of list of str
        Empty when no agent has a value.
    """
    ids = sorted(agents)
    keys = sorted({k for a in ids for k in agents[a]})
    if not keys:
        return [], []
    if len(ids) <= max_columns:
        headers = ["metric", *(f"agent {a}" for a in ids)]
        rows = [[metric_label(k), *(format_metric(k, agents[a].get(k)) for a in ids)] for k in keys]
        return headers, rows
    headers = ["metric", "agents", "min", "mean", "max"]
    rows = []
    for k in keys:
        vals = [float(agents[a][k]) for a in ids if _is_finite(agents[a].get(k))]
        if not vals:
            rows.append([metric_label(k), "0", "-", "-", "-"])
            continue
        mean = sum(vals) / len(vals)
        rows.append(
            [metric_label(k), str(len(vals))]
            + [format_metric(k, float(v)) for v in (min(vals), mean, max(vals))]
        )
    return headers, rows


def _is_finite(v: Any) -> bool:
    try:
        return v is not None and not isinstance(v, str) and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False
