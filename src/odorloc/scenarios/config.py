"""Typed scenario configuration that round-trips to YAML.

A scenario names every component by its registry name (``type``) and gives its parameters
inline; :meth:`Scenario.validate_components` checks them with the component's own parameter
model so errors name the exact field (``world.plume.sigma0: must be a finite number > 0``).

Example (YAML)::

    name: my-room
    world:
      arena: {lower: [0, 0], upper: [10, 5], resolution: 0.1}
      sources: [{position: [1, 2.5], rate: 10}]
      wind: {type: uniform, velocity: [0.5, 0]}
      plume: {type: filament}
    platform: {type: holonomic, max_speed: 0.3}
    agents: {starts: [[8, 2.5]]}
    searcher: {type: zigzag}
    task: {success_radius: 0.5}
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import re
from pathlib import Path
from typing import Any, Literal

import pydantic
import yaml
from pydantic import BaseModel, ConfigDict, Field, model_validator

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.loading import load_yaml_mapping
from odorloc.core.params import (
    Finite,
    NonNegative,
    Positive,
    Seed,
    Vector,
    refuse_bools_as_numbers,
)
from odorloc.core.registry import ComponentRef
from odorloc.geometry.regions import check_region, narrow_box
from odorloc.plume.sources import Source


class _Strict(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", defer_build=True)

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        # true/false in a numeric field would be read as 1/0
        refuse_bools_as_numbers(cls)


Component = ComponentRef
"""A registry reference: ``type`` plus the component's own parameters (validated by
:meth:`Scenario.validate_components`)."""


COMPONENTS: dict[str, str] = {
    "world.wind": "wind",
    "world.plume": "plume",
    "world.source_draw": "source_draw",
    "sensors.gas": "gas_sensor",
    "sensors.anemometer": "anemometer",
    "platform": "platform",
    "searcher": "searcher",
}
"""Registry family of every component field of a scenario (dotted path -> family)."""


def is_file_field(info: Any) -> bool:
    """Whether a pydantic field holds a file path (``json_schema_extra={"file_path": True}``);
    such paths in a scenario file are relative to the file's folder."""
    extra = getattr(info, "json_schema_extra", None)
    return isinstance(extra, dict) and bool(extra.get("file_path"))


class ObstaclesConfig(_Strict):
    """Obstacles: axis-aligned boxes, 2D polygons, and/or an occupancy file (CSV or image; a
    relative path in a scenario file is relative to that file's folder)."""

    boxes: list[tuple[tuple[float, ...], tuple[float, ...]]] = []
    polygons: list[list[tuple[float, float]]] = []
    file: str | None = Field(None, json_schema_extra={"file_path": True})


class ArenaConfig(_Strict):
    """Arena bounds (metres) and occupancy-grid resolution (metres)."""

    lower: tuple[float, ...]
    upper: tuple[float, ...]
    resolution: Positive = 0.1
    obstacles: ObstaclesConfig = ObstaclesConfig()


class WorldConfig(_Strict):
    """The simulated world.

    Attributes
    ----------
    dt : float
        World integration step, seconds (the plume and wind advance by ``dt``).
    warmup : float
        Seconds simulated before the episode clock starts, so the plume is developed.
    source_draw : dict, optional
        Draw the sources' positions anew for every episode from the world's random stream
        (``{type: uniform, region: ..., min_start_distance: ...}``; see
        :mod:`odorloc.plume.source_draw`). Default: the configured positions.
    """

    arena: ArenaConfig
    sources: list[Source] = Field(min_length=1)
    wind: Component = Component(type="uniform")
    plume: Component = Component(type="filament")
    dt: Positive = 0.1
    warmup: NonNegative = 0.0
    source_draw: Component | None = None


class SensorsConfig(_Strict):
    """Gas sensor and anemometer of every agent."""

    gas: Component = Component(type="concentration")
    anemometer: Component = Component(type="anemometer")


class GroupConfig(_Strict):
    """A named group of agents (e.g. one formation): ``{name: A, agents: [0, 1, 2]}``."""

    name: str = ""
    agents: list[int] = Field(min_length=1)


Point = Vector
"""A point, metres: finite components, true/false refused (the arena checks how many)."""


class AgentsConfig(_Strict):
    """Who searches, and from where.

    Attributes
    ----------
    starts : list of points, metres
        Start position of each agent (the agent id is its index here).
    heading : float, rad
        Start heading of every agent.
    comm_radius : float, metres
        Communication radius of the team (``inf``: everybody hears everybody; 0: nobody).
    groups : list of GroupConfig
        Disjoint groups of agent ids (formations, teams); empty = no groups.
    start_points : list of points, metres
        Candidate single-agent start points (the sweep shorthand ``start_index: i`` starts agent
        0 at point ``i``).
    start_sets : dict of name to list of points, metres
        Named start positions, one point per group (the sweep shorthand ``start_set: NAME``
        moves each group so that its centroid lies on the set's point).
    """

    starts: list[Point] = Field(min_length=1)
    heading: Finite = 0.0
    comm_radius: float = math.inf
    groups: list[GroupConfig] = []
    start_points: list[Point] = []
    start_sets: dict[str, list[Point]] = {}

    @model_validator(mode="after")
    def _check(self) -> AgentsConfig:
        if not (self.comm_radius >= 0):
            raise ConfigError("comm_radius", "must be >= 0")
        seen: set[int] = set()
        n = len(self.starts)
        for k, g in enumerate(self.groups):
            for a in g.agents:
                if not 0 <= a < n:
                    raise ConfigError(
                        f"groups[{k}].agents", f"names agent {a}, but there are {n} agents"
                    )
                if a in seen:
                    raise ConfigError(f"groups[{k}].agents", f"agent {a} is in two groups")
                seen.add(a)
        for name, pts in self.start_sets.items():
            # without groups the agents move as one group (their centroid onto the point)
            n_groups = len(self.groups) or 1
            if len(pts) != n_groups:
                what = f"{n_groups} groups" if self.groups else "the agents (one group)"
                raise ConfigError(f"start_sets.{name}", f"has {len(pts)} points for {what}")
        return self


class TaskConfig(_Strict):
    """What the searchers must do, and when an episode ends.

    Attributes
    ----------
    region : ((x0, y0[, z0]), (x1, y1[, z1])), optional
        The area to search or map, metres (searchers are told it).
    end : {"first_declaration", "all_groups", "reach", "limits"}
        ``first_declaration``: the first declaration ends the episode; ``all_groups``: the
        episode ends once every group (or, without groups, the team) has declared;
        ``reach``: it ends when an agent comes within ``reach_radius`` of a source;
        ``limits``: only the time or energy limit ends it. Time and energy limits always apply.
    success_radius : float, metres
        A true source counts as found when a declared position lies this close.
    reach_radius : float, metres, optional
        Distance at which an agent has reached a source (required by ``end: reach``; otherwise
        reaching is only recorded).
    stuck_limit : int, optional
        Ends the episode as ``stuck`` (a failure) once every agent has moved back and forth more
        than this many steps in a row: an agent's counter grows at each step that brings it back
        to where it stood two steps earlier and resets at any other step (the lattice problem of
        infotaxis uses 8, Loisy & Eloy 2022). ``None``: no such rule.
    """

    region: tuple[Point, Point] | None = None
    end: Literal["first_declaration", "all_groups", "reach", "limits"] = "first_declaration"
    success_radius: Positive = 0.5
    reach_radius: Positive | None = None
    stuck_limit: int | None = Field(None, ge=0, le=1_000_000)

    @model_validator(mode="after")
    def _check(self) -> TaskConfig:
        if self.region is not None:
            check_region(self.region, "region")
        if self.end == "reach" and self.reach_radius is None:
            raise ConfigError("reach_radius", "is required by end 'reach'")
        return self


MAX_CONTROL_STEPS = 1_000_000
"""Most control periods of one episode (``limits.time / limits.control_dt``)."""
MAX_WORLD_STEPS = 20_000_000
"""Most world steps of one episode, warm-up included (``(warmup + time) / world.dt``)."""


class LimitsConfig(_Strict):
    """Episode limits: control period (s), time limit (s), energy limit (J).

    An episode may have at most :data:`MAX_CONTROL_STEPS` control periods and
    :data:`MAX_WORLD_STEPS` world steps (warm-up included), and the time limit must hold at
    least one control period.
    """

    control_dt: Positive = 0.5
    time: Positive = 600.0
    energy: float = Field(math.inf, gt=0)


class RecordingConfig(_Strict):
    """What the recorder keeps: every ``stride``-th step, beliefs every ``belief_stride`` steps,
    a coarse plume frame every ``plume_stride`` steps on a grid of ``plume_grid`` cells per
    metre."""

    stride: int = Field(1, ge=1, le=1_000_000)
    belief_stride: int = Field(4, ge=1, le=1_000_000_000)
    plume_stride: int = Field(4, ge=1, le=1_000_000_000)
    plume_grid: Positive = 10.0
    enabled: bool = True


class Scenario(_Strict):
    """A complete, reproducible experiment setting.

    ``knobs`` name settings that move together: ``{frequency: [world.wind.frequency_factor,
    world.sources.0.modulation.frequency_factor]}`` makes ``frequency`` one override (and one
    sweep axis) that sets every listed path to its value (:meth:`with_overrides`).
    """

    name: str = "custom"
    description: str = ""
    paper: str = ""
    world: WorldConfig
    sensors: SensorsConfig = SensorsConfig()
    platform: Component = Component(type="holonomic")
    agents: AgentsConfig
    searcher: Component = Component(type="zigzag")
    task: TaskConfig = TaskConfig()
    limits: LimitsConfig = LimitsConfig()
    seed: Seed = 0
    recording: RecordingConfig = RecordingConfig()
    knobs: dict[str, list[str]] = {}

    # ------------------------------------------------------------------ validation
    def validate_components(self) -> Scenario:
        """Check every registry reference and geometric consistency; raise :class:`ConfigError`."""
        for path, family in COMPONENTS.items():
            ref = self._component(path)
            if ref is not None:
                ref.params(family, path)
        d = len(self.world.arena.lower)
        if len(self.world.arena.upper) != d or d not in (2, 3):
            raise ConfigError(
                "world.arena.upper", "lower and upper need the same 2 or 3 components"
            )
        for k, s in enumerate(self.agents.starts):
            if len(s) != d:
                raise ConfigError(f"agents.starts[{k}]", f"needs {d} components, got {len(s)}")
        for k, s in enumerate(self.agents.start_points):
            if len(s) != d:
                raise ConfigError(f"agents.start_points[{k}]", f"needs {d} components")
        for name, pts in self.agents.start_sets.items():
            for k, s in enumerate(pts):
                if len(s) != d:
                    raise ConfigError(f"agents.start_sets.{name}[{k}]", f"needs {d} components")
        arena = self.world.arena
        narrow_box(arena.lower, arena.upper, self.task.region, "task.region")
        if self.world.dt > self.limits.control_dt:
            raise ConfigError("world.dt", "must not exceed limits.control_dt")
        ratio = self.limits.control_dt / self.world.dt
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            # the engine steps the world a whole number of times per control period
            raise ConfigError(
                "world.dt",
                f"{self.world.dt:g} s does not divide limits.control_dt "
                f"({self.limits.control_dt:g} s) into whole steps",
            )
        self._check_sizes(d)
        self._check_knobs()
        return self

    def _component(self, path: str) -> ComponentRef | None:
        node: Any = self
        for k in path.split("."):
            node = getattr(node, k)
        return node

    def _check_sizes(self, d: int) -> None:
        """Consistent limits and bounded work: step counts and the arena's grid."""
        from odorloc.geometry.grid import check_cell_count

        lim, w = self.limits, self.world
        if lim.control_dt > lim.time:
            raise ConfigError(
                "limits.control_dt",
                f"{lim.control_dt:g} s is longer than the time limit limits.time "
                f"({lim.time:g} s): the episode would have no step",
            )
        steps = lim.time / lim.control_dt
        if steps > MAX_CONTROL_STEPS:
            raise ConfigError(
                "limits.time",
                f"{lim.time:g} s at limits.control_dt {lim.control_dt:g} s is {steps:.3g} "
                f"control periods; at most {MAX_CONTROL_STEPS}",
            )
        world_steps = (w.warmup + lim.time) / w.dt
        if world_steps > MAX_WORLD_STEPS:
            field = "world.warmup" if w.warmup > lim.time else "world.dt"
            raise ConfigError(
                field,
                f"warm-up {w.warmup:g} s plus {lim.time:g} s at world.dt {w.dt:g} s is "
                f"{world_steps:.3g} world steps; at most {MAX_WORLD_STEPS}",
            )
        a = self.world.arena
        for name, bound in (("lower", a.lower), ("upper", a.upper)):
            if not all(math.isfinite(x) for x in bound):
                raise ConfigError(f"world.arena.{name}", "bounds must be finite")
        size = [hi - lo for lo, hi in zip(a.lower, a.upper, strict=True)]
        if all(math.isfinite(x) and x > 0 for x in size):
            check_cell_count(
                [x / a.resolution for x in size], a.resolution, "world.arena.resolution"
            )
        if d and self.recording.enabled:
            cells = [x * self.recording.plume_grid for x in size[:2]]
            check_cell_count(cells, 1.0 / self.recording.plume_grid, "recording.plume_grid")

    def _check_knobs(self) -> None:
        data = self.to_dict()
        reserved = set(type(self).model_fields) | {"start_set", "start_index"}
        for name, paths in self.knobs.items():
            field = f"knobs.{name}"
            if not name or "." in name or name in reserved:
                raise ConfigError(field, "a knob name must be a plain word, not a setting's name")
            if not paths:
                raise ConfigError(field, "names no setting")
            for path in paths:
                if path.split(".")[0] == "knobs":
                    raise ConfigError(field, f"{path!r}: a knob cannot set knobs")
                try:
                    node, last = _walk(data, path)
                except ConfigError as exc:
                    raise ConfigError(field, f"{path!r}: {exc.problem}") from None
                if isinstance(node, list):
                    if not (last.isdigit() and int(last) < len(node)):
                        raise ConfigError(field, f"{path!r}: no such setting {last!r}")
                elif last not in node and "type" not in node:
                    # component parameters (a mapping with ``type``) may be left at default
                    raise ConfigError(field, f"{path!r}: no such setting {last!r}")

    # ------------------------------------------------------------------ I/O
    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scenario:
        """Validate a plain dict (e.g. parsed YAML) into a scenario; :class:`ConfigError` if bad."""
        if not isinstance(data, dict):
            raise ConfigError("<root>", "a scenario must be a mapping")
        try:
            sc = cls.model_validate(data)
        except pydantic.ValidationError as err:
            field, _, problem = format_validation_error(err, model=cls).partition(": ")
            raise ConfigError(field, problem) from None
        return sc.validate_components()

    @classmethod
    def from_yaml(cls, path: str | Path) -> Scenario:
        """Load a scenario file.

        It is read through :mod:`odorloc.core.loading` (a binary, non-UTF-8, oversized or
        alias-bomb file is refused with one line), and relative file paths inside it (an
        obstacle file, a replayed movie) are taken relative to the file's folder.
        """
        data = load_yaml_mapping(path, "scenario")
        return cls.from_dict(_resolve_files(data, Path(path).absolute().parent))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (JSON/YAML serialisable; infinities kept as floats)."""
        return self.model_dump(mode="python")

    def to_yaml(self, path: str | Path | None = None) -> str:
        """YAML text of the scenario; written to ``path`` when given."""
        text = yaml.safe_dump(_plain(self.to_dict()), sort_keys=False)
        if path is not None:
            Path(path).write_text(text)
        return text

    def config_hash(self) -> str:
        """Stable hash of everything that affects results (the seed included)."""
        blob = json.dumps(_plain(self.to_dict()), sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def with_start_point(self, index: int) -> Scenario:
        """A copy whose (single) agent starts at ``agents.start_points[index]``."""
        points = self.agents.start_points
        if not 0 <= int(index) < len(points):
            raise ConfigError(
                "start_index", f"{index} is not an index of agents.start_points ({len(points)})"
            )
        if len(self.agents.starts) != 1:
            raise ConfigError("start_index", "needs a single-agent scenario")
        return self.with_overrides({"agents.starts": [list(points[int(index)])]})

    def with_start_set(self, name: str) -> Scenario:
        """A copy with every group moved so that its start centroid lies on ``start_sets[name]``.

        The agents of a group keep their positions relative to each other (e.g. a formation).
        """
        sets = self.agents.start_sets
        if name not in sets:
            known = ", ".join(sorted(sets)) or "none"
            raise ConfigError("start_set", f"unknown start set {name!r} (known: {known})")
        groups = self.agents.groups or [GroupConfig(agents=list(range(len(self.agents.starts))))]
        starts = [list(p) for p in self.agents.starts]
        for g, target in zip(groups, sets[name], strict=True):
            pts = [starts[a] for a in g.agents]
            centre = [sum(c) / len(pts) for c in zip(*pts, strict=True)]
            for a in g.agents:
                starts[a] = [x - c + t for x, c, t in zip(starts[a], centre, target, strict=True)]
        return self.with_overrides({"agents.starts": starts})

    def with_overrides(self, overrides: dict[str, Any]) -> Scenario:
        """A copy with dotted-path overrides, e.g. ``{"searcher.n_particles": 500}``.

        A path must lead through existing settings (list items by index, ``"agents.starts.0"``);
        its last key may be new only inside a component (``type`` plus free parameters), where
        the component's own parameter model then checks it. A key naming one of :attr:`knobs`
        sets every path of the knob to the value.

        Raises
        ------
        ConfigError
            Naming the override path: an unknown setting, a bad index or an invalid value.
        """
        data = copy.deepcopy(self.to_dict())
        expanded: dict[str, Any] = {}
        knob_of: dict[str, str] = {}
        for path, value in overrides.items():
            for p in self.knobs.get(path, [path]):
                if p in expanded:
                    raise ConfigError(path, f"sets {p!r}, which another override sets too")
                expanded[p] = value
                if path in self.knobs:
                    knob_of[p] = path
        for path, value in expanded.items():
            node: Any = data
            keys = str(path).split(".")
            for depth, k in enumerate(keys):
                last = depth == len(keys) - 1
                where = ".".join(keys[:depth]) or "the scenario"
                if isinstance(node, list):
                    if not (k.isdigit() and int(k) < len(node)):
                        raise ConfigError(
                            path, f"{k!r} is not an index of {where} ({len(node)} items)"
                        )
                    if last:
                        node[int(k)] = value
                    else:
                        node = node[int(k)]
                elif isinstance(node, dict):
                    free = "type" in node  # a component: its parameters are checked by type
                    if k not in node and not (last and free):
                        known = ", ".join(str(x) for x in node) or "none"
                        raise ConfigError(
                            path, f"no such setting {k!r} in {where} (known: {known})"
                        )
                    if last:
                        node[k] = value
                    else:
                        node = node[k]
                else:
                    raise ConfigError(path, f"{where} is a value, not a group of settings")
        try:
            return Scenario.from_dict(data)
        except ConfigError as exc:
            # a bad knob value is the knob's: name it, and the setting that refused it
            at = re.sub(r"\[(\d+)\]", r".\1", exc.field)
            for p, knob in knob_of.items():
                if at == p or at.startswith(p + "."):
                    raise ConfigError(knob, f"{exc.field} {exc.problem}") from None
            raise


def _absolute(value: Any, base: Path) -> Any:
    if isinstance(value, list):
        return [_absolute(v, base) for v in value]
    if isinstance(value, str) and value and not Path(value).expanduser().is_absolute():
        return str(base / value)
    return value


def _resolve_files(data: dict[str, Any], base: Path) -> dict[str, Any]:
    """``data`` with the relative file paths of its file fields made absolute against ``base``
    (the obstacle file and any component parameter marked as a file path)."""
    from odorloc.core.registry import entry

    data = copy.deepcopy(data)
    obstacles = data.get("world", {}).get("arena", {}).get("obstacles")
    if isinstance(obstacles, dict) and "file" in obstacles:
        obstacles["file"] = _absolute(obstacles["file"], base)
    for path, family in COMPONENTS.items():
        node: Any = data
        for k in path.split("."):
            node = node.get(k) if isinstance(node, dict) else None
        if not (isinstance(node, dict) and isinstance(node.get("type"), str)):
            continue
        try:
            model = entry(family, node["type"]).params
        except ConfigError:
            continue  # an unknown type is reported by the validation that follows
        for name, info in model.model_fields.items():
            if name in node and is_file_field(info):
                node[name] = _absolute(node[name], base)
    return data


def _walk(data: Any, path: str) -> tuple[Any, str]:
    """The container holding the last key of a dotted ``path`` in plain ``data``, and that key."""
    node: Any = data
    keys = path.split(".")
    for k in keys[:-1]:
        if isinstance(node, list) and k.isdigit() and int(k) < len(node):
            node = node[int(k)]
        elif isinstance(node, dict) and k in node:
            node = node[k]
        else:
            raise ConfigError(path, f"no such setting {k!r}")
    if not isinstance(node, list | dict):
        raise ConfigError(path, f"no such setting {keys[-1]!r}")
    return node, keys[-1]


def _plain(obj: Any) -> Any:
    """Tuples to lists recursively (YAML-safe)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    return obj
