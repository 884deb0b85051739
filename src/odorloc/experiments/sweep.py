"""Monte Carlo sweeps: sweep files, their expansion into episode tasks, and the sweep runner.

A sweep file (YAML) crosses scenarios x searchers x parameter grids x episodes under one root
seed::

    name: pf-vs-gradient            # free text, does not affect results
    seed: 20240611                  # root of every random stream of the sweep
    episodes: 50                    # episodes per cell (initial count in adaptive mode)
    keep_arrays: false              # store per-episode trajectories/beliefs (npz blobs)
    keep_episodes: [0]              # ... or only for these episode indices
    replay: false                   # record each world's flow once, replay it to every searcher
    scenarios:
      - name: indoor-pf-entropy     # built-in name or path to a scenario file
        params: {time_limit: 600}   # fixed overrides
        grid: {start_index: [2, 4]} # swept overrides (cartesian product)
        agent_grid: {}              # swept agent placements that share the flow (see below)
    searchers:
      - name: pf-entropy
        grid: {n_particles: [500, 1000]}
      - name: gradient-bionic
    adaptive:                       # optional: add episodes until the interval is narrow
      metric: success               # success | search_time
      target_width: 0.2             # full width of the 95 % interval
      batch: 25
      max_episodes: 400

Common random numbers
---------------------
Every episode gets two seeds derived from the root :class:`numpy.random.SeedSequence`: the
``world_seed`` depends only on (root seed, world key, episode index) where the world key is the
scenario's name (the entry's ``label`` if it has one, else the scenario's own ``name`` field,
never the path a file was given by: :func:`~odorloc.experiments.sweep_check.world_name`) and its
swept overrides, and the ``agent_seed`` on (root seed, world key, episode index) through a
separate stream. Neither depends on the searcher, so episode ``i`` of every searcher in a
scenario faces the same world realisation (wind, plume, start pose) and differences between
searchers can be paired episode by episode. Because the seeds travel inside the task, results do not
depend on the backend, the number of workers or the order of execution.

Agent placements that share the flow
------------------------------------
A scenario's ``agent_grid`` sweeps settings that only place the agents (``start_set``,
``start_index``, ``agents.*``). Its cells keep their own world key (the cell id, and the cells
paired in comparisons), but share the *flow key* of the scenario's grid point: the world seeds
come from the flow key, so every placement of episode ``i`` faces the same wind and plume, and
with ``replay: true`` one recorded flow serves them all.

Record once, replay many
------------------------
With ``replay: true`` the flow (wind and plume) of each flow key and episode is recorded once
(:func:`~odorloc.engine.replay.record_flow`) and replayed to every cell of that flow key, in one
work item (:func:`~odorloc.experiments.runner.replay_group`). Every searcher then faces
exactly the same plume frames, which a live plume gives only when it does not depend on the agents;
for expensive plumes (filaments, Eulerian grids) it also saves simulating the flow once per
searcher.

Config hash
-----------
:func:`config_hash` is the SHA-256 of the canonical JSON of everything that changes the result of
an episode or names it in the store: root seed, scenarios (and the bytes of scenario files given
by path), searchers, overrides, grids, labels and the package version. The episode count, the
adaptive settings, ``keep_arrays`` and the name are left out on purpose: raising the episode
count of a finished sweep then simply adds episodes to the same store.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import pydantic
from pydantic import Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from odorloc.core.errors import ConfigError, OdorlocError, format_validation_error
from odorloc.core.loading import load_yaml_mapping
from odorloc.core.params import Params, Seed
from odorloc.core.seeds import episode_seeds

#: Overrides that only place agents (allowed in a scenario's ``agent_grid``, with ``agents.*``).
AGENT_KEYS = ("start_set", "start_index")

EpisodeFn = Callable[["EpisodeTask"], dict]
"""An episode function: runs one task and returns one row dict (see :mod:`.store`)."""

_SCALAR = (str, int, float, bool, type(None))

MAX_EPISODES = 1_000_000
"""Most episodes per cell (``episodes``, ``adaptive.max_episodes``)."""
MAX_CELLS = 10_000
"""Most cells of a sweep's cross product (every one is validated before the first episode)."""


def _check_value(v: Any, where: str) -> Any:
    """Reject values that cannot be written canonically to JSON (so the hash is well defined);
    :class:`ConfigError` naming ``where`` (the override key)."""
    if isinstance(v, float) and not math.isfinite(v):
        raise ConfigError(where, "must be finite")
    if isinstance(v, _SCALAR):
        return v
    if isinstance(v, list | tuple):
        return [_check_value(x, where) for x in v]
    if isinstance(v, dict):
        return {str(k): _check_value(x, where) for k, x in v.items()}
    raise ConfigError(where, f"unsupported value type {type(v).__name__}")


class ComponentSpec(Params):
    """One scenario or searcher entry of a sweep file.

    Parameters
    ----------
    name : str
        Registered name (or, for scenarios, a path to a scenario file).
    params : dict
        Fixed parameter overrides.
    grid : dict of list
        Swept parameter overrides; the cartesian product of the lists is taken.
    agent_grid : dict of list
        Swept agent placements (scenarios only: ``start_set``, ``start_index``, ``agents.*``),
        crossed with ``grid``; their cells share the flow of their ``grid`` point (module
        docstring).
    label : str, optional
        Short display name used in cell ids and reports (defaults to ``name``).
    """

    name: str = Field(min_length=1)
    params: dict[str, Any] = Field(default_factory=dict)
    grid: dict[str, list[Any]] = Field(default_factory=dict)
    agent_grid: dict[str, list[Any]] = Field(default_factory=dict)
    label: str | None = None

    @field_validator("params")
    @classmethod
    def _params_ok(cls, v: dict[str, Any]) -> dict[str, Any]:
        return {str(k): _check_value(x, str(k)) for k, x in v.items()}

    @field_validator("agent_grid")
    @classmethod
    def _agent_grid_ok(cls, v: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key in v:
            if key not in AGENT_KEYS and not key.startswith("agents."):
                raise ValueError(
                    f"{key!r} is not an agent placement (start_set, start_index, agents.*); "
                    "put settings that change the world in 'grid'"
                )
        return cls._grid_ok(v)

    @field_validator("grid")
    @classmethod
    def _grid_ok(cls, v: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in v.items():
            if len(values) == 0:
                raise ConfigError(key, "has no values")
            _check_value(values, key)
            canon = [json.dumps(x, sort_keys=True) for x in values]
            if len(set(canon)) != len(canon):
                raise ConfigError(key, "repeats a value")
        return v

    @model_validator(mode="after")
    def _no_overlap(self) -> ComponentSpec:
        for a, b, field, what in (
            (self.params, self.grid, "grid", "is also a fixed parameter (params)"),
            (self.params, self.agent_grid, "agent_grid", "is also a fixed parameter (params)"),
            (self.grid, self.agent_grid, "agent_grid", "is both a grid and an agent_grid axis"),
        ):
            both = sorted(set(a) & set(b))
            if both:
                raise ConfigError(f"{field}.{both[0]}", what)
        return self

    @property
    def display(self) -> str:
        """Label used in cell ids."""
        return self.label or self.name


class AdaptiveSpec(Params):
    """Adaptive episode count: add batches until the interval is narrow enough.

    Parameters
    ----------
    metric : {"success", "search_time"}
        ``success``: width of the Wilson interval of the success rate (a fraction);
        ``search_time``: width of the bootstrap interval of the mean search time, seconds.
    target_width : float
        Stop adding episodes to a cell once the full interval width is <= this.
    batch : int
        Episodes added per round to a cell that is not yet narrow enough.
    max_episodes : int
        Cap on the episodes of a cell.
    level : float
        Confidence level of the interval.
    extend_together : bool
        If any cell of a world key (scenario + overrides) needs more episodes, extend every
        searcher of that world key, so that paired comparisons keep all their pairs.
    """

    metric: Literal["success", "search_time"] = "success"
    target_width: float = Field(gt=0)
    batch: int = Field(default=20, ge=1, le=MAX_EPISODES)
    max_episodes: int = Field(default=1000, ge=1, le=MAX_EPISODES)
    level: float = Field(default=0.95, gt=0, lt=1)
    extend_together: bool = True


class SweepSpec(Params):
    """A validated sweep file (see the module docstring for the YAML layout).

    ``episodes`` lies in ``[1, MAX_EPISODES]`` and the cross product of scenarios, searchers
    and their grids may have at most :data:`MAX_CELLS` cells.
    """

    name: str = "sweep"
    seed: Seed
    episodes: int = Field(ge=1, le=MAX_EPISODES)
    scenarios: list[ComponentSpec] = Field(min_length=1)
    searchers: list[ComponentSpec] = Field(min_length=1)
    keep_arrays: bool = False
    keep_episodes: list[int] = Field(default_factory=list, max_length=10_000)
    replay: bool = False
    adaptive: AdaptiveSpec | None = None
    base_dir: str | None = Field(default=None, exclude=True)
    """Directory that relative scenario paths are resolved against (the sweep file's folder)."""

    @field_validator("keep_episodes")
    @classmethod
    def _episode_indices(cls, v: list[int]) -> list[int]:
        for e in v:
            if not 0 <= e < MAX_EPISODES:
                raise ValueError(f"episode index {e} is not in [0, {MAX_EPISODES})")
        return v

    @model_validator(mode="after")
    def _labels_and_size(self) -> SweepSpec:
        for j, se in enumerate(self.searchers):
            if se.agent_grid:
                raise _field_error(
                    f"searchers[{j}].agent_grid", "only scenarios take an agent_grid"
                )
        if self.adaptive is not None and self.adaptive.max_episodes < self.episodes:
            raise _field_error(
                "adaptive.max_episodes",
                f"is {self.adaptive.max_episodes}, below the {self.episodes} episodes every "
                "cell starts with",
            )
        for fam in ("scenarios", "searchers"):
            labels = [c.display for c in getattr(self, fam)]
            for i, lab in enumerate(labels):
                if lab in labels[:i]:
                    raise _field_error(
                        f"{fam}[{i}].label", f"{lab!r} is used twice (give a distinct 'label')"
                    )

        def points(c: ComponentSpec) -> int:
            return math.prod(len(v) for v in c.grid.values())

        n = sum(points(c) for c in self.scenarios) * sum(points(c) for c in self.searchers)
        if n > MAX_CELLS:
            fam, i = max(
                ((f, i) for f in ("scenarios", "searchers") for i in range(len(getattr(self, f)))),
                key=lambda fi: points(getattr(self, fi[0])[fi[1]]),
            )
            raise _field_error(f"{fam}[{i}].grid", f"the grids make {n} cells; at most {MAX_CELLS}")
        # cell ids are labels and points written out: two cells must not share one (the store
        # keys episodes by it, and the cells would share their worlds)
        seen: dict[str, str] = {}
        for i, sc in enumerate(self.scenarios):
            for sp in _grid_points({**sc.grid, **sc.agent_grid}):
                for j, se in enumerate(self.searchers):
                    for ep in _grid_points(se.grid):
                        cid = f"{sc.display}{_fmt_point(sp)}/{se.display}{_fmt_point(ep)}"
                        where = f"scenarios[{i}] x searchers[{j}]"
                        if cid in seen:
                            raise _field_error(
                                f"scenarios[{i}].label",
                                f"{where} makes the cell {cid!r} again ({seen[cid]}): "
                                "give a distinct 'label'",
                            )
                        seen[cid] = where
        return self


def _field_error(field: str, problem: str) -> PydanticCustomError:
    """A validation error that names ``field`` (see :func:`format_validation_error`)."""
    return PydanticCustomError("component", "{problem}", {"field": field, "problem": problem})


# ----------------------------------------------------------------------------- loading


def load_sweep(source: str | Path | Mapping[str, Any] | SweepSpec) -> SweepSpec:
    """Read and validate a sweep file, a dict or an existing :class:`SweepSpec`.

    Files are read through :mod:`odorloc.core.loading` (size, encoding, YAML limits,
    duplicate keys); relative scenario paths are relative to the sweep file's folder.

    Raises
    ------
    ConfigError
        One line naming the first invalid field (``searchers[1].grid: ...``).
    """
    if isinstance(source, SweepSpec):
        return source
    base_dir = None
    if isinstance(source, str | Path):
        path = Path(source)
        data: Any = load_yaml_mapping(path, "sweep")
        base_dir = str(path.absolute().parent)
    elif isinstance(source, Mapping):
        data = dict(source)
    else:
        raise ConfigError("sweep", f"expected a file or a mapping, got {type(source).__name__}")
    if base_dir is not None and "base_dir" not in data:
        data["base_dir"] = base_dir
    try:
        return SweepSpec.model_validate(data)
    except pydantic.ValidationError as err:
        line = format_validation_error(err, model=SweepSpec)
        fld, _, problem = line.partition(": ")
        fld = fld.replace(".[", "[")
        raise ConfigError(fld, problem) from None


# ----------------------------------------------------------------------------- hashing


def _canon(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def _scenario_file_digest(name: str, base_dir: str | None) -> str | None:
    """SHA-256 of a scenario given as a file path (so editing the file changes the hash)."""
    from odorloc.scenarios.loading import resolve_ref

    p = Path(resolve_ref(name, base_dir))
    if not p.is_file():
        return None
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _file_digest(p: Path) -> str:
    """SHA-256 of a file's bytes, or of a folder's listing (relative names and sizes: a
    simulation folder may hold gigabytes)."""
    h = hashlib.sha256()
    if p.is_file():
        h.update(p.read_bytes())
    else:
        for f in sorted(p.rglob("*"))[:100_000]:
            if f.is_file():
                h.update(f"{f.relative_to(p).as_posix()}\0{f.stat().st_size}\n".encode())
    return h.hexdigest()


def _referenced_files(obj: Any, base_dir: str | None) -> dict[str, str]:
    """Digests of the files and folders that strings in ``obj`` name (a scenario's obstacle map
    or recorded plume, a policy's weights), so that editing one changes the hash."""
    out: dict[str, str] = {}

    def walk(v: Any) -> None:
        if isinstance(v, dict):
            for x in v.values():
                walk(x)
        elif isinstance(v, list | tuple):
            for x in v:
                walk(x)
        elif isinstance(v, str) and 0 < len(v) < 4096 and ("/" in v or "." in v):
            for cand in (Path(v), Path(base_dir or ".") / v):
                try:
                    found = cand.exists()
                except (OSError, ValueError):  # prose, not a path (too long, a NUL byte)
                    found = False
                if found:
                    out[v] = _file_digest(cand)
                    break

    walk(obj)
    return out


def hashed_content(spec: SweepSpec) -> dict[str, Any]:
    """The part of the sweep that determines every episode's result (what the hash covers)."""
    from odorloc import __version__

    scen = []
    for s in spec.scenarios:
        d = s.model_dump()
        if not d["agent_grid"]:
            del d["agent_grid"]  # sweeps without one keep the hash they always had
        d["file_sha256"] = _scenario_file_digest(s.name, spec.base_dir)
        try:
            from odorloc.scenarios.loading import load_scenario

            data = [load_scenario(s.name, spec.base_dir).to_dict(), s.params, s.grid]
        except OdorlocError:  # refused by name later (check_names)
            data = [s.params, s.grid]
        files = _referenced_files(data, spec.base_dir)
        if files:
            d["files_sha256"] = files  # sweeps without such files keep the hash they had
        scen.append(d)
    searchers = []
    for se in spec.searchers:
        d = se.model_dump()
        files = _referenced_files([se.params, se.grid], spec.base_dir)
        if files:
            d["files_sha256"] = files
        searchers.append(d)
    out = {
        "seed": spec.seed,
        "scenarios": scen,
        "searchers": searchers,
        "odorloc": __version__,
    }
    if spec.replay:
        out["replay"] = True
    return out


def config_hash(spec: SweepSpec) -> str:
    """Stable hex digest (16 hex digits) of what affects results; see the module docstring."""
    return hashlib.sha256(_canon(hashed_content(spec)).encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------- cells and tasks


@dataclass(frozen=True)
class Cell:
    """One (scenario, overrides, searcher, overrides) combination of a sweep.

    Attributes
    ----------
    index : int
        Position in the deterministic expansion order (used to sort results).
    cell_id : str
        Readable unique id, e.g. ``"room[start=2]/pf[n=500]"``.
    world_key : str
        Scenario part of the id; cells sharing it are paired (common random numbers).
    spec : dict
        ``{"scenario", "scenario_params", "searcher", "searcher_params"}`` with the fixed and
        swept overrides merged; ``scenario`` is a built-in name or an absolute file path.
    swept : dict
        Only the swept overrides, keys prefixed ``scenario.`` / ``searcher.``.
    scenario_index, searcher_index : int
        Which entries of the sweep's ``scenarios`` and ``searchers`` the cell comes from.
    flow_key : str
        Key of the world seeds and of the recorded flow: the world key without the
        ``agent_grid`` axes (equal to it without them).
    """

    index: int
    cell_id: str
    world_key: str
    spec: dict[str, Any]
    swept: dict[str, Any]
    scenario_index: int = 0
    searcher_index: int = 0
    flow_key: str = ""

    def __post_init__(self) -> None:
        if not self.flow_key:
            object.__setattr__(self, "flow_key", self.world_key)


def _fmt_point(point: dict[str, Any]) -> str:
    if not point:
        return ""
    inner = ",".join(f"{k}={_canon(v)}" for k, v in sorted(point.items()))
    return f"[{inner}]"


def _grid_points(grid: dict[str, list[Any]]) -> Iterator[dict[str, Any]]:
    keys = sorted(grid)
    for combo in itertools.product(*(grid[k] for k in keys)):
        yield dict(zip(keys, combo, strict=True))


def iter_cells(spec: SweepSpec) -> Iterator[Cell]:
    """The cells one by one, in deterministic order: scenarios, their grid, their agent grid,
    searchers, their grid. Scenario file paths are made absolute (relative to the sweep file's
    folder), so an episode opens the same file whatever the current folder of the process
    running it."""
    from odorloc.experiments.sweep_check import world_name
    from odorloc.scenarios.loading import resolve_ref

    index = 0
    for i, sc in enumerate(spec.scenarios):
        ref = resolve_ref(sc.name, spec.base_dir)
        seed_name = world_name(sc, spec.base_dir)
        for gp in _grid_points(sc.grid):
            flow_key = f"{seed_name}{_fmt_point(gp)}"
            for ap in _grid_points(sc.agent_grid):
                sp = {**gp, **ap}
                world_key = f"{sc.display}{_fmt_point(sp)}"
                for j, se in enumerate(spec.searchers):
                    for ep in _grid_points(se.grid):
                        cell_id = f"{world_key}/{se.display}{_fmt_point(ep)}"
                        swept = {f"scenario.{k}": v for k, v in sp.items()}
                        swept.update({f"searcher.{k}": v for k, v in ep.items()})
                        yield Cell(
                            index=index,
                            cell_id=cell_id,
                            world_key=world_key,
                            spec={
                                "scenario": ref,
                                "scenario_label": sc.display,
                                "scenario_params": {**sc.params, **sp},
                                "searcher": se.name,
                                "searcher_label": se.display,
                                "searcher_params": {**se.params, **ep},
                                "swept": swept,
                            },
                            swept=swept,
                            scenario_index=i,
                            searcher_index=j,
                            flow_key=flow_key,
                        )
                        index += 1


def expand_cells(spec: SweepSpec) -> list[Cell]:
    """All cells in deterministic order (see :func:`iter_cells`)."""
    return list(iter_cells(spec))


@dataclass(frozen=True)
class EpisodeTask:
    """Everything a worker needs to run one episode; picklable and self-contained.

    Attributes
    ----------
    cell_id : str
        Id of the cell (see :class:`Cell`).
    cell : dict
        ``{"scenario": name, "scenario_params": {...}, "searcher": name,
        "searcher_params": {...}, "scenario_label", "searcher_label", "swept": {...}}``.
    episode : int
        Episode index within the cell (0-based).
    seed : int
        Root seed of the sweep.
    world_seed : int
        Seed of the world realisation (wind, plume, start pose); shared by every searcher.
        Use ``np.random.default_rng(task.world_seed)``.
    agent_seed : int
        Seed of the searcher's own randomness; also searcher-independent.
    config_hash : str
        Hash of the sweep the task belongs to.
    cell_index : int
        Position of the cell in the sweep's expansion order.
    world_key : str
        Scenario part of ``cell_id`` (episodes with equal ``world_key`` and index are paired).
    flow_key : str
        Key of the world seeds and of the recorded flow (``world_key`` unless the scenario has
        an ``agent_grid``).
    keep_arrays : bool
        Whether the sweep stores per-episode arrays; an episode function may skip recording
        them when ``False`` (the harness drops them anyway).
    """

    cell_id: str
    cell: dict[str, Any]
    episode: int
    seed: int
    world_seed: int
    agent_seed: int
    config_hash: str
    cell_index: int = 0
    world_key: str = ""
    keep_arrays: bool = False
    flow_key: str = ""

    def __post_init__(self) -> None:
        if not self.flow_key:
            object.__setattr__(self, "flow_key", self.world_key)


def make_task(spec: SweepSpec, cell: Cell, episode: int, chash: str | None = None) -> EpisodeTask:
    """The task of episode ``episode`` of ``cell``."""
    ws, as_ = episode_seeds(spec.seed, cell.flow_key, episode)
    return EpisodeTask(
        cell_id=cell.cell_id,
        cell=cell.spec,
        episode=episode,
        seed=spec.seed,
        world_seed=ws,
        agent_seed=as_,
        config_hash=chash or config_hash(spec),
        cell_index=cell.index,
        world_key=cell.world_key,
        keep_arrays=spec.keep_arrays or episode in spec.keep_episodes,
        flow_key=cell.flow_key,
    )


def expand_tasks(
    spec: SweepSpec, episodes: int | None = None, cells: Sequence[Cell] | None = None
) -> list[EpisodeTask]:
    """All tasks of ``episodes`` (default ``spec.episodes``) per cell, ordered by cell, episode."""
    n = spec.episodes if episodes is None else episodes
    chash = config_hash(spec)
    cells = expand_cells(spec) if cells is None else cells
    return [make_task(spec, c, e, chash) for c in cells for e in range(n)]


# ----------------------------------------------------------------------------- validation hook


def validate_names(spec: SweepSpec) -> None:
    """Check scenario and searcher names (see :func:`.sweep_check.check_names`).

    Raises
    ------
    ConfigError
        Naming ``scenarios[i].name`` / ``searchers[i].name``.
    """
    from odorloc.experiments.sweep_check import check_names

    check_names(spec)


def iter_pending(
    spec: SweepSpec,
    cells: Sequence[Cell],
    targets: Mapping[str, int],
    done: set[tuple[str, int]],
    chash: str,
) -> Iterator[EpisodeTask]:
    """The tasks not yet stored, generated one by one (ordered by cell, then episode)."""
    for c in cells:
        for e in range(targets[c.cell_id]):
            if (c.cell_id, e) not in done:
                yield make_task(spec, c, e, chash)


def iter_pending_groups(
    spec: SweepSpec,
    cells: Sequence[Cell],
    targets: Mapping[str, int],
    done: set[tuple[str, int]],
    chash: str,
) -> Iterator[list[EpisodeTask]]:
    """The pending tasks of a replay sweep as flow groups (one flow key and episode each: all
    cells replaying one recorded flow), generated one by one (ordered by flow key, then
    episode)."""
    by_world: dict[str, list[Cell]] = {}
    for c in cells:
        by_world.setdefault(c.flow_key, []).append(c)
    for group_cells in by_world.values():
        n = max(targets[c.cell_id] for c in group_cells)
        for e in range(n):
            group = [
                make_task(spec, c, e, chash)
                for c in group_cells
                if e < targets[c.cell_id] and (c.cell_id, e) not in done
            ]
            if group:
                yield group


def count_pending(targets: Mapping[str, int], done: set[tuple[str, int]]) -> int:
    """How many of the ``targets`` episodes are not in ``done``."""
    have = sum(1 for cid, e in done if e < targets.get(cid, 0))
    return sum(targets.values()) - have


# ----------------------------------------------------------------------------- runner


def default_episode_fn() -> EpisodeFn:
    """The package's real episode function, imported only when needed."""
    try:
        from odorloc.experiments.runner import run_task  # type: ignore[import-not-found]
    except ImportError as exc:
        raise ConfigError(
            "episode_fn", f"odorloc.experiments.runner.run_task is not available ({exc})"
        ) from None
    return run_task


def _cells_needing_more(
    spec: SweepSpec, cells: Sequence[Cell], counts: dict[str, int], df: Any
) -> dict[str, int]:
    """Adaptive mode: target episode count of each cell for the next round."""
    from odorloc.experiments import stats

    ad = spec.adaptive
    assert ad is not None
    need: dict[str, int] = {}
    for c in cells:
        n = counts.get(c.cell_id, 0)
        if n >= ad.max_episodes:
            continue
        # only the first n episodes count, so a resumed run replays the same decisions even if
        # the store already holds episodes of a later round
        sub = df[(df["cell_id"] == c.cell_id) & (df["episode"] < n)] if len(df) else df
        width = stats.interval_width(sub, ad.metric, level=ad.level, seed=spec.seed)
        if not (width <= ad.target_width):
            need[c.cell_id] = min(n + ad.batch, ad.max_episodes)
    if ad.extend_together and need:
        by_world: dict[str, int] = {}
        for c in cells:
            if c.cell_id in need:
                by_world[c.world_key] = max(by_world.get(c.world_key, 0), need[c.cell_id])
        for c in cells:
            if c.world_key in by_world:
                target = min(by_world[c.world_key], ad.max_episodes)
                if target > counts.get(c.cell_id, 0):
                    need[c.cell_id] = target
    return need


def run_sweep(
    sweep_path_or_model: str | Path | Mapping[str, Any] | SweepSpec,
    store_path: str | Path,
    backend: str = "local",
    workers: int = 2,
    scheduler: str | None = None,
    episode_fn: EpisodeFn | None = None,
    progress: bool = True,
    *,
    retry_errors: bool = False,
    validate: bool | None = None,
    timeout: float = 5.0,
    chunk_size: int | None = None,
    group_fn: Callable[[list[EpisodeTask]], list[dict]] | None = None,
    summary: bool | None = None,
    success: str = "success",
    select: Callable[[Cell], bool] | None = None,
) -> Any:
    """Run (or resume) a sweep, writing every finished episode to the store at once.

    Parameters
    ----------
    sweep_path_or_model : path, dict or SweepSpec
        The sweep file.
    store_path : path
        SQLite results store (created if absent). A store of a different sweep is refused.
    backend : {"local", "dask"}
        ``local``: a process pool on this machine. ``dask``: a Dask ``LocalCluster`` of
        ``workers`` processes, or the cluster at ``scheduler``.
    workers : int
        Worker processes (``1`` with ``backend="local"`` runs in this process).
    scheduler : str, optional
        ``"tcp://host:port"`` of a running Dask scheduler (implies ``backend="dask"``).
    episode_fn : callable, optional
        ``episode_fn(task) -> row``; must be importable (a top-level function of a module) for
        process backends, and a script calling ``run_sweep`` needs an
        ``if __name__ == "__main__":`` guard (workers are started, not forked from the caller).
        Defaults to ``odorloc.experiments.runner.run_task``.
    progress : bool
        Show a live progress bar and print the summary table at the end.
    retry_errors : bool
        Run again the episodes stored with status ``"error"`` (their rows are replaced).
    validate : bool, optional
        Validate every cell before anything runs (:func:`.sweep_check.check_sweep`: names,
        overrides, grid values, each cell's scenario built and its searcher reset); default:
        only with the real episode function. An invalid sweep raises before the store is
        opened, so the store is left untouched.
    timeout : float, seconds
        How long to wait for a Dask scheduler before giving up.
    chunk_size : int, optional
        Episodes per work item; default chosen from the number of tasks and workers.
    group_fn : callable, optional
        With ``replay: true``, the function running one world group (all cells of a flow key
        and episode, on one recorded flow); default
        :func:`odorloc.experiments.runner.replay_group`.
    summary : bool, optional
        Print the per-cell summary table at the end (default: with ``progress``; a
        reproduction prints its own tables instead).
    success : str
        Row column the progress bars count as a success (a reproduction's own criterion).
    select : callable, optional
        ``select(cell) -> bool``: run only the cells it accepts. The store stays this whole
        sweep's (the same config hash), so a later call without ``select`` resumes it and runs
        the rest; a replay sweep records a world's flow for the accepted cells only.

    Returns
    -------
    pandas.DataFrame
        The stored table of this sweep, ordered by cell, episode; ``df.attrs["added"]`` is the
        number of episodes this call ran and stored (fewer than the rows when it resumed).

    Raises
    ------
    ConfigError
        Invalid sweep file, store of another sweep, unreachable scheduler.
    """
    from odorloc.experiments.backends import make_backend
    from odorloc.experiments.progress import SweepProgress
    from odorloc.experiments.store import ResultStore

    spec = load_sweep(sweep_path_or_model)
    if validate is None:
        validate = episode_fn is None
    if validate:
        # every cell, before the store is opened or a worker started
        from odorloc.experiments.sweep_check import check_sweep

        check_sweep(spec, iter_cells(spec))
    if episode_fn is None:
        episode_fn = default_episode_fn()
    if spec.replay and group_fn is None:
        from odorloc.experiments.runner import replay_group

        group_fn = replay_group
    if scheduler is not None:
        backend = "dask"
    cells = [c for c in expand_cells(spec) if select is None or select(c)]
    chash = config_hash(spec)
    if Path(store_path).exists():
        # refuse a store of another sweep before writing anything to it
        with ResultStore(store_path, readonly=True) as probe:
            probe.check(chash)
    runner = make_backend(backend, workers=workers, scheduler=scheduler, timeout=timeout)
    added = 0
    started = time.time()
    t0 = time.perf_counter()
    # connect first: an unreachable scheduler must not leave a new, empty store behind
    with runner, ResultStore(store_path) as store:
        store.check(chash)
        with SweepProgress(enabled=progress, success=success) as prog:
            store.bind(chash, spec)
            if retry_errors:
                store.delete_errors()
            targets = {c.cell_id: spec.episodes for c in cells}
            while True:
                done = store.done_keys()
                n_pending = count_pending(targets, done)
                prog.begin_round(cells, targets, store.cell_counts(success))
                keep = spec.keep_arrays or bool(spec.keep_episodes)
                if n_pending and spec.replay:
                    assert group_fn is not None
                    groups = iter_pending_groups(spec, cells, targets, done, chash)
                    work = runner.run((), group_fn, keep_arrays=keep, groups=groups)
                elif n_pending:
                    work = runner.run(
                        iter_pending(spec, cells, targets, done, chash),
                        episode_fn,
                        keep_arrays=keep,
                        chunk_size=chunk_size,
                        total=n_pending,
                    )
                else:
                    work = iter(())
                for task, row in work:
                    added += int(store.add(task, row))
                    prog.advance(task, row)
                if spec.adaptive is None:
                    break
                df = store.frame()
                counts = {c.cell_id: max(targets[c.cell_id], 0) for c in cells}
                more = _cells_needing_more(spec, cells, counts, df)
                if not more:
                    break
                targets.update(more)
        from odorloc.experiments.provenance import run_record

        store.note_run(run_record(started, time.perf_counter() - t0, added, backend, workers))
        df = store.frame()
    # what this call ran, as opposed to what the store holds (a resumed sweep adds fewer)
    df.attrs["added"] = added
    if progress if summary is None else summary:
        from odorloc.experiments.progress import print_summary

        print_summary(df)
    return df
