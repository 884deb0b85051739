"""Who is who in a team figure: one colour and one name per agent, shared by every figure.

The trajectory, the traces, the animations and the 3-D views of one recording all take their
colours and names from :func:`team_style`, so agent 3 is the same colour everywhere:

- up to :data:`PALETTE` agents without groups: a qualitative palette (no gold, magenta or grey,
  which mark the true source, the declared source and particle weights);
- a team in groups (``agents.groups``, recorded as ``meta["groups"]``): one hue family per
  group (reds, blues, greens, ...), its members in shades of it, so a group reads as one colour
  and its members stay apart;
- more agents than the palette and no groups: evenly spaced colours of a cyclic map.

Small multiples (:meth:`TeamStyle.units`) show one column per agent up to
:data:`MAX_AGENT_PANELS` agents, and one column per group beyond (each with a band over its
members), so that a dozen robots never end up as one black block.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib import colormaps, colors

__all__ = [
    "MAX_AGENT_PANELS",
    "PALETTE",
    "TeamStyle",
    "Unit",
    "agent_noun",
    "team_style",
]

PALETTE = (
    "tab:red",
    "tab:blue",
    "tab:green",
    "tab:orange",
    "tab:purple",
    "tab:brown",
    "tab:cyan",
    "tab:olive",
)
"""Agent colours of a team without groups (in agent order)."""

_GROUP_MAPS = ("Reds", "Blues", "Greens", "Oranges", "Purples", "Greys", "YlOrBr", "PuRd")
"""Hue families of groups, in group order (members in shades of their group's map)."""

MAX_AGENT_PANELS = 6
"""Most agents drawn as one small-multiple column each; larger teams get one per group."""


@dataclass(frozen=True)
class Unit:
    """One column of small multiples: one agent, or a group drawn as a band over its members.

    Attributes
    ----------
    label : str
        Column title (``"UAV 1"``, ``"group A (robots 0-5)"``).
    agents : tuple of int
        The agents it shows.
    color : (4,) tuple of float
        RGBA of the agent, or of the group (the middle shade of its family).
    """

    label: str
    agents: tuple[int, ...]
    color: tuple[float, float, float, float]

    @property
    def is_group(self) -> bool:
        """Whether the unit stands for several agents (drawn as a band)."""
        return len(self.agents) > 1


@dataclass(frozen=True)
class TeamStyle:
    """Colours and names of the agents of one recording (see the module docstring).

    Attributes
    ----------
    colors : (A, 4) ndarray
        RGBA of every agent.
    noun : str
        ``"robot"`` or ``"UAV"``.
    groups : tuple of (str, tuple of int)
        Named groups (empty without groups).
    group_colors : (G, 4) ndarray
        RGBA of every group.
    """

    colors: np.ndarray
    noun: str
    groups: tuple[tuple[str, tuple[int, ...]], ...]
    group_colors: np.ndarray

    @property
    def n_agents(self) -> int:
        """Number of agents."""
        return len(self.colors)

    def color(self, agent: int) -> tuple[float, float, float, float]:
        """RGBA of ``agent``."""
        return tuple(float(c) for c in self.colors[agent])  # type: ignore[return-value]

    def name(self, agent: int) -> str:
        """``"robot"`` (or ``"UAV"``) alone, else ``"<noun> <id>"`` (``"UAV 2"``)."""
        if self.n_agents == 1:
            return "UAV" if self.noun == "UAV" else "robot"
        return f"{self.noun} {agent}"

    def group_label(self, k: int) -> str:
        """``"group A (robots 0-5)"``: the group's name and its agents."""
        name, members = self.groups[k]
        return f"group {name} ({self.noun}s {_ranges(members)})"

    def units(self, max_agents: int = MAX_AGENT_PANELS) -> list[Unit]:
        """Small-multiple columns: one per agent up to ``max_agents`` agents, else one per group
        (agents in no group share one more column); a large team without groups is one
        column."""
        if self.n_agents <= max_agents:
            return [Unit(self.name(a), (a,), self.color(a)) for a in range(self.n_agents)]
        out: list[Unit] = []
        grouped: set[int] = set()
        for k, (_, members) in enumerate(self.groups):
            gc = tuple(float(c) for c in self.group_colors[k])
            out.append(Unit(self.group_label(k), members, gc))  # type: ignore[arg-type]
            grouped.update(members)
        rest = tuple(a for a in range(self.n_agents) if a not in grouped)
        if rest:
            label = f"{'other ' if out else 'all '}{self.noun}s ({_ranges(rest)})"
            out.append(Unit(label, rest, colors.to_rgba("0.3")))  # type: ignore[arg-type]
        if len(out) > max_agents:  # too many groups for columns: the team as one band
            everyone = tuple(range(self.n_agents))
            return [Unit(f"all {self.noun}s", everyone, colors.to_rgba("0.3"))]  # type: ignore[arg-type]
        return out

    def legend_units(self, max_entries: int = len(PALETTE)) -> list[Unit]:
        """Legend entries of the agents: one per agent up to ``max_entries`` agents, else one
        per group (the team when there are none)."""
        return self.units(max_entries)


def _ranges(ids: Sequence[int]) -> str:
    """``0-5, 8`` for ``[0, 1, 2, 3, 4, 5, 8]``."""
    ids = sorted(ids)
    parts: list[str] = []
    start = prev = ids[0]
    for a in [*ids[1:], None]:
        if a is not None and a == prev + 1:
            prev = a
            continue
        parts.append(str(start) if start == prev else f"{start}-{prev}")
        if a is not None:
            start = prev = a
    return ", ".join(parts)


def agent_noun(platform: str) -> str:
    """What an agent on ``platform`` (a registry name; empty when unknown) is called in
    figures: ``"UAV"``, ``"robot"``, or ``"agent"``."""
    if not platform:
        return "agent"
    return "UAV" if "uav" in platform.lower() else "robot"


def _groups(meta: Mapping[str, Any], n_agents: int) -> tuple[tuple[str, tuple[int, ...]], ...]:
    out = []
    for k, g in enumerate(meta.get("groups") or []):
        if not isinstance(g, Mapping):
            continue
        members = tuple(int(a) for a in g.get("agents", ()) if 0 <= int(a) < n_agents)
        if members:
            out.append((str(g.get("name") or chr(65 + k)), members))
    return tuple(out)


def team_style(n_agents: int, meta: Mapping[str, Any] | None = None) -> TeamStyle:
    """The colours and names of ``n_agents`` agents of a recording with metadata ``meta``.

    Parameters
    ----------
    n_agents : int
        Agents in the recording.
    meta : mapping, optional
        The recording's ``meta``: ``groups`` (list of ``{name, agents}``) and ``platform`` (a
        registry name, which names the agents) are read when present.

    Returns
    -------
    TeamStyle
    """
    meta = meta or {}
    groups = _groups(meta, n_agents)
    noun = agent_noun(str(meta.get("platform") or ""))
    rgba = np.zeros((n_agents, 4))
    group_rgba = np.zeros((len(groups), 4))
    if len(groups) > 1:
        cyc = colormaps["hsv"]
        for k, (_, members) in enumerate(groups):
            cmap = colormaps[_GROUP_MAPS[k]] if k < len(_GROUP_MAPS) else None
            if cmap is None:  # more groups than hue families: one plain hue each
                base = np.asarray(cyc(k / len(groups)))
                group_rgba[k] = base
                rgba[list(members)] = base
                continue
            group_rgba[k] = cmap(0.7)
            # dark to light within the family; never so light that a path fades into white
            shades = np.linspace(0.9, 0.5, len(members)) if len(members) > 1 else [0.7]
            for a, s in zip(members, shades, strict=True):
                rgba[a] = cmap(float(s))
        rest = [a for a in range(n_agents) if not any(a in m for _, m in groups)]
        for i, a in enumerate(rest):
            rgba[a] = colors.to_rgba(str(0.15 + 0.4 * i / max(len(rest), 1)))
    elif n_agents <= len(PALETTE):
        for a in range(n_agents):
            rgba[a] = colors.to_rgba(PALETTE[a])
        for k, (_, members) in enumerate(groups):
            group_rgba[k] = rgba[members[0]]
    else:
        cyc = colormaps["turbo"]
        for a in range(n_agents):
            rgba[a] = cyc(0.05 + 0.9 * a / max(n_agents - 1, 1))
        group_rgba[:] = colors.to_rgba("0.3")
    return TeamStyle(colors=rgba, noun=noun, groups=groups, group_colors=group_rgba)
