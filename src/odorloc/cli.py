"""The ``odorloc`` command line.

Every command validates its input first; invalid input prints one line naming the field and
exits with code 2 (no traceback).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from odorloc.core.errors import ConfigError, OdorlocError
from odorloc.core.seeds import check_seed

app = typer.Typer(
    help="odorloc: simulate odor plumes and robots, run and compare odor source localization.",
    no_args_is_help=False,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


def _fail(msg: str) -> None:
    err_console.print(f"[bold red]error:[/] {msg}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


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
) -> None:
    """Run one episode, print a summary and write the figures and the animation.

    Episode I of root seed R is exactly episode I of ``odorloc batch`` with ``--seed R`` and the
    same scenario (given the same way, name or file path).
    """
    from odorloc.core.seeds import episode_seeds
    from odorloc.engine.episode import run_episode
    from odorloc.scenarios import DEFAULT_SCENARIO, get_scenario
    from odorloc.viz.episode import animate, ffmpeg_available, plot_traces, plot_trajectory

    try:
        sc = get_scenario(scenario or DEFAULT_SCENARIO)
        if searcher:
            from odorloc.experiments.runner import cell_scenario

            sc = cell_scenario({"scenario": scenario or DEFAULT_SCENARIO, "searcher": searcher})
        if seed is not None:
            sc = sc.model_copy(update={"seed": check_seed(seed, "--seed")})
        if episode < 0:
            raise ConfigError("--episode", f"must be >= 0, got {episode}")
        world_seed, agent_seed = episode_seeds(sc.seed, scenario or DEFAULT_SCENARIO, episode)
        console.print(
            f"running [bold]{sc.name}[/] with searcher [bold]{sc.searcher.type}[/], "
            f"root seed {sc.seed}, episode {episode}"
        )
        res = run_episode(sc, world_seed, agent_seed, record=True)
    except OdorlocError as exc:
        _fail(str(exc))
        return
    rec = res.recording
    assert rec is not None
    rec.meta.update(searcher=sc.searcher.type, seed=sc.seed, episode=episode)
    out.mkdir(parents=True, exist_ok=True)
    table = Table(title=f"{sc.name} — {sc.searcher.type} — seed {sc.seed}, episode {episode}")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for k in (
        "success",
        "termination",
        "search_time",
        "loc_error",
        "path_length",
        "first_detection_time",
        "energy",
        "bytes",
        "start_distance",
        "steps",
        "wall_time",
        "wall_per_step_ms",
    ):
        table.add_row(k, _fmt(res.metrics.get(k)))
    console.print(table)
    written = [
        plot_trajectory(rec, out / "trajectory.png") and out / "trajectory.png",
        plot_traces(rec, out / "traces.png") and out / "traces.png",
        rec.save(out / "recording.npz"),
    ]
    if rec.positions.shape[2] == 3:
        from odorloc.viz.team3d import plot_team_3d

        plot_team_3d(rec, out / "view_3d.png")
        written.append(out / "view_3d.png")
    sc.to_yaml(out / "scenario.yaml")
    written.append(out / "scenario.yaml")
    if animation:
        written.append(animate(rec, out / "episode.gif", max_frames=frames))
        if ffmpeg_available():
            written.append(animate(rec, out / "episode.mp4", max_frames=frames))
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
    episodes: Annotated[int, typer.Option(help="Episodes per cell, without a sweep file.")] = 10,
    seed: Annotated[int, typer.Option(help="Root seed, without a sweep file.")] = 0,
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
    ``results.sqlite``, ``results.csv`` and ``results.parquet`` into ``--out``.
    """
    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import run_sweep

    if sweep is None:
        if not scenario:
            _fail("batch: give a sweep file or at least one --scenario")
        spec: Any = {
            "name": "cli-batch",
            "seed": seed,
            "episodes": episodes,
            "scenarios": [{"name": s} for s in scenario or []],
            "searchers": [{"name": a} for a in (searcher or [])] or None,
        }
        if spec["searchers"] is None:
            from odorloc.scenarios import get_scenario

            try:
                names = sorted({get_scenario(s).searcher.type for s in scenario or []})
            except OdorlocError as exc:
                _fail(str(exc))
            spec["searchers"] = [{"name": n} for n in names]
    else:
        spec = sweep
    out.mkdir(parents=True, exist_ok=True)
    store_path = out / "results.sqlite"
    try:
        df = run_sweep(
            spec,
            store_path,
            backend=backend,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
    except OdorlocError as exc:
        _fail(str(exc))
        return
    with ResultStore(store_path, readonly=True) as store:
        csv = store.to_csv(out / "results.csv")
        pq = store.to_parquet(out / "results.parquet")
    errors = df[df["status"] == "error"] if len(df) else df
    if len(errors):
        log = out / "errors.log"
        with log.open("w") as fh:
            for r in errors.itertuples():
                fh.write(f"== {r.cell_id} episode {r.episode}\n{r.error}\n\n")
        console.print(f"{len(errors)} episode(s) failed; tracebacks in {log}")
    console.print(f"{len(df)} episodes -> {store_path}, {csv}, {pq}")


@app.command()
def report(
    results: Annotated[Path, typer.Argument(help="Results store (.sqlite) or CSV/Parquet export.")],
    out: Annotated[Path | None, typer.Option(help="HTML file to write.")] = None,
) -> None:
    """Write a self-contained HTML report (tables with intervals, figures, episode viewer)."""
    from odorloc.experiments.report import report_main

    target = out or results.with_suffix(".html")
    try:
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
    list_: Annotated[bool, typer.Option("--list", help="List the reproductions.")] = False,
) -> None:
    """Reproduce a paper's headline comparison: table beside the paper's numbers, figures, report.

    Results are stored as they finish; running the same command again resumes.
    """
    from odorloc.experiments import reproduction as rp

    if list_ or not paper:
        for n in rp.names_of_reproductions():
            r = rp.get(n)
            console.print(
                f"[bold]{n}[/]  ({r.paper}) {r.summary}; default {r.default_episodes} "
                f"episode(s) per cell, the paper's {r.paper_episodes}"
            )
        return
    try:
        r = rp.get(paper)
        check_seed(seed, "--seed")
        if episodes is not None and episodes < 1:
            raise ConfigError("--episodes", "must be >= 1")
        r.run(
            out or Path("odorloc-reproduce") / paper,
            episodes=episodes,
            workers=workers,
            seed=seed,
            backend="dask" if scheduler else backend,
            scheduler=scheduler,
            only=[w.strip() for o in only for w in o.split(",") if w.strip()] if only else None,
        )
    except OdorlocError as exc:
        _fail(str(exc))


@app.command("replay-log")
def replay_log(
    bag: Annotated[Path, typer.Argument(help="ROS 1 (.bag) or ROS 2 (folder) bag.")],
    topics: Annotated[Path, typer.Option(help="YAML mapping topics and fields (see docs).")],
    estimator: Annotated[
        str,
        typer.Option(
            help="Searcher whose belief to replay (pf-entropy, ds-mapping, ...) or odor-path."
        ),
    ] = "pf-entropy",
    seed: Annotated[int, typer.Option(help="Seed of the estimator's random stream.")] = 0,
    out: Annotated[Path, typer.Option(help="Output folder.")] = Path("odorloc-replay"),
) -> None:
    """Replay an estimator offline over a recorded robot log; plot its belief on the map.

    Needs the ``ros`` extra (``pip install odorloc[ros]``). Writes ``belief.png`` and
    ``recording.npz`` into ``--out``.
    """
    try:
        check_seed(seed, "--seed")
        try:
            from odorloc.replay.bag import BagLog
        except ImportError:
            raise ConfigError(
                "bag", "reading bags needs the ros extra (pip install odorloc[ros])"
            ) from None
        import numpy as np

        from odorloc.replay.offline import replay_estimator
        from odorloc.viz.episode import plot_belief_map

        log = BagLog(bag, topics)
        src = np.asarray(log.mapping.sources, float) if log.mapping.sources else None
        rec = replay_estimator(
            log.observations(), log.context(), estimator, seed=seed, sources=src, name=bag.name
        )
    except OdorlocError as exc:
        _fail(str(exc))
        return
    out.mkdir(parents=True, exist_ok=True)
    plot_belief_map(rec, out / "belief.png")
    rec.save(out / "recording.npz")
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
    try:
        app()
    except ConfigError as exc:  # pragma: no cover - commands handle their own
        err_console.print(f"error: {exc}")
        sys.exit(2)


if __name__ == "__main__":
    main()
