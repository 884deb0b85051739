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

from odorloc.errors import ConfigError, OdorlocError

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
        typer.Argument(help="Built-in scenario name or scenario YAML file (default: the main job)."),
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Episode seed (default: the scenario's).")] = None,
    searcher: Annotated[
        str | None, typer.Option(help="Replace the scenario's searcher (registry name).")
    ] = None,
    out: Annotated[Path, typer.Option(help="Output folder for figures, animation, recording.")] = Path(
        "odorloc-out"
    ),
    animation: Annotated[bool, typer.Option(help="Write the animation (GIF, and MP4 with ffmpeg).")] = True,
    frames: Annotated[int, typer.Option(help="Maximum number of animation frames.")] = 120,
) -> None:
    """Run one episode, print a summary and write the figures and the animation."""
    from odorloc.engine.episode import run_episode, seeds_for
    from odorloc.scenarios import DEFAULT_SCENARIO, get_scenario
    from odorloc.viz.episode import animate, ffmpeg_available, plot_traces, plot_trajectory

    try:
        sc = get_scenario(scenario or DEFAULT_SCENARIO)
        if searcher:
            from odorloc.experiments.runner import cell_scenario

            sc = cell_scenario({"scenario": scenario or DEFAULT_SCENARIO, "searcher": searcher})
        if seed is not None:
            sc = sc.model_copy(update={"seed": seed})
        world_seed, agent_seed = seeds_for(sc.seed, 0)
        console.print(f"running [bold]{sc.name}[/] with searcher [bold]{sc.searcher.type}[/], seed {sc.seed}")
        res = run_episode(sc, world_seed, agent_seed, record=True)
    except OdorlocError as exc:
        _fail(str(exc))
        return
    rec = res.recording
    assert rec is not None
    rec.meta.update(searcher=sc.searcher.type, seed=sc.seed)
    out.mkdir(parents=True, exist_ok=True)
    table = Table(title=f"{sc.name} — {sc.searcher.type} — seed {sc.seed}")
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
def components() -> None:
    """List every registered component (wind, plume, sensors, platforms, searchers)."""
    from odorloc import registry

    table = Table(title="components")
    table.add_column("family")
    table.add_column("name")
    table.add_column("summary")
    for fam in ("wind", "plume", "gas_sensor", "anemometer", "platform", "searcher"):
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
