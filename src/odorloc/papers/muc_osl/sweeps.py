"""The four sweeps of the multi-UAV paper (Sect. VI.2, Figs. 4-7) as settings and sweep files.

A :class:`Setting` is one point; the default is the paper's (Table 1): 100 x 60 x 30 m, source
[10, 30, 25], 3 UAVs, N = 100, and a 30 m radius (Fig. 6's largest, where results level off).
Each sweep changes one: the area (Fig. 4), 1-8 UAVs (Fig. 5), the radius 0-30 m with 4 UAVs
(Fig. 6), the particle count 20-220 (Fig. 7). The source keeps the default's place relative to
the area, ``(0.1 L_x, 0.5 L_y, 0.833 L_z)``; the UAVs start on the lower downwind edge
(:func:`uav_starts`). A setting's world is a
:class:`~odorloc.experiments.variants.WorldVariant` of ``muc-osl-3d``; particle counts are
searcher parameters on the default world only (:func:`sweep_files`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from odorloc.core.registry import make_params
from odorloc.experiments.variants import Sweep, WorldVariant, variant_sweeps
from odorloc.scenarios.placement import edge_starts

Area = tuple[float, float, float]
DEFAULT_AREA: Area = (100.0, 60.0, 30.0)
DEFAULT_SOURCE = (10.0, 30.0, 25.0)
AREAS: tuple[Area, ...] = (
    (60.0, 60.0, 30.0),
    (100.0, 60.0, 30.0),
    (100.0, 100.0, 50.0),
    (100.0, 200.0, 50.0),
)
#: The paper's four algorithms (reversible PUGL moves where Col-PF is used).
ALGORITHMS = ("muc-osl", "col-inf", "col-pf", "adap-pp")
#: Col-PF's PUGL moves as printed, run at every point beside the four.
PRINTED = ("muc-osl-printed", "col-pf-printed")
ROWS = (*ALGORITHMS, *PRINTED)
#: MUC-OSL without eq. 16: an ablation at the default point of each world (:func:`sweep_files`
#: with ``extra_searchers``) and at every other point of a world (:func:`ablation_files`).
NO_ENV_PU = "muc-osl-no-env-pu"
NO_ENV_PU_PARAMS = {"estimator": {"type": "col-pf", "env_pu": "off"}}


#: The paper's three starts (Sect. VI.2, Fig. 3), metres; more UAVs continue along that edge.
PAPER_STARTS = ((10.0, 10.0, 5.0), (30.0, 10.0, 5.0), (60.0, 10.0, 5.0))


def uav_starts(n: int, area: Sequence[float] = DEFAULT_AREA) -> list[list[float]]:
    """Starts of ``n`` UAVs in ``area``: the paper's three, then every 10 m along their edge
    (:func:`~odorloc.scenarios.placement.edge_starts`)."""
    return edge_starts(
        n, [p[0] for p in PAPER_STARTS], 10.0, area[0], 10.0, 5.0, depth=area[1], height=area[2]
    )


def source_position(area: Sequence[float]) -> tuple[float, float, float]:
    """The source in ``area`` (metres): the default source at the same fraction of each side."""
    return tuple(  # type: ignore[return-value]
        round(s * a / d, 6) for s, a, d in zip(DEFAULT_SOURCE, area, DEFAULT_AREA, strict=True)
    )


def _area_text(area: Sequence[float]) -> str:
    return "x".join(f"{v:g}" for v in area)


@dataclass(frozen=True)
class Setting:
    """One point: ``area`` (m), ``n_uavs``, communication ``radius`` (m), ``n_particles``."""

    area: Area = DEFAULT_AREA
    n_uavs: int = 3
    radius: float = 30.0
    n_particles: int = 100

    def _changes(self) -> list[tuple[str, str]]:
        """What differs from the default, as (suffix part, short name)."""
        d, out = DEFAULT, []
        if self.area != d.area:
            out.append((f"area={_area_text(self.area)}", _area_text(self.area)))
        if self.radius != d.radius:
            out.append((f"radius={self.radius:g}", f"r={self.radius:g}"))
        if self.n_uavs != d.n_uavs:
            out.append((f"uavs={self.n_uavs}", f"{self.n_uavs} UAVs"))
        return out

    def world_suffix(self) -> str:
        """What sets the world apart from the default, ``""`` or e.g. ``"[radius=0,uavs=4]"``."""
        parts = [a for a, _ in self._changes()]
        return f"[{','.join(parts)}]" if parts else ""

    def world(self) -> WorldVariant:
        """The world of this setting (dotted overrides of ``muc-osl-3d``)."""
        out: dict[str, Any] = {}
        if self.area != DEFAULT_AREA:
            out["world.arena.upper"] = list(self.area)
            out["world.sources.0.position"] = list(source_position(self.area))
        if self.area != DEFAULT_AREA or self.n_uavs != DEFAULT.n_uavs:
            out["agents.starts"] = uav_starts(self.n_uavs, self.area)
        if self.radius != DEFAULT.radius:
            out["agents.comm_radius"] = float(self.radius)
        return WorldVariant(self.world_suffix(), out)

    def where(self) -> str:
        """A short name: ``"default"`` or what differs, e.g. ``"4 UAVs, r=0"``."""
        parts = [b for _, b in self._changes()]
        parts += [f"N={self.n_particles}"] if self.n_particles != DEFAULT.n_particles else []
        return ", ".join(parts) or "default"


DEFAULT = Setting()


SWEEPS: tuple[Sweep, ...] = (
    Sweep("area", "Fig. 4", "search area (m)", AREAS, DEFAULT, "area"),
    Sweep("uavs", "Fig. 5", "number of UAVs", tuple(range(1, 9)), DEFAULT, "n_uavs"),
    Sweep(
        "radius",
        "Fig. 6",
        "communication radius (m)",
        tuple(float(r) for r in range(0, 31, 5)),
        Setting(n_uavs=4),
        "radius",
    ),
    Sweep("particles", "Fig. 7", "particles N", tuple(range(20, 221, 20)), DEFAULT, "n_particles"),
)

#: Fig. 9's settings in the filament world: the ends, the default and a middle value of each.
FIG9_VALUES: dict[str, tuple[Any, ...]] = {
    "area": AREAS,
    "uavs": (1, 3, 5, 8),
    "radius": (0.0, 10.0, 20.0, 30.0),
    "particles": (20, 100, 160, 220),
}


def fig9_settings() -> tuple[Sweep, ...]:
    """The four sweeps restricted to :data:`FIG9_VALUES`."""
    return tuple(replace(s, values=FIG9_VALUES[s.key]) for s in SWEEPS)


def searcher_label(algorithm: str, n_particles: int) -> str:
    """The label of an algorithm at a particle count (the bare name at the default)."""
    return algorithm if n_particles == DEFAULT.n_particles else f"{algorithm}[N={n_particles}]"


def cell_of(scenario: str, setting: Setting, algorithm: str) -> tuple[str, str]:
    """``(world_key, searcher label)`` of ``algorithm`` at ``setting`` in ``scenario``'s sweeps."""
    return f"{scenario}{setting.world_suffix()}", searcher_label(algorithm, setting.n_particles)


def _with_count(algorithm: str, n: int, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """The preset's own estimator (its type and every setting), changed by ``params`` (a
    searcher's parameters that set only its estimator), with ``n`` particles."""
    ref = make_params("searcher", algorithm, params or {}).estimator  # type: ignore[attr-defined]
    return {"estimator": {"type": ref.type, **ref.values, "n_particles": n}}


def sweep_files(
    scenario: str,
    sweeps: Sequence[Sweep],
    episodes: int,
    seed: int,
    *,
    algorithms: Sequence[str] = ROWS,
    replay: bool = False,
    extra_searchers: Sequence[dict[str, Any]] = (),
    scenario_params: dict[str, Any] | None = None,
    name: str = "muc-osl",
) -> dict[str, dict[str, Any]]:
    """Sweep files covering every setting of ``sweeps`` with every algorithm:
    ``{"": worlds x algorithms, "particles": the default world x the other particle counts,
    plus extra_searchers}``.

    Raises :class:`~odorloc.core.errors.ConfigError` for a particle count off the default
    world (it would cross every world).
    """
    from odorloc.core.errors import ConfigError

    settings = list(dict.fromkeys(s for sw in sweeps for s in sw.settings()))
    counts = sorted({s.n_particles for s in settings} - {DEFAULT.n_particles})
    off = [s for s in settings if s.n_particles in counts and s.world() != DEFAULT.world()]
    if off:
        raise ConfigError(
            "sweeps", f"particle counts are swept on the default world only, not {off[0]}"
        )
    extra = [
        {"name": a, "label": searcher_label(a, n), "params": _with_count(a, n)}
        for n in counts
        for a in algorithms
    ]
    return variant_sweeps(
        scenario,
        [s.world() for s in settings],
        [{"name": a} for a in algorithms],
        episodes,
        seed,
        base_searchers=[*extra, *extra_searchers],
        base_part="particles",
        replay=replay,
        common=scenario_params,
        name=name,
    )


def ablation_files(
    scenario: str,
    sweeps: Sequence[Sweep],
    episodes: int,
    seed: int,
    *,
    algorithm: str = "muc-osl",
    label: str = NO_ENV_PU,
    params: dict[str, Any] | None = None,
    replay: bool = False,
    scenario_params: dict[str, Any] | None = None,
    name: str = "muc-osl",
) -> dict[str, dict[str, Any]]:
    """Sweep files running one more variant (by default MUC-OSL without eq. 16) at every
    setting of ``sweeps`` but the default point: ``{"ablation": the other worlds,
    "ablation-particles": the default world at the other particle counts}`` (a part with
    nothing to run is left out).

    The default point is left to :func:`sweep_files`' ``extra_searchers``, so that a study
    run before the ablation covered the sweeps keeps its stores and only these parts run. Its
    episodes share the world keys of :func:`sweep_files`' (common random numbers): episode
    ``i`` of the variant at a setting faces the world of episode ``i`` of every algorithm there.
    """
    params = NO_ENV_PU_PARAMS if params is None else params
    settings = list(dict.fromkeys(s for sw in sweeps for s in sw.settings()))
    worlds = [s.world() for s in settings if s.world() != DEFAULT.world()]
    counts = sorted(
        {s.n_particles for s in settings if s.world() == DEFAULT.world()} - {DEFAULT.n_particles}
    )
    others = [
        {
            "name": algorithm,
            "label": searcher_label(label, n),
            "params": _with_count(algorithm, n, params),
        }
        for n in counts
    ]
    files = variant_sweeps(
        scenario,
        worlds,
        [{"name": algorithm, "label": label, "params": params}],
        episodes,
        seed,
        base_searchers=others,
        base_part="particles",
        replay=replay,
        common=scenario_params,
        name=f"{name} ablation",
    )
    out = {"ablation": files[""]} if worlds else {}
    if "particles" in files:
        out["ablation-particles"] = files["particles"]
    return out
