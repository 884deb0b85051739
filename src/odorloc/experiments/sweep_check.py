"""The validation pass of a sweep: every cell of the cross product, before the first episode.

:func:`check_sweep` resolves every scenario (built-in name or file, relative to the sweep file),
looks every searcher up in the registry, then builds the scenario of every cell (overrides,
grid values, ``start_index``/``start_set``, searcher parameters) and checks it the way
:func:`odorloc.scenarios.loading.check_scenario` does: every component built and the searcher
reset on the search context. The first problem is raised as one
:class:`~odorloc.core.errors.ConfigError` naming the field *of the sweep file* that causes it
(``scenarios[0].grid.limits.time_limit: no such setting ...``), so ``odorloc batch`` exits before
it opens the store or starts a worker.

Each world (a scenario and its grid point) is built once and every searcher cell of it is
checked against that world, so the pass costs one world build per world key plus one searcher
reset per cell.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from typing import Any, Protocol

from odorloc.core.errors import ConfigError, OdorlocError

__all__ = ["check_names", "check_sweep", "locate", "world_name"]


# What this pass reads of :class:`odorloc.experiments.sweep.SweepSpec` and ``Cell``: the sweep
# module calls this one, so it names their shape instead of importing them.
class SweepSpec(Protocol):
    """The parts of a sweep specification the validation reads."""

    base_dir: str | None
    scenarios: Sequence[Any]
    searchers: Sequence[Any]


class Cell(Protocol):
    """The parts of a sweep cell the validation reads."""

    cell_id: str
    world_key: str
    scenario_index: int
    searcher_index: int
    spec: dict[str, Any]
    swept: dict[str, Any]


def _norm(path: str) -> str:
    """A dotted path with list indices in brackets: ``a.0.b`` -> ``a[0].b``."""
    return re.sub(r"\.(\d+)(?=\.|$)", r"[\1]", path).replace(".[", "[")


def _under(field: str, key: str) -> str | None:
    """The rest of ``field`` below ``key`` ('' if equal), or ``None`` if it is not below it."""
    f, k = _norm(field), _norm(key)
    if f == k:
        return ""
    if f.startswith((f"{k}.", f"{k}[")):
        return f[len(k) :]
    return None


def locate(exc: ConfigError, spec: SweepSpec, cell: Cell) -> ConfigError:
    """``exc`` (raised for the scenario of ``cell``) named by the sweep field that causes it.

    An error of an override names ``scenarios[i].params.KEY`` or ``scenarios[i].grid.KEY``
    (``searchers[j]...`` for searcher parameters); grid values add the cell id. An error that
    no override explains keeps the scenario's field and says which entry and cell it is.
    """
    i, j = cell.scenario_index, cell.searcher_index
    sc, se = spec.scenarios[i], spec.searchers[j]
    field = exc.field
    candidates: list[tuple[str, str, bool]] = []
    for key in sc.params:
        candidates.append((key, f"scenarios[{i}].params.{key}", False))
    for key in sc.grid:
        candidates.append((key, f"scenarios[{i}].grid.{key}", True))
    for key in sc.agent_grid:
        candidates.append((key, f"scenarios[{i}].agent_grid.{key}", True))
    for key in se.params:
        candidates.append((f"searcher.{key}", f"searchers[{j}].params.{key}", False))
    for key in se.grid:
        candidates.append((f"searcher.{key}", f"searchers[{j}].grid.{key}", True))
    # the longest matching key is the most specific
    for key, where, swept in sorted(candidates, key=lambda c: -len(c[0])):
        rest = _under(field, key)
        if rest is not None:
            note = f" (cell {cell.cell_id})" if swept else ""
            return ConfigError(f"{where}{rest}", f"{exc.problem}{note}")
    entry = f"scenarios[{i}] {sc.display!r}"
    if cell.swept:
        entry += f", cell {cell.cell_id}"
    if field == "searcher" or field.startswith("searcher."):
        entry = f"searchers[{j}] {se.display!r} in {entry}"
    return ConfigError(field, f"{exc.problem} ({entry})")


def check_names(spec: SweepSpec) -> None:
    """Every scenario loads (built-in name or file) and every searcher is registered.

    Raises
    ------
    ConfigError
        ``scenarios[i].name`` (unknown name, unreadable file) or the scenario file's own field
        (with the file named), ``searchers[j].name``.
    """
    from odorloc.core import registry
    from odorloc.scenarios.loading import load_scenario, resolve_ref

    for i, sc in enumerate(spec.scenarios):
        try:
            base = load_scenario(sc.name, spec.base_dir)
        except ConfigError as exc:
            if exc.field == "scenario":
                raise ConfigError(f"scenarios[{i}].name", exc.problem) from None
            ref = resolve_ref(sc.name, spec.base_dir)
            raise ConfigError(exc.field, f"{exc.problem} (in {ref}, scenarios[{i}])") from None
        drawn = base.world.source_draw is not None or any(
            k.startswith("world.source_draw") for k in (*sc.params, *sc.grid)
        )
        plume_start = base.world.plume.values.get("start")
        for key in (*sc.params, *sc.grid):
            if key == "world.plume.start":
                plume_start = "swept"
        if spec.replay and (drawn or plume_start in ("initial-hit", "swept")):
            # a replayed flow keeps the sources it was recorded with, not a drawn one
            raise ConfigError(
                "replay",
                f"scenarios[{i}] ({sc.name}) draws its source per episode "
                "(world.source_draw or a lattice plume's initial hit): run it without replay",
            )
        if sc.agent_grid and drawn:
            # drawn sources keep a distance from the starts: the placements would not share
            # one world
            raise ConfigError(f"scenarios[{i}].agent_grid", "cannot be used with world.source_draw")
    _distinct_world_names(spec)
    known = registry.names("searcher")
    for j, se in enumerate(spec.searchers):
        if ":" in se.name:
            registry.entry("searcher", se.name, field=f"searchers[{j}].name")
        elif se.name not in known:
            raise ConfigError(
                f"searchers[{j}].name",
                f"unknown searcher {se.name!r} (known: {', '.join(known)})",
            )


def world_name(entry: Any, base_dir: str | None = None) -> str:
    """The name a sweep's scenario entry keys its seeds by: its ``label`` if it has one, else
    the scenario's own ``name`` (a built-in name, or the ``name`` field of a file), never the
    path as typed, so ``iv.yaml``, ``./iv.yaml`` and ``/abs/iv.yaml`` give the same episodes
    (and those of the built-in scenario the file was printed from).

    ``entry`` is a sweep's scenario entry (``name``, ``label``). A scenario that cannot be
    loaded keys by the entry's ``name``; :func:`check_names` refuses it before any episode runs.
    """
    from odorloc.scenarios.loading import scenario_name

    if entry.label:
        return str(entry.label)
    try:
        return scenario_name(entry.name, base_dir)
    except OdorlocError:
        return str(entry.name)


def _distinct_world_names(spec: SweepSpec) -> None:
    """Two scenario entries must not key their seeds (and recorded flows) by the same name:
    two files holding the same ``name``, or a file and the built-in scenario it names."""
    seen: dict[str, int] = {}
    for i, sc in enumerate(spec.scenarios):
        key = world_name(sc, spec.base_dir)
        if key in seen:
            raise ConfigError(
                f"scenarios[{i}].label",
                f"{sc.name!r} is the scenario {key!r}, as scenarios[{seen[key]}] is: both "
                "would share their seeds and flows; give one a distinct 'label'",
            )
        seen[key] = i


def check_sweep(spec: SweepSpec, cells: Iterable[Cell]) -> int:
    """Validate every cell of ``spec`` (see the module docstring).

    Parameters
    ----------
    spec : SweepSpec
    cells : iterable of Cell
        The sweep's cells in order (:func:`odorloc.experiments.sweep.iter_cells`), generated
        lazily.

    Returns
    -------
    int
        The number of cells checked.

    Raises
    ------
    ConfigError
        The first problem, named by its field in the sweep file.
    """
    from odorloc.experiments.runner import cell_scenario
    from odorloc.scenarios.loading import check_scenario

    check_names(spec)
    world_key: str | None = None
    world: Any = None
    n = 0
    for cell in cells:
        if cell.world_key != world_key:
            world_key, world = cell.world_key, None
        try:
            sc = cell_scenario(cell.spec)
            world = check_scenario(sc, world)
        except ConfigError as exc:
            raise locate(exc, spec, cell) from None
        n += 1
    return n
