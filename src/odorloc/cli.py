"""The ``odorloc`` command line.

Every command validates all of its input first (options, files, every cell of a sweep, and where
its outputs go) and only then starts work; invalid input prints one line naming the field or
file and the problem and exits with code 2 (no traceback), leaving every stored file as it was.
Command-line usage errors (an unknown option, a value of the wrong type) are one line too.
"""

from __future__ import annotations

import math
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from typer.core import TyperGroup

from odorloc.core.errors import ConfigError, OdorlocError
from odorloc.core.loading import check_output_dir, check_output_file
from odorloc.core.seeds import check_seed

try:  # typer vendors its own click in recent versions
    from typer._click import exceptions as _click_errors
except ImportError:  # pragma: no cover - older typer on the click package
    from click import exceptions as _click_errors

MAX_FRAMES = 10_000
"""Most animation frames of ``odorloc run``."""


def _one_line(msg: str) -> str:
    return " ".join(str(msg).split())


class _OneLineErrors(TyperGroup):
    """Usage errors (unknown option, bad value type, missing argument) as one ``error:`` line
    with exit code 2, like every other invalid input."""

    def main(self, *args: Any, standalone_mode: bool = True, **kwargs: Any) -> Any:
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        try:
            rv = super().main(*args, standalone_mode=False, **kwargs)
        except _click_errors.UsageError as exc:
            err_console.print(
                f"error: {escape(_one_line(exc.format_message()))}",
                highlight=False,
                soft_wrap=True,
            )
            sys.exit(2)
        except _click_errors.ClickException as exc:
            err_console.print(
                f"error: {escape(_one_line(exc.format_message()))}",
                highlight=False,
                soft_wrap=True,
            )
            sys.exit(exc.exit_code)
        except typer.Abort:
            sys.exit(1)
        except OdorlocError as exc:  # any command: invalid input is one line, never a traceback
            err_console.print(
                f"error: {escape(_one_line(str(exc)))}", highlight=False, soft_wrap=True
            )
            sys.exit(2)
        sys.exit(rv if isinstance(rv, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    help="odorloc: simulate odor plumes and robots, run and compare odor source localization.",
    no_args_is_help=False,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


def _fail(msg: str) -> None:
    err_console.print(
        f"[bold red]error:[/] {escape(_one_line(msg))}", highlight=False, soft_wrap=True
    )
    raise typer.Exit(code=2)


def _check_count(value: int, field: str, low: int = 1, high: int | None = None) -> int:
    if value < low or (high is not None and value > high):
        upper = f" and <= {high}" if high is not None else ""
        raise ConfigError(field, f"must be >= {low}{upper}, got {value}")
    return value


def _check_backend(backend: str, scheduler: str | None) -> str:
    if scheduler is not None:
        if "://" not in scheduler:
            raise ConfigError(
                "--scheduler", f"expected an address like tcp://host:8786, got {scheduler!r}"
            )
        return "dask"
    if backend not in ("local", "dask"):
        raise ConfigError("--backend", f"unknown backend {backend!r} (known: local, dask)")
    return backend


_SCENARIO_KEYS = ("world", "agents", "searcher", "sensors", "platform", "task", "limits")
_SWEEP_KEYS = ("scenarios", "searchers", "episodes", "seed", "adaptive")


def _wrong_kind(path: str | Path, expected: str, field: str, hint: str) -> ConfigError | None:
    """An error saying that ``path`` is the other kind of file (a scenario given as a sweep or
    the reverse), or ``None``; called once loading it has failed, so that the user reads which
    option takes the file instead of the first of a dozen missing fields."""
    from odorloc.core.loading import load_yaml_mapping

    p = Path(path)
    try:
        data = load_yaml_mapping(p, expected) if p.is_file() else None
    except OdorlocError:
        return None
    if not isinstance(data, dict):
        return None
    # the key the expected kind cannot do without is missing, the other kind's is there
    if expected == "sweep" and "scenarios" not in data and "world" in data:
        other, keys = "scenario", [k for k in _SCENARIO_KEYS if k in data]
    elif expected == "scenario" and "world" not in data and "scenarios" in data:
        other, keys = "sweep", [k for k in _SWEEP_KEYS if k in data]
    else:
        return None
    listed = ", ".join(keys[:3]) + (", ..." if len(keys) > 3 else "")
    return ConfigError(field, f"{p.name} looks like a {other} file (it has {listed}); {hint}")


def _load_or_name_kind(
    load: Callable[[Any], Any], path: str | Path, expected: str, field: str, hint: str
) -> Any:
    """``load(path)``; if that fails and ``path`` is the other kind of file, an error saying so
    (:func:`_wrong_kind`) instead of the loader's."""
    try:
        return load(path)
    except ConfigError:
        wrong = _wrong_kind(path, expected, field, hint)
        if wrong is None:
            raise
        raise wrong from None


def _renamed(exc: ConfigError, field: str, option: str) -> ConfigError:
    """``exc`` naming the command-line ``option`` the user typed when it names ``field``."""
    return ConfigError(option, exc.problem) if exc.field == field else exc


def _failure_line(df: Any) -> str | None:
    """``"N of M episodes failed (first: ...)"`` for the error rows of ``df``, or ``None``."""
    if not len(df) or "status" not in df:
        return None
    bad = df[df["status"] == "error"]
    if not len(bad):
        return None
    first = str(bad.iloc[0].get("error") or "").strip().splitlines()
    what = first[0] if first else "no error text stored"
    # an invalid setting reads as "field: problem", like the refusals before a run
    for name in ("ConfigError: ", "OdorlocError: "):
        what = what.removeprefix(name)
    if len(what) > 300:
        what = what[:297] + "..."
    return f"{len(bad)} of {len(df)} episodes failed (first: {what})"


def _write_errors_log(df: Any, path: Path) -> None:
    """Every error row of ``df`` with its stored traceback."""
    bad = df[df["status"] == "error"]
    with path.open("w") as fh:
        for r in bad.itertuples():
            where = f"{r.sweep}: " if "sweep" in bad.columns else ""
            fh.write(f"== {where}{r.cell_id} episode {r.episode}\n{r.error}\n\n")


def _report_failures(command: str, df: Any, out: Path) -> bool:
    """With failed episodes: write ``out/errors.log``, print one summary line on stderr and
    return ``True`` (the command then exits 1; its stored results stay as they are)."""
    line = _failure_line(df)
    if line is None:
        return False
    log = out / "errors.log"
    try:
        _write_errors_log(df, log)
        where = f"; see {log}"
    except OSError as exc:  # the results are stored; say so rather than fail on the log
        where = f"; cannot write {log} ({exc.strerror or exc}), the store holds the tracebacks"
    err_console.print(
        escape(_one_line(f"{command}: {line}{where}")), highlight=False, soft_wrap=True
    )
    return True


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.3g}" if abs(v) < 1e4 else f"{v:.0f}"
    return str(v)


@app.command()
def run(
    scenario: Annotated[
        str | None,
        typer.Argument(
            help="Built-in scenario name or scenario YAML file (default: the main job)."
        ),
    ] = None,
    seed: Annotated[
        int | None, typer.Option(help="Root seed (default: the scenario's seed).")
    ] = None,
    episode: Annotated[
        int, typer.Option(help="Episode index: the same episode as in `batch --seed ROOT`.")
    ] = 0,
    searcher: Annotated[
        str | None, typer.Option(help="Replace the scenario's searcher (registry name).")
    ] = None,
    out: Annotated[
        Path, typer.Option(help="Output folder for figures, animation, recording.")
    ] = Path("odorloc-out"),
    animation: Annotated[
        bool, typer.Option(help="Write the animation (GIF, and MP4 with ffmpeg).")
    ] = True,
    frames: Annotated[int, typer.Option(help="Maximum number of animation frames.")] = 120,
    world_key: Annotated[
        str | None,
        typer.Option(
            help="Key of the episode's seeds (default: the scenario argument as given); the "
            "summary and scenario.yaml name it, to repeat the episode from the saved file."
        ),
    ] = None,
    from_batch: Annotated[
        Path | None,
        typer.Option(
            help="Re-run episode --episode of cell --cell of a batch or reproduction: its "
            "output folder or .sqlite store. Compares the metrics with the stored row."
        ),
    ] = None,
    cell: Annotated[
        str | None,
        typer.Option(help="Cell id of the episode to re-run with --from-batch (as stored)."),
    ] = None,
) -> None:
    """Run one episode, print a summary and write the figures and the animation.

    Episode I of root seed R is exactly episode I of ``odorloc batch`` with ``--seed R`` and the
    same scenario (given the same way, name or file path: the text is the seeds' world key).
    Any stored episode of a sweep or a reproduction, whatever its overrides, is re-run with
    ``--from-batch OUT --cell ID --episode I``.
    """
    from odorloc.experiments.sweep import MAX_EPISODES

    try:
        # the options first, before the heavy imports and any file is read
        _check_count(episode, "--episode", 0, MAX_EPISODES - 1)
        _check_count(frames, "--frames", 1, MAX_FRAMES)
        if seed is not None:
            check_seed(seed, "--seed")
        check_output_dir(out, "--out")
    except OdorlocError as exc:
        _fail(str(exc))
        return
    from odorloc.core.seeds import episode_seeds
    from odorloc.engine.episode import run_episode
    from odorloc.scenarios import DEFAULT_SCENARIO
    from odorloc.scenarios.loading import check_scenario, load_scenario
    from odorloc.viz.episode import animate, ffmpeg_available, plot_traces, plot_trajectory

    stored = None
    try:
        if from_batch is not None:
            from odorloc.experiments.rerun import rerun, stored_episode

            for given, name in (
                (scenario, "scenario"),
                (seed, "--seed"),
                (searcher, "--searcher"),
                (world_key, "--world-key"),
            ):
                if given is not None:
                    raise ConfigError(name, "cannot be combined with --from-batch")
            if cell is not None and not cell.strip():
                raise ConfigError("--cell", "is empty")
            stored = stored_episode(from_batch, cell, episode)
            from odorloc.experiments.runner import cell_scenario

            sc = cell_scenario(stored.cell)
            check_scenario(sc)
            key = stored.cell_id
            console.print(
                f"re-running [bold]{escape(stored.cell_id)}[/], episode {episode}, of "
                f"{escape(str(stored.store))} (world seed {stored.world_seed}, agent seed "
                f"{stored.agent_seed}{', on its recorded flow' if stored.replay else ''})"
            )
        else:
            if cell is not None:
                raise ConfigError("--cell", "needs --from-batch")
            ref = scenario if scenario is not None else DEFAULT_SCENARIO
            if not ref.strip():
                raise ConfigError("scenario", "is empty (give a built-in name or a file)")
            if searcher is not None and not searcher.strip():
                raise ConfigError("--searcher", "is empty")
            if world_key is not None and not world_key.strip():
                raise ConfigError("--world-key", "is empty")
            key = world_key if world_key is not None else ref
            sc = _load_or_name_kind(
                load_scenario, ref, "scenario", "scenario", "run it with odorloc batch"
            )
            if searcher:
                from odorloc.core import registry
                from odorloc.experiments.runner import cell_scenario

                registry.entry("searcher", searcher, field="--searcher")
                sc = cell_scenario({"scenario": ref, "searcher": searcher})
            if seed is not None:
                sc = sc.model_copy(update={"seed": seed})
            try:
                check_scenario(sc)
            except ConfigError as exc:
                # the searcher the user chose does not fit the scenario: name the option
                raise (_renamed(exc, "searcher.type", "--searcher") if searcher else exc) from None
            world_seed, agent_seed = episode_seeds(sc.seed, key, episode)
            console.print(
                f"running [bold]{escape(sc.name)}[/] with searcher "
                f"[bold]{escape(sc.searcher.type)}[/], root seed {sc.seed}, episode {episode}, "
                f"world key {escape(repr(key))}"
            )
        # numba's one-off runtime start belongs to the process, not to the episode's time
        from odorloc.core.jit import start

        start()
        if stored is not None:
            sc, res = rerun(stored, record=True)
        else:
            res = run_episode(sc, world_seed, agent_seed, record=True)
    except OdorlocError as exc:
        _fail(str(exc))
        return
    rec = res.recording
    assert rec is not None
    rec.meta.update(searcher=sc.searcher.type, seed=sc.seed, episode=episode)
    title = stored.cell_id if stored is not None else f"{sc.name} — {sc.searcher.type}"
    seed_text = "" if stored is not None else f"seed {sc.seed}, "
    table = Table(title=escape(f"{title} — {seed_text}episode {episode}"))
    table.add_column("metric")
    table.add_column("value", justify="right")
    if stored is not None:
        table.add_column("stored", justify="right")
    from odorloc.experiments.rerun import COMPARED

    for k in (*COMPARED, "wall_time", "wall_per_step_ms"):
        cells = [k, _fmt(res.metrics.get(k))]
        if stored is not None:
            was = stored.row.get(k)
            cells.append(_fmt(bool(was) if k == "success" and was is not None else was))
        table.add_row(*cells)
    console.print(table)
    if stored is not None:
        from odorloc.experiments.rerun import differences

        diff = differences(stored, res.metrics)
        if stored.row.get("status") == "error":
            console.print(f"the stored episode failed: {escape(str(stored.row.get('error')))}")
        elif diff:
            console.print(
                f"[bold red]differs from the stored episode[/] in {', '.join(diff)}: the "
                "package, a file the scenario reads or the installed kernels changed since"
            )
        else:
            console.print("the same episode as stored (every compared metric equal)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        written = [
            plot_trajectory(rec, out / "trajectory.png") and out / "trajectory.png",
            plot_traces(rec, out / "traces.png") and out / "traces.png",
            rec.save(out / "recording.npz"),
        ]
        if rec.positions.shape[2] == 3:
            from odorloc.viz.team3d import plot_team_3d

            plot_team_3d(rec, out / "view_3d.png")
            written.append(out / "view_3d.png")
        if stored is not None:
            again = (
                f"# odorloc run --from-batch {shlex.quote(str(stored.store))} "
                f"--cell {shlex.quote(stored.cell_id)} --episode {episode}\n"
                "# repeats this episode (the cell of a stored batch; below, its scenario)\n"
            )
        else:
            again = (
                f"# odorloc run {shlex.quote(str(out / 'scenario.yaml'))} --seed {sc.seed} "
                f"--episode {episode} --world-key {shlex.quote(key)}\n"
                "# repeats this episode (the seeds derive from the world key)\n"
            )
        (out / "scenario.yaml").write_text(again + sc.to_yaml())
        written.append(out / "scenario.yaml")
        if animation:
            written.append(animate(rec, out / "episode.gif", max_frames=frames))
            if ffmpeg_available():
                written.append(animate(rec, out / "episode.mp4", max_frames=frames))
    except OSError as exc:
        _fail(f"--out: cannot write into {out}: {exc.strerror or exc}")
        return
    for p in written:
        console.print(f"wrote {p}")


@app.command()
def scenarios(
    show: Annotated[str | None, typer.Argument(help="Print this scenario's YAML.")] = None,
) -> None:
    """List the built-in scenarios (or print one as YAML)."""
    from odorloc.scenarios import builtin_names, get_scenario

    try:
        if show:
            sys.stdout.write(get_scenario(show).to_yaml())
            return
        table = Table(title="built-in scenarios")
        for col in ("name", "paper", "searcher", "description"):
            table.add_column(col)
        for n in builtin_names():
            sc = get_scenario(n)
            table.add_row(n, sc.paper, sc.searcher.type, sc.description)
        console.print(table)
    except OdorlocError as exc:
        _fail(str(exc))


@app.command()
def batch(
    sweep: Annotated[
        str | None,
        typer.Argument(help="Sweep YAML file (scenarios x searchers x grids x episodes)."),
    ] = None,
    scenario: Annotated[
        list[str] | None,
        typer.Option("--scenario", "-s", help="Scenario(s), without a sweep file."),
    ] = None,
    searcher: Annotated[
        list[str] | None,
        typer.Option("--searcher", "-a", help="Searcher(s), without a sweep file."),
    ] = None,
    episodes: Annotated[
        int | None, typer.Option(help="Episodes per cell, without a sweep file (default 10).")
    ] = None,
    seed: Annotated[
        int | None, typer.Option(help="Root seed, without a sweep file (default 0).")
    ] = None,
    out: Annotated[Path, typer.Option(help="Output folder (store, CSV, Parquet).")] = Path(
        "odorloc-batch"
    ),
    backend: Annotated[str, typer.Option(help="local (process pool) or dask.")] = "local",
    workers: Annotated[int, typer.Option(help="Worker processes.")] = 2,
    scheduler: Annotated[
        str | None, typer.Option(help="Join a running Dask scheduler (tcp://host:port).")
    ] = None,
    progress: Annotated[bool, typer.Option(help="Live progress bar.")] = True,
) -> None:
    """Run (or resume) a Monte Carlo set; every finished episode is stored at once.

    Re-running the same command resumes: finished episodes are skipped. Writes
    ``results.sqlite``, ``results.csv`` and ``results.parquet`` into ``--out``. Episodes that
    fail are stored as error rows, their tracebacks written to ``errors.log``, one summary line
    goes to stderr and the exit status is 1 (2: invalid input, nothing run).
    """
    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import MAX_EPISODES, load_sweep, run_sweep

    try:
        _check_count(workers, "--workers", 1, 1024)
        backend = _check_backend(backend, scheduler)
        check_output_dir(out, "--out")
        if sweep is not None and (scenario or searcher):
            raise ConfigError("--scenario", "give a sweep file or --scenario/--searcher, not both")
        if sweep is not None and (episodes is not None or seed is not None):
            opt = "--episodes" if episodes is not None else "--seed"
            raise ConfigError(opt, "the sweep file sets it; edit the file instead")
        if sweep is None:
            episodes = 10 if episodes is None else episodes
            seed = 0 if seed is None else seed
            if not scenario:
                raise ConfigError("batch", "give a sweep file or at least one --scenario")
            _check_count(episodes, "--episodes", 1, MAX_EPISODES)
            check_seed(seed, "--seed")
            spec: Any = {
                "name": "cli-batch",
                "seed": seed,
                "episodes": episodes,
                "scenarios": [{"name": s} for s in scenario],
                "searchers": [{"name": a} for a in (searcher or [])] or None,
            }
            from odorloc.scenarios.loading import load_scenario

            # each --scenario as typed, so that a refusal names the option
            loaded: dict[str, Any] = {}
            for s in scenario:
                try:
                    loaded[s] = load_scenario(s)
                except ConfigError as exc:
                    hint = "give it as the sweep argument"
                    wrong = _wrong_kind(s, "scenario", "--scenario", hint)
                    raise (wrong or _renamed(exc, "scenario", "--scenario")) from None
            if spec["searchers"] is None:
                names = sorted({sc.searcher.type for sc in loaded.values()})
                spec["searchers"] = [{"name": n} for n in names]
            spec = load_sweep(spec)
        else:
            spec = _load_or_name_kind(
                load_sweep, sweep, "sweep", "sweep", "give it with --scenario"
            )
        store_path = out / "results.sqlite"
        check_output_file(store_path, "--out")
        df = run_sweep(
            spec,
            store_path,
            backend=backend,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
    except ConfigError as exc:
        # the store and the cluster are the command's --out and --scheduler
        if exc.field == "store":
            exc = ConfigError(
                "--out",
                exc.problem.replace("use another store path", "use another --out folder"),
            )
        _fail(str(_renamed(exc, "scheduler", "--scheduler")))
        return
    except OdorlocError as exc:
        _fail(str(exc))
        return
    with ResultStore(store_path, readonly=True) as store:
        csv = store.to_csv(out / "results.csv")
        pq = store.to_parquet(out / "results.parquet")
    console.print(f"{len(df)} episodes -> {store_path}, {csv}, {pq}")
    # every result is stored and exported above; failed episodes make the exit status 1
    if _report_failures("batch", df, out):
        raise typer.Exit(code=1)


@app.command()
def report(
    results: Annotated[Path, typer.Argument(help="Results store (.sqlite) or CSV/Parquet export.")],
    out: Annotated[Path | None, typer.Option(help="HTML file to write.")] = None,
) -> None:
    """Write a self-contained HTML report (tables with intervals, figures, episode viewer)."""
    from odorloc.experiments.report import report_main

    target = out or results.with_suffix(".html")
    try:
        check_output_file(target, "--out")
        path = report_main(results, target)
    except OdorlocError as exc:
        _fail(str(exc))
        return
    console.print(f"wrote {path}")


@app.command()
def reproduce(
    paper: Annotated[str, typer.Argument(help="Reproduction name (see --list).")] = "",
    out: Annotated[Path | None, typer.Option(help="Output folder.")] = None,
    episodes: Annotated[
        int | None, typer.Option(help="Episodes per cell (default: fits the time budget).")
    ] = None,
    workers: Annotated[int, typer.Option(help="Worker processes.")] = 2,
    seed: Annotated[int, typer.Option(help="Root seed.")] = 2024,
    backend: Annotated[str, typer.Option(help="local (process pool) or dask.")] = "local",
    scheduler: Annotated[
        str | None, typer.Option(help="Join a running Dask scheduler (tcp://host:port).")
    ] = None,
    only: Annotated[
        list[str] | None,
        typer.Option(
            help="Run only these sweeps of a reproduction made of several (repeat or separate "
            "by commas); the others' stored rows are still shown."
        ),
    ] = None,
    list_: Annotated[
        bool,
        typer.Option(
            "--list", help="List the reproductions (with a name: describe only that one)."
        ),
    ] = False,
) -> None:
    """Reproduce a paper's headline comparison: table beside the paper's numbers, figures, report.

    Results are stored as they finish; running the same command again resumes. Episodes that
    fail are stored as error rows (tracebacks in ``errors.log``): one summary line goes to
    stderr and the exit status is 1, after the tables, figures and report of the rest.
    """
    from odorloc.experiments import reproduction as rp

    if list_ or not paper:
        import textwrap

        shown = rp.names_of_reproductions()
        if paper:
            try:
                rp.get(paper)  # an unknown name is refused, not ignored
            except OdorlocError as exc:
                _fail(str(exc))
                return
            shown = [paper]
        for n in shown:
            r = rp.get(n)
            console.print(f"[bold]{n}[/]  ({r.paper})")
            text = (
                f"{r.summary}. Default {r.default_episodes} episode(s) per cell; the paper's "
                f"count: --episodes {r.paper_episodes}"
                + (f" ({r.paper_episodes_note})" if r.paper_episodes_note else "")
            )
            for line in textwrap.wrap(text, width=max(console.width - 4, 40)):
                console.print(f"    {line}", highlight=False)
        return
    try:
        from odorloc.experiments.sweep import MAX_EPISODES

        r = rp.get(paper)
        check_seed(seed, "--seed")
        _check_count(workers, "--workers", 1, 1024)
        if episodes is not None:
            _check_count(episodes, "--episodes", 1, MAX_EPISODES)
        backend = _check_backend(backend, scheduler)
        target = out or Path("odorloc-reproduce") / paper
        check_output_dir(target, "--out")
        parts = [w.strip() for o in only for w in o.split(",") if w.strip()] if only else None
        if only and not parts:
            raise ConfigError("--only", "names no sweep")
        outcome = r.run(
            target,
            episodes=episodes,
            workers=workers,
            seed=seed,
            backend=backend,
            scheduler=scheduler,
            only=parts,
        )
    except ConfigError as exc:
        # the stores and the cluster are the command's --out and --scheduler
        if exc.field == "store":
            exc = ConfigError(
                "--out",
                exc.problem.replace(
                    "use another store path", "use another --out folder or the seed it holds"
                ),
            )
        elif exc.field == "scheduler":
            exc = ConfigError("--scheduler", exc.problem)
        _fail(str(exc))
        return
    except OdorlocError as exc:
        _fail(str(exc))
        return
    # the tables, figures and report are written; failed episodes make the exit status 1
    if _report_failures("reproduce", outcome.results, target):
        raise typer.Exit(code=1)


@app.command("replay-log")
def replay_log(
    bag: Annotated[Path, typer.Argument(help="ROS 1 (.bag) or ROS 2 (folder) bag.")],
    topics: Annotated[Path, typer.Option(help="YAML mapping topics and fields (see docs).")],
    estimator: Annotated[
        str,
        typer.Option(
            help="Estimator to replay (particle-filter, ds-map, odor-path, ...) or a "
            "searcher composing one (pf-entropy, ds-mapping, ...)."
        ),
    ] = "pf-entropy",
    seed: Annotated[int, typer.Option(help="Seed of the estimator's random stream.")] = 0,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("odorloc-replay"),
) -> None:
    """Replay an estimator offline over a recorded robot log; plot its belief on the map.

    Needs the ``ros`` extra (``pip install odorloc\\[ros]``). Writes ``belief.png`` and
    ``recording.npz`` into ``--out``.
    """
    try:
        check_seed(seed, "--seed")
        check_output_dir(out, "--out")
        from odorloc.replay.offline import check_estimator

        check_estimator(estimator, "--estimator")
        try:
            from odorloc.replay.bag import BagLog, load_mapping
        except ImportError:
            raise ConfigError(
                "bag", "reading bags needs the ros extra (pip install odorloc[ros])"
            ) from None
        import numpy as np

        from odorloc.replay.offline import replay_estimator
        from odorloc.viz.episode import plot_belief_map

        # the options and the topics file are checked before the bag is opened; context()
        # below reads the whole bag
        mapping = load_mapping(topics)
        log = BagLog(bag, mapping)
        src = np.asarray(log.mapping.sources, float) if log.mapping.sources else None
        rec = replay_estimator(
            log.observations(), log.context(), estimator, seed=seed, sources=src, name=bag.name
        )
    except OdorlocError as exc:
        _fail(str(exc))
        return
    try:
        out.mkdir(parents=True, exist_ok=True)
        plot_belief_map(rec, out / "belief.png")
        rec.save(out / "recording.npz")
    except OSError as exc:
        _fail(f"--out: cannot write into {out}: {exc.strerror or exc}")
        return
    m = rec.meta
    console.print(
        f"{m['steps']} periods, {m['detections']} with a detection, "
        f"{len(rec.beliefs)} belief snapshot(s)"
    )
    if "loc_error" in m:
        console.print(f"final {estimator} estimate: {m['loc_error']:.2f} m from the source")
    for p in (out / "belief.png", out / "recording.npz"):
        console.print(f"wrote {p}")


@app.command()
def components() -> None:
    """List every registered component (wind, plume, sensors, platforms, searchers)."""
    from odorloc.core import registry
    from odorloc.experiments.reproduction import discover

    discover()  # the papers' reproductions are listed too

    table = Table(title="components")
    table.add_column("family")
    table.add_column("name")
    table.add_column("summary")
    for fam in registry.families():
        for e in registry.entries(fam):
            table.add_row(fam, e.name, e.summary)
    console.print(table)


def main() -> None:
    """Entry point of the ``odorloc`` script."""
    app()


if __name__ == "__main__":
    main()
