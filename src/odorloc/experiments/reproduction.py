"""The common shape of a paper reproduction: a stored sweep, tables beside the paper, figures.

A reproduction (registry family ``"reproduction"``) lives in its paper package
(``odorloc/papers/<paper>/reproduction.py``) and subclasses :class:`Reproduction`. The core
registry does not search the papers: this module adds ``odorloc.papers`` to its discovery
(:func:`discover`) when a reproduction is asked for, and then only the modules that register a
reproduction are imported.

- :meth:`Reproduction.sweep` gives the sweep (scenarios x searchers x grids x episodes, the
  ``replay`` option for record-once/replay-many); it runs through the ordinary harness, so it is
  stored as it goes, resumes after a kill, and runs on the local pool or on Dask. A reproduction
  made of several sweeps (different worlds, a ``replay`` flag for some, searcher grids that must
  not cross every scenario) overrides :meth:`Reproduction.sweeps` instead: each named sweep has
  its own store ``<name>.sqlite``, ``run(only=...)`` runs some of them and reads the others'
  stored rows, and the tables and figures see all rows with a ``sweep`` column;
- :meth:`Reproduction.tables` turns the stored rows into compact tables printed beside the
  paper's numbers (wide tables go to CSV and the report);
- :meth:`Reproduction.figures` draws the paper's figures; each figure is drawn on its own, so
  one that fails is reported and never takes the tables, the other figures or the report down.

:meth:`Reproduction.run` is the template every reproduction follows.
"""

from __future__ import annotations

import math
import numbers
import re
import shutil
import textwrap
import time
import traceback
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.loading import check_output_dir, check_output_file
from odorloc.core.params import Params

__all__ = [
    "CONSOLE_WIDTH",
    "Citation",
    "Figure",
    "Reproduction",
    "ReproductionParams",
    "Table",
    "check_time_limit",
    "console_headers",
    "console_table",
    "discover",
    "fmt",
    "get",
    "names_of_reproductions",
    "select_sweeps",
]


class ReproductionParams(Params):
    """Reproductions take their options at :meth:`Reproduction.run`, not as parameters."""


@dataclass(frozen=True)
class Citation:
    """A published paper as a reproduction cites it.

    Attributes
    ----------
    authors : str
        The authors as the paper lists them (``"Ye, X.; Guo, B.; ..."``).
    title : str
    venue : str
        Journal or proceedings with volume, issue and pages where known (``""``: unknown).
    year : int or None
    doi : str
        The DOI without its resolver (``"10.3390/..."``), ``""`` when none is known.
    note : str
        What our copy of the paper does not say (e.g. that its title page is missing).
    """

    authors: str
    title: str
    venue: str = ""
    year: int | None = None
    doi: str = ""
    note: str = ""

    def __str__(self) -> str:
        parts = [self.authors or "", f"({self.year})" if self.year else "", f'"{self.title}".']
        text = " ".join(p for p in parts if p)
        if self.venue:
            text += f" {self.venue}."
        if self.doi:
            text += f" https://doi.org/{self.doi}"
        if self.note:
            text += f" [{self.note}]"
        return text


@dataclass
class Table:
    """A result table: a title, headers, formatted rows, and whether to print it.

    Wide tables (``console=False``) go only to CSV and the report. The first ``left`` columns
    are aligned left on the console (text, wrapped when long), the others right (numbers).
    """

    name: str
    title: str
    headers: list[str]
    rows: list[list[str]]
    console: bool = True
    note: str = ""
    left: int = 1
    """Leading text columns (left-aligned); the others are numbers (right-aligned)."""
    widths: tuple[int, ...] = ()
    """Console share of each text column when the table must wrap (empty: by content)."""


@dataclass
class Figure:
    """A figure to draw: a file name, a caption and the function that draws it to a path."""

    name: str
    caption: str
    draw: Callable[[Path], Any]


def check_time_limit(value: object, field: str = "time_limit") -> float | None:
    """A reproduction's shorter episode limit: ``None`` or a finite number of seconds > 0, as a
    float. Anything else (a bool, a string, NaN, inf, zero or less) is refused with a
    :class:`~odorloc.core.errors.ConfigError` naming ``field``: a bool is an int to Python, and
    ``True`` would silently run 1 s episodes."""
    if value is None:
        return None
    # NumPy's scalars are numbers.Real too; a bool (Python's or NumPy's) is not a duration
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(field, f"must be a finite number of seconds > 0, got {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise ConfigError(field, f"must be a finite number of seconds > 0, got {value!r}")
    return float(value)


def fmt(x: Any, digits: int = 1) -> str:
    """A number for a table: ``-`` for NaN/None."""
    if x is None:
        return "-"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "-" if math.isnan(v) else f"{v:.{digits}f}"


@dataclass
class Outcome:
    """What :meth:`Reproduction.run` produced."""

    results: Any
    tables: list[Table] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    failed_figures: list[str] = field(default_factory=list)
    report: Path | None = None
    wall_time: float = math.nan
    stores: dict[str, Path] = field(default_factory=dict)


class Reproduction:
    """Base class of paper reproductions (see the module docstring).

    Class attributes
    ----------------
    name, paper, summary : str
        Registry name, the paper's file in ``shared/papers``, a one-line description.
    citations : tuple of Citation
        The full reference of each paper reproduced (``--list``, the report).
    default_episodes : int
        Episodes per cell of the default run (fits the issue's time budget on 2 cores).
    paper_episodes : int
        The paper's own count (``--episodes`` reaches it).
    paper_episodes_note : str
        What ``--list`` adds about that count (e.g. that no paper fixes one).
    report_paired : bool
        Include the generic paired comparisons of every two cells of a world in the report
        (a reproduction with many cells per world and its own paired tables turns them off).
    success_column, success_label : str
        The row column that says an episode succeeded by the paper's own criterion (default
        the episode's ``success``) and what it means; the console tables and every table of
        the report count that column, so they say one thing.
    cell_summary : bool
        Print the harness's per-cell summary before the reproduction's own tables (off for
        sweeps of many cells, whose compact tables say it better; never printed when the
        reproduction counts success by a column of its own, so the console says one thing).
    """

    name: ClassVar[str] = ""
    paper: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    citations: ClassVar[tuple[Citation, ...]] = ()
    default_episodes: ClassVar[int] = 10
    paper_episodes: ClassVar[int] = 10
    paper_episodes_note: ClassVar[str] = ""
    report_paired: ClassVar[bool] = True
    success_column: ClassVar[str] = "success"
    success_label: ClassVar[str] = ""
    cell_summary: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # a reproduction is its sweeps: refuse one that defines neither when it is declared
        if cls.sweep is Reproduction.sweep and cls.sweeps is Reproduction.sweeps:
            raise TypeError(f"{cls.__name__} must define sweep() or sweeps()")

    def __init__(self, params: ReproductionParams | None = None) -> None:
        self.params = params or ReproductionParams()

    # ------------------------------------------------------------------ to override
    def sweep(self, episodes: int, seed: int) -> dict[str, Any]:
        """The sweep specification (see :mod:`odorloc.experiments.sweep`) of a one-sweep
        reproduction; a reproduction of several sweeps overrides :meth:`sweeps` instead."""
        raise TypeError(f"{type(self).__name__} runs several sweeps: call sweeps()")

    #: Whether the reproduction sweeps points around a default one (``points="default"``).
    has_points: ClassVar[bool] = False

    def select_points(self, points: str) -> None:
        """Keep ``"all"`` points (the only choice here) or only the ``"default"`` one.

        Raises
        ------
        ConfigError
            Naming ``points`` for another value, or ``"default"`` where there are no points.
        """
        if points not in ("all", "default"):
            raise ConfigError("points", f"must be 'all' or 'default', got {points!r}")
        if points == "default" and not self.has_points:
            raise ConfigError("points", f"{self.name} sweeps no points around a default one")

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        """The reproduction's sweeps by name, in running order; each is stored in
        ``<name>.sqlite``.

        ``episodes`` is the count asked for (``None``: the reproduction's defaults, which may
        differ between sweeps). The default is one sweep named ``results``: :meth:`sweep` with
        ``episodes`` or :attr:`default_episodes`.
        """
        n = self.default_episodes if episodes is None else int(episodes)
        return {"results": self.sweep(n, seed)}

    def group_fn(self) -> Callable[[list[Any]], list[dict[str, Any]]] | None:
        """The group function of a ``replay`` sweep (default: the harness's)."""
        return None

    def tables(self, df: Any, seed: int) -> list[Table]:
        """Tables of the stored rows beside the paper's numbers."""
        return []

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        """The paper's figures (drawn one by one by :meth:`run`)."""
        return []

    def reference_text(self) -> str:
        """``Paper: <full reference>.`` (each cited paper), or the paper's file name."""
        if not self.citations:
            return f"Paper: {self.paper}."
        refs = "; ".join(str(c) for c in self.citations)
        return f"Paper{'s' if len(self.citations) > 1 else ''}: {refs}"

    def reference(self) -> dict[str, dict[str, Any]]:
        """The paper's numbers per cell id or searcher label, for the report."""
        return {}

    def _run_info(
        self,
        specs: dict[str, Any],
        episodes: int | None,
        seed: int,
        wall: float,
        backend: str,
        workers: int,
    ) -> dict[str, Any]:
        """The facts of this run for the report's settings section."""
        from odorloc import __version__
        from odorloc.experiments.provenance import machine

        return {
            "name": f"{self.name} ({', '.join(specs)})",
            "seed": seed,
            "episodes": _episodes_text(specs, episodes),
            "wall_time": wall,
            "odorloc_version": __version__,
            "machine": machine(),
            "backend": backend,
            "workers": workers,
        }

    # ------------------------------------------------------------------ template
    @staticmethod
    def method_of(cell: Any) -> str:
        """The method a sweep cell runs (a :class:`~odorloc.experiments.sweep.Cell`, or a task's
        cell dictionary): its searcher's label without a setting in brackets (``muc-osl[N=20]``
        is ``muc-osl``)."""
        spec = cell if isinstance(cell, Mapping) else cell.spec
        label = str(spec.get("searcher_label") or spec["searcher"])
        return re.sub(r"\[[^\]]*\]$", "", label)

    def _method_filter(
        self, specs: Mapping[str, Any], chosen: Sequence[str], methods: Sequence[str]
    ) -> tuple[Callable[[Any], bool], list[str]]:
        """``methods`` as a cell filter, and the chosen sweeps that run any of them;
        :class:`ConfigError` naming ``--methods`` for one no chosen sweep runs."""
        from odorloc.experiments.sweep import expand_cells

        wanted = [str(m) for m in methods]
        if not wanted:
            raise ConfigError("--methods", "names no method")
        held = {n: dict.fromkeys(self.method_of(c) for c in expand_cells(specs[n])) for n in chosen}
        known = list(dict.fromkeys(m for n in chosen for m in held[n]))
        for m in wanted:
            if m not in known:
                raise ConfigError("--methods", f"no method {m!r} (methods: {', '.join(known)})")
        keep = set(wanted)
        # a sweep with none of the methods runs nothing: its stored rows are shown
        return (lambda cell: self.method_of(cell) in keep), [
            n for n in chosen if keep.intersection(held[n])
        ]

    def run(
        self,
        out: Path,
        episodes: int | None = None,
        workers: int = 2,
        seed: int = 2024,
        progress: bool = True,
        backend: str = "local",
        scheduler: str | None = None,
        only: Sequence[str] | None = None,
        points: str = "all",
        methods: Sequence[str] | None = None,
    ) -> Outcome:
        """Run (or resume) the reproduction and write tables, figures and the report to ``out``.

        Parameters
        ----------
        out : path
            Output folder (stores, CSV, figures, report).
        episodes : int, optional
            Episodes per cell (default: the reproduction's defaults).
        workers, backend, scheduler
            Where the episodes run (see :func:`~odorloc.experiments.sweep.run_sweep`).
        seed : int
            Root seed.
        progress : bool
            Live progress bars (the tables and the harness's summary are printed either way).
        only : sequence of str, optional
            Run only these sweeps (a name selects the sweep of that name and those named
            ``<name>-...``); the others contribute the rows already in their stores.
        points : {"all", "default"}
            ``"default"``: run every method at the default point of each world only (a
            reproduction over points, :attr:`has_points`), e.g. to give that one point the
            paper's episode count.
        methods : sequence of str, optional
            Run only these methods' cells (:meth:`method_of`); the others contribute the rows
            already stored. The stores stay the whole sweeps', so a later run without
            ``methods`` resumes them and adds the rest.
        """
        import pandas as pd
        from rich.console import Console

        from odorloc.experiments.report import ReportSection, write_report
        from odorloc.experiments.store import ResultStore, agent_dicts, agent_table, agents_path
        from odorloc.experiments.sweep import load_sweep, run_sweep

        if episodes is not None and int(episodes) < 1:
            raise ConfigError("episodes", f"must be >= 1, got {episodes}")
        self.select_points(points)
        specs = {name: load_sweep(spec) for name, spec in self.sweeps(episodes, seed).items()}
        chosen = select_sweeps(list(specs), only)
        select = None
        if methods is not None:
            select, chosen = self._method_filter(specs, chosen, methods)
        out = Path(out)
        check_output_dir(out, "out")
        # every file of a fixed name, before any episode runs (figures and tables are named by
        # the reproduction as it draws them)
        for name in [*(f"{n}.sqlite" for n in chosen), "results.csv", "report.html"]:
            check_output_file(out / name, "out")
        out.mkdir(parents=True, exist_ok=True)
        console = Console(width=shutil.get_terminal_size((CONSOLE_WIDTH, 24)).columns)
        # every store this run will write is checked before any episode runs: a store of other
        # settings found only when its sweep's turn comes would stop the run hours in
        from odorloc.experiments.sweep import config_hash

        for name in chosen:
            path = out / f"{name}.sqlite"
            if path.exists():
                # opened as its sweep will open it (an empty file becomes an empty store)
                with ResultStore(path) as held:
                    held.check(config_hash(specs[name]))
        t0 = time.perf_counter()
        frames = []
        stores: dict[str, Path] = {}
        added = 0
        for name, spec in specs.items():
            path = out / f"{name}.sqlite"
            if name in chosen:
                part = run_sweep(
                    spec,
                    path,
                    backend=backend,
                    workers=workers,
                    scheduler=scheduler,
                    progress=progress,
                    group_fn=self.group_fn(),
                    # the summary is printed with or without the live bar
                    summary=self.cell_summary and self.success_column == "success",
                    success=self.success_column,
                    select=select,
                )
            else:
                part = _stored_rows(spec, path, console)
            if name in chosen:
                added += int(part.attrs.get("added", 0))
            if path.is_file():
                stores[name] = path
            if len(part):
                part = part[part["episode"] < spec.episodes].copy()
                part["sweep"] = name
                with ResultStore(path, readonly=True) as held:
                    part["agents"] = agent_dicts(held.agent_frame(), part)
                frames.append(part)
        wall = time.perf_counter() - t0
        df = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
        outcome = Outcome(results=df, wall_time=wall, stores=stores)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            flat = df.drop(columns=["agents"], errors="ignore")
            flat.to_csv(out / "results.csv", index=False)
            long = agent_table(df)
            if len(long):
                long.to_csv(agents_path(out / "results.csv"), index=False)
        try:
            tables = self.tables(df, seed)
        except Exception:  # the stored rows stay; say what failed
            tables = []
            console.print(f"[red]tables failed:[/]\n{traceback.format_exc()}")
        outcome.tables = tables
        for tab in tables:
            pd.DataFrame(tab.rows, columns=tab.headers).to_csv(out / f"{tab.name}.csv", index=False)
            if tab.console:
                console.print(console_table(tab))
                if tab.note:
                    console.print(tab.note)
        console.print(
            f"added {added} episode{'s' if added != 1 else ''} ({len(df)} in the "
            f"store{'s' if len(stores) > 1 else ''}); wall time {wall:.0f} s on {workers} "
            f"worker(s) ({backend})",
            highlight=False,
        )
        sections = []
        figs: list[tuple[Path, str]] = []
        if not stores:
            console.print("nothing stored yet: no figures or report")
            return outcome
        # the first sweep's store goes to the figures (and, for one sweep, to the report)
        with ResultStore(next(iter(stores.values())), readonly=True) as store:
            try:
                fig_specs = self.figures(df, store, out, seed)
            except Exception:
                fig_specs = []
                outcome.failed_figures.append("figures")
                console.print(f"[red]figures failed:[/]\n{traceback.format_exc()}")
            for fig in fig_specs:
                path = out / fig.name
                try:
                    fig.draw(path)
                except Exception as exc:
                    outcome.failed_figures.append(fig.name)
                    console.print(f"[red]figure {fig.name} failed:[/] {type(exc).__name__}: {exc}")
                    continue
                outcome.figures.append(path)
                figs.append((path, fig.caption))
            sections.append(
                ReportSection(
                    title=f"Reproduction: {self.summary}",
                    text=f"{self.reference_text()} {len(df)} episodes, root seed {seed}.",
                    tables=[(t.title, t.headers, t.rows) for t in tables],
                    figures=figs,
                )
            )
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    outcome.report = write_report(
                        store if len(specs) == 1 else df,
                        out / "report.html",
                        title=f"{self.name} reproduction",
                        reference=self.reference(),
                        sections=sections,
                        seed=seed,
                        paired=self.report_paired,
                        success=self.success_column,
                        success_label=self.success_label,
                        rows=df,
                        run_info=self._run_info(specs, episodes, seed, wall, backend, workers),
                    )
            except Exception:
                console.print(f"[red]report failed:[/]\n{traceback.format_exc()}")
        for p in [*outcome.figures, outcome.report]:
            if p is not None:
                console.print(f"wrote {p}")
        return outcome


def _episodes_text(specs: dict[str, Any], episodes: int | None) -> str:
    counts = {name: spec.episodes for name, spec in specs.items()}
    if episodes is not None or len(set(counts.values())) == 1:
        return str(episodes if episodes is not None else next(iter(counts.values())))
    return ", ".join(f"{n}: {c}" for n, c in counts.items())


def select_sweeps(names: Sequence[str], only: Sequence[str] | None) -> list[str]:
    """The sweeps ``only`` selects (all when ``None``): a name selects the sweep of that name and
    the sweeps named ``<name>-...``; :class:`ConfigError` naming ``--only`` for one that selects
    none."""
    if not only:
        return list(names)
    chosen: list[str] = []
    for want in only:
        hit = [n for n in names if n == want or n.startswith(f"{want}-")]
        if not hit:
            raise ConfigError("--only", f"no sweep {want!r} (sweeps: {', '.join(names)})")
        chosen += [n for n in hit if n not in chosen]
    return [n for n in names if n in chosen]


def _stored_rows(spec: Any, path: Path, console: Any) -> Any:
    """The stored rows of a sweep that is not run now (empty if none, or of other settings)."""
    import pandas as pd

    from odorloc.experiments.store import ResultStore
    from odorloc.experiments.sweep import config_hash

    if not path.is_file():
        return pd.DataFrame()
    with ResultStore(path, readonly=True) as store:
        if store.config_hash != config_hash(spec):
            console.print(f"{path.name} holds another sweep's settings: not used")
            return pd.DataFrame()
        return store.frame()


CONSOLE_WIDTH = 100
"""Columns a reproduction's console tables must fit in (wider ones go to CSV and the report)."""


def console_headers(
    headers: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1
) -> list[str]:
    """The headers as a console table prints them: a number column's header folded at its
    words to the width of the column's widest cell (never narrower than its longest word), so
    that a long method name makes the header taller, not the column wider; the first ``left``
    (text) columns' headers as they are."""
    out = []
    for i, h in enumerate(headers):
        if i < left or " " not in h:
            out.append(h)
            continue
        cells = max((len(r[i]) for r in rows if i < len(r)), default=0)
        out.append(textwrap.fill(h, max(cells, *(len(w) for w in h.split()))))
    return out


def console_table(tab: Table) -> Any:
    """A compact rich table of ``tab`` (no vertical rules, so that it fits
    :data:`CONSOLE_WIDTH` columns)."""
    from rich import box
    from rich.table import Table as RichTable

    rt = RichTable(
        title=tab.title,
        box=box.SIMPLE_HEAD,
        show_edge=False,
        collapse_padding=True,
        expand=bool(tab.widths),  # column ratios only act on a table as wide as the console
    )
    for i, h in enumerate(console_headers(tab.headers, tab.rows, tab.left)):
        # text may wrap (a long statement stays readable); numbers never do
        text = i < tab.left
        ratio = tab.widths[i] if text and i < len(tab.widths) else None
        rt.add_column(h, justify="left" if text else "right", no_wrap=not text, ratio=ratio)
    for r in tab.rows:
        rt.add_row(*r)
    return rt


#: The package whose paper packages hold the reproductions.
PAPERS_PACKAGE = "odorloc.papers"


def discover() -> None:
    """Let the registry find the reproductions (and whatever else) registered by the papers."""
    registry.include(PAPERS_PACKAGE)


def names_of_reproductions() -> list[str]:
    """Registered reproduction names."""
    discover()
    return registry.names("reproduction")


def get(name: str) -> Reproduction:
    """A reproduction by name; :class:`ConfigError` naming it if unknown."""
    discover()
    e = registry.entry("reproduction", name, field="paper")
    return e.build(ReproductionParams())
