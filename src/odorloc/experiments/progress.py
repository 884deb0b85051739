"""Live progress of a sweep and its final summary table (``rich``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from rich.markup import escape

MAX_CELL_BARS = 12
"""Above this many cells only the overall bar is shown (plus the worst cells' success rates)."""


class SweepProgress:
    """A progress display: an overall bar with ETA and one bar per cell with its success rate.

    Disabled (``enabled=False``) it does nothing, so the runner calls it unconditionally.
    ``success`` names the row column counted as a success (a reproduction's own criterion, so
    the bars say what its tables say).
    """

    def __init__(self, enabled: bool = True, console: Any = None, success: str = "success") -> None:
        self.enabled = enabled
        self.success = success
        self._console = console
        self._progress: Any = None
        self._overall: Any = None
        self._cell_tasks: dict[str, Any] = {}
        self._counts: dict[str, list[int]] = {}

    def __enter__(self) -> SweepProgress:
        if not self.enabled:
            return self
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self._progress = Progress(
            TextColumn("{task.description}", justify="left"),
            BarColumn(bar_width=30),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=self._console,
            transient=False,
            refresh_per_second=4,
        )
        self._progress.__enter__()
        self._overall = self._progress.add_task("all episodes", total=0, rate="")
        return self

    def __exit__(self, *exc: object) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)
            self._progress = None

    def _rate(self, n: int, k: int, err: int) -> str:
        s = f"{self.success} {100 * k / n:5.1f}%" if n else f"{self.success}   -  "
        return s + (f" errors {err}" if err else "")

    def begin_round(
        self,
        cells: Sequence[Any],
        targets: dict[str, int],
        counts: dict[str, tuple[int, int, int]],
    ) -> None:
        """(Re)set totals: ``targets`` episodes per cell, ``counts`` already stored."""
        self._counts = {c.cell_id: list(counts.get(c.cell_id, (0, 0, 0))) for c in cells}
        if self._progress is None:
            return
        total = sum(targets.values())
        done = sum(min(self._counts[c.cell_id][0], targets[c.cell_id]) for c in cells)
        n_all = sum(v[0] for v in self._counts.values())
        k_all = sum(v[1] for v in self._counts.values())
        e_all = sum(v[2] for v in self._counts.values())
        self._progress.update(
            self._overall, total=total, completed=done, rate=self._rate(n_all, k_all, e_all)
        )
        if len(cells) <= MAX_CELL_BARS:
            for c in cells:
                n, k, e = self._counts[c.cell_id]
                kw = {"total": targets[c.cell_id], "completed": min(n, targets[c.cell_id])}
                if c.cell_id not in self._cell_tasks:
                    self._cell_tasks[c.cell_id] = self._progress.add_task(
                        f"  {escape(c.cell_id)}", rate=self._rate(n, k, e), **kw
                    )
                else:
                    self._progress.update(
                        self._cell_tasks[c.cell_id], rate=self._rate(n, k, e), **kw
                    )

    def counts(self, cell_id: str) -> tuple[int, int, int]:
        """``(episodes, successes, errors)`` of a cell counted so far."""
        n, k, e = self._counts.get(cell_id, (0, 0, 0))
        return int(n), int(k), int(e)

    def advance(self, task: Any, row: dict) -> None:
        """Count one finished episode."""
        c = self._counts.setdefault(task.cell_id, [0, 0, 0])
        c[0] += 1
        ok = row.get(self.success)
        # as the store counts it: NaN (or None) is not a success
        hit = ok is not None and not (isinstance(ok, float) and math.isnan(ok)) and bool(ok)
        c[1] += int(hit and row.get("status", "ok") != "error")
        c[2] += int(row.get("status") == "error")
        if self._progress is None:
            return
        n_all = sum(v[0] for v in self._counts.values())
        k_all = sum(v[1] for v in self._counts.values())
        e_all = sum(v[2] for v in self._counts.values())
        self._progress.update(self._overall, advance=1, rate=self._rate(n_all, k_all, e_all))
        tid = self._cell_tasks.get(task.cell_id)
        if tid is not None:
            self._progress.update(tid, advance=1, rate=self._rate(*c))


def _fmt(x: float, digits: int = 1) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _pct_ci(p: float, lo: float, hi: float) -> str:
    return f"{_fmt(100 * p)} [{_fmt(100 * lo)}, {_fmt(100 * hi)}]"


def summary_table(df: Any, level: float = 0.95, seed: int = 0, title: str | None = None) -> Any:
    """A ``rich.table.Table`` per cell: n, success % [Wilson CI], mean time [bootstrap CI],
    median time, mean localisation error, errors."""
    from rich.table import Table

    from odorloc.experiments.stats import summarize

    s = summarize(df, level=level, seed=seed)
    pct = f"{round(100 * level)} %"
    t = Table(title=title or f"Sweep summary ({pct} intervals; times of successful episodes)")
    t.add_column("cell", overflow="fold", min_width=18)
    t.add_column("n", justify="right")
    t.add_column(f"success % [{pct} CI]", justify="right")
    t.add_column("mean time s [CI]", justify="right")
    t.add_column("median time s", justify="right")
    t.add_column("mean loc err m", justify="right")
    t.add_column("errors", justify="right")
    for r in s.itertuples():
        t.add_row(
            escape(str(r.cell_id)),
            str(r.n),
            _pct_ci(r.success_rate, r.success_lo, r.success_hi),
            f"{_fmt(r.mean_time)} [{_fmt(r.mean_time_lo)}, {_fmt(r.mean_time_hi)}]",
            _fmt(r.median_time),
            _fmt(r.mean_loc_error, 2),
            str(r.errors) if r.errors else "0",
        )
    return t


def print_summary(df: Any, console: Any = None, **kw: Any) -> None:
    """Print :func:`summary_table` to the terminal."""
    from rich.console import Console

    if len(df) == 0:
        return
    if console is None:
        console = Console()
        if not console.is_terminal:
            # Logs and pipes: do not squeeze the table into 80 columns.
            console = Console(width=160)
    console.print(summary_table(df, **kw))
