"""The four sweeps of the multi-UAV paper (Sect. VI.2, Figs. 4-7), as settings and sweep files.

A :class:`Setting` is one point of the paper's parameter space: the search area, the number of
UAVs, the communication radius and the initial particle count. The default setting is the
paper's (Table 1, Sect. VI.2): 100 x 60 x 30 m, source [10, 30, 25], 3 UAVs, N = 100, and the
scenario's 30 m radius (the largest of Fig. 6, where the paper's results have levelled off).
Each sweep changes one of them:

====== ========= ===================================== ===========================
sweep  figure    values                                other settings
====== ========= ===================================== ===========================
area   Fig. 4    60x60x30, 100x60x30, 100x100x50,      3 UAVs
                 100x200x50 m
uavs   Fig. 5    1 .. 8                                100 x 60 x 30 m
radius Fig. 6    0, 5, .., 30 m                        4 UAVs in 100 x 60 x 30 m
N      Fig. 7    20, 40, .., 220                       3 UAVs in 100 x 60 x 30 m
====== ========= ===================================== ===========================

Placement (a choice; the paper gives only the default source and the first three starts):

- the source keeps the default's position *relative to the area*: ``[10, 30, 25] / [100, 60,
  30]`` of each side, i.e. ``(0.1 L_x, 0.5 L_y, 0.833 L_z)``, half-way up the wind and near the
  ceiling, so the 100 x 60 x 30 m point of the area sweep is the default point of the others;
  in 100 x 200 x 50 m it is at [10, 100, 41.7], 98 m from the nearest UAV start;
- the UAVs start on the lower downwind edge (:func:`~odorloc.papers.muc_osl.placement.uav_starts`,
  ``y = 10``, ``z = 5``).

Settings that share the world (everything but the particle count) share the world key, so the
same episode index gives the same world and agent seeds to every algorithm and every particle
count there (common random numbers). The default setting's world key is the scenario name
itself, so ``odorloc run muc-osl-3d --seed S --episode I`` is episode ``I`` of the default point.

:func:`sweep_files` turns settings into sweep files: one of every world (areas, team sizes,
radii) x the four algorithms, and one of the particle counts (searcher parameters) on the
default world, which would otherwise cross every world.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from odorloc.core.errors import ConfigError
from odorloc.core.registry import make_params
from odorloc.papers.muc_osl.placement import uav_starts
from odorloc.papers.muc_osl.reference import ALGORITHMS

__all__ = [
    "AREAS",
    "DEFAULT",
    "FIG9_VALUES",
    "NO_ENV_PU",
    "SWEEPS",
    "Setting",
    "SweepDef",
    "cell_of",
    "fig9_settings",
    "searcher_label",
    "source_position",
    "sweep_files",
]

Area = tuple[float, float, float]

#: The default area, source and UAV start height of the paper (Sect. VI.2).
DEFAULT_AREA: Area = (100.0, 60.0, 30.0)
DEFAULT_SOURCE = (10.0, 30.0, 25.0)
#: Fig. 4's areas, metres.
AREAS: tuple[Area, ...] = (
    (60.0, 60.0, 30.0),
    (100.0, 60.0, 30.0),
    (100.0, 100.0, 50.0),
    (100.0, 200.0, 50.0),
)
#: Fig. 6 runs 4 UAVs.
RADIUS_UAVS = 4
#: Label of MUC-OSL without the upwind particle moves of eq. 16 (an ablation run beside the four
#: at the default setting of each world).
NO_ENV_PU = "muc-osl-no-env-pu"


def source_position(area: Sequence[float]) -> tuple[float, float, float]:
    """The source in ``area`` (metres): the default source at the same fraction of each side."""
    return tuple(  # type: ignore[return-value]
        round(s * a / d, 6) for s, a, d in zip(DEFAULT_SOURCE, area, DEFAULT_AREA, strict=True)
    )


def _area_text(area: Sequence[float]) -> str:
    return "x".join(f"{v:g}" for v in area)


@dataclass(frozen=True)
class Setting:
    """One point of the paper's parameter space.

    Attributes
    ----------
    area : (3,) tuple of float, metres
    n_uavs : int
    radius : float, metres
        Communication radius.
    n_particles : int
        Initial particle count of every UAV's filter (``N``; Col-PF then adapts it within
        ``[20, 160]``, Table 1).
    """

    area: Area = DEFAULT_AREA
    n_uavs: int = 3
    radius: float = 30.0
    n_particles: int = 100

    def world_suffix(self) -> str:
        """What sets the world apart from the default, ``""`` or e.g. ``"[radius=0,uavs=4]"``."""
        parts = []
        if self.area != DEFAULT_AREA:
            parts.append(f"area={_area_text(self.area)}")
        if self.radius != DEFAULT.radius:
            parts.append(f"radius={self.radius:g}")
        if self.n_uavs != DEFAULT.n_uavs:
            parts.append(f"uavs={self.n_uavs}")
        return f"[{','.join(parts)}]" if parts else ""

    def world(self) -> Setting:
        """The setting with the default particle count (what decides the world)."""
        return replace(self, n_particles=DEFAULT.n_particles)

    def scenario_params(self) -> dict[str, Any]:
        """Dotted scenario overrides giving this setting's world (empty for the default)."""
        out: dict[str, Any] = {}
        if self.area != DEFAULT_AREA:
            out["world.arena.upper"] = list(self.area)
            out["world.sources.0.position"] = list(source_position(self.area))
        if self.area != DEFAULT_AREA or self.n_uavs != DEFAULT.n_uavs:
            out["agents.starts"] = uav_starts(
                self.n_uavs, width=self.area[0], depth=self.area[1], height=self.area[2]
            )
        if self.radius != DEFAULT.radius:
            out["agents.comm_radius"] = float(self.radius)
        return out


DEFAULT = Setting()


@dataclass(frozen=True)
class SweepDef:
    """One of the paper's sweeps: the swept values and how to show them.

    Attributes
    ----------
    key : str
        ``area``, ``uavs``, ``radius`` or ``particles``.
    figure : str
        The paper's figure.
    xlabel : str
    values : tuple
        The swept values (areas as tuples).
    base : Setting
        The other settings.
    """

    key: str
    figure: str
    xlabel: str
    values: tuple[Any, ...]
    base: Setting = DEFAULT

    def setting(self, value: Any) -> Setting:
        """The setting of one swept value."""
        field = {"area": "area", "uavs": "n_uavs", "radius": "radius", "particles": "n_particles"}
        return replace(self.base, **{field[self.key]: value})

    def settings(self) -> list[Setting]:
        """Every swept setting, in order."""
        return [self.setting(v) for v in self.values]

    def tick(self, value: Any) -> str:
        """The x tick of a value."""
        return _area_text(value) if self.key == "area" else f"{value:g}"


SWEEPS: tuple[SweepDef, ...] = (
    SweepDef("area", "Fig. 4", "search area (m)", AREAS),
    SweepDef("uavs", "Fig. 5", "number of UAVs", tuple(range(1, 9))),
    SweepDef(
        "radius",
        "Fig. 6",
        "communication radius (m)",
        tuple(float(r) for r in range(0, 31, 5)),
        Setting(n_uavs=RADIUS_UAVS),
    ),
    SweepDef("particles", "Fig. 7", "particles N", tuple(range(20, 221, 20))),
)

#: Fig. 9's settings in the filament world: the ends, the default and a middle value of each.
FIG9_VALUES: dict[str, tuple[Any, ...]] = {
    "area": AREAS,
    "uavs": (1, 3, 5, 8),
    "radius": (0.0, 10.0, 20.0, 30.0),
    "particles": (20, 100, 160, 220),
}


def fig9_settings() -> tuple[SweepDef, ...]:
    """The four sweeps restricted to :data:`FIG9_VALUES`."""
    return tuple(replace(s, values=FIG9_VALUES[s.key]) for s in SWEEPS)


def _estimator_type(algorithm: str) -> str:
    """The estimator a preset composes (``col-pf`` or ``standard-pf``)."""
    return str(make_params("searcher", algorithm, {}).estimator.type)  # type: ignore[attr-defined]


def searcher_label(algorithm: str, n_particles: int) -> str:
    """The label of an algorithm at a particle count (the bare name at the default)."""
    return algorithm if n_particles == DEFAULT.n_particles else f"{algorithm}[N={n_particles}]"


def cell_of(scenario: str, setting: Setting, algorithm: str) -> tuple[str, str]:
    """``(world_key, searcher label)`` of ``algorithm`` at ``setting`` in ``scenario``'s sweeps."""
    return f"{scenario}{setting.world_suffix()}", searcher_label(algorithm, setting.n_particles)


def _unique(settings: Iterable[Setting]) -> list[Setting]:
    seen: list[Setting] = []
    for s in settings:
        if s not in seen:
            seen.append(s)
    return seen


def sweep_files(
    scenario: str,
    sweeps: Sequence[SweepDef],
    episodes: int,
    seed: int,
    *,
    algorithms: Sequence[str] = ALGORITHMS,
    replay: bool = False,
    extra_searchers: Sequence[dict[str, Any]] = (),
    scenario_params: dict[str, Any] | None = None,
    name: str = "muc-osl",
) -> dict[str, dict[str, Any]]:
    """Sweep files covering every setting of ``sweeps`` with every algorithm.

    Returns ``{"": worlds x algorithms, "particles": the default world x algorithms x the
    other particle counts, plus extra_searchers}`` (the second only when needed).

    Parameters
    ----------
    scenario : str
        The base scenario (``muc-osl-3d`` or ``muc-osl-filament-3d``).
    sweeps : sequence of SweepDef
    episodes, seed : int
    algorithms : sequence of str
    replay : bool
        Record each world's flow once per episode and replay it to every searcher.
    extra_searchers : sequence of dict
        More searcher entries (e.g. an ablation) run on the default world only.
    scenario_params : dict, optional
        Overrides applied to every world (e.g. a shorter time limit in tests).
    name : str
        Name of the sweeps.
    """
    settings = _unique(s for sw in sweeps for s in sw.settings())
    worlds = _unique(s.world() for s in settings)
    counts = sorted({s.n_particles for s in settings} - {DEFAULT.n_particles})
    off_default = [s for s in settings if s.n_particles in counts and s.world() != DEFAULT]
    if off_default:
        raise ConfigError(
            "sweeps", f"particle counts are swept on the default world only, not {off_default[0]}"
        )
    common = dict(scenario_params or {})

    def entry(w: Setting) -> dict[str, Any]:
        e: dict[str, Any] = {"name": scenario, "params": {**w.scenario_params(), **common}}
        if w.world_suffix():
            e["label"] = f"{scenario}{w.world_suffix()}"
        return e

    def base(tag: str) -> dict[str, Any]:
        return {"name": f"{name} {tag}", "seed": seed, "episodes": episodes, "replay": replay}

    out = {
        "": {
            **base("worlds"),
            "scenarios": [entry(w) for w in worlds],
            "searchers": [{"name": a} for a in algorithms],
        }
    }
    extra = [
        {
            "name": a,
            "label": searcher_label(a, n),
            "params": {"estimator": {"type": _estimator_type(a), "n_particles": n}},
        }
        for n in counts
        for a in algorithms
    ]
    extra += list(extra_searchers)
    if extra:
        out["particles"] = {**base("particles"), "scenarios": [entry(DEFAULT)], "searchers": extra}
    return out
