"""The metrics of one episode as a typed record: core columns, extra columns, per-agent values.

The episode fills the **core** columns (``success``, ``search_time``, ``path_length``, the
energy breakdown, the times each source was found, ...). A searcher's
:meth:`~odorloc.searchers.base.Searcher.final_metrics` and an experiment's own columns are
**extra** columns: they are added beside the core ones and can never replace one (an extra
column named like a core column is refused, naming it). Values that belong to one agent of a
team (a UAV's cue count, a group's declaration time) are kept **per agent**
(``metrics.agents[agent][key]``), never folded into column names: the results store keeps
them as a long table ``(episode, agent, key, value)`` beside the episode row.

:class:`EpisodeMetrics` reads like the flat dict it replaces (``m["success"]``,
``m.get("loc_error")``, ``dict(m)``, ``m.items()``: core columns first, then the extras) and
adds columns with ``m["name"] = value`` or :meth:`EpisodeMetrics.add`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, MutableMapping
from typing import Any

__all__ = ["AgentMetrics", "EpisodeMetrics", "MetricsError", "check_agent_metrics"]

AgentMetrics = dict[int, dict[str, Any]]
"""Per-agent values: agent id -> metric name -> value."""


class MetricsError(ValueError):
    """A column that would overwrite a core metric, or per-agent values of the wrong shape."""


def check_agent_metrics(agents: Mapping[Any, Mapping[str, Any]], source: str) -> AgentMetrics:
    """``agents`` as ``{int agent id: {str key: value}}``; :class:`MetricsError` naming
    ``source`` and the offending entry otherwise."""
    out: AgentMetrics = {}
    for a, values in agents.items():
        if isinstance(a, bool) or not isinstance(a, int):
            raise MetricsError(f"{source}: agent id {a!r} is not an integer")
        if not isinstance(values, Mapping):
            raise MetricsError(f"{source}[{a}]: expected a dict of metric name -> value")
        for k in values:
            if not isinstance(k, str) or not k:
                raise MetricsError(f"{source}[{a}]: metric name {k!r} is not a name")
        out[int(a)] = dict(values)
    return out


class EpisodeMetrics(MutableMapping[str, Any]):
    """An episode's metrics row (see the module docstring).

    Parameters
    ----------
    core : mapping of str to value
        The columns the episode itself computes; fixed once given.
    extra : mapping of str to value, optional
        Further columns (a searcher's, an experiment's); none may be named like a core column.
    agents : mapping of int to mapping of str to value, optional
        Per-agent values, by agent id.

    Raises
    ------
    MetricsError
        An extra column named like a core column (the message names it), or malformed
        per-agent values.
    """

    __slots__ = ("_agents", "_core", "_extra")

    def __init__(
        self,
        core: Mapping[str, Any],
        extra: Mapping[str, Any] | None = None,
        agents: Mapping[int, Mapping[str, Any]] | None = None,
    ) -> None:
        self._core: dict[str, Any] = dict(core)
        self._extra: dict[str, Any] = {}
        self._agents: AgentMetrics = check_agent_metrics(agents or {}, "agent metrics")
        if extra:
            self.add(extra)

    # ------------------------------------------------------------------ typed access
    @property
    def core(self) -> dict[str, Any]:
        """The core columns (a copy)."""
        return dict(self._core)

    @property
    def extra(self) -> dict[str, Any]:
        """The extra columns (a copy)."""
        return dict(self._extra)

    @property
    def agents(self) -> AgentMetrics:
        """Per-agent values, ``{agent id: {key: value}}`` (a copy)."""
        return {a: dict(v) for a, v in self._agents.items()}

    def agent_rows(self) -> list[tuple[int, str, Any]]:
        """Per-agent values as long rows ``(agent, key, value)``, by agent then key."""
        return [(a, k, v) for a in sorted(self._agents) for k, v in self._agents[a].items()]

    def add(self, columns: Mapping[str, Any], source: str = "extra") -> None:
        """Add extra columns; a name of a core column is refused (:class:`MetricsError`
        naming it and ``source``), an extra column may be updated."""
        clash = [k for k in columns if k in self._core]
        if clash:
            raise MetricsError(
                f"{source}.{clash[0]}: {clash[0]!r} is a core metric of the episode and "
                "cannot be overwritten by an extra column"
            )
        for k in columns:
            if not isinstance(k, str) or not k:
                raise MetricsError(f"{source}: column name {k!r} is not a name")
        self._extra.update(columns)

    def row(self) -> dict[str, Any]:
        """The flat row: core columns, then extra columns (per-agent values are not in it)."""
        return {**self._core, **self._extra}

    # ------------------------------------------------------------------ mapping protocol
    def __getitem__(self, key: str) -> Any:
        if key in self._core:
            return self._core[key]
        return self._extra[key]

    def __setitem__(self, key: str, value: Any) -> None:
        self.add({key: value})

    def __delitem__(self, key: str) -> None:
        if key in self._core:
            raise MetricsError(f"{key!r} is a core metric of the episode and cannot be removed")
        del self._extra[key]

    def __iter__(self) -> Iterator[str]:
        yield from self._core
        yield from self._extra

    def __len__(self) -> int:
        return len(self._core) + len(self._extra)

    def __contains__(self, key: object) -> bool:
        return key in self._core or key in self._extra

    def __repr__(self) -> str:
        return f"EpisodeMetrics({self.row()!r}, agents={self._agents!r})"

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self._core, self._extra, self._agents))
