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
    # help texts are Markdown: paragraphs are rewrapped to the terminal, `code` shows as code
    rich_markup_mode="markdown",
)
console = Console()
err_console = Console(stderr=True)


def _version(value: bool) -> None:
    if value:
        from odorloc import __version__

        console.print(f"odorloc {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """odorloc: simulate odor plumes and robots, run and compare odor source localization.

    Documentation: the `docs/` folder of the source (a MkDocs site: `mkdocs serve`).
    """


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


#: Files ``odorloc run`` writes into ``--out`` (each checked before the episode runs).
RUN_OUTPUTS = (
    "trajectory.png",
    "traces.png",
    "recording.npz",
    "view_3d.png",
    "scenario.yaml",
    "episode.gif",
    "episode.mp4",
)

#: Files ``odorloc batch`` writes into ``--out``.
BATCH_OUTPUTS = ("results.sqlite", "results.csv", "results.parquet", "errors.log")

#: Files every reproduction writes into ``--out`` (its stores are checked by the reproduction).
REPRODUCE_OUTPUTS = ("results.csv", "report.html", "errors.log")


def _check_outputs(out: Path, names: tuple[str, ...], field: str = "--out") -> None:
    """Every file a command will write into ``out`` can be written (:class:`ConfigError`
    naming ``field`` otherwise), before any work."""
    check_output_dir(out, field)
    for name in names:
        check_output_file(out / name, field)


def _animation_progress(name: str) -> Any:
    """A transient progress bar for writing an animation (nothing on a non-terminal)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    return Progress(
        f"writing {escape(name)}",
        BarColumn(bar_width=30),
        MofNCompleteColumn(),
        "frames, ETA",
        TimeRemainingColumn(),
        console=console,
        transient=True,
    )


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
            help="Key of the episode's seeds (default: the scenario's name, whichever way its "
            "file is given)."
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

    Episode I of root seed R is exactly episode I of `odorloc batch --seed R` with the same
    scenario. The seeds derive from the scenario's own name, so a built-in name and any path
    to a file holding that scenario (`odorloc scenarios NAME > x.yaml`) give the same episode.
    Any stored episode of a sweep or a reproduction, whatever its overrides, is re-run with
    `--from-batch OUT --cell ID --episode I`.
    """
    from odorloc.experiments.sweep import MAX_EPISODES

    try:
        # the options first, before the heavy imports and any file is read
        _check_count(episode, "--episode", 0, MAX_EPISODES - 1)
        _check_count(frames, "--frames", 1, MAX_FRAMES)
        if seed is not None:
            check_seed(seed, "--seed")
        _check_outputs(out, RUN_OUTPUTS)
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
            sc = _load_or_name_kind(
                load_scenario, ref, "scenario", "scenario", "run it with odorloc batch"
            )
            # the scenario's own name, however its file was typed (the seeds of a batch too)
            key = world_key if world_key is not None else sc.name
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
    # the title on a line of its own: a table's title wraps to the table's narrow width
    console.print(escape(f"{title} — {seed_text}episode {episode}"), style="bold")
    table = Table()
    table.add_column("metric")
    table.add_column("value", justify="right")
    if stored is not None:
        table.add_column("stored", justify="right")
    from odorloc.experiments.display import (
        METRICS,
        agent_table,
        explain_failure,
        explain_reach,
        format_metric,
        metric_label,
    )

    # the standard metrics in their order: what happened, what explains a failure, the cost
    for k in METRICS:
        if k not in res.metrics and (stored is None or k not in stored.row):
            continue
        cells = [metric_label(k), format_metric(k, res.metrics.get(k))]
        if stored is not None:
            was = stored.row.get(k)
            cells.append(format_metric(k, bool(was) if k == "success" and was is not None else was))
        table.add_row(*cells)
    console.print(table)
    headers, rows = agent_table(res.metrics.agents)
    if rows:
        per_agent = Table(title="per agent")
        for i, h in enumerate(headers):
            per_agent.add_column(h, justify="left" if i == 0 else "right")
        for r in rows:
            per_agent.add_row(*(escape(c) for c in r))
        console.print(per_agent)
    why = explain_failure(res.metrics, len(rec.sources), sc.task.end)
    if why is not None:
        console.print(f"failure: {escape(why)}", highlight=False)
    t = sc.task
    reach = explain_reach(res.metrics, len(rec.sources), t.end, t.reach_radius, t.success_radius)
    if reach is not None:
        console.print(f"note: {escape(reach)}", highlight=False)
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
            keyed = "" if key == sc.name else f" --world-key {shlex.quote(key)}"
            again = (
                f"# odorloc run {shlex.quote(str(out / 'scenario.yaml'))} --seed {sc.seed} "
                f"--episode {episode}{keyed}\n"
                "# repeats this episode (the seeds derive from the scenario's name)\n"
            )
        (out / "scenario.yaml").write_text(again + sc.to_yaml())
        written.append(out / "scenario.yaml")
        if animation:
            targets = [out / "episode.gif"]
            if ffmpeg_available():
                targets.append(out / "episode.mp4")
            for target in targets:
                with _animation_progress(target.name) as bar:
                    job = bar.add_task("frames", total=None)

                    def advance(i: int, n: int, bar: Any = bar, job: Any = job) -> None:
                        bar.update(job, completed=i, total=n)

                    written.append(animate(rec, target, max_frames=frames, progress=advance))
    except OSError as exc:
        _fail(f"--out: cannot write into {out}: {exc.strerror or exc}")
        return
    for p in written:
        console.print(f"wrote {p}")


@app.command()
def scenarios(
    show: Annotated[
        str | None, typer.Argument(help="Print this scenario as YAML (a name or a file).")
    ] = None,
    resolved: Annotated[
        bool,
        typer.Option(
            help="Fill in every component's parameters, defaults included (the same scenario: "
            "`odorloc run` of the output gives the same episode)."
        ),
    ] = False,
) -> None:
    """List the built-in scenarios, or print one as YAML to copy and edit.

    The printed file keeps the scenario's `name`, which keys its seeds: running the file gives
    the episodes of the built-in scenario. Change the `name` for other worlds.
    """
    from odorloc.scenarios import builtin_names, get_scenario

    try:
        if show:
            sc = get_scenario(show)
            if resolved:
                from odorloc.scenarios.loading import resolve_components

                sc = resolve_components(sc)
            sys.stdout.write(sc.to_yaml())
            return
        if resolved:
            raise ConfigError("--resolved", "needs a scenario name (odorloc scenarios NAME)")
        _list_scenarios([get_scenario(n) for n in builtin_names()])
    except OdorlocError as exc:
        _fail(str(exc))


def _list_scenarios(items: list[Any]) -> None:
    """Each scenario's name on a line of its own, its description, searcher and paper below,
    wrapped to the terminal: names are never cut, whatever the width."""
    import textwrap

    width = max(min(console.width, 100), 40)
    console.print("built-in scenarios (odorloc scenarios NAME prints one)\n", highlight=False)
    for sc in items:
        console.print(f"[bold]{escape(sc.name)}[/]", highlight=False, soft_wrap=True)
        about = f"{sc.description} (searcher {sc.searcher.type}" + (
            f"; paper {sc.paper})" if sc.paper else ")"
        )
        for line in textwrap.wrap(about, width=width - 4, break_on_hyphens=False):
            console.print(f"    {escape(line)}", highlight=False, soft_wrap=True)
        console.print()


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
    `results.sqlite`, `results.csv` and `results.parquet` into `--out`. Episodes that fail are
    stored as error rows, their tracebacks written to `errors.log`, one summary line goes to
    stderr and the exit status is 1 (2: invalid input, nothing run).
    """
    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import MAX_EPISODES, load_sweep, run_sweep

    try:
        _check_count(workers, "--workers", 1, 1024)
        backend = _check_backend(backend, scheduler)
        _check_outputs(out, BATCH_OUTPUTS)
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
            summary=False,
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
    from odorloc.experiments.progress import print_summary

    # the summary after every batch, with or without the live bar
    print_summary(df, console=console)
    try:
        with ResultStore(store_path, readonly=True) as store:
            csv = store.to_csv(out / "results.csv")
            pq = store.to_parquet(out / "results.parquet")
    except OSError as exc:
        _fail(
            f"--out: cannot write into {out}: {exc.strerror or exc} (the store holds the results)"
        )
        return
    added = int(df.attrs.get("added", 0))
    console.print(
        f"added {added} episode{'s' if added != 1 else ''} ({len(df)} in the store)",
        highlight=False,
    )
    for p in (store_path, csv, pq):
        console.print(f"wrote {escape(str(p))}", highlight=False)
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
    points: Annotated[
        str,
        typer.Option(
            help="all, or default: every method at the default point of each world only (a "
            "reproduction over points; e.g. with --episodes 200)."
        ),
    ] = "all",
    methods: Annotated[
        list[str] | None,
        typer.Option(
            help="Run only these methods (repeat or separate by commas; names as in the "
            "tables' keys, e.g. muc-osl,col-inf); the others' stored rows are still shown, and "
            "the same command without it later adds them."
        ),
    ] = None,
    list_: Annotated[
        bool,
        typer.Option(
            "--list", help="List the reproductions (with a name: describe only that one)."
        ),
    ] = False,
    progress: Annotated[
        bool, typer.Option(help="Live progress bar (the tables are printed either way).")
    ] = True,
) -> None:
    """Reproduce a paper's headline comparison: table beside the paper's numbers, figures, report.

    Results are stored as they finish; running the same command again resumes. Episodes that
    fail are stored as error rows (tracebacks in `errors.log`): one summary line goes to stderr
    and the exit status is 1, after the tables, figures and report of the rest. `--list` names
    each reproduction with its paper's full reference.
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
        width = max(min(console.width, 100) - 4, 40)
        for k, n in enumerate(shown):
            r = rp.get(n)
            if k:
                console.print()
            console.print(f"[bold]{escape(n)}[/]", highlight=False)
            text = (
                f"{r.summary}. Default {r.default_episodes} episode(s) per cell; the paper's "
                f"count: --episodes {r.paper_episodes}"
                + (f" ({r.paper_episodes_note})" if r.paper_episodes_note else "")
                + "."
            )
            cited = [f"Paper: {c}" for c in r.citations] or [r.reference_text()]
            for para in (text, *cited):
                for line in textwrap.wrap(para, width=width, break_on_hyphens=False):
                    console.print(f"    {escape(line)}", highlight=False)
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
        _check_outputs(target, REPRODUCE_OUTPUTS)
        parts = _names(only) if only else None
        if only and not parts:
            raise ConfigError("--only", "names no sweep")
        wanted = _names(methods) if methods else None
        if methods and not wanted:
            raise ConfigError("--methods", "names no method")
        outcome = r.run(
            target,
            episodes=episodes,
            workers=workers,
            seed=seed,
            backend=backend,
            scheduler=scheduler,
            only=parts,
            progress=progress,
            points=points,
            methods=wanted,
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
        elif exc.field in ("scheduler", "out", "points"):
            exc = ConfigError(f"--{exc.field}", exc.problem)
        _fail(str(exc))
        return
    except OdorlocError as exc:
        _fail(str(exc))
        return
    # the tables, figures and report are written; failed episodes make the exit status 1
    if _report_failures("reproduce", outcome.results, target):
        raise typer.Exit(code=1)


#: Files ``odorloc replay-log`` writes into ``--out``.
REPLAY_OUTPUTS = ("belief.png", "recording.npz")


def _xy(p: Any) -> str:
    return "(" + ", ".join(f"{float(v):.2f}" for v in p) + ") m"


@app.command("replay-log")
def replay_log(
    bag: Annotated[Path, typer.Argument(help="ROS 1 (.bag) or ROS 2 (folder) bag.")],
    topics: Annotated[
        Path,
        typer.Option(help="YAML mapping topics and fields (docs/how-to/ros-bags.md)."),
    ],
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
    """Replay an estimator offline over a recorded robot log; print, draw and store its
    estimate.

    Needs the `ros` extra (`pip install odorloc[ros]`). The search area is the topics file's
    `arena`; without one it is the driven path's extent plus `margin` (1 m by default) on
    every side, and an estimate on that area's edge is warned about (the source may lie beyond
    it). The estimate is the estimator's own sources where it has them (the mapped sources of
    ds-mapping), else its belief's mean; with `sources` in the topics file it is scored
    against them. Writes `belief.png` and `recording.npz` (the estimate in its metadata) into
    `--out`. The topics file is described in the documentation's how-to guide "Replay a ROS
    bag" (`docs/how-to/ros-bags.md`).
    """
    try:
        check_seed(seed, "--seed")
        _check_outputs(out, REPLAY_OUTPUTS)
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
            log.observations(),
            log.context(),
            estimator,
            seed=seed,
            sources=src,
            name=bag.name,
            success_radius=log.mapping.success_radius,
        )
    except OdorlocError as exc:
        _fail(str(exc))
        return
    m = rec.meta
    default_area = log.mapping.arena is None
    m["search_area_rule"] = (
        f"path's extent + {log.mapping.margin:g} m" if default_area else "topics file's arena"
    )
    try:
        out.mkdir(parents=True, exist_ok=True)
        plot_belief_map(rec, out / "belief.png")
        rec.save(out / "recording.npz")
    except OSError as exc:
        _fail(f"--out: cannot write into {out}: {exc.strerror or exc}")
        return
    console.print(
        f"{m['steps']} periods, {m['detections']} with a detection, "
        f"{len(rec.beliefs)} belief snapshot(s)"
    )
    lo, hi = m["search_area"]
    console.print(
        f"search area [{lo[0]:.2f}, {hi[0]:.2f}] x [{lo[1]:.2f}, {hi[1]:.2f}] m "
        f"({m['search_area_rule']})",
        highlight=False,
    )
    est = m["estimates"]
    what = "mapped source(s)" if m["estimate_kind"] == "sources" else "belief mean"
    if est:
        console.print(
            f"{escape(estimator)} estimate ({what}): " + ", ".join(_xy(e) for e in est),
            highlight=False,
        )
    elif m["estimate_kind"] == "sources":
        console.print(f"{escape(estimator)} mapped no source", highlight=False)
    else:
        console.print(f"{escape(estimator)} recorded no belief: no estimate", highlight=False)
    if "loc_error" in m:
        n_src = len(rec.sources)
        console.print(
            f"against {n_src} known source(s): loc_error {m['loc_error']:.2f} m (mean distance "
            f"from each source to the nearest estimate); {m['sources_found']} of {n_src} found "
            f"within {m['success_radius']:g} m; {m['false_sources']} false",
            highlight=False,
        )
    for i in m["on_edge"]:
        hint = " (set arena or a larger margin in the topics file)" if default_area else ""
        err_console.print(
            f"warning: estimate {_xy(est[i])} lies within {m['edge_tolerance']:.2f} m of the "
            f"search area's edge: the source may be outside it{hint}",
            highlight=False,
            soft_wrap=True,
        )
    for p in (out / "belief.png", out / "recording.npz"):
        console.print(f"wrote {p}")


def _settings(items: list[str] | None, field: str) -> dict[str, Any]:
    """``KEY=VALUE`` options as a dict (values read as YAML scalars or lists)."""
    from odorloc.core.loading import parse_yaml

    out: dict[str, Any] = {}
    for item in items or []:
        key, eq, text = item.partition("=")
        key = key.strip()
        if not eq or not key or not text.strip():
            raise ConfigError(field, f"expected KEY=VALUE, got {item!r}")
        if key in out:
            raise ConfigError(field, f"{key} is given twice")
        out[key] = parse_yaml(text, field, f"{field} {key}")
    return out


@app.command("map")
def map_(
    source: Annotated[
        Path, typer.Argument(help="A recording (.npz, e.g. from `odorloc run`) or a ROS bag.")
    ],
    method: Annotated[
        str, typer.Option(help="Gas map (kernel-dmv, kernel-dmvw, td-kernel-dmv, gmrf).")
    ] = "kernel-dmv",
    cell_size: Annotated[
        float | None,
        typer.Option(
            help="Cell side, m (default: a recording's plume-frame cells, scored against the "
            "time-averaged truth; else 0.25, coarser in a large arena)."
        ),
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="A map parameter, KEY=VALUE (repeat for several)."),
    ] = None,
    select: Annotated[
        list[str] | None,
        typer.Option(
            help="Choose a parameter by cross-validated NLPD among values, KEY=[V1, V2, ...] "
            "(repeat for several; cell_size too)."
        ),
    ] = None,
    topics: Annotated[
        Path | None, typer.Option(help="For a bag: the YAML mapping its topics (see docs).")
    ] = None,
    agent: Annotated[
        list[int] | None, typer.Option(help="Map only these agents' readings (repeat).")
    ] = None,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("odorloc-map"),
) -> None:
    """Build a gas distribution map from a recording or a robot log.

    Writes gas-map.png (mean, standard deviation, confidence; the
    time-averaged truth beside them when the recording holds plume frames
    on the map's cells) and gas-map.npz (mean, variance, confidence, lower,
    upper) into --out.
    """
    import numpy as np

    from odorloc.core import registry

    try:
        check_output_dir(out, "--out")
        registry.entry("gas_map", method, field="--method")
        params = _settings(set_, "--set")
        candidates = _settings(select, "--select")
        for key, values in candidates.items():
            if not isinstance(values, list) or not values:
                raise ConfigError(f"--select {key}", "needs a list of values, e.g. [0.1, 0.2]")
            if key in params:
                raise ConfigError(f"--select {key}", "is also given with --set")
        if cell_size is not None:
            if not (math.isfinite(cell_size) and cell_size > 0):
                raise ConfigError("--cell-size", f"must be a finite number > 0, got {cell_size}")
            if "cell_size" in params:
                raise ConfigError("--set cell_size", "is also given with --cell-size")
            params["cell_size"] = cell_size
        # every value is checked against the method's parameters before any data is read
        try:
            checked = registry.make_params("gas_map", method, params)
            for key, values in candidates.items():
                for v in values:
                    registry.make_params("gas_map", method, {**params, key: v})
        except ConfigError as exc:
            raise ConfigError(f"--set {exc.field}", exc.problem) from None
        if not source.exists():
            raise ConfigError("source", f"{source} does not exist")
        from odorloc.experiments.gas_maps import (
            default_cell_size,
            map_readings,
            map_recording,
            readings_from_observations,
        )
        from odorloc.inference.gas_map.base import map_grid

        if source.is_file() and source.suffix not in (".npz", ".bag"):
            raise ConfigError(
                "source",
                f"{source.name} is neither a recording (.npz) nor a ROS bag (.bag, or a folder)",
            )
        if source.is_file() and source.suffix == ".npz":
            if topics is not None:
                raise ConfigError("--topics", "is for bags; the source is a recording")
            from odorloc.engine.recorder import Recording

            try:
                rec = Recording.load(source)
            except (OSError, ValueError, KeyError) as exc:
                raise ConfigError("source", f"{source} is not a recording ({exc})") from None
            cell = checked.cell_size if "cell_size" in params else None  # type: ignore[attr-defined]
            result = map_recording(rec, method, params, cell, candidates, agent)
            sources = np.asarray(rec.sources, float)
        else:
            if topics is None:
                raise ConfigError("--topics", "a bag needs the YAML mapping its topics")
            if agent:
                raise ConfigError("--agent", "a bag holds one robot's readings")
            try:
                from odorloc.replay.bag import BagLog, load_mapping
            except ImportError:
                raise ConfigError(
                    "bag", "reading bags needs the ros extra (pip install odorloc[ros])"
                ) from None
            log = BagLog(source, load_mapping(topics))
            ctx = log.context()
            readings = readings_from_observations(log.observations(), ctx.dim)
            lo, hi = ctx.arena.lower, ctx.arena.upper
            cell = default_cell_size(lo, hi)
            if "cell_size" in params:
                cell = float(checked.cell_size)  # type: ignore[attr-defined]
            grid = map_grid(lo, hi, cell, "--cell-size")
            result = map_readings(readings, grid, method, params, ctx.arena, candidates)
            sources = np.asarray(log.mapping.sources or np.zeros((0, ctx.dim)), float)
        gm = result.gas_map
        mean, var, conf = gm.mean(), gm.variance(), gm.confidence()
        maxima = gm.estimate()
    except OdorlocError as exc:
        _fail(str(exc))
        return
    from odorloc.experiments.gas_maps import score_map
    from odorloc.viz.gas_map import plot_gas_map

    grid = gm.grid
    lines = [
        f"{len(result.readings)} readings, {method} on {' x '.join(map(str, grid.shape))} cells "
        f"of {' x '.join(f'{c:.3g}' for c in grid.cells)} m"
    ]
    if result.selection is not None:
        chosen = ", ".join(f"{k}={v}" for k, v in result.selection.best.items())
        lines.append(f"selected by cross-validated NLPD: {chosen}")
    for k, p in enumerate(maxima):
        lines.append(f"map maximum {k}: ({', '.join(f'{v:.2f}' for v in p)}) m")
    if len(sources) and result.truth is not None:
        sc = score_map(gm, result.truth, sources)
        lines.append(f"against the time-averaged truth: RMSE {sc['rmse']:.3g}, KL {sc['kl']:.3g}")
    for i, s in enumerate(sources):
        if len(maxima):
            d = float(np.min(np.linalg.norm(maxima[:, : len(s)] - s[: grid.dim], axis=1)))
            lines.append(f"source {i}: {d:.2f} m from the nearest map maximum")
    try:
        out.mkdir(parents=True, exist_ok=True)
        png, npz = out / "gas-map.png", out / "gas-map.npz"
        plot_gas_map(
            grid,
            mean,
            var,
            conf,
            png,
            blocked=gm.blocked,
            positions=result.readings.positions,
            sources=sources if len(sources) else None,
            maxima=maxima,
            truth=result.truth,
            title=f"{source.name}: {method}",
        )
        np.savez_compressed(
            npz,
            mean=mean,
            variance=var,
            confidence=conf,
            lower=np.asarray(grid.lower),
            upper=np.asarray(grid.upper),
        )
    except OSError as exc:
        _fail(f"--out: cannot write into {out}: {exc.strerror or exc}")
        return
    for line in lines:
        console.print(line, highlight=False)
    for p in (png, npz):
        console.print(f"wrote {p}")


@app.command()
def components(
    name: Annotated[
        str | None,
        typer.Argument(help="Describe this component: its parameters with type, default, unit."),
    ] = None,
    family: Annotated[
        str | None,
        typer.Option(help="The family, where a name serves several (e.g. plume or model)."),
    ] = None,
) -> None:
    """List every registered component, or describe one with all its parameters.

    A component is named in a scenario as `{type: NAME, parameter: value, ...}`; the listing
    gives each family's members with a one-line summary.
    """
    import textwrap

    from odorloc.core import describe, registry
    from odorloc.experiments.reproduction import discover

    discover()  # the papers' reproductions are listed and described too
    width = max(min(console.width, 100), 40)
    try:
        if name is None:
            if family is not None and family not in registry.families():
                known = ", ".join(registry.families())
                raise ConfigError("--family", f"unknown family {family!r} (known: {known})")
            for fam in [family] if family else registry.families():
                console.print(f"[bold]{escape(fam)}[/]", highlight=False)
                entries = registry.entries(fam)
                pad = max(len(e.name) for e in entries) + 2
                for e in entries:
                    text = describe.plain(e.summary)
                    lines = textwrap.wrap(text, width=max(width - pad - 2, 20)) or [""]
                    console.print(f"  {e.name:<{pad}}{escape(lines[0])}", highlight=False)
                    for more in lines[1:]:
                        console.print(f"  {'':<{pad}}{escape(more)}", highlight=False)
                console.print()
            console.print(
                "odorloc components NAME describes one, with its parameters.", highlight=False
            )
            return
        hits = [(family, name)] if family is not None else describe.find(name)
        for k, (fam, n) in enumerate(hits):
            if k:
                console.print()
            text = describe.render_text(describe.describe(fam, n), width=width)
            console.print(escape(text), highlight=False, end="", soft_wrap=True)
    except OdorlocError as exc:
        _fail(str(exc))


bench_app = typer.Typer(
    cls=_OneLineErrors,
    help="The benchmark: a versioned suite of tasks, every method that can run them, a board.",
    no_args_is_help=True,
    rich_markup_mode="markdown",
)
app.add_typer(bench_app, name="bench")


def _names(values: list[str] | None) -> list[str]:
    """Repeated or comma-separated option values, in order, without repeats."""
    out: list[str] = []
    for v in values or []:
        for part in v.split(","):
            part = part.strip()
            if part and part not in out:
                out.append(part)
    return out


@bench_app.command("run")
def bench_run(
    tier: Annotated[
        str, typer.Option(help="quick (minutes) or standard (the published board).")
    ] = ("quick"),
    tasks: Annotated[
        list[str] | None, typer.Option("--tasks", help="Task names (repeat or comma-separate).")
    ] = None,
    methods: Annotated[
        list[str] | None,
        typer.Option("--methods", help="Only these methods (registered names)."),
    ] = None,
    method: Annotated[
        list[str] | None,
        typer.Option(
            "--method", help="Add a method: `package.module:Searcher` or a YAML preset file."
        ),
    ] = None,
    suite: Annotated[str, typer.Option(help="Suite version or file.")] = "2027.1",
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("odorloc-bench"),
    backend: Annotated[str, typer.Option(help="local (process pool) or dask.")] = "local",
    workers: Annotated[int, typer.Option(help="Worker processes.")] = 2,
    scheduler: Annotated[
        str | None, typer.Option(help="Join a running Dask scheduler (tcp://host:port).")
    ] = None,
    html: Annotated[bool, typer.Option(help="Write the HTML leaderboard and figures.")] = True,
    episodes: Annotated[
        int | None, typer.Option(help="Episodes per method instead of the tier's (a trial run).")
    ] = None,
    progress: Annotated[bool, typer.Option(help="Live progress bars.")] = True,
) -> None:
    """Run (or resume) the suite: every method that can run each task, on the sweep harness.

    Writes `results.json` (the board, documented schema), `leaderboard.html` and `figures/`
    into `--out`, and one resumable store per task under `stores/`.
    """
    from odorloc.experiments.bench import run_bench
    from odorloc.experiments.bench.board import text_board

    try:
        _check_count(workers, "--workers", 1, 1024)
        backend = _check_backend(backend, scheduler)
        doc = run_bench(
            out,
            suite=suite,
            tier=tier,
            tasks=_names(tasks),
            methods=_names(methods),
            extra=_names(method),
            backend=backend,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
            html=html,
            episodes=episodes,
        )
    except OdorlocError as exc:
        _fail(str(_renamed(exc, "scheduler", "--scheduler")))
        return
    console.print(escape(text_board(doc, width=console.width or 80)), highlight=False)
    console.print(f"wall time {doc['wall_time_s']:.0f} s", highlight=False)
    console.print(f"wrote {escape(str(out / 'results.json'))}", highlight=False)
    if html:
        console.print(f"wrote {escape(str(out / 'leaderboard.html'))}", highlight=False)


@bench_app.command("compare")
def bench_compare(
    a: Annotated[Path, typer.Argument(help="Results JSON (the baseline).")],
    b: Annotated[Path, typer.Argument(help="Results JSON (the new run).")],
    fail_on_worse: Annotated[
        bool, typer.Option(help="Exit with status 1 when anything got worse.")
    ] = False,
) -> None:
    """What got better or worse from A to B: a value of B outside A's 95 % interval."""
    from odorloc.experiments.bench import compare_results, load_results

    try:
        diff = compare_results(load_results(a, "A"), load_results(b, "B"))
    except OdorlocError as exc:
        _fail(str(exc))
        return
    changes = diff["changes"]
    if not changes:
        console.print("no change beyond the intervals", highlight=False)
    else:
        t = Table(title="changes beyond A's 95 % interval", title_justify="left")
        for col in ("task", "method", "metric", "A [interval]", "B", "verdict"):
            t.add_column(col)
        for c in changes:
            t.add_row(
                c["task"],
                c["method"],
                c["metric"],
                f"{c['a']:.3g} [{c['a_lo']:.3g}, {c['a_hi']:.3g}]",
                f"{c['b']:.3g}",
                c["verdict"],
            )
        console.print(t)
    for what in ("added", "removed"):
        rows = diff[what]
        if len(rows) > 8:
            tasks = sorted({r.split("/", 1)[0] for r in rows})
            console.print(f"{what}: {len(rows)} rows of {', '.join(tasks)}", highlight=False)
        elif rows:
            console.print(f"{what}: {', '.join(rows)}", highlight=False)
    if fail_on_worse and any(c["verdict"] == "worse" for c in changes):
        raise typer.Exit(code=1)


@bench_app.command("board")
def bench_board(
    results: Annotated[Path, typer.Argument(help="Results JSON of `odorloc bench run`.")],
    out: Annotated[
        Path | None, typer.Option(help="Folder for leaderboard.html and its figures.")
    ] = None,
    markdown: Annotated[
        Path | None, typer.Option(help="Write the board as Markdown tables to this file.")
    ] = None,
) -> None:
    """Draw the board of a results file again: the HTML leaderboard, or Markdown tables."""
    from odorloc.experiments.bench import load_results
    from odorloc.experiments.bench.board import markdown_board, text_board, write_leaderboard

    try:
        doc = load_results(results, "results")
        if out is not None:
            check_output_dir(out, "--out")
        if markdown is not None:
            check_output_file(markdown, "--markdown")
    except OdorlocError as exc:
        _fail(str(exc))
        return
    console.print(escape(text_board(doc, width=console.width or 80)), highlight=False)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        console.print(f"wrote {escape(str(write_leaderboard(doc, out)))}", highlight=False)
    if markdown is not None:
        markdown.write_text(markdown_board(doc), encoding="utf-8")
        console.print(f"wrote {escape(str(markdown))}", highlight=False)


@bench_app.command("tasks")
def bench_tasks(
    suite: Annotated[str, typer.Option(help="Suite version or file.")] = "2027.1",
) -> None:
    """List the suite's tasks: scenario, success rule, episodes per tier."""
    from odorloc.experiments.bench import load_suite

    try:
        s = load_suite(suite)
    except OdorlocError as exc:
        _fail(str(exc))
        return
    console.print(f"suite {s.suite} (root seed {s.seed})", highlight=False)
    for t in s.tasks:
        eps = ", ".join(f"{k} {v}" for k, v in t.episodes.items())
        console.print(f"\n[bold]{escape(t.name)}[/] ({escape(t.scenario)}; {eps} episodes)")
        console.print(f"    {escape(t.rule)}", highlight=False)


def main() -> None:
    """Entry point of the ``odorloc`` script."""
    app()


if __name__ == "__main__":
    main()
