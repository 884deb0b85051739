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
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import pydantic
import yaml
from pydantic import BaseModel, ConfigDict, Field, model_validator

from odorloc import registry
from odorloc.errors import ConfigError, format_validation_error
from odorloc.params import NonNegative, Params, Positive
from odorloc.world.sources import Source


class _Strict(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Component(BaseModel):
    """A registry reference: ``type`` plus the component's own parameters (validated later)."""

    model_config = ConfigDict(frozen=True, extra="allow")
    type: str

    @property
    def values(self) -> dict[str, Any]:
        """The parameters without ``type``."""
        return dict(self.model_extra or {})

    def params(self, family: str, field: str) -> Params:
        """Validate the parameters against the registered model of ``family/type``."""
        return registry.make_params(family, self.type, self.values, field=field)


class ObstaclesConfig(_Strict):
    """Obstacles: axis-aligned boxes, 2D polygons, and/or an occupancy file (CSV or image)."""

    boxes: list[tuple[tuple[float, ...], tuple[float, ...]]] = []
    polygons: list[list[tuple[float, float]]] = []
    file: str | None = None


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
    """

    arena: ArenaConfig
    sources: list[Source] = Field(min_length=1)
    wind: Component = Component(type="uniform")
    plume: Component = Component(type="filament")
    dt: Positive = 0.1
    warmup: NonNegative = 0.0


class SensorsConfig(_Strict):
    """Gas sensor and anemometer of every agent."""

    gas: Component = Component(type="concentration")
    anemometer: Component = Component(type="anemometer")


class AgentsConfig(_Strict):
    """Start positions (one per agent, metres), start heading (rad) and communication radius (m)."""

    starts: list[tuple[float, ...]] = Field(min_length=1)
    heading: float = 0.0
    comm_radius: float = math.inf

    @model_validator(mode="after")
    def _check(self) -> AgentsConfig:
        if not (self.comm_radius >= 0):
            raise ValueError("comm_radius must be >= 0")
        return self


class LimitsConfig(_Strict):
    """Episode limits: control period (s), time limit (s), energy limit (J)."""

    control_dt: Positive = 0.5
    time: Positive = 600.0
    energy: float = Field(math.inf, gt=0)


class RecordingConfig(_Strict):
    """What the recorder keeps: every ``stride``-th step, beliefs every ``belief_stride`` steps,
    a coarse plume frame every ``plume_stride`` steps on a grid of ``plume_grid`` cells per
    metre."""

    stride: int = Field(1, ge=1)
    belief_stride: int = Field(4, ge=1)
    plume_stride: int = Field(4, ge=1)
    plume_grid: Positive = 10.0
    enabled: bool = True


class Scenario(_Strict):
    """A complete, reproducible experiment setting."""

    name: str = "custom"
    description: str = ""
    paper: str = ""
    world: WorldConfig
    sensors: SensorsConfig = SensorsConfig()
    platform: Component = Component(type="holonomic")
    agents: AgentsConfig
    searcher: Component = Component(type="zigzag")
    limits: LimitsConfig = LimitsConfig()
    success_radius: Positive = 0.5
    seed: int = 0
    recording: RecordingConfig = RecordingConfig()
    info: dict[str, Any] = {}

    # ------------------------------------------------------------------ validation
    def validate_components(self) -> Scenario:
        """Check every registry reference and geometric consistency; raise :class:`ConfigError`."""
        self.world.wind.params("wind", "world.wind")
        self.world.plume.params("plume", "world.plume")
        self.sensors.gas.params("gas_sensor", "sensors.gas")
        self.sensors.anemometer.params("anemometer", "sensors.anemometer")
        self.platform.params("platform", "platform")
        self.searcher.params("searcher", "searcher")
        d = len(self.world.arena.lower)
        if len(self.world.arena.upper) != d or d not in (2, 3):
            raise ConfigError(
                "world.arena.upper", "lower and upper need the same 2 or 3 components"
            )
        for k, s in enumerate(self.agents.starts):
            if len(s) != d:
                raise ConfigError(f"agents.starts[{k}]", f"needs {d} components, got {len(s)}")
        if self.world.dt > self.limits.control_dt:
            raise ConfigError("world.dt", "must not exceed limits.control_dt")
        return self

    # ------------------------------------------------------------------ I/O
    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scenario:
        """Validate a plain dict (e.g. parsed YAML) into a scenario; :class:`ConfigError` if bad."""
        if not isinstance(data, dict):
            raise ConfigError("<root>", "a scenario must be a mapping")
        try:
            sc = cls.model_validate(data)
        except pydantic.ValidationError as err:
            field, _, problem = format_validation_error(err).partition(": ")
            raise ConfigError(field, problem) from None
        return sc.validate_components()

    @classmethod
    def from_yaml(cls, path: str | Path) -> Scenario:
        """Load a scenario file."""
        p = Path(path)
        try:
            text = p.read_text()
        except OSError as exc:
            raise ConfigError("scenario", f"cannot read {p}: {exc.strerror}") from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1})" if mark is not None else ""
            raise ConfigError("scenario", f"{p} is not valid YAML{where}") from None
        return cls.from_dict(data)

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

    def with_overrides(self, overrides: dict[str, Any]) -> Scenario:
        """A copy with dotted-path overrides, e.g. ``{"searcher.n_particles": 500}``."""
        data = copy.deepcopy(self.to_dict())
        for path, value in overrides.items():
            node: Any = data
            keys = path.split(".")
            for k in keys[:-1]:
                if isinstance(node, list):
                    node = node[int(k)]
                elif isinstance(node, dict) and k in node:
                    node = node[k]
                else:
                    raise ConfigError(path, f"no such setting {k!r}")
            last = keys[-1]
            if isinstance(node, list):
                node[int(last)] = value
            else:
                node[last] = value
        return Scenario.from_dict(data)


def _plain(obj: Any) -> Any:
    """Tuples to lists recursively (YAML-safe)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    return obj
