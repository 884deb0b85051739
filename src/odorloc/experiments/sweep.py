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
scenario name and its overrides, and the ``agent_seed`` on (root seed, world key, episode index)
through a separate stream. Neither depends on the searcher, so episode ``i`` of every searcher in a
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
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import pydantic
import yaml
from pydantic import Field, field_validator, model_validator

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.params import Params
from odorloc.core.seeds import episode_seeds

#: Overrides that only place agents (allowed in a scenario's ``agent_grid``, with ``agents.*``).
AGENT_KEYS = ("start_set", "start_index")

EpisodeFn = Callable[["EpisodeTask"], dict]
"""An episode function: runs one task and returns one row dict (see :mod:`.store`)."""

_SCALAR = (str, int, float, bool, type(None))


def _check_value(v: Any, where: str) -> Any:
    """Reject values that cannot be written canonically to JSON (so the hash is well defined)."""
    if isinstance(v, float) and not math.isfinite(v):
        raise ValueError(f"{where}: must be finite")
    if isinstance(v, _SCALAR):
        return v
    if isinstance(v, list | tuple):
        return [_check_value(x, where) for x in v]
    if isinstance(v, dict):
        return {str(k): _check_value(x, where) for k, x in v.items()}
    raise ValueError(f"{where}: unsupported value type {type(v).__name__}")


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
        return _check_value(v, "value")

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
                raise ValueError(f"grid {key!r} has no values")
            _check_value(values, key)
            canon = [json.dumps(x, sort_keys=True) for x in values]
            if len(set(canon)) != len(canon):
                raise ValueError(f"grid {key!r} repeats a value")
        return v

    @model_validator(mode="after")
    def _no_overlap(self) -> ComponentSpec:
        for a, b, what in (
            (self.params, self.grid, "a fixed param and a grid axis"),
            (self.params, self.agent_grid, "a fixed param and an agent_grid axis"),
            (self.grid, self.agent_grid, "a grid and an agent_grid axis"),
        ):
            both = sorted(set(a) & set(b))
            if both:
                raise ValueError(f"{both[0]!r} is both {what}")
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
    batch: int = Field(default=20, ge=1)
    max_episodes: int = Field(default=1000, ge=1)
    level: float = Field(default=0.95, gt=0, lt=1)
    extend_together: bool = True


class SweepSpec(Params):
    """A validated sweep file (see the module docstring for the YAML layout)."""

    name: str = "sweep"
    seed: int = Field(ge=0, lt=2**63)
    episodes: int = Field(ge=1)
    scenarios: list[ComponentSpec] = Field(min_length=1)
    searchers: list[ComponentSpec] = Field(min_length=1)
    keep_arrays: bool = False
    keep_episodes: list[int] = Field(default_factory=list)
    replay: bool = False
    adaptive: AdaptiveSpec | None = None
    base_dir: str | None = Field(default=None, exclude=True)
    """Directory that relative scenario paths are resolved against (the sweep file's folder)."""

    @model_validator(mode="after")
    def _unique_labels(self) -> SweepSpec:
        for fam in ("scenarios", "searchers"):
            labels = [c.display for c in getattr(self, fam)]
            for i, lab in enumerate(labels):
                if lab in labels[:i]:
                    raise ValueError(f"{fam}: label {lab!r} used twice (give a distinct 'label')")
        return self


# ----------------------------------------------------------------------------- loading


def load_sweep(source: str | Path | Mapping[str, Any] | SweepSpec) -> SweepSpec:
    """Read and validate a sweep file, a dict or an existing :class:`SweepSpec`.

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
        if not path.is_file():
            raise ConfigError("sweep", f"file not found: {path}")
        try:
            data = yaml.safe_load(path.read_text())
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1})" if mark is not None else ""
            raise ConfigError("sweep", f"not valid YAML{where}: {path}") from None
        base_dir = str(path.resolve().parent)
    else:
        data = dict(source)
    if not isinstance(data, dict):
        raise ConfigError("sweep", "the file must hold a mapping (name, seed, episodes, ...)")
    if base_dir is not None and "base_dir" not in data:
        data["base_dir"] = base_dir
    try:
        return SweepSpec.model_validate(data)
    except pydantic.ValidationError as err:
        line = format_validation_error(err)
        fld, _, problem = line.partition(": ")
        raise ConfigError(fld, problem) from None


# ----------------------------------------------------------------------------- hashing


def _canon(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def _scenario_file_digest(name: str, base_dir: str | None) -> str | None:
    """SHA-256 of a scenario given as a file path (so editing the file changes the hash)."""
    if not name.endswith((".yaml", ".yml", ".json", ".toml")):
        return None
    p = Path(name)
    if not p.is_absolute() and base_dir is not None:
        p = Path(base_dir) / p
    if not p.is_file():
        return None
    return hashlib.sha256(p.read_bytes()).hexdigest()


def hashed_content(spec: SweepSpec) -> dict[str, Any]:
    """The part of the sweep that determines every episode's result (what the hash covers)."""
    from odorloc import __version__

    scen = []
    for s in spec.scenarios:
        d = s.model_dump()
        if not d["agent_grid"]:
            del d["agent_grid"]  # sweeps without one keep the hash they always had
        d["file_sha256"] = _scenario_file_digest(s.name, spec.base_dir)
        scen.append(d)
    out = {
        "seed": spec.seed,
        "scenarios": scen,
        "searchers": [s.model_dump() for s in spec.searchers],
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
        swept overrides merged.
    swept : dict
        Only the swept overrides, keys prefixed ``scenario.`` / ``searcher.``.
    flow_key : str
        Key of the world seeds and of the recorded flow: the world key without the
        ``agent_grid`` axes (equal to it without them).
    """

    index: int
    cell_id: str
    world_key: str
    spec: dict[str, Any]
    swept: dict[str, Any]
    flow_key: str = ""

    def __post_init__(self) -> None:
        if not self.flow_key:
            object.__setattr__(self, "flow_key", self.world_key)


def _fmt_point(point: dict[str, Any]) -> str:
    if not point:
        return ""
    inner = ",".join(f"{k}={_canon(v)}" for k, v in sorted(point.items()))
    return f"[{inner}]"


def _grid_points(grid: dict[str, list[Any]]) -> list[dict[str, Any]]:
    keys = sorted(grid)
    return [
        dict(zip(keys, combo, strict=True)) for combo in itertools.product(*(grid[k] for k in keys))
    ]


def expand_cells(spec: SweepSpec) -> list[Cell]:
    """All cells in deterministic order: scenarios, their grid, searchers, their grid."""
    cells: list[Cell] = []
    for sc in spec.scenarios:
        for gp in _grid_points(sc.grid):
            flow_key = f"{sc.display}{_fmt_point(gp)}"
            for ap in _grid_points(sc.agent_grid):
                sp = {**gp, **ap}
                world_key = f"{sc.display}{_fmt_point(sp)}"
                for se in spec.searchers:
                    for ep in _grid_points(se.grid):
                        cell_id = f"{world_key}/{se.display}{_fmt_point(ep)}"
                        swept = {f"scenario.{k}": v for k, v in sp.items()}
                        swept.update({f"searcher.{k}": v for k, v in ep.items()})
                        cells.append(
                            Cell(
                                index=len(cells),
                                cell_id=cell_id,
                                world_key=world_key,
                                spec={
                                    "scenario": sc.name,
                                    "scenario_label": sc.display,
                                    "scenario_params": {**sc.params, **sp},
                                    "searcher": se.name,
                                    "searcher_label": se.display,
                                    "searcher_params": {**se.params, **ep},
                                    "swept": swept,
                                },
                                swept=swept,
                                flow_key=flow_key,
                            )
                        )
    return cells


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
    """Check scenario and searcher names against the package's own registries where present.

    Scenarios are resolved with ``odorloc.scenarios.get_scenario`` and searchers looked up in the
    ``"searcher"`` registry family. A module that does not exist yet is skipped.

    Raises
    ------
    ConfigError
        Naming ``scenarios[i].name`` / ``searchers[i].name``.
    """
    try:
        from odorloc.scenarios import get_scenario  # type: ignore[attr-defined]
    except ImportError:
        get_scenario = None
    if get_scenario is not None:
        for i, sc in enumerate(spec.scenarios):
            name = sc.name
            if spec.base_dir and name.endswith((".yaml", ".yml", ".json")):
                p = Path(spec.base_dir) / name
                if p.is_file():
                    name = str(p)
            try:
                base = get_scenario(name)
            except ConfigError as exc:
                raise ConfigError(f"scenarios[{i}].name", str(exc)) from None
            except (KeyError, FileNotFoundError, ValueError) as exc:
                raise ConfigError(
                    f"scenarios[{i}].name", f"unknown scenario {sc.name!r}: {exc}"
                ) from None
            drawn = base.world.source_draw is not None or any(
                k.startswith("world.source_draw") for k in (*sc.params, *sc.grid)
            )
            if sc.agent_grid and drawn:
                # the drawn sources keep a distance from the starts: placements would not
                # share one world
                raise ConfigError(
                    f"scenarios[{i}].agent_grid", "cannot be used with world.source_draw"
                )
    try:
        from odorloc.core import registry

        known = registry.names("searcher")
    except ImportError:
        known = []
    if known:
        for i, se in enumerate(spec.searchers):
            if se.name not in known:
                raise ConfigError(
                    f"searchers[{i}].name",
                    f"unknown searcher {se.name!r} (known: {', '.join(known)})",
                )


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
        Check scenario/searcher names against the registries; default: only with the real
        episode function.
    timeout : float, seconds
        How long to wait for a Dask scheduler before giving up.
    chunk_size : int, optional
        Episodes per work item; default chosen from the number of tasks and workers.
    group_fn : callable, optional
        With ``replay: true``, the function running one world group (all cells of a flow key
        and episode, on one recorded flow); default
        :func:`odorloc.experiments.runner.replay_group`.
    summary : bool, optional
        Print the per-cell summary table at the end (default: with ``progress``).

    Returns
    -------
    pandas.DataFrame
        The stored table of this sweep, ordered by cell, episode.

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
        validate_names(spec)
    if episode_fn is None:
        episode_fn = default_episode_fn()
    if spec.replay and group_fn is None:
        from odorloc.experiments.runner import replay_group

        group_fn = replay_group
    if scheduler is not None:
        backend = "dask"
    cells = expand_cells(spec)
    chash = config_hash(spec)
    cell_by_id = {c.cell_id: c for c in cells}

    runner = make_backend(backend, workers=workers, scheduler=scheduler, timeout=timeout)
    with ResultStore(store_path) as store:
        # refuse a store of another sweep before starting any worker
        store.check(chash)
        with runner, SweepProgress(enabled=progress) as prog:
            store.bind(chash, spec)
            if retry_errors:
                store.delete_errors()
            targets = {c.cell_id: spec.episodes for c in cells}
            while True:
                done = store.done_keys()
                pending = [
                    make_task(spec, cell_by_id[cid], e, chash)
                    for cid, n in targets.items()
                    for e in range(n)
                    if (cid, e) not in done
                ]
                prog.begin_round(cells, targets, store.cell_counts())
                keep = spec.keep_arrays or bool(spec.keep_episodes)
                if pending and spec.replay:
                    assert group_fn is not None
                    groups: dict[tuple[str, int], list[EpisodeTask]] = {}
                    for task in pending:
                        groups.setdefault((task.flow_key, task.episode), []).append(task)
                    work = runner.run(
                        pending, group_fn, keep_arrays=keep, groups=list(groups.values())
                    )
                elif pending:
                    work = runner.run(pending, episode_fn, keep_arrays=keep, chunk_size=chunk_size)
                else:
                    work = iter(())
                for task, row in work:
                    store.add(task, row)
                    prog.advance(task, row)
                if spec.adaptive is None:
                    break
                df = store.frame()
                counts = {c.cell_id: max(targets[c.cell_id], 0) for c in cells}
                more = _cells_needing_more(spec, cells, counts, df)
                if not more:
                    break
                targets.update(more)
        df = store.frame()
    if progress if summary is None else summary:
        from odorloc.experiments.progress import print_summary

        print_summary(df)
    return df


def iter_rows_sequential(
    tasks: Iterable[EpisodeTask], episode_fn: EpisodeFn
) -> Iterable[tuple[EpisodeTask, dict]]:
    """Run tasks one after another in this process (reference for the other backends)."""
    from odorloc.experiments.backends import execute_task

    for t in tasks:
        yield t, execute_task(episode_fn, t, keep_arrays=True)
